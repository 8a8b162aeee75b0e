//! Attributes through save and load: every attribute a format can hold comes back bit for
//! bit (the same content hash), in every encoding; [`unsupported`] names the others; the
//! files a mesh names beside it are copied, and hostile names are never followed.

use std::path::Path;

use meshflow_mesh::MeshData;
use meshflow_mesh::attributes::{Attribute, Attributes, Domain, Materials, Values};
use meshflow_meshio::{self as io, Format, PlyEncoding, copy_companion_files, unsupported};

/// Six vertices (the last unreferenced), a quad's two triangles and two more; values hard
/// to print: thirds, tiny and huge magnitudes, negative zero.
fn base() -> MeshData {
    MeshData::new(
        vec![
            0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.5, 0.5, 1.0, 9.0, 9.0,
            9.0,
        ],
        vec![0, 1, 2, 0, 2, 3, 4, 1, 0, 2, 4, 3],
    )
}

fn tricky(n: usize, seed: u32) -> Vec<f32> {
    let special = [1.0 / 3.0, -0.0, 1e-30, 3.4e30, 0.1, -7.25, 1e-7, 16_777_217.0];
    (0..n).map(|i| special[(i + seed as usize) % special.len()] * (1.0 + i as f32 / 7.0)).collect()
}

fn with(mut mesh: MeshData, attributes: Vec<Attribute>, materials: Materials) -> MeshData {
    let (v, t) = (mesh.vertex_count(), mesh.triangle_count());
    for a in attributes {
        mesh.attributes.insert(a, v, t).unwrap();
    }
    mesh.attributes.materials = materials;
    mesh
}

fn colours(n: usize, opaque: bool) -> Attribute {
    let rgba =
        (0..n * 4).map(|i| if opaque && i % 4 == 3 { 255 } else { (i * 37 % 256) as u8 }).collect();
    Attribute::color(rgba)
}

fn plain(domain: Domain, name: &str, components: u8, values: Values) -> Attribute {
    Attribute { domain, name: name.into(), components, values }
}

/// Everything PLY holds.
fn everything() -> MeshData {
    let (v, t) = (6, 4);
    with(
        base(),
        vec![
            colours(v, false),
            Attribute::normal(tricky(3 * v, 1)),
            Attribute::quality(tricky(v, 2)),
            Attribute::texcoord(Domain::Vertex, tricky(2 * v, 3)),
            Attribute::texcoord(Domain::Corner, tricky(6 * t, 4)),
            Attribute::material(vec![1, 1, 0, 1]),
            plain(Domain::Vertex, "flags", 1, Values::U8(vec![0, 1, 2, 3, 4, 255])),
            plain(
                Domain::Vertex,
                "confidence",
                1,
                Values::F64(vec![0.1, 1e-300, -2.5, 0.0, 1.0 / 3.0, 7.0]),
            ),
            plain(Domain::Vertex, "curvature", 2, Values::F32(tricky(2 * v, 5))),
            plain(Domain::Vertex, "id", 1, Values::I32(vec![-1, i32::MIN, i32::MAX, 0, 5, 6])),
            plain(Domain::Face, "color", 4, Values::U8((0..16).collect())),
            plain(Domain::Face, "region", 1, Values::U32(vec![0, u32::MAX, 2, 3])),
            plain(Domain::Face, "pair", 3, Values::I32((0..12).map(|i| i - 6).collect())),
        ],
        Materials {
            names: vec!["skin".into(), "eyes and teeth".into()],
            libraries: vec!["scan.mtl".into()],
            textures: vec!["skin.png".into(), "eyes.png".into()],
        },
    )
}

fn round_trip(mesh: &MeshData, format: Format, encoding: PlyEncoding) -> MeshData {
    let mut bytes = Vec::new();
    io::write_as(&mut bytes, mesh, format, encoding).unwrap();
    let loaded = io::load_bytes_reporting(&bytes, format, "mem").unwrap();
    assert!(
        loaded.dropped.is_empty(),
        "{format} {encoding:?}: {:?}\n{}",
        loaded.dropped,
        String::from_utf8_lossy(&bytes[..bytes.len().min(2000)])
    );
    loaded.mesh
}

fn assert_same(loaded: &MeshData, mesh: &MeshData, what: &str) {
    assert_eq!(loaded.attributes.describe(), mesh.attributes.describe(), "{what}");
    assert_eq!(loaded.attributes, mesh.attributes, "{what}");
    assert_eq!(loaded.content_hash(), mesh.content_hash(), "{what}");
}

