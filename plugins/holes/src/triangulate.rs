//! Liepa's minimum-weight triangulation of a hole's boundary polygon.
//!
//! Dynamic programming over sub-polygons `i..=k` of the loop (O(n³) time, O(n²) memory):
//! the weight of a triangulation is the pair (largest dihedral angle, total area), compared
//! lexicographically. The dihedral angles include those with the mesh triangles on the
//! hole's rim, so the patch continues the surface instead of cutting across it.

use meshflow_plugin_sdk::geometry::{Vec3, cross, dot, norm, scale, smaller, sub};

/// Cosines closer than this count as the same dihedral angle, so area decides between
/// triangulations whose worst angles differ only by rounding (planar holes).
const COS_TOLERANCE: f64 = 1e-9;

/// The weight of a (partial) triangulation: larger `worst_cos` (smaller largest dihedral
/// angle) first, then smaller `area`.
#[derive(Clone, Copy, Debug)]
struct Weight {
    worst_cos: f64,
    area: f64,
}

impl Weight {
    const INFEASIBLE: Weight = Weight { worst_cos: f64::NEG_INFINITY, area: f64::INFINITY };
    const EMPTY: Weight = Weight { worst_cos: 1.0, area: 0.0 };

    fn is_feasible(self) -> bool {
        self.worst_cos.is_finite()
    }

    fn is_better_than(self, other: Weight) -> bool {
        if !other.is_feasible() {
            return self.is_feasible();
        }
        if (self.worst_cos - other.worst_cos).abs() > COS_TOLERANCE {
            self.worst_cos > other.worst_cos
        } else {
            self.area < other.area
        }
    }
}

/// One cell of the table: the best triangulation of the sub-polygon `i..=k`.
#[derive(Clone, Copy)]
struct Cell {
    weight: Weight,
    /// The apex `m` of the triangle on edge `(i, k)`.
    apex: u32,
    /// The unit normal of that triangle (for `k = i + 1`: of the rim triangle), or zero.
    normal: Vec3,
}

/// The hole to triangulate, as loop-local data (index `i` is the loop's `i`-th vertex).
pub struct Polygon<'a> {
    /// The loop's vertices in walking order (the surface on the loop's left).
    pub points: &'a [Vec3],
    /// `rim_normals[i]`: unit normal of the mesh triangle on loop edge `i → i + 1` (mod n),
    /// or zero if that triangle is degenerate.
    pub rim_normals: &'a [Vec3],
}

/// The minimum-weight triangulation of the polygon as `n - 2` triangles of loop indices,
/// oriented like the rim triangles (each loop edge `i → i + 1` appears as `i + 1 → i`).
/// `is_forbidden_chord(i, k)` (with `i < k`, not a loop edge) rules out diagonals that would
/// duplicate an edge the mesh already has. `None` if `n < 3` or every triangulation uses a
/// forbidden chord.
pub fn triangulate(
    polygon: &Polygon,
    is_forbidden_chord: impl Fn(usize, usize) -> bool,
) -> Option<Vec<[u32; 3]>> {
    let n = polygon.points.len();
    if n < 3 || polygon.rim_normals.len() != n {
        return None;
    }
    let p = polygon.points;
    let empty = Cell { weight: Weight::INFEASIBLE, apex: 0, normal: [0.0; 3] };
    let mut table = vec![empty; n * n];
    for i in 0..n - 1 {
        table[i * n + i + 1] =
            Cell { weight: Weight::EMPTY, apex: 0, normal: polygon.rim_normals[i] };
    }
    for span in 2..n {
        for i in 0..n - span {
            let k = i + span;
            let closing = i == 0 && k == n - 1;
            if !closing && is_forbidden_chord(i, k) {
                continue;
            }
            let mut best = empty;
            for m in i + 1..k {
                let (left, right) = (table[i * n + m], table[m * n + k]);
                let inherited = smaller(left.weight.worst_cos, right.weight.worst_cos);
                // Infeasible halves, or halves already bending worse than the best so far:
                // this apex cannot win, skip its geometry (most candidates on real holes).
                if !inherited.is_finite()
                    || (best.weight.is_feasible()
                        && inherited < best.weight.worst_cos - COS_TOLERANCE)
                {
                    continue;
                }
                // Reversed corner order: the patch runs against the loop, like the rim.
                let twice_normal = cross(sub(p[m], p[k]), sub(p[i], p[k]));
                let length = norm(twice_normal);
                let (normal, mut worst) = if length > 0.0 && length.is_finite() {
                    let u = scale(twice_normal, 1.0 / length);
                    (u, smaller(bend(u, left.normal), bend(u, right.normal)))
                } else {
                    // A degenerate triangle folds the patch as badly as anything can.
                    ([0.0; 3], -1.0)
                };
                if closing {
                    worst = smaller(worst, bend(normal, polygon.rim_normals[n - 1]));
                }
                let weight = Weight {
                    worst_cos: smaller(
                        smaller(worst, left.weight.worst_cos),
                        right.weight.worst_cos,
                    ),
                    area: left.weight.area + right.weight.area + 0.5 * length,
                };
                if weight.is_better_than(best.weight) {
                    best = Cell { weight, apex: m as u32, normal };
                }
            }
            table[i * n + k] = best;
        }
    }
    if !table[n - 1].weight.is_feasible() {
        return None;
    }
    let mut result = Vec::with_capacity(n - 2);
    let mut pending = vec![(0, n - 1)];
    while let Some((i, k)) = pending.pop() {
        if k - i < 2 {
            continue;
        }
        let m = table[i * n + k].apex as usize;
        result.push([k as u32, m as u32, i as u32]);
        pending.push((i, m));
        pending.push((m, k));
    }
    Some(result)
}

