//! Code moves to the data (issue 34 item 3): a task whose planned host is still catching up
//! with the current mesh — re-running the step before, or downloading it — runs instead on
//! the host that produced that mesh, which fetches the task's plugin by digest (as hosts do
//! for replays), when the cost model expects that sooner by a clear margin. The plugin is
//! the one the planned host would have run (a pin still holds), so the step's result is the
//! same; the record says where the step ran and why. Only in `auto` and `replay` transfers
//! (the others name the protocol the user asked for), only to a host that runs fetched
//! plugins (not one started with `--no-foreign-plugins`) and that the admin trusts fully.

use std::sync::Arc;
use std::time::{Duration, Instant};

use meshflow_api::engine::MovedToData;
use meshflow_api::host::{PrefetchOutcome, WantedPlugin};

use super::Executor;
use super::cost::{PLUGIN_BYTES_GUESS, PluginAt};
use super::prefetch::learn_compile;
use crate::plan::QUEUE_MS_PER_TASK;
use crate::registry::HostEntry;
use crate::trust::Trust;
use crate::workflow::{Task, Transfer};

/// How much sooner the host holding the mesh must be expected to start the task before it
/// moves there: a move piles the run onto one host, and estimates err; a replay of a
/// cotangent smoothing step of a 1M-vertex scan (~400 ms) is worth moving for, the tens of
/// milliseconds a small mesh's update takes on loopback are not.
pub const MOVE_MARGIN_MS: f64 = 250.0;

/// Where a task moves, with what, and why.
pub(super) struct Move {
    pub host: Arc<HostEntry>,
    /// The plugin the planned host would have run the task with.
    pub plugin: String,
    pub record: MovedToData,
}

impl Executor {
    /// Whether `task`, planned on `planned`, should run on the producer of the current mesh
    /// instead; when it should, the plugin is made ready there first.
    pub(super) async fn move_to_data(&self, task: &Task, planned: &Arc<HostEntry>) -> Option<Move> {
        if !matches!(self.transfer, Transfer::Auto | Transfer::Replay) {
            return None;
        }
        let producer = self.registry.host(self.current.producer.as_deref()?)?;
        let usable = producer.is_up()
            && !producer.is_suspect()
            && producer.trust() == Trust::Trusted
            && producer.runs_foreign_plugins();
        if Arc::ptr_eq(&producer, planned) || !usable {
            return None;
        }
        // The planned host's copy: how long until it holds the current mesh.
        let replica = self.replicas.iter().find(|r| Arc::ptr_eq(&r.host, planned))?;
        let waiting_ms = replica.expected_wait_ms(&self.current.hash, Instant::now())?;
        let (plugin, _) = planned.plugin_for(&task.service, task.plugin.as_deref())?;
        let measured = &self.registry.measured;
        // The producer may be busy with other runs' tasks: as the planner counts them.
        let queue_ms = QUEUE_MS_PER_TASK * f64::from(producer.load());
        let budget_ms = waiting_ms - queue_ms - MOVE_MARGIN_MS;
        // The plugin's bytes must cross the link within that; its compile is not estimated
        // but raced (a compile cache may answer it in milliseconds, a busy machine take a
        // second): the producer is asked for it, and the task moves only if it is ready
        // while the planned host is still expected to wait by the margin.
        let fetch_ms = match self.prefetches.plugin_at(&self.registry, &producer, &plugin) {
            PluginAt::Ready => 0.0,
            PluginAt::Missing(size, _) => measured
                .link(&planned.url, &producer.url)
                .transfer_ms(size.sent().unwrap_or(PLUGIN_BYTES_GUESS)),
        };
        if fetch_ms >= budget_ms {
            return None;
        }
        let asked = Instant::now();
        // What an earlier run fetched there is only a hint for the estimate: a host that
        // restarted since holds its fetched plugins no longer. Unless it offers the plugin
        // or this run's prefetch made it ready, it is asked (a plugin it has: "present").
        let ready = producer.has_plugin(&plugin) || self.prefetches.ready(&producer.url, &plugin);
        if !ready {
            let wanted = vec![WantedPlugin { digest: plugin.clone(), from: planned.url.clone() }];
            // A prefetch that loses the race goes on there: the plugin is ready next time.
            let prefetch = producer.client.prefetch_plugins(wanted);
            let limit = Duration::try_from_secs_f64(budget_ms / 1e3).ok()?;
            let answer = tokio::time::timeout(limit, prefetch).await.ok()?.ok()?;
            if let Some(fetched) = answer.plugins.first() {
                learn_compile(&self.registry, (&planned.url, &producer.url), fetched);
            }
            let made_ready = answer.plugins.first().is_some_and(|p| {
                matches!(
                    p.outcome,
                    PrefetchOutcome::Present | PrefetchOutcome::Loaded | PrefetchOutcome::Fetched
                )
            });
            if !made_ready {
                return None;
            }
            measured.prefetched(&producer.url, &plugin);
            // The planned host may have caught up sooner than expected meanwhile.
            if !replica.is_catching_up(&self.current.hash) {
                return None;
            }
        }
        let plugin_ms = asked.elapsed().as_secs_f64() * 1e3;
        let record = MovedToData {
            planned: planned.url.clone(),
            why: format!(
                "{} holds the current mesh; {} was expected to hold it in {:.0} ms, the \
                 plugin was ready here in {:.0} ms",
                producer.url, planned.url, waiting_ms, plugin_ms
            ),
        };
        Some(Move { host: producer, plugin, record })
    }
}
