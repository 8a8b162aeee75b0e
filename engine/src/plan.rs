//! Host selection: every task of a workflow (IF and WHILE bodies and conditions included)
//! gets a host before the run starts, so the input can be broadcast to exactly those hosts.

use std::collections::HashMap;
use std::sync::Arc;

use crate::measured::Measured;
use crate::registry::{HostEntry, Registry};
use crate::workflow::{Placement, Workflow, WorkflowError};

/// Which host runs which task (and its service), by task path.
pub struct Plan {
    by_task: HashMap<String, (String, Arc<HostEntry>)>,
    /// The plugin digest (or prefix) each pinned task must run.
    pins: HashMap<String, String>,
    placement: Placement,
}

impl Plan {
    pub fn new(workflow: &Workflow, registry: &Registry) -> Result<Self, WorkflowError> {
        let mut chosen: Vec<Arc<HostEntry>> = Vec::new();
        let mut by_task = HashMap::new();
        let mut pins = HashMap::new();
        for task in workflow.tasks() {
            let pin = task.plugin.as_deref();
            let candidates = offering_pinned(&registry.hosts(), &task.service, pin);
            let measured = placed_by_link(workflow.placement, registry);
            let host =
                pick(&candidates, &chosen, &task.service, &[], measured).ok_or_else(|| {
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
        Ok(Self { by_task, pins, placement: workflow.placement })
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

    /// How hosts were chosen, for replacements.
    pub fn placement(&self) -> Placement {
        self.placement
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

/// The measurements `pick` weighs, if the placement weighs links.
pub fn placed_by_link(placement: Placement, registry: &Registry) -> Option<&Measured> {
    (placement == Placement::Link).then_some(&registry.measured)
}

/// What bringing a host into a run costs, in the units of its measured link: a mesh of
/// about a million vertices, packed.
const REFERENCE_MESH_BYTES: u64 = 4 << 20;
/// What each task already running or assigned on a host adds to a new task's wait there.
pub const QUEUE_MS_PER_TASK: f64 = 500.0;

/// Among the hosts that are up and offer `service` (and are not excluded), one already in
/// the plan if any (few distinct hosts, few transfers); else, with `measured` links, the
/// one where a task is expected soonest: the mesh brought over its measured link plus the
/// wait behind its load (the paper's connection efficiency and load balancing); without,
/// the least loaded. Ties go to the first registered.
pub fn pick(
    hosts: &[Arc<HostEntry>],
    in_plan: &[Arc<HostEntry>],
    service: &str,
    excluded: &[Arc<HostEntry>],
    measured: Option<&Measured>,
) -> Option<Arc<HostEntry>> {
    let is = |list: &[Arc<HostEntry>], h: &Arc<HostEntry>| list.iter().any(|x| Arc::ptr_eq(x, h));
    let expected_ms = |h: &Arc<HostEntry>| {
        let link = measured.map_or(0.0, |m| m.link_into(&h.url).transfer_ms(REFERENCE_MESH_BYTES));
        link + QUEUE_MS_PER_TASK * f64::from(h.load())
    };
    hosts
        .iter()
        .filter(|h| h.offers(service) && !is(excluded, h))
        .map(|h| ((!is(in_plan, h), expected_ms(h)), h))
        .min_by(|(a, _), (b, _)| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal))
        .map(|(_, h)| h.clone())
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Three hosts offer smoothing; the first's link was measured at 2 Mbit/s, the second's
    /// at 50 Mbit/s, the third is busy.
    #[tokio::test]
    async fn a_host_outside_the_plan_is_chosen_by_its_link_and_its_load() {
        let dir = tempfile::tempdir().unwrap();
        let (registry, _) = crate::registry::test_registry(dir.path());
        let mut hosts = Vec::new();
        for name in ["slow", "fast", "busy"] {
            let host = registry.register(&format!("http://127.0.0.1:9/{name}")).await.unwrap();
            host.pretend_offering(&["smooth"]);
            hosts.push(host);
        }
        let (slow, fast, busy) = (&hosts[0], &hosts[1], &hosts[2]);
        for _ in 0..20 {
            // 5 MB inputs: 20 s at 2 Mbit/s, 0.8 s at 50 Mbit/s.
            registry.measured.downloaded(None, &slow.url, 5_000_000, 20_000.0);
            registry.measured.downloaded(None, &fast.url, 5_000_000, 800.0);
            registry.measured.downloaded(None, &busy.url, 5_000_000, 800.0);
        }
        let _tasks: Vec<_> = (0..4).map(|_| busy.assign()).collect();
        let measured = Some(&registry.measured);
        let chosen = pick(&hosts, &[], "smooth", &[], measured).unwrap();
        assert_eq!(chosen.url, fast.url);
        // By load alone: the first registered of the idle ones, whatever its link.
        assert_eq!(pick(&hosts, &[], "smooth", &[], None).unwrap().url, slow.url);
        // Without the fast one: 0.7 s of transfer and 4 tasks to wait for (2 s) beat 17 s.
        let chosen = pick(&hosts, &[], "smooth", std::slice::from_ref(fast), measured).unwrap();
        assert_eq!(chosen.url, busy.url);
        // A host already in the plan is kept, however slow its link: it follows the run.
        let chosen = pick(&hosts, std::slice::from_ref(slow), "smooth", &[], measured).unwrap();
        assert_eq!(chosen.url, slow.url);
        assert!(pick(&hosts, &[], "other", &[], measured).is_none());
    }
}
