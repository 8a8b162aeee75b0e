//! Parameters as JSON objects, as workflows and the HTTP APIs carry them.

use serde_json::{Map, Value as Json};

use crate::{ParamError, ServiceInfo, Value, ValueType, describe_params, resolve};

/// JSON parameters as typed values, by each parameter's declared type, checked against
/// the service's description (names, types, ranges, choices). Returns the values given
/// (not the defaults); the error lists what the service accepts.
pub fn from_json(
    info: &ServiceInfo,
    params: &Map<String, Json>,
) -> Result<Vec<(String, Value)>, ParamError> {
    let typed = params
        .iter()
        .map(|(name, json)| {
            let declared = info.params.iter().find(|p| &p.name == name).map(|p| p.ty);
            let refuse = |problem: String| ParamError {
                service: info.name.clone(),
                problem,
                accepted: describe_params(info),
            };
            // JSON has numbers and booleans: "0.1" for a real is a typing slip, said rather
            // than read (a command line's `k=v` is text, and is parsed in `resolve`).
            if let (Json::String(text), Some(ty)) = (json, declared)
                && ty != ValueType::Text
            {
                let shown = crate::clip(text);
                return Err(refuse(format!(
                    "parameter `{}`: \"{shown}\" is a string; {} is written without quotes",
                    crate::clip(name),
                    crate::type_name(ty)
                )));
            }
            let value = json_value(declared, json).ok_or_else(|| {
                refuse(format!("parameter `{name}`: {json} is not a number, boolean or string"))
            })?;
            Ok((name.clone(), value))
        })
        .collect::<Result<Vec<_>, ParamError>>()?;
    resolve(info, &typed)?;
    Ok(typed)
}

/// The value of a JSON scalar, guided by the declared type so that `3` is an integer for
/// an integer parameter and a real for a real one. Range and type mismatches are left to
/// [`resolve`], which words them.
fn json_value(declared: Option<ValueType>, json: &Json) -> Option<Value> {
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

/// A value as JSON.
pub fn value_json(value: &Value) -> Json {
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
    use crate::{ParamInfo, ServiceKind};

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

    fn json(text: &str) -> Map<String, Json> {
        serde_json::from_str(text).unwrap()
    }

    #[test]
    fn a_number_in_quotes_is_refused_saying_so() {
        let error = from_json(&smoothing(), &json(r#"{"factor": "0.1"}"#)).unwrap_err();
        let expected = "parameter `factor`: \"0.1\" is a string; a real is written without quotes";
        assert_eq!(error.problem, expected);
        assert!(from_json(&smoothing(), &json(r#"{"factor": 0.1}"#)).is_ok());
    }

    #[test]
    fn numbers_take_the_declared_type() {
        let typed = from_json(&smoothing(), &json(r#"{"iterations": 3, "factor": 1}"#));
        assert_eq!(
            typed.unwrap(),
            vec![("factor".into(), Value::Real(1.0)), ("iterations".into(), Value::Integer(3))]
        );
    }

    #[test]
    fn bad_params_are_refused_with_what_is_accepted() {
        let error =
            from_json(&smoothing(), &json(r#"{"iterations": 1000}"#)).unwrap_err().to_string();
        assert!(error.contains("iterations"), "{error}");
        let error = from_json(&smoothing(), &json(r#"{"speed": 1}"#)).unwrap_err().to_string();
        assert!(error.contains("unknown parameter `speed`") && error.contains("factor"), "{error}");
        let error = from_json(&smoothing(), &json(r#"{"factor": [1]}"#)).unwrap_err().to_string();
        assert!(error.contains("is not a number"), "{error}");
    }
}
