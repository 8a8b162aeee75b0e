//! Attributes through edits: every element the store makes gets values, and the values of
//! the elements it keeps stay as they were, bit for bit.
//!
//! - A vertex made by a split is interpolated from its parents at the split's parameter
//!   (an edge's: the projection of the new point on the edge; a triangle's: the new point's
//!   barycentric coordinates), rounded once to the attribute's type.
//! - A vertex from `add-vertices` gets the attribute's default (opaque white, else zero)
//!   until the service sets it; the step counts such vertices for its report.
//! - A collapse keeps the surviving vertex's values, and every corner keeps its own.
//! - A new triangle's corners copy the corner they continue (the split triangle's, the
//!   extended edge's, or for `add-triangles` the first live corner at the same vertex); its
//!   face values copy the triangle it came from, else the default.
//! - Normals are recomputed at the end of the step (area-weighted face normals) on every
//!   vertex whose neighbourhood the step changed, unless the step set them.

use crate::attributes::{
    Attribute, Domain, MAX_ATTRIBUTES, NORMAL, NumberType, Values, check_name,
};

use super::{EditError, MeshStore, REMOVED};

/// Largest component count: an attribute's element is at most this many numbers.
const MAX_COMPONENTS: usize = 4;

/// One element's values for every attribute of a domain, in canonical order.
type ElementValues = Vec<[f64; MAX_COMPONENTS]>;

/// Where a new or rewritten corner's values come from.
#[derive(Clone)]
pub(super) enum CornerOrigin {
    Default,
    Copy(usize),
    Blend(Vec<(usize, f64)>),
}

/// What the store tracks for normals: which vertices the step touched, which it set.
pub(super) struct NormalTracking {
    touched: Vec<bool>,
    set_by_step: Vec<bool>,
}

impl NormalTracking {
    pub(super) fn new(slots: usize) -> Self {
        Self { touched: vec![false; slots], set_by_step: vec![false; slots] }
    }
}

impl MeshStore {
    /// Marks a vertex whose neighbourhood changed (see the module notes on normals).
    pub(super) fn touch(&mut self, vertex: u32) {
        if let Some(slot) = self.normals.as_mut().and_then(|t| t.touched.get_mut(vertex as usize)) {
            *slot = true;
        }
    }

    /// Gives a just-pushed vertex its values: a blend of `parents` (weights summing to 1),
    /// or the defaults when there are none.
    pub(super) fn attributes_for_new_vertex(&mut self, parents: &[(u32, f64)]) {
        if let Some(t) = &mut self.normals {
            t.touched.push(true);
            t.set_by_step.push(false);
        }
        if !self.mesh.attributes.has_domain(Domain::Vertex) {
            return;
        }
        let defaulted = parents.is_empty();
        let blends = parents.iter().map(|&(v, w)| (v as usize, w)).collect::<Vec<_>>();
        for a in super::owned(&mut self.mesh).attributes.of_domain_mut(Domain::Vertex) {
            let value = if defaulted { default_of(a) } else { blend(a, &blends) };
            push(a, &value);
        }
        if defaulted {
            self.defaulted.push(self.vertex_slots() - 1);
        }
    }

    /// The values of a triangle's three corners as they will be, read before an edit
    /// changes them.
    pub(super) fn corner_values(&self, origins: &[CornerOrigin; 3]) -> Vec<ElementValues> {
        let corner_attributes: Vec<&Attribute> =
            self.mesh.attributes.iter().filter(|a| a.domain == Domain::Corner).collect();
        origins
            .iter()
            .map(|origin| {
                corner_attributes
                    .iter()
                    .map(|a| match origin {
                        CornerOrigin::Default => default_of(a),
                        CornerOrigin::Copy(c) => element(a, *c),
                        CornerOrigin::Blend(parts) => blend(a, parts),
                    })
                    .collect()
            })
            .collect()
    }

