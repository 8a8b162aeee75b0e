//! `meshflow services`: what can be run, and how.

use crate::output::out;
use meshflow_runtime::{ServiceInfo, ServiceKind, describe_params};

use crate::PluginArgs;

/// One service of `meshflow services --json`: its description, as the HTTP APIs give it,
/// and the digest of the plugin that offers it.
#[derive(serde::Serialize)]
struct Listed<'a> {
    #[serde(flatten)]
    info: &'a ServiceInfo,
    plugin: &'a str,
}

pub fn run(args: &PluginArgs, json: bool) -> anyhow::Result<()> {
    let (_runtime, catalog) = crate::plugins::load(args)?;
    if json {
        let services: Vec<Listed> = catalog
            .services()
            .into_iter()
            .map(|(info, plugin)| Listed { info, plugin: &plugin.digest })
            .collect();
        out!("{}", serde_json::to_string_pretty(&services)?);
        return Ok(());
    }
    for (s, plugin) in catalog.services() {
        print(s, &plugin.digest);
    }
    Ok(())
}

/// One service and its parameters, as `meshflow services` lists them.
pub fn print(s: &ServiceInfo, digest: &str) {
    out!(
        "{} ({}, plugin {}): {}",
        s.name,
        kind_name(s.kind),
        &digest[..12.min(digest.len())],
        s.doc
    );
    for line in describe_params(s).lines().skip(1) {
        out!("{line}");
    }
}

fn kind_name(kind: ServiceKind) -> &'static str {
    match kind {
        ServiceKind::Filter => "filter",
        ServiceKind::Check => "check",
    }
}
