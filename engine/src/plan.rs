//! Host selection: every task of a workflow (IF and WHILE bodies and conditions included)
//! gets a host before the run starts, so the input can be broadcast to exactly those hosts.

use std::collections::HashMap;
use std::sync::Arc;

use crate::registry::{HostEntry, Registry};
use crate::workflow::{Workflow, WorkflowError};

/// Which host runs which task (and its service), by task path.
pub struct Plan {
    by_task: HashMap<String, (String, Arc<HostEntry>)>,
    /// The plugin digest (or prefix) each pinned task must run.
    pins: HashMap<String, String>,
}

impl Plan {
    pub fn new(workflow: &Workflow, registry: &Registry) -> Result<Self, WorkflowError> {
        let mut chosen: Vec<Arc<HostEntry>> = Vec::new();
        let mut by_task = HashMap::new();
        let mut pins = HashMap::new();
        for task in workflow.tasks() {
            let pin = task.plugin.as_deref();
            let candidates = offering_pinned(&registry.hosts(), &task.service, pin);
            let host = pick(&candidates, &chosen, &task.service, &[]).ok_or_else(|| {
                let from = pin.map(|p| format!(" from plugin {p}")).unwrap_or_default();
                WorkflowError::new(
                    &task.path,
                    format!("no host that is up offers \"{}\"{from}", task.service),
                )
            })?;
            if let Some(pin) = pin {
                pins.insert(task.path.clone(), pin.to_owned());
            }
            if !chosen.iter().any(|h| Arc::ptr_eq(h, &host)) {
                chosen.push(host.clone());
            }
            by_task.insert(task.path.clone(), (task.service.clone(), host));
        }
        Ok(Self { by_task, pins })
    }

    /// The plugin a pinned task must run.
    pub fn pin(&self, task_path: &str) -> Option<&str> {
        self.pins.get(task_path).map(String::as_str)
    }

    pub fn host(&self, task_path: &str) -> &Arc<HostEntry> {
        &self.by_task[task_path].1
    }

    pub fn service(&self, task_path: &str) -> &str {
        &self.by_task[task_path].0
    }

    /// Moves a task to another host (after its host failed).
    pub fn assign(&mut self, task_path: &str, host: Arc<HostEntry>) {
        if let Some(entry) = self.by_task.get_mut(task_path) {
            entry.1 = host;
        }
    }

    /// The paths of the tasks planned on `host`.
    pub fn tasks_on(&self, host: &Arc<HostEntry>) -> Vec<String> {
        let mut paths: Vec<String> = self
            .by_task
            .iter()
            .filter(|(_, (_, h))| Arc::ptr_eq(h, host))
            .map(|(path, _)| path.clone())
            .collect();
        paths.sort();
        paths
    }

    /// The distinct hosts of the plan, in a stable order.
    pub fn hosts(&self) -> Vec<Arc<HostEntry>> {
        let mut hosts: Vec<Arc<HostEntry>> = Vec::new();
        for (_, host) in self.by_task.values() {
            if !hosts.iter().any(|h| Arc::ptr_eq(h, host)) {
                hosts.push(host.clone());
            }
        }
        hosts.sort_by(|a, b| a.url.cmp(&b.url));
        hosts
    }
}

/// Among the hosts that are up and offer `service` (and are not excluded), one already in
/// the plan if any, else the least loaded; ties go to the first registered.
pub fn pick(
    hosts: &[Arc<HostEntry>],
    in_plan: &[Arc<HostEntry>],
    service: &str,
    excluded: &[Arc<HostEntry>],
) -> Option<Arc<HostEntry>> {
    let is = |list: &[Arc<HostEntry>], h: &Arc<HostEntry>| list.iter().any(|x| Arc::ptr_eq(x, h));
    hosts
        .iter()
        .filter(|h| h.offers(service) && !is(excluded, h))
        .min_by_key(|h| (!is(in_plan, h), h.load()))
        .cloned()
}

/// The hosts that may run a task: with a pin, only those offering the service from that
/// plugin; without one, all (the planner then looks at who offers the service at all).
pub fn offering_pinned(
    hosts: &[Arc<HostEntry>],
    service: &str,
    pin: Option<&str>,
) -> Vec<Arc<HostEntry>> {
    match pin {
        None => hosts.to_vec(),
        Some(pin) => hosts.iter().filter(|h| h.offers_plugin(service, pin)).cloned().collect(),
    }
}
