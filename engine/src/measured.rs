//! What the engine has measured of its hosts across runs, for the cost model (DESIGN §5):
//! the link between each pair of hosts (bandwidth and latency, from the updates it
//! forwarded), the link into each host (from its input downloads, until a pair is
//! measured), each host's speed at applying edits, unpacking meshes and re-running steps,
//! which plugins a host fetched for a replay, and what each filter step (plugin, service,
//! parameters) gives per vertex of its mesh. Every figure is its first sample, then a
//! moving average. The engine saves a [`Snapshot`] with its runs and restores it at start,
//! so a restart does not fall back to the defaults; figures of hosts it forgets go too.

use std::collections::{HashMap, HashSet};
use std::sync::Mutex;

use serde::{Deserialize, Serialize};

use crate::limits::MAX_HOSTS;

/// Weight of a new sample in the moving averages.
const SMOOTHING: f64 = 0.3;
/// A compile its cache answered still takes a moment: the least a sample may say.
const MIN_COMPILE_MS: f64 = 1.0;
/// Only transfers at least this large tell the bandwidth; smaller ones tell the latency.
pub const MIN_BANDWIDTH_SAMPLE_BYTES: u64 = 64 << 10;
/// Until measured: a 100 Mbit/s link with 2 ms to the first byte.
const DEFAULT_LINK: Link = Link { bytes_per_ms: 12_500.0, latency_ms: 2.0 };
/// Until measured: what this machine kind does in release builds (2 cores).
const DEFAULT_SPEED: HostSpeed =
    HostSpeed { apply_ms_per_element: 0.000_25, unpack_ms_per_vertex: 0.000_6, replay_ratio: 1.2 };

/// At most this many host pairs are measured (every pair of the most hosts the engine
/// keeps); a pair beyond it uses the link into its receiver.
pub const MAX_MEASURED_PAIRS: usize = MAX_HOSTS * MAX_HOSTS;
/// At most this many (host, plugin) fetches are remembered; beyond it a replay's estimate
/// includes a download it may not need.
pub const MAX_REMEMBERED_FETCHES: usize = 64 * MAX_HOSTS;

/// At most this many step shapes are remembered; a step beyond it is judged as unknown
/// (its plugin prefetched wherever it may be needed).
pub const MAX_STEP_SHAPES: usize = 1024;

/// A filter step's output per vertex of its mesh, as learned for one plugin, service and
/// parameter set ([`step_key`]): what the engine expects of the step before it runs. Edit
/// logs scale with the edits, the edits and the compute with the mesh (a smoothing moves
/// every vertex; a repair's share of a scan's triangles is about the same on the next).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepShape {
    pub correction_bytes_per_vertex: f64,
    pub full_bytes_per_vertex: f64,
    pub edits_per_vertex: f64,
    pub compute_ms_per_vertex: f64,
    pub replay_bytes: f64,
}

impl StepShape {
    fn figures(&self) -> [f64; 5] {
        [
            self.correction_bytes_per_vertex,
            self.full_bytes_per_vertex,
            self.edits_per_vertex,
            self.compute_ms_per_vertex,
            self.replay_bytes,
        ]
    }

    fn from_figures([correction, full, edits, compute, replay]: [f64; 5]) -> Self {
        Self {
            correction_bytes_per_vertex: correction,
            full_bytes_per_vertex: full,
            edits_per_vertex: edits,
            compute_ms_per_vertex: compute,
            replay_bytes: replay,
        }
    }
}

