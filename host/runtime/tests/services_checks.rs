//! Every check of the `checks` plugin, run as WebAssembly through the host, against meshes
//! with known answers: hand-built ones, the Stanford bunny, and a generated raw scan.

use std::f64::consts::PI;
use std::path::Path;

use meshflow_builtin_plugins::PLUGINS;
use meshflow_generate::{ScanSpec, scan};
use meshflow_mesh::MeshData;
use meshflow_meshio::{self as io, Format};
use meshflow_runtime::{Limits, Plugin, Runtime, ServiceKind, Value, ValueType};
use meshflow_topology::{self as topology, HalfEdges, TriangleComponents};

/// What every check should say about a mesh.
#[derive(Debug)]
struct Expected {
    vertices: i64,
    edges: i64,
    triangles: i64,
    components: i64,
    holes: i64,
    manifold: bool,
    oriented: bool,
    orientable: bool,
    /// Degrees.
    min_angle: f64,
    max_angle: f64,
    normal_instability: f64,
}

impl Expected {
    /// `(service, expected value)` for every check.
    fn values(&self) -> [(&'static str, Value); 11] {
        [
            ("vertex-count", Value::Integer(self.vertices)),
            ("edge-count", Value::Integer(self.edges)),
            ("triangle-count", Value::Integer(self.triangles)),
            ("component-count", Value::Integer(self.components)),
            ("hole-count", Value::Integer(self.holes)),
            ("is-manifold", Value::Boolean(self.manifold)),
            ("is-oriented", Value::Boolean(self.oriented)),
            ("is-orientable", Value::Boolean(self.orientable)),
            ("min-angle", Value::Real(self.min_angle)),
            ("max-angle", Value::Real(self.max_angle)),
            ("normal-instability", Value::Real(self.normal_instability)),
        ]
    }
}

struct Checks {
    runtime: Runtime,
    plugin: Plugin,
}

impl Checks {
    fn load() -> Self {
        let runtime = Runtime::new(Limits::default(), None).expect("a runtime");
        let wasm = PLUGINS.iter().find(|p| p.name == "checks").expect("the checks plugin").wasm;
        let plugin = runtime.load(wasm).expect("the checks plugin loads");
        Self { runtime, plugin }
    }

    fn run(&self, service: &str, mesh: &MeshData) -> Value {
        let out = self.runtime.run(&self.plugin, service, mesh.clone(), &[]).expect(service);
        assert!(out.log.is_empty() && out.mesh.is_none(), "{service} changed the mesh");
        out.value.unwrap_or_else(|| panic!("{service} returned no value"))
    }

