//! Closest points on a fixed triangle mesh: a uniform grid of triangle bounding boxes,
//! searched in growing shells of cells around the query.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use meshflow_plugin_sdk::geometry::{Vec3, closest_point_on_triangle, norm, point, sub};

/// Cells per axis are capped so a key packs into 63 bits (21 bits per axis).
const MAX_CELLS_PER_AXIS: f64 = ((1u32 << 21) - 1) as f64;
/// A triangle whose bounding box spans more cells than this is stored in every cell of
/// its box only up to this many; beyond it the grid is too fine for the mesh and the
/// triangle is put into its corners' cells (queries then fall back to a wider search).
const MAX_CELLS_PER_TRIANGLE: usize = 64;

/// The reference surface and its grid.
pub struct Surface {
    positions: Vec<f32>,
    triangles: Vec<[u32; 3]>,
    origin: Vec3,
    cell: f64,
    /// The triangles of each cell, one run per cell in `triangles_by_cell`.
    cells: HashMap<u64, (u32, u32), BuildHasherDefault<CellHasher>>,
    triangles_by_cell: Vec<u32>,
    /// Cells per axis.
    extent: [i64; 3],
}

impl Surface {
    /// Indexes the given triangles (all corners in range) with cells of about `cell_size`.
    pub fn new(positions: &[f32], triangles: Vec<[u32; 3]>, cell_size: f64) -> Self {
        Self::from_owned(positions.to_vec(), triangles, cell_size)
    }

