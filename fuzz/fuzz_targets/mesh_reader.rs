//! What every mesh reader target checks: any bytes either fail with a typed error or give a
//! mesh with finite coordinates and in-range ids, which survives a binary PLY round trip
//! bit for bit (the format hosts and the CLI write).

use meshflow_meshio::{Format, load_bytes, write_to};

pub fn check(data: &[u8], format: Format) {
    let Ok(mesh) = load_bytes(data, format, "fuzz input") else { return };
    assert_eq!(mesh.positions.len() % 3, 0);
    assert_eq!(mesh.triangles.len() % 3, 0);
    assert!(mesh.positions.iter().all(|c| c.is_finite()), "a non-finite coordinate got through");
    let vertices = mesh.vertex_count();
    assert!(mesh.triangles.iter().all(|&i| (i as usize) < vertices), "an id out of range");
    let mut ply = Vec::new();
    write_to(&mut ply, &mesh, Format::Ply).expect("a read mesh writes");
    let again = load_bytes(&ply, Format::Ply, "round trip").expect("own output reads");
    assert_eq!(again.content_hash(), mesh.content_hash());
}