    /// Runs every check on `mesh` and compares with `expected` (reals to 1e-6 degrees).
    fn assert_all(&self, name: &str, mesh: &MeshData, expected: &Expected) {
        for (service, want) in expected.values() {
            let got = self.run(service, mesh);
            let same = match (&got, &want) {
                (Value::Real(g), Value::Real(w)) => (g - w).abs() < 1e-6,
                _ => got == want,
            };
            assert!(same, "{name}: {service} gave {got:?}, expected {want:?}");
        }
    }
}

fn obj(text: &str) -> MeshData {
    io::load_bytes(text.as_bytes(), Format::Obj, "test mesh").expect("a valid OBJ")
}

/// The unit cube, two right isosceles triangles per face, oriented outwards.
const CUBE: &str = "
v 0 0 0
v 1 0 0
v 0 1 0
v 1 1 0
v 0 0 1
v 1 0 1
v 0 1 1
v 1 1 1
f 1 3 4
f 1 4 2
f 5 6 8
f 5 8 7
f 1 2 6
f 1 6 5
f 3 7 8
f 3 8 4
f 1 5 7
f 1 7 3
f 2 4 8
f 2 8 6
";

fn cube_expected() -> Expected {
    Expected {
        vertices: 8,
        edges: 18,
        triangles: 12,
        components: 1,
        holes: 0,
        manifold: true,
        oriented: true,
        orientable: true,
        min_angle: 45.0,
        max_angle: 90.0,
        // 12 cube edges at 90°, 6 face diagonals at 0°.
        normal_instability: 60.0,
    }
}

/// Two flat sheets crossing at right angles along their common middle edge 1–2.
const TWO_SHEETS: &str = "
v 0 0 0
v 1 0 0
v 0 1 0
v 0 -1 0
v 0 0 1
v 0 0 -1
f 1 2 3
f 2 1 4
f 1 2 5
f 2 1 6
";

/// Two right isosceles triangles touching only at vertex 1, and an unused vertex.
const BOW_TIE: &str = "
v 0 0 0
v 1 0 0
v 0 1 0
v -1 0 0
v 0 -1 0
v 7 7 7
f 1 2 3
f 1 4 5
";

/// A Möbius strip of `quads` quads around a circle of radius 2, width 1.
fn mobius_strip(quads: u32) -> MeshData {
    let mut positions = Vec::new();
    for i in 0..quads {
        let phi = 2.0 * PI * i as f64 / quads as f64;
        for s in [0.5, -0.5] {
            let r = 2.0 + s * (phi / 2.0).cos();
            positions
                .extend([r * phi.cos(), r * phi.sin(), s * (phi / 2.0).sin()].map(|c| c as f32));
        }
    }
    let mut triangles = Vec::new();
    for i in 0..quads {
        let (t, b) = (2 * i, 2 * i + 1);
        // Half a turn later the top edge has become the bottom edge.
        let (nt, nb) = if i + 1 < quads { (t + 2, b + 2) } else { (1, 0) };
        triangles.extend([t, b, nb, t, nb, nt]);
    }
    MeshData::new(positions, triangles)
}

#[test]
fn every_check_is_listed_with_its_result_type() {
    let checks = Checks::load();
    for (service, value) in cube_expected().values() {
        let info = checks.plugin.service(service).unwrap_or_else(|| panic!("{service} missing"));
        assert_eq!(info.kind, ServiceKind::Check, "{service}");
        let want = match value {
            Value::Integer(_) => ValueType::Integer,
            Value::Boolean(_) => ValueType::Boolean,
            _ => ValueType::Real,
        };
        assert_eq!(info.result_type, Some(want), "{service}");
        assert!(!info.doc.is_empty(), "{service} is undocumented");
    }
}

#[test]
fn closed_open_and_flipped_cubes() {
    let checks = Checks::load();
    let cube = obj(CUBE);
    checks.assert_all("cube", &cube, &cube_expected());

    let mut flipped = cube.clone();
    flipped.triangles.swap(1, 2);
    // The flipped triangle's diagonal now sees opposite normals: one 0° becomes 180°.
    let expected = Expected { oriented: false, normal_instability: 70.0, ..cube_expected() };
    checks.assert_all("flipped cube", &flipped, &expected);

    let mut open = cube;
    open.triangles.drain(6..12);
    // The top face and its diagonal are gone; its four edges are the border of one hole.
    let expected = Expected {
        edges: 17,
        triangles: 10,
        holes: 1,
        normal_instability: 8.0 * 90.0 / 13.0,
        ..cube_expected()
    };
    checks.assert_all("open cube", &open, &expected);
}

#[test]
fn non_manifold_configurations() {
    let checks = Checks::load();
    let right_triangles = |vertices, edges, components| Expected {
        vertices,
        edges,
        triangles: 4,
        components,
        holes: 2,
        manifold: false,
        oriented: true,
        orientable: true,
        min_angle: 45.0,
        max_angle: 90.0,
        normal_instability: 0.0,
    };
    checks.assert_all("two sheets", &obj(TWO_SHEETS), &right_triangles(6, 9, 1));
    let bow_tie = Expected { triangles: 2, ..right_triangles(6, 6, 2) };
    checks.assert_all("bow-tie", &obj(BOW_TIE), &bow_tie);
}

#[test]
fn a_mobius_strip_is_manifold_with_one_border_and_not_orientable() {
    let checks = Checks::load();
    let strip = mobius_strip(6);
    let value = |service| checks.run(service, &strip);
    assert_eq!(value("edge-count"), Value::Integer(24));
    assert_eq!(value("component-count"), Value::Integer(1));
    assert_eq!(value("hole-count"), Value::Integer(1));
    assert_eq!(value("is-manifold"), Value::Boolean(true));
    assert_eq!(value("is-oriented"), Value::Boolean(false));
    assert_eq!(value("is-orientable"), Value::Boolean(false));
}

#[test]
fn the_bunny() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/bunny.obj");
    let bunny = io::load(&path).expect("the bunny loads");
    // Topology as pymeshlab 2025.7 reports it (get_topological_measures): closed, genus 0,
    // two-manifold. Angles and normal instability from an independent numpy computation on
    // the same f32 positions (arctan2 of |cross| and dot, per corner and per edge).
    let expected = Expected {
        vertices: 1839,
        edges: 5511,
        triangles: 3674,
        components: 1,
        holes: 0,
        manifold: true,
        oriented: true,
        orientable: true,
        min_angle: 13.191354334093175,
        max_angle: 150.17635133300186,
        normal_instability: 11.334689372934205,
    };
    Checks::load().assert_all("bunny", &bunny, &expected);
}

