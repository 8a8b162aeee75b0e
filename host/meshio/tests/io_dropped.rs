//! A load keeps what a file held beyond positions and triangles, and names only what it
//! still leaves behind (issue 35): the cases users met — a scan with flags and quality,
//! colours and double coordinates, a textured OBJ, normals and colours — and the plain
//! files that hold nothing more, which report nothing.

use meshflow_mesh::attributes::{Domain, Values};
use meshflow_meshio::{Dropped, Format, Loaded, load_bytes_reporting};

fn loaded(bytes: &[u8], format: Format) -> Loaded {
    load_bytes_reporting(bytes, format, "test").unwrap()
}

fn dropped(bytes: &[u8], format: Format) -> Dropped {
    loaded(bytes, format).dropped
}

fn binary_ply(header: &str, body: &[u8]) -> Vec<u8> {
    let mut bytes = header.as_bytes().to_vec();
    bytes.extend_from_slice(body);
    bytes
}

#[test]
fn a_scan_keeps_its_flags_and_quality() {
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nproperty uchar flags\nproperty float quality\nelement face 1\n\
               property list uchar int vertex_indices\nend_header\n\
               0 0 0 0 0.5\n1 0 0 1 0.25\n0 1 0 0 1\n3 0 1 2\n";
    let Loaded { mesh, dropped } = loaded(ply.as_bytes(), Format::Ply);
    assert!(dropped.is_empty(), "{dropped:?}");
    assert_eq!(mesh.attributes.describe(), ["vertex flags (1 × u8)", "vertex quality (1 × f32)"]);
    let get = |name| &mesh.attributes.get(Domain::Vertex, name).unwrap().values;
    assert_eq!(get("flags"), &Values::U8(vec![0, 1, 0]));
    assert_eq!(get("quality"), &Values::F32(vec![0.5, 0.25, 1.0]));
}

#[test]
fn colours_and_quality_are_kept_and_double_coordinates_name_their_largest_rounding() {
    // Binary doubles, one of which (0.1) has no exact f32.
    let header = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\n\
                  property double y\nproperty double z\nproperty uchar red\nproperty uchar green\n\
                  property uchar blue\nproperty uchar alpha\nproperty float quality\n\
                  element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    let mut body = Vec::new();
    for (p, rgba) in [[0.1f64, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]].into_iter().zip([
        [255, 0, 0, 255],
        [0, 255, 0, 128],
        [0, 0, 255, 0],
    ]) {
        p.iter().for_each(|c| body.extend_from_slice(&c.to_le_bytes()));
        body.extend_from_slice(&rgba);
        body.extend_from_slice(&0.5f32.to_le_bytes());
    }
    body.push(3);
    [0i32, 1, 2].iter().for_each(|i| body.extend_from_slice(&i.to_le_bytes()));
    let loaded = load_bytes_reporting(&binary_ply(header, &body), Format::Ply, "t").unwrap();
    assert_eq!(loaded.mesh.positions[0], 0.1f32);
    let colour = loaded.mesh.attributes.get(Domain::Vertex, "color").unwrap();
    assert_eq!(colour.values, Values::U8(vec![255, 0, 0, 255, 0, 255, 0, 128, 0, 0, 255, 0]));
    assert!(loaded.mesh.attributes.get(Domain::Vertex, "quality").is_some());
    let d = loaded.dropped;
    assert!(d.attributes.is_empty(), "{d:?}");
    assert_eq!(d.rounding, Some((0.1f64 - f64::from(0.1f32)).abs()));
    assert_eq!(d.lines().len(), 1);
    assert!(d.lines()[0].starts_with("double coordinates, rounded to float"));

    // The same in ascii: the value is what it always was, and the rounding is reported.
    let ascii = "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n\
                 property double z\nelement face 1\nproperty list uchar int vertex_indices\n\
                 end_header\n0.1 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    let loaded = load_bytes_reporting(ascii.as_bytes(), Format::Ply, "t").unwrap();
    assert_eq!(loaded.mesh.positions[0], 0.1f32);
    assert_eq!(loaded.dropped.rounding, Some((0.1f64 - f64::from(0.1f32)).abs()));
}

#[test]
fn ply_normals_texture_coordinates_are_kept_and_other_elements_named() {
    let ply = "ply\nformat ascii 1.0\ncomment TextureFile skin.png\nelement vertex 3\n\
               property float x\nproperty float y\nproperty float z\nproperty float nx\n\
               property float ny\nproperty float nz\nproperty float u\nproperty float v\n\
               element face 1\nproperty list uchar int vertex_indices\n\
               property list uchar float texcoord\nproperty int texnumber\n\
               property list uchar int neighbours\n\
               element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n\
               0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n0 1 0 0 0 1 0 1\n3 0 1 2 6 0 0 1 0 0 1 0 2 5 6\n0 1\n";
    let Loaded { mesh, dropped } = loaded(ply.as_bytes(), Format::Ply);
    assert_eq!(
        mesh.attributes.describe(),
        [
            "vertex normal (3 × f32)",
            "vertex texcoord (2 × f32)",
            "face material (1 × u32)",
            "face neighbours (2 × i32)",
            "corner texcoord (2 × f32)",
            "materials: skin.png",
            "textures: skin.png"
        ]
    );
    let corner = mesh.attributes.get(Domain::Corner, "texcoord").unwrap();
    assert_eq!(corner.values, Values::F32(vec![0.0, 0.0, 1.0, 0.0, 0.0, 1.0]));
    assert_eq!(dropped.attributes, ["element 'edge' (1 records)"]);
}

