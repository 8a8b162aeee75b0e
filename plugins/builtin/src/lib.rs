//! The in-house plugins as component bytes, built from `plugins/*` by `build.rs`.

/// One embedded plugin: the crate it was built from and its component bytes.
pub struct BuiltinPlugin {
    pub name: &'static str,
    pub wasm: &'static [u8],
}

/// Every in-house plugin.
pub const PLUGINS: &[BuiltinPlugin] = include!(concat!(env!("OUT_DIR"), "/plugins.rs"));

/// Misbehaving plugins from `tests/plugins/*`, for the sandbox's tests.
#[cfg(feature = "test-fixtures")]
pub const FIXTURES: &[BuiltinPlugin] = include!(concat!(env!("OUT_DIR"), "/fixtures.rs"));

/// The fixture of the given crate name (`hostile`, `bad-describe`).
#[cfg(feature = "test-fixtures")]
pub fn fixture(name: &str) -> &'static [u8] {
    FIXTURES.iter().find(|f| f.name == name).map(|f| f.wasm).expect("a fixture of that name")
}
