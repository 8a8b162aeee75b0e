//! Fairing: moves the patch's new vertices so the patch blends with the surface around it.
//!
//! Liepa's umbrella-operator fairing of second order: the new vertices minimise
//! `Σ |U(v)|²` over every patch vertex `v`, with `U(v)` the uniform umbrella (mean of the
//! neighbours minus `v`). The loop vertices stay fixed, but their umbrellas include their
//! neighbours in the mesh, so the patch takes up the surrounding surface's slope and
//! curvature instead of spanning the hole like a soap film. The least-squares system is
//! sparse and small; conjugate gradients on the normal equations (CGLS) solve it in a fixed
//! number of steps without assembling a matrix.

use meshflow_plugin_sdk::geometry::{Vec3, add, dot, scale, sub};
use meshflow_plugin_sdk::topology::{Csr, VertexNeighbours, for_each_by_four};

/// The mesh neighbours of one loop vertex, summed (each neighbour once).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Ring {
    pub sum: Vec3,
    pub count: u32,
}

/// The umbrella operator over a patch: rows for every vertex, columns for the new ones.
struct Umbrellas {
    /// Per row: the new vertices among its neighbours, as column (unknown) indices,
    /// ascending.
    columns: Csr,
    /// Per row: 1 / (number of neighbours counted in the umbrella).
    inverse_degree: Vec<f64>,
    rim_len: usize,
}

impl Umbrellas {
    /// `U x` over the new vertices' values `x` (the fixed part left out).
    fn apply(&self, x: &[Vec3], out: &mut [Vec3]) {
        for (v, o) in out.iter_mut().enumerate() {
            let mut sum = [0.0; 3];
            for_each_by_four(self.columns.row(v), |_, c| sum = add(sum, x[c as usize]));
            *o = scale(sum, self.inverse_degree[v]);
            if v >= self.rim_len {
                *o = sub(*o, x[v - self.rim_len]);
            }
        }
    }

    /// `Uᵀ y`, the transpose of [`apply`](Self::apply).
    fn apply_transposed(&self, y: &[Vec3], out: &mut [Vec3]) {
        out.fill([0.0; 3]);
        for (v, &yv) in y.iter().enumerate() {
            let share = scale(yv, self.inverse_degree[v]);
            for_each_by_four(self.columns.row(v), |_, c| {
                let o = &mut out[c as usize];
                *o = add(*o, share);
            });
            if v >= self.rim_len {
                out[v - self.rim_len] = sub(out[v - self.rim_len], yv);
            }
        }
    }
}

/// For loop vertex `v` only the patch neighbours `w` the mesh ring lacks count: the loop
/// edges to `v - 1` and `v + 1` are mesh edges, every other patch edge is new.
fn counts(rim_len: usize, v: usize, w: u32) -> bool {
    let (n, w) = (rim_len, w as usize);
    v >= n || w >= n || (w != (v + 1) % n && w != (v + n - 1) % n)
}

/// Fairs the vertices of `points` from index `rings.len()` on (the new ones); the first
/// `rings.len()` are the loop, in order, with their mesh neighbourhoods in `rings`.
/// `triangles` are the patch's, by local vertex id. `iterations` bounds the CGLS steps.
pub fn fair(points: &mut [Vec3], triangles: &[[u32; 3]], rings: &[Ring], iterations: u32) {
    let rim_len = rings.len();
    if points.len() <= rim_len {
        return;
    }
    let neighbours = VertexNeighbours::new(points.len(), triangles.as_flattened());
    // The fixed part of every umbrella: loop neighbours, mesh rings, minus a loop vertex.
    let mut fixed = vec![[0.0; 3]; points.len()];
    let mut inverse_degree = vec![0.0; points.len()];
    let (mut offsets, mut columns) = (vec![0u32], Vec::new());
    for v in 0..points.len() {
        let ring = rings.get(v).copied().unwrap_or_default();
        let (mut sum, mut count) = (ring.sum, ring.count as usize);
        for &w in neighbours.of(v as u32) {
            if counts(rim_len, v, w) {
                count += 1;
                if (w as usize) < rim_len {
                    sum = add(sum, points[w as usize]);
                }
            }
            if w as usize >= rim_len {
                columns.push(w - rim_len as u32);
            }
        }
        offsets.push(columns.len() as u32);
        inverse_degree[v] = 1.0 / count.max(1) as f64;
        fixed[v] = scale(sum, inverse_degree[v]);
        if v < rim_len {
            fixed[v] = sub(fixed[v], points[v]);
        }
    }
    let umbrellas = Umbrellas {
        columns: Csr::from_parts(offsets, columns).expect("offsets ascend to the column count"),
        inverse_degree,
        rim_len,
    };
    let unknowns = points.len() - rim_len;
    let mut x = points[rim_len..].to_vec();
    // Residual r = -fixed - U x; CGLS on min |U x + fixed|², per coordinate.
    let mut r = vec![[0.0; 3]; points.len()];
    umbrellas.apply(&x, &mut r);
    for (rv, f) in r.iter_mut().zip(&fixed) {
        *rv = scale(add(*rv, *f), -1.0);
    }
    let mut s = vec![[0.0; 3]; unknowns];
    umbrellas.apply_transposed(&r, &mut s);
    let mut p = s.clone();
    let mut gamma = squared_norms(&s);
    let mut q = vec![[0.0; 3]; points.len()];
    for _ in 0..iterations {
        umbrellas.apply(&p, &mut q);
        let qq = squared_norms(&q);
        let alpha: Vec3 = [0, 1, 2].map(|k| if qq[k] > 0.0 { gamma[k] / qq[k] } else { 0.0 });
        for (xi, pi) in x.iter_mut().zip(&p) {
            *xi = add(*xi, mul(alpha, *pi));
        }
        for (ri, qi) in r.iter_mut().zip(&q) {
            *ri = sub(*ri, mul(alpha, *qi));
        }
        umbrellas.apply_transposed(&r, &mut s);
        let next_gamma = squared_norms(&s);
        let beta: Vec3 =
            [0, 1, 2].map(|k| if gamma[k] > 0.0 { next_gamma[k] / gamma[k] } else { 0.0 });
        for (pi, si) in p.iter_mut().zip(&s) {
            *pi = add(*si, mul(beta, *pi));
        }
        gamma = next_gamma;
        if dot(gamma, [1.0; 3]) == 0.0 {
            break;
        }
    }
    points[rim_len..].copy_from_slice(&x);
}

