//! Geometry over flat arrays: normals, areas, angles, bounding boxes, cotangent weights,
//! dihedral angles.
//!
//! Positions are `f32` (x y z per vertex) as the host stores them; every computation here
//! converts to `f64` first (exactly) and works in `f64`, so cross products, areas and angles
//! of small or thin triangles on large coordinates keep their precision. Results that go
//! back into per-vertex arrays ([`vertex_normals`]) are rounded to `f32` at the end.
//!
//! Functions taking a triangle id `t` or half-edge id `h` panic if it, or one of its
//! vertex ids, is out of range (that is a caller bug, not a mesh defect). Whole-mesh
//! functions skip triangles with out-of-range ids and never panic on raw-scan defects.
//!
//! Angles are radians unless the name says `degrees`.

use crate::VertexNeighbours;
use crate::halfedge::{HalfEdges, next, prev};

/// A point or vector in `f64`.
pub type Vec3 = [f64; 3];

/// `a + b`.
#[inline]
pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a - b`.
#[inline]
pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a * s`.
#[inline]
pub fn scale(a: Vec3, s: f64) -> Vec3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// Dot product.
#[inline]
pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Cross product `a × b`.
#[inline]
pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// Euclidean length.
#[inline]
pub fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

/// `f64::min` as two compares. In wasm, `f64::min` (and `f32::min`) is a call to a software
/// `fmin`, as the instruction's NaN rule differs; this gives the same answers (a NaN argument
/// yields the other one), fast. Use it in hot loops of plugins.
#[inline(always)]
pub fn smaller(a: f64, b: f64) -> f64 {
    if b < a || a.is_nan() { b } else { a }
}

/// `f64::max` as two compares; see [`smaller`].
#[inline(always)]
pub fn larger(a: f64, b: f64) -> f64 {
    if b > a || a.is_nan() { b } else { a }
}

