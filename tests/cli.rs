//! The `meshflow` command line, end to end: real files, real plugins, real exit codes.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use common::process::{UpProcess, failure, meshflow, ok};

fn bunny() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data/bunny.obj").display().to_string()
}

fn json(text: &str) -> serde_json::Value {
    serde_json::from_str(text).unwrap_or_else(|e| panic!("not JSON ({e}): {text}"))
}

#[test]
fn apply_smooths_the_bunny_and_reports_hashes_that_match_the_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("smooth.ply").display().to_string();
    let summary = json(&ok(&[
        "apply",
        "laplacian-smoothing",
        &bunny(),
        "-o",
        &out,
        "--param",
        "iterations=2",
        "--json",
    ]));
    assert_eq!(summary["service"], "laplacian-smoothing");
    assert_eq!(summary["vertices"], 1839);
    assert_eq!(summary["triangles"], 3674);
    // One move-all edit of every vertex.
    assert_eq!(summary["edits"], 1839);
    for timing in ["load", "run", "save"] {
        assert!(summary["timings_ms"][timing].as_f64().unwrap() >= 0.0);
    }
    assert_eq!(summary["input_hash"].as_str().unwrap(), ok(&["hash", &bunny()]).trim());
    assert_eq!(summary["output_hash"].as_str().unwrap(), ok(&["hash", &out]).trim());
    assert_ne!(summary["input_hash"], summary["output_hash"]);
    // The same step again gives the same bytes.
    let again = dir.path().join("again.ply").display().to_string();
    ok(&["apply", "laplacian-smoothing", &bunny(), "-o", &again, "--param", "iterations=2"]);
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&again).unwrap());
}

/// A step written as a replay is a few hundred bytes, says what it is, and re-running it
/// gives the same mesh bit for bit; a plugin that is not built in must be given.
#[test]
fn a_replay_correction_names_the_step_and_reruns_to_the_same_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).display().to_string();
    let noisy = path("noisy.ply");
    let (edits, replay) = (path("step.mfc"), path("step.mfr"));
    for (file, kind) in [(&edits, "edits"), (&replay, "replay")] {
        let summary = json(&ok(&[
            "apply",
            "add-noise",
            &bunny(),
            "-o",
            &noisy,
            "--param",
            "seed=7",
            "--correction",
            file,
            "--correction-kind",
            kind,
            "--json",
        ]));
        assert_eq!(summary["correction_bytes"], std::fs::metadata(file).unwrap().len());
    }
    let (edits_bytes, replay_bytes) =
        (std::fs::metadata(&edits).unwrap().len(), std::fs::metadata(&replay).unwrap().len());
    assert!(
        replay_bytes <= 300 && 20 * replay_bytes < edits_bytes,
        "{replay_bytes} vs {edits_bytes}"
    );

    let inspected = json(&ok(&["correction", "inspect", &replay, "--json"]));
    assert_eq!(
        (&inspected["kind"], &inspected["service"]),
        (&"replay".into(), &"add-noise".into())
    );
    assert_eq!(inspected["params"]["seed"], 7);
    assert!(inspected["params"]["amount"].is_number(), "defaults are named: {inspected}");
    assert_eq!(json(&ok(&["correction", "inspect", &edits, "--json"]))["kind"], "edits");

    let rerun = path("rerun.ply");
    ok(&["correction", "apply", &bunny(), &replay, "-o", &rerun]);
    assert_eq!(ok(&["hash", &rerun]), ok(&["hash", &noisy]));
    // Not the base it names: refused, nothing written.
    let wrong = path("wrong.ply");
    let error = failure(&["correction", "apply", &noisy, &replay, "-o", &wrong]);
    assert!(error.contains("the replay is for mesh"), "{error}");
    assert!(!Path::new(&wrong).exists());

    // A plugin that is not built in: the replay names it, and needs it given.
    let plugin = path("hostile.wasm");
    std::fs::write(&plugin, meshflow_builtin_plugins::fixture("hostile")).unwrap();
    let flipped = path("flipped.ply");
    let own = path("own.mfr");
    ok(&[
        "apply",
        "ignore-bad-edits",
        &bunny(),
        "-o",
        &flipped,
        "--plugin",
        &plugin,
        "--correction",
        &own,
        "--correction-kind",
        "auto",
    ]);
    assert_eq!(json(&ok(&["correction", "inspect", &own, "--json"]))["kind"], "replay");
    let error = failure(&["correction", "apply", &bunny(), &own, "-o", &path("x.ply")]);
    assert!(error.contains("--plugin") && error.contains("ignore-bad-edits"), "{error}");
    let again = path("again.ply");
    ok(&["correction", "apply", &bunny(), &own, "-o", &again, "--plugin", &plugin]);
    assert_eq!(ok(&["hash", &again]), ok(&["hash", &flipped]));
}

