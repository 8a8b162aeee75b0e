//! Plugins made ready before a replay needs them (issue 34, "nothing waits that could
//! have run beside"): every host of the plan that may replay a filter step is asked to
//! fetch and compile that step's plugin (`POST /replay-plugins`), from the host planned to
//! run the step, as soon as it holds the run's input (before, the plugins shared its link
//! with the input the first task waits for). A replay then finds the plugin compiled instead
//! of fetching and compiling it inside the transfer (an 18 MB Python component: 23 s).
//!
//! Only what the plan names is asked for: per filter task, its pinned digest or the plugin
//! its planned host serves the service from, to every other host of the plan that does not
//! offer it. A failed prefetch is recorded and nothing else: the replay still fetches the
//! plugin on demand.

use std::collections::HashSet;
use std::sync::{Arc, Mutex};

use meshflow_api::host::{PluginPrefetch, PrefetchOutcome, PrefetchedPlugins, WantedPlugin};
use meshflow_api::params::ServiceKind;
use serde_json::json;

use super::broadcast::InputHolders;
use super::cost::{self, PluginAt, StepOutput};
use super::to_data::MOVE_MARGIN_MS;
use crate::measured::{Measured, step_key};
use crate::plan::Plan;
use crate::record::PrefetchRecord;
use crate::registry::{HostEntry, Registry};
use crate::run::Run;
use crate::workflow::{Transfer, Workflow};
use meshflow_api::host::Transfer as Use;

/// The prefetches of one run: which (host, plugin digest) are ready. The requests are
/// not awaited: one that outlives its run still teaches `measured` that the host holds the
/// plugin (the run's record is final by then and keeps it `pending`).
#[derive(Default)]
pub(super) struct Prefetches {
    ready: Arc<Mutex<HashSet<(String, String)>>>,
}

impl Prefetches {
    /// Asks every host of `plan` that may replay a filter step for that step's plugin, in
    /// the background. Nothing is asked when the workflow's transfer never replays.
    pub fn start(
        run: &Arc<Run>,
        registry: &Arc<Registry>,
        plan: &Plan,
        workflow: &Workflow,
        holders: &InputHolders,
    ) -> Self {
        let prefetches = Self::default();
        if !matches!(workflow.transfer, Transfer::Auto | Transfer::Replay) {
            return prefetches;
        }
        let transfer = workflow.transfer;
        for (receiver, wanted) in wanted(plan, workflow) {
            let (run, registry, ready) = (run.clone(), registry.clone(), prefetches.ready.clone());
            let held = holders.held_by(&receiver.url);
            tokio::spawn(async move {
                let Some(held) = held.await else { return };
                // Only the plugins the cost model is expected to use (on this mesh, by what
                // the steps gave before): the others would take the link and a core from
                // the first tasks for nothing.
                let measured = &registry.measured;
                let (wanted, why): (Vec<WantedPlugin>, Vec<Vec<String>>) = wanted
                    .into_iter()
                    .filter_map(|w| {
                        let bytes = registry.plugin_size(&w.plugin.digest).sent();
                        let expected = w
                            .needs
                            .iter()
                            .filter(|n| n.expected(measured, transfer, held.vertices, bytes));
                        let why: Vec<String> = expected.map(|n| n.why.clone()).collect();
                        (!why.is_empty()).then_some((w.plugin, why))
                    })
                    .unzip();
                if wanted.is_empty() {
                    return;
                }
                let explained = |mut records: Vec<PrefetchRecord>| {
                    for (record, why) in records.iter_mut().zip(&why) {
                        record.why = why.clone();
                    }
                    records
                };
                let started_ms = run.elapsed_ms();
                // In the record before the request: a run that ends before the host
                // answers still says what was under way.
                let pending = explained(pending(&receiver.url, &wanted, started_ms));
                run.update("prefetch", |r| {
                    let json = json!({"host": receiver.url, "plugins": pending});
                    r.prefetches.extend(pending);
                    json
                });
                let answer = receiver.client.prefetch_plugins(wanted.clone()).await;
                let finished_ms = run.elapsed_ms();
                for answered in answer.iter().flat_map(|a| &a.plugins) {
                    if let Some(w) = wanted.iter().find(|w| w.digest == answered.digest) {
                        learn_compile(&registry, (&w.from, &receiver.url), answered);
                    }
                }
                let timing = (started_ms, finished_ms);
                let records = explained(records(&receiver.url, &wanted, answer, timing));
                for record in &records {
                    if record.outcome != PrefetchOutcome::Failed.name() {
                        let key = (receiver.url.clone(), record.plugin.clone());
                        ready.lock().unwrap().insert(key);
                        registry.measured.prefetched(&receiver.url, &record.plugin);
                    }
                }
                run.update("prefetch", |r| {
                    let json = json!({"host": receiver.url, "plugins": records});
                    for record in records {
                        let asked = |p: &&mut PrefetchRecord| {
                            p.host == record.host
                                && p.plugin == record.plugin
                                && p.outcome == PENDING
                        };
                        match r.prefetches.iter_mut().find(asked) {
                            Some(entry) => *entry = record,
                            None => r.prefetches.push(record),
                        }
                    }
                    json
                });
            });
        }
        prefetches
    }