    /// Where each corner of `corners` takes its values from: the corner of the first of
    /// `sources` at the same vertex, a blend of `sources`' corners for `new_vertex`, else
    /// the default. Empty when the mesh has no corner attributes.
    pub(super) fn corner_origins(
        &self,
        sources: &[u32],
        corners: [u32; 3],
        new_vertex: Option<(u32, &[(u32, f64)])>,
    ) -> Option<[CornerOrigin; 3]> {
        if !self.mesh.attributes.has_domain(Domain::Corner) {
            return None;
        }
        let corner_at = |vertex: u32| {
            sources.iter().find_map(|&t| {
                let at = self.corners(t).iter().position(|&c| c == vertex)?;
                Some(3 * t as usize + at)
            })
        };
        Some(corners.map(|x| match new_vertex {
            Some((v, parents)) if x == v => {
                let parts: Option<Vec<(usize, f64)>> =
                    parents.iter().map(|&(p, w)| corner_at(p).map(|c| (c, w))).collect();
                parts.map_or(CornerOrigin::Default, CornerOrigin::Blend)
            }
            _ => corner_at(x).map_or(CornerOrigin::Default, CornerOrigin::Copy),
        }))
    }

    /// Writes corner values (from [`corner_values`](Self::corner_values)) into triangle
    /// `triangle`, which may be one just pushed.
    pub(super) fn write_corners(&mut self, triangle: u32, values: Vec<ElementValues>) {
        let attributes = &mut super::owned(&mut self.mesh).attributes;
        for (k, corner) in values.into_iter().enumerate() {
            let c = 3 * triangle as usize + k;
            for (a, value) in attributes.of_domain_mut(Domain::Corner).zip(corner) {
                set(a, c, &value);
            }
        }
    }

    /// Gives a just-pushed triangle its face values (a copy of `from`, else the defaults)
    /// and room for its corner values.
    pub(super) fn attributes_for_new_triangle(&mut self, from: Option<u32>) {
        let attributes = &self.mesh.attributes;
        if !attributes.has_domain(Domain::Face) && !attributes.has_domain(Domain::Corner) {
            return;
        }
        let attributes = &mut super::owned(&mut self.mesh).attributes;
        for a in attributes.of_domain_mut(Domain::Face) {
            let value = from.map_or_else(|| default_of(a), |t| element(a, t as usize));
            push(a, &value);
        }
        for a in attributes.of_domain_mut(Domain::Corner) {
            let value = default_of(a);
            for _ in 0..3 {
                push(a, &value);
            }
        }
    }

    /// Swaps the values of corners 1 and 2, as a flip swaps the corners.
    pub(super) fn flip_corner_values(&mut self, triangle: u32) {
        if !self.mesh.attributes.has_domain(Domain::Corner) {
            return;
        }
        let (c1, c2) = (3 * triangle as usize + 1, 3 * triangle as usize + 2);
        for a in super::owned(&mut self.mesh).attributes.of_domain_mut(Domain::Corner) {
            let (one, two) = (element(a, c1), element(a, c2));
            set(a, c1, &two);
            set(a, c2, &one);
        }
    }

    pub(super) fn set_attribute(
        &mut self,
        domain: Domain,
        name: &str,
        components: u8,
        ids: Option<&[u32]>,
        values: &Values,
    ) -> Result<(), EditError> {
        let what = format!("set-attribute {} {name}", domain.name());
        check_name(name).map_err(|e| EditError::argument(format!("{what}: {e}")))?;
        if !(1..=MAX_COMPONENTS as u8).contains(&components) {
            return Err(EditError::argument(format!(
                "{what}: {components} components; an attribute has 1 to {MAX_COMPONENTS}"
            )));
        }
        if let Some((ty, n)) = Attribute::required_shape(domain, name)
            && (ty, n) != (values.number_type(), components)
        {
            return Err(EditError::argument(format!(
                "{what}: must be {n} × {}, got {components} × {}",
                ty.name(),
                values.number_type().name()
            )));
        }
        let slots = self.slots_of(domain);
        let elements = match ids {
            Some(ids) => {
                for &id in ids {
                    self.check_element(domain, id, &what)?;
                }
                ids.len()
            }
            None => slots,
        };
        let per = usize::from(components);
        if values.len() != elements * per {
            return Err(EditError::argument(format!(
                "{what}: {elements} elements need {} numbers, got {}",
                elements * per,
                values.len()
            )));
        }
        if let Some(i) = values.first_non_finite() {
            return Err(EditError::argument(format!(
                "{what}: element {}'s value is not finite",
                i / per
            )));
        }
        match self.mesh.attributes.get(domain, name) {
            Some(a)
                if (a.components, a.values.number_type()) != (components, values.number_type()) =>
            {
                return Err(EditError::argument(format!(
                    "{what}: the mesh holds it as {} × {}, got {components} × {}",
                    a.components,
                    a.values.number_type().name(),
                    values.number_type().name()
                )));
            }
            Some(_) => {}
            None if self.mesh.attributes.len() >= MAX_ATTRIBUTES => {
                return Err(EditError::not_applicable(format!(
                    "{what}: the mesh already holds {MAX_ATTRIBUTES} attributes"
                )));
            }
            None => self.create_attribute(domain, name, components, values.number_type()),
        }
        let (vertex_slots, triangle_slots) =
            (self.vertex_slots() as usize, self.triangle_slots() as usize);
        let attributes = &mut super::owned(&mut self.mesh).attributes;
        let a = attributes.get_mut(domain, name).expect("present or just created");
        match ids {
            None => a.values = values.clone(),
            Some(ids) => {
                for (j, &id) in ids.iter().enumerate() {
                    for k in 0..per {
                        a.values.set(per * id as usize + k, values.get(per * j + k));
                    }
                }
            }
        }
        debug_assert_eq!(a.element_count(), domain.len(vertex_slots, triangle_slots));
        if domain == Domain::Vertex {
            let all: Vec<u32>;
            let set_ids = match ids {
                Some(ids) => ids,
                None => {
                    all = (0..self.vertex_slots()).collect();
                    &all
                }
            };
            if name == NORMAL {
                if let Some(t) = &mut self.normals {
                    set_ids.iter().for_each(|&v| t.set_by_step[v as usize] = true);
                }
            } else {
                let mut sorted = set_ids.to_vec();
                sorted.sort_unstable();
                self.defaulted.retain(|v| sorted.binary_search(v).is_err());
            }
        }
        Ok(())
    }

