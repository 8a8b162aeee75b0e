//! Property tests: every helper against a naive reference on random small meshes, including
//! non-manifold, degenerate, duplicated and out-of-range triangles.

use std::collections::{BTreeMap, BTreeSet};

use meshflow_topology::geometry;
use meshflow_topology::halfedge::{next, origin, target};
use meshflow_topology::{
    Connectivity, EdgeBuckets, EdgeKind, EdgeLookup, HalfEdges, Members, NONE, TriangleComponents,
    VertexNeighbours, VertexTriangles, boundary_loops, is_edge_manifold, is_orientable,
    is_oriented, non_manifold_vertices, orientation_flips,
};
use proptest::prelude::*;

/// Random "soup": up to 8 vertices, up to 24 triangles, ids in `0..=vertex_count` (so the
/// last id is out of range).
fn soup() -> impl Strategy<Value = (usize, Vec<u32>)> {
    (1usize..8).prop_flat_map(|v| {
        (
            Just(v),
            prop::collection::vec(0..=v as u32, 0..=24).prop_map(|mut t| {
                t.truncate(t.len() / 3 * 3);
                t
            }),
        )
    })
}

/// Random subsets of a 4 × 4 grid (32 triangles), some triangles flipped, vertices
/// relabelled: boundary loops, pinched vertices and orientation seams, no non-manifold edge.
fn grid_subset() -> impl Strategy<Value = (usize, Vec<u32>)> {
    (
        prop::collection::vec(any::<bool>(), 32),
        prop::collection::vec(prop::bool::weighted(0.15), 32),
        Just((0..25u32).collect::<Vec<_>>()).prop_shuffle(),
    )
        .prop_map(|(keep, flip, perm)| {
            let mut t = Vec::new();
            for y in 0..4 {
                for x in 0..4 {
                    let v = x + 5 * y;
                    let w = v + 5;
                    for (i, tri) in [[v, v + 1, w + 1], [v, w + 1, w]].into_iter().enumerate() {
                        let k = (2 * (x + 4 * y) + i as u32) as usize;
                        if keep[k] {
                            let tri = tri.map(|v| perm[v as usize]);
                            t.extend(if flip[k] { [tri[0], tri[2], tri[1]] } else { tri });
                        }
                    }
                }
            }
            (25, t)
        })
}

/// Random subsets of a twisted or plain band of 3–7 quads, some triangles flipped, vertices
/// relabelled: non-orientable meshes (whole Möbius strips) among orientable ones.
fn band_subset() -> impl Strategy<Value = (usize, Vec<u32>)> {
    (3u32..8, any::<bool>()).prop_flat_map(|(n, twisted)| {
        let tris = 2 * n as usize;
        (
            prop::collection::vec(prop::bool::weighted(0.9), tris),
            prop::collection::vec(prop::bool::weighted(0.3), tris),
            Just((0..2 * n).collect::<Vec<_>>()).prop_shuffle(),
        )
            .prop_map(move |(keep, flip, perm)| {
                let mut t = Vec::new();
                for i in 0..n {
                    let (p0, q0) = (i, n + i);
                    let (p1, q1) = match (i + 1 < n, twisted) {
                        (true, _) => (i + 1, n + i + 1),
                        (false, true) => (n, 0),
                        (false, false) => (0, n),
                    };
                    for (j, tri) in [[q0, q1, p1], [q0, p1, p0]].into_iter().enumerate() {
                        let k = 2 * i as usize + j;
                        if keep[k] {
                            let tri = tri.map(|v| perm[v as usize]);
                            t.extend(if flip[k] { [tri[0], tri[2], tri[1]] } else { tri });
                        }
                    }
                }
                (2 * n as usize, t)
            })
    })
}

fn any_mesh() -> impl Strategy<Value = (usize, Vec<u32>)> {
    prop_oneof![soup(), grid_subset(), band_subset()]
}

fn tri(t: &[u32], i: usize) -> [u32; 3] {
    [t[3 * i], t[3 * i + 1], t[3 * i + 2]]
}

fn proper(c: [u32; 3], v: usize) -> bool {
    c[0] != c[1] && c[1] != c[2] && c[0] != c[2] && c.iter().all(|&x| (x as usize) < v)
}