#[test]
fn an_operator_sets_how_long_a_plugin_run_may_take() {
    let dir = tempfile::tempdir().unwrap();
    let plugin = dir.path().join("hostile.wasm");
    std::fs::write(&plugin, meshflow_builtin_plugins::fixture("hostile")).unwrap();
    let (plugin, out) = (plugin.to_str().unwrap(), dir.path().join("out.ply"));
    let run = |deadline: &str| {
        let args = ["apply", "loop-forever", &bunny(), "-o", out.to_str().unwrap(), "--plugin"];
        let started = std::time::Instant::now();
        let error = failure(&[&args[..], &[plugin, "--run-deadline", deadline]].concat());
        (error, started.elapsed())
    };
    let (error, took) = run("1");
    assert!(error.contains("deadline of 1s"), "{error}");
    // Well before the default deadline of a minute.
    assert!(took < std::time::Duration::from_secs(30), "{took:?}");
    for refused in ["0", "3601", "soon"] {
        let (error, _) = run(refused);
        assert!(error.contains("--run-deadline"), "{refused}: {error}");
    }
    assert!(!out.exists());
}

#[test]
fn check_and_info_report_the_bunny() {
    assert_eq!(ok(&["check", "vertex-count", &bunny()]).trim(), "1839");
    let value = json(&ok(&["check", "triangle-count", &bunny(), "--json"]));
    assert_eq!(value["value"], 3674);
    let info = json(&ok(&["info", &bunny(), "--json"]));
    assert_eq!(info["vertices"], 1839);
    assert_eq!(info["bbox"]["min"].as_array().unwrap().len(), 3);
}

#[test]
fn a_malformed_mesh_is_a_clear_error_and_leaves_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nv 0 1 oops\nf 1 2 3\n").unwrap();
    let out = dir.path().join("out.ply");
    let stderr = failure(&[
        "apply",
        "laplacian-smoothing",
        bad.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(stderr.contains("bad.obj") && stderr.contains("line 3"), "{stderr}");
    assert!(!out.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "a temporary file was left");
}

#[test]
fn unknown_services_and_wrong_kinds_say_what_to_do() {
    let stderr = failure(&["check", "vertex-cuont", &bunny()]);
    assert!(
        stderr.contains("unknown service `vertex-cuont`; did you mean \"vertex-count\"?"),
        "{stderr}"
    );
    assert!(stderr.contains("vertex-count") && stderr.contains("laplacian-smoothing"), "{stderr}");
    let stderr = failure(&["apply", "vertex-count", &bunny(), "-o", "/tmp/never.ply"]);
    assert!(stderr.contains("is a check, not a filter"), "{stderr}");
    let stderr =
        failure(&["apply", "laplacian-smoothing", &bunny(), "-o", "x.ply", "--param", "x"]);
    assert!(stderr.contains("expected NAME=VALUE"), "{stderr}");
    let misspelt =
        ["apply", "laplacian-smoothing", &bunny(), "-o", "x.ply", "--param", "iteratons=2"];
    let stderr = failure(&misspelt);
    assert!(stderr.contains("did you mean \"iterations\"?"), "{stderr}");
}

#[test]
fn services_lists_every_service_with_its_parameters() {
    let services = json(&ok(&["services", "--json"]));
    let smoothing = services
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == "laplacian-smoothing")
        .expect("laplacian-smoothing is listed");
    assert_eq!(smoothing["kind"], "filter");
    assert_eq!(smoothing["params"][0]["name"], "iterations");
    assert_eq!(smoothing["params"][0]["default"], 1);
}

#[test]
fn generate_scan_is_deterministic_by_seed() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).display().to_string();
    let args = |out: &str, seed: &str| {
        ok(&[
            "generate",
            "scan",
            "--vertices",
            "3000",
            "--holes",
            "3",
            "--components",
            "2",
            "--seed",
            seed,
            "-o",
            out,
        ]);
    };
    args(&path("a.ply"), "5");
    args(&path("b.ply"), "5");
    args(&path("c.ply"), "6");
    let hash = |name: &str| ok(&["hash", &path(name)]);
    assert_eq!(hash("a.ply"), hash("b.ply"));
    assert_ne!(hash("a.ply"), hash("c.ply"));
}

