//! The input broadcast (DESIGN §5): the run's input goes to every host of the plan at once;
//! a host that fails to load it has its tasks moved to other hosts, which load it in turn.

use super::words::bounded_words;
use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use std::time::Instant;

use meshflow_api::engine::InputRecord;
use meshflow_api::host::GridSpec;
use serde_json::json;

use super::current::Current;
use super::error::ExecError;
use super::failure::StepFailed;
use super::replica::Replica;
use super::session::load_input;
use crate::plan::{Plan, offering_pinned, pick, placed_by_link};
use crate::record::{BroadcastRecord, HostLoad};
use crate::registry::{HostEntry, Registry};
use crate::run::Run;

/// Which hosts hold the run's input so far, and whether the broadcast is over: a host's
/// plugin prefetches wait for its input, so that the plugins do not share its link with
/// the input, which the first task waits for (at 5 Mbit/s they made the 200k scan's
/// broadcast 0.4-0.9 s longer).
pub(super) struct InputHolders(tokio::sync::watch::Sender<Holders>);

#[derive(Default)]
pub(super) struct Holders {
    /// With the input's vertex count as each loaded it, and its session there.
    hosts: BTreeMap<String, Held>,
    /// Every host of the plan holds it already (a resumed run's restored input): its
    /// vertex count as recorded.
    all: Option<Option<u64>>,
    over: bool,
}

/// A host holds the run's input, of this many vertices (when it said).
#[derive(Clone)]
pub(super) struct Held {
    pub vertices: Option<u64>,
    /// The session holding it there; not known of a restored input.
    pub session: Option<String>,
}

impl InputHolders {
    pub fn new() -> Self {
        Self(tokio::sync::watch::Sender::new(Holders::default()))
    }

    fn hold(&self, host: &str, session: &str, vertices: Option<u64>) {
        let held = Held { vertices, session: Some(session.to_owned()) };
        self.0.send_modify(|h| {
            h.hosts.insert(host.to_owned(), held);
        });
    }

    /// The hosts kept their sessions of the input (a resumed run), of `vertices`.
    pub fn restored(&self, vertices: Option<u64>) {
        self.0.send_modify(|h| h.all = Some(vertices));
    }

    /// The broadcast ended (loaded, restored or failed): nobody waits any longer.
    pub fn over(&self) {
        self.0.send_modify(|h| h.over = true);
    }

    /// Resolves once `host` holds the input, or to `None` once the broadcast ended without
    /// it or the run is gone (a prefetch there would serve nothing).
    pub fn held_by(
        &self,
        host: &str,
    ) -> impl std::future::Future<Output = Option<Held>> + Send + 'static {
        let (mut holders, host) = (self.0.subscribe(), host.to_owned());
        async move {
            let held = |h: &Holders| {
                let restored = h.all.map(|vertices| Held { vertices, session: None });
                restored.or_else(|| h.hosts.get(&host).cloned())
            };
            match holders.wait_for(|h| h.over || held(h).is_some()).await {
                Ok(holders) => held(&holders),
                Err(_) => None,
            }
        }
    }
}

/// The input once loaded: the current mesh, and the hosts holding it.
pub(super) struct Loaded {
    pub current: Current,
    pub replicas: Vec<Replica>,
}

/// Sends the run's input to every host of the plan at once and waits until all hold it,
/// telling `holders` of each as it does.
pub(super) async fn broadcast(
    run: &Arc<Run>,
    registry: &Registry,
    plan: &mut Plan,
    quantize: Option<u32>,
    holders: &InputHolders,
) -> Result<Loaded, ExecError> {
    let input = run.input.as_str();
    let started = Instant::now();
    let mut hosts = plan.hosts();
    let mut loads = Vec::new();
    let mut excluded = Vec::new();
    let mut current = None;
    let mut replicas = Vec::new();
    while !hosts.is_empty() {
        let grid = quantize.map(GridSpec::Bits);
        let attempts = hosts.iter().map(|host| async move {
            let outcome = load_input(run, host.clone(), input, None, grid).await;
            if let Ok((session, status)) = &outcome {
                holders.hold(&host.url, session, status.vertices.map(|v| v as u64));
            }
            outcome
        });
        let outcomes = futures_util::future::join_all(attempts).await;
        let mut retry = Vec::new();
        for (host, outcome) in hosts.iter().zip(outcomes) {
            match outcome {
                Ok((session, status)) => {
                    let hash = status.hash.clone().unwrap_or_default();
                    let load = HostLoad {
                        host: host.url.clone(),
                        bytes: status.input_bytes.unwrap_or(0),
                        download_ms: status.download_ms.unwrap_or(0.0),
                        load_ms: status.load_ms.unwrap_or(0.0),
                    };
                    // What the link into this host is worth, until pairs are measured.
                    let measured = &registry.measured;
                    measured.downloaded(None, &host.url, load.bytes, load.download_ms);
                    loads.push(load);
                    if current.is_none() {
                        current = Some(input_loaded(run, input, &status));
                    }
                    replicas.push(Replica::new(host.clone(), session, hash));
                }
                Err(failure) => {
                    failure.set_aside(host).map_err(|StepFailed(message)| ExecError::Input {
                        input: input.to_owned(),
                        message,
                    })?;
                    excluded.push(host.clone());
                    retry.extend(replace(plan, registry, host, &excluded)?);
                }
            }
        }
        hosts = retry;
    }
    let hashes: BTreeSet<String> = replicas.iter().map(|r: &Replica| r.hash.clone()).collect();
    if hashes.len() > 1 {
        return Err(ExecError::InputDecodedDifferently { input: input.to_owned(), hashes });
    }
    // Every workflow has a task, so some host of the plan loaded the input.
    let current = current.ok_or_else(|| ExecError::Input {
        input: input.to_owned(),
        message: "no host of the plan loaded it".to_owned(),
    })?;
    let ms = started.elapsed().as_secs_f64() * 1e3;
    run.update("broadcast", |r| {
        let record = BroadcastRecord { ms, hosts: loads };
        let json = json!(record);
        r.broadcast = Some(record);
        json
    });
    Ok(Loaded { current, replicas })
}

/// The input as the first host to load it tells it, which the record keeps.
fn input_loaded(run: &Run, url: &str, status: &meshflow_api::host::SessionStatus) -> Current {
    let current = Current::loaded(url, status);
    let record = InputRecord {
        not_kept: bounded_words(&status.not_kept),
        attributes: bounded_words(&status.attributes),
        ..current.input_record(url)
    };
    run.update("input", |r| {
        let json = json!(record);
        r.input = Some(record);
        json
    });
    current
}

/// Moves every task planned on the failed `host` to other hosts; returns the hosts that are
/// new to the plan.
fn replace(
    plan: &mut Plan,
    registry: &Registry,
    host: &Arc<HostEntry>,
    excluded: &[Arc<HostEntry>],
) -> Result<Vec<Arc<HostEntry>>, ExecError> {
    let before = plan.hosts();
    for path in plan.tasks_on(host) {
        let service = plan.service(&path).to_owned();
        let pin = plan.pin(&path);
        let candidates = offering_pinned(&registry.hosts(), &service, pin);
        let measured = placed_by_link(plan.placement(), registry);
        let replacement =
            pick(&candidates, &before, &service, excluded, measured).ok_or_else(|| {
                ExecError::NoReplacement { path: path.clone(), host: host.url.clone(), service }
            })?;
        plan.assign(&path, replacement);
    }
    let after = plan.hosts();
    Ok(after.into_iter().filter(|h| !before.iter().any(|b| Arc::ptr_eq(b, h))).collect())
}
