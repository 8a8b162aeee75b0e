//! Triangle edits: add, remove, flip, split.

use super::{EditError, MeshStore, check_distinct, check_finite, check_triples};

impl MeshStore {
    pub(super) fn add_triangles(&mut self, abc: &[u32]) -> Result<u32, EditError> {
        check_triples(abc.len(), "add-triangles")?;
        for t in abc.chunks_exact(3) {
            self.check_new_triangle([t[0], t[1], t[2]])?;
        }
        let first = self.triangle_slots();
        for t in abc.chunks_exact(3) {
            self.push_triangle([t[0], t[1], t[2]]);
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
        let p = match at {
            Some(p) => {
                check_finite(&p, "split-triangle")?;
                p
            }
            None => centroid(self.point(a), self.point(b), self.point(c)),
        };
        let v = self.push_vertex(p);
        self.set_corners(triangle, [a, b, v]);
        self.push_triangle([b, c, v]);
        self.push_triangle([c, a, v]);
        Ok(v)
    }
}

/// `(a + b + c) / 3` per axis, in this order of f32 operations: part of the contract, as a
/// replaying host must compute the same bits.
fn centroid(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|k| (a[k] + b[k] + c[k]) / 3.0)
}