    /// [`Surface::new`] keeping `positions` rather than a copy of them.
    pub fn from_owned(positions: Vec<f32>, triangles: Vec<[u32; 3]>, cell_size: f64) -> Self {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for t in &triangles {
            for &v in t {
                let p = point(&positions, v);
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        if triangles.is_empty() {
            lo = [0.0; 3];
            hi = [0.0; 3];
        }
        let span = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        let cell = cell_size.max(span / MAX_CELLS_PER_AXIS).max(f64::MIN_POSITIVE);
        let extent = std::array::from_fn(|k| ((hi[k] - lo[k]) / cell) as i64 + 1);
        let mut surface = Surface {
            positions,
            triangles,
            origin: lo,
            cell,
            cells: HashMap::default(),
            triangles_by_cell: Vec::new(),
            extent,
        };
        let mut entries = Vec::with_capacity(surface.triangles.len() * 2);
        for (t, c) in surface.triangles.iter().enumerate() {
            let cells = c.map(|v| surface.cell_of(point(&surface.positions, v)));
            let min: [i64; 3] = std::array::from_fn(|k| cells.iter().map(|c| c[k]).min().unwrap());
            let max: [i64; 3] = std::array::from_fn(|k| cells.iter().map(|c| c[k]).max().unwrap());
            let count: i64 = (0..3).map(|k| max[k] - min[k] + 1).product();
            if count as usize <= MAX_CELLS_PER_TRIANGLE {
                for x in min[0]..=max[0] {
                    for y in min[1]..=max[1] {
                        for z in min[2]..=max[2] {
                            entries.push((key([x, y, z]), t as u32));
                        }
                    }
                }
            } else {
                entries.extend(cells.iter().map(|&c| (key(c), t as u32)));
            }
        }
        entries.sort_unstable();
        entries.dedup();
        for run in entries.chunk_by(|x, y| x.0 == y.0) {
            let start = surface.triangles_by_cell.len() as u32;
            surface.triangles_by_cell.extend(run.iter().map(|&(_, t)| t));
            surface.cells.insert(run[0].0, (start, surface.triangles_by_cell.len() as u32));
        }
        surface
    }

    fn cell_of(&self, p: Vec3) -> [i64; 3] {
        std::array::from_fn(|k| {
            (((p[k] - self.origin[k]) / self.cell).floor() as i64).clamp(0, self.extent[k] - 1)
        })
    }

    /// The distance from `p` to the box of cell `c` (0 inside).
    fn distance_to_cell(&self, p: Vec3, c: [i64; 3]) -> f64 {
        let gap = std::array::from_fn(|k| {
            let low = self.origin[k] + c[k] as f64 * self.cell;
            (low - p[k]).max(p[k] - (low + self.cell)).max(0.0)
        });
        norm(gap)
    }

    fn cell_triangles(&self, c: [i64; 3]) -> &[u32] {
        match self.cells.get(&key(c)) {
            Some(&(start, end)) => &self.triangles_by_cell[start as usize..end as usize],
            None => &[],
        }
    }

    /// The closest point of the surface to `p`, or `None` for an empty surface or a
    /// non-finite `p`.
    pub fn closest(&self, p: Vec3) -> Option<Vec3> {
        // A NaN distance never ends the search: it would walk every cell of the grid.
        if self.triangles.is_empty() || !p.iter().all(|x| x.is_finite()) {
            return None;
        }
        let centre = self.cell_of(p);
        let mut best: Option<(f64, Vec3)> = None;
        let widest = *self.extent.iter().max().expect("three axes");
        for radius in 0..=widest {
            // Every point in a cell beyond this shell is at least this far away.
            if let Some((d, _)) = best
                && d < (radius - 1).max(0) as f64 * self.cell
            {
                break;
            }
            for_shell(centre, radius, self.extent, |c| {
                // Most shell cells are farther than the best so far: skip their lookup.
                if best.is_some_and(|(d, _)| self.distance_to_cell(p, c) >= d) {
                    return;
                }
                for &t in self.cell_triangles(c) {
                    let corners = self.triangles[t as usize].map(|v| point(&self.positions, v));
                    let q = closest_point_on_triangle(p, corners);
                    let d = norm(sub(p, q));
                    // A triangle with a non-finite corner (NaN distance) is never taken.
                    if d < best.map_or(f64::INFINITY, |(bd, _)| bd) {
                        best = Some((d, q));
                    }
                }
            });
        }
        best.map(|(_, q)| q)
    }
}

/// Cell keys need no protection from chosen collisions: a multiply and a fold mix them
/// enough, where SipHash took a tenth of all remeshing time.
#[derive(Default)]
struct CellHasher(u64);

impl Hasher for CellHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(self.0 ^ b as u64);
        }
    }

    fn write_u64(&mut self, x: u64) {
        let h = (self.0 ^ x).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        self.0 = h ^ (h >> 32);
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

fn key(c: [i64; 3]) -> u64 {
    ((c[0] as u64) << 42) | ((c[1] as u64) << 21) | c[2] as u64
}

/// Calls `f` on every in-range cell at Chebyshev distance exactly `radius` from `centre`.
fn for_shell(centre: [i64; 3], radius: i64, extent: [i64; 3], mut f: impl FnMut([i64; 3])) {
    let range = |k: usize| (centre[k] - radius).max(0)..=(centre[k] + radius).min(extent[k] - 1);
    for x in range(0) {
        for y in range(1) {
            let on_side = (x - centre[0]).abs() == radius || (y - centre[1]).abs() == radius;
            if on_side {
                for z in range(2) {
                    f([x, y, z]);
                }
            } else {
                for z in [centre[2] - radius, centre[2] + radius] {
                    if (0..extent[2]).contains(&z) {
                        f([x, y, z]);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_points_match_a_brute_force_search() {
        // A bumpy grid and points around it, near and far.
        let n = 12u32;
        let positions: Vec<f32> = (0..n * n)
            .flat_map(|i| {
                let (x, y) = ((i % n) as f32, (i / n) as f32);
                [x, y, (x * 0.7).sin() + (y * 0.4).cos()]
            })
            .collect();
        let mut triangles = Vec::new();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let v = y * n + x;
                triangles.extend([[v, v + 1, v + n + 1], [v, v + n + 1, v + n]]);
            }
        }
        let surface = Surface::new(&positions, triangles.clone(), 1.0);
        for i in 0..200 {
            let f = i as f64;
            let p = [(f * 0.37) % 14.0 - 1.0, (f * 0.61) % 14.0 - 1.0, (f * 0.13) % 6.0 - 3.0];
            let brute = triangles
                .iter()
                .map(|t| closest_point_on_triangle(p, t.map(|v| point(&positions, v))))
                .map(|q| norm(sub(p, q)))
                .fold(f64::INFINITY, f64::min);
            let found = norm(sub(p, surface.closest(p).unwrap()));
            assert!((found - brute).abs() < 1e-12, "{p:?}: {found} vs {brute}");
        }
        assert!(Surface::new(&positions, Vec::new(), 1.0).closest([0.0; 3]).is_none());
    }

    #[test]
    fn a_triangle_with_a_repeated_corner_or_a_nan_query_stops_nothing() {
        // Triangle 0 has two corners at one spot (a scan's zero-area triangle) and is the
        // first one tested; it once answered NaN, which no later triangle could beat.
        let positions = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 2.0, 0.0];
        let surface = Surface::new(&positions, vec![[0, 1, 2], [0, 2, 3]], 10.0);
        assert_eq!(surface.closest([0.5, 0.5, 1.0]), Some([0.5, 0.5, 0.0]));
        assert_eq!(surface.closest([1.5, -1.0, 0.0]), Some([1.5, 0.0, 0.0]));
        assert_eq!(surface.closest([f64::NAN, 0.0, 0.0]), None);
    }
}
