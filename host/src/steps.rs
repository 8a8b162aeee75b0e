//! The two things a ready session does: take another host's step (`update`: re-run its
//! replay, replay its edit log, or take its full mesh) and run a service (`run`: a filter
//! replaces the session's mesh and is named for other hosts, a check yields its value).
//! No HTTP here: `routes/steps.rs` adapts requests and [`StepError`]s.

use std::sync::Arc;
use std::time::Instant;

use meshflow_api::fetch_rules::quoted;
use meshflow_api::fetch_rules::{FetchScope, origin};
use meshflow_api::host::{
    BlobRef, CheckResult, FilterResult, FullRef, RunRequest, RunResult, Transfer, Update, Updated,
    millis,
};
use meshflow_codec::correction::{self, CorrectionError};
use meshflow_codec::quantize::{Grid, snap_step};
use meshflow_mesh::ContentHash;
use meshflow_mesh::store::EditError;
use meshflow_params::{ParamError, from_json as params_from_json, value_json};
use meshflow_runtime::{Invocation, Plugin, RunError, ServiceInfo, ServiceKind};

use crate::blobs::{BlobError, Stored};
use crate::downloads::PeersError;
use crate::edit_logs::{self, Beside, PreparedMeans, StepKind, StepLog};
use crate::meshes::{self, CurrentMesh, MeshError};
use crate::plugins::PluginSetError;
use crate::replay::{self, NameError, PluginSource, ReplayFailure};
use crate::sessions::SessionError;
use crate::spool::SpoolError;
use crate::state::Host;