/// The cosine of the dihedral angle between two unit normals; 1 (flat) when one is unknown
/// (zero), so a degenerate rim triangle does not constrain the patch.
#[inline]
fn bend(a: Vec3, b: Vec3) -> f64 {
    if b == [0.0; 3] { 1.0 } else { dot(a, b) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// Checks that `tris` triangulate the n-gon: n - 2 triangles, every loop edge used once
    /// against the loop direction, every diagonal used twice in opposite directions.
    fn assert_triangulates(n: usize, tris: &[[u32; 3]]) {
        assert_eq!(tris.len(), n - 2);
        let mut directed = BTreeSet::new();
        for t in tris {
            for k in 0..3 {
                assert!(directed.insert((t[k], t[(k + 1) % 3])), "edge used twice: {t:?}");
            }
        }
        for i in 0..n as u32 {
            let j = (i + 1) % n as u32;
            assert!(directed.contains(&(j, i)), "loop edge {i}->{j} not closed");
            assert!(!directed.contains(&(i, j)), "loop edge {i}->{j} misoriented");
        }
        for &(a, b) in &directed {
            let loop_edge = (a + 1) % n as u32 == b || (b + 1) % n as u32 == a;
            assert!(loop_edge || directed.contains(&(b, a)), "diagonal {a}-{b} open");
        }
    }

    /// Rim normals of a flat surface around a loop that runs clockwise seen from +z (the
    /// surface is on the loop's left, the hole on its right).
    fn flat(points: &[Vec3]) -> Vec<Vec3> {
        vec![[0.0, 0.0, 1.0]; points.len()]
    }

    #[test]
    fn a_planar_polygon_gives_a_valid_triangulation() {
        // A ten-gon with a notch (non-convex): a fold would have a normal flipped by π.
        let mut points: Vec<Vec3> = (0..10)
            .map(|i| {
                let a = -(i as f64) * std::f64::consts::TAU / 10.0;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        points[3] = [0.2, -0.2, 0.0];
        let rim = flat(&points);
        let tris = triangulate(&Polygon { points: &points, rim_normals: &rim }, |_, _| false)
            .expect("a triangulation");
        assert_triangulates(10, &tris);
        // No triangle is folded over: every normal points up like the rim's.
        for t in &tris {
            let [a, b, c] = t.map(|v| points[v as usize]);
            assert!(cross(sub(b, a), sub(c, a))[2] > 0.0, "folded triangle {t:?}");
        }
    }

    #[test]
    fn a_regular_polygon_is_not_a_fan() {
        // With many equal candidates the area tie-break avoids a fan of slivers from one
        // vertex: no vertex is in every triangle.
        let n = 12;
        let points: Vec<Vec3> = (0..n)
            .map(|i| {
                let a = -(i as f64) * std::f64::consts::TAU / n as f64;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        let rim = flat(&points);
        let tris =
            triangulate(&Polygon { points: &points, rim_normals: &rim }, |_, _| false).unwrap();
        assert_triangulates(n, &tris);
        for v in 0..n as u32 {
            assert!(tris.iter().any(|t| !t.contains(&v)), "fan around {v}");
        }
    }

    /// Every triangulation of the sub-polygon `i..=k`, triangles oriented as `triangulate`'s.
    fn all_triangulations(i: u32, k: u32) -> Vec<Vec<[u32; 3]>> {
        if k - i < 2 {
            return vec![Vec::new()];
        }
        let mut all = Vec::new();
        for m in i + 1..k {
            for left in all_triangulations(i, m) {
                for right in all_triangulations(m, k) {
                    all.push([vec![[k, m, i]], left.clone(), right].concat());
                }
            }
        }
        all
    }

    /// Liepa's weight computed directly: (largest angle between the normals of triangles
    /// sharing an edge, rim triangles included; total area).
    fn direct_weight(points: &[Vec3], rim: &[Vec3], tris: &[[u32; 3]]) -> (f64, f64) {
        let n = points.len() as u32;
        let normal = |t: &[u32; 3]| unit_normal(points, t.map(|v| v as usize));
        let angle = |a: Vec3, b: Vec3| dot(a, b).clamp(-1.0, 1.0).acos();
        let mut worst = 0f64;
        for (x, s) in tris.iter().enumerate() {
            for e in 0..3 {
                let (a, b) = (s[e], s[(e + 1) % 3]);
                if (b + 1) % n == a {
                    worst = worst.max(angle(normal(s), rim[b as usize]));
                }
                for t in &tris[x + 1..] {
                    if t.contains(&a) && t.contains(&b) {
                        worst = worst.max(angle(normal(s), normal(t)));
                    }
                }
            }
        }
        let area = tris.iter().map(|t| {
            let [a, b, c] = t.map(|v| points[v as usize]);
            0.5 * norm(cross(sub(b, a), sub(c, a)))
        });
        (worst, area.sum())
    }

    fn unit_normal(points: &[Vec3], [a, b, c]: [usize; 3]) -> Vec3 {
        let n = cross(sub(points[b], points[a]), sub(points[c], points[a]));
        scale(n, 1.0 / norm(n))
    }

    #[test]
    fn the_result_is_optimal_among_all_triangulations() {
        // A hole in a wavy surface z = f(x, y), rim normals from the surface itself.
        let f = |x: f64, y: f64| 0.4 * (3.0 * x).sin() * (2.0 * y).cos();
        let surface_normal = |x: f64, y: f64| {
            let (dx, dy) =
                (1.2 * (3.0 * x).cos() * (2.0 * y).cos(), -0.8 * (3.0 * x).sin() * (2.0 * y).sin());
            scale([-dx, -dy, 1.0], 1.0 / norm([-dx, -dy, 1.0]))
        };
        for (n, radius) in [(6, 0.5), (7, 0.8), (8, 1.0)] {
            let points: Vec<Vec3> = (0..n)
                .map(|i| {
                    let a = -(i as f64) * std::f64::consts::TAU / n as f64 + 0.3;
                    let (x, y) = (radius * a.cos(), 0.7 * radius * a.sin());
                    [x, y, f(x, y)]
                })
                .collect();
            let rim: Vec<Vec3> = (0..n)
                .map(|i| {
                    let (p, q) = (points[i], points[(i + 1) % n]);
                    surface_normal(0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1]))
                })
                .collect();
            let tris =
                triangulate(&Polygon { points: &points, rim_normals: &rim }, |_, _| false).unwrap();
            assert_triangulates(n, &tris);
            let found = direct_weight(&points, &rim, &tris);
            for other in all_triangulations(0, n as u32 - 1) {
                let w = direct_weight(&points, &rim, &other);
                assert!(
                    w.0 > found.0 - 1e-6 && (w.0 > found.0 + 1e-6 || w.1 >= found.1 - 1e-12),
                    "n = {n}: {other:?} weighs {w:?}, better than {tris:?} at {found:?}"
                );
            }
        }
    }

    #[test]
    fn forbidden_chords_are_avoided_or_reported() {
        let points = vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, 0.0]];
        let rim = flat(&points);
        let polygon = Polygon { points: &points, rim_normals: &rim };
        let tris = triangulate(&polygon, |i, k| (i, k) == (0, 2)).unwrap();
        assert!(tris.iter().all(|t| !(t.contains(&0) && t.contains(&2))));
        assert!(triangulate(&polygon, |_, _| true).is_none());
        assert!(
            triangulate(&Polygon { points: &points[..2], rim_normals: &rim[..2] }, |_, _| {
                false
            })
            .is_none()
        );
    }

    #[test]
    fn degenerate_input_does_not_panic() {
        let points = vec![[0.0; 3]; 5];
        let rim = vec![[0.0; 3]; 5];
        let tris =
            triangulate(&Polygon { points: &points, rim_normals: &rim }, |_, _| false).unwrap();
        assert_triangulates(5, &tris);
        let nan = vec![[f64::NAN; 3]; 4];
        let tris = triangulate(&Polygon { points: &nan, rim_normals: &rim[..4] }, |_, _| false);
        assert_triangulates(4, &tris.unwrap());
    }
}
