//! Vertex positions predicted from already decoded neighbours (in the order of
//! [`CodingOrder`](super::order::CodingOrder)).
//!
//! A vertex whose triangle `(v, a, b)` has an edge `a b` shared with a triangle `(b, a, c)`
//! of known vertices is predicted by the parallelogram rule `a + b - c` (the average of all
//! such rules), which on a smooth surface sampled evenly misses by about the local
//! curvature; otherwise by the mean of its known neighbours, otherwise by the vertex coded
//! before it.

use meshflow_topology::VertexTriangles;

/// The prediction for vertex `v`, reading only positions of `decoded` vertices; `previous`
/// is the vertex coded last.
pub(super) fn predict(
    v: u32,
    previous: Option<u32>,
    positions: &[f32],
    decoded: &[bool],
    triangles: &[u32],
    around: &VertexTriangles,
) -> [f32; 3] {
    let known = |u: u32| decoded[u as usize];
    let corners = |t: u32| {
        let i = 3 * t as usize;
        [triangles[i], triangles[i + 1], triangles[i + 2]]
    };
    let at = |u: u32| {
        let i = 3 * u as usize;
        [positions[i], positions[i + 1], positions[i + 2]].map(f64::from)
    };
    let (mut rules, mut rule_count) = ([0.0f64; 3], 0u32);
    let (mut near, mut near_count) = ([0.0f64; 3], 0u32);
    for &t in around.of(v) {
        let c = corners(t);
        let Some(k) = c.iter().position(|&x| x == v) else { continue };
        let (a, b) = (c[(k + 1) % 3], c[(k + 2) % 3]);
        for n in [a, b] {
            if known(n) {
                let p = at(n);
                (0..3).for_each(|i| near[i] += p[i]);
                near_count += 1;
            }
        }
        if !known(a) || !known(b) || a == b {
            continue;
        }
        // The triangle across edge a-b, with its third corner known.
        let opposite = around.of(a).iter().filter(|&&u| u != t).find_map(|&u| {
            let d = corners(u);
            let third = d.iter().copied().find(|&x| x != a && x != b)?;
            (d.contains(&b) && known(third)).then_some(third)
        });
        if let Some(o) = opposite {
            let (pa, pb, po) = (at(a), at(b), at(o));
            (0..3).for_each(|i| rules[i] += pa[i] + pb[i] - po[i]);
            rule_count += 1;
        }
    }
    if rule_count > 0 {
        rules.map(|s| (s / f64::from(rule_count)) as f32)
    } else if near_count > 0 {
        near.map(|s| (s / f64::from(near_count)) as f32)
    } else {
        previous.map_or([0.0; 3], |u| at(u).map(|x| x as f32))
    }
}
