//! The runtime and catalog a CLI invocation works with: the user's plugins first, then the
//! built-in ones, compiled components cached on disk between invocations.

use std::path::{Path, PathBuf};

use anyhow::Context;
use meshflow_runtime::{Catalog, Runtime};

use crate::PluginArgs;

pub fn load(args: &PluginArgs) -> anyhow::Result<(Runtime, Catalog)> {
    let cache = cache_dir();
    let runtime = Runtime::new(args.sandbox.limits(), cache.as_deref())?;
    let mut catalog = Catalog::new();
    let mut local = Vec::new();
    for path in &args.plugins {
        let bytes = read_plugin_file(path)?;
        let plugin =
            runtime.load(&bytes).with_context(|| format!("loading plugin {}", path.display()))?;
        local.push((path.as_path(), plugin.services.iter().map(|s| s.name.clone()).collect()));
        catalog.add(plugin);
    }
    for builtin in meshflow_builtin_plugins::PLUGINS {
        let plugin = runtime
            .load(builtin.wasm)
            .with_context(|| format!("loading built-in plugin {}", builtin.name))?;
        warn_shadowed(&local, &plugin);
        catalog.add(plugin);
    }
    Ok((runtime, catalog))
}

/// One line on stderr per built-in service a `--plugin` file hides: the local plugin's
/// service of that name runs instead (a host would refuse such an upload without
/// `--replace`).
fn warn_shadowed(local: &[(&Path, Vec<String>)], builtin: &meshflow_runtime::Plugin) {
    use std::io::Write;
    for service in &builtin.services {
        if let Some((file, _)) = local.iter().find(|(_, names)| names.contains(&service.name)) {
            let _ = writeln!(
                std::io::stderr(),
                "warning: `{}` of --plugin {} shadows the built-in service of that name",
                service.name,
                file.display()
            );
        }
    }
}

/// The built-in plugins' component bytes, for a host server to load.
pub fn builtin_components() -> Vec<&'static [u8]> {
    meshflow_builtin_plugins::PLUGINS.iter().map(|builtin| builtin.wasm).collect()
}

/// `$MESHFLOW_CACHE_DIR`, else the user's cache directory; none if neither is known.
pub fn cache_dir() -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os("MESHFLOW_CACHE_DIR") {
        return Some(dir.into());
    }
    let base = std::env::var_os("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|home| PathBuf::from(home).join(".cache")))?;
    Some(base.join("meshflow").join("components"))
}

/// What the plugin printed, on stderr, when `--plugin-output` asks for it.
pub fn show_output(args: &PluginArgs, output: &meshflow_runtime::RunOutput) {
    if !args.plugin_output {
        return;
    }
    for (name, text) in [("stdout", &output.stdout), ("stderr", &output.stderr)] {
        if text.is_empty() {
            eprintln!("plugin {name}: (nothing)");
        } else {
            eprintln!("plugin {name}:\n{}", text.trim_end());
        }
    }
}

/// A plugin file's bytes. A missing `.wasm` is usually a build that made none: say which
/// (an `.rlib` alone beside it means the crate lacks `crate-type = ["cdylib"]`).
pub fn read_plugin_file(path: &Path) -> anyhow::Result<Vec<u8>> {
    match std::fs::read(path) {
        Ok(bytes) => Ok(bytes),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(missing_wasm(path)),
        Err(e) => Err(e).with_context(|| format!("reading plugin {}", path.display())),
    }
}

fn missing_wasm(path: &Path) -> anyhow::Error {
    let shown = path.display();
    let (Some(dir), Some(stem)) = (path.parent(), path.file_stem()) else {
        return anyhow::anyhow!("{shown} does not exist");
    };
    let rlib = dir.join(format!("lib{}.rlib", stem.to_string_lossy()));
    if rlib.exists() {
        return anyhow::anyhow!(
            "{shown} does not exist, but {} does: the build made a Rust library and no \
             component. Add `crate-type = [\"cdylib\", \"rlib\"]` under `[lib]` in Cargo.toml \
             and build again",
            rlib.display()
        );
    }
    anyhow::anyhow!(
        "{shown} does not exist: build the plugin with `cargo build --release --target \
         wasm32-wasip2` (the file is target/wasm32-wasip2/release/<crate name with _ for ->.wasm)"
    )
}
