//! What a mesh carries beyond positions and triangles: per-vertex colours, normals, quality
//! and texture coordinates, per-corner texture coordinates, per-face materials, and other
//! numbers by name ([`Mesh::attributes`], [`Mesh::read_attribute`],
//! [`Mesh::set_attribute`]; typed shortcuts such as [`Mesh::vertex_colors`] and
//! [`Mesh::quality`]).
//!
//! The host keeps attributes through every edit: a vertex a split makes is interpolated from
//! its parents, a collapse keeps the survivor's values, normals are recomputed where the
//! geometry changed. A vertex from `add-vertices` alone gets the default (opaque white,
//! else zero), and the step's report says so, unless the service gives it values:
//! [`blend_new_vertex_attributes`] does that from the vertices it was made from.
//!
//! [`Mesh::attributes`]: crate::Mesh::attributes
//! [`Mesh::read_attribute`]: crate::Mesh::read_attribute
//! [`Mesh::set_attribute`]: crate::Mesh::set_attribute
//! [`Mesh::vertex_colors`]: crate::Mesh::vertex_colors
//! [`Mesh::quality`]: crate::Mesh::quality

pub use crate::bindings::meshflow::geometry::mesh::{
    AttributeDomain, AttributeInfo, AttributeValues, NumberType,
};
use crate::{Error, Mesh, Result};

/// Per-vertex colour: RGBA, 4 × u8.
pub const COLOR: &str = "color";
/// Per-vertex normal: 3 × f32. The host recomputes it where a step changed the geometry
/// around a vertex, unless the step set it.
pub const NORMAL: &str = "normal";
/// Per-vertex quality (a scanner's confidence, a curvature): 1 × f32.
pub const QUALITY: &str = "quality";
/// Per-vertex or per-corner texture coordinate: 2 × f32.
pub const TEXCOORD: &str = "texcoord";
/// Per-face material, an index into the file's material names: 1 × u32.
pub const MATERIAL: &str = "material";

impl AttributeValues {
    /// An empty list of `ty` with room for `capacity` numbers.
    pub fn with_capacity(ty: NumberType, capacity: usize) -> Self {
        match ty {
            NumberType::U8 => AttributeValues::U8(Vec::with_capacity(capacity)),
            NumberType::S32 => AttributeValues::S32(Vec::with_capacity(capacity)),
            NumberType::U32 => AttributeValues::U32(Vec::with_capacity(capacity)),
            NumberType::F32 => AttributeValues::F32(Vec::with_capacity(capacity)),
            NumberType::F64 => AttributeValues::F64(Vec::with_capacity(capacity)),
        }
    }

    pub fn number_type(&self) -> NumberType {
        match self {
            AttributeValues::U8(_) => NumberType::U8,
            AttributeValues::S32(_) => NumberType::S32,
            AttributeValues::U32(_) => NumberType::U32,
            AttributeValues::F32(_) => NumberType::F32,
            AttributeValues::F64(_) => NumberType::F64,
        }
    }