/// Half-edges of proper triangles grouped by undirected edge.
fn naive_edges(v: usize, t: &[u32]) -> BTreeMap<(u32, u32), Vec<u32>> {
    let mut m: BTreeMap<(u32, u32), Vec<u32>> = BTreeMap::new();
    for i in 0..t.len() / 3 {
        if proper(tri(t, i), v) {
            for h in 3 * i as u32..3 * i as u32 + 3 {
                let (a, b) = (origin(t, h), target(t, h));
                m.entry((a.min(b), a.max(b))).or_default().push(h);
            }
        }
    }
    m
}

/// Component labels by flood fill over a "connected" relation, numbered by first triangle.
fn naive_labels(n: usize, connected: impl Fn(usize, usize) -> bool) -> Vec<u32> {
    let mut label = vec![u32::MAX; n];
    let mut next_label = 0;
    for s in 0..n {
        if label[s] != u32::MAX {
            continue;
        }
        label[s] = next_label;
        let mut stack = vec![s];
        while let Some(a) = stack.pop() {
            for (b, l) in label.iter_mut().enumerate() {
                if *l == u32::MAX && connected(a, b) {
                    *l = next_label;
                    stack.push(b);
                }
            }
        }
        next_label += 1;
    }
    label
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(600))]

    #[test]
    fn vertex_triangles_match_naive((v, t) in any_mesh()) {
        let vt = VertexTriangles::new(v, &t);
        prop_assert_eq!(vt.offsets().len(), v + 1);
        for x in 0..v as u32 {
            let naive: Vec<u32> = (0..t.len() / 3).filter(|&i| tri(&t, i).contains(&x)).map(|i| i as u32).collect();
            prop_assert_eq!(vt.of(x), &naive[..]);
        }
    }

    #[test]
    fn vertex_neighbours_match_naive((v, t) in any_mesh()) {
        let vn = VertexNeighbours::new(v, &t);
        for x in 0..v as u32 {
            let mut naive = BTreeSet::new();
            for i in 0..t.len() / 3 {
                let c = tri(&t, i);
                if c.contains(&x) {
                    naive.extend(c.iter().copied().filter(|&w| w != x && (w as usize) < v));
                }
            }
            prop_assert_eq!(vn.of(x), &naive.into_iter().collect::<Vec<_>>()[..]);
        }
    }

    #[test]
    fn half_edges_match_naive((v, t) in any_mesh()) {
        let he = HalfEdges::new(v, &t);
        let edges = naive_edges(v, &t);
        prop_assert_eq!(he.len(), t.len());
        prop_assert_eq!(he.edge_count(), edges.len());
        let mut seen = vec![false; t.len()];
        let mut non_manifold = Vec::new();
        for group in edges.values() {
            for &h in group {
                seen[h as usize] = true;
                let (kind, twin) = match group[..] {
                    [_] => (EdgeKind::Boundary, NONE),
                    [a, b] => {
                        let o = if a == h { b } else { a };
                        let same_way = origin(&t, h) == origin(&t, o);
                        (if same_way { EdgeKind::InteriorInconsistent } else { EdgeKind::Interior }, o)
                    }
                    _ => (EdgeKind::NonManifold, NONE),
                };
                prop_assert_eq!(he.kind(h), kind);
                prop_assert_eq!(he.opposite(h), twin);
            }
            if group.len() > 2 {
                non_manifold.push(group.clone());
            }
        }
        for h in 0..t.len() as u32 {
            if !seen[h as usize] {
                prop_assert_eq!(he.kind(h), EdgeKind::Degenerate);
                prop_assert_eq!(he.opposite(h), NONE);
            }
            let o = he.opposite(h);
            if o != NONE {
                prop_assert_eq!(he.opposite(o), h);
            }
        }
        prop_assert_eq!(he.non_manifold_edges().rows().map(|r| r.to_vec()).collect::<Vec<_>>(), non_manifold);
        let count = |k: EdgeKind| he.kinds().iter().filter(|&&x| x == k).count();
        prop_assert_eq!(he.boundary_edge_count(), count(EdgeKind::Boundary));
        prop_assert_eq!(he.inconsistent_edge_count() * 2, count(EdgeKind::InteriorInconsistent));
        prop_assert_eq!(he.interior_edge_count() * 2, count(EdgeKind::Interior) + count(EdgeKind::InteriorInconsistent));
    }

    #[test]
    fn every_boundary_half_edge_in_exactly_one_loop((v, t) in any_mesh()) {
        let he = HalfEdges::new(v, &t);
        let loops = boundary_loops(&t, &he);
        let mut all: Vec<u32> = loops.iter().flat_map(|l| l.half_edges.iter().copied()).collect();
        all.sort_unstable();
        prop_assert_eq!(all, he.boundary_half_edges().collect::<Vec<_>>());
        let mut firsts = Vec::new();
        for l in &loops {
            prop_assert!(!l.is_empty());
            prop_assert_eq!(l.vertices.len(), l.len());
            prop_assert_eq!(l.half_edges.iter().min(), l.half_edges.first());
            prop_assert_eq!(l.vertices[0], origin(&t, l.half_edges[0]));
            firsts.push(l.half_edges[0]);
            let mut forward = true;
            for (i, &h) in l.half_edges.iter().enumerate() {
                let (a, b) = (origin(&t, h), target(&t, h));
                let start = l.vertices[i];
                prop_assert!(start == a || start == b);
                forward &= start == a;
                let end = if start == a { b } else { a };
                if i + 1 < l.len() {
                    prop_assert_eq!(end, l.vertices[i + 1]);
                } else if l.closed {
                    prop_assert_eq!(end, l.vertices[0]);
                }
            }
            prop_assert_eq!(forward, l.consistent);
            if is_edge_manifold(&he) {
                prop_assert!(l.closed);
                if is_oriented(&he) {
                    prop_assert!(l.consistent);
                }
            }
        }
        prop_assert!(firsts.windows(2).all(|w| w[0] < w[1]));
        // Deterministic.
        prop_assert_eq!(boundary_loops(&t, &he), loops);
    }

    #[test]
    fn edge_bucket_lookups_match_half_edges((v, t) in any_mesh()) {
        let (he, buckets) = (HalfEdges::new(v, &t), EdgeBuckets::new(v, &t));
        for h in 0..he.len() as u32 {
            prop_assert_eq!(EdgeLookup::kind(&buckets, h), he.kind(h), "kind of {}", h);
            prop_assert_eq!(EdgeLookup::opposite(&buckets, h), he.opposite(h), "twin of {}", h);
        }
        prop_assert_eq!(boundary_loops(&t, &buckets), boundary_loops(&t, &he));
    }

    #[test]
    fn connectivity_derived_on_threads_is_the_same((v, t) in any_mesh(), parts in 2usize..6) {
        let (one, several) = (Connectivity::new(v, &t), Connectivity::in_parts(v, &t, parts));
        prop_assert_eq!(several.opposites(), one.opposites());
        prop_assert_eq!(several.kind_codes(), one.kind_codes());
        prop_assert_eq!(several.edges(), one.edges());
        let (a, b) = (several.half_edges(), one.half_edges());
        prop_assert_eq!(a.non_manifold_edges(), b.non_manifold_edges());
        prop_assert_eq!(
            [a.edge_count(), a.boundary_edge_count(), a.interior_edge_count()],
            [b.edge_count(), b.boundary_edge_count(), b.interior_edge_count()]
        );
        prop_assert_eq!(a.inconsistent_edge_count(), b.inconsistent_edge_count());
        for members in [Members::ProperTriangles, Members::AnyEdge] {
            let (one, several) =
                (EdgeBuckets::of(v, &t, members), EdgeBuckets::of_in_parts(v, &t, members, parts));
            let mut groups = (Vec::new(), Vec::new());
            one.for_each_edge(|a, sides| groups.0.push((a, sides.to_vec())));
            several.for_each_edge(|a, sides| groups.1.push((a, sides.to_vec())));
            prop_assert_eq!(groups.0, groups.1);
        }
    }

    #[test]
    fn components_match_naive((v, t) in any_mesh()) {
        let n = t.len() / 3;
        let edge_set = |i: usize| {
            let c = tri(&t, i);
            (0..3)
                .map(|k| (c[k], c[(k + 1) % 3]))
                .filter(|&(a, b)| a != b && (a as usize) < v && (b as usize) < v)
                .map(|(a, b)| (a.min(b), a.max(b)))
                .collect::<BTreeSet<_>>()
        };
        let sets: Vec<_> = (0..n).map(edge_set).collect();
        let naive = naive_labels(n, |a, b| !sets[a].is_disjoint(&sets[b]));
        let c = TriangleComponents::new(v, &t);
        prop_assert_eq!(c.labels(), &naive[..]);
        prop_assert_eq!(c.sizes().iter().sum::<u32>() as usize, n);
        if let Some(l) = c.largest() {
            prop_assert_eq!(c.sizes()[l as usize], *c.sizes().iter().max().unwrap());
            prop_assert_eq!(c.triangles_of(l).len(), c.sizes()[l as usize] as usize);
        }
        let corners = |i: usize| tri(&t, i).into_iter().filter(|&x| (x as usize) < v).collect::<BTreeSet<_>>();
        let naive_v = naive_labels(n, |a, b| !corners(a).is_disjoint(&corners(b)));
        let vc = TriangleComponents::vertex_connected(v, &t);
        prop_assert_eq!(vc.labels(), &naive_v[..]);
    }

    #[test]
    fn non_manifold_vertices_match_naive((v, t) in any_mesh()) {
        let he = HalfEdges::new(v, &t);
        let edges = naive_edges(v, &t);
        let mut naive = Vec::new();
        for x in 0..v as u32 {
            let around: Vec<usize> = (0..t.len() / 3).filter(|&i| proper(tri(&t, i), v) && tri(&t, i).contains(&x)).collect();
            // Triangles around x linked by an interior edge containing x.
            let linked = |a: usize, b: usize| {
                edges.iter().any(|(&(p, q), g)| {
                    (p == x || q == x) && g.len() == 2 && {
                        let (ta, tb) = (g[0] as usize / 3, g[1] as usize / 3);
                        (ta, tb) == (around[a], around[b]) || (tb, ta) == (around[a], around[b])
                    }
                })
            };
            let labels = naive_labels(around.len(), linked);
            if labels.iter().any(|&l| l > 0) {
                naive.push(x);
            }
        }
        prop_assert_eq!(non_manifold_vertices(v, &t, &he), naive);
    }

    #[test]
    fn orientability_matches_brute_force((v, t) in any_mesh()) {
        let he = HalfEdges::new(v, &t);
        let n = t.len() / 3;
        let flips = orientation_flips(&he);
        prop_assert_eq!(flips.is_some(), is_orientable(&he));
        let apply = |f: &dyn Fn(usize) -> bool| {
            let mut out = t.clone();
            for i in 0..n {
                if f(i) {
                    out.swap(3 * i + 1, 3 * i + 2);
                }
            }
            out
        };
        if let Some(f) = &flips {
            // Applying the flips orients the mesh, and keeps the classification.
            let flipped = apply(&|i| f[i]);
            let hf = HalfEdges::new(v, &flipped);
            prop_assert!(is_oriented(&hf));
            prop_assert_eq!(hf.interior_edge_count(), he.interior_edge_count());
            prop_assert_eq!(hf.non_manifold_edge_count(), he.non_manifold_edge_count());
            if is_oriented(&he) {
                prop_assert!(f.iter().all(|&x| !x));
            }
        }
        if n <= 14 {
            let brute = (0u32..1 << n).any(|mask| is_oriented(&HalfEdges::new(v, &apply(&|i| mask >> i & 1 == 1))));
            prop_assert_eq!(brute, flips.is_some());
        }
    }

    #[test]
    fn geometry_is_consistent(
        p in prop::collection::vec(-100.0f32..100.0, 9),
        scale in prop::sample::select(vec![1e-3f32, 1.0, 1e4]),
    ) {
        let p: Vec<f32> = p.iter().map(|x| x * scale).collect();
        let t = [0, 1, 2];
        let n = geometry::triangle_normal(&p, &t, 0);
        let area = geometry::triangle_area(&p, &t, 0);
        prop_assert!((geometry::norm(n) - 2.0 * area).abs() <= 1e-12 * geometry::norm(n).max(1e-300));
        let pts = geometry::triangle_points(&p, &t, 0);
        let longest = (0..3).map(|k| geometry::distance(pts[k], pts[(k + 1) % 3])).fold(0.0, f64::max);
        for k in 0..3 {
            let e = geometry::sub(pts[(k + 1) % 3], pts[k]);
            prop_assert!(geometry::dot(n, e).abs() <= 1e-9 * geometry::norm(n) * longest);
        }
        let a = geometry::corner_angles(&p, &t, 0);
        if !geometry::is_degenerate(&p, &t, 0) {
            prop_assert!((a.iter().sum::<f64>() - std::f64::consts::PI).abs() < 1e-9);
            let u = geometry::triangle_unit_normal(&p, &t, 0).unwrap();
            prop_assert!((geometry::norm(u) - 1.0).abs() < 1e-12);
            // Law of cotangents: the cot weights of the three half-edges sum to (Σ l²) / (4 A).
            let cots: f64 = (0..3).map(|h| geometry::half_edge_cotangent(&p, &t, h)).sum();
            let l2: f64 = (0..3).map(|h| geometry::edge_length(&p, &t, h).powi(2)).sum();
            prop_assert!((cots - l2 / (4.0 * area)).abs() <= 1e-6 * cots.abs().max(1.0));
        }
        let vn = geometry::vertex_normals(&p, &t);
        for x in vn {
            let len = (x[0] as f64).hypot(x[1] as f64).hypot(x[2] as f64);
            prop_assert!(len == 0.0 || (len - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn cotangent_weights_match_half_edges((v, t) in any_mesh(), seed in any::<u64>()) {
        let mut s = seed;
        let p: Vec<f32> = (0..3 * v).map(|_| { s = s.wrapping_mul(6364136223846793005).wrapping_add(1); (s >> 44) as f32 / 1e3 }).collect();
        let vn = VertexNeighbours::new(v, &t);
        let w = geometry::cotangent_weights(&p, &t, &vn);
        prop_assert_eq!(w.len(), vn.neighbours().len());
        let he = HalfEdges::new(v, &t);
        for ((a, b), group) in naive_edges(v, &t) {
            let naive: f64 = group.iter().map(|&h| 0.5 * geometry::half_edge_cotangent(&p, &t, h)).sum();
            for (x, y) in [(a, b), (b, a)] {
                let i = vn.offsets()[x as usize] as usize + vn.of(x).binary_search(&y).unwrap();
                prop_assert!((w[i] as f64 - naive).abs() <= 1e-5 * naive.abs().max(1.0), "{} vs {}", w[i], naive);
            }
            if group.len() <= 2 {
                let per_half_edge = geometry::cotangent_weight(&p, &t, &he, group[0]);
                prop_assert!((per_half_edge - naive).abs() <= 1e-9 * naive.abs().max(1.0));
            }
        }
    }

    #[test]
    fn whole_mesh_geometry_never_panics((v, t) in any_mesh(), seed in any::<u64>()) {
        let mut s = seed;
        let p: Vec<f32> = (0..3 * v).map(|_| { s = s.wrapping_mul(6364136223846793005).wrapping_add(1); (s >> 40) as f32 / 1e5 }).collect();
        let he = HalfEdges::new(v, &t);
        let _ = geometry::vertex_normals(&p, &t);
        let _ = geometry::total_area(&p, &t);
        let _ = geometry::surface_centroid(&p, &t);
        for h in 0..he.len() as u32 {
            if he.kind(h) != EdgeKind::Degenerate {
                let w = geometry::cotangent_weight(&p, &t, &he, h);
                prop_assert!(w.is_finite());
                if let Some(d) = geometry::dihedral_angle(&p, &t, &he, h) {
                    prop_assert!((0.0..=std::f64::consts::PI).contains(&d));
                }
                prop_assert_eq!(origin(&t, next(h)), target(&t, h));
            }
        }
    }
}