/// Why a step was not taken or run; the session's mesh is then unchanged.
#[derive(Debug, thiserror::Error)]
pub enum StepError {
    #[error(transparent)]
    Peers(#[from] PeersError),
    #[error(transparent)]
    Session(#[from] SessionError),
    #[error(transparent)]
    Plugins(#[from] PluginSetError),
    #[error(transparent)]
    Params(#[from] ParamError),
    #[error(transparent)]
    Run(#[from] RunError),
    /// The full mesh could not be downloaded.
    #[error(transparent)]
    Download(#[from] SpoolError),
    /// The full mesh is not a mesh.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The full mesh is not the announced one.
    #[error("{url}: the mesh has content hash {found}, not the expected {expected}")]
    HashMismatch { url: String, found: String, expected: String },
    #[error(transparent)]
    Blob(#[from] BlobError),
    #[error(transparent)]
    Task(#[from] tokio::task::JoinError),
    #[error("session hash `{0}` is not a hash")]
    SessionHash(String),
    #[error("snapping to the grid: {0}")]
    Snap(#[source] EditError),
    #[error("naming the step: {0}")]
    Name(#[source] NameError),
}

/// Why a replay or an edit log was not used; the update falls back to the next transfer.
#[derive(Debug, thiserror::Error)]
pub enum TransferFailure {
    #[error(transparent)]
    Download(#[from] SpoolError),
    #[error(transparent)]
    Replay(#[from] ReplayFailure),
    #[error("{0:?} is not a content hash")]
    NotAHash(String),
    #[error("{url}: {source}")]
    Correction {
        url: String,
        #[source]
        source: CorrectionError,
    },
    #[error(transparent)]
    Task(#[from] tokio::task::JoinError),
    #[error(transparent)]
    Blob(#[from] BlobError),
}

impl TransferFailure {
    /// The mesh the producer's edit log or replay reached, when it was not the announced
    /// one: the producer's data contradicts its own claim (or this host computes wrong).
    fn reached_another_mesh(&self) -> Option<String> {
        match self {
            Self::Replay(ReplayFailure::OtherResult { found, .. })
            | Self::Replay(ReplayFailure::Diverged { found, .. }) => Some(found.clone()),
            Self::Correction { source: CorrectionError::ResultMismatch { found, .. }, .. } => {
                Some(found.to_hex())
            }
            _ => None,
        }
    }
}

/// Session `id` takes another host's step: re-run it (`replay`) or replay its edit log
/// (`correction`), as asked, falling back to the edit log and then to the full mesh.
/// `peers` are the cluster's origins the engine vouched for.
pub async fn update(
    host: &Host,
    id: &str,
    update: Update,
    peers: &[String],
) -> Result<Updated, StepError> {
    let scope = host.downloads.scope(peers)?;
    let session = host.sessions.begin(id)?;
    let mut downloaded = 0;
    let mut download_ms = 0.0;
    let mut plugin_wait_ms = None;
    let mut reasons = Vec::new();
    let mut disagreed = None;
    let order: &[Transfer] = match update.use_ {
        Transfer::Replay => &[Transfer::Replay, Transfer::Correction],
        Transfer::Correction => &[Transfer::Correction],
        Transfer::Full => &[],
    };
    // A log that sets every position is predicted from this mesh's neighbour means:
    // gathered while it downloads.
    let mut prepared = match (update.use_, &update.correction) {
        (Transfer::Correction, Some(log)) if log.sets_positions => {
            let current = &session.current;
            ContentHash::from_hex(&current.hash)
                .and_then(|hash| host.edit_logs.prepare(&current.mesh, hash, Beside::Download))
        }
        _ => None,
    };
    for &via in order {
        let blob = match via {
            Transfer::Replay => update.replay.as_ref(),
            _ => update.correction.as_ref(),
        };
        let Some(blob) = blob else {
            reasons.push(format!("no {} was given", via.name()));
            continue;
        };
        let (base, grid, cancel) = (&session.current, session.grid, &session.cancel);
        let target = (blob, via, update.full.hash.as_str());
        let means = prepared.take().filter(|_| via == Transfer::Correction);
        let attempt = apply_step(host, &scope, (base, means), grid, target, cancel).await;
        downloaded += attempt.bytes;
        download_ms += attempt.download_ms;
        plugin_wait_ms = plugin_wait_ms.or(attempt.plugin_wait_ms);
        match attempt.result {
            Ok((next, name, _stored)) => {
                let updated = Updated {
                    hash: next.hash.clone(),
                    via,
                    bytes: downloaded,
                    download_ms,
                    apply_ms: attempt.apply_ms,
                    fallback: fallback(&reasons),
                    disagreed,
                    plugin_wait_ms,
                };
                session.commit(next, name)?;
                return Ok(updated);
            }
            Err(reason) => {
                disagreed = disagreed.or_else(|| reason.reached_another_mesh());
                reasons.push(format!("{}: {reason}", via.name()));
            }
        }
    }
    let fallback = fallback(&reasons);
    if let Some(reason) = &fallback {
        tracing::info!("session {id}: using the full mesh: {reason}");
    }
    let url = &update.full.url;
    // On disk as it comes, kept as the blob by renaming; a packed mesh decoded meanwhile.
    let fetched = host.downloads.mesh::<StepError>(url, &scope, &session.cancel).await?;
    download_ms += millis(fetched.download);
    downloaded += fetched.spooled.bytes;
    let (spooled, next, encoding) = (fetched.spooled, fetched.mesh, fetched.encoding);
    if !next.hash.eq_ignore_ascii_case(&update.full.hash) {
        return Err(StepError::HashMismatch {
            url: url.clone(),
            found: next.hash,
            expected: update.full.hash,
        });
    }
    let name = meshes::blob_name(&spooled.digest, encoding, &next.hash);
    let stored = host.blobs.adopt(&name, spooled.path).await?;
    let updated = Updated {
        hash: next.hash.clone(),
        via: Transfer::Full,
        bytes: downloaded,
        download_ms,
        apply_ms: millis(fetched.load),
        fallback,
        disagreed,
        plugin_wait_ms,
    };
    session.commit(next, name)?;
    drop(stored);
    crate::eviction::enforce_budget(host).await;
    Ok(updated)
}

fn fallback(reasons: &[String]) -> Option<String> {
    (!reasons.is_empty()).then(|| reasons.join("; "))
}

struct Attempt<'a> {
    bytes: u64,
    download_ms: f64,
    apply_ms: f64,
    /// A replay's wait for its plugin, when it was not ready here.
    plugin_wait_ms: Option<f64>,
    /// The new mesh, the stored blob's name and its hold against eviction, or why the
    /// blob was not used.
    result: Result<(CurrentMesh, String, Stored<'a>), TransferFailure>,
}

/// Downloads a correction or replay correction and applies it to `base` (an edit log with
/// `base`'s neighbour means, if they are being gathered); the result must be `expected`.
/// The blob is kept, so a restart can apply it again.
async fn apply_step<'a>(
    host: &'a Host,
    scope: &FetchScope,
    (base, means): (&CurrentMesh, Option<PreparedMeans>),
    grid: Option<Grid>,
    (blob, via, expected): (&BlobRef, Transfer, &str),
    cancel: &tokio_util::sync::CancellationToken,
) -> Attempt<'a> {
    let started = Instant::now();
    let downloaded = match host.downloads.spool(&blob.url, scope, cancel, None).await {
        Ok(spooled) => match spooled.read().await {
            Ok(bytes) => Ok((spooled, bytes)),
            Err(source) => Err(SpoolError::Io { url: quoted(&blob.url), source }),
        },
        Err(error) => Err(error),
    };
    let download_ms = millis(started.elapsed());
    let (spooled, bytes) = match downloaded {
        // Shared from here on: applied and named without another copy; stored by renaming.
        Ok((spooled, bytes)) => (spooled, Arc::new(bytes)),
        Err(error) => {
            let result = Err(error.into());
            return Attempt { bytes: 0, download_ms, apply_ms: 0.0, plugin_wait_ms: None, result };
        }
    };
    let size = spooled.bytes;
    let started = Instant::now();
    let mut plugin_wait_ms = None;
    let (applied, name) = match via {
        Transfer::Replay => {
            let producer = reqwest::Url::parse(&blob.url).ok().map(|url| origin(&url));
            let source = PluginSource { scope, producer: producer.as_deref() };
            let next = host
                .replay_plugins
                .apply(&host.plugins, source, base, grid, &bytes, expected)
                .await
                .map(|replayed| {
                    plugin_wait_ms = replayed.plugin_wait.map(millis);
                    replayed.mesh
                })
                .map_err(TransferFailure::from);
            (next, meshes::replay_name(&bytes))
        }
        _ => (
            apply_correction((base, means), bytes.clone(), expected, &blob.url).await,
            meshes::correction_name(&bytes),
        ),
    };
    let apply_ms = millis(started.elapsed());
    drop(bytes);
    let result = match applied {
        Ok(next) => match host.blobs.adopt(&name, spooled.path).await {
            Ok(stored) => Ok((next, name, stored)),
            Err(e) => Err(e.into()),
        },
        Err(reason) => Err(reason),
    };
    Attempt { bytes: size, download_ms, apply_ms, plugin_wait_ms, result }
}

/// Replays an edit log on a thread of its own. The session's hash is known: the base is
/// not hashed again.
async fn apply_correction(
    (base, means): (&CurrentMesh, Option<PreparedMeans>),
    bytes: Arc<Vec<u8>>,
    expected: &str,
    url: &str,
) -> Result<CurrentMesh, TransferFailure> {
    let hash = |hex: &str| {
        ContentHash::from_hex(hex).ok_or_else(|| TransferFailure::NotAHash(hex.to_owned()))
    };
    let (base_hash, result_hash) = (hash(&base.hash)?, hash(expected)?);
    let (mesh, url) = (base.mesh.clone(), url.to_owned());
    let means = edit_logs::prepared(means).await;
    let next = tokio::task::spawn_blocking(move || {
        let means = means.as_ref().map(|p| &p.means);
        correction::apply_known(mesh, base_hash, &bytes, result_hash, means)
            .map_err(|source| TransferFailure::Correction { url, source })
    })
    .await??;
    Ok(CurrentMesh { mesh: Arc::new(next), hash: expected.to_ascii_lowercase() })
}

/// The plugin and service a run request names: from the plugins this host offers, or, for a
/// request pinned to a digest it does not offer, a plugin it fetched (the engine moved the
/// step here, where the mesh is, and made the plugin ready first; or it fetched it before
/// it last restarted), unless this host runs only its own plugins.
async fn plugin_for_run(
    host: &Host,
    request: &RunRequest,
) -> Result<(Plugin, ServiceInfo), StepError> {
    let offered = host.plugins.find(&request.service, request.plugin.as_deref());
    match (offered, request.plugin.as_deref()) {
        (Err(PluginSetError::NotFound(_)), Some(digest)) => {
            let Some(plugin) = host.replay_plugins.kept(&host.plugins, digest).await else {
                let why = match host.replay_plugins.runs_foreign() {
                    true => "neither offered nor fetched here".to_owned(),
                    false => crate::replay::NO_FOREIGN_PLUGINS.to_owned(),
                };
                return Err(PluginSetError::NotFoundBecause(digest.to_owned(), why).into());
            };
            Ok(crate::plugins::with_service(plugin, &request.service)?)
        }
        (found, _) => Ok(found?),
    }
}

/// Runs a service on session `id`: a filter replaces the session's mesh and yields a
/// correction, a replay and a full-mesh URL; a check yields its value.
pub async fn run(host: &Host, id: &str, request: RunRequest) -> Result<RunResult, StepError> {
    let (plugin, info) = plugin_for_run(host, &request).await?;
    let given = params_from_json(&info, &request.params)?;
    // The service is looked up and its parameters resolved here, once: the answer, the
    // replay, the edit log's estimate and the run itself all take these.
    let invocation = Invocation::resolve(plugin, info, &given)?;
    let resolved_params = replay::params_json(invocation.params());
    let params = serde_json::Value::Object(resolved_params.clone()).to_string();
    let kind = StepKind::of(&invocation.plugin().digest, &request.service, &params);
    let session = host.sessions.begin(id)?;
    let input = session.current.clone();
    // Gathered beside the run, for the edit log, if this kind of step sets every position.
    let prepared = match (invocation.info().kind, ContentHash::from_hex(&input.hash)) {
        (ServiceKind::Filter, Some(hash)) => host.edit_logs.prepare_for(&kind, &input.mesh, hash),
        _ => None,
    };
    let _running = host.start_run();
    let runtime = host.runtime.clone();
    let mesh = input.mesh.clone();
    let (output, invocation) = tokio::task::spawn_blocking(move || {
        let output = runtime.invoke(&invocation, mesh);
        (output, invocation)
    })
    .await?;
    let ran = output.as_ref().map(|output| output.duration);
    host.metrics.sandbox_run(invocation.info().kind, ran);
    let output = output?;
    let (compute_ms, queue_ms) = (millis(output.duration), millis(output.queued));
    let (service, plugin) = (request.service, invocation.plugin().digest.clone());
    if invocation.info().kind == ServiceKind::Check {
        let value = output.value.as_ref().map(value_json).unwrap_or_default();
        let report = output.report;
        let result =
            CheckResult { service, plugin, value, compute_ms, queue_ms, report, resolved_params };
        return Ok(RunResult::Check(result));
    }

    let result = output.mesh.expect("a filter returns a mesh");
    let base_hash = ContentHash::from_hex(&input.hash)
        .ok_or_else(|| StepError::SessionHash(input.hash.clone()))?;
    // A quantised run: the plugin computes freely, its result goes back onto the grid.
    let (result, log) = match session.grid {
        Some(grid) => {
            let base = input.mesh.clone();
            tokio::task::spawn_blocking(move || snap_step(&grid, &base, result, output.log))
                .await?
                .map_err(StepError::Snap)?
        }
        None => (result, output.log),
    };
    let edits = log.iter().map(|op| op.edit_count()).sum();
    let result = Arc::new(result);
    let hashing = result.clone();
    let result_hash = tokio::task::spawn_blocking(move || hashing.content_hash()).await?;
    let next = CurrentMesh { mesh: result.clone(), hash: result_hash.to_hex() };
    let service_name = &invocation.info().name;
    let named = replay::name_resolved(
        &plugin,
        service_name,
        params.clone(),
        base_hash,
        &next.mesh,
        result_hash,
    )
    .map(|step| meshflow_codec::replay::encode(&step))
    .map_err(StepError::Name)?;
    let (replay_name, replay_bytes) = (meshes::replay_name(&named), named.len() as u64);
    // Before the replay is stored: no eviction hold may be kept while waiting for a slot.
    let sets_positions = edit_logs::sets_positions(&log);
    let step_log =
        StepLog { kind, base: input.mesh, base_hash, log, result, result_hash, prepared };
    let (correction_name, correction_bytes) =
        host.edit_logs.encode_later(&host.blobs, step_log).await;
    let stored = host.blobs.put(&replay_name, Arc::new(named)).await?;
    let full_name = host.blobs.remember(next.mesh.clone(), &next.hash);
    let result = FilterResult {
        service,
        plugin,
        input_hash: session.current.hash.clone(),
        output_hash: next.hash.clone(),
        vertices: next.mesh.vertex_count(),
        triangles: next.mesh.triangle_count(),
        edits,
        attributes: next.mesh.attributes.describe(),
        compute_ms,
        queue_ms,
        report: output.report,
        resolved_params,
        correction: BlobRef {
            url: host.blob_url(&correction_name),
            bytes: correction_bytes,
            sets_positions,
        },
        replay: BlobRef::new(host.blob_url(&replay_name), replay_bytes),
        full: FullRef { url: host.blob_url(&full_name), hash: next.hash.clone() },
    };
    session.commit_offering(next, correction_name, Some(replay_name))?;
    drop(stored);
    crate::eviction::enforce_budget(host).await;
    Ok(RunResult::Filter(result))
}
