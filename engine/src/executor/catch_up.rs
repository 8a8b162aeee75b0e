//! Catching a host up to the current mesh before its task: it waits for the updates
//! forwarded to it; a host that fell behind (or whose update failed) fetches the mesh whole
//! from its producer or any host holding it; a host new to the run opens a session from
//! such a copy; and when no copy survives, a host offering every filter run so far
//! rebuilds the mesh from the input, hash-checked step by step.

use std::sync::Arc;

use meshflow_api::host::{FullRef, GridSpec, RunRequest, RunResult, Transfer as Use, Update};
use serde_json::json;

use super::failure::Failure;
use super::replica::Replica;
use super::session::load_input;
use super::verify::{self, full_mesh_url};
use super::{Executor, busy};
use crate::registry::HostEntry;

impl Executor {
    /// The session on `host` holding the current mesh: waits for forwarded updates, sends
    /// the full mesh to a host that fell behind, and opens a session on a host new to the
    /// run (a replacement) from the current full mesh.
    pub(super) async fn bring_up_to_date(
        &mut self,
        host: &Arc<HostEntry>,
    ) -> Result<String, Failure> {
        // A disagreement about a step this host took is settled before it builds on it.
        if let Some(replica) = self.replicas.iter_mut().find(|r| Arc::ptr_eq(&r.host, host)) {
            replica.wait().await;
        }
        self.resolve_disputes().await.map_err(|error| Failure::Step(error.to_string()))?;
        if let Some(why) = host.suspicion() {
            return Err(Failure::Suspect(why.trim_start_matches("suspect: ").to_owned()));
        }
        let hash = self.current.hash.clone();
        let sources = self.full_sources(host);
        // Why each copy could not be used, for the error if nothing else works either.
        let mut refusals: Vec<String> = Vec::new();
        if let Some(index) = self.replicas.iter().position(|r| Arc::ptr_eq(&r.host, host)) {
            let replica = &mut self.replicas[index];
            if replica.settle(&hash).await {
                return Ok(replica.session.clone());
            }
            for url in &sources {
                let full = FullRef { url: url.clone(), hash: hash.clone() };
                let update = Update { correction: None, replay: None, full, use_: Use::Full };
                let started = std::time::Instant::now();
                let outcome = host.client.update(&replica.session, &update).await;
                match &outcome {
                    Ok(updated) => self.registry.metrics.transferred(
                        Use::Full,
                        updated.bytes,
                        started.elapsed(),
                    ),
                    Err(_) => self.registry.metrics.transfer_failed(Use::Full),
                }
                match outcome {
                    Ok(updated) => {
                        verify::updated(&updated, &hash)?;
                        replica.hash = hash;
                        return Ok(replica.session.clone());
                    }
                    Err(error) if error.is_host_failure() => return Err(error.into()),
                    Err(error) => refusals.push(format!("update from {url}: {error}")),
                }
            }
            self.replicas.remove(index);
        }
        let grid = self.current.grid.map(GridSpec::Exponents);
        for url in &sources {
            match load_input(&self.run, host.clone(), url, Some(hash.clone()), grid).await {
                Ok((session, _)) => {
                    self.replicas.push(Replica::new(host.clone(), session.clone(), hash));
                    return Ok(session);
                }
                Err(Failure::Step(error)) => refusals.push(format!("load of {url}: {error}")),
                Err(host_failure) => return Err(host_failure),
            }
        }
        for message in &refusals {
            tracing::warn!(host = %host.url, "no copy of mesh {hash}: {message}");
        }
        let missing: Vec<&str> = self
            .history
            .iter()
            .map(|(task, _)| task.service.as_str())
            .filter(|service| !host.offers(service))
            .collect();
        if !missing.is_empty() {
            return Err(Failure::Step(format!(
                "{} could not get mesh {hash} ({}) and cannot rebuild it from the input: it does \
                 not offer {}",
                host.url,
                refusals.join("; "),
                missing.join(", ")
            )));
        }
        self.replay_from_input(host).await
    }

    /// The last resort when no copy of the current mesh is reachable: load the input on
    /// `host` (which offers every service run so far) and run every filter since, checking
    /// each output hash against the record.
    async fn replay_from_input(&mut self, host: &Arc<HostEntry>) -> Result<String, Failure> {
        let input_hash = self.run.record().input.map(|i| i.hash);
        let grid = self.quantize.map(GridSpec::Bits);
        let (session, _) =
            load_input(&self.run, host.clone(), &self.run.input, input_hash, grid).await?;
        for (task, expected) in &self.history {
            let request = RunRequest {
                service: task.service.clone(),
                params: task.params.clone(),
                plugin: task.plugin.clone(),
            };
            let output = match busy::run_when_free(&host.client, &session, &request).await.0? {
                RunResult::Filter(filter) => filter.output_hash,
                RunResult::Check(_) => String::new(),
            };
            if &output != expected {
                return Err(Failure::Step(format!(
                    "replaying {} on {} gave mesh {output}, the run had {expected}",
                    task.path, host.url
                )));
            }
        }
        let warning = format!(
            "no copy of the current mesh survived; {} replayed {} filter step(s) from the input",
            host.url,
            self.history.len()
        );
        self.run.update("warning", |r| {
            r.warnings.push(warning.clone());
            json!(warning)
        });
        let hash = self.current.hash.clone();
        self.replicas.push(Replica::new(host.clone(), session.clone(), hash));
        Ok(session)
    }

    /// Where the current mesh can be fetched whole: the producer's full-mesh URL, then every
    /// other host whose session holds (or is about to hold) it — hosts pack a session's
    /// mesh on request — in case the producer is gone.
    fn full_sources(&self, except: &Arc<HostEntry>) -> Vec<String> {
        let current = &self.current;
        let mut sources = vec![current.full.url.clone()];
        let holders = self.replicas.iter().filter(|r| r.hash == current.hash).map(|r| &r.host.url);
        for host in holders.chain(&self.holders) {
            let url = full_mesh_url(host, &current.hash);
            if *host != except.url && !sources.contains(&url) {
                sources.push(url);
            }
        }
        sources
    }
}
