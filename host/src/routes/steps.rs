//! The two things a ready session does: take another host's step (`update`) and run a
//! service (`run`).

use std::sync::Arc;
use std::time::Instant;

use axum::Json;
use axum::extract::{Path, State};

use super::error::{ApiError, ApiJson};
use crate::blobs::Stored;
use crate::edit_logs::{EditLogs, StepLog};
use crate::meshes::{self, MeshEncoding};
use crate::rebuild::hashed;
use crate::replay;
use crate::sessions::CurrentMesh;
use crate::state::Host;
use meshflow_api::fetch_rules::{FetchScope, origin};
use meshflow_api::host::{
    BlobRef, CheckResult, FilterResult, FullRef, RunRequest, RunResult, Transfer, Update, Updated,
    Vouched, millis,
};
use meshflow_codec::correction;
use meshflow_codec::quantize::{Grid, snap_step};
use meshflow_mesh::{ContentHash, MeshData};
use meshflow_params::{from_json as params_from_json, resolve, value_json};
use meshflow_runtime::{ServiceInfo, ServiceKind, Value};

/// `POST /sessions/{id}/update`: re-run the step (`replay`) or replay its edit log
/// (`correction`), as asked, falling back to the edit log and then to the full mesh.
pub async fn update(
    State(host): State<Arc<Host>>,
    Path(id): Path<String>,
    ApiJson(Vouched { body: update, peers }): ApiJson<Vouched<Update>>,
) -> Result<Json<Updated>, ApiError> {
    let scope = host.scope(&peers).map_err(|e| ApiError::bad_request("bad-peers", e))?;
    let session = host.sessions.begin(&id)?;
    let mut downloaded = 0;
    let mut download_ms = 0.0;
    let mut reasons = Vec::new();
    let order: &[Transfer] = match update.use_ {
        Transfer::Replay => &[Transfer::Replay, Transfer::Correction],
        Transfer::Correction => &[Transfer::Correction],
        Transfer::Full => &[],
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
        let (base, grid) = (&session.current, session.grid);
        let attempt = apply_step(&host, &scope, base, grid, blob, via, &update.full.hash).await;
        downloaded += attempt.bytes;
        download_ms += attempt.download_ms;
        match attempt.result {
            Ok((next, name, _stored)) => {
                let updated = Updated {
                    hash: next.hash.clone(),
                    via,
                    bytes: downloaded,
                    download_ms,
                    apply_ms: attempt.apply_ms,
                    fallback: fallback(&reasons),
                };
                session.commit(next, name)?;
                return Ok(Json(updated));
            }
            Err(reason) => reasons.push(format!("{}: {reason}", via.name())),
        }
    }
    let fallback = fallback(&reasons);
    if let Some(reason) = &fallback {
        tracing::info!("session {id}: using the full mesh: {reason}");
    }
    let url = &update.full.url;
    let started = Instant::now();
    let bytes = host.download(url, &scope).await?;
    download_ms += millis(started.elapsed());
    downloaded += bytes.len() as u64;
    let started = Instant::now();
    let encoding =
        MeshEncoding::detect(url, &bytes).map_err(|e| ApiError::unprocessable("bad-mesh", e))?;
    let (mesh, bytes) = decode_off_thread(bytes, encoding, url.clone()).await?;
    let next = hashed(mesh).await?;
    if !next.hash.eq_ignore_ascii_case(&update.full.hash) {
        return Err(ApiError::unprocessable(
            "hash-mismatch",
            format!(
                "{url}: the mesh has content hash {}, not the expected {}",
                next.hash, update.full.hash
            ),
        ));
    }
    let name = meshes::blob_name(&bytes, encoding, &next.hash);
    let stored = host.blobs.put(&name, Arc::new(bytes)).await?;
    let updated = Updated {
        hash: next.hash.clone(),
        via: Transfer::Full,
        bytes: downloaded,
        download_ms,
        apply_ms: millis(started.elapsed()),
        fallback,
    };
    session.commit(next, name)?;
    drop(stored);
    crate::eviction::enforce_budget(&host).await;
    Ok(Json(updated))
}

