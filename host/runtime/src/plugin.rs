//! A loaded plugin: its identity, its pre-linked component and the services it describes.

use meshflow_params::{ServiceInfo, ServiceKind, type_name};
use wasmtime::component::ComponentExportIndex;

use super::bindings::PluginPre;
use super::error::PluginError;
use super::state::RunState;

/// A validated, compiled plugin, ready to instantiate (~11 µs per run).
#[derive(Clone)]
pub struct Plugin {
    /// Hex SHA-256 of the component's bytes: the plugin's identity on every host.
    pub digest: String,
    pub services: Vec<ServiceInfo>,
    pub(crate) pre: PluginPre<RunState>,
    /// Its `locality.reach`, when it exports one (the `local-plugin` world): which services
    /// may run on partitions of a mesh.
    pub(crate) reach: Option<ComponentExportIndex>,
    /// Its `blocks.block-triangles`, when it exports one (the `block-plugin` world): which
    /// services run block by block on a large mesh.
    pub(crate) blocks: Option<ComponentExportIndex>,
}

impl std::fmt::Debug for Plugin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<&str> = self.services.iter().map(|s| s.name.as_str()).collect();
        f.debug_struct("Plugin").field("digest", &self.digest).field("services", &names).finish()
    }
}

impl Plugin {
    pub fn service(&self, name: &str) -> Option<&ServiceInfo> {
        self.services.iter().find(|s| s.name == name)
    }

    /// Whether it can say which of its services may run on partitions.
    pub fn declares_locality(&self) -> bool {
        self.reach.is_some()
    }
}

/// The SHA-256 of a component, hex: how plugins are named in caches and APIs.
pub fn digest(bytes: &[u8]) -> String {
    use sha2::Digest;
    hex::encode(sha2::Sha256::digest(bytes))
}

/// Refuses descriptions the host could not honour: duplicate names, a check without a
/// result type, defaults of the wrong type or outside their own range.
pub(crate) fn validate_description(services: &[ServiceInfo]) -> Result<(), PluginError> {
    let bad = |message: String| Err(PluginError::Description(message));
    if services.is_empty() {
        return bad("it describes no services".into());
    }
    for (i, service) in services.iter().enumerate() {
        let name = &service.name;
        if !is_service_name(name) {
            return bad(format!("service name `{name}` must be lower-case words joined by `-`"));
        }
        if services[..i].iter().any(|s| &s.name == name) {
            return bad(format!("service `{name}` is described twice"));
        }
        match (service.kind, service.result_type) {
            (ServiceKind::Check, None) => return bad(format!("check `{name}` has no result type")),
            (ServiceKind::Filter, Some(_)) => {
                return bad(format!("filter `{name}` declares a result type"));
            }
            _ => {}
        }
        for (j, p) in service.params.iter().enumerate() {
            if !is_service_name(&p.name) || service.params[..j].iter().any(|q| q.name == p.name) {
                return bad(format!(
                    "`{name}`: parameter name `{}` is invalid or repeated",
                    p.name
                ));
            }
            if !p.default.is_of(p.ty) {
                return bad(format!(
                    "`{name}`: default of `{}` is not {}",
                    p.name,
                    type_name(p.ty)
                ));
            }
            // Also refuses a NaN bound, which compares as neither.
            if let (Some(min), Some(max)) = (p.min, p.max)
                && min.partial_cmp(&max).is_none_or(|order| order.is_gt())
            {
                return bad(format!("`{name}`: parameter `{}` has range [{min}, {max}]", p.name));
            }
            let given = [(p.name.clone(), p.default.clone())];
            let only = ServiceInfo { params: vec![p.clone()], ..service.clone() };
            if let Err(e) = meshflow_params::resolve(&only, &given) {
                return bad(format!(
                    "`{name}`: the default does not pass its own check: {}",
                    e.problem
                ));
            }
        }
    }
    Ok(())
}

fn is_service_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 64
        && name.split('-').all(|w| {
            !w.is_empty() && w.bytes().all(|b| b.is_ascii_lowercase() || b.is_ascii_digit())
        })
}

/// Refuses what is not a component before compiling, so the user reads what to do rather
/// than a parser's complaint. A wasm binary starts with `\0asm` and a version: 1 for a core
/// module, (0x0d, layer 1) for a component.
pub(crate) fn check_component_preamble(bytes: &[u8]) -> Result<(), PluginError> {
    match bytes.get(..8) {
        Some([0, b'a', b's', b'm', 1, 0, 0, 0]) => Err(PluginError::CoreModule),
        Some([0, b'a', b's', b'm', ..]) => Ok(()),
        _ => Err(PluginError::NotWasm),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use meshflow_params::{ParamInfo, Value, ValueType};

    fn filter_with_range(min: f64, max: f64) -> Vec<ServiceInfo> {
        vec![ServiceInfo {
            name: "scale".into(),
            kind: ServiceKind::Filter,
            doc: String::new(),
            params: vec![ParamInfo {
                name: "factor".into(),
                doc: String::new(),
                ty: ValueType::Real,
                default: Value::Real(1.0),
                min: Some(min),
                max: Some(max),
                choices: vec![],
            }],
            result_type: None,
        }]
    }

    #[test]
    fn a_range_must_be_ordered_and_bounds_numbers() {
        assert!(validate_description(&filter_with_range(0.0, 2.0)).is_ok());
        assert!(validate_description(&filter_with_range(1.0, 1.0)).is_ok());
        for (min, max) in [(2.0, 0.0), (f64::NAN, 2.0), (0.0, f64::NAN)] {
            let error = validate_description(&filter_with_range(min, max)).unwrap_err();
            assert!(error.to_string().contains("has range"), "[{min}, {max}]: {error}");
        }
    }
}
