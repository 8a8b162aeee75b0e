//! The in-house plugins as component bytes, built from `plugins/*` by `build.rs`.

/// One embedded plugin: the crate it was built from and its component bytes.
pub struct BuiltinPlugin {
    pub name: &'static str,
    pub wasm: &'static [u8],
}

/// Every in-house plugin.
pub const PLUGINS: &[BuiltinPlugin] = include!(concat!(env!("OUT_DIR"), "/plugins.rs"));