/// The README's walkthrough: the example plugin, built only on the SDK, runs in the CLI.
/// The code blocks of the Rust template's README that name a file (```toml Cargo.toml),
/// joined per file in order: the crate the README makes.
fn readme_crate() -> BTreeMap<String, String> {
    let readme = std::fs::read_to_string(template_dir().join("README.md")).unwrap();
    let mut files = BTreeMap::<String, String>::new();
    let mut open: Option<String> = None;
    for line in readme.lines() {
        match (&open, line.strip_prefix("```")) {
            (None, Some(info)) => {
                open =
                    Some(info.split_once(' ').map(|(_, name)| name.to_owned()).unwrap_or_default())
            }
            (Some(_), Some("")) => open = None,
            (Some(name), _) if !name.is_empty() => {
                let file = files.entry(name.clone()).or_default();
                file.push_str(line);
                file.push('\n');
            }
            _ => {}
        }
    }
    files
}

fn template_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/plugin-template")
}

#[test]
fn the_template_crate_is_what_its_readme_says() {
    let files = readme_crate();
    let names: Vec<&str> = files.keys().map(String::as_str).collect();
    assert_eq!(names, [".cargo/config.toml", "Cargo.toml", "src/lib.rs"]);
    for (name, text) in &files {
        let actual = std::fs::read_to_string(template_dir().join(name)).unwrap();
        // The template's manifest adds only a patch to the checkout's SDK.
        assert!(actual.starts_with(text.as_str()), "{name} differs from the README");
        assert_eq!(actual.len() == text.len(), name != "Cargo.toml", "{name}");
    }
}

#[test]
fn a_crate_pasted_from_the_template_readme_builds_and_runs_outside_the_checkout() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scratch = tempfile::tempdir().unwrap();
    for (name, text) in readme_crate() {
        let path = scratch.path().join(&name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }
    // The README's git URL, pointed at this checkout's SDK; the template's lock pins the
    // same versions as the workspace, so the build needs no network.
    let mut manifest = std::fs::read_to_string(scratch.path().join("Cargo.toml")).unwrap();
    let sdk = root.join("sdk");
    manifest.push_str(&format!(
        "\n[patch.\"file:///home/me/src/meshflow\"]\nmeshflow-plugin-sdk = {{ path = {:?} }}\n",
        sdk.display().to_string()
    ));
    std::fs::write(scratch.path().join("Cargo.toml"), manifest).unwrap();
    std::fs::copy(template_dir().join("Cargo.lock"), scratch.path().join("Cargo.lock")).unwrap();

    let target_dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("plugin-template");
    let status = Command::new(env!("CARGO"))
        .current_dir(scratch.path())
        .args(["build", "--release", "--offline", "--target", "wasm32-wasip2", "--target-dir"])
        .arg(&target_dir)
        .status()
        .expect("running cargo");
    assert!(status.success(), "building the README's crate failed");
    let wasm: PathBuf = target_dir.join("wasm32-wasip2/release/surface_tools.wasm");
    let plugin = wasm.to_str().unwrap();

    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.ply").display().to_string();
    let area = |mesh: &str| -> f64 {
        ok(&["check", "total-area", mesh, "--plugin", plugin]).trim().parse().unwrap()
    };
    let apply = ["apply", "scale-about-centroid", &bunny(), "-o", &big, "--param", "factor=3"];
    ok(&[&apply[..], &["--plugin", plugin]].concat());
    let ratio = area(&big) / area(&bunny());
    assert!((ratio - 9.0).abs() < 1e-3, "area grew by {ratio}, not 9");
}

#[test]
fn a_build_without_cdylib_or_for_another_target_gets_told_what_to_change() {
    let dir = tempfile::tempdir().unwrap();
    let release = dir.path().join("target/wasm32-wasip2/release");
    std::fs::create_dir_all(&release).unwrap();
    let wasm = release.join("surface_tools.wasm").display().to_string();
    let error = failure(&["services", "--plugin", &wasm]);
    assert!(error.contains("--target wasm32-wasip2"), "{error}");
    // A crate without `crate-type = ["cdylib"]` leaves only the rlib.
    std::fs::write(release.join("libsurface_tools.rlib"), b"!<arch>\n").unwrap();
    let error = failure(&["services", "--plugin", &wasm]);
    assert!(error.contains("crate-type = [\"cdylib\", \"rlib\"]"), "{error}");
    // A core module (wasm32-unknown-unknown, wasip1) is not a component.
    std::fs::write(&wasm, b"\0asm\x01\0\0\0").unwrap();
    let error = failure(&["services", "--plugin", &wasm]);
    assert!(error.contains("wasm32-wasip2") && error.contains("plugin componentize"), "{error}");
}

#[test]
fn a_reader_that_stops_early_does_not_make_meshflow_panic() {
    for args in [&["services"][..], &["services", "--json"], &["info", &bunny(), "--json"]] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_meshflow"))
            .args(args)
            .env("MESHFLOW_CACHE_DIR", Path::new(env!("CARGO_TARGET_TMPDIR")).join("components"))
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // `| head -0`: the pipe closes before meshflow writes.
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success() && stderr.is_empty(), "meshflow {args:?}: {stderr}");
    }
}