fn fallback(reasons: &[String]) -> Option<String> {
    (!reasons.is_empty()).then(|| reasons.join("; "))
}

struct Attempt<'a> {
    bytes: u64,
    download_ms: f64,
    apply_ms: f64,
    /// The new mesh, the stored blob's name and its hold against eviction, or why the
    /// blob was not used.
    result: Result<(CurrentMesh, String, Stored<'a>), String>,
}

/// Downloads a correction or replay correction and applies it to `base`; the result must
/// be `expected`. The blob is kept, so a restart can apply it again.
async fn apply_step<'a>(
    host: &'a Host,
    scope: &FetchScope,
    base: &CurrentMesh,
    grid: Option<Grid>,
    blob: &BlobRef,
    via: Transfer,
    expected: &str,
) -> Attempt<'a> {
    let started = Instant::now();
    let downloaded = host.download(&blob.url, scope).await;
    let download_ms = millis(started.elapsed());
    let bytes = match downloaded {
        Ok(bytes) => bytes,
        Err(error) => {
            let result = Err(error.to_string());
            return Attempt { bytes: 0, download_ms, apply_ms: 0.0, result };
        }
    };
    let size = bytes.len() as u64;
    let started = Instant::now();
    let (applied, name) = match via {
        Transfer::Replay => {
            let producer = reqwest::Url::parse(&blob.url).ok().map(|url| origin(&url));
            let producer = producer.as_deref();
            let next = replay::apply(host, scope, producer, base, grid, &bytes, expected)
                .await
                .map_err(|e| e.to_string());
            (next, meshes::replay_name(&bytes))
        }
        _ => (
            apply_correction(base, &bytes, expected, &blob.url).await,
            meshes::correction_name(&bytes),
        ),
    };
    let apply_ms = millis(started.elapsed());
    let result = match applied {
        Ok(next) => host
            .blobs
            .put(&name, Arc::new(bytes))
            .await
            .map(|stored| (next, name, stored))
            .map_err(|e| e.to_string()),
        Err(reason) => Err(reason),
    };
    Attempt { bytes: size, download_ms, apply_ms, result }
}

/// Replays an edit log on a thread of its own. The session's hash is known: the base is
/// not hashed again.
async fn apply_correction(
    base: &CurrentMesh,
    bytes: &[u8],
    expected: &str,
    url: &str,
) -> Result<CurrentMesh, String> {
    let (mesh, base_hash) = (base.mesh.clone(), base.hash.clone());
    let (bytes, expected, url) = (bytes.to_vec(), expected.to_owned(), url.to_owned());
    tokio::task::spawn_blocking(move || {
        let hash = |hex: &str| {
            ContentHash::from_hex(hex).ok_or_else(|| format!("{hex:?} is not a content hash"))
        };
        let mesh = correction::apply_known(mesh, hash(&base_hash)?, &bytes, hash(&expected)?)
            .map_err(|e| format!("{url}: {e}"))?;
        Ok(CurrentMesh { mesh: Arc::new(mesh), hash: expected.to_ascii_lowercase() })
    })
    .await
    .unwrap_or_else(|e| Err(e.to_string()))
}

async fn decode_off_thread(
    bytes: Vec<u8>,
    encoding: MeshEncoding,
    name: String,
) -> Result<(MeshData, Vec<u8>), ApiError> {
    tokio::task::spawn_blocking(move || meshes::decode(&bytes, encoding, &name).map(|m| (m, bytes)))
        .await?
        .map_err(|e| ApiError::unprocessable("bad-mesh", e))
}

