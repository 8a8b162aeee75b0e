//! `meshflow plugin componentize`: a `wasm32-wasip1` core module (what clang with
//! wasi-libc builds from C or C++) into a plugin component, with the WASI preview-1 adapter
//! of the wasmtime release the hosts run, then loaded as a host loads an upload.

use anyhow::{Context, bail};
use meshflow_runtime::{Plugin, Runtime};
use wasi_preview1_component_adapter_provider::{
    WASI_SNAPSHOT_PREVIEW1_ADAPTER_NAME, WASI_SNAPSHOT_PREVIEW1_REACTOR_ADAPTER,
};
use wit_component::ComponentEncoder;

/// The package whose `plugin` world a plugin implements, as `wit/meshflow.wit` names it.
const PLUGIN_PACKAGE: &str = "meshflow:geometry@0.1.0";
const PLUGIN_WORLD: &str = "plugin";

/// The component made from `core`, and the plugin it loads as.
pub fn componentize(runtime: &Runtime, core: &[u8]) -> anyhow::Result<(Vec<u8>, Plugin)> {
    match core.get(..8) {
        Some([0, b'a', b's', b'm', 1, 0, 0, 0]) => {}
        Some([0, b'a', b's', b'm', ..]) => {
            bail!("this is already a component: upload or run it as it is")
        }
        _ => bail!("not a WebAssembly file (it does not start with `\\0asm`)"),
    }
    check_world(core)?;
    let mut encoder = ComponentEncoder::default();
    let component = encoder
        .validate(true)
        .module(core)
        .and_then(|encoder| {
            encoder.adapter(
                WASI_SNAPSHOT_PREVIEW1_ADAPTER_NAME,
                WASI_SNAPSHOT_PREVIEW1_REACTOR_ADAPTER,
            )
        })
        .and_then(|encoder| encoder.encode())
        .map_err(|e| {
            anyhow::anyhow!(
                "the module does not implement {PLUGIN_PACKAGE}/{PLUGIN_WORLD} as its bindings \
                 declare: {e:#}"
            )
        })?;
    let plugin = runtime.load(&component).context("the component does not load as a plugin")?;
    Ok((component, plugin))
}

/// Refuses a module that carries no world, or another one than meshflow's, naming it.
fn check_world(core: &[u8]) -> anyhow::Result<()> {
    let (with_world, bindgen) =
        wit_component::metadata::decode(core).context("reading the module's component type")?;
    if with_world.is_none() {
        bail!(
            "the module carries no component type: link the world's type object \
             (sdk/cpp/generated/plugin_component_type.o, as the C++ template's Makefile does)"
        );
    }
    let world = &bindgen.resolve.worlds[bindgen.world];
    let package = world.package.map(|p| bindgen.resolve.packages[p].name.to_string());
    let package = package.unwrap_or_default();
    if package != PLUGIN_PACKAGE || world.name != PLUGIN_WORLD {
        bail!(
            "the module was built for the world {package}/{}, not {PLUGIN_PACKAGE}/{PLUGIN_WORLD}: \
             generate its bindings from meshflow's wit/ (sdk/cpp/generated/ has them)",
            world.name
        );
    }
    Ok(())
}
