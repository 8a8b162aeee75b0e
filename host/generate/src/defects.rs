//! What makes a clean surface look like a raw scan: punched holes, floating debris,
//! degenerate triangles, non-manifold spots and stray vertices.

use meshflow_topology::adjacency::VertexTriangles;

use super::rng::SplitMix64;

/// Positions (f64, x y z per vertex) and triangles being roughened.
pub(crate) struct Draft {
    pub(crate) positions: Vec<f64>,
    pub(crate) triangles: Vec<u32>,
}

impl Draft {
    fn point(&self, v: u32) -> [f64; 3] {
        let i = 3 * v as usize;
        [self.positions[i], self.positions[i + 1], self.positions[i + 2]]
    }

    fn push_vertex(&mut self, p: [f64; 3]) -> u32 {
        self.positions.extend(p);
        (self.positions.len() / 3 - 1) as u32
    }

    fn vertex_count(&self) -> usize {
        self.positions.len() / 3
    }

    /// Mean length of the first edges: the mesh's sampling density.
    pub(crate) fn mean_edge_length(&self) -> f64 {
        let sample = self.triangles.chunks_exact(3).take(1000);
        let (sum, count) = sample.fold((0.0, 0), |(sum, count), t| {
            (sum + distance(self.point(t[0]), self.point(t[1])), count + 1)
        });
        if count == 0 { 1.0 } else { sum / count as f64 }
    }

    /// Moves every vertex along its direction from the origin by up to `amount`: the depth
    /// noise of a range scanner.
    pub(crate) fn add_depth_noise(&mut self, amount: f64, rng: &mut SplitMix64) {
        for p in self.positions.chunks_exact_mut(3) {
            let len = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt().max(1e-12);
            let shift = amount * rng.range(-1.0, 1.0) / len;
            p.iter_mut().for_each(|c| *c += *c * shift);
        }
    }

    /// Removes `count` discs of triangles of varied radius (mostly small, a few large),
    /// apart from each other so every hole has its own boundary loop.
    pub(crate) fn punch_holes(&mut self, count: usize, edge: f64, rng: &mut SplitMix64) {
        let around = VertexTriangles::new(self.vertex_count(), &self.triangles);
        let mut removed = vec![false; self.triangles.len() / 3];
        let mut holes: Vec<([f64; 3], f64)> = Vec::new();
        let mut visited = vec![false; self.vertex_count()];
        for _ in 0..count * 20 {
            if holes.len() == count || self.vertex_count() == 0 {
                break;
            }
            let u = rng.unit();
            let rings = if u < 0.95 { 1.2 + 7.0 * u * u } else { 10.0 + 15.0 * rng.unit() };
            let radius = rings * edge;
            let seed = rng.below(self.vertex_count()) as u32;
            let centre = self.point(seed);
            let clear = |(c, r): &([f64; 3], f64)| distance(*c, centre) > r + radius + 4.0 * edge;
            if around.of(seed).is_empty() || !holes.iter().all(clear) {
                continue;
            }
            holes.push((centre, radius));
            // Grow from the centre through vertices inside the disc.
            let mut inside = vec![seed];
            visited[seed as usize] = true;
            while let Some(v) = inside.pop() {
                for &t in around.of(v) {
                    removed[t as usize] = true;
                    for &w in &self.triangles[3 * t as usize..3 * t as usize + 3] {
                        if !visited[w as usize] && distance(self.point(w), centre) <= radius {
                            visited[w as usize] = true;
                            inside.push(w);
                        }
                    }
                }
            }
        }
        let mut kept = Vec::with_capacity(self.triangles.len());
        for (t, corners) in self.triangles.chunks_exact(3).enumerate() {
            if !removed[t] {
                kept.extend_from_slice(corners);
            }
        }
        self.triangles = kept;
    }