    /// How many numbers (not elements).
    pub fn len(&self) -> usize {
        match self {
            AttributeValues::U8(v) => v.len(),
            AttributeValues::S32(v) => v.len(),
            AttributeValues::U32(v) => v.len(),
            AttributeValues::F32(v) => v.len(),
            AttributeValues::F64(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number `i`, exactly (f64 holds every number of every type).
    pub fn get(&self, i: usize) -> f64 {
        match self {
            AttributeValues::U8(v) => f64::from(v[i]),
            AttributeValues::S32(v) => f64::from(v[i]),
            AttributeValues::U32(v) => f64::from(v[i]),
            AttributeValues::F32(v) => f64::from(v[i]),
            AttributeValues::F64(v) => v[i],
        }
    }

    /// Sets number `i` to `x` rounded to the type as the host rounds a blend (see
    /// [`round`]).
    pub fn set(&mut self, i: usize, x: f64) {
        let x = round(self.number_type(), x);
        match self {
            AttributeValues::U8(v) => v[i] = x as u8,
            AttributeValues::S32(v) => v[i] = x as i32,
            AttributeValues::U32(v) => v[i] = x as u32,
            AttributeValues::F32(v) => v[i] = x as f32,
            AttributeValues::F64(v) => v[i] = x,
        }
    }

    /// Appends `x` rounded to the type (see [`round`]).
    pub fn push(&mut self, x: f64) {
        let x = round(self.number_type(), x);
        match self {
            AttributeValues::U8(v) => v.push(x as u8),
            AttributeValues::S32(v) => v.push(x as i32),
            AttributeValues::U32(v) => v.push(x as u32),
            AttributeValues::F32(v) => v.push(x as f32),
            AttributeValues::F64(v) => v.push(x),
        }
    }
}

/// `x` rounded to `ty` as the host rounds an interpolated value: integers to the nearest
/// (ties away from zero) and saturated to the type's range, `f32` to the nearest `f32`.
pub fn round(ty: NumberType, x: f64) -> f64 {
    match ty {
        NumberType::U8 => x.round().clamp(0.0, 255.0),
        NumberType::S32 => x.round().clamp(f64::from(i32::MIN), f64::from(i32::MAX)),
        NumberType::U32 => x.round().clamp(0.0, f64::from(u32::MAX)),
        NumberType::F32 => f64::from(x as f32),
        NumberType::F64 => x,
    }
}

/// Gives vertices the service made with `add-vertices` the values of every vertex attribute
/// (normals aside: the host recomputes them) blended from the vertices they came from, so
/// a filled hole, a subdivided or remeshed surface carries on its colours, quality and
/// texture coordinates instead of taking the defaults.
///
/// `new` lists `(vertex, parents)`, each parent `(vertex, weight)`; weights must be finite,
/// not negative, and sum above zero (they are divided by their sum). A parent may be a
/// vertex listed earlier in `new`: it is used with the value just given to it, so a vertex
/// made from vertices made in the same step (a second subdivision level) needs no
/// composed weights. Values are summed in `f64` in the order given and rounded once to
/// the attribute's type, as the host rounds the splits it interpolates.
///
/// Cost: one `attributes` call; then per vertex attribute one read of the whole attribute
/// and one `set-attribute` of the new vertices' values. Nothing when the mesh carries no
/// vertex attribute. Returns how many attributes were written.
///
/// ```no_run
/// # fn f(mesh: &meshflow_plugin_sdk::Mesh) -> meshflow_plugin_sdk::Result<()> {
/// use meshflow_plugin_sdk::attributes::blend_new_vertex_attributes;
/// // Vertex 10 at the midpoint of vertices 2 and 7, vertex 11 at a third of 10 and 3.
/// let first = mesh.add_vertices(&[0.5, 0.0, 0.0, 0.5, 0.5, 0.0])?;
/// blend_new_vertex_attributes(
///     mesh,
///     &[(first, vec![(2, 0.5), (7, 0.5)]), (first + 1, vec![(first, 2.0), (3, 1.0)])],
/// )?;
/// # Ok(()) }
/// ```
pub fn blend_new_vertex_attributes<P: AsRef<[(u32, f64)]>>(
    mesh: &Mesh,
    new: &[(u32, P)],
) -> Result<usize> {
    if new.is_empty() {
        return Ok(0);
    }
    let slots = mesh.vertex_slots();
    let blends = checked_blends(new, slots)?;
    let ids: Vec<u32> = new.iter().map(|(v, _)| *v).collect();
    let mut written = 0;
    for info in mesh.attributes() {
        if info.domain != AttributeDomain::Vertex || info.name == NORMAL {
            continue;
        }
        let Some(mut values) = mesh.read_attribute(AttributeDomain::Vertex, &info.name) else {
            continue;
        };
        let per = usize::from(info.components);
        if values.len() != per * slots {
            return Err(Error(format!(
                "vertex attribute {}: {} numbers for {slots} vertex slots of {per}",
                info.name,
                values.len()
            )));
        }
        let mut out = AttributeValues::with_capacity(values.number_type(), per * new.len());
        for (&vertex, parents) in ids.iter().zip(&blends) {
            for k in 0..per {
                let x: f64 = parents.iter().map(|&(p, w)| w * values.get(per * p + k)).sum();
                values.set(per * vertex as usize + k, x);
                out.push(values.get(per * vertex as usize + k));
            }
        }
        mesh.set_attribute(AttributeDomain::Vertex, &info.name, info.components, Some(&ids), &out)?;
        written += 1;
    }
    Ok(written)
}

/// The parents of every new vertex with weights divided by their sum; refuses ids past the
/// mesh and weights that are negative, not finite or sum to nothing.
fn checked_blends<P: AsRef<[(u32, f64)]>>(
    new: &[(u32, P)],
    slots: usize,
) -> Result<Vec<Vec<(usize, f64)>>> {
    new.iter()
        .map(|(vertex, parents)| {
            let parents = parents.as_ref();
            if *vertex as usize >= slots {
                return Err(Error(format!(
                    "blend: vertex {vertex} is past the mesh ({slots} slots)"
                )));
            }
            if let Some(&(p, _)) = parents.iter().find(|(p, _)| *p as usize >= slots) {
                return Err(Error(format!(
                    "blend: vertex {vertex}'s parent {p} is past the mesh ({slots} slots)"
                )));
            }
            if parents.iter().any(|&(_, w)| !(w.is_finite() && w >= 0.0)) {
                return Err(Error(format!(
                    "blend: vertex {vertex}'s weights must be finite and not negative"
                )));
            }
            let total: f64 = parents.iter().map(|&(_, w)| w).sum();
            if !(total > 0.0 && total.is_finite()) {
                return Err(Error(format!("blend: vertex {vertex}'s weights sum to {total}")));
            }
            Ok(parents.iter().map(|&(p, w)| (p as usize, w / total)).collect())
        })
        .collect()
}
