//! One module per subcommand.

pub mod apply;
pub mod check;
pub mod correction;
pub mod generate;
pub mod inspect;
pub mod pack;
pub mod services;

use meshflow_host::runtime::Value;

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

/// Milliseconds, rounded to microseconds, for timings in JSON output.
pub fn millis(d: std::time::Duration) -> f64 {
    (d.as_secs_f64() * 1e6).round() / 1e3
}

/// A value as JSON.
pub fn value_json(value: &Value) -> serde_json::Value {
    match value {
        Value::Boolean(b) => (*b).into(),
        Value::Integer(i) => (*i).into(),
        Value::Real(r) => (*r).into(),
        Value::Text(t) => t.clone().into(),
    }
}
