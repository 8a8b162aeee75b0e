//! Component- and mesh-level edits: remove or transform a component, transform, clear.

use meshflow_topology::TriangleComponents;

use super::{Affine, EditError, MeshStore, check_finite};

/// An edge-connected component of the live triangles (WIT `component`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Component {
    /// Its smallest triangle id.
    pub first_triangle: u32,
    /// Its live triangles.
    pub triangles: u32,
}

impl MeshStore {
    /// The edge-connected components of the live triangles, ascending by first triangle:
    /// the components [`remove_component`](Self::remove_component) removes, as the SDK's
    /// `TriangleComponents` finds them. O(V + T log d), on the host: a plugin that only
    /// chooses components need not read the mesh.
    pub fn components(&self) -> Vec<Component> {
        let found = TriangleComponents::new(self.vertex_slots() as usize, self.triangles());
        let sizes = found.sizes();
        let mut components = Vec::with_capacity(sizes.len());
        // Labels follow the smallest triangle id: label `l` first appears at its first.
        for (t, &label) in (0u32..).zip(found.labels()) {
            if label as usize == components.len() {
                components.push(Component { first_triangle: t, triangles: sizes[label as usize] });
            }
        }
        // A removed slot has no corner in range: a component of its own, not a live one.
        components.retain(|c| self.is_triangle_live(c.first_triangle));
        components
    }

    /// The live triangles edge-connected to `seed` (sharing two distinct corners), ascending.
    fn component_of(&mut self, seed: u32) -> Vec<u32> {
        self.incidence();
        let slots = self.triangle_slots() as usize;
        if self.component_marks.len() < slots {
            self.component_marks.resize(slots, false);
        }
        let (incidence, triangles, in_component) = (
            self.incidence.as_ref().expect("built above"),
            &self.mesh.triangles,
            &mut self.component_marks,
        );
        let corners = |t: u32| &triangles[3 * t as usize..3 * t as usize + 3];
        in_component[seed as usize] = true;
        let mut component = vec![seed];
        let mut next = 0;
        while next < component.len() {
            let c = corners(component[next]);
            next += 1;
            for k in 0..3 {
                let (a, b) = (c[k], c[(k + 1) % 3]);
                if a == b {
                    continue;
                }
                for &t in incidence.around(a) {
                    if !in_component[t as usize] && corners(t).contains(&b) {
                        in_component[t as usize] = true;
                        component.push(t);
                    }
                }
            }
        }
        // Cleared where set, so the next component's search starts from all false without
        // a pass over every triangle (removing 150 small pieces of a 2M-triangle scan wrote
        // 300 MB of marks).
        component.iter().for_each(|&t| in_component[t as usize] = false);
        component.sort_unstable();
        component
    }

    /// Distinct corners of the given triangles, ascending.
    fn vertices_of(&self, triangles: &[u32]) -> Vec<u32> {
        let mut vertices: Vec<u32> = triangles.iter().flat_map(|&t| self.corners(t)).collect();
        vertices.sort_unstable();
        vertices.dedup();
        vertices
    }

    pub(super) fn remove_component(&mut self, triangle: u32) -> Result<(), EditError> {
        self.check_triangle(triangle)?;
        let component = self.component_of(triangle);
        let vertices = self.vertices_of(&component);
        for &t in &component {
            self.kill_triangle(t);
        }
        for v in vertices {
            if self.incidence().around(v).is_empty() {
                self.kill_vertex(v);
            }
        }
        Ok(())
    }

    pub(super) fn transform_component(
        &mut self,
        triangle: u32,
        matrix: &Affine,
    ) -> Result<(), EditError> {
        self.check_triangle(triangle)?;
        let component = self.component_of(triangle);
        let vertices = self.vertices_of(&component);
        self.transform_vertices(&vertices, matrix, "transform-component")
    }

    pub(super) fn transform(&mut self, matrix: &Affine) -> Result<(), EditError> {
        let live: Vec<u32> = (0..self.vertex_slots()).filter(|&v| self.is_vertex_live(v)).collect();
        self.transform_vertices(&live, matrix, "transform")
    }

    /// A finite map can still overflow to infinity: every image is checked before any write.
    fn transform_vertices(
        &mut self,
        vertices: &[u32],
        matrix: &Affine,
        op: &str,
    ) -> Result<(), EditError> {
        check_finite(matrix, &format!("{op} matrix"))?;
        let images: Vec<[f32; 3]> =
            vertices.iter().map(|&v| apply_affine(matrix, self.point(v))).collect();
        let bad = vertices.iter().zip(&images).find(|(_, p)| p.iter().any(|c| !c.is_finite()));
        if let Some((v, p)) = bad {
            check_finite(p, &format!("{op}: image of vertex {v}"))?;
        }
        for (&v, p) in vertices.iter().zip(images) {
            self.touch(v);
            self.positions_mut()[3 * v as usize..3 * v as usize + 3].copy_from_slice(&p);
        }
        Ok(())
    }

    pub(super) fn clear(&mut self) -> Result<(), EditError> {
        // Every list would end empty: dropping the index is cheaper than emptying it.
        self.incidence = None;
        for t in 0..self.triangle_slots() {
            if self.is_triangle_live(t) {
                self.kill_triangle(t);
            }
        }
        for v in 0..self.vertex_slots() {
            if self.is_vertex_live(v) {
                self.kill_vertex(v);
            }
        }
        Ok(())
    }
}

/// `R p + t` with a fixed order of f32 operations, so every host computes the same bits.
pub(crate) fn apply_affine(m: &Affine, p: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|r| {
        let row = &m[4 * r..4 * r + 4];
        row[0] * p[0] + row[1] * p[1] + row[2] * p[2] + row[3]
    })
}
