//! How one step's result reaches one receiving host (DESIGN §5): the expected time of each
//! way over the measured link and at the receiver's measured speed, and the choice.
//!
//! - edit log: its bytes over the link, then replaying its edits;
//! - replay: its few hundred bytes over the link, then the producer's compute time at the
//!   receiver's speed, once more for every task the receiver is busy with (a re-run waits
//!   for a run slot there); plus, when the receiver does not hold the plugin compiled
//!   (offered, replayed before or prefetched for this run), its download and compile;
//! - full mesh: the last full size seen, scaled to the current vertex count, over the link,
//!   then unpacking it.

use meshflow_api::engine::TransferEstimates;
use meshflow_api::host::Transfer as Use;

use crate::measured::{HostSpeed, Link, StepShape};
use crate::registry::PluginSize;
use crate::workflow::Transfer;

/// Fallbacks only, for a plugin no host has said the size of (a host older than the
/// `plugin_bytes` of `GET /services`): what a receiver lacking it downloads (the built-in
/// plugins are 0.2-0.35 MB, 66-110 KB compressed), and what compiling it costs at least.
pub const PLUGIN_BYTES_GUESS: u64 = 256 << 10;
pub const PLUGIN_COMPILE_MS_GUESS: f64 = 100.0;
/// Compiling scales with the component: an 18 MB Python component took 20-40 s uncached
/// on this machine kind (2 cores), about 1.5 s per MiB (the built-ins: about 0.5 s per
/// MiB). Only until a prefetch to the host showed its speed (`Measured::compile_ms_per_mib`,
/// which a compile its cache answers makes small).
pub const PLUGIN_COMPILE_MS_PER_MIB_GUESS: f64 = 1_500.0;

/// Whether the receiver can re-run the step's plugin at once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PluginAt {
    /// Compiled there: offered, fetched for an earlier replay, or prefetched for this run.
    Ready,
    /// To be fetched and compiled first: its size, and the milliseconds the receiver takes
    /// to compile a MiB of component once a prefetch there showed it.
    Missing(PluginSize, Option<f64>),
}

impl PluginAt {
    /// Expected milliseconds before a replay can start over `link`.
    pub fn ready_ms(self, link: &Link) -> f64 {
        match self {
            PluginAt::Ready => 0.0,
            PluginAt::Missing(size, compile_ms_per_mib) => {
                let mib = |bytes: u64| bytes as f64 / f64::from(1 << 20);
                let compile = match (size.component, compile_ms_per_mib) {
                    (Some(bytes), Some(rate)) => mib(bytes) * rate,
                    (Some(bytes), None) => {
                        (mib(bytes) * PLUGIN_COMPILE_MS_PER_MIB_GUESS).max(PLUGIN_COMPILE_MS_GUESS)
                    }
                    (None, _) => PLUGIN_COMPILE_MS_GUESS,
                };
                link.transfer_ms(size.sent().unwrap_or(PLUGIN_BYTES_GUESS)) + compile
            }
        }
    }
}

/// One filter step's result, as the producer reported it.
#[derive(Clone, Copy, Debug)]
pub struct StepOutput {
    pub correction_bytes: u64,
    pub replay_bytes: u64,
    pub full_bytes: u64,
    pub edits: u64,
    pub vertices: u64,
    pub compute_ms: f64,
}

impl StepOutput {
    /// What the step gave per vertex of its mesh (none for an empty mesh).
    pub fn shape(&self) -> Option<StepShape> {
        let per_vertex = |figure: f64| figure / self.vertices as f64;
        (self.vertices > 0).then(|| StepShape {
            correction_bytes_per_vertex: per_vertex(self.correction_bytes as f64),
            full_bytes_per_vertex: per_vertex(self.full_bytes as f64),
            edits_per_vertex: per_vertex(self.edits as f64),
            compute_ms_per_vertex: per_vertex(self.compute_ms),
            replay_bytes: self.replay_bytes as f64,
        })
    }

