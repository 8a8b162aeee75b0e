//! `meshflow plugin componentize`: a `wasm32-wasip1` core module (what clang with
//! wasi-libc builds from C or C++) into a plugin component, with the WASI preview-1 adapter
//! of the wasmtime release the hosts run, then loaded as a host loads an upload.

use anyhow::{Context, bail};
use meshflow_runtime::{Plugin, Runtime};
use wasi_preview1_component_adapter_provider::{
    WASI_SNAPSHOT_PREVIEW1_ADAPTER_NAME, WASI_SNAPSHOT_PREVIEW1_REACTOR_ADAPTER,
};
use wit_component::ComponentEncoder;

/// The world a plugin implements and the interface it exports, as `wit/meshflow.wit` names
/// them.
const PLUGIN_WORLD: &str = "meshflow:geometry/plugin@0.1.0";
const SERVICE_INTERFACE: &str = "meshflow:geometry/service@0.1.0";

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
                "the module does not implement {PLUGIN_WORLD} as its bindings declare: {e:#}"
            )
        })?;
    let plugin = runtime.load(&component).context("the component does not load as a plugin")?;
    Ok((component, plugin))
}

/// Refuses a module that carries no world, or one that does not export meshflow's service
/// interface, naming what it exports instead.
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
    let exports: Vec<String> =
        world.exports.keys().map(|key| bindgen.resolve.name_world_key(key)).collect();
    if !exports.iter().any(|name| name == SERVICE_INTERFACE) {
        bail!(
            "the module was built for another world: it exports [{}], not {SERVICE_INTERFACE}; \
             generate its bindings from meshflow's wit/ (sdk/cpp/generated/ has them)",
            exports.join(", ")
        );
    }
    Ok(())
}