/// Per-coordinate sums of squares.
fn squared_norms(values: &[Vec3]) -> Vec3 {
    values.iter().fold([0.0; 3], |s, v| add(s, mul(*v, *v)))
}

/// Per-coordinate product.
fn mul(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] * b[0], a[1] * b[1], a[2] * b[2]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::patch::Patch;
    use crate::refine::refine;
    use crate::triangulate::{Polygon, triangulate};
    use meshflow_plugin_sdk::geometry::{distance, norm};

    /// A hole in the unit sphere around the north pole (loop at polar angle `cap`, `n` edges),
    /// triangulated and refined; with each loop vertex's mesh ring: its loop neighbours and
    /// the point one ring further down the sphere.
    fn sphere_hole(n: usize, cap: f64) -> (Patch, Vec<Ring>) {
        let on_sphere =
            |polar: f64, a: f64| [polar.sin() * a.cos(), polar.sin() * a.sin(), polar.cos()];
        let step = std::f64::consts::TAU / n as f64;
        // Clockwise seen from outside (+z), so the sphere is on the loop's left.
        let points: Vec<Vec3> = (0..n).map(|i| on_sphere(cap, -(i as f64) * step)).collect();
        let rim: Vec<Vec3> = points.clone();
        let tris =
            triangulate(&Polygon { points: &points, rim_normals: &rim }, |_, _| false).unwrap();
        let edge = distance(points[0], points[1]);
        let mut patch = Patch::new(points.clone(), vec![edge; n], tris);
        refine(&mut patch, usize::MAX, |_, _| false);
        let rings = (0..n)
            .map(|i| {
                let below = on_sphere(cap + edge, -(i as f64) * step);
                let sum = add(add(points[(i + 1) % n], points[(i + n - 1) % n]), below);
                Ring { sum, count: 3 }
            })
            .collect();
        (patch, rings)
    }

    #[test]
    fn fairing_keeps_the_loop_and_bulges_the_patch_onto_the_sphere() {
        let (mut patch, rings) = sphere_hole(24, 0.6);
        assert!(patch.points.len() > 30);
        let before = patch.points.clone();
        fair(&mut patch.points, &patch.triangles, &rings, 200);
        assert_eq!(patch.points[..24], before[..24], "the loop moved");
        // The flat fill lies inside the sphere; the faired one is closer to it.
        let off_sphere = |p: &[Vec3]| p[24..].iter().map(|&q| (norm(q) - 1.0).abs()).sum::<f64>();
        let (flat, faired) = (off_sphere(&before), off_sphere(&patch.points));
        assert!(faired < 0.5 * flat, "off the sphere by {faired} after, {flat} before");
        assert!(patch.points[24..].iter().all(|&q| norm(q) < 1.02), "overshoot");
    }

    #[test]
    fn a_flat_hole_stays_flat() {
        let n = 16;
        let points: Vec<Vec3> = (0..n)
            .map(|i| {
                let a = -(i as f64) * std::f64::consts::TAU / n as f64;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        let rim = vec![[0.0, 0.0, 1.0]; n];
        let tris =
            triangulate(&Polygon { points: &points, rim_normals: &rim }, |_, _| false).unwrap();
        let mut patch = Patch::new(points.clone(), vec![0.2; n], tris);
        refine(&mut patch, usize::MAX, |_, _| false);
        let rings: Vec<Ring> = (0..n)
            .map(|i| {
                let out = scale(points[i], 1.3);
                Ring { sum: add(add(points[(i + 1) % n], points[(i + n - 1) % n]), out), count: 3 }
            })
            .collect();
        fair(&mut patch.points, &patch.triangles, &rings, 50);
        assert!(patch.points.iter().all(|p| p[2].abs() < 1e-12));
        assert!(patch.points[n..].iter().all(|p| norm(*p) < 1.0), "left the hole");
    }
}
