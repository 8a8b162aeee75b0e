//! A service of a plugin with its parameters resolved once: checked against the service's
//! description, every default filled in. What [`crate::Runtime::invoke`] runs, and what a
//! caller that also records the parameters (a host naming its step) reads them from.

use meshflow_params::{ParamError, ServiceInfo, Value, resolve};

use super::plugin::Plugin;

/// One service of one plugin and the parameters it runs with, resolved.
#[derive(Clone, Debug)]
pub struct Invocation {
    plugin: Plugin,
    info: ServiceInfo,
    params: Vec<(String, Value)>,
}

impl Invocation {
    /// Resolves `given` against `info`, one of `plugin`'s services as the catalogue or
    /// [`Plugin::service`] gave it: the service is not looked up again.
    pub fn resolve(
        plugin: Plugin,
        info: ServiceInfo,
        given: &[(String, Value)],
    ) -> Result<Self, ParamError> {
        debug_assert!(plugin.service(&info.name).is_some(), "a service of this plugin");
        let params = resolve(&info, given)?;
        Ok(Self { plugin, info, params })
    }

    pub fn plugin(&self) -> &Plugin {
        &self.plugin
    }

    pub fn info(&self) -> &ServiceInfo {
        &self.info
    }

    /// Every parameter of the service, in declaration order, defaults filled in.
    pub fn params(&self) -> &[(String, Value)] {
        &self.params
    }
}