/// A one-step workflow file in `dir`.
fn one_step_workflow(dir: &Path) -> String {
    let path = dir.join("degenerate.json");
    std::fs::write(&path, r#"{"steps": [{"run": "remove-degenerate-triangles"}]}"#).unwrap();
    path.display().to_string()
}

#[test]
fn run_goes_through_an_embedded_engine_and_hosts_with_fresh_tokens() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.ply").display().to_string();
    let workflow = one_step_workflow(dir.path());
    ok(&["run", &workflow, &bunny(), "-o", &out, "--hosts", "2", "--layout", "all"]);
    assert!(Path::new(&out).is_file());
    // Across hosts that each offer one family, every step travels as its replay.
    let repair = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/workflows/repair.json");
    let report = dir.path().join("r.json");
    let args = ["--transfer", "replay", "--report", &report.display().to_string()];
    ok(&[&["run", &repair.display().to_string(), &bunny(), "-o", &out][..], &args].concat());
    let record = json(&std::fs::read_to_string(&report).unwrap());
    let transfers: Vec<&serde_json::Value> = record["steps"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|s| s["transfers"].as_array().unwrap())
        .collect();
    assert!(!transfers.is_empty(), "{record}");
    for t in transfers {
        assert_eq!(
            (&t["asked"], &t["via"], &t["fallback"]),
            (&"replay".into(), &"replay".into(), &serde_json::Value::Null),
            "{t}"
        );
    }
}

#[test]
fn up_prints_the_ui_address_with_its_token_and_submit_needs_that_token() {
    let up = UpProcess::start(&["--hosts", "2", "--layout", "all", "--listen", "127.0.0.1:0"]);
    let engine = up.field("engine: ");
    let token = up.field("export MESHFLOW_API_TOKEN=");
    assert_eq!(token.len(), 64, "{}", up.printed);
    assert_eq!(up.field("web UI: "), format!("{engine}/#token={token}"));

    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.ply").display().to_string();
    let workflow = one_step_workflow(dir.path());
    let submit = |token: Option<&str>| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_meshflow"));
        command.args(["submit", "--engine", &engine, &workflow, "--input", &bunny(), "-o", &out]);
        command.env_remove("MESHFLOW_API_TOKEN");
        if let Some(token) = token {
            command.env("MESHFLOW_API_TOKEN", token);
        }
        command.output().expect("running meshflow submit")
    };
    let refused = submit(None);
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("401"), "{refused:?}");
    let done = submit(Some(&token));
    assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
    assert!(Path::new(&out).is_file());
}

