//! Deterministic generators of test meshes.
//!
//! [`scan`] makes what a 3D scanner delivers: a smooth closed surface with depth noise,
//! punched holes of varied size, small spurious components, and a few degenerate and
//! non-manifold spots and stray vertices. The same [`ScanSpec`] always gives the same bytes.
//!
//! This crate must not depend on anything but the mesh model and the plain-array topology:
//! tests, benches and the CLI use it alike.
//!
//! ```
//! use meshflow_generate::{ScanSpec, scan};
//! let spec = ScanSpec { vertices: 2_000, components: 3, holes: 4, noise: 0.1, seed: 7 };
//! let mesh = scan(&spec);
//! assert_eq!(mesh.content_hash(), scan(&spec).content_hash());
//! ```

mod defects;
mod rng;
mod surface;

use defects::Draft;
use meshflow_mesh::MeshData;
use rng::SplitMix64;

#[derive(Clone, Debug, PartialEq)]
pub struct ScanSpec {
    /// Vertices of the main surface before holes are punched (approximate).
    pub vertices: usize,
    /// Spurious small pieces besides the main surface.
    pub components: usize,
    /// Holes punched into the main surface.
    pub holes: usize,
    /// Depth noise, as a fraction of the mean edge length.
    pub noise: f64,
    pub seed: u64,
}

pub fn scan(spec: &ScanSpec) -> MeshData {
    let mut rng = SplitMix64::new(spec.seed);
    let (positions, triangles) = surface::bumpy_sphere(spec.vertices, &mut rng);
    let mut draft = Draft { positions, triangles };
    let edge = draft.mean_edge_length();
    draft.add_depth_noise(spec.noise * edge, &mut rng);
    draft.punch_holes(spec.holes, edge, &mut rng);
    // A few raw-scan defects, more on bigger scans.
    let spots = 2 + spec.vertices / 250_000;
    draft.add_degenerate_spots(spots, &mut rng);
    draft.add_non_manifold_spots(spots, edge, &mut rng);
    draft.drop_unreferenced();
    draft.add_debris(spec.components, edge, &mut rng);
    draft.add_stray_vertices(spots, &mut rng);
    MeshData::new(draft.positions.iter().map(|&c| c as f32).collect(), draft.triangles)
}

/// The mesh with vertices and triangles in a fixed pseudo-random order (positions and
/// triangles only), as real scans and other tools' meshes come: no code may rely on ids
/// that follow the surface.
pub fn shuffled(mesh: &MeshData) -> MeshData {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = |n: usize| {
        state =
            state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        ((state >> 33) as usize) % n
    };
    let vertices = mesh.vertex_count();
    let mut order: Vec<usize> = (0..vertices).collect();
    for i in (1..vertices).rev() {
        order.swap(i, next(i + 1));
    }
    let mut new_id = vec![0u32; vertices];
    let mut positions = vec![0.0; 3 * vertices];
    for (new, &old) in order.iter().enumerate() {
        positions[3 * new..3 * new + 3].copy_from_slice(&mesh.positions[3 * old..3 * old + 3]);
        new_id[old] = new as u32;
    }
    let mut faces: Vec<[u32; 3]> = mesh
        .triangles
        .chunks_exact(3)
        .map(|t| [new_id[t[0] as usize], new_id[t[1] as usize], new_id[t[2] as usize]])
        .collect();
    for i in (1..faces.len()).rev() {
        faces.swap(i, next(i + 1));
    }
    MeshData::new(positions, faces.concat())
}

#[cfg(test)]
mod tests {
    use super::*;
    use meshflow_topology::boundary::boundary_loops;
    use meshflow_topology::components::TriangleComponents;
    use meshflow_topology::halfedge::HalfEdges;

    fn spec(seed: u64) -> ScanSpec {
        ScanSpec { vertices: 20_000, components: 12, holes: 15, noise: 0.2, seed }
    }

    #[test]
    fn the_same_seed_gives_the_same_mesh_and_another_seed_another() {
        assert_eq!(scan(&spec(1)), scan(&spec(1)));
        assert_ne!(scan(&spec(1)).content_hash(), scan(&spec(2)).content_hash());
    }

    #[test]
    fn a_scan_has_the_requested_size_holes_and_pieces() {
        let mesh = scan(&spec(3));
        let v = mesh.vertex_count();
        assert!((15_000..22_000).contains(&v), "{v} vertices");
        let he = HalfEdges::new(v, &mesh.triangles);
        let loops = boundary_loops(&mesh.triangles, &he);
        // Every punched hole, plus the open borders of the debris patches and fins.
        assert!(loops.len() >= 15 + 12, "{} boundary loops", loops.len());
        let components = TriangleComponents::new(v, &mesh.triangles);
        // Main surface + debris (+ bow-tie triangles, which share only a vertex).
        assert!(
            components.count() > 12,
            "{} components (main surface + 12 debris)",
            components.count()
        );
        let largest = components.largest().unwrap();
        assert!(components.sizes()[largest as usize] as usize > mesh.triangle_count() * 9 / 10);
        assert!(he.non_manifold_edge_count() >= 1, "no non-manifold edge");
        assert!(mesh.positions.iter().all(|c| c.is_finite()));
    }
}
