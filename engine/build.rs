//! Builds the workbench (`web/`: npm packages bundled by Vite) into `OUT_DIR` and writes a
//! table embedding every file of the bundle, so `cargo build` alone yields an engine that
//! serves its web UI offline. Node.js and npm must be on the PATH; `npm ci` installs the
//! locked packages when `node_modules` is missing or older than the lockfile.

use std::path::{Path, PathBuf};
use std::process::Command;

/// What the bundle is made from; a change to any of these rebuilds it.
const SOURCES: &[&str] =
    &["src", "public", "index.html", "package.json", "package-lock.json", "vite.config.js"];

fn main() {
    let web = PathBuf::from(env("CARGO_MANIFEST_DIR")).join("web");
    let dist = PathBuf::from(env("OUT_DIR")).join("web-dist");
    for source in SOURCES {
        println!("cargo:rerun-if-changed={}", web.join(source).display());
    }
    // The example workflows the builder offers are bundled too.
    println!("cargo:rerun-if-changed={}", web.join("../../examples/workflows").display());
    if needs_install(&web) {
        npm(&web, &["ci", "--no-audit", "--no-fund"]);
    }
    let out_dir = dist.to_str().expect("OUT_DIR is UTF-8");
    npm(&web, &["run", "build", "--", "--outDir", out_dir, "--emptyOutDir"]);
    write_table(&PathBuf::from(env("OUT_DIR")).join("web_assets.rs"), &dist);
}

/// Whether `node_modules` is missing or older than the lockfile (npm writes its own copy of
/// the lockfile into `node_modules` on every install).
fn needs_install(web: &Path) -> bool {
    let modified = |path: PathBuf| std::fs::metadata(path).and_then(|m| m.modified()).ok();
    match (
        modified(web.join("node_modules/.package-lock.json")),
        modified(web.join("package-lock.json")),
    ) {
        (Some(installed), Some(locked)) => installed < locked,
        _ => true,
    }
}

fn npm(dir: &Path, args: &[&str]) {
    let status = Command::new("npm").current_dir(dir).args(args).status().unwrap_or_else(|e| {
        panic!("running npm {args:?} for the workbench failed ({e}): install Node.js and npm")
    });
    assert!(status.success(), "npm {args:?} for the workbench failed ({status})");
}

/// `&[("index.html", include_bytes!(...)), ("assets/index-1a2b.js", ...), ...]`.
fn write_table(path: &Path, dist: &Path) {
    let mut files = Vec::new();
    collect(dist, dist, &mut files);
    files.sort();
    assert!(files.iter().any(|(name, _)| name == "index.html"), "the bundle has no index.html");
    let mut table = String::from("&[\n");
    for (name, file) in files {
        table.push_str(&format!(
            "    ({name:?}, include_bytes!({:?})),\n",
            file.display().to_string()
        ));
    }
    table.push(']');
    std::fs::write(path, table).expect("writing the asset table");
}

fn collect(root: &Path, dir: &Path, files: &mut Vec<(String, PathBuf)>) {
    for entry in std::fs::read_dir(dir).expect("reading the bundle") {
        let path = entry.expect("reading the bundle").path();
        if path.is_dir() {
            collect(root, &path, files);
        } else {
            let name = path.strip_prefix(root).unwrap().to_str().expect("UTF-8 names").to_owned();
            files.push((name, path));
        }
    }
}

fn env(name: &str) -> String {
    std::env::var(name).unwrap_or_else(|_| panic!("cargo sets {name} for build scripts"))
}
