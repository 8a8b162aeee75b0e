//! A filter step: its output becomes the current mesh, and is forwarded at once, in
//! parallel, to every host that still has a task on the active list, each by the transfer
//! the cost model (or the workflow) chooses.

use std::sync::Arc;

use meshflow_api::host::{FilterResult, RunResult, Update};

use super::error::ExecError;
use super::{Executor, cost, replica};
use crate::measured::step_key;
use crate::registry::HostEntry;
use crate::workflow::{Task, Transfer};

impl Executor {
    /// Runs a filter (or takes it as done before a restart) and forwards its result to the
    /// `receivers`, the hosts of the tasks still to come.
    pub(super) async fn run_filter(
        &mut self,
        task: &Task,
        receivers: &[Arc<HostEntry>],
    ) -> Result<(), ExecError> {
        if let Some(step) = self.take_done(task, "filter")? {
            return self.restore_filter(task, &step);
        }
        let (index, result, host) = self.run_task(task, "filter").await?;
        let input = self.step_input(index, task, &result);
        let (result, host) = self.vouch(&input, result, host).await?;
        let RunResult::Filter(filter) = result else {
            return Err(ExecError::NotAMesh {
                path: task.path.clone(),
                service: task.service.clone(),
            });
        };
        self.advance(&filter, &host);
        self.history.push((task.clone(), filter.output_hash.clone()));
        let output = cost::StepOutput {
            correction_bytes: filter.correction.bytes,
            replay_bytes: filter.replay.bytes,
            full_bytes: self.current.last_full.estimate(filter.vertices as u64),
            edits: filter.edits as u64,
            vertices: filter.vertices as u64,
            compute_ms: filter.compute_ms,
        };
        // The log's real size, for the record and, as the step's shape, for the next
        // runs' prefetches.
        let log_size = super::finish::record_log_size(
            self.run.clone(),
            (host.client.clone(), filter.correction.url.clone()),
            index,
            (self.registry.clone(), step_key(&filter.plugin, &task.service, &task.params), output),
        );
        self.log_sizes.push(log_size);
        let hash = self.current.hash.clone();
        let last_full = self.current.last_full.clone();
        let measured = &self.registry.measured;
        for replica in &mut self.replicas {
            let wanted = receivers.iter().any(|h| Arc::ptr_eq(h, &replica.host));
            if !wanted || Arc::ptr_eq(&replica.host, &host) || replica.host.is_suspect() {
                continue;
            }
            let receiver = &replica.host;
            let plugin = self.prefetches.plugin_at(&self.registry, receiver, &filter.plugin);
            let has_plugin = plugin == cost::PluginAt::Ready;
            let mut estimates = cost::estimate(
                &output,
                &cost::Receiver {
                    link: measured.link(&host.url, &receiver.url),
                    speed: measured.speed(&receiver.url),
                    plugin,
                    load: receiver.load(),
                },
            );
            if !has_plugin && !receiver.runs_foreign_plugins() {
                // It would refuse to fetch the plugin and fall back to the edit log. (The
                // largest finite number: the record keeps estimates as JSON numbers.)
                estimates.replay_ms = f64::MAX;
            }
            let use_ = cost::choose(self.transfer, &estimates);
            let expected_ms = cost::expected_ms(&estimates, use_);
            let update = Update {
                correction: Some(filter.correction.clone()),
                replay: Some(filter.replay.clone()),
                full: filter.full.clone(),
                use_,
            };
            let forwarded = replica::Forwarded {
                update,
                plugin: filter.plugin.clone(),
                had_plugin: has_plugin,
                estimates: (self.transfer == Transfer::Auto).then_some(estimates),
                output,
                last_full: last_full.clone(),
                registry: self.registry.clone(),
                disputes: self.disputes.clone(),
            };
            replica.forward(&self.run, index, forwarded, &hash, &host, expected_ms);
        }
        Ok(())
    }

    /// The filter's output becomes the current mesh; the producer already holds it.
    fn advance(&mut self, filter: &FilterResult, producer: &Arc<HostEntry>) {
        self.holders.clear();
        self.current.advance(filter, &producer.url);
        if let Some(replica) = self.replicas.iter_mut().find(|r| Arc::ptr_eq(&r.host, producer)) {
            replica.hash = filter.output_hash.clone();
        }
    }
}