#[test]
fn ply_holds_every_attribute_in_every_encoding() {
    let mesh = everything();
    assert_eq!(unsupported(&mesh, Format::Ply), Vec::<String>::new());
    for encoding in
        [PlyEncoding::Ascii, PlyEncoding::BinaryLittleEndian, PlyEncoding::BinaryBigEndian]
    {
        let loaded = round_trip(&mesh, Format::Ply, encoding);
        assert_same(&loaded, &mesh, &format!("{encoding:?}"));
    }
    // Material names that are the textures' need no comment of their own, as MeshLab
    // writes them; and a mesh without triangles keeps its (empty) attributes too.
    let mut meshlab = mesh.clone();
    meshlab.attributes.materials.names = meshlab.attributes.materials.textures.clone();
    let mut bytes = Vec::new();
    io::write_as(&mut bytes, &meshlab, Format::Ply, PlyEncoding::Ascii).unwrap();
    assert!(!String::from_utf8_lossy(&bytes).contains("meshflow material"));
    assert_same(&round_trip(&meshlab, Format::Ply, PlyEncoding::Ascii), &meshlab, "meshlab");
}

#[test]
fn obj_holds_colours_normals_texture_coordinates_and_materials() {
    let (v, t) = (6, 4);
    let materials = Materials {
        names: vec!["unused".into(), "skin".into(), "eyes and teeth".into()],
        libraries: vec!["scan.mtl".into(), "more.mtl".into()],
        textures: Vec::new(),
    };
    let corner = with(
        base(),
        vec![
            colours(v, true),
            Attribute::normal(tricky(3 * v, 1)),
            Attribute::texcoord(Domain::Corner, tricky(6 * t, 4)),
            Attribute::material(vec![2, 1, 1, 2]),
        ],
        materials.clone(),
    );
    let per_vertex = with(
        base(),
        vec![Attribute::texcoord(Domain::Vertex, tricky(2 * v, 3))],
        Materials::default(),
    );
    // Corner coordinates that happen to be one per vertex in vertex order stay per corner.
    let soup = MeshData::new(tricky(9, 0), vec![0, 1, 2]);
    let soup =
        with(soup, vec![Attribute::texcoord(Domain::Corner, tricky(6, 2))], Materials::default());
    for (mesh, what) in [(corner, "corner"), (per_vertex, "vertex"), (soup, "soup")] {
        assert_eq!(unsupported(&mesh, Format::Obj), Vec::<String>::new(), "{what}");
        assert_same(&round_trip(&mesh, Format::Obj, PlyEncoding::default()), &mesh, what);
    }
}

#[test]
fn off_holds_vertex_colours_normals_texture_coordinates_and_face_colours() {
    let mesh = with(
        base(),
        vec![
            colours(6, false),
            Attribute::normal(tricky(18, 1)),
            Attribute::texcoord(Domain::Vertex, tricky(12, 3)),
            plain(Domain::Face, "color", 4, Values::U8((0..16).map(|i| i * 16).collect())),
        ],
        Materials::default(),
    );
    assert_eq!(unsupported(&mesh, Format::Off), Vec::<String>::new());
    assert_same(&round_trip(&mesh, Format::Off, PlyEncoding::default()), &mesh, "off");
}

