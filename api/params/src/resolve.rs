//! Checking the parameters a caller gives against a service's description.

use crate::{ParamInfo, ServiceInfo, Value, ValueType};

/// Why a parameter was refused; the message lists what the service accepts.
#[derive(Debug, thiserror::Error)]
#[error("{service}: {problem}\n{accepted}")]
pub struct ParamError {
    pub service: String,
    pub problem: String,
    pub accepted: String,
}

/// Resolves the given `(name, value)` pairs into the full parameter list of a run: every
/// declared parameter once, in declaration order, defaults filled in. Text values are
/// parsed as the declared type (so `iterations=3` from a command line works); integers
/// widen to reals; reals that are whole numbers narrow to integers.
pub fn resolve(
    info: &ServiceInfo,
    given: &[(String, Value)],
) -> Result<Vec<(String, Value)>, ParamError> {
    let fail = |problem: String| ParamError {
        service: info.name.clone(),
        problem,
        accepted: describe_params(info),
    };
    for (i, (name, _)) in given.iter().enumerate() {
        if !info.params.iter().any(|p| &p.name == name) {
            let hint = crate::did_you_mean(name, info.params.iter().map(|p| p.name.as_str()));
            return Err(fail(format!("unknown parameter `{}`{hint}", crate::clip(name))));
        }
        if given[..i].iter().any(|(earlier, _)| earlier == name) {
            return Err(fail(format!("parameter `{}` given twice", crate::clip(name))));
        }
    }
    info.params
        .iter()
        .map(|spec| {
            let value = match given.iter().find(|(name, _)| name == &spec.name) {
                Some((_, value)) => coerce(spec, value).map_err(|e| fail(e.to_string()))?,
                None => spec.default.clone(),
            };
            Ok((spec.name.clone(), value))
        })
        .collect()
}

/// Why one given value was refused: the `problem` of a [`ParamError`].
#[derive(Debug, thiserror::Error)]
enum ValueError {
    #[error("parameter `{name}`: `{text}` is not {expected}")]
    Unparsed { name: String, text: String, expected: &'static str },
    #[error("parameter `{name}` must be {expected}, got {}", crate::clip(&given.to_string()))]
    WrongType { name: String, expected: &'static str, given: Value },
    #[error("parameter `{name}` = {value} is out of range {range}")]
    OutOfRange { name: String, value: f64, range: String },
    #[error("parameter `{name}` = `{text}` is not one of: {}", .choices.join(", "))]
    NotAChoice { name: String, text: String, choices: Vec<String> },
}

fn coerce(spec: &ParamInfo, value: &Value) -> Result<Value, ValueError> {
    let name = &spec.name;
    let typed = match (spec.ty, value) {
        (ValueType::Boolean, Value::Boolean(_))
        | (ValueType::Integer, Value::Integer(_))
        | (ValueType::Real, Value::Real(_))
        | (ValueType::Text, Value::Text(_)) => value.clone(),
        (ValueType::Real, Value::Integer(i)) => Value::Real(*i as f64),
        (ValueType::Integer, Value::Real(r)) if r.fract() == 0.0 && r.abs() < 9e15 => {
            Value::Integer(*r as i64)
        }
        (ty, Value::Text(text)) => parse(ty, text).ok_or_else(|| ValueError::Unparsed {
            name: name.clone(),
            text: crate::clip(text),
            expected: type_name(ty),
        })?,
        (ty, other) => {
            return Err(ValueError::WrongType {
                name: name.clone(),
                expected: type_name(ty),
                given: other.clone(),
            });
        }
    };
    check_bounds(spec, &typed)?;
    Ok(typed)
}

fn parse(ty: ValueType, text: &str) -> Option<Value> {
    match ty {
        ValueType::Boolean => match text {
            "true" | "yes" | "1" => Some(Value::Boolean(true)),
            "false" | "no" | "0" => Some(Value::Boolean(false)),
            _ => None,
        },
        ValueType::Integer => text.parse().ok().map(Value::Integer),
        ValueType::Real => text.parse::<f64>().ok().filter(|r| r.is_finite()).map(Value::Real),
        ValueType::Text => Some(Value::Text(text.to_owned())),
    }
}

fn check_bounds(spec: &ParamInfo, value: &Value) -> Result<(), ValueError> {
    let number = match value {
        Value::Integer(i) => Some(*i as f64),
        Value::Real(r) => Some(*r),
        _ => None,
    };
    if let Some(x) = number {
        let below = spec.min.is_some_and(|min| x < min);
        let above = spec.max.is_some_and(|max| x > max);
        if below || above || x.is_nan() {
            return Err(ValueError::OutOfRange {
                name: spec.name.clone(),
                value: x,
                range: range_text(spec),
            });
        }
    }
    if let Value::Text(text) = value
        && !spec.choices.is_empty()
        && !spec.choices.contains(text)
    {
        return Err(ValueError::NotAChoice {
            name: spec.name.clone(),
            text: crate::clip(text),
            choices: spec.choices.clone(),
        });
    }
    Ok(())
}

pub fn type_name(ty: ValueType) -> &'static str {
    match ty {
        ValueType::Boolean => "a boolean",
        ValueType::Integer => "an integer",
        ValueType::Real => "a real",
        ValueType::Text => "a text",
    }
}

fn range_text(spec: &ParamInfo) -> String {
    let bound = |b: Option<f64>| b.map_or("…".to_owned(), |b| b.to_string());
    format!("[{}, {}]", bound(spec.min), bound(spec.max))
}

/// One line per parameter: name, type, default, range or choices, doc.
pub fn describe_params(info: &ServiceInfo) -> String {
    if info.params.is_empty() {
        return format!("`{}` takes no parameters", info.name);
    }
    let mut text = format!("`{}` accepts:", info.name);
    for p in &info.params {
        text.push_str(&format!("\n  {} ({}", p.name, type_name(p.ty)));
        text.push_str(&format!(", default {}", value_text(&p.default)));
        if p.min.is_some() || p.max.is_some() {
            text.push_str(&format!(", range {}", range_text(p)));
        }
        if !p.choices.is_empty() {
            text.push_str(&format!(", one of {}", p.choices.join("|")));
        }
        text.push(')');
        if !p.doc.is_empty() {
            text.push_str(&format!(": {}", p.doc));
        }
    }
    text
}

/// A value as a user would type it.
pub fn value_text(value: &Value) -> String {
    match value {
        Value::Boolean(b) => b.to_string(),
        Value::Integer(i) => i.to_string(),
        Value::Real(r) => r.to_string(),
        Value::Text(t) => t.clone(),
    }
}