/// The key a step's shape is learned under: its plugin, service and parameters as the
/// workflow gives them (JSON objects serialise with sorted keys here, so equal parameters
/// give equal keys).
pub fn step_key(
    plugin: &str,
    service: &str,
    params: &serde_json::Map<String, serde_json::Value>,
) -> String {
    let mut hasher = blake3::Hasher::new();
    for part in [plugin, service, &serde_json::Value::Object(params.clone()).to_string()] {
        hasher.update(&(part.len() as u64).to_le_bytes()).update(part.as_bytes());
    }
    hasher.finalize().to_hex().to_string()
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Link {
    pub bytes_per_ms: f64,
    pub latency_ms: f64,
}

impl Link {
    /// Expected milliseconds to move `bytes` over this link.
    pub fn transfer_ms(&self, bytes: u64) -> f64 {
        self.latency_ms + bytes as f64 / self.bytes_per_ms
    }
}

/// A link as learned, with how many samples made each of its figures.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct Learned {
    link: Link,
    bandwidth_samples: u32,
    latency_samples: u32,
}

impl Learned {
    fn starting_from(link: Link) -> Self {
        Self { link, bandwidth_samples: 0, latency_samples: 0 }
    }

    /// A download of `bytes` in `ms`: large ones tell the bandwidth, small ones the latency.
    fn learn(&mut self, bytes: u64, ms: f64) {
        if !(ms.is_finite() && ms > 0.0) {
            return;
        }
        let link = &mut self.link;
        if bytes >= MIN_BANDWIDTH_SAMPLE_BYTES {
            let rate = bytes as f64 / (ms - link.latency_ms).max(ms / 2.0);
            link.bytes_per_ms = learned(link.bytes_per_ms, rate, &mut self.bandwidth_samples);
        } else {
            link.latency_ms = learned(link.latency_ms, ms, &mut self.latency_samples);
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HostSpeed {
    /// Replaying an edit log, per edit and per vertex of the mesh: the result is hashed
    /// whole, so a log of a few edits still costs a pass over a large mesh.
    pub apply_ms_per_element: f64,
    /// Unpacking and hashing one vertex of a full mesh.
    pub unpack_ms_per_vertex: f64,
    /// A re-run's time here over the producer's compute time for the same step.
    pub replay_ratio: f64,
}

/// How a host applied one update, as its answer said.
pub struct Applied {
    pub via: meshflow_api::host::Transfer,
    pub apply_ms: f64,
    pub edits: u64,
    pub vertices: u64,
    pub producer_compute_ms: f64,
    /// The receiver had the plugin before this update: a replay's time is then the re-run
    /// alone, not a download and compilation too.
    pub had_plugin: bool,
}

#[derive(Default)]
pub struct Measured {
    tables: Mutex<Tables>,
}

/// Everything measured, as saved in the engine's database.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    pairs: Vec<(String, String, Learned)>,
    into: Vec<(String, Learned)>,
    speeds: Vec<(String, HostSpeed, [u32; 3])>,
    fetched: Vec<(String, String)>,
    /// Absent from snapshots of engines before step shapes were learned.
    #[serde(default)]
    shapes: Vec<(String, StepShape, u32)>,
    /// Absent from snapshots of engines before compile times were learned.
    #[serde(default)]
    compiles: Vec<(String, f64, u32)>,
}

#[derive(Default)]
struct Tables {
    /// By (producer, receiver) host URL.
    pairs: HashMap<(String, String), Learned>,
    /// By receiver: from its input downloads.
    into: HashMap<String, Learned>,
    /// By host, with the sample count of each figure.
    speeds: HashMap<String, (HostSpeed, [u32; 3])>,
    /// (receiver, plugin digest): fetched there for a replay, so the next needs no download.
    fetched: HashSet<(String, String)>,
    /// By [`step_key`], with the sample count.
    shapes: HashMap<String, (StepShape, u32)>,
    /// By host: milliseconds to compile a MiB of component there (a compile its cache
    /// answers counts as what it cost), with the sample count.
    compiles: HashMap<String, (f64, u32)>,
    /// Something changed since the last [`Measured::take_snapshot`].
    changed: bool,
}

impl Measured {
    fn tables(&self) -> std::sync::MutexGuard<'_, Tables> {
        self.tables.lock().expect("measurements lock")
    }

    /// Starts from what an earlier engine measured. Entries beyond the limits are dropped.
    pub fn restore(snapshot: Snapshot) -> Self {
        let measured = Measured::default();
        {
            let mut tables = measured.tables();
            for (producer, receiver, learned) in snapshot.pairs.into_iter().take(MAX_MEASURED_PAIRS)
            {
                tables.pairs.insert((producer, receiver), learned);
            }
            tables.into = snapshot.into.into_iter().take(MAX_MEASURED_PAIRS).collect();
            tables.speeds = with_samples(snapshot.speeds, MAX_MEASURED_PAIRS);
            tables.fetched = snapshot.fetched.into_iter().take(MAX_REMEMBERED_FETCHES).collect();
            tables.shapes = with_samples(snapshot.shapes, MAX_STEP_SHAPES);
            tables.compiles = with_samples(snapshot.compiles, MAX_MEASURED_PAIRS);
        }
        measured
    }

    /// What to save, if anything changed since the last call.
    pub fn take_snapshot(&self) -> Option<Snapshot> {
        let mut tables = self.tables();
        if !std::mem::take(&mut tables.changed) {
            return None;
        }
        let mut snapshot = Snapshot {
            pairs: tables.pairs.iter().map(|((p, r), l)| (p.clone(), r.clone(), *l)).collect(),
            into: tables.into.iter().map(|(r, l)| (r.clone(), *l)).collect(),
            speeds: tables.speeds.iter().map(|(h, (s, n))| (h.clone(), *s, *n)).collect(),
            fetched: tables.fetched.iter().cloned().collect(),
            shapes: tables.shapes.iter().map(|(k, (s, n))| (k.clone(), *s, *n)).collect(),
            compiles: tables.compiles.iter().map(|(h, (r, n))| (h.clone(), *r, *n)).collect(),
        };
        // In a stable order, so equal measurements save equal bytes.
        snapshot.pairs.sort_by(|a, b| (&a.0, &a.1).cmp(&(&b.0, &b.1)));
        snapshot.into.sort_by(|a, b| a.0.cmp(&b.0));
        snapshot.speeds.sort_by(|a, b| a.0.cmp(&b.0));
        snapshot.fetched.sort();
        snapshot.shapes.sort_by(|a, b| a.0.cmp(&b.0));
        snapshot.compiles.sort_by(|a, b| a.0.cmp(&b.0));
        Some(snapshot)
    }

    /// Drops every figure about `host` (the registry forgot it).
    pub fn forget_host(&self, host: &str) {
        let mut tables = self.tables();
        tables.pairs.retain(|(p, r), _| p != host && r != host);
        tables.into.remove(host);
        tables.speeds.remove(host);
        tables.fetched.retain(|(r, _)| r != host);
        tables.compiles.remove(host);
        tables.changed = true;
    }

    /// The link from `producer` to `receiver`: measured for the pair, else as measured
    /// into the receiver, else the default.
    pub fn link(&self, producer: &str, receiver: &str) -> Link {
        let tables = self.tables();
        let pair = (producer.to_owned(), receiver.to_owned());
        let learned = tables.pairs.get(&pair).or_else(|| tables.into.get(receiver));
        learned.map_or(DEFAULT_LINK, |l| l.link)
    }

    /// The link into `receiver` as its input downloads measured it, else the default.
    pub fn link_into(&self, receiver: &str) -> Link {
        self.tables().into.get(receiver).map_or(DEFAULT_LINK, |l| l.link)
    }

    pub fn speed(&self, host: &str) -> HostSpeed {
        self.tables().speeds.get(host).map_or(DEFAULT_SPEED, |(speed, _)| *speed)
    }

    /// Whether `receiver` fetched the plugin `digest` for an earlier replay.
    pub fn has_fetched(&self, receiver: &str, digest: &str) -> bool {
        self.tables().fetched.contains(&(receiver.to_owned(), digest.to_owned()))
    }

    /// `host` restarted: the plugins it fetched are gone from its memory.
    pub fn forget_fetched(&self, host: &str) {
        let mut tables = self.tables();
        let before = tables.fetched.len();
        tables.fetched.retain(|(r, _)| r != host);
        tables.changed |= tables.fetched.len() != before;
    }

    /// `receiver` made the plugin `digest` ready before a replay asked for it (a prefetch).
    pub fn prefetched(&self, receiver: &str, digest: &str) {
        let mut tables = self.tables();
        if tables.fetched.len() < MAX_REMEMBERED_FETCHES {
            tables.changed |= tables.fetched.insert((receiver.to_owned(), digest.to_owned()));
        }
    }

    /// Milliseconds `host` takes to compile a MiB of component, once a prefetch showed it.
    pub fn compile_ms_per_mib(&self, host: &str) -> Option<f64> {
        self.tables().compiles.get(host).map(|(rate, _)| *rate)
    }

    /// `host` fetched a plugin of `component` bytes, `sent` over the link from `producer`,
    /// and compiled it, in `ms` all told: what the link does not explain was the compile.
    pub fn fetched_and_compiled(
        &self,
        (producer, host): (&str, &str),
        (component, sent): (u64, u64),
        ms: f64,
    ) {
        if !ms.is_finite() || component == 0 {
            return;
        }
        let compile_ms = (ms - self.link(producer, host).transfer_ms(sent)).max(MIN_COMPILE_MS);
        let mib = component as f64 / f64::from(1 << 20);
        let mut tables = self.tables();
        if tables.compiles.len() >= MAX_MEASURED_PAIRS && !tables.compiles.contains_key(host) {
            return;
        }
        tables.changed = true;
        let (rate, samples) = tables.compiles.entry(host.to_owned()).or_insert((0.0, 0));
        *rate = learned(*rate, compile_ms / mib, samples);
    }

    /// A download of `bytes` in `ms` by `receiver`, from `producer` (a host) or from
    /// wherever the input lies (`None`).
    pub fn downloaded(&self, producer: Option<&str>, receiver: &str, bytes: u64, ms: f64) {
        let mut tables = self.tables();
        tables.changed = true;
        // A pair starts from what the receiver's input downloads taught.
        let start = tables.into.get(receiver).map_or(DEFAULT_LINK, |l| l.link);
        let fresh = || Learned::starting_from(start);
        let table_full = match producer {
            Some(_) => tables.pairs.len() >= MAX_MEASURED_PAIRS,
            None => tables.into.len() >= MAX_MEASURED_PAIRS,
        };
        let learned = match producer {
            Some(p) => {
                let pair = (p.to_owned(), receiver.to_owned());
                if table_full && !tables.pairs.contains_key(&pair) {
                    return;
                }
                tables.pairs.entry(pair).or_insert_with(fresh)
            }
            None => {
                if table_full && !tables.into.contains_key(receiver) {
                    return;
                }
                tables.into.entry(receiver.to_owned()).or_insert_with(fresh)
            }
        };
        learned.learn(bytes, ms);
    }

    /// What the step under `key` ([`step_key`]) gave per vertex, as learned so far.
    pub fn step_shape(&self, key: &str) -> Option<StepShape> {
        self.tables().shapes.get(key).map(|(shape, _)| *shape)
    }

    /// A step under `key` gave `sample` (per vertex of its mesh). Figures that are not
    /// numbers of at least zero (zero is real here: a step with no edits) are no sample.
    pub fn learn_step(&self, key: &str, sample: StepShape) {
        let new = sample.figures();
        if !new.iter().all(|f| f.is_finite() && *f >= 0.0) {
            return;
        }
        let mut tables = self.tables();
        if tables.shapes.len() >= MAX_STEP_SHAPES && !tables.shapes.contains_key(key) {
            return;
        }
        tables.changed = true;
        let (shape, samples) = tables.shapes.entry(key.to_owned()).or_insert((sample, 0));
        if *samples > 0 {
            let old = shape.figures();
            *shape = StepShape::from_figures(std::array::from_fn(|i| {
                old[i] + SMOOTHING * (new[i] - old[i])
            }));
        }
        *samples = samples.saturating_add(1);
    }

    /// How `host` applied an update of a step made with plugin `digest`.
    pub fn applied(&self, host: &str, digest: &str, applied: &Applied) {
        use meshflow_api::host::Transfer;
        let mut tables = self.tables();
        tables.changed = true;
        if applied.via == Transfer::Replay && tables.fetched.len() < MAX_REMEMBERED_FETCHES {
            tables.fetched.insert((host.to_owned(), digest.to_owned()));
        }
        if tables.speeds.len() >= MAX_MEASURED_PAIRS && !tables.speeds.contains_key(host) {
            return;
        }
        let (speed, samples) =
            tables.speeds.entry(host.to_owned()).or_insert((DEFAULT_SPEED, [0; 3]));
        let ms = applied.apply_ms;
        match applied.via {
            Transfer::Correction if applied.edits + applied.vertices > 0 => {
                let sample = ms / (applied.edits + applied.vertices) as f64;
                speed.apply_ms_per_element =
                    learned(speed.apply_ms_per_element, sample, &mut samples[0]);
            }
            Transfer::Full if applied.vertices > 0 => {
                let sample = ms / applied.vertices as f64;
                speed.unpack_ms_per_vertex =
                    learned(speed.unpack_ms_per_vertex, sample, &mut samples[1]);
            }
            Transfer::Replay if applied.producer_compute_ms > 0.0 && applied.had_plugin => {
                let sample = ms / applied.producer_compute_ms;
                speed.replay_ratio = learned(speed.replay_ratio, sample, &mut samples[2]);
            }
            _ => {}
        }
    }
}

/// A saved table of figures with their sample counts, by key, as at most `limit` entries.
fn with_samples<T, N>(rows: Vec<(String, T, N)>, limit: usize) -> HashMap<String, (T, N)> {
    rows.into_iter().take(limit).map(|(key, figure, samples)| (key, (figure, samples))).collect()
}

/// A figure after a new sample: the sample itself if it is the first, else the moving
/// average. Samples that are not positive numbers are ignored.
fn learned(old: f64, sample: f64, samples: &mut u32) -> f64 {
    if !(sample.is_finite() && sample > 0.0) {
        return old;
    }
    *samples += 1;
    if *samples == 1 { sample } else { old + SMOOTHING * (sample - old) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pair_is_measured_from_its_transfers_and_defaults_to_the_link_into_the_receiver() {
        let measured = Measured::default();
        assert_eq!(measured.link("a", "b"), DEFAULT_LINK);
        // The receiver downloaded its 5 MB input at 5 Mbit/s (625 B/ms): 8 s. The first
        // sample replaces the default at once.
        measured.downloaded(None, "b", 5_000_000, 8_000.0);
        let into_b = measured.link("a", "b");
        assert!((into_b.bytes_per_ms - 625.0).abs() < 1.0, "{into_b:?}");
        // Then a 1 MB correction from a at 50 Mbit/s, many times.
        for _ in 0..30 {
            measured.downloaded(Some("a"), "b", 1_000_000, 160.0);
        }
        let pair = measured.link("a", "b");
        assert!((pair.bytes_per_ms - 6_250.0).abs() < 200.0, "{pair:?}");
        // Small transfers tell the latency, not the bandwidth.
        for _ in 0..30 {
            measured.downloaded(Some("a"), "b", 300, 40.0);
        }
        let pair = measured.link("a", "b");
        assert!((pair.latency_ms - 40.0).abs() < 1.0 && pair.bytes_per_ms > 6_000.0, "{pair:?}");
        assert!((pair.transfer_ms(6_250_000) - 1_040.0).abs() < 50.0);
        // Another pair into b still starts from the link into b.
        assert_eq!(measured.link("c", "b"), into_b);
    }

    #[test]
    fn speeds_follow_what_hosts_report_and_ignore_nonsense() {
        use meshflow_api::host::Transfer;
        let measured = Measured::default();
        let applied = |via, apply_ms| Applied {
            via,
            apply_ms,
            edits: 1_000_000,
            vertices: 500_000,
            producer_compute_ms: 100.0,
            had_plugin: true,
        };
        assert!(!measured.has_fetched("h", "p"));
        for _ in 0..30 {
            measured.applied("h", "p", &applied(Transfer::Replay, 150.0));
            measured.applied("h", "p", &applied(Transfer::Correction, 200.0));
            measured.applied("h", "p", &applied(Transfer::Full, f64::NAN));
        }
        assert!(measured.has_fetched("h", "p") && !measured.has_fetched("g", "p"));
        // A replay that first fetched and compiled the plugin says nothing of re-run speed.
        let first = Applied { had_plugin: false, ..applied(Transfer::Replay, 5_000.0) };
        measured.applied("g", "p", &first);
        assert!(measured.has_fetched("g", "p"));
        assert_eq!(measured.speed("g").replay_ratio, DEFAULT_SPEED.replay_ratio);
        let speed = measured.speed("h");
        assert!((speed.replay_ratio - 1.5).abs() < 0.01, "{speed:?}");
        assert!((speed.apply_ms_per_element - 200.0 / 1_500_000.0).abs() < 1e-6, "{speed:?}");
        assert_eq!(speed.unpack_ms_per_vertex, DEFAULT_SPEED.unpack_ms_per_vertex);
    }

    #[test]
    fn a_log_of_few_edits_on_a_large_mesh_does_not_make_every_edit_look_slow() {
        use meshflow_api::host::Transfer;
        let measured = Measured::default();
        // Filling 100 holes' worth of edits in a 1M-vertex scan: the 150 ms are mostly the
        // pass over the mesh. Counted per edit they made a global log look like hours.
        let few = Applied {
            via: Transfer::Correction,
            apply_ms: 150.0,
            edits: 100,
            vertices: 1_000_000,
            producer_compute_ms: 50.0,
            had_plugin: true,
        };
        measured.applied("h", "p", &few);
        let speed = measured.speed("h");
        let global_ms = speed.apply_ms_per_element * (1_000_000 + 1_000_000) as f64;
        assert!((200.0..400.0).contains(&global_ms), "{global_ms} ms for a global log");
    }

    #[test]
    fn a_step_shape_starts_at_its_first_sample_then_averages_and_ignores_non_numbers() {
        let measured = Measured::default();
        let shape = |correction_bytes_per_vertex| StepShape {
            correction_bytes_per_vertex,
            full_bytes_per_vertex: 6.0,
            edits_per_vertex: 0.0,
            compute_ms_per_vertex: 0.001,
            replay_bytes: 200.0,
        };
        measured.learn_step("k", shape(1.0));
        assert_eq!(measured.step_shape("k"), Some(shape(1.0)));
        measured.learn_step("k", shape(f64::NAN));
        measured.learn_step("k", shape(-1.0));
        assert_eq!(measured.step_shape("k"), Some(shape(1.0)));
        measured.learn_step("k", shape(2.0));
        let learned = measured.step_shape("k").unwrap().correction_bytes_per_vertex;
        assert!((learned - (1.0 + SMOOTHING)).abs() < 1e-12, "{learned}");
        assert_eq!(measured.step_shape("other"), None);
        // Equal parameters, any order: one key; other parameters, another.
        let params = |json: &str| serde_json::from_str::<serde_json::Map<_, _>>(json).unwrap();
        let key = |json| step_key("d", "laplacian-smoothing", &params(json));
        assert_eq!(key(r#"{"a": 1, "b": 2}"#), key(r#"{"b": 2, "a": 1}"#));
        assert_ne!(key(r#"{"a": 1}"#), key(r#"{"a": 2}"#));
    }

    #[test]
    fn a_snapshot_restores_every_figure_and_forgetting_a_host_drops_its_own() {
        use meshflow_api::host::Transfer;
        let measured = Measured::default();
        assert_eq!(measured.take_snapshot(), None, "nothing measured, nothing to save");
        measured.downloaded(None, "b", 5_000_000, 8_000.0);
        measured.downloaded(Some("a"), "b", 1_000_000, 160.0);
        measured.downloaded(Some("b"), "c", 1_000_000, 400.0);
        let replay = Applied {
            via: Transfer::Replay,
            apply_ms: 150.0,
            edits: 0,
            vertices: 0,
            producer_compute_ms: 100.0,
            had_plugin: true,
        };
        measured.applied("b", "digest", &replay);
        let shape = StepShape {
            correction_bytes_per_vertex: 0.25,
            full_bytes_per_vertex: 6.0,
            edits_per_vertex: 0.05,
            compute_ms_per_vertex: 0.000_6,
            replay_bytes: 170.0,
        };
        measured.learn_step("holes", shape);
        measured.fetched_and_compiled(("a", "b"), (1 << 20, 1 << 18), 300.0);
        let snapshot = measured.take_snapshot().expect("changed");
        assert_eq!(measured.take_snapshot(), None, "saved once until something changes");

        let text = serde_json::to_string(&snapshot).unwrap();
        let restored = Measured::restore(serde_json::from_str(&text).unwrap());
        for (producer, receiver) in [("a", "b"), ("b", "c"), ("x", "b")] {
            assert_eq!(restored.link(producer, receiver), measured.link(producer, receiver));
        }
        assert_eq!(restored.speed("b"), measured.speed("b"));
        assert!(restored.has_fetched("b", "digest"));
        assert_eq!(restored.step_shape("holes"), Some(shape));
        assert_eq!(restored.compile_ms_per_mib("b"), measured.compile_ms_per_mib("b"));
        // A snapshot from before compile times were learned still restores.
        let older: serde_json::Value = serde_json::from_str(&text).unwrap();
        let mut older = older.as_object().unwrap().clone();
        older.remove("compiles");
        let older = Measured::restore(serde_json::from_value(older.into()).unwrap());
        assert_eq!((older.step_shape("holes"), older.compile_ms_per_mib("b")), (Some(shape), None));

        restored.forget_host("b");
        assert_eq!(restored.link("a", "b"), DEFAULT_LINK);
        assert_eq!(restored.link("b", "c"), DEFAULT_LINK);
        assert_eq!(restored.speed("b"), DEFAULT_SPEED);
        assert!(!restored.has_fetched("b", "digest"));
        let left = restored.take_snapshot().expect("forgetting is a change");
        assert!(left.pairs.is_empty() && left.into.is_empty() && left.speeds.is_empty());
        assert_eq!(restored.compile_ms_per_mib("b"), None);
    }

    #[test]
    fn a_compile_is_what_the_link_does_not_explain_of_a_fetch() {
        let measured = Measured::default();
        assert_eq!(measured.compile_ms_per_mib("b"), None);
        // 5 Mbit/s into b: 256 KiB sent take 420 ms; a 1 MiB component ready after 920 ms
        // compiled in about 500 ms.
        measured.downloaded(None, "b", 5_000_000, 8_000.0);
        measured.fetched_and_compiled(("a", "b"), (1 << 20, 256 << 10), 920.0);
        let rate = measured.compile_ms_per_mib("b").unwrap();
        assert!((rate - 500.0).abs() < 5.0, "{rate}");
        // The next one came from the compile cache: ready as soon as it arrived. The rate
        // falls towards it, never below the least a compile takes.
        measured.fetched_and_compiled(("a", "b"), (1 << 20, 256 << 10), 300.0);
        let cached = measured.compile_ms_per_mib("b").unwrap();
        assert!(cached < rate && cached >= MIN_COMPILE_MS, "{cached}");
        // Nonsense teaches nothing.
        measured.fetched_and_compiled(("a", "b"), (0, 256 << 10), 300.0);
        measured.fetched_and_compiled(("a", "b"), (1 << 20, 256 << 10), f64::NAN);
        assert_eq!(measured.compile_ms_per_mib("b"), Some(cached));
    }
}
