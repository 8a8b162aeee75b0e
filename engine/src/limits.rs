//! Every limit the engine enforces, in one place: what a client may send, how much a run may
//! grow, how many runs one client may have going, and how long state is kept.

use std::time::Duration;

/// Largest `POST /runs` body (a workflow and its input URL).
pub const MAX_SUBMIT_BYTES: usize = 1 << 20;
/// Largest `POST /hosts` body.
pub const MAX_REGISTER_BYTES: usize = 4 << 10;
/// The largest mesh accepted by `POST /inputs`; it is streamed to disk, never held whole.
pub const MAX_INPUT_BYTES: u64 = 4 << 30;

/// Tasks (runs and checks, bodies included) in one workflow.
pub const MAX_WORKFLOW_TASKS: usize = 1000;
/// How deep IF and WHILE blocks may nest.
pub const MAX_NESTING: usize = 16;
/// The highest `max-iterations` a WHILE may ask for.
pub const MAX_ITERATIONS_CAP: u32 = 10_000;
/// Steps one run may execute (WHILE rounds included) before it is stopped; this bounds the
/// size of its record.
pub const MAX_STEPS_PER_RUN: usize = 20_000;

/// Runs of one API token (or of all anonymous clients together) executing at once; more
/// wait in a queue of [`MAX_QUEUED_RUNS_PER_CLIENT`], and beyond that `POST /runs` answers
/// 429.
pub const MAX_ACTIVE_RUNS_PER_CLIENT: usize = 8;
pub const MAX_QUEUED_RUNS_PER_CLIENT: usize = 64;
/// Batches of one user not yet finished; `POST /batches` beyond it answers 429.
pub const MAX_ACTIVE_BATCHES_PER_USER: usize = 16;
/// How long `POST /runs/{id}/cancel` waits for the run to end, to answer its final status.
pub const CANCEL_WAIT: Duration = Duration::from_secs(5);
/// What a 429 asks the client to wait before trying again.
pub const RETRY_AFTER: Duration = Duration::from_secs(5);

/// Finished runs kept (in the database and in memory); older ones are deleted first.
pub const KEPT_RUNS: usize = 1000;
/// Uploaded inputs no kept run names are deleted after this long (an upload is normally
/// followed by its submission at once).
pub const UNUSED_INPUT_TTL: Duration = Duration::from_secs(3600);
/// A registered host that has not answered for this long is forgotten (hosts given at start
/// with `--host` are kept).
pub const FORGET_DOWN_HOST_AFTER: Duration = Duration::from_secs(3600);
/// Most hosts the registry keeps; registrations beyond it are refused.
pub const MAX_HOSTS: usize = 256;
/// How often forgotten runs, inputs and hosts are looked for.
pub const JANITOR_INTERVAL: Duration = Duration::from_secs(300);
/// Changes to a run's record are written to the database at most this often.
pub const PERSIST_INTERVAL: Duration = Duration::from_millis(200);

// ---- what the engine believes of a host ----

/// Vertices and triangles a mesh may claim: far beyond what a host's default sandbox
/// (2 GiB of memory, ~60M vertices with their triangles) lets a plugin produce.
pub const MAX_VERTICES: u64 = 100_000_000;
pub const MAX_TRIANGLES: u64 = 200_000_000;
/// The largest correction a host may announce: what a host downloads at most by default.
pub const MAX_CORRECTION_BYTES: u64 = 2 << 30;
/// A replay correction names a step: hashes, a service and its parameters.
pub const MAX_REPLAY_BYTES: u64 = 64 << 10;
/// How long a host that gave an answer which cannot be true is left out of plans. Answering
/// polls well proves nothing (a fake host does that too), so only time clears it, and each
/// new false answer starts it again.
pub const SUSPECT_FOR: Duration = Duration::from_secs(15 * 60);
/// A host answering 429 (all run slots and its queue taken) is asked again this often,
/// pausing as it asks but at least [`BUSY_FIRST_PAUSE`], doubling, at most [`BUSY_MAX_PAUSE`],
/// before the task moves to another host.
pub const BUSY_RETRIES: u32 = 6;
/// The first pause after a 429; each next one doubles, up to [`BUSY_MAX_PAUSE`].
pub const BUSY_FIRST_PAUSE: Duration = Duration::from_millis(250);
/// No pause is longer, whatever the host's `Retry-After` says.
pub const BUSY_MAX_PAUSE: Duration = Duration::from_secs(8);

// ---- downloads in the user's format ----

/// Largest mesh file the engine takes from a host for a download (`POST /meshes/convert`),
/// spooled to disk: a `raw` mesh is 12 bytes per vertex and per triangle, so a 60M-triangle
/// scan (issue 33) needs 1.1 GB and 4 GiB holds 200M triangles.
pub const MAX_DOWNLOAD_FETCH_BYTES: u64 = 4 << 30;
/// Longest the engine waits for a host's written mesh, connection to last byte (a binary PLY
/// of a million vertices is 37 MB: a minute at 5 Mbit/s).
pub const DOWNLOAD_FETCH_TIMEOUT: Duration = Duration::from_secs(300);
/// Downloads asked of hosts at once; more wait for a slot, so the engine's memory stays near
/// this many mesh files whatever the clients ask.
pub const MAX_CONCURRENT_DOWNLOADS: usize = 2;
/// Largest `.wasm` the engine forwards to a host for `POST /plugins` (the host's own limit).
pub const MAX_PLUGIN_FORWARD_BYTES: usize = 64 << 20;

/// The most inputs one batch may name.
pub const MAX_BATCH_INPUTS: usize = 1000;
/// How many of a batch's runs go at once, at most and by default (the rest wait their
/// turn, so a large batch leaves its client's other run slots free).
pub const MAX_BATCH_RUNS_AT_ONCE: usize = 4;
/// How often a batch looks whether it may start its next run.
pub const BATCH_POLL: Duration = Duration::from_millis(250);