#[test]
fn run_over_several_meshes_writes_a_summary_row_each_and_a_broken_one_fails_alone() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).display().to_string();
    std::fs::write(
        path("smooth.json"),
        r#"[{"run": "laplacian-smoothing"}, {"if": {"check": "hole-count", "op": ">=", "value": 0}, "then": []}]"#,
    )
    .unwrap();
    std::fs::copy(bunny(), path("bunny.obj")).unwrap();
    std::fs::write(path("broken.ply"), "ply\nformat ascii 1.0\nnonsense\n").unwrap();
    std::fs::write(path("list.txt"), "broken.ply\n").unwrap();
    let stderr = failure(&[
        "run",
        &path("smooth.json"),
        &bunny(),
        &path("bunny.obj"),
        "--inputs",
        &path("list.txt"),
        "--out-dir",
        &path("out"),
        "--hosts",
        "2",
        "--layout",
        "all",
    ]);
    assert!(stderr.contains("1 of 3 inputs failed: broken.ply"), "{stderr}");
    let rows = json(&std::fs::read_to_string(path("out/summary.json")).unwrap());
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 3);
    assert_eq!(
        (rows[0]["status"].as_str(), rows[1]["status"].as_str()),
        (Some("completed"), Some("completed"))
    );
    assert_eq!(
        rows[0]["result_hash"], rows[1]["result_hash"],
        "the same mesh gives the same result"
    );
    assert_eq!(rows[2]["status"], "failed");
    let csv = std::fs::read_to_string(path("out/summary.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    assert!(header.starts_with("name,status,error,vertices_in,triangles_in"), "{header}");
    assert!(header.ends_with("hole-count [steps[1].if]"), "{header}");
    assert_eq!(csv.lines().count(), 4, "{csv}");
    // The results, named after their inputs, are the recorded meshes; a record re-runs
    // bit-identically from the file.
    let result_hash = ok(&["hash", &path("out/bunny.ply")]);
    assert!(result_hash.contains(rows[0]["result_hash"].as_str().unwrap()), "{result_hash}");
    assert!(Path::new(&path("out/bunny-2.ply")).is_file());
    let said = ok(&[
        "rerun",
        &path("out/records/bunny.json"),
        "--input",
        &bunny(),
        "-o",
        &path("again.ply"),
        "--hosts",
        "1",
    ]);
    assert!(said.contains("bit-identical"), "{said}");
    let other = failure(&[
        "rerun",
        &path("out/records/bunny.json"),
        "--input",
        &path("broken.ply"),
        "--hosts",
        "1",
    ]);
    assert!(other.contains("diverged"), "{other}");
}

#[test]
fn meshlab_scripts_convert_to_workflows_and_back() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).display().to_string();
    // Saved as pymeshlab's MeshSet.save_filter_script writes scripts (pymeshlab is not
    // needed to run this test).
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/pymeshlab-repair.mlx");
    let out =
        meshflow(&["workflow", "from-mlx", &script.display().to_string(), "-o", &path("w.json")]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let notes = String::from_utf8_lossy(&out.stderr);
    assert!(notes.contains("-> quadric-decimation"), "{notes}");
    let workflow = json(&std::fs::read_to_string(path("w.json")).unwrap());
    assert_eq!(workflow["steps"][1]["run"], "laplacian-smoothing");
    // Every filter of the script has a built-in service now.
    assert!(!notes.contains("no built-in plugin offers"), "{notes}");
    assert_eq!(workflow["steps"][4]["run"], "quadric-decimation");
    ok(&["workflow", "to-mlx", &path("w.json"), "-o", &path("back.mlx"), "--mesh", &bunny()]);
    let back = std::fs::read_to_string(path("back.mlx")).unwrap();
    assert!(back.contains("<filter name=\"Laplacian Smooth\">"), "{back}");
    std::fs::write(
        path("poisson.mlx"),
        "<FilterScript><filter name=\"Surface Reconstruction: Screened Poisson\"/></FilterScript>",
    )
    .unwrap();
    let refused = failure(&["workflow", "from-mlx", &path("poisson.mlx"), "-o", &path("p.json")]);
    assert!(refused.contains("Screened Poisson"), "{refused}");
}

/// Two consecutive ports free right now (the OS picks the first).
fn two_free_ports() -> u16 {
    for _ in 0..20 {
        let first = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let port = first.local_addr().unwrap().port();
        if port < u16::MAX && std::net::TcpListener::bind(("127.0.0.1", port + 1)).is_ok() {
            return port;
        }
    }
    panic!("no two consecutive free ports");
}

