//! DESIGN §1: the engine speaks to hosts only through `meshflow-api`. Neither it nor the API
//! crate may link what runs plugins or handles mesh bytes: those live on hosts.

/// Crates that must stay out of the engine's build (matched by name prefix).
const HOST_ONLY: &[&str] = &[
    "wasmtime",
    "cranelift",
    "constriction",
    "meshflow-codec",
    "meshflow-mesh",
    "meshflow-meshio",
    "meshflow-runtime",
    "meshflow-host",
];

/// Names of the packages `root` links on this platform (normal dependencies, transitively).
fn linked_by(root: &str) -> Vec<String> {
    let output = std::process::Command::new(env!("CARGO"))
        .args(["tree", "-e", "normal", "--prefix", "none", "-f", "{p}", "--offline", "--locked"])
        .args(["-p", root])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo runs");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let tree = String::from_utf8(output.stdout).unwrap();
    tree.lines().filter_map(|line| line.split_whitespace().next()).map(str::to_owned).collect()
}

#[test]
fn the_engine_and_the_api_link_nothing_that_runs_plugins_or_decodes_meshes() {
    for root in ["meshflow-engine", "meshflow-api"] {
        let linked = linked_by(root);
        assert!(linked.iter().any(|name| name == "meshflow-params"), "{root} links {linked:?}");
        let forbidden: Vec<_> = linked
            .iter()
            .filter(|name| HOST_ONLY.iter().any(|prefix| name.starts_with(prefix)))
            .collect();
        assert!(forbidden.is_empty(), "{root} links {forbidden:?} (DESIGN §1)");
    }
}