#[test]
fn what_a_format_cannot_hold_is_named_and_left_out() {
    let mesh = everything();
    let stl = unsupported(&mesh, Format::Stl);
    assert_eq!(stl.len(), mesh.attributes.len() + 3);
    assert_eq!(stl[0], "vertex color (4 × u8)");
    assert_eq!(stl[mesh.attributes.len()], "materials (skin, eyes and teeth)");
    assert_eq!(
        unsupported(&mesh, Format::Off),
        [
            "vertex confidence (1 × f64)",
            "vertex curvature (2 × f32)",
            "vertex flags (1 × u8)",
            "vertex id (1 × i32)",
            "vertex quality (1 × f32)",
            "face material (1 × u32)",
            "face pair (3 × i32)",
            "face region (1 × u32)",
            "corner texcoord (2 × f32)",
            "materials (skin, eyes and teeth)",
            "material libraries (scan.mtl)",
            "textures (skin.png, eyes.png)"
        ]
    );
    let obj = unsupported(&mesh, Format::Obj);
    assert!(obj.contains(&"vertex color's alpha (not opaque everywhere)".to_string()), "{obj:?}");
    assert!(obj.contains(&"vertex texcoord (2 × f32)".to_string()), "{obj:?}");
    assert!(obj.contains(&"face color (4 × u8)".to_string()), "{obj:?}");
    assert!(!obj.iter().any(|l| l.contains("material")), "{obj:?}");

    // What is left out is just left out: the rest loads back.
    let mut bytes = Vec::new();
    io::write_to(&mut bytes, &mesh, Format::Off).unwrap();
    let loaded = io::load_bytes(&bytes, Format::Off, "m.off").unwrap();
    assert_eq!(loaded.attributes.len(), 4);
    let mut bytes = Vec::new();
    io::write_to(&mut bytes, &mesh, Format::Stl).unwrap();
    assert!(io::load_bytes(&bytes, Format::Stl, "m.stl").unwrap().attributes.is_empty());

    // An attribute named like the colour's properties moves the colour to other names;
    // attributes a reader would take together as one are named, not written.
    let beside = with(
        base(),
        vec![colours(6, true), plain(Domain::Vertex, "alpha", 1, Values::U8(vec![1; 6]))],
        Materials::default(),
    );
    assert!(unsupported(&beside, Format::Ply).is_empty());
    let mut bytes = Vec::new();
    io::write_as(&mut bytes, &beside, Format::Ply, PlyEncoding::Ascii).unwrap();
    assert!(String::from_utf8_lossy(&bytes).contains("property uchar diffuse_red\n"));
    assert_same(&round_trip(&beside, Format::Ply, PlyEncoding::Ascii), &beside, "beside");
    let channels =
        ["red", "green", "blue"].map(|n| plain(Domain::Vertex, n, 1, Values::U8(vec![7; 6])));
    let clash = with(base(), channels.to_vec(), Materials::default());
    assert_eq!(
        unsupported(&clash, Format::Ply),
        ["vertex blue (1 × u8)", "vertex green (1 × u8)", "vertex red (1 × u8)"]
    );
    let loaded = round_trip(&clash, Format::Ply, PlyEncoding::BinaryLittleEndian);
    assert!(loaded.attributes.is_empty());
}

#[test]
fn a_mesh_with_broken_attributes_is_not_saved() {
    let mut mesh = base();
    let mut bad = Attributes::default();
    bad.insert(Attribute::quality(vec![0.0; 6]), 6, 4).unwrap();
    mesh.attributes = bad;
    mesh.positions.truncate(15);
    let error = io::write_to(Vec::new(), &mesh, Format::Ply).unwrap_err();
    assert!(error.to_string().contains("quality"), "{error}");
}

fn write(dir: &Path, name: &str, text: &str) {
    std::fs::write(dir.join(name), text).unwrap();
}