/// `up` makes an upload token like its other tokens and prints it; its hosts listen on the
/// ports asked for and take a plugin with that token (and refuse it without).
#[test]
fn up_prints_an_upload_token_and_its_hosts_on_fixed_ports_take_plugins() {
    let first = two_free_ports();
    let ports = first.to_string();
    let up = UpProcess::start(&["--hosts", "2", "--listen", "127.0.0.1:0", "--host-ports", &ports]);
    let expected = [format!("http://127.0.0.1:{first}"), format!("http://127.0.0.1:{}", first + 1)];
    assert_eq!(up.hosts(), expected, "{}", up.printed);
    let token = up.field("export MESHFLOW_UPLOAD_TOKEN=");
    assert_eq!(token.len(), 64, "{}", up.printed);

    let dir = tempfile::tempdir().unwrap();
    let wasm = dir.path().join("hostile.wasm");
    std::fs::write(&wasm, meshflow_builtin_plugins::fixture("hostile")).unwrap();
    let upload = |token: &str| {
        Command::new(env!("CARGO_BIN_EXE_meshflow"))
            .args(["plugin", "upload", "--host", &expected[1]])
            .arg(&wasm)
            .env("MESHFLOW_UPLOAD_TOKEN", token)
            .output()
            .unwrap()
    };
    let refused = upload("not-the-upload-token-0123");
    assert!(String::from_utf8_lossy(&refused.stderr).contains("401"), "{refused:?}");
    let uploaded = upload(&token);
    assert!(uploaded.status.success(), "{}", String::from_utf8_lossy(&uploaded.stderr));
    let digest = meshflow_runtime::digest(meshflow_builtin_plugins::fixture("hostile"));

    // A publisher lists with the upload token and deletes by a pin's 12-digit prefix.
    let plugin = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_meshflow"))
            .arg("plugin")
            .args(args)
            .env("MESHFLOW_UPLOAD_TOKEN", &token)
            .env_remove("MESHFLOW_CLUSTER_TOKEN")
            .output()
            .unwrap()
    };
    let listed = plugin(&["list", "--host", &expected[1]]);
    assert!(listed.status.success(), "{}", String::from_utf8_lossy(&listed.stderr));
    assert!(String::from_utf8_lossy(&listed.stdout).contains(&digest));
    let deleted = plugin(&["delete", "--host", &expected[1], &digest[..12]]);
    assert!(deleted.status.success(), "{}", String::from_utf8_lossy(&deleted.stderr));
    assert_eq!(String::from_utf8_lossy(&deleted.stdout).trim(), format!("deleted {digest}"));

    // Through the engine, a workflow pinned to the new plugin is accepted at once.
    let engine = up.field("engine: ");
    let api_token = up.field("export MESHFLOW_API_TOKEN=");
    let v2 = meshflow_builtin_plugins::fixture("smoothing-v2");
    let v2_file = dir.path().join("v2.wasm");
    std::fs::write(&v2_file, v2).unwrap();
    let through_engine = Command::new(env!("CARGO_BIN_EXE_meshflow"))
        .args(["plugin", "upload", "--replace", "--engine", &engine, "--host", &expected[0]])
        .arg(&v2_file)
        .env("MESHFLOW_UPLOAD_TOKEN", &token)
        .env("MESHFLOW_API_TOKEN", &api_token)
        .output()
        .unwrap();
    assert!(through_engine.status.success(), "{}", String::from_utf8_lossy(&through_engine.stderr));
    let pinned = dir.path().join("pinned.json");
    let v2_digest = meshflow_runtime::digest(v2);
    let workflow = format!(
        r#"{{"steps": [{{"run": "laplacian-smoothing", "plugin": "{}"}}]}}"#,
        &v2_digest[..12]
    );
    std::fs::write(&pinned, workflow).unwrap();
    let out = dir.path().join("out.ply");
    let submitted = Command::new(env!("CARGO_BIN_EXE_meshflow"))
        .args(["submit", "--engine", &engine])
        .arg(&pinned)
        .args(["--input", &bunny()])
        .arg("-o")
        .arg(&out)
        .env("MESHFLOW_API_TOKEN", &api_token)
        .output()
        .unwrap();
    assert!(submitted.status.success(), "{}", String::from_utf8_lossy(&submitted.stderr));
}