    /// Whether a prefetch made the plugin `digest` ready on `host` in this run.
    pub fn ready(&self, host: &str, digest: &str) -> bool {
        self.ready.lock().unwrap().contains(&(host.to_owned(), digest.to_owned()))
    }

    /// Whether `host` can run the plugin `digest` at once (it offers it, fetched it for an
    /// earlier replay, or a prefetch made it ready), or must fetch it first.
    pub fn plugin_at(&self, registry: &Registry, host: &HostEntry, digest: &str) -> PluginAt {
        let ready = host.has_plugin(digest)
            || registry.measured.has_fetched(&host.url, digest)
            || self.ready(&host.url, digest);
        match ready {
            true => PluginAt::Ready,
            false => PluginAt::Missing(
                registry.plugin_size(digest),
                registry.measured.compile_ms_per_mib(&host.url),
            ),
        }
    }
}

/// A plugin a host may need in the run, and why.
struct Wanted {
    plugin: WantedPlugin,
    needs: Vec<Need>,
}

/// One reason a host may need a plugin, in terms of a filter step's result at `to` from
/// `from`: `to` may replay the step (`Replay`; `to` is the host asking), or a later task
/// planned on `to` may move to `from` (the host asking) because `to` would wait long for
/// the step's result (`Move`).
struct Need {
    /// The step's [`step_key`].
    step: String,
    /// The need in words, for the record.
    why: String,
    from: Arc<HostEntry>,
    to: Arc<HostEntry>,
    kind: NeedKind,
}

#[derive(Clone, Copy, PartialEq)]
enum NeedKind {
    Replay,
    Move,
}

impl Need {
    /// Whether the cost model is expected to act on it, by the step's learned shape on a
    /// mesh of `vertices` (a step never seen, or a mesh of unknown size, is), and whether
    /// that saves more than the plugin's `plugin_bytes` (as sent) cost on the link into the host
    /// fetching it: while they arrive, every request into that host queues behind them —
    /// the edit log the host just made, asked for by the next step's host, waited 0.3–0.7 s
    /// behind 480 KB of plugins on a 5 Mbit/s link, for a move that saved 50 ms.
    fn expected(
        &self,
        measured: &Measured,
        transfer: Transfer,
        vertices: Option<u64>,
        plugin_bytes: Option<u64>,
    ) -> bool {
        let (Some(vertices), Some(shape)) = (vertices, measured.step_shape(&self.step)) else {
            return true;
        };
        let receiver = cost::Receiver {
            link: measured.link(&self.from.url, &self.to.url),
            speed: measured.speed(&self.to.url),
            plugin: PluginAt::Ready,
            load: 0,
        };
        let estimates = cost::estimate(&StepOutput::expected(&shape, vertices), &receiver);
        let way = cost::choose(transfer, &estimates);
        // What acting on it saves, and the link the plugin takes into the asking host (a
        // replay's receiver fetches it from the producer; a producer, from the moving
        // task's planned host).
        let (saved_ms, plugin_link) = match self.kind {
            // A workflow that asks for replays replays whatever the plugin costs.
            NeedKind::Replay if transfer == Transfer::Replay => return true,
            NeedKind::Replay if way == Use::Replay => {
                let otherwise = estimates.correction_ms.min(estimates.full_ms);
                (otherwise - estimates.replay_ms, receiver.link)
            }
            NeedKind::Replay => return false,
            NeedKind::Move => {
                let saved_ms = cost::expected_ms(&estimates, way);
                if saved_ms < MOVE_MARGIN_MS {
                    return false;
                }
                (saved_ms, measured.link(&self.to.url, &self.from.url))
            }
        };
        plugin_bytes.is_none_or(|bytes| saved_ms > plugin_link.transfer_ms(bytes))
    }
}