/// `POST /sessions/{id}/run`: a filter replaces the session's mesh and yields a
/// correction and a full-mesh URL; a check yields its value.
pub async fn run(
    State(host): State<Arc<Host>>,
    Path(id): Path<String>,
    ApiJson(request): ApiJson<RunRequest>,
) -> Result<Json<RunResult>, ApiError> {
    let (plugin, info) = host.plugins.find(&request.service, request.plugin.as_deref())?;
    let params = params_from_json(&info, &request.params)
        .map_err(|e| ApiError::bad_request("bad-params", e.to_string()))?;
    let resolved_params = resolved_json(&info, &params)?;
    let ran = (plugin.clone(), params.clone());
    let session = host.sessions.begin(&id)?;
    let input = session.current.clone();
    let _running = host.start_run();
    let runtime = host.runtime.clone();
    let digest = plugin.digest.clone();
    let service = request.service.clone();
    let mesh = input.mesh.clone();
    let output = tokio::task::spawn_blocking(move || runtime.run(&plugin, &service, mesh, &params))
        .await??;
    let (compute_ms, queue_ms) = (millis(output.duration), millis(output.queued));
    let (service, plugin) = (request.service, digest);
    if info.kind == ServiceKind::Check {
        let value = output.value.as_ref().map(value_json).unwrap_or_default();
        let report = output.report;
        let result =
            CheckResult { service, plugin, value, compute_ms, queue_ms, report, resolved_params };
        return Ok(Json(RunResult::Check(result)));
    }

    let result = output.mesh.expect("a filter returns a mesh");
    let base_hash = ContentHash::from_hex(&input.hash).ok_or_else(|| {
        ApiError::internal(format!("session hash `{}` is not a hash", input.hash))
    })?;
    // A quantised run: the plugin computes freely, its result goes back onto the grid.
    let (result, log) = match session.grid {
        Some(grid) => {
            let base = input.mesh.clone();
            tokio::task::spawn_blocking(move || snap_step(&grid, &base, result, output.log))
                .await?
                .map_err(|e| ApiError::internal(format!("snapping to the grid: {e}")))?
        }
        None => (result, output.log),
    };
    let edits = log.iter().map(|op| op.edit_count()).sum();
    let result = Arc::new(result);
    let hashing = result.clone();
    let result_hash = tokio::task::spawn_blocking(move || hashing.content_hash()).await?;
    let next = CurrentMesh { mesh: result.clone(), hash: result_hash.to_hex() };
    let named = replay::name(&ran.0, &info, &ran.1, base_hash, &next.mesh, result_hash)
        .map(|step| meshflow_codec::replay::encode(&step))
        .map_err(|e| ApiError::internal(format!("naming the step: {e}")))?;
    let (replay_name, replay_bytes) = (meshes::replay_name(&named), named.len() as u64);
    // Before the replay is stored: no eviction hold may be kept while waiting for a slot.
    let step_log = StepLog {
        plugin: plugin.clone(),
        service: service.clone(),
        params: serde_json::Value::Object(resolved_params.clone()).to_string(),
        base: input.mesh,
        base_hash,
        log,
        result,
        result_hash,
    };
    let (correction_name, correction_bytes) = EditLogs::encode_later(&host, step_log).await;
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
        compute_ms,
        queue_ms,
        report: output.report,
        resolved_params,
        correction: BlobRef { url: host.blob_url(&correction_name), bytes: correction_bytes },
        replay: BlobRef { url: host.blob_url(&replay_name), bytes: replay_bytes },
        full: FullRef { url: host.blob_url(&full_name), hash: next.hash.clone() },
    };
    session.commit_offering(next, correction_name, Some(replay_name))?;
    drop(stored);
    crate::eviction::enforce_budget(&host).await;
    Ok(Json(RunResult::Filter(result)))
}

/// Every parameter of the run with defaults filled in, as JSON: what the plugin receives.
fn resolved_json(
    info: &ServiceInfo,
    given: &[(String, Value)],
) -> Result<serde_json::Map<String, serde_json::Value>, ApiError> {
    let resolved =
        resolve(info, given).map_err(|e| ApiError::bad_request("bad-params", e.to_string()))?;
    Ok(resolved.iter().map(|(name, value)| (name.clone(), value_json(value))).collect())
}
