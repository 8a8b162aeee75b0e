//! The runtime and catalog a CLI invocation works with: the user's plugins first, then the
//! built-in ones, compiled components cached on disk between invocations.

use std::path::PathBuf;

use anyhow::Context;
use meshflow_runtime::Limits;
use meshflow_runtime::{Catalog, Runtime};

use crate::PluginArgs;

pub fn load(args: &PluginArgs) -> anyhow::Result<(Runtime, Catalog)> {
    let cache = cache_dir();
    let runtime = Runtime::new(Limits::default(), cache.as_deref())?;
    let mut catalog = Catalog::new();
    for path in &args.plugins {
        let bytes =
            std::fs::read(path).with_context(|| format!("reading plugin {}", path.display()))?;
        let plugin =
            runtime.load(&bytes).with_context(|| format!("loading plugin {}", path.display()))?;
        catalog.add(plugin);
    }
    for builtin in meshflow_builtin_plugins::PLUGINS {
        let plugin = runtime
            .load(builtin.wasm)
            .with_context(|| format!("loading built-in plugin {}", builtin.name))?;
        catalog.add(plugin);
    }
    Ok((runtime, catalog))
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