/// `run --plugin` puts a plugin on the embedded hosts: its service serves its name first,
/// the user hears that it hides the built-in, and the record names its digest.
#[test]
fn run_takes_a_plugin_for_its_embedded_hosts() {
    let dir = tempfile::tempdir().unwrap();
    let v2 = meshflow_builtin_plugins::fixture("smoothing-v2");
    let wasm = dir.path().join("v2.wasm");
    std::fs::write(&wasm, v2).unwrap();
    let workflow = dir.path().join("smooth.json");
    std::fs::write(&workflow, r#"{"steps": [{"run": "laplacian-smoothing"}]}"#).unwrap();
    let workflow = workflow.display().to_string();
    let report = dir.path().join("run.json").display().to_string();
    let out = dir.path().join("out.ply").display().to_string();
    let wasm = wasm.display().to_string();
    let ran =
        meshflow(&["run", &workflow, &bunny(), "-o", &out, "--report", &report, "--plugin", &wasm]);
    let stderr = String::from_utf8_lossy(&ran.stderr);
    assert!(ran.status.success(), "{stderr}");
    let warning = "a --plugin component's `laplacian-smoothing` shadows the built-in service";
    assert_eq!(stderr.matches(warning).count(), 1, "{stderr}");
    let record = json(&std::fs::read_to_string(&report).unwrap());
    let digest = meshflow_runtime::digest(v2);
    assert_eq!(record["steps"][0]["plugin"], digest.as_str(), "{record:#}");
}

/// A coloured scan with double coordinates: `info` lists what it carries and names what
/// meshflow does not keep (the doubles' precision), `apply` keeps the colours and quality
/// and warns about the rest, and `hash` tells two colourings apart (issue 35).
#[test]
fn what_a_file_holds_beyond_the_mesh_is_kept_or_named_not_dropped_silently() {
    let dir = tempfile::tempdir().unwrap();
    let scan = dir.path().join("coloured.ply");
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n\
         property double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
         property float quality\nelement face 1\nproperty list uchar int vertex_indices\n\
         end_header\n0.1 0 0 255 0 0 1\n1 0 0 0 255 0 1\n0 1 0 0 0 255 1\n3 0 1 2\n";
    std::fs::write(&scan, text).unwrap();
    let scan = scan.display().to_string();
    let info = json(&ok(&["info", &scan, "--json"]));
    assert_eq!(
        info["attributes"],
        serde_json::json!(["vertex color (4 × u8)", "vertex quality (1 × f32)"])
    );
    let not_kept = info["not_kept"].as_array().unwrap();
    assert_eq!(not_kept.len(), 1, "{not_kept:?}");
    assert!(not_kept[0].as_str().unwrap().starts_with("double coordinates, rounded to float"));
    let text_info = ok(&["info", &scan]);
    assert!(text_info.contains("attribute: vertex color (4 × u8)\n"), "{text_info}");

    let out = dir.path().join("out.ply").display().to_string();
    let applied = meshflow(&["apply", "remove-degenerate-triangles", &scan, "-o", &out]);
    let stderr = String::from_utf8_lossy(&applied.stderr);
    assert!(applied.status.success(), "{stderr}");
    assert!(stderr.contains("not kept: double coordinates"), "{stderr}");
    let kept = json(&ok(&["info", &out, "--json"]));
    assert_eq!(kept["attributes"], info["attributes"]);
    assert_eq!(kept["not_kept"], serde_json::json!([]), "the output holds all it has");
    let hashed = meshflow(&["hash", &scan]);
    assert!(String::from_utf8_lossy(&hashed.stderr).contains("not kept: double coordinates"));

    // One colour differs: another hash. The saved PLY hashes as the mesh it was made from.
    let recoloured = dir.path().join("recoloured.ply");
    std::fs::write(&recoloured, text.replace("0 1 0 0 0 255 1", "0 1 0 0 0 254 1")).unwrap();
    let recoloured = recoloured.display().to_string();
    assert_ne!(ok(&["hash", &scan]), ok(&["hash", &recoloured]));
    let copy = dir.path().join("copy.ply").display().to_string();
    ok(&["apply", "remove-degenerate-triangles", &out, "-o", &copy]);
    assert_eq!(ok(&["hash", &out]), ok(&["hash", &copy]));

    // Through the engine and its hosts: the run record says what was not kept, and so
    // does `run`.
    let workflow = dir.path().join("w.json");
    std::fs::write(&workflow, r#"{"steps": [{"run": "remove-degenerate-triangles"}]}"#).unwrap();
    let report = dir.path().join("run.json");
    let (workflow, report_path) = (workflow.display().to_string(), report.display().to_string());
    let ran = ok(&["run", &workflow, &scan, "-o", &out, "--report", &report_path]);
    let record = json(&std::fs::read_to_string(&report).unwrap());
    let recorded = record["input"]["not_kept"].as_array().unwrap();
    assert_eq!(recorded.len(), 1, "{record:#}");
    assert!(recorded[0].as_str().unwrap().starts_with("double coordinates"), "{record:#}");
    assert!(ran.contains("warning: the input's double coordinates"), "{ran}");
}

/// Saving a coloured mesh as STL warns, naming what is left out; `--strict` refuses and
/// writes nothing, in every command that saves a mesh.
#[test]
fn saving_a_coloured_mesh_as_stl_warns_and_strict_refuses() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).display().to_string();
    let scan = path("coloured.ply");
    std::fs::write(
        &scan,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n",
    )
    .unwrap();
    let stl = path("out.stl");
    let saved = meshflow(&["apply", "remove-degenerate-triangles", &scan, "-o", &stl]);
    let stderr = String::from_utf8_lossy(&saved.stderr);
    assert!(saved.status.success(), "{stderr}");
    let warning =
        format!("warning: {stl}: STL cannot hold vertex color (4 × u8); saved without it");
    assert!(stderr.contains(&warning), "{stderr}");
    assert!(Path::new(&stl).exists());

    let refused = path("refused.stl");
    let edits = path("step.mfc");
    let error = failure(&[
        "apply",
        "remove-degenerate-triangles",
        &scan,
        "-o",
        &refused,
        "--strict",
        "--correction",
        &edits,
    ]);
    assert!(error.contains("STL cannot hold vertex color (4 × u8)"), "{error}");
    assert!(error.contains("nothing was written"), "{error}");
    assert!(!Path::new(&refused).exists());
    assert!(!Path::new(&edits).exists(), "a refused apply writes no correction either");
    // A format that holds the colours is fine with --strict.
    let ply = path("out.ply");
    ok(&[
        "apply",
        "remove-degenerate-triangles",
        &scan,
        "-o",
        &ply,
        "--strict",
        "--correction",
        &edits,
    ]);

    let error = failure(&["correction", "apply", &scan, &edits, "-o", &refused, "--strict"]);
    assert!(error.contains("STL cannot hold vertex color"), "{error}");
    assert!(!Path::new(&refused).exists());
    let off = path("corrected.off");
    ok(&["correction", "apply", &scan, &edits, "-o", &off, "--strict"]);

    let packed = path("coloured.mfm");
    ok(&["pack", &scan, "-o", &packed]);
    let error = failure(&["unpack", &packed, "-o", &refused, "--strict"]);
    assert!(error.contains("STL cannot hold vertex color"), "{error}");
    assert!(!Path::new(&refused).exists());
    let unpacked = meshflow(&["unpack", &packed, "-o", &stl]);
    assert!(String::from_utf8_lossy(&unpacked.stderr).contains("STL cannot hold vertex color"));
}