#[test]
fn an_obj_names_its_textures_through_its_library_and_they_are_copied_beside_the_output() {
    let root = tempfile::tempdir().unwrap();
    let (input, output) = (root.path().join("in"), root.path().join("out"));
    std::fs::create_dir_all(&input).unwrap();
    std::fs::create_dir_all(&output).unwrap();
    write(root.path(), "secret.png", "not to be copied");
    write(
        &input,
        "scan.obj",
        "mtllib scan.mtl ../secret.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n\
         usemtl skin\nf 1/1 2/2 3/3\n",
    );
    write(
        &input,
        "scan.mtl",
        "newmtl skin\nKd 1 1 1\nmap_Kd -s 1 1 1 skin.png\nmap_Bump ../secret.png\n\
         bump /etc/passwd\nmap_Ks missing.png\n",
    );
    write(&input, "skin.png", "PNG bytes");
    let loaded = io::load_reporting(&input.join("scan.obj")).unwrap();
    let materials = &loaded.mesh.attributes.materials;
    assert_eq!(materials.libraries, ["scan.mtl"]);
    let lines = loaded.dropped.lines();
    assert!(lines.iter().any(|l| l.contains("\"../secret.mtl\"") && l.contains("never followed")));
    // The mesh is what the file holds, wherever it lies: from memory it is the same mesh.
    let bytes = std::fs::read(input.join("scan.obj")).unwrap();
    let from_memory = io::load_bytes(&bytes, Format::Obj, "scan.obj").unwrap();
    assert_eq!(from_memory.content_hash(), loaded.mesh.content_hash());

    let target = output.join("result.obj");
    io::save(&target, &loaded.mesh).unwrap();
    let copied = copy_companion_files(&input.join("scan.obj"), &target, materials).unwrap();
    // The library's textures are copied with it; what it names outside its folder never is.
    assert_eq!(copied.copied, [output.join("scan.mtl"), output.join("skin.png")]);
    let skipped = &copied.skipped;
    for refused in ["\"../secret.png\"", "\"/etc/passwd\""] {
        assert!(
            skipped.iter().any(|l| l.contains(refused) && l.contains("never followed")),
            "{refused}: {skipped:?}"
        );
    }
    assert!(skipped.iter().any(|l| l.starts_with("missing.png: not beside")), "{skipped:?}");
    assert!(!output.join("secret.png").exists());
    assert_eq!(std::fs::read_to_string(output.join("skin.png")).unwrap(), "PNG bytes");
    let again = io::load(&target).unwrap();
    assert_eq!(again.content_hash(), loaded.mesh.content_hash());

    // Names that leave the folder are never followed, whoever made the materials.
    let hostile = Materials {
        names: Vec::new(),
        libraries: vec!["../secret.png".into()],
        textures: vec!["../../secret.png".into(), "/etc/passwd".into(), "..".into()],
    };
    let done =
        copy_companion_files(&input.join("scan.obj"), &output.join("x.ply"), &hostile).unwrap();
    assert!(done.copied.is_empty());
    assert_eq!(done.skipped.len(), 4);
    assert!(!root.path().join("out").join("secret.png").exists());
    // Formats without materials get nothing; the same folder needs nothing.
    let stl = copy_companion_files(&input.join("scan.obj"), &output.join("x.stl"), materials);
    assert_eq!(stl.unwrap(), Default::default());
    let same = copy_companion_files(&input.join("scan.obj"), &input.join("y.obj"), materials);
    assert_eq!(same.unwrap(), Default::default());
}

#[test]
fn hostile_ply_texture_names_are_refused_and_texnumber_stays_a_number() {
    let ply = "ply\nformat ascii 1.0\ncomment TextureFile ../../etc/passwd\n\
               comment TextureFile ok.png\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
               property int texnumber\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 1\n";
    let loaded = io::load_bytes_reporting(ply.as_bytes(), Format::Ply, "t.ply").unwrap();
    let attributes = &loaded.mesh.attributes;
    assert_eq!(attributes.materials.textures, ["ok.png"]);
    assert!(attributes.materials.names.is_empty());
    assert_eq!(attributes.describe(), ["face texnumber (1 × i32)", "textures: ok.png"]);
    assert!(
        loaded.dropped.lines()[0].starts_with("texture \"../../etc/passwd\" (a name that leaves")
    );
    attributes.check(3, 1).unwrap();
}

#[test]
fn polygons_give_each_triangle_their_values_and_corners_theirs() {
    let ply = "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n\
               property float z\nelement face 2\nproperty list uchar int vertex_indices\n\
               property uchar red\nproperty uchar green\nproperty uchar blue\n\
               property list uchar float texcoord\nend_header\n\
               0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 2 0\n\
               4 0 1 2 3 10 20 30 8 0 0 1 0 1 1 0 1\n3 1 4 2 40 50 60 6 1 0 2 2 1 1\n";
    let mesh = io::load_bytes(ply.as_bytes(), Format::Ply, "p.ply").unwrap();
    assert_eq!(mesh.triangles, [0, 1, 2, 0, 2, 3, 1, 4, 2]);
    let colour = mesh.attributes.get(Domain::Face, "color").unwrap();
    assert_eq!(colour.values, Values::U8(vec![10, 20, 30, 255, 10, 20, 30, 255, 40, 50, 60, 255]));
    let uv = mesh.attributes.get(Domain::Corner, "texcoord").unwrap();
    assert_eq!(
        uv.values,
        Values::F32(vec![
            0., 0., 1., 0., 1., 1., // corners 0 1 2
            0., 0., 1., 1., 0., 1., // corners 0 2 3
            1., 0., 2., 2., 1., 1.,
        ])
    );
    // OBJ polygons: the same fan, each triangle the polygon's material.
    // (Five `vt` for four `v`: per corner; one per vertex in their order would be per vertex.)
    let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 9 9\n\
               f 1/1 2/2 3/3 4/4\nusemtl a\nf 1/1 2/2 3/3\n";
    let mesh = io::load_bytes(obj.as_bytes(), Format::Obj, "p.obj").unwrap();
    let material = mesh.attributes.get(Domain::Face, "material").unwrap();
    assert_eq!(material.values, Values::U32(vec![1, 1, 0]));
    assert_eq!(mesh.attributes.materials.names, ["a", "default"]);
    let uv = mesh.attributes.get(Domain::Corner, "texcoord").unwrap();
    assert_eq!(
        uv.values,
        Values::F32(vec![0., 0., 1., 0., 1., 1., 0., 0., 1., 1., 0., 1., 0., 0., 1., 0., 1., 1.])
    );
}