    pub(super) fn remove_attribute(&mut self, domain: Domain, name: &str) -> Result<(), EditError> {
        if self.mesh.attributes.get(domain, name).is_none() {
            return Err(EditError::not_applicable(format!(
                "remove-attribute: the mesh has no {} attribute {name}",
                domain.name()
            )));
        }
        super::owned(&mut self.mesh).attributes.remove(domain, name);
        if (domain, name) == (Domain::Vertex, NORMAL) {
            self.normals = None;
        }
        Ok(())
    }

    /// A new attribute, every slot at the default.
    fn create_attribute(&mut self, domain: Domain, name: &str, components: u8, ty: NumberType) {
        let slots = self.slots_of(domain);
        let mut a =
            Attribute { domain, name: name.to_owned(), components, values: Values::empty(ty) };
        let value = default_of(&a);
        a.values.reserve(slots * usize::from(components));
        for _ in 0..slots {
            push(&mut a, &value);
        }
        let (v, t) = (self.vertex_slots() as usize, self.triangle_slots() as usize);
        super::owned(&mut self.mesh)
            .attributes
            .insert(a, v, t)
            .expect("a new attribute of the checked shape fits the mesh");
        if (domain, name) == (Domain::Vertex, NORMAL) {
            self.normals = Some(NormalTracking::new(v));
        }
    }

    fn slots_of(&self, domain: Domain) -> usize {
        domain.len(self.vertex_slots() as usize, self.triangle_slots() as usize)
    }

    fn check_element(&self, domain: Domain, id: u32, what: &str) -> Result<(), EditError> {
        match domain {
            Domain::Vertex => self.check_vertex(id),
            Domain::Face => self.check_triangle(id),
            Domain::Corner => self.check_triangle(id / 3),
        }
        .map_err(|e| EditError::new(e.kind, format!("{what}: {}", e.message)))
    }

    /// Live vertices given defaults by `add-vertices` that the step never set.
    pub fn defaulted_vertex_count(&self) -> usize {
        self.defaulted.iter().filter(|&&v| self.is_vertex_live(v)).count()
    }

