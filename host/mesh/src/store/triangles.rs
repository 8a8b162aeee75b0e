//! Triangle edits: add, remove, flip, split.

use super::attributes::barycentric;
use super::{CornerOrigin, EditError, MeshStore, check_distinct, check_finite, check_triples};
use crate::attributes::Domain;

impl MeshStore {
    pub(super) fn add_triangles(&mut self, abc: &[u32]) -> Result<u32, EditError> {
        check_triples(abc.len(), "add-triangles")?;
        for t in abc.chunks_exact(3) {
            self.check_new_triangle([t[0], t[1], t[2]])?;
        }
        let first = self.triangle_slots();
        for t in abc.chunks_exact(3) {
            let corners = [t[0], t[1], t[2]];
            let origins = self.continued_corners(corners);
            self.push_triangle(corners, None, origins);
        }
        Ok(first)
    }

    pub(super) fn remove_triangles(&mut self, ids: &[u32]) -> Result<(), EditError> {
        for &t in ids {
            self.check_triangle(t)?;
        }
        check_distinct(ids, "remove-triangles")?;
        for &t in ids {
            self.kill_triangle(t);
        }
        Ok(())
    }

    pub(super) fn flip_triangles(&mut self, ids: &[u32]) -> Result<(), EditError> {
        for &t in ids {
            self.check_triangle(t)?;
        }
        for &t in ids {
            let i = 3 * t as usize;
            // Same vertex set, so the incidence lists stay valid.
            self.triangles_mut().swap(i + 1, i + 2);
            self.flip_corner_values(t);
            self.corners(t).iter().for_each(|&v| self.touch(v));
        }
        Ok(())
    }

    /// `(a, b, c)` becomes `(a, b, v)`, `(b, c, v)`, `(c, a, v)`: the old id keeps edge 0.
    pub(super) fn split_triangle(
        &mut self,
        triangle: u32,
        at: Option<[f32; 3]>,
    ) -> Result<u32, EditError> {
        self.check_triangle(triangle)?;
        let [a, b, c] = self.corners(triangle);
        if a == b || b == c || a == c {
            return Err(EditError::not_applicable(format!(
                "split-triangle: triangle {triangle} ({a}, {b}, {c}) is degenerate"
            )));
        }
        let (pa, pb, pc) = (self.point(a), self.point(b), self.point(c));
        let (p, weights) = match at {
            Some(p) => {
                check_finite(&p, "split-triangle")?;
                (p, barycentric(p, pa, pb, pc))
            }
            None => (centroid(pa, pb, pc), [1.0 / 3.0; 3]),
        };
        let parents = [(a, weights[0]), (b, weights[1]), (c, weights[2])];
        let v = self.push_vertex(p, &parents);
        let from = [triangle];
        let new = Some((v, &parents[..]));
        let [kept, second, third] = [[a, b, v], [b, c, v], [c, a, v]]
            .map(|corners| (corners, self.corner_origins(&from, corners, new)));
        let kept_values = kept.1.map(|origins| self.corner_values(&origins));
        self.push_triangle(second.0, Some(triangle), second.1);
        self.push_triangle(third.0, Some(triangle), third.1);
        self.set_corners(triangle, kept.0);
        if let Some(values) = kept_values {
            self.write_corners(triangle, values);
        }
        Ok(v)
    }

    /// Where a new triangle's corners take their values: the first live corner at the same
    /// vertex (a hole's new triangles continue the texture around it).
    fn continued_corners(&mut self, corners: [u32; 3]) -> Option<[CornerOrigin; 3]> {
        if !self.mesh.attributes.has_domain(Domain::Corner) {
            return None;
        }
        Some(corners.map(|v| {
            let first = self.triangles_around(v).into_iter().next();
            first.map_or(CornerOrigin::Default, |t| {
                let k = self.corners(t).iter().position(|&c| c == v).expect("around v");
                CornerOrigin::Copy(3 * t as usize + k)
            })
        }))
    }
}

/// `(a + b + c) / 3` per axis, in this order of f32 operations: part of the contract, as a
/// replaying host must compute the same bits.
fn centroid(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|k| (a[k] + b[k] + c[k]) / 3.0)
}
