//! What a service is, as every part of meshflow speaks of it: its kind, its typed
//! parameters with defaults, ranges and choices, and the values it takes and returns —
//! and the one set of rules that checks given parameters against a description.
//!
//! The runtime converts the WIT's bindgen types to these at its edge and the HTTP APIs
//! serialise these as plain JSON (`{"name", "type": "real", "default": 1.0, …}`), so
//! neither the wire nor the engine changes when the WIT does. This crate must not depend
//! on wasmtime, wit-bindgen or any HTTP crate.

mod clip;
mod json;
mod resolve;
mod suggest;

pub use clip::{MAX_ECHO_BYTES, clip};
pub use json::{from_json, value_json};
pub use resolve::{ParamError, describe_params, resolve, type_name, value_text};
pub use suggest::{closest, did_you_mean};

use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ServiceKind {
    Filter,
    Check,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ValueType {
    Boolean,
    Integer,
    Real,
    Text,
}

/// A parameter value or a check's result; on the wire a plain JSON scalar.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Value {
    Boolean(bool),
    Integer(i64),
    Real(f64),
    Text(String),
}

impl Value {
    /// Whether this value is of type `ty` (no conversion).
    pub fn is_of(&self, ty: ValueType) -> bool {
        matches!(
            (ty, self),
            (ValueType::Boolean, Value::Boolean(_))
                | (ValueType::Integer, Value::Integer(_))
                | (ValueType::Real, Value::Real(_))
                | (ValueType::Text, Value::Text(_))
        )
    }
}

/// As a user wrote it: `28088`, `0.5`, `true`, `"uniform"` (never Rust's debug form).
impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Boolean(b) => write!(f, "{b}"),
            Value::Integer(i) => write!(f, "{i}"),
            Value::Real(r) => write!(f, "{r}"),
            Value::Text(t) => write!(f, "{t:?}"),
        }
    }
}

/// One parameter a service accepts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamInfo {
    pub name: String,
    #[serde(rename = "type")]
    pub ty: ValueType,
    /// Used when the caller does not give the parameter.
    pub default: Value,
    /// Inclusive bounds of an integer or real parameter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max: Option<f64>,
    /// The allowed values of a text parameter; empty for any.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub choices: Vec<String>,
    #[serde(default)]
    pub doc: String,
}

/// What a plugin says one of its services is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ServiceInfo {
    pub name: String,
    pub kind: ServiceKind,
    #[serde(default)]
    pub doc: String,
    #[serde(default)]
    pub params: Vec<ParamInfo>,
    /// The type of a check's value; `None` for filters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub result_type: Option<ValueType>,
}

/// Why a service's result does not match its description.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ResultError {
    #[error("a filter returned a value ({0})")]
    FilterValue(Value),
    #[error("a check returned no value; expected {expected}")]
    NoValue { expected: &'static str },
    #[error("expected {expected}, got {found}")]
    WrongType { expected: &'static str, found: Value },
}

/// A result against its service's description: a filter returns no value, a check one of
/// its declared type. The host and the native test backends check it the same way.
pub fn check_result(info: &ServiceInfo, value: Option<&Value>) -> Result<(), ResultError> {
    match (info.result_type, value) {
        (None, None) => Ok(()),
        (None, Some(v)) => Err(ResultError::FilterValue(v.clone())),
        (Some(ty), None) => Err(ResultError::NoValue { expected: type_name(ty) }),
        (Some(ty), Some(v)) if v.is_of(ty) => Ok(()),
        (Some(ty), Some(v)) => {
            Err(ResultError::WrongType { expected: type_name(ty), found: v.clone() })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn descriptions_are_plain_json() {
        let info = ServiceInfo {
            name: "smooth".into(),
            kind: ServiceKind::Filter,
            doc: "Smooths.".into(),
            params: vec![ParamInfo {
                name: "factor".into(),
                ty: ValueType::Real,
                default: Value::Real(1.0),
                min: Some(0.0),
                max: None,
                choices: vec![],
                doc: String::new(),
            }],
            result_type: None,
        };
        let json = serde_json::to_value(&info).unwrap();
        assert_eq!(
            json,
            serde_json::json!({"name": "smooth", "kind": "filter", "doc": "Smooths.",
                "params": [{"name": "factor", "type": "real", "default": 1.0, "min": 0.0, "doc": ""}]})
        );
        let back: ServiceInfo = serde_json::from_value(json).unwrap();
        assert_eq!(back, info);
    }

    #[test]
    fn messages_show_values_as_written() {
        let info = ServiceInfo {
            name: "smooth".into(),
            kind: ServiceKind::Filter,
            doc: String::new(),
            params: vec![ParamInfo {
                name: "flag".into(),
                ty: ValueType::Boolean,
                default: Value::Boolean(false),
                min: None,
                max: None,
                choices: vec![],
                doc: String::new(),
            }],
            result_type: None,
        };
        let error = resolve(&info, &[("flag".into(), Value::Integer(28088))]).unwrap_err();
        assert!(error.problem.ends_with("got 28088"), "{}", error.problem);
        assert_eq!(Value::Text("uniform".into()).to_string(), "\"uniform\"");
    }

    #[test]
    fn values_are_plain_scalars() {
        for (value, text) in [
            (Value::Boolean(true), "true"),
            (Value::Integer(3), "3"),
            (Value::Real(3.5), "3.5"),
            (Value::Real(1.0), "1.0"),
            (Value::Text("cot".into()), "\"cot\""),
        ] {
            assert_eq!(serde_json::to_string(&value).unwrap(), text);
            assert_eq!(serde_json::from_str::<Value>(text).unwrap(), value);
        }
    }
}