    /// Recomputes the normals of the vertices whose neighbourhood changed (see the module
    /// notes): called once, as the step ends.
    pub(super) fn recompute_normals(&mut self) {
        let Some(tracking) = self.normals.take() else { return };
        if !tracking.touched.contains(&true) {
            return;
        }
        let triangles = &self.mesh.triangles;
        let touched = tracking.touched;
        let mut recompute = touched.clone();
        for c in triangles.chunks_exact(3) {
            if c[0] != REMOVED && c.iter().any(|&v| touched[v as usize]) {
                c.iter().for_each(|&v| recompute[v as usize] = true);
            }
        }
        let positions = &self.mesh.positions;
        let point = |v: u32| {
            let i = 3 * v as usize;
            [positions[i], positions[i + 1], positions[i + 2]].map(f64::from)
        };
        let mut sums = vec![[0.0f64; 3]; recompute.len()];
        for c in triangles.chunks_exact(3) {
            let [a, b, d] = [c[0], c[1], c[2]];
            if a == REMOVED
                || a == b
                || b == d
                || a == d
                || !c.iter().any(|&v| recompute[v as usize])
            {
                continue;
            }
            let (pa, pb, pd) = (point(a), point(b), point(d));
            let (u, w) = (sub(pb, pa), sub(pd, pa));
            let n =
                [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]];
            for v in [a, b, d] {
                let s = &mut sums[v as usize];
                (0..3).for_each(|k| s[k] += n[k]);
            }
        }
        let live: Vec<bool> = self.vertex_removed.iter().map(|r| !r).collect();
        let attributes = &mut super::owned(&mut self.mesh).attributes;
        let Some(normal) = attributes.get_mut(Domain::Vertex, NORMAL) else { return };
        for (v, s) in sums.iter().enumerate() {
            let length = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
            if recompute[v] && live[v] && !tracking.set_by_step[v] && length > 0.0 {
                (0..3).for_each(|k| normal.values.set(3 * v + k, s[k] / length));
            }
        }
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn default_of(a: &Attribute) -> [f64; MAX_COMPONENTS] {
    [a.default_value(); MAX_COMPONENTS]
}

fn element(a: &Attribute, e: usize) -> [f64; MAX_COMPONENTS] {
    let per = usize::from(a.components);
    std::array::from_fn(|k| if k < per { a.values.get(per * e + k) } else { 0.0 })
}

fn blend(a: &Attribute, parts: &[(usize, f64)]) -> [f64; MAX_COMPONENTS] {
    let mut out = [0.0; MAX_COMPONENTS];
    for &(e, w) in parts {
        let value = element(a, e);
        (0..MAX_COMPONENTS).for_each(|k| out[k] += w * value[k]);
    }
    out
}

fn push(a: &mut Attribute, value: &[f64; MAX_COMPONENTS]) {
    for &x in &value[..usize::from(a.components)] {
        a.values.push(x);
    }
}

fn set(a: &mut Attribute, e: usize, value: &[f64; MAX_COMPONENTS]) {
    let per = usize::from(a.components);
    for (k, &x) in value[..per].iter().enumerate() {
        a.values.set(per * e + k, x);
    }
}

/// Weights of the point `p` in triangle `(a, b, c)`: its barycentric coordinates, clamped
/// to the triangle, or thirds for a triangle without area.
pub(super) fn barycentric(p: [f32; 3], a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> [f64; 3] {
    let [p, a, b, c] = [p, a, b, c].map(|q| q.map(f64::from));
    let (v0, v1, v2) = (sub(b, a), sub(c, a), sub(p, a));
    let dot = |x: [f64; 3], y: [f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    let (d00, d01, d11, d20, d21) =
        (dot(v0, v0), dot(v0, v1), dot(v1, v1), dot(v2, v0), dot(v2, v1));
    let denominator = d00 * d11 - d01 * d01;
    if denominator.abs() <= f64::EPSILON * d00 * d11 || denominator == 0.0 {
        return [1.0 / 3.0; 3];
    }
    let v = (d11 * d20 - d01 * d21) / denominator;
    let w = (d00 * d21 - d01 * d20) / denominator;
    let weights = [1.0 - v - w, v, w].map(|x| x.max(0.0));
    let total: f64 = weights.iter().sum();
    weights.map(|x| x / total)
}

/// The parameter of `p` projected on the segment `a b`, clamped to it; half for a segment
/// of no length.
pub(super) fn edge_parameter(p: [f32; 3], a: [f32; 3], b: [f32; 3]) -> f64 {
    let [p, a, b] = [p, a, b].map(|q| q.map(f64::from));
    let (ab, ap) = (sub(b, a), sub(p, a));
    let length2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
    if length2 == 0.0 {
        return 0.5;
    }
    ((ab[0] * ap[0] + ab[1] * ap[1] + ab[2] * ap[2]) / length2).clamp(0.0, 1.0)
}