    /// Adds `count` small flat patches floating near the surface, 2 to 72 triangles each.
    pub(crate) fn add_debris(&mut self, count: usize, edge: f64, rng: &mut SplitMix64) {
        for _ in 0..count {
            let cells = 1 + rng.below(6);
            let centre = rng.direction().map(|c| c * rng.range(1.1, 1.4));
            let (a, b) = orthonormal_pair(rng.direction());
            let first = self.vertex_count() as u32;
            for i in 0..=cells {
                for j in 0..=cells {
                    let (s, t) = (i as f64 * edge, j as f64 * edge);
                    self.push_vertex(std::array::from_fn(|k| centre[k] + s * a[k] + t * b[k]));
                }
            }
            let row = cells as u32 + 1;
            for i in 0..cells as u32 {
                for j in 0..cells as u32 {
                    let v = first + i * row + j;
                    self.triangles.extend([v, v + row, v + row + 1, v, v + row + 1, v + 1]);
                }
            }
        }
    }

    /// Makes `count` triangles degenerate: alternately a needle (a corner moved onto
    /// another) and a cap (a corner moved onto the midpoint of the opposite edge).
    pub(crate) fn add_degenerate_spots(&mut self, count: usize, rng: &mut SplitMix64) {
        let surface_triangles = self.triangles.len() / 3;
        for i in 0..count.min(surface_triangles) {
            let t = rng.below(surface_triangles);
            let [a, b, c] = [0, 1, 2].map(|k| self.triangles[3 * t + k]);
            let (pa, pb) = (self.point(a), self.point(b));
            let target =
                if i % 2 == 0 { pa } else { std::array::from_fn(|k| 0.5 * (pa[k] + pb[k])) };
            self.positions[3 * c as usize..3 * c as usize + 3].copy_from_slice(&target);
        }
    }

    /// Adds `count` non-manifold spots: alternately a fin (a third triangle on an edge) and
    /// a bow-tie (a triangle touching the surface at one vertex only).
    pub(crate) fn add_non_manifold_spots(&mut self, count: usize, edge: f64, rng: &mut SplitMix64) {
        let surface_triangles = self.triangles.len() / 3;
        for i in 0..count.min(surface_triangles) {
            let t = rng.below(surface_triangles);
            let [a, b, _] = [0, 1, 2].map(|k| self.triangles[3 * t + k]);
            let (pa, pb) = (self.point(a), self.point(b));
            let out = |p: [f64; 3], d: f64| {
                let len = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt().max(1e-12);
                p.map(|c| c * (1.0 + d / len))
            };
            if i % 2 == 0 {
                let apex =
                    self.push_vertex(out(std::array::from_fn(|k| 0.5 * (pa[k] + pb[k])), edge));
                self.triangles.extend([a, b, apex]);
            } else {
                let p = self.push_vertex(out(pa, edge));
                let q = self.push_vertex(out(pb, 1.5 * edge));
                self.triangles.extend([a, p, q]);
            }
        }
    }

    /// Drops vertices no triangle uses (those inside holes), keeping order.
    pub(crate) fn drop_unreferenced(&mut self) {
        let mut used = vec![false; self.vertex_count()];
        self.triangles.iter().for_each(|&v| used[v as usize] = true);
        let mut new_id = vec![u32::MAX; used.len()];
        let mut kept = Vec::with_capacity(self.positions.len());
        for (v, &u) in used.iter().enumerate() {
            if u {
                new_id[v] = (kept.len() / 3) as u32;
                kept.extend_from_slice(&self.positions[3 * v..3 * v + 3]);
            }
        }
        self.positions = kept;
        self.triangles.iter_mut().for_each(|v| *v = new_id[*v as usize]);
    }

    /// Adds `count` vertices no triangle uses, as scanners leave behind.
    pub(crate) fn add_stray_vertices(&mut self, count: usize, rng: &mut SplitMix64) {
        for _ in 0..count {
            let p = rng.direction().map(|c| c * rng.range(0.5, 1.5));
            self.push_vertex(p);
        }
    }
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Two unit vectors orthogonal to `n` and to each other.
fn orthonormal_pair(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let helper = if n[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    };
    let a = cross(n, helper);
    let len = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    let a = a.map(|c| c / len);
    (a, cross(n, a))
}
