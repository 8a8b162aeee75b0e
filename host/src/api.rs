//! The host HTTP API's bodies: serde types shared by the server and [`HostClient`]
//! (crate::client::HostClient), and the JSON ↔ typed-parameter conversion the engine also
//! uses to validate workflows.

use serde::{Deserialize, Serialize};

use crate::runtime::{ServiceInfo, Value, ValueType, describe_params, resolve_params};

/// `GET /health`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Health {
    pub status: String,
    pub version: String,
    /// Runs in progress: the engine's measure of load.
    pub running: usize,
    pub sessions: usize,
}

/// One entry of `GET /services`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ServiceEntry {
    pub plugin: String,
    pub builtin: bool,
    pub info: ServiceInfo,
}

/// `POST /plugins`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct UploadedPlugin {
    pub digest: String,
    pub services: Vec<ServiceInfo>,
}

/// One entry of `GET /plugins`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct PluginEntry {
    pub digest: String,
    pub builtin: bool,
    pub services: Vec<String>,
}

/// `POST /sessions`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct CreateSession {
    pub input: InputRef,
}

/// Where a session's input mesh is, and optionally the content hash it must have.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct InputRef {
    pub url: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hash: Option<String>,
}

/// `POST /sessions` answer.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SessionCreated {
    pub id: String,
    pub state: SessionState,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum SessionState {
    Loading,
    Ready,
    Busy,
    Failed,
}

/// `GET /sessions/{id}`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SessionStatus {
    pub id: String,
    pub state: SessionState,
    /// Content hash of the session's current mesh, once loaded.
    pub hash: Option<String>,
    pub vertices: Option<usize>,
    pub triangles: Option<usize>,
    /// Why the session failed.
    pub error: Option<String>,
    pub download_ms: Option<f64>,
    pub load_ms: Option<f64>,
    pub input_bytes: Option<u64>,
}

/// A blob another host produced: a correction.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct BlobRef {
    pub url: String,
    pub bytes: u64,
}

/// A full mesh another host can produce, named by its content hash.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct FullRef {
    pub url: String,
    pub hash: String,
}

/// Which of the two transfers a receiving host should use.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Transfer {
    Correction,
    Full,
}

/// `POST /sessions/{id}/update`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Update {
    pub correction: Option<BlobRef>,
    pub full: FullRef,
    #[serde(rename = "use")]
    pub use_: Transfer,
}

/// `POST /sessions/{id}/update` answer.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Updated {
    pub hash: String,
    pub via: Transfer,
    /// Bytes downloaded, the failed correction attempt included.
    pub bytes: u64,
    pub download_ms: f64,
    pub apply_ms: f64,
    /// Why the correction was not used, when the host fell back to the full mesh.
    pub fallback: Option<String>,
}

/// `POST /sessions/{id}/run`.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct RunRequest {
    pub service: String,
    #[serde(default)]
    pub params: serde_json::Map<String, serde_json::Value>,
    /// Run this plugin's service rather than the one the catalogue picks.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plugin: Option<String>,
}

/// `POST /sessions/{id}/run` answer.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum RunResult {
    Filter(FilterResult),
    Check(CheckResult),
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct FilterResult {
    pub service: String,
    pub plugin: String,
    pub input_hash: String,
    pub output_hash: String,
    pub vertices: usize,
    pub triangles: usize,
    pub edits: usize,
    pub compute_ms: f64,
    pub report: String,
    pub correction: BlobRef,
    pub full: FullRef,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct CheckResult {
    pub service: String,
    pub plugin: String,
    pub value: serde_json::Value,
    pub compute_ms: f64,
    pub report: String,
}

/// Every error body: `{"error": {"code", "message"}}`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ErrorBody {
    pub error: ErrorDetail,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ErrorDetail {
    pub code: String,
    pub message: String,
}

/// JSON parameters as typed runtime values, by each parameter's declared type, checked
/// against the service's description (names, types, ranges, choices). The message lists
/// what the service accepts.
pub fn params_from_json(
    info: &ServiceInfo,
    params: &serde_json::Map<String, serde_json::Value>,
) -> Result<Vec<(String, Value)>, String> {
    let typed = params
        .iter()
        .map(|(name, json)| {
            let declared = info.params.iter().find(|p| &p.name == name).map(|p| p.ty);
            let value = json_value(declared, json).ok_or_else(|| {
                format!(
                    "{}: parameter `{name}`: {json} is not a number, boolean or string\n{}",
                    info.name,
                    describe_params(info)
                )
            })?;
            Ok((name.clone(), value))
        })
        .collect::<Result<Vec<_>, String>>()?;
    resolve_params(info, &typed).map_err(|e| e.to_string())?;
    Ok(typed)
}

/// The runtime value of a JSON scalar, guided by the declared type so that `3` is an
/// integer for an integer parameter and a real for a real one. Range and type mismatches
/// are left to [`resolve_params`], which words them.
fn json_value(declared: Option<ValueType>, json: &serde_json::Value) -> Option<Value> {
    use serde_json::Value as Json;
    Some(match json {
        Json::Bool(b) => Value::Boolean(*b),
        Json::String(s) => Value::Text(s.clone()),
        Json::Number(n) => match (declared, n.as_i64()) {
            (Some(ValueType::Real), _) | (_, None) => Value::Real(n.as_f64()?),
            (_, Some(i)) => Value::Integer(i),
        },
        Json::Null | Json::Array(_) | Json::Object(_) => return None,
    })
}

/// Milliseconds, rounded to microseconds: how the API reports timings.
pub fn millis(duration: std::time::Duration) -> f64 {
    (duration.as_secs_f64() * 1e6).round() / 1e3
}

/// A runtime value as JSON.
pub fn value_json(value: &Value) -> serde_json::Value {
    match value {
        Value::Boolean(b) => (*b).into(),
        Value::Integer(i) => (*i).into(),
        Value::Real(r) => (*r).into(),
        Value::Text(t) => t.clone().into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::runtime::{ParamInfo, ServiceKind};

    fn smoothing() -> ServiceInfo {
        let param = |name: &str, ty, default| ParamInfo {
            name: name.into(),
            doc: String::new(),
            ty,
            default,
            min: Some(0.0),
            max: Some(100.0),
            choices: vec![],
        };
        ServiceInfo {
            name: "smooth".into(),
            kind: ServiceKind::Filter,
            doc: String::new(),
            params: vec![
                param("iterations", ValueType::Integer, Value::Integer(1)),
                param("factor", ValueType::Real, Value::Real(0.5)),
            ],
            result_type: None,
        }
    }

    fn json(text: &str) -> serde_json::Map<String, serde_json::Value> {
        serde_json::from_str(text).unwrap()
    }

    #[test]
    fn numbers_take_the_declared_type() {
        let typed = params_from_json(&smoothing(), &json(r#"{"iterations": 3, "factor": 1}"#));
        assert_eq!(
            typed.unwrap(),
            vec![("factor".into(), Value::Real(1.0)), ("iterations".into(), Value::Integer(3))]
        );
    }

    #[test]
    fn bad_params_are_refused_with_what_is_accepted() {
        let error = params_from_json(&smoothing(), &json(r#"{"iterations": 1000}"#)).unwrap_err();
        assert!(error.contains("iterations"), "{error}");
        let error = params_from_json(&smoothing(), &json(r#"{"speed": 1}"#)).unwrap_err();
        assert!(error.contains("unknown parameter `speed`") && error.contains("factor"), "{error}");
        let error = params_from_json(&smoothing(), &json(r#"{"factor": [1]}"#)).unwrap_err();
        assert!(error.contains("is not a number"), "{error}");
    }
}