/// The cases of issue 35 through `apply`: a scan's flags and quality, a PLY's normals and
/// colours through smoothing, and a textured OBJ whose coordinates, library and texture
/// come along.
#[test]
fn apply_keeps_what_scans_and_textured_meshes_carry() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).display().to_string();
    // Two triangles and a separate small one, each vertex with flags and quality.
    let scan = path("scan.ply");
    std::fs::write(
        &scan,
        "ply\nformat ascii 1.0\nelement vertex 7\nproperty float x\nproperty float y\n\
         property float z\nproperty uchar flags\nproperty float quality\nelement face 3\n\
         property list uchar int vertex_indices\nend_header\n\
         0 0 0 1 0.5\n4 0 0 2 0.25\n4 4 0 3 0.125\n0 4 0 4 1\n9 9 9 5 2\n9.1 9 9 6 3\n9 9.1 9 7 4\n\
         3 0 1 2\n3 0 2 3\n3 4 5 6\n",
    )
    .unwrap();
    let cleaned = path("cleaned.ply");
    ok(&["apply", "remove-smallest-components", &scan, "-o", &cleaned]);
    let info = json(&ok(&["info", &cleaned, "--json"]));
    assert_eq!(
        info["attributes"],
        serde_json::json!(["vertex flags (1 × u8)", "vertex quality (1 × f32)"]),
        "{info}"
    );

    // Normals and colours, smoothed: both still there.
    let shaded = path("shaded.ply");
    std::fs::write(
        &shaded,
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
         property float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 2\n\
         property list uchar int vertex_indices\nend_header\n\
         0 0 0 0 0 1 255 0 0\n1 0 0 0 0 1 0 255 0\n1 1 0.2 0 0 1 0 0 255\n0 1 0 0 0 1 9 9 9\n\
         3 0 1 2\n3 0 2 3\n",
    )
    .unwrap();
    let smooth = path("smooth.ply");
    ok(&["apply", "laplacian-smoothing", &shaded, "-o", &smooth]);
    let info = json(&ok(&["info", &smooth, "--json"]));
    assert_eq!(
        info["attributes"],
        serde_json::json!(["vertex color (4 × u8)", "vertex normal (3 × f32)"]),
        "{info}"
    );

    // A textured OBJ: more texture coordinates than vertices, a library and its PNG.
    let input = dir.path().join("in");
    let output = dir.path().join("out");
    std::fs::create_dir_all(&input).unwrap();
    std::fs::create_dir_all(&output).unwrap();
    std::fs::write(
        input.join("model.obj"),
        "mtllib model.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n\
         vt 0 1\nvt 0.5 0.5\nusemtl skin\nf 1/1 2/2 3/3\nf 1/5 3/3 4/4\n",
    )
    .unwrap();
    std::fs::write(input.join("model.mtl"), "newmtl skin\nmap_Kd skin.png\n").unwrap();
    std::fs::write(input.join("skin.png"), b"\x89PNG\r\n\x1a\n").unwrap();
    let model = input.join("model.obj").display().to_string();
    let result = output.join("result.obj");
    let result_path = result.display().to_string();
    ok(&["apply", "remove-degenerate-triangles", &model, "-o", &result_path, "--strict"]);
    let written = std::fs::read_to_string(&result).unwrap();
    assert!(written.contains("mtllib model.mtl\n"), "{written}");
    assert!(written.contains("vt 0.5 0.5\n"), "{written}");
    assert!(written.contains("usemtl skin\n"), "{written}");
    assert!(written.contains("f 1/1 2/2 3/3\n"), "{written}");
    assert_eq!(std::fs::read(output.join("skin.png")).unwrap(), b"\x89PNG\r\n\x1a\n");
    assert!(output.join("model.mtl").exists());
    let info = json(&ok(&["info", &result_path, "--json"]));
    assert_eq!(
        info["attributes"],
        serde_json::json!([
            "face material (1 × u32)",
            "corner texcoord (2 × f32)",
            "materials: skin",
            "material libraries: model.mtl"
        ]),
        "{info}"
    );
    assert_eq!(ok(&["hash", &model]), ok(&["hash", &result_path]));
}
