//! Surface area and enclosed volume.

use meshflow_plugin_sdk::geometry::total_area;
use meshflow_plugin_sdk::topology::TriangleComponents;
use meshflow_plugin_sdk::topology::measure::closed_component_volumes_of;

use crate::arrays::MeshArrays;
use crate::counts::edge_connected;

/// The total area of the live triangles (removed and out-of-range ones skipped).
pub fn surface_area(mesh: &MeshArrays) -> f64 {
    total_area(mesh.positions(), mesh.triangles())
}

/// Why a mesh has no enclosed volume to measure.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "no closed component: every component has boundary edges, so none encloses a volume \
     (fill its holes first)"
)]
pub struct NoClosedComponent;

impl From<NoClosedComponent> for meshflow_plugin_sdk::Error {
    fn from(e: NoClosedComponent) -> Self {
        Self(e.to_string())
    }
}

/// The signed volume enclosed by the closed components, summed: positive for outward
/// winding. Open components enclose nothing and are skipped; a mesh without a closed
/// component is refused, since 0 would read as a measurement.
pub fn enclosed_volume(mesh: &MeshArrays) -> meshflow_plugin_sdk::Result<f64> {
    let components = TriangleComponents::from_forest(&mut edge_connected(mesh)?);
    let (positions, triangles) = (|| mesh.positions(), mesh.triangles());
    let vertex_count = mesh.vertex_slots();
    let kinds = mesh.kinds()?;
    let closed =
        closed_component_volumes_of(vertex_count, positions, triangles, &components, kinds);
    if closed.is_empty() {
        return Err(NoClosedComponent.into());
    }
    Ok(closed.iter().map(|c| c.volume).sum())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::{cube, open_cube, sphere};
    use std::f64::consts::PI;

    #[test]
    fn the_unit_cube_has_area_six_and_volume_one() {
        let c = cube();
        assert!(
            (surface_area(&MeshArrays::native(&c.positions, &c.triangles)) - 6.0).abs() < 1e-12
        );
        assert!(
            (enclosed_volume(&MeshArrays::native(&c.positions, &c.triangles)).unwrap() - 1.0).abs()
                < 1e-12
        );
        let mut inside_out = cube();
        inside_out.triangles.chunks_exact_mut(3).for_each(|t| t.swap(1, 2));
        let volume =
            enclosed_volume(&MeshArrays::native(&inside_out.positions, &inside_out.triangles))
                .unwrap();
        assert!((volume + 1.0).abs() < 1e-12, "{volume}");
    }

    #[test]
    fn a_fine_sphere_approaches_four_pi_and_four_thirds_pi() {
        let s = sphere(32);
        let area = surface_area(&MeshArrays::native(&s.positions, &s.triangles));
        let volume = enclosed_volume(&MeshArrays::native(&s.positions, &s.triangles)).unwrap();
        assert!((area / (4.0 * PI) - 1.0).abs() < 0.01, "{area}");
        assert!((volume / (4.0 / 3.0 * PI) - 1.0).abs() < 0.01, "{volume}");
        assert!(volume < 4.0 / 3.0 * PI, "an inscribed polyhedron is smaller");
    }

    #[test]
    fn the_derived_connectivity_gives_the_sdk_volume_bit_for_bit() {
        use crate::fixtures::*;
        use meshflow_plugin_sdk::topology::measure::closed_component_volumes;
        let mut glued = tetrahedron();
        glued.triangles.extend([0, 0, 1, 2, 3, 2]);
        let mut far = cube();
        far.positions.iter_mut().for_each(|c| *c += 1000.3);
        far.positions.extend(&sphere(12).positions);
        far.triangles.extend(sphere(12).triangles.iter().map(|v| v + 8));
        for mesh in [cube(), sphere(16), tetrahedron(), flipped_cube(), mobius_strip(6), glued, far]
        {
            let sdk = closed_component_volumes(&mesh.positions, &mesh.triangles);
            let ours = enclosed_volume(&MeshArrays::native(&mesh.positions, &mesh.triangles));
            match ours {
                Ok(v) => {
                    assert_eq!(v.to_bits(), sdk.iter().map(|c| c.volume).sum::<f64>().to_bits())
                }
                Err(_) => assert!(sdk.is_empty()),
            }
        }
    }

    #[test]
    fn an_open_mesh_is_refused_and_open_pieces_do_not_count() {
        let open = open_cube();
        let err = enclosed_volume(&MeshArrays::native(&open.positions, &open.triangles))
            .unwrap_err()
            .to_string();
        assert!(err.contains("no closed component"), "{err}");
        let mut both = cube();
        both.positions.extend(&open.positions);
        both.triangles.extend(open.triangles.iter().map(|v| v + 8));
        assert!(
            (enclosed_volume(&MeshArrays::native(&both.positions, &both.triangles)).unwrap() - 1.0)
                .abs()
                < 1e-12
        );
    }
}