/// Per host, the plugins it may need: for every filter task, its plugin (the pin, or what
/// its planned host serves the service from), by every host that lacks it and has a task
/// that may come after it (a later one, or any at all for a task in a WHILE body, which
/// may run again), to replay it; and for every task, its plugin, by every host that lacks
/// it and produces a filter that may come before it (the task may move there, where the
/// mesh is).
fn wanted(plan: &Plan, workflow: &Workflow) -> Vec<(Arc<HostEntry>, Vec<Wanted>)> {
    let tasks = workflow.tasks();
    let mut wanted: Vec<(Arc<HostEntry>, Vec<Wanted>)> =
        plan.hosts().into_iter().map(|h| (h, Vec::new())).collect();
    let want = |plugins: &mut Vec<Wanted>, digest: &str, from: &HostEntry, need: Need| match plugins
        .iter_mut()
        .find(|w| w.plugin.digest == digest)
    {
        Some(wanted) => wanted.needs.push(need),
        None => plugins.push(Wanted {
            plugin: WantedPlugin { digest: digest.to_owned(), from: from.url.clone() },
            needs: vec![need],
        }),
    };
    // Per task, if a filter: its planned host, its plugin there, and its shape's key.
    let filters: Vec<Option<(&Arc<HostEntry>, String, String)>> = tasks
        .iter()
        .map(|t| {
            let host = plan.host(&t.path);
            let digest = filter_plugin(host, &t.service, plan.pin(&t.path))?;
            let key = step_key(&digest, &t.service, &t.params);
            Some((host, digest, key))
        })
        .collect();
    for (index, task) in tasks.iter().enumerate() {
        let Some((producer, digest, step)) = &filters[index] else { continue };
        let repeats = task.path.contains(".do[");
        let after = if repeats { &tasks[..] } else { &tasks[index + 1..] };
        for (receiver, plugins) in &mut wanted {
            let receives = after.iter().any(|t| Arc::ptr_eq(plan.host(&t.path), receiver));
            let lacks = !Arc::ptr_eq(receiver, producer) && !receiver.has_plugin(digest);
            if receives && lacks {
                let (from, to) = (Arc::clone(producer), receiver.clone());
                let why = format!("a replay of {} ({})", task.path, task.service);
                let need = Need { step: step.clone(), why, from, to, kind: NeedKind::Replay };
                want(plugins, digest, producer, need);
            }
        }
    }
    // A task may also move to the host holding the mesh (`to_data`): every host producing a
    // filter that may come before a task planned elsewhere makes that task's plugin ready.
    for (index, task) in tasks.iter().enumerate() {
        let home = plan.host(&task.path);
        let Some((digest, _)) = home.plugin_for(&task.service, plan.pin(&task.path)) else {
            continue;
        };
        let repeats = task.path.contains(".do[") || task.path.contains(".while");
        let before = if repeats { tasks.len() } else { index };
        for (producer, plugins) in &mut wanted {
            if Arc::ptr_eq(producer, home) || producer.has_plugin(&digest) {
                continue;
            }
            for (filter, earlier) in filters[..before].iter().zip(&tasks) {
                let Some((host, _, step)) = filter else { continue };
                if !Arc::ptr_eq(host, producer) {
                    continue;
                }
                let (from, to) = (producer.clone(), home.clone());
                let why =
                    format!("{} ({}) moving here after {}", task.path, task.service, earlier.path);
                let need = Need { step: step.clone(), why, from, to, kind: NeedKind::Move };
                want(plugins, &digest, home, need);
            }
        }
    }
    // A host that runs only its own plugins would refuse them.
    wanted.retain(|(host, plugins)| !plugins.is_empty() && host.runs_foreign_plugins());
    wanted
}