    /// What a step of `shape` is expected to give on a mesh of `vertices`.
    pub fn expected(shape: &StepShape, vertices: u64) -> Self {
        let scaled = |per_vertex: f64| (per_vertex * vertices as f64).round() as u64;
        Self {
            correction_bytes: scaled(shape.correction_bytes_per_vertex),
            replay_bytes: shape.replay_bytes.round() as u64,
            full_bytes: scaled(shape.full_bytes_per_vertex),
            edits: scaled(shape.edits_per_vertex),
            vertices,
            compute_ms: shape.compute_ms_per_vertex * vertices as f64,
        }
    }
}

/// The receiving host as the engine sees it.
#[derive(Clone, Copy, Debug)]
pub struct Receiver {
    pub link: Link,
    pub speed: HostSpeed,
    pub plugin: PluginAt,
    /// Tasks running or assigned there.
    pub load: u32,
}

pub fn estimate(step: &StepOutput, receiver: &Receiver) -> TransferEstimates {
    let Receiver { link, speed, plugin, load } = *receiver;
    let compute_ms = speed.replay_ratio * step.compute_ms;
    let plugin_ms = plugin.ready_ms(&link);
    TransferEstimates {
        correction_ms: link.transfer_ms(step.correction_bytes)
            + speed.apply_ms_per_element * (step.edits + step.vertices) as f64,
        replay_ms: link.transfer_ms(step.replay_bytes)
            + plugin_ms
            + compute_ms * f64::from(1 + load),
        full_ms: link.transfer_ms(step.full_bytes)
            + speed.unpack_ms_per_vertex * step.vertices as f64,
    }
}

/// The way a workflow's `transfer` asks for; for `auto`, the least expected time (the edit
/// log on a tie: it needs no plugin and no compute slot).
/// What the estimates expect of `way`.
pub fn expected_ms(estimates: &TransferEstimates, way: Use) -> f64 {
    match way {
        Use::Correction => estimates.correction_ms,
        Use::Replay => estimates.replay_ms,
        Use::Full => estimates.full_ms,
    }
}