/// Any PLY that loads saves as PLY with nothing left out and loads back to the same hash
/// (what the fuzz targets check): headers of random property names and types, drawn
/// from the names readers group, with textures and `texnumber`s in and out of range.
#[test]
fn whatever_a_ply_holds_that_loads_round_trips_through_ply() {
    const VERTEX: [&str; 24] = [
        "red",
        "green",
        "blue",
        "alpha",
        "diffuse_red",
        "diffuse_green",
        "diffuse_blue",
        "nx",
        "ny",
        "nz",
        "normal_x",
        "normal_y",
        "normal_z",
        "u",
        "v",
        "s",
        "t",
        "texture_u",
        "texture_v",
        "quality",
        "flags",
        "color",
        "normal",
        "texcoord",
    ];
    const FACE: [&str; 8] =
        ["red", "green", "blue", "alpha", "texnumber", "quality", "material", "region"];
    const TYPES: [&str; 8] = ["char", "uchar", "short", "ushort", "int", "uint", "float", "double"];
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = |n: usize| {
        state =
            state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (state >> 33) as usize % n
    };
    for case in 0..400 {
        let mut header = String::from("ply\nformat ascii 1.0\n");
        for t in 0..next(3) {
            header.push_str(&format!("comment TextureFile t{t}.png\n"));
        }
        if next(4) == 0 {
            header.push_str("comment meshflow material one\n");
        }
        header.push_str("element vertex 3\nproperty float x\nproperty float y\nproperty float z\n");
        let mut vertex_values = Vec::new();
        for name in VERTEX {
            if next(3) == 0 {
                let list = next(6) == 0;
                let ty = TYPES[next(TYPES.len())];
                match list {
                    true => header.push_str(&format!("property list uchar {ty} {name}\n")),
                    false => header.push_str(&format!("property {ty} {name}\n")),
                }
                vertex_values.push(list);
            }
        }
        header.push_str("element face 2\nproperty list uchar int vertex_indices\n");
        let mut face_values = Vec::new();
        for name in FACE {
            if next(3) == 0 {
                let ty = TYPES[next(TYPES.len())];
                header.push_str(&format!("property {ty} {name}\n"));
                face_values.push(false);
            }
        }
        header.push_str("end_header\n");
        let mut body = String::new();
        for v in 0..3 {
            body.push_str(&format!("{v} {} 0", v % 2));
            for &list in &vertex_values {
                let x = next(3);
                match list {
                    true => body.push_str(&format!(" 2 {x} 1")),
                    false => body.push_str(&format!(" {x}")),
                }
            }
            body.push('\n');
        }
        for f in 0..2 {
            body.push_str(if f == 0 { "3 0 1 2" } else { "4 0 1 2 0" });
            for _ in &face_values {
                body.push_str(&format!(" {}", next(3)));
            }
            body.push('\n');
        }
        let text = header + &body;
        let mesh = io::load_bytes(text.as_bytes(), Format::Ply, "case")
            .unwrap_or_else(|e| panic!("case {case}: {e}\n{text}"));
        assert_eq!(unsupported(&mesh, Format::Ply), Vec::<String>::new(), "case {case}:\n{text}");
        for encoding in [PlyEncoding::Ascii, PlyEncoding::BinaryBigEndian] {
            let mut bytes = Vec::new();
            io::write_as(&mut bytes, &mesh, Format::Ply, encoding).unwrap();
            let again = io::load_bytes(&bytes, Format::Ply, "again").unwrap();
            assert_eq!(
                again.attributes,
                mesh.attributes,
                "case {case} {encoding:?}:\n{text}\n{}",
                String::from_utf8_lossy(&bytes)
            );
            assert_eq!(again.content_hash(), mesh.content_hash());
        }
    }
}