/// The digest of the plugin `host` runs the filter `service` from (pinned to a digest
/// starting with `pin`, else the one serving the name to unpinned runs); none for a check.
fn filter_plugin(host: &HostEntry, service: &str, pin: Option<&str>) -> Option<String> {
    let (plugin, kind) = host.plugin_for(service, pin)?;
    (kind == ServiceKind::Filter).then_some(plugin)
}

/// What a plugin fetched and compiled on `host` (from `from`) tells of the host's compile
/// speed.
pub(super) fn learn_compile(
    registry: &Registry,
    (from, host): (&str, &str),
    prefetch: &PluginPrefetch,
) {
    if prefetch.outcome != PrefetchOutcome::Fetched {
        return;
    }
    let size = registry.plugin_size(&prefetch.digest);
    if let (Some(component), Some(sent)) = (prefetch.bytes.or(size.component), size.sent()) {
        registry.measured.fetched_and_compiled((from, host), (component, sent), prefetch.ms);
    }
}

/// A prefetch asked for and not answered yet (the record keeps it if the run ends first).
const PENDING: &str = "pending";

fn pending(host: &str, wanted: &[WantedPlugin], started_ms: f64) -> Vec<PrefetchRecord> {
    let record = |w: &WantedPlugin| PrefetchRecord {
        host: host.to_owned(),
        plugin: w.digest.clone(),
        from: w.from.clone(),
        outcome: PENDING.to_owned(),
        ms: 0.0,
        bytes: None,
        started_ms,
        finished_ms: started_ms,
        error: None,
        why: Vec::new(),
    };
    wanted.iter().map(record).collect()
}

