//! Edge edits, addressed by half-edge id `3 * t + k` (corner k to corner (k+1) % 3).

use meshflow_topology::edits::split_on_edge;

use super::attributes::edge_parameter;
use super::{EditError, EditErrorKind, MeshStore, check_finite};

/// A validated half-edge: its triangle, corner, and end points.
struct HalfEdge {
    triangle: u32,
    corner: usize,
    from: u32,
    to: u32,
}

impl MeshStore {
    fn half_edge(&self, edge: u32, op: &str) -> Result<HalfEdge, EditError> {
        let triangle = edge / 3;
        if triangle >= self.triangle_slots() || !self.is_triangle_live(triangle) {
            return Err(EditError::new(
                EditErrorKind::InvalidEdge,
                format!("{op}: half-edge {edge} belongs to no live triangle"),
            ));
        }
        let corner = (edge % 3) as usize;
        let corners = self.corners(triangle);
        let (from, to) = (corners[corner], corners[(corner + 1) % 3]);
        if from == to {
            return Err(EditError::not_applicable(format!(
                "{op}: half-edge {edge} joins vertex {from} to itself"
            )));
        }
        Ok(HalfEdge { triangle, corner, from, to })
    }

    /// Live triangles that have both ends of the edge as corners, ascending.
    fn triangles_on_edge(&mut self, a: u32, b: u32) -> Vec<u32> {
        let mut on_edge = self.triangles_around(a);
        on_edge.retain(|&t| self.corners(t).contains(&b));
        on_edge
    }

    pub(super) fn extend_edge(&mut self, edge: u32, vertex: u32) -> Result<u32, EditError> {
        let HalfEdge { triangle, from, to, .. } = self.half_edge(edge, "extend-edge")?;
        self.check_new_triangle([to, from, vertex])?;
        let corners = [to, from, vertex];
        let origins = self.corner_origins(&[triangle], corners, None);
        Ok(self.push_triangle(corners, Some(triangle), origins))
    }

    /// Each triangle `(x, y, o)` on the edge becomes `(x, v, o)` and appends `(v, y, o)`,
    /// in ascending triangle order, so orientation is kept and ids are canonical.
    pub(super) fn split_edge(&mut self, edge: u32, at: Option<[f32; 3]>) -> Result<u32, EditError> {
        let HalfEdge { from: a, to: b, .. } = self.half_edge(edge, "split-edge")?;
        if let Some(p) = at {
            check_finite(&p, "split-edge")?;
        }
        let on_edge = self.triangles_on_edge(a, b);
        if let Some(&t) = on_edge.iter().find(|&&t| is_degenerate(self.corners(t))) {
            return Err(EditError::not_applicable(format!(
                "split-edge: degenerate triangle {t} lies on edge ({a}, {b})"
            )));
        }
        let (pa, pb) = (self.point(a), self.point(b));
        let (p, s) = match at {
            Some(p) => (p, edge_parameter(p, pa, pb)),
            None => (midpoint(pa, pb), 0.5),
        };
        let parents = [(a, 1.0 - s), (b, s)];
        let v = self.push_vertex(p, &parents);
        for t in on_edge {
            let (kept, appended) = split_on_edge(self.corners(t), a, b, v)
                .expect("a non-degenerate triangle with both ends has the edge");
            let new = Some((v, &parents[..]));
            let kept_origins = self.corner_origins(&[t], kept, new);
            let appended_origins = self.corner_origins(&[t], appended, new);
            let kept_values = kept_origins.map(|origins| self.corner_values(&origins));
            self.push_triangle(appended, Some(t), appended_origins);
            self.set_corners(t, kept);
            if let Some(values) = kept_values {
                self.write_corners(t, values);
            }
        }
        Ok(v)
    }

    /// `(a, b, c)` and `(b, a, d)` become `(a, d, c)` and `(b, c, d)`, each keeping its id
    /// and the corner slot of its edge's start.
    pub(super) fn swap_edge(&mut self, edge: u32) -> Result<(), EditError> {
        let HalfEdge { triangle: t, corner: k, from: a, to: b } =
            self.half_edge(edge, "swap-edge")?;
        let on_edge = self.triangles_on_edge(a, b);
        let [first, second] = on_edge[..] else {
            return Err(EditError::not_applicable(format!(
                "swap-edge: edge ({a}, {b}) has {} triangles, not 2",
                on_edge.len()
            )));
        };
        let u = if first == t { second } else { first };
        let tc = self.corners(t);
        let uc = self.corners(u);
        let Some(m) = (0..3).find(|&m| uc[m] == b && uc[(m + 1) % 3] == a) else {
            return Err(EditError::not_applicable(format!(
                "swap-edge: triangles {t} and {u} are not oriented alike across ({a}, {b})"
            )));
        };
        let (c, d) = (tc[(k + 2) % 3], uc[(m + 2) % 3]);
        if c == d || is_degenerate(tc) || is_degenerate(uc) {
            return Err(EditError::not_applicable(format!(
                "swap-edge: triangles {t} and {u} do not form a quad"
            )));
        }
        if !self.triangles_on_edge(c, d).is_empty() {
            return Err(EditError::not_applicable(format!(
                "swap-edge: the other diagonal ({c}, {d}) is already an edge"
            )));
        }
        let mut new_t = tc;
        new_t[(k + 1) % 3] = d;
        let mut new_u = uc;
        new_u[(m + 1) % 3] = c;
        let values = [(t, new_t, [t, u]), (u, new_u, [u, t])].map(|(id, corners, sources)| {
            let origins = self.corner_origins(&sources, corners, None);
            (id, origins.map(|origins| self.corner_values(&origins)))
        });
        self.set_corners(t, new_t);
        self.set_corners(u, new_u);
        for (id, values) in values {
            if let Some(values) = values {
                self.write_corners(id, values);
            }
        }
        Ok(())
    }

    /// Triangles on the edge are removed; every other use of the end vertex becomes the start.
    pub(super) fn collapse_edge(&mut self, edge: u32) -> Result<(), EditError> {
        let HalfEdge { from: a, to: b, .. } = self.half_edge(edge, "collapse-edge")?;
        for t in self.triangles_around(b) {
            let corners = self.corners(t);
            if corners.contains(&a) {
                self.kill_triangle(t);
            } else {
                self.set_corners(t, corners.map(|v| if v == b { a } else { v }));
            }
        }
        self.kill_vertex(b);
        Ok(())
    }
}

fn is_degenerate([a, b, c]: [u32; 3]) -> bool {
    a == b || b == c || a == c
}

/// `(a + b) * 0.5` per axis, in f32: part of the contract, as replaying hosts must agree.
fn midpoint(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|k| (a[k] + b[k]) * 0.5)
}
