//! The docs name files a reader will open: every file path that `docs/architecture.md` (and
//! the other guides) put in backticks must exist, so a moved or renamed file fails here
//! instead of sending a reader to nothing.

use std::path::{Path, PathBuf};

/// Source kinds whose names the docs cite; other backticked words (flags, routes, outputs
/// like `summary.json`) are not paths of this repository.
const CITED_KINDS: &[&str] = &["rs", "md", "toml", "mjs", "wit", "sh", "py", "hpp"];

/// Folders that hold no source a doc would cite.
const SKIPPED: &[&str] = &["target", "node_modules", ".git", "dist", "__pycache__"];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every file of the repository, as `/`-separated paths from its root.
fn tree(dir: &Path, prefix: &str, out: &mut Vec<String>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let entry = entry.unwrap();
        let name = entry.file_name().to_string_lossy().into_owned();
        if SKIPPED.contains(&name.as_str()) {
            continue;
        }
        let path = format!("{prefix}{name}");
        if entry.file_type().unwrap().is_dir() {
            tree(&entry.path(), &format!("{path}/"), out);
        } else {
            out.push(path);
        }
    }
}

/// The backticked words of `text` that look like a file path of ours. (Folders are left
/// out: the docs also name folders that runs make, like `demo-out/`.)
fn cited_paths(text: &str) -> Vec<String> {
    let plain = |c: char| c.is_ascii_alphanumeric() || "_./-".contains(c);
    text.split('`')
        .skip(1)
        .step_by(2)
        .filter(|word| !word.is_empty() && word.chars().all(plain) && !word.starts_with('.'))
        .filter(|word| {
            let kind = word.rsplit_once('.').map(|(_, kind)| kind);
            kind.is_some_and(|kind| CITED_KINDS.contains(&kind))
        })
        .map(str::to_owned)
        .collect()
}

/// A cited path exists when it is a path from the root, or the tail of one (docs name
/// files within the crate they are describing: `executor/mod.rs`, `routes/steps.rs`).
fn exists(cited: &str, tree: &[String]) -> bool {
    let cited = cited.trim_start_matches("./");
    tree.iter().any(|path| path == cited || path.ends_with(&format!("/{cited}")))
}

fn missing_in(doc: &str) -> Vec<String> {
    let text = std::fs::read_to_string(root().join(doc)).unwrap();
    let mut files = Vec::new();
    tree(&root(), "", &mut files);
    cited_paths(&text).into_iter().filter(|cited| !exists(cited, &files)).collect()
}

#[test]
fn architecture_names_only_files_that_exist() {
    let missing = missing_in("docs/architecture.md");
    assert!(missing.is_empty(), "docs/architecture.md names files that do not exist: {missing:?}");
}

#[test]
fn guides_name_only_files_that_exist() {
    for doc in ["README.md", "docs/api.md", "docs/workflows.md", "docs/benchmarks.md"] {
        let missing = missing_in(doc);
        assert!(missing.is_empty(), "{doc} names files that do not exist: {missing:?}");
    }
}

#[test]
fn a_moved_file_is_caught() {
    let mut files = Vec::new();
    tree(&root(), "", &mut files);
    let cited = cited_paths("see `src/remote.rs`, `executor/mod.rs` and `--json`");
    assert_eq!(cited, ["src/remote.rs", "executor/mod.rs"]);
    assert!(!exists("src/remote.rs", &files), "src/remote.rs moved to src/commands/");
    assert!(exists("executor/mod.rs", &files));
}