#[test]
fn a_raw_scan_gives_the_same_answers_as_the_sdk_natively() {
    let checks = Checks::load();
    let spec = ScanSpec { vertices: 20_000, components: 12, holes: 15, noise: 0.2, seed: 5 };
    let mesh = scan(&spec);
    let (v, t) = (mesh.vertex_count(), &mesh.triangles);
    let he = HalfEdges::new(v, t);
    let components = TriangleComponents::new(v, t).count();
    let holes = topology::boundary_loops(t, &he).len();
    // The generator's promise: the main surface, the debris, the holes, defects.
    assert!(components > spec.components && holes >= spec.holes + spec.components);
    let integer = |n: usize| Value::Integer(n as i64);
    assert_eq!(checks.run("vertex-count", &mesh), integer(v));
    assert_eq!(checks.run("triangle-count", &mesh), integer(mesh.triangle_count()));
    assert_eq!(checks.run("edge-count", &mesh), integer(he.edge_count()));
    assert_eq!(checks.run("component-count", &mesh), integer(components));
    assert_eq!(checks.run("hole-count", &mesh), integer(holes));
    assert_eq!(checks.run("is-manifold", &mesh), Value::Boolean(false));
    let oriented = topology::is_oriented(&he);
    assert_eq!(checks.run("is-oriented", &mesh), Value::Boolean(oriented));
    let orientable = topology::is_orientable(&he);
    assert_eq!(checks.run("is-orientable", &mesh), Value::Boolean(orientable));
    let real = |service| match checks.run(service, &mesh) {
        Value::Real(x) => x,
        other => panic!("{service} gave {other:?}"),
    };
    let (min, max) = (real("min-angle"), real("max-angle"));
    assert!(0.0 < min && min < 60.0 && 60.0 < max && max < 180.0, "{min} {max}");
    let instability = real("normal-instability");
    assert!(instability > 0.0 && instability < 90.0, "{instability}");
}

#[test]
fn repeated_corners_and_duplicated_triangles_are_not_manifold_in_the_sandbox() {
    let checks = Checks::load();
    let positions = vec![0., 0., 0., 1., 0., 0., 0., 1., 0.];
    // The mesh: the triangle `1 1 1` many times (every vertex "has no triangle").
    let degenerate = MeshData::new(positions.clone(), [1, 1, 1].repeat(100_000));
    assert_eq!(checks.run("is-manifold", &degenerate), Value::Boolean(false));
    // One triangle twice: each edge has exactly two triangles, yet it is no surface.
    let duplicated = MeshData::new(positions.clone(), vec![0, 1, 2, 0, 2, 1]);
    assert_eq!(checks.run("is-manifold", &duplicated), Value::Boolean(false));
    // The single triangle is manifold: the check can still say yes.
    let single = MeshData::new(positions, vec![0, 1, 2]);
    assert_eq!(checks.run("is-manifold", &single), Value::Boolean(true));
}
