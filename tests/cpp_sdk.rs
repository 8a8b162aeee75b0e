//! The C++ SDK header (sdk/cpp/include/meshflow.hpp) as a C++ author uses it: every `Mesh`
//! wrapper of the WIT mesh (attributes included), `MESHFLOW_TRY`, formatted `fail`, direct
//! parameter getters, builders on named objects, capturing lambdas and a filter declared to
//! run in blocks (tests/cpp_sdk/api.cpp), built with `-Wall -Wextra` in a project `meshflow
//! plugin new --lang cpp` wrote, and run by a host.

mod common;

use std::collections::HashSet;
use std::path::Path;
use std::process::Command;

use common::process::meshflow_in;
use meshflow_mesh::partition::Partitioning;

#[test]
fn every_part_of_the_cpp_header_works_against_a_host() {
    let scratch = tempfile::tempdir().unwrap();
    let dir = scratch.path();
    assert!(
        meshflow_in(dir, &["plugin", "new", "sdk-api", "--lang", "cpp", "--dir", "p"])
            .status
            .success()
    );
    let project = dir.join("p");
    for file in std::fs::read_dir(project.join("src")).unwrap() {
        std::fs::remove_file(file.unwrap().path()).unwrap();
    }
    let api = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/cpp_sdk/api.cpp");
    std::fs::copy(api, project.join("src/api.cpp")).unwrap();
    let made = Command::new("make")
        .current_dir(&project)
        .arg(format!("MESHFLOW={}", env!("CARGO_BIN_EXE_meshflow")))
        .arg("CXX=clang++-19 -Werror")
        .env("MESHFLOW_CACHE_DIR", Path::new(env!("CARGO_TARGET_TMPDIR")).join("components"))
        .output()
        .expect("running make (scripts/test.sh installs clang-19 and wasi-libc)");
    let log = format!(
        "{}{}",
        String::from_utf8_lossy(&made.stdout),
        String::from_utf8_lossy(&made.stderr)
    );
    assert!(made.status.success(), "make failed:\n{log}");
    assert!(
        log.contains("rounds (an integer, default 3, range [1, 10]): Split and collapse rounds."),
        "{log}"
    );

    let plugin = project.join("build/sdk-api.wasm").display().to_string();
    let bunny = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data/bunny.obj");
    let bunny = bunny.display().to_string();
    let edited = dir.join("edited.ply").display().to_string();
    let out =
        meshflow_in(dir, &["apply", "sdk-api-edits", &bunny, "-o", &edited, "--plugin", &plugin]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // The refused edit came back as a value with the host's reason; removed vertices listed.
    assert!(stdout.contains("edit refused (invalid triangle)"), "{stdout}");
    assert!(stdout.contains("removed=9 "), "{stdout}");
    // The connectivity the host derives reads as the triangles say.
    assert!(stdout.contains("edges-agree=1 opposites-agree=1"), "{stdout}");

    let out = meshflow_in(dir, &["check", "sdk-api-fail", &bunny, "--plugin", &plugin]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("3674 triangles and a failure"), "{stderr}");

    // Attributes written through the header reach the host's result, and its file.
    let coloured = dir.join("coloured.ply").display().to_string();
    let out = meshflow_in(
        dir,
        &["apply", "sdk-api-attributes", &bunny, "-o", &coloured, "--plugin", &plugin],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        stdout.contains("attributes=color:4x0,quality:1x3,label:1x1, same=1 missing=1"),
        "{stdout}"
    );
    let ply = std::fs::read(&coloured).unwrap();
    let header = String::from_utf8_lossy(&ply[..ply.len().min(600)]);
    assert!(header.contains("quality") && header.contains("red"), "{header}");
    // A check reads, and is refused writing.
    let out = meshflow_in(
        dir,
        &["check", "sdk-api-quality-in-check", &coloured, "--plugin", &plugin, "--json"],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let value: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        value["value"],
        "edit refused (read-only mesh): set-attribute refused: a check may not edit the mesh"
    );

    let cleared = dir.join("cleared.ply").display().to_string();
    let out =
        meshflow_in(dir, &["apply", "sdk-api-clear", &bunny, "-o", &cleared, "--plugin", &plugin]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && stdout.contains("sdk-api-clear: 0 left"), "{stdout}");

    // Service::blocks: the host asks, and on the bunny (3,674 triangles) over the declared
    // 1,000 runs the filter on each block as a mesh of its own. It lifts what is off the
    // boundary, and a block's border is a boundary: the result is the whole run's but for
    // the vertices blocks share, which stay where they were.
    let apply = |service: &str, out: &str, more: &[&str]| {
        let out = dir.join(out).display().to_string();
        let mut args = vec!["apply", service, &bunny, "-o", &out, "--plugin", &plugin, "--json"];
        args.extend(more);
        let answer = meshflow_in(dir, &args);
        assert!(answer.status.success(), "{}", String::from_utf8_lossy(&answer.stderr));
        let summary: serde_json::Value = serde_json::from_slice(&answer.stdout).unwrap();
        (summary, meshflow_meshio::load(Path::new(&out)).unwrap())
    };
    let input = meshflow_meshio::load(Path::new(&bunny)).unwrap();
    let (whole, whole_mesh) = apply("sdk-api-lift", "whole.ply", &[]);
    assert!(whole["partitions"].is_null(), "{whole}");
    let (blocked, blocked_mesh) = apply("sdk-api-lift-in-blocks", "blocks.ply", &[]);
    let cut = Partitioning::new(&input, 1000);
    let blocks = cut.blocks();
    assert!(blocks.len() >= 3, "{}", blocks.len());
    assert_eq!(blocked["partitions"]["count"], blocks.len(), "{blocked}");
    assert!(blocked["report"].as_str().unwrap().contains("blocks"), "{blocked}");
    let shared: HashSet<usize> = (0..blocks.len())
        .flat_map(|i| {
            let block = blocks.block(i);
            block.shared.iter().map(|&v| block.vertices[v as usize] as usize).collect::<Vec<_>>()
        })
        .collect();
    assert_eq!(shared.len(), blocks.shared_count());
    let at = |mesh: &meshflow_mesh::MeshData, v: usize| {
        mesh.positions[3 * v..][..3].iter().map(|c| c.to_bits()).collect::<Vec<_>>()
    };
    assert_eq!(blocked_mesh.vertex_count(), input.vertex_count());
    for v in 0..input.vertex_count() {
        let expected = if shared.contains(&v) { at(&input, v) } else { at(&whole_mesh, v) };
        assert_eq!(at(&blocked_mesh, v), expected, "vertex {v} (shared: {})", shared.contains(&v));
    }
    assert_ne!(blocked["output_hash"], whole["output_hash"]);
    // Another host, with other limits, cuts the same blocks: the same hash.
    let limits = ["--max-partition-triangles", "500", "--memory-cap", "1024"];
    let (again, _) = apply("sdk-api-lift-in-blocks", "again.ply", &limits);
    assert_eq!(again["output_hash"], blocked["output_hash"]);
    // Declared, but 0 triangles: none, so whole, as the service without the declaration.
    let (zero, _) = apply("sdk-api-lift-in-blocks", "zero.ply", &["--param", "block-triangles=0"]);
    assert!(zero["partitions"].is_null(), "{zero}");
    assert_eq!(zero["output_hash"], whole["output_hash"]);
}