/// The point of triangle `abc` closest to `p` (Ericson, *Real-Time Collision Detection*,
/// 5.1.5: by the Voronoi region of `p`). A flat triangle answers with the closest point of
/// its sides. O(1).
pub fn closest_point_on_triangle(p: Vec3, [a, b, c]: [Vec3; 3]) -> Vec3 {
    let along = |o: Vec3, d: Vec3, t: f64| add(o, scale(d, t));
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    if cross(ab, ac) == [0.0; 3] {
        // The regions below divide by the sides' squared lengths: NaN at a repeated corner.
        return [(a, b), (b, c), (c, a)]
            .map(|(s, e)| closest_point_on_segment(p, s, e))
            .into_iter()
            .min_by(|x, y| distance(p, *x).total_cmp(&distance(p, *y)))
            .expect("three sides");
    }
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return along(a, ab, d1 / (d1 - d3));
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return along(a, ac, d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return along(b, sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom == 0.0 {
        return a;
    }
    add(a, add(scale(ab, vb / denom), scale(ac, vc / denom)))
}

/// The point of segment `s`–`e` closest to `p`; `s` if the segment is a point. O(1).
pub fn closest_point_on_segment(p: Vec3, s: Vec3, e: Vec3) -> Vec3 {
    let d = sub(e, s);
    let length_squared = dot(d, d);
    if length_squared == 0.0 {
        return s;
    }
    let t = (dot(sub(p, s), d) / length_squared).clamp(0.0, 1.0);
    add(s, scale(d, t))
}

/// Distance between two points.
#[inline]
pub fn distance(a: Vec3, b: Vec3) -> f64 {
    norm(sub(a, b))
}

/// `a` scaled to unit length, or `None` if its length is zero or not finite.
#[inline]
pub fn normalize(a: Vec3) -> Option<Vec3> {
    let n = norm(a);
    (n > 0.0 && n.is_finite()).then(|| scale(a, 1.0 / n))
}

/// The angle between two vectors in `[0, π]`, computed as `atan2(|a × b|, a · b)`, which is
/// accurate for nearly parallel vectors too (unlike `acos`). 0 if either vector is zero.
#[inline]
pub fn angle_between(a: Vec3, b: Vec3) -> f64 {
    norm(cross(a, b)).atan2(dot(a, b))
}

/// The cotangent of the angle between `a` and `b`: `(a · b) / |a × b|`; 0 when the vectors
/// are parallel or zero (the angle is 0 or π and the cotangent unbounded).
#[inline]
pub fn cotangent(a: Vec3, b: Vec3) -> f64 {
    let s = norm(cross(a, b));
    if s > 0.0 { dot(a, b) / s } else { 0.0 }
}

/// Vertex `v` as an `f64` point. O(1).
#[inline(always)]
pub fn point(positions: &[f32], v: u32) -> Vec3 {
    let i = 3 * v as usize;
    [positions[i] as f64, positions[i + 1] as f64, positions[i + 2] as f64]
}

/// The three corners of triangle `t`. O(1).
#[inline(always)]
pub fn triangle_points(positions: &[f32], triangles: &[u32], t: u32) -> [Vec3; 3] {
    let i = 3 * t as usize;
    [
        point(positions, triangles[i]),
        point(positions, triangles[i + 1]),
        point(positions, triangles[i + 2]),
    ]
}

/// The unnormalised normal `(p1 - p0) × (p2 - p0)` of a triangle given by its corners: its
/// length is twice the area, its direction follows the right-hand rule on the corner order.
#[inline]
pub fn normal_of(p: &[Vec3; 3]) -> Vec3 {
    cross(sub(p[1], p[0]), sub(p[2], p[0]))
}

/// The area of a triangle given by its corners.
#[inline]
pub fn area_of(p: &[Vec3; 3]) -> f64 {
    0.5 * norm(normal_of(p))
}

/// The interior angles at corners 0, 1, 2 of a triangle given by its corners, in radians.
///
/// Computed with [`angle_between`], so collinear corners give exactly 0 and π. By convention
/// the angle at a corner that coincides with another corner is 0 (so a triangle with two
/// equal corners has all angles 0; check [`is_degenerate`] first if that matters).
#[inline]
pub fn corner_angles_of(p: &[Vec3; 3]) -> [f64; 3] {
    [
        angle_between(sub(p[1], p[0]), sub(p[2], p[0])),
        angle_between(sub(p[2], p[1]), sub(p[0], p[1])),
        angle_between(sub(p[0], p[2]), sub(p[1], p[2])),
    ]
}

/// The unnormalised normal of triangle `t` (length = 2 × area). O(1).
#[inline]
pub fn triangle_normal(positions: &[f32], triangles: &[u32], t: u32) -> Vec3 {
    normal_of(&triangle_points(positions, triangles, t))
}

/// The unit normal of triangle `t`, or `None` if it has zero area. O(1).
#[inline]
pub fn triangle_unit_normal(positions: &[f32], triangles: &[u32], t: u32) -> Option<Vec3> {
    normalize(triangle_normal(positions, triangles, t))
}

/// The area of triangle `t`. O(1).
#[inline]
pub fn triangle_area(positions: &[f32], triangles: &[u32], t: u32) -> f64 {
    area_of(&triangle_points(positions, triangles, t))
}

/// The centroid (mean of the corners) of triangle `t`. O(1).
#[inline]
pub fn triangle_centroid(positions: &[f32], triangles: &[u32], t: u32) -> Vec3 {
    let p = triangle_points(positions, triangles, t);
    scale(add(add(p[0], p[1]), p[2]), 1.0 / 3.0)
}

/// The interior angles of triangle `t` at its corners 0, 1, 2 in radians (see
/// [`corner_angles_of`] for degenerate triangles). O(1).
#[inline]
pub fn corner_angles(positions: &[f32], triangles: &[u32], t: u32) -> [f64; 3] {
    corner_angles_of(&triangle_points(positions, triangles, t))
}

/// The interior angles of triangle `t` at its corners 0, 1, 2 in degrees. O(1).
#[inline]
pub fn corner_angles_degrees(positions: &[f32], triangles: &[u32], t: u32) -> [f64; 3] {
    corner_angles(positions, triangles, t).map(f64::to_degrees)
}

/// Whether triangle `t` is degenerate: a repeated vertex id, or exactly zero area (the `f64`
/// cross product of its edge vectors is zero, i.e. its corners are collinear or coincide up to
/// `f64` rounding of exactly converted `f32` inputs). O(1).
#[inline]
pub fn is_degenerate(positions: &[f32], triangles: &[u32], t: u32) -> bool {
    is_degenerate_within(positions, triangles, t, 0.0)
}

/// Whether triangle `t` is degenerate up to a relative tolerance: a repeated vertex id, or
/// flat by [`is_flat_within`]. With `eps = 0` this is [`is_degenerate`]. O(1).
#[inline]
pub fn is_degenerate_within(positions: &[f32], triangles: &[u32], t: u32, eps: f64) -> bool {
    let i = 3 * t as usize;
    let c = &triangles[i..i + 3];
    c[0] == c[1] || c[1] == c[2] || c[0] == c[2] || {
        is_flat_within(&triangle_points(positions, triangles, t), eps)
    }
}

/// Whether a triangle given by its corners is flat: with `eps = 0`, exactly zero area;
/// else `2 × area <= eps × (longest edge)²`, i.e. its height onto the longest edge is at most
/// `eps` times that edge (a scale-free shape measure: about 0.87 for an equilateral
/// triangle, 0 for a collinear one). `eps` around `1e-6` catches needles and caps that are
/// numerically collinear. O(1).
#[inline]
pub fn is_flat_within(p: &[Vec3; 3], eps: f64) -> bool {
    let normal = normal_of(p);
    if eps == 0.0 {
        // No edge lengths needed: a third of the time on a large scan.
        return normal == [0.0; 3];
    }
    let longest = [sub(p[1], p[0]), sub(p[2], p[1]), sub(p[0], p[2])]
        .map(|e| dot(e, e))
        .into_iter()
        .fold(0.0, f64::max);
    norm(normal) <= eps * longest
}

/// The length of the edge of half-edge `h`. O(1).
#[inline]
pub fn edge_length(positions: &[f32], triangles: &[u32], h: u32) -> f64 {
    distance(point(positions, triangles[h as usize]), point(positions, triangles[next(h) as usize]))
}

/// The cotangent of the angle opposite half-edge `h` in its own triangle (at the corner
/// `h` does not touch); 0 if the triangle has zero area. O(1).
#[inline]
pub fn half_edge_cotangent(positions: &[f32], triangles: &[u32], h: u32) -> f64 {
    let a = point(positions, triangles[h as usize]);
    let b = point(positions, triangles[next(h) as usize]);
    let c = point(positions, triangles[prev(h) as usize]);
    cotangent(sub(a, c), sub(b, c))
}

/// The cotangent Laplacian weight of the edge of `h`: `(cot α + cot β) / 2`, with `α` the
/// angle opposite `h` in its triangle and `β` the angle opposite its twin in the twin's
/// triangle (either orientation). Boundary and non-manifold half-edges have no twin: only
/// `cot α / 2`. Zero-area triangles contribute 0. The weight is negative across obtuse
/// angle pairs summing over π; clamp in the caller if the algorithm needs positive weights.
/// O(1).
pub fn cotangent_weight(
    positions: &[f32],
    triangles: &[u32],
    half_edges: &HalfEdges,
    h: u32,
) -> f64 {
    let mut w = half_edge_cotangent(positions, triangles, h);
    let twin = half_edges.opposite(h);
    if twin != u32::MAX {
        w += half_edge_cotangent(positions, triangles, twin);
    }
    0.5 * w
}

/// Cotangent Laplacian weights aligned with a neighbour CSR: entry `i` of the result belongs
/// to `neighbours.neighbours()[i]`, so row `v` of weights pairs with `neighbours.of(v)`. The
/// weight of edge `{a, b}` is `Σ cot(angle opposite {a, b}) / 2` over every proper triangle on
/// the edge (two on an interior edge, one on a boundary edge, all of them on a non-manifold
/// edge); it is symmetric. Cotangents are computed in `f64` and summed into `f32` (at most
/// a few terms per entry); zero-area triangles contribute 0, weights may be negative (clamp in
/// the caller if needed). Triangles with repeated or out-of-range ids are skipped.
///
/// `neighbours` must have been built from the same `triangles`. O(T log d) (binary search of
/// the slot in each row), memory 4 bytes per CSR entry.
pub fn cotangent_weights(
    positions: &[f32],
    triangles: &[u32],
    neighbours: &VertexNeighbours,
) -> Vec<f32> {
    let vertex_count = neighbours.vertex_count().min(positions.len() / 3);
    let mut weights = vec![0f32; neighbours.neighbours().len()];
    let offsets = neighbours.offsets();
    let mut add_to = |a: u32, b: u32, w: f64| {
        if let Ok(i) = neighbours.of(a).binary_search(&b) {
            weights[offsets[a as usize] as usize + i] += w as f32;
        }
    };
    for c in triangles.chunks_exact(3) {
        if !crate::proper([c[0], c[1], c[2]], vertex_count) {
            continue;
        }
        let p = [point(positions, c[0]), point(positions, c[1]), point(positions, c[2])];
        for k in 0..3 {
            let (a, b, o) = (k, (k + 1) % 3, (k + 2) % 3);
            let w = 0.5 * cotangent(sub(p[a], p[o]), sub(p[b], p[o]));
            add_to(c[a], c[b], w);
            add_to(c[b], c[a], w);
        }
    }
    weights
}

/// The angle in `[0, π]` between the normals of triangles `t0` and `t1` as they are stored
/// (no orientation correction); 0 if either has zero area. O(1).
#[inline]
pub fn normal_angle(positions: &[f32], triangles: &[u32], t0: u32, t1: u32) -> f64 {
    let n0 = triangle_normal(positions, triangles, t0);
    let n1 = triangle_normal(positions, triangles, t1);
    if n0 == [0.0; 3] || n1 == [0.0; 3] {
        return 0.0;
    }
    angle_between(n0, n1)
}

/// The dihedral angle across the edge of half-edge `h`, measured as the angle in `[0, π]`
/// between the two triangles' normals: 0 where the surface is flat, near π where it folds
/// back onto itself. If the two triangles are inconsistently oriented the twin's normal is
/// reversed first, so the angle measures the surface's bend, not the orientation defect.
/// `None` if `h` has no twin (boundary, non-manifold, degenerate) or a triangle has zero
/// area. O(1).
pub fn dihedral_angle(
    positions: &[f32],
    triangles: &[u32],
    half_edges: &HalfEdges,
    h: u32,
) -> Option<f64> {
    let twin = half_edges.opposite(h);
    if twin == u32::MAX {
        return None;
    }
    let n0 = triangle_normal(positions, triangles, h / 3);
    let mut n1 = triangle_normal(positions, triangles, twin / 3);
    if n0 == [0.0; 3] || n1 == [0.0; 3] {
        return None;
    }
    if !half_edges.is_consistent(h) {
        n1 = scale(n1, -1.0);
    }
    Some(angle_between(n0, n1))
}

/// Area-weighted vertex normals: each vertex gets the unit vector of the sum of the
/// unnormalised normals (length 2 × area) of the triangles around it, summed in `f64`.
/// Vertices without area (unreferenced, only degenerate triangles, or cancelling normals)
/// get `[0, 0, 0]`. Triangles with out-of-range ids are skipped. O(V + T), `24 V` bytes of
/// scratch. The result has the layout of `positions` (`as_flattened()` gives `&[f32]`).
pub fn vertex_normals(positions: &[f32], triangles: &[u32]) -> Vec<[f32; 3]> {
    let vertex_count = positions.len() / 3;
    let mut sum = vec![[0.0f64; 3]; vertex_count];
    for c in triangles.chunks_exact(3) {
        if c.iter().any(|&v| v as usize >= vertex_count) {
            continue;
        }
        let n =
            normal_of(&[point(positions, c[0]), point(positions, c[1]), point(positions, c[2])]);
        for &v in c {
            let s = &mut sum[v as usize];
            *s = add(*s, n);
        }
    }
    sum.into_iter().map(|s| normalize(s).map_or([0.0; 3], |u| u.map(|x| x as f32))).collect()
}

/// The sum of all triangle areas (triangles with out-of-range ids skipped). O(T).
pub fn total_area(positions: &[f32], triangles: &[u32]) -> f64 {
    let vertex_count = positions.len() / 3;
    triangles
        .chunks_exact(3)
        .filter(|c| c.iter().all(|&v| (v as usize) < vertex_count))
        .map(|c| area_of(&[point(positions, c[0]), point(positions, c[1]), point(positions, c[2])]))
        .sum()
}

/// An axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundingBox {
    /// Smallest x, y, z.
    pub min: [f32; 3],
    /// Largest x, y, z.
    pub max: [f32; 3],
}

impl BoundingBox {
    /// The extent along x, y, z (in `f64`).
    #[inline]
    pub fn size(&self) -> Vec3 {
        [0, 1, 2].map(|i| self.max[i] as f64 - self.min[i] as f64)
    }

    /// The length of the diagonal (e.g. the scale for `add-noise`'s `amount`).
    #[inline]
    pub fn diagonal(&self) -> f64 {
        norm(self.size())
    }

    /// The centre point.
    #[inline]
    pub fn center(&self) -> Vec3 {
        [0, 1, 2].map(|i| 0.5 * (self.min[i] as f64 + self.max[i] as f64))
    }
}

/// The bounding box of all vertices, referenced or not (as MeshLab reports it); `None` for
/// no vertices. NaN coordinates are ignored (`None` if an axis has only NaNs). O(V).
pub fn bounding_box(positions: &[f32]) -> Option<BoundingBox> {
    let mut min = [f32::INFINITY; 3];
    let mut max = [f32::NEG_INFINITY; 3];
    for p in positions.chunks_exact(3) {
        for i in 0..3 {
            // Compares, not `f32::min`, which is a software call in wasm; NaNs are skipped.
            if p[i] < min[i] {
                min[i] = p[i];
            }
            if p[i] > max[i] {
                max[i] = p[i];
            }
        }
    }
    (0..3).all(|i| min[i] <= max[i]).then_some(BoundingBox { min, max })
}

/// The mean of all vertex positions (summed in `f64`), or `None` for no vertices. O(V).
pub fn centroid(positions: &[f32]) -> Option<Vec3> {
    let n = positions.len() / 3;
    if n == 0 {
        return None;
    }
    let mut s = [0.0f64; 3];
    for p in positions.chunks_exact(3) {
        s = add(s, [p[0] as f64, p[1] as f64, p[2] as f64]);
    }
    Some(scale(s, 1.0 / n as f64))
}

/// The area-weighted centroid of the surface (the centre of mass of a thin shell), or `None`
/// if the total area is zero. Triangles with out-of-range ids are skipped. O(T).
pub fn surface_centroid(positions: &[f32], triangles: &[u32]) -> Option<Vec3> {
    let vertex_count = positions.len() / 3;
    let mut s = [0.0f64; 3];
    let mut total = 0.0;
    for c in triangles.chunks_exact(3) {
        if c.iter().any(|&v| v as usize >= vertex_count) {
            continue;
        }
        let p = [point(positions, c[0]), point(positions, c[1]), point(positions, c[2])];
        let a = area_of(&p);
        s = add(s, scale(add(add(p[0], p[1]), p[2]), a / 3.0));
        total += a;
    }
    (total > 0.0).then(|| scale(s, 1.0 / total))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

    const EPS: f64 = 1e-12;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < EPS
    }

    // Right isosceles triangle in the xy plane plus a second one folded up by 90° on edge 1-2.
    const POS: [f32; 15] = [0., 0., 0., 1., 0., 0., 0., 1., 0., 1., 1., 0., 0.5, 0.5, 1.];

    #[test]
    fn triangle_basics() {
        let t = [0, 1, 2];
        assert_eq!(triangle_normal(&POS, &t, 0), [0., 0., 1.]);
        assert_eq!(triangle_unit_normal(&POS, &t, 0), Some([0., 0., 1.]));
        assert!(close(triangle_area(&POS, &t, 0), 0.5));
        let a = corner_angles(&POS, &t, 0);
        assert!(close(a[0], FRAC_PI_2) && close(a[1], FRAC_PI_4) && close(a[2], FRAC_PI_4));
        let d = corner_angles_degrees(&POS, &t, 0);
        assert!((d[0] - 90.0).abs() < 1e-9 && (d.iter().sum::<f64>() - 180.0).abs() < 1e-9);
        let c = triangle_centroid(&POS, &t, 0);
        assert!(close(c[0], 1. / 3.) && close(c[1], 1. / 3.) && c[2] == 0.);
        assert!(close(edge_length(&POS, &t, 1), 2f64.sqrt()));
        assert!(!is_degenerate(&POS, &t, 0));
    }

    #[test]
    fn degenerate() {
        let pos = [0., 0., 0., 1., 1., 1., 2., 2., 2., 1., 1.0001, 1.];
        // collinear, repeated index, thin but fine
        let t = [0, 1, 2, 0, 0, 1, 0, 2, 3];
        assert!(is_degenerate(&pos, &t, 0));
        assert!(is_degenerate(&pos, &t, 1));
        assert!(!is_degenerate(&pos, &t, 2));
        assert!(is_degenerate_within(&pos, &t, 2, 1e-3));
        assert!(!is_degenerate_within(&pos, &t, 2, 1e-6));
        assert_eq!(triangle_unit_normal(&pos, &t, 0), None);
        assert_eq!(corner_angles(&pos, &t, 0), [0., PI, 0.]);
        assert_eq!(corner_angles(&pos, &t, 1), [0., 0., 0.]);
        assert_eq!(half_edge_cotangent(&pos, &t, 0), 0.0);
    }

    #[test]
    fn cotangents_and_dihedral() {
        // Two triangles in a unit square, sharing the diagonal 1-2.
        let t = [0, 1, 2, 2, 1, 3];
        let he = HalfEdges::new(5, &t);
        // Opposite the diagonal: right angles, cot = 0.
        assert!(close(cotangent_weight(&POS, &t, &he, 1), 0.0));
        // Half-edge 0 (0->1), opposite corner 2 at 45°: cot = 1, boundary: weight 1/2.
        assert!(close(cotangent_weight(&POS, &t, &he, 0), 0.5));
        assert_eq!(dihedral_angle(&POS, &t, &he, 1), Some(0.0));
        assert_eq!(dihedral_angle(&POS, &t, &he, 0), None);
        // Same pair with the second triangle flipped: bend still 0, raw normals opposite.
        let f = [0, 1, 2, 1, 2, 3];
        let hf = HalfEdges::new(5, &f);
        assert_eq!(dihedral_angle(&POS, &f, &hf, 1), Some(0.0));
        assert!(close(normal_angle(&POS, &f, 0, 1), PI));
        // Folded: triangle (2, 1, 4) rises to z = 1 above the diagonal's midpoint.
        let g = [0, 1, 2, 2, 1, 4];
        let hg = HalfEdges::new(5, &g);
        let d = dihedral_angle(&POS, &g, &hg, 1).unwrap();
        assert!((d - FRAC_PI_2).abs() < 1e-12, "{d}");
    }

    #[test]
    fn whole_mesh() {
        let t = [0, 1, 2, 2, 1, 3, 0, 0, 1, 0, 1, 99];
        let n = vertex_normals(&POS, &t);
        assert_eq!(n.len(), 5);
        assert_eq!(n[0], [0., 0., 1.]);
        assert_eq!(n[4], [0., 0., 0.]);
        assert!(close(total_area(&POS, &t), 1.0));
        let b = bounding_box(&POS).unwrap();
        assert_eq!((b.min, b.max), ([0., 0., 0.], [1., 1., 1.]));
        assert!(close(b.diagonal(), 3f64.sqrt()));
        assert_eq!(b.center(), [0.5; 3]);
        assert_eq!(bounding_box(&[]), None);
        assert_eq!(bounding_box(&[f32::NAN, 1., 2.]), None);
        let c = centroid(&POS).unwrap();
        assert!(close(c[0], 0.5) && close(c[2], 0.2));
        let s = surface_centroid(&POS, &t).unwrap();
        assert!(close(s[0], 0.5) && close(s[1], 0.5) && s[2] == 0.);
        assert_eq!(surface_centroid(&POS, &[0, 0, 1]), None);
    }

    #[test]
    fn vector_helpers() {
        assert_eq!(normalize([0.0; 3]), None);
        assert_eq!(normalize([0., 0., 4.]), Some([0., 0., 1.]));
        assert_eq!(angle_between([1., 0., 0.], [0., 0., 0.]), 0.0);
        assert!(close(angle_between([1., 0., 0.], [-1., 1e-20, 0.]), PI));
        assert!(close(cotangent([1., 0., 0.], [1., 1., 0.]), 1.0));
    }

    #[test]
    fn closest_points_on_a_triangle_by_region() {
        let t = [[0., 0., 0.], [2., 0., 0.], [0., 2., 0.]];
        let cases = [
            ([0.5, 0.5, 3.0], [0.5, 0.5, 0.0]),   // above the inside
            ([-1.0, -1.0, 0.0], [0.0, 0.0, 0.0]), // beyond corner a
            ([3.0, -1.0, 1.0], [2.0, 0.0, 0.0]),  // beyond corner b
            ([-1.0, 3.0, 0.0], [0.0, 2.0, 0.0]),  // beyond corner c
            ([1.0, -2.0, 0.0], [1.0, 0.0, 0.0]),  // beyond edge ab
            ([-2.0, 1.0, 5.0], [0.0, 1.0, 0.0]),  // beyond edge ca
            ([2.0, 2.0, 0.0], [1.0, 1.0, 0.0]),   // beyond edge bc
        ];
        for (p, expected) in cases {
            let q = closest_point_on_triangle(p, t);
            assert!(distance(q, expected) < EPS, "{p:?}: {q:?}");
        }
        // A flat triangle answers with the closest point of its sides, even with a corner
        // repeated (which made the region tests divide zero by zero) or all three at one spot.
        let flat = [[0., 0., 0.], [1., 0., 0.], [2., 0., 0.]];
        assert_eq!(closest_point_on_triangle([1.0, 1.0, 0.0], flat), [1.0, 0.0, 0.0]);
        assert_eq!(closest_point_on_triangle([3.0, 1.0, 0.0], flat), [2.0, 0.0, 0.0]);
        let repeated = [[0., 0., 0.], [0., 0., 0.], [2., 0., 0.]];
        for corners in [repeated, [repeated[2], repeated[0], repeated[1]]] {
            assert_eq!(closest_point_on_triangle([1.5, 1.0, 0.0], corners), [1.5, 0.0, 0.0]);
        }
        assert_eq!(closest_point_on_triangle([1.0, 1.0, 1.0], [[0.5; 3]; 3]), [0.5; 3]);
    }
}