pub fn choose(transfer: Transfer, estimates: &TransferEstimates) -> Use {
    match transfer {
        Transfer::Correction => Use::Correction,
        Transfer::Replay => Use::Replay,
        Transfer::Full => Use::Full,
        Transfer::Auto => {
            let ways = [
                (estimates.correction_ms, Use::Correction),
                (estimates.replay_ms, Use::Replay),
                (estimates.full_ms, Use::Full),
            ];
            let mut best = ways[0];
            for way in &ways[1..] {
                if way.0 < best.0 {
                    best = *way;
                }
            }
            best.1
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MBIT_5: Link = Link { bytes_per_ms: 625.0, latency_ms: 20.0 };
    const LAN: Link = Link { bytes_per_ms: 125_000.0, latency_ms: 0.2 };
    const SPEED: HostSpeed = HostSpeed {
        apply_ms_per_element: 0.000_1,
        unpack_ms_per_vertex: 0.000_6,
        replay_ratio: 1.2,
    };

    /// Cotangent smoothing of a 1M-vertex scan: a correction as large as the mesh, 300 ms
    /// of compute.
    const GLOBAL: StepOutput = StepOutput {
        correction_bytes: 5_000_000,
        replay_bytes: 200,
        full_bytes: 5_500_000,
        edits: 1_000_000,
        vertices: 1_000_000,
        compute_ms: 300.0,
    };
    /// Removing small components: a tiny correction, a little compute.
    const LOCAL: StepOutput = StepOutput {
        correction_bytes: 250,
        replay_bytes: 200,
        full_bytes: 5_500_000,
        edits: 7_000,
        vertices: 1_000_000,
        compute_ms: 150.0,
    };

    fn receiver(link: Link, has_plugin: bool, load: u32) -> Receiver {
        let plugin = match has_plugin {
            true => PluginAt::Ready,
            false => PluginAt::Missing(PluginSize::default(), None),
        };
        Receiver { link, speed: SPEED, plugin, load }
    }

    #[test]
    fn a_large_plugin_the_receiver_lacks_is_not_replayed_but_a_prefetched_one_is() {
        // An 18 MB Python component, 5 MB compressed, over 5 Mbit/s: 8 s to fetch and
        // about 27 s to compile (by the component's size, not the bytes sent).
        let size = PluginSize { component: Some(18 << 20), sent: Some(5 << 20) };
        let python = PluginAt::Missing(size, None);
        let lacking = Receiver { plugin: python, ..receiver(MBIT_5, false, 0) };
        let lacking = estimate(&GLOBAL, &lacking);
        assert!(lacking.replay_ms > 35_000.0, "{lacking:?}");
        assert_ne!(choose(Transfer::Auto, &lacking), Use::Replay, "{lacking:?}");
        // The size unknown: the fallback guess, which would still replay.
        let guessed = estimate(&GLOBAL, &receiver(MBIT_5, false, 0));
        assert_eq!(choose(Transfer::Auto, &guessed), Use::Replay, "{guessed:?}");
        // Prefetched while the input broadcast: ready, and replayed.
        let prefetched = estimate(&GLOBAL, &receiver(MBIT_5, true, 0));
        assert_eq!(choose(Transfer::Auto, &prefetched), Use::Replay, "{prefetched:?}");
        assert!(prefetched.replay_ms < lacking.replay_ms / 50.0, "{prefetched:?}");
        // A host whose compile cache answered: the fetch alone, 8 s.
        let cached = PluginAt::Missing(size, Some(1.0));
        let cached = estimate(&GLOBAL, &Receiver { plugin: cached, ..receiver(MBIT_5, false, 0) });
        assert!(cached.replay_ms < 10_000.0 && cached.replay_ms > 8_000.0, "{cached:?}");
    }

    #[test]
    fn a_global_step_is_replayed_over_a_slow_link_and_shipped_over_a_fast_one() {
        let slow = estimate(&GLOBAL, &receiver(MBIT_5, true, 0));
        assert_eq!(choose(Transfer::Auto, &slow), Use::Replay, "{slow:?}");
        // A receiver without the plugin first fetches and compiles it: still far quicker.
        let without = estimate(&GLOBAL, &receiver(MBIT_5, false, 0));
        assert_eq!(choose(Transfer::Auto, &without), Use::Replay);
        // On a LAN the edit log (40 ms to fetch, 200 ms to apply) beats 360 ms of compute.
        let fast = estimate(&GLOBAL, &receiver(LAN, true, 0));
        assert_eq!(choose(Transfer::Auto, &fast), Use::Correction, "{fast:?}");
    }

    #[test]
    fn a_busy_receiver_is_not_given_compute_it_would_queue_for() {
        let idle = estimate(&GLOBAL, &receiver(MBIT_5, true, 0));
        let busy = estimate(&GLOBAL, &receiver(MBIT_5, true, 30));
        assert!(busy.replay_ms > 30.0 * idle.replay_ms / 2.0, "{busy:?}");
        assert_eq!(busy.correction_ms, idle.correction_ms);
        assert_eq!(choose(Transfer::Auto, &busy), Use::Correction, "{busy:?}");
    }

    #[test]
    fn a_local_step_travels_as_its_edit_log() {
        let slow = estimate(&LOCAL, &receiver(MBIT_5, true, 0));
        assert_eq!(choose(Transfer::Auto, &slow), Use::Correction, "{slow:?}");
    }

    #[test]
    fn a_forced_transfer_is_obeyed_whatever_the_estimates() {
        let slow = estimate(&GLOBAL, &receiver(MBIT_5, true, 0));
        assert_eq!(choose(Transfer::Full, &slow), Use::Full);
        assert_eq!(choose(Transfer::Correction, &slow), Use::Correction);
        let local = estimate(&LOCAL, &receiver(LAN, true, 0));
        assert_eq!(choose(Transfer::Replay, &local), Use::Replay);
    }
}