/// The record of one host's prefetch: its answer per plugin, or the request's failure for
/// each. An answer is believed only for the digests asked, once each.
fn records(
    host: &str,
    wanted: &[WantedPlugin],
    answer: Result<PrefetchedPlugins, meshflow_api::ClientError>,
    (started_ms, finished_ms): (f64, f64),
) -> Vec<PrefetchRecord> {
    let failed = |w: &WantedPlugin, error: String| PrefetchRecord {
        host: host.to_owned(),
        plugin: w.digest.clone(),
        from: w.from.clone(),
        outcome: PrefetchOutcome::Failed.name().to_owned(),
        ms: finished_ms - started_ms,
        bytes: None,
        started_ms,
        finished_ms,
        error: Some(error),
        why: Vec::new(),
    };
    let answered = match answer {
        Ok(answered) => answered.plugins,
        Err(error) => return wanted.iter().map(|w| failed(w, error.to_string())).collect(),
    };
    wanted
        .iter()
        .map(|w| match answered.iter().find(|a| a.digest == w.digest) {
            Some(a) => PrefetchRecord {
                outcome: a.outcome.name().to_owned(),
                ms: a.ms,
                bytes: a.bytes,
                error: a.error.as_ref().map(|e| meshflow_api::params::clip(e)),
                ..failed(w, String::new())
            },
            None => failed(w, "the host's answer did not name it".to_owned()),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use meshflow_api::ClientError;
    use meshflow_api::host::PluginPrefetch;

    use super::*;

    /// What three steps of the repair workflow gave on a 1.07M-vertex scan (the WAN run).
    fn step(correction_bytes: u64, edits: u64, compute_ms: f64) -> StepOutput {
        let (full_bytes, replay_bytes, vertices) = (6_250_000, 200, 1_050_000);
        StepOutput { correction_bytes, replay_bytes, full_bytes, edits, vertices, compute_ms }
    }

    #[tokio::test]
    async fn a_plugin_is_wanted_where_the_cost_model_is_expected_to_use_it() {
        let dir = tempfile::tempdir().unwrap();
        let (registry, _store) = crate::registry::test_registry(dir.path());
        let (from, to) = (
            registry.register("http://127.0.0.1:9/p").await.unwrap(),
            registry.register("http://127.0.0.1:9/r").await.unwrap(),
        );
        let measured = &registry.measured;
        // A 5 Mbit/s link into the receiver.
        measured.downloaded(None, &to.url, 6_250_000, 10_000.0);
        let learn =
            |key: &str, output: StepOutput| measured.learn_step(key, output.shape().unwrap());
        learn("components", step(278, 9_016, 392.0));
        learn("holes", step(270_916, 50_000, 666.0));
        learn("noise", step(6_171_500, 1_050_000, 74.0));
        let need = |step: &str, kind| Need {
            step: step.to_owned(),
            why: String::new(),
            from: from.clone(),
            to: to.clone(),
            kind,
        };
        let expected =
            |need: Need, vertices| need.expected(measured, Transfer::Auto, vertices, None);
        let at = Some(1_000_000);
        // A step never seen, or a mesh of unknown size: wanted, as before anything is learned.
        assert!(expected(need("never seen", NeedKind::Replay), at));
        assert!(expected(need("components", NeedKind::Replay), None));
        // A 278-byte edit log crosses the link in a blink: nobody replays the step, and
        // applying it (a pass over the mesh: ~0.25 µs a vertex until measured) is too short
        // a wait to move for on half a million vertices.
        assert!(!expected(need("components", NeedKind::Replay), at));
        assert!(!expected(need("components", NeedKind::Move), Some(500_000)));
        // 6 MB of noise is replayed (74 ms of compute).
        assert!(expected(need("noise", NeedKind::Replay), at));
        // Filled holes travel as their 270 KB log, but the ~0.4 s it takes at 5 Mbit/s is
        // worth moving the next task to the data for.
        assert!(!expected(need("holes", NeedKind::Replay), at));
        assert!(expected(need("holes", NeedKind::Move), at));
        // On a mesh a hundredth the size the log is a few KB: no move either.
        assert!(!expected(need("holes", NeedKind::Move), Some(10_000)));
        // A workflow that asks for replays gets its plugins whatever the shapes.
        let replays = need("components", NeedKind::Replay);
        assert!(replays.expected(measured, Transfer::Replay, at, None));
        assert!(replays.expected(measured, Transfer::Replay, at, Some(20_000_000)));

        // Only where it saves more than the plugin's time on the link into the host that
        // fetches it (5 Mbit/s into `from` too): 2 MB of plugin (3.2 s) for a move that
        // saves about half a second is not worth it; 100 KB (0.16 s) is. The noise's replay
        // saves seconds: worth a plugin of 2 MB.
        measured.downloaded(None, &from.url, 6_250_000, 10_000.0);
        let sized = |need: Need, bytes| need.expected(measured, Transfer::Auto, at, Some(bytes));
        assert!(!sized(need("holes", NeedKind::Move), 2_000_000));
        assert!(sized(need("holes", NeedKind::Move), 100_000));
        assert!(sized(need("noise", NeedKind::Replay), 2_000_000));
        assert!(!sized(need("noise", NeedKind::Replay), 20_000_000));
    }

    #[test]
    fn an_answer_counts_only_for_the_plugins_asked() {
        let wanted = vec![
            WantedPlugin { digest: "a".repeat(64), from: "http://p".into() },
            WantedPlugin { digest: "b".repeat(64), from: "http://p".into() },
        ];
        let answer = PrefetchedPlugins {
            plugins: vec![
                PluginPrefetch {
                    digest: "a".repeat(64),
                    outcome: PrefetchOutcome::Fetched,
                    ms: 12.5,
                    bytes: Some(1000),
                    error: None,
                },
                // Not asked: ignored.
                PluginPrefetch {
                    digest: "c".repeat(64),
                    outcome: PrefetchOutcome::Present,
                    ms: 0.0,
                    bytes: None,
                    error: None,
                },
            ],
        };
        let found = records("http://r", &wanted, Ok(answer), (1.0, 20.0));
        let outcomes: Vec<&str> = found.iter().map(|r| r.outcome.as_str()).collect();
        assert_eq!(outcomes, ["fetched", "failed"]);
        assert_eq!(
            (found[0].ms, found[0].bytes, found[0].error.as_deref()),
            (12.5, Some(1000), None)
        );
        assert!(found[1].error.as_deref().unwrap().contains("did not name it"));
        let refused = ClientError::Timeout { url: "http://r".into(), message: "slow".into() };
        let found = records("http://r", &wanted, Err(refused), (1.0, 20.0));
        assert!(found.iter().all(|r| r.outcome == "failed" && r.ms == 19.0), "{found:?}");
    }
}
