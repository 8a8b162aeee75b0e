//! One module per subcommand.

pub mod apply;
mod batch;
pub mod check;
pub mod correction;
pub mod engine;
pub mod generate;
pub mod host;
pub mod inspect;
pub mod options;
pub mod pack;
pub mod plugin;
mod remote;
pub mod rerun;
pub mod run;
pub mod services;
pub mod submit;
pub mod tokens;
pub mod up;
pub mod workflow;

use meshflow_runtime::Value;

/// `k=v` pairs from the command line; values stay text until the service's declared
/// types say how to read them.
pub fn parse_params(pairs: &[String]) -> anyhow::Result<Vec<(String, Value)>> {
    pairs
        .iter()
        .map(|pair| match pair.split_once('=') {
            Some((k, v)) if !k.is_empty() => Ok((k.to_owned(), Value::Text(v.to_owned()))),
            _ => anyhow::bail!("--param `{pair}`: expected NAME=VALUE"),
        })
        .collect()
}

/// Timings in JSON output and values as JSON, as the host API gives them.
pub use meshflow_api::host::millis;
pub use meshflow_params::value_json;
