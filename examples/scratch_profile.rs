// TEMPORARY profiling harness (not to be committed).
#[path = "../benches/common/mod.rs"]
mod common;
use meshflow_builtin_plugins::PLUGINS;
use meshflow_host::generate::scan;
use meshflow_host::runtime::{Limits, Runtime, Value};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (plugin_name, service, mode, n) = (&args[1], &args[2], &args[3], args[4].parse::<usize>().unwrap());
    let mesh = scan(&common::SCAN_1M);
    let runtime = Runtime::new(Limits::default(), None).unwrap();
    let wasm = PLUGINS.iter().find(|p| p.name == plugin_name).unwrap().wasm;
    let plugin = runtime.load(wasm).unwrap();
    eprintln!("ready");
    for _ in 0..n {
        let t = Instant::now();
        if mode == "wasm" {
            let out = runtime.run(&plugin, service, &mesh, &[]).unwrap();
            eprintln!("{:?} {:?} {}", t.elapsed(), out.value, out.report);
        } else {
            let v = match service.as_str() {
                "edge-count" => Value::Integer(meshflow_plugin_checks::counts::edge_count(mesh.vertex_count(), &mesh.triangles) as i64),
                "normal-instability" => Value::Real(meshflow_plugin_checks::normals::normal_instability(&mesh.positions, &mesh.triangles)),
                "fill-holes" => { let f = meshflow_plugin_holes::fill::fill_holes(&mesh.positions, &mesh.triangles, meshflow_plugin_holes::fill::Settings{max_hole_edges:500, refine:true, fairing_iterations:100}); Value::Integer(f.new_triangles.len() as i64) }
                _ => panic!(),
            };
            eprintln!("{:?} {:?}", t.elapsed(), v);
        }
    }
}
