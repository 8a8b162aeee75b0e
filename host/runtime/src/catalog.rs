//! The plugins one host (or one CLI invocation) knows, and which one offers a service.

use crate::{Plugin, RunError, ServiceInfo};

/// Plugins in priority order: when two offer a service of the same name, the earlier wins,
/// so a user's plugin can stand in for a built-in one.
#[derive(Default, Clone)]
pub struct Catalog {
    plugins: Vec<Plugin>,
}

impl Catalog {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a plugin after those already present; a plugin already present (same digest)
    /// is not added twice.
    pub fn add(&mut self, plugin: Plugin) {
        if !self.plugins.iter().any(|p| p.digest == plugin.digest) {
            self.plugins.push(plugin);
        }
    }

    pub fn plugins(&self) -> &[Plugin] {
        &self.plugins
    }

    /// Every service on offer with the plugin that provides it; shadowed ones left out.
    pub fn services(&self) -> Vec<(&ServiceInfo, &Plugin)> {
        let mut seen = std::collections::HashSet::new();
        self.plugins
            .iter()
            .flat_map(|p| p.services.iter().map(move |s| (s, p)))
            .filter(|(s, _)| seen.insert(s.name.as_str()))
            .collect()
    }

    /// Every service of every plugin, in priority order, each with whether it is the one
    /// an unpinned run gets (false: a plugin earlier in the order offers the same name).
    pub fn every_service(&self) -> Vec<(&ServiceInfo, &Plugin, bool)> {
        let mut seen = std::collections::HashSet::new();
        self.plugins
            .iter()
            .flat_map(|p| p.services.iter().map(move |s| (s, p)))
            .map(|(s, p)| (s, p, seen.insert(s.name.as_str())))
            .collect()
    }

    /// The plugin offering `service`, or an error listing every service on offer (and
    /// the one a typo probably meant).
    pub fn find(&self, service: &str) -> Result<(&Plugin, &ServiceInfo), RunError> {
        self.plugins.iter().find_map(|p| p.service(service).map(|s| (p, s))).ok_or_else(|| {
            let offered = self.services();
            let names = || offered.iter().map(|(s, _)| s.name.as_str());
            RunError::UnknownService {
                service: service.to_owned(),
                suggestion: meshflow_params::did_you_mean(service, names()),
                available: names().collect::<Vec<_>>().join(", "),
            }
        })
    }
}