#[test]
fn a_textured_obj_keeps_its_coordinates_normals_colours_and_materials() {
    let obj = "mtllib scan.mtl\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nvt 0 0\nvt 1 0\n\
               vt 0 1\nvt 0.5 0.5\nvn 0 0 1\nusemtl skin\nf 1/1/1 2/2/1 3/3/1\nf 1/4/1 3/3/1 2/2/1\n";
    let Loaded { mesh, dropped } = loaded(obj.as_bytes(), Format::Obj);
    assert!(dropped.is_empty(), "{dropped:?}");
    assert_eq!(
        mesh.attributes.describe(),
        [
            "vertex color (4 × u8)",
            "vertex normal (3 × f32)",
            "face material (1 × u32)",
            "corner texcoord (2 × f32)",
            "materials: skin",
            "material libraries: scan.mtl"
        ]
    );
    let colour = mesh.attributes.get(Domain::Vertex, "color").unwrap();
    assert_eq!(colour.values, Values::U8(vec![255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255]));
}

#[test]
fn obj_normals_that_differ_per_face_are_averaged_and_said_so() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nvn 1 0 0\n\
               f 1//1 2//1 3//1\nf 2//2 4//2 3//2\n";
    let Loaded { mesh, dropped } = loaded(obj.as_bytes(), Format::Obj);
    let normal = mesh.attributes.get(Domain::Vertex, "normal").unwrap();
    let h = std::f32::consts::FRAC_1_SQRT_2;
    assert_eq!(
        normal.values,
        Values::F32(vec![0.0, 0.0, 1.0, h, 0.0, h, h, 0.0, h, 1.0, 0.0, 0.0])
    );
    assert_eq!(dropped.attributes.len(), 1);
    assert!(dropped.attributes[0].contains("2 vertices have different normals"), "{dropped:?}");
}

#[test]
fn coloured_off_files_keep_their_colours() {
    let off = "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n\
               3 0 1 2 10 20 30\n";
    let Loaded { mesh, dropped } = loaded(off.as_bytes(), Format::Off);
    assert!(dropped.is_empty(), "{dropped:?}");
    let face = mesh.attributes.get(Domain::Face, "color").unwrap();
    assert_eq!(face.values, Values::U8(vec![10, 20, 30, 255]));
    let vertex = mesh.attributes.get(Domain::Vertex, "color").unwrap();
    assert_eq!(vertex.values, Values::U8(vec![255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255]));
    // Floats from 0 to 1, with normals first as the prefix order says.
    let off = "CNOFF\n3 1\n0 0 0 0 0 1 1 0 0\n1 0 0 0 0 1 0 1 0\n0 1 0 0 0 1 0 0 0.5\n3 0 1 2\n";
    let mesh = loaded(off.as_bytes(), Format::Off).mesh;
    let vertex = mesh.attributes.get(Domain::Vertex, "color").unwrap();
    assert_eq!(vertex.values, Values::U8(vec![255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 128, 255]));
    assert!(mesh.attributes.get(Domain::Vertex, "normal").is_some());
}

#[test]
fn stl_colour_words_are_named_and_plain_files_report_nothing() {
    let mut stl = vec![0u8; 80];
    stl.extend_from_slice(&1u32.to_le_bytes());
    let mut record = vec![0u8; 12];
    for p in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        p.iter().for_each(|c| record.extend_from_slice(&c.to_le_bytes()));
    }
    let plain = [stl.clone(), record.clone(), vec![0, 0]].concat();
    assert!(dropped(&plain, Format::Stl).is_empty());
    let coloured = [stl, record, 0x801fu16.to_le_bytes().to_vec()].concat();
    assert_eq!(
        dropped(&coloured, Format::Stl).attributes,
        ["triangle colour (STL attribute words)"]
    );

    let bunny = std::fs::read(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/bunny.obj"),
    )
    .unwrap();
    let bunny = loaded(&bunny, Format::Obj);
    assert!(bunny.dropped.is_empty(), "the bunny holds only v and f");
    assert!(bunny.mesh.attributes.is_empty());
}

#[test]
fn what_the_model_refuses_is_named_not_an_error() {
    // A property name with a character names cannot hold, a list of differing lengths, a
    // quality that is not finite, and more properties than a mesh holds attributes.
    let mut header = String::from(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nproperty float bad@name\nproperty list uchar int ragged\n\
         property float quality\n",
    );
    for i in 0..40 {
        header.push_str(&format!("property uchar extra{i}\n"));
    }
    header.push_str("element face 1\nproperty list uchar int vertex_indices\nend_header\n");
    let extras = " 7".repeat(40);
    let body =
        format!("0 0 0 1 1 5 nan{extras}\n1 0 0 1 2 5 6 0{extras}\n0 1 0 1 0 0{extras}\n3 0 1 2\n");
    let Loaded { mesh, dropped } = loaded((header + &body).as_bytes(), Format::Ply);
    // 32 planned: quality, ragged and extra0..extra29; the two refused leave 30.
    assert_eq!(mesh.attributes.len(), 30);
    let lines = dropped.lines();
    assert!(lines[0].starts_with("vertex property 'bad@name' (its name is not one"), "{lines:?}");
    assert!(
        lines.iter().any(|l| l.contains("properties 'extra30', 'extra31', 'extra32' and 7 more")),
        "{lines:?}"
    );
    assert!(lines.iter().any(|l| l.starts_with("vertex list 'ragged' (lists not of one")));
    assert!(lines.iter().any(|l| l == "vertex property 'quality' (element 0 is not finite)"));
}
