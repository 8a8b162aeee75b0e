//! The C++ SDK's native test harness (`sdk/cpp/native`, `make test`) in projects that
//! `meshflow plugin new --lang cpp` wrote into empty folders: the template's own test passes;
//! the same Taubin run natively and built to .wasm and run by a host reach the same content
//! hash, bit for bit; an edit a host refuses is refused natively with the same kind and the
//! same message, and a check cannot edit on either.

mod common;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use common::process::meshflow_in;

fn bunny() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data/bunny.obj").display().to_string()
}

/// A project `plugin new NAME --lang cpp` wrote into `dir`.
fn new_project(dir: &Path, name: &str) -> PathBuf {
    let out = meshflow_in(dir, &["plugin", "new", name, "--lang", "cpp"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let project = dir.join(name);
    assert!(project.join("meshflow-sdk/lib/libmeshflow_native.so").is_file());
    project
}

/// `make ARGS` in `project`; its output, after asserting it succeeded.
fn make(project: &Path, args: &[&str]) -> String {
    let out = Command::new("make")
        .current_dir(project)
        .args(args)
        .arg(format!("MESHFLOW={}", env!("CARGO_BIN_EXE_meshflow")))
        .env("MESHFLOW_CACHE_DIR", common::components_cache())
        .output()
        .expect(
            "running make (scripts/test.sh installs clang-19, wasi-libc, libc++-19-dev and \
             libclang-rt-19-dev)",
        );
    let log =
        format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "make {args:?} failed:\n{log}");
    log
}

#[test]
fn the_template_tests_natively_and_agrees_with_a_host_bit_for_bit() {
    let scratch = tempfile::tempdir().unwrap();
    let project = new_project(scratch.path(), "smooth");

    // The library implements every function plugin.h declares but the plugin's exports.
    let header = std::fs::read_to_string(project.join("meshflow-sdk/generated/plugin.h")).unwrap();
    let library = std::fs::read(project.join("meshflow-sdk/lib/libmeshflow_native.so")).unwrap();
    let declared: Vec<&str> = header
        .lines()
        .filter(|l| !l.starts_with(' ') && !l.starts_with('#') && l.ends_with(");"))
        .filter_map(|l| l.split('(').next()?.rsplit([' ', '*']).next())
        .filter(|name| !name.starts_with("exports_meshflow_geometry_service_describe"))
        .filter(|name| *name != "exports_meshflow_geometry_service_run")
        .filter(|name| *name != "exports_meshflow_geometry_locality_reach")
        .filter(|name| *name != "exports_meshflow_geometry_blocks_block_triangles")
        .collect();
    assert!(declared.len() > 60, "{declared:?}");
    let missing: Vec<&&str> = declared
        .iter()
        .filter(|name| {
            !library.windows(name.len() + 2).any(|w| w == format!("\0{name}\0").as_bytes())
        })
        .collect();
    assert!(missing.is_empty(), "libmeshflow_native.so lacks {missing:?}");

    let log = make(&project, &["test"]);
    assert!(
        log.contains("on test/patch.obj: 144 vertices") && log.contains("ok: 0 failed"),
        "{log}"
    );

    // The same service on the bunny: natively, then as a component on the host's runtime.
    let log = make(&project, &["test", &format!("TEST_MESH={}", bunny())]);
    let line = log.lines().find(|l| l.starts_with("taubin-smoothing-cpp on ")).expect(&log);
    let native_hash = line.rsplit(' ').next().unwrap();
    let native_edits: u64 =
        line.split(", ").find_map(|p| p.strip_suffix(" edits")?.parse().ok()).unwrap();
    make(&project, &[]);
    let out = meshflow_in(
        &project,
        &[
            "apply",
            "taubin-smoothing-cpp",
            &bunny(),
            "-o",
            "smooth.ply",
            "--param",
            "iterations=5",
            "--plugin",
            "build/smooth.wasm",
            "--json",
        ],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let host: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_ne!(host["output_hash"], host["input_hash"], "Taubin moved nothing");
    // x86-64 and wasm both compute IEEE doubles without FMA here (-ffp-contract=off): the
    // same code gives the same bits.
    assert_eq!(host["output_hash"], native_hash, "native: {line}");
    assert_eq!(host["edits"], native_edits);
}

#[test]
fn edits_a_host_refuses_are_refused_natively_alike_and_a_check_cannot_edit() {
    let scratch = tempfile::tempdir().unwrap();
    let project = new_project(scratch.path(), "refusals");
    for folder in ["src", "test"] {
        std::fs::remove_dir_all(project.join(folder)).unwrap();
        std::fs::create_dir(project.join(folder)).unwrap();
    }
    let here = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/cpp_native");
    std::fs::copy(here.join("edits.cpp"), project.join("src/edits.cpp")).unwrap();
    std::fs::copy(here.join("edits_test.cpp"), project.join("test/edits_test.cpp")).unwrap();

    // Natively: each refusal's kind (checked by edits_test.cpp) and message.
    let log = make(&project, &["test", &format!("TEST_MESH={}", bunny())]);
    let native: HashMap<&str, (&str, &str)> = log
        .lines()
        .filter_map(|line| {
            let mut fields = line.splitn(3, '\t');
            Some((fields.next()?, (fields.next()?, fields.next()?)))
        })
        .collect();
    assert_eq!(native["repeat-corner"].0, "repeated vertex", "{log}");
    assert_eq!(native["move-removed"].0, "invalid vertex", "{log}");
    assert_eq!(native["clear-in-check"].0, "read-only mesh", "{log}");
    assert_eq!(native["bad-attribute-shape"].0, "invalid argument", "{log}");
    assert_eq!(native["quality-in-check"].0, "read-only mesh", "{log}");

    // On a host: the same services as a component; the same messages.
    make(&project, &[]);
    let plugin = "build/refusals.wasm";
    for (service, command) in [
        ("repeat-corner", "apply"),
        ("move-removed", "apply"),
        ("clear-in-check", "check"),
        ("bad-attribute-shape", "apply"),
        ("quality-in-check", "check"),
    ] {
        let input = bunny();
        let mut args = vec![command, service, &input, "--plugin", plugin];
        if command == "apply" {
            args.extend(["-o", "out.ply"]);
        }
        let out = meshflow_in(&project, &args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "the host ran {service}");
        let message = native[service].1;
        assert!(message.starts_with(&format!("{service}: edit refused (")), "{message}");
        assert!(stderr.contains(message), "{service}: the host said {stderr}, natively {message}");
    }
    let out =
        meshflow_in(&project, &["check", "edit-in-check", &bunny(), "--plugin", plugin, "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let host: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let value = native["edit-in-check"].1;
    assert_eq!(
        value,
        "edit refused (read-only mesh): clear refused: a check may not edit the mesh"
    );
    assert_eq!(host["value"], value);

    // Attributes written natively and on a host: the same result, to the content hash.
    let out = meshflow_in(
        &project,
        &["apply", "write-attributes", &bunny(), "-o", "written.ply", "--plugin", plugin, "--json"],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let host: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(host["output_hash"], native["write-attributes"].1, "{log}");
}
