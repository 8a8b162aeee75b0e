//! The C++ SDK header (sdk/cpp/include/meshflow.hpp) as a C++ author uses it: every `Mesh`
//! wrapper of the WIT mesh (attributes included), `MESHFLOW_TRY`, formatted `fail`, direct
//! parameter getters, builders on named objects and capturing lambdas
//! (tests/cpp_sdk/api.cpp), built with `-Wall -Wextra` in a project `meshflow plugin new
//! --lang cpp` wrote, and run by a host.

mod common;

use std::path::Path;
use std::process::Command;

use common::process::meshflow_in;

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
}
