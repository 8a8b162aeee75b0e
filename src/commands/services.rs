//! `meshflow services`: what can be run, and how.

use meshflow_host::runtime::{ServiceInfo, ServiceKind, describe_params};

use super::value_json;
use crate::PluginArgs;

pub fn run(args: &PluginArgs, json: bool) -> anyhow::Result<()> {
    let (_runtime, catalog) = crate::plugins::load(args)?;
    if json {
        let services: Vec<_> = catalog
            .services()
            .into_iter()
            .map(|(s, plugin)| {
                serde_json::json!({
                    "name": s.name,
                    "kind": kind_name(s.kind),
                    "doc": s.doc,
                    "plugin": plugin.digest,
                    "result": s.result_type.map(|t| format!("{t:?}").to_lowercase()),
                    "params": s.params.iter().map(|p| serde_json::json!({
                        "name": p.name,
                        "type": format!("{:?}", p.ty).to_lowercase(),
                        "default": value_json(&p.default),
                        "min": p.min,
                        "max": p.max,
                        "choices": p.choices,
                        "doc": p.doc,
                    })).collect::<Vec<_>>(),
                })
            })
            .collect();
        println!("{}", serde_json::to_string_pretty(&services)?);
        return Ok(());
    }
    for (s, plugin) in catalog.services() {
        print(s, &plugin.digest);
    }
    Ok(())
}

/// One service and its parameters, as `meshflow services` lists them.
pub fn print(s: &ServiceInfo, digest: &str) {
    println!(
        "{} ({}, plugin {}): {}",
        s.name,
        kind_name(s.kind),
        &digest[..12.min(digest.len())],
        s.doc
    );
    for line in describe_params(s).lines().skip(1) {
        println!("{line}");
    }
}

fn kind_name(kind: ServiceKind) -> &'static str {
    match kind {
        ServiceKind::Filter => "filter",
        ServiceKind::Check => "check",
    }
}
