//! Test fixture: a plugin that describes the same service twice. The host must refuse to
//! load it, saying why.

use meshflow_plugin_sdk::{Mesh, Params, Result, Service};

fn nothing(_: &Mesh, _: &Params) -> Result<String> {
    Ok(String::new())
}

fn services() -> Vec<Service> {
    vec![Service::filter("twin", "First.", nothing), Service::filter("twin", "Second.", nothing)]
}

meshflow_plugin_sdk::export_plugin!(services);
