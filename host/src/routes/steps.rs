//! The two things a ready session does: take another host's step (`update`) and run a
//! service (`run`).

use std::sync::Arc;
use std::time::Instant;

use axum::Json;
use axum::extract::{Path, State};

use super::error::{ApiError, ApiJson};
use crate::blobs::Stored;
use crate::meshes::{self, MeshEncoding};
use crate::rebuild::hashed;
use crate::sessions::CurrentMesh;
use crate::state::Host;
use meshflow_api::fetch_rules::FetchScope;
use meshflow_api::host::{
    BlobRef, CheckResult, FilterResult, FullRef, RunRequest, RunResult, Transfer, Update, Updated,
    Vouched, millis,
};
use meshflow_codec::correction;
use meshflow_mesh::{ContentHash, MeshData};
use meshflow_params::{from_json as params_from_json, resolve, value_json};
use meshflow_runtime::{ServiceInfo, ServiceKind, Value};

/// `POST /sessions/{id}/update`: replay the correction, or fall back to the full mesh.
pub async fn update(
    State(host): State<Arc<Host>>,
    Path(id): Path<String>,
    ApiJson(Vouched { body: update, peers }): ApiJson<Vouched<Update>>,
) -> Result<Json<Updated>, ApiError> {
    let scope = host.scope(&peers).map_err(|e| ApiError::bad_request("bad-peers", e))?;
    let session = host.sessions.begin(&id)?;
    let mut downloaded = 0;
    let mut download_ms = 0.0;
    let fallback = match (update.use_, &update.correction) {
        (Transfer::Full, _) => None,
        (Transfer::Correction, None) => Some("no correction was given".to_owned()),
        (Transfer::Correction, Some(correction)) => {
            let attempt =
                replay_correction(&host, &scope, &session.current, correction, &update.full.hash)
                    .await;
            downloaded += attempt.bytes;
            download_ms += attempt.download_ms;
            match attempt.result {
                Ok((next, name, _stored)) => {
                    let updated = Updated {
                        hash: next.hash.clone(),
                        via: Transfer::Correction,
                        bytes: downloaded,
                        download_ms,
                        apply_ms: attempt.apply_ms,
                        fallback: None,
                    };
                    session.commit(next, name)?;
                    return Ok(Json(updated));
                }
                Err(reason) => Some(reason),
            }
        }
    };
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

struct Attempt<'a> {
    bytes: u64,
    download_ms: f64,
    apply_ms: f64,
    /// The new mesh, the stored correction's name and its hold against eviction, or why
    /// the correction was not used.
    result: Result<(CurrentMesh, String, Stored<'a>), String>,
}

async fn replay_correction<'a>(
    host: &'a Host,
    scope: &FetchScope,
    base: &CurrentMesh,
    correction: &BlobRef,
    expected: &str,
) -> Attempt<'a> {
    let started = Instant::now();
    let downloaded = host.download(&correction.url, scope).await;
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
    let url = correction.url.clone();
    let expected = expected.to_owned();
    let (mesh, base_hash) = (base.mesh.clone(), base.hash.clone());
    let applied = tokio::task::spawn_blocking(move || {
        let hash = |hex: &str| {
            ContentHash::from_hex(hex).ok_or_else(|| format!("{hex:?} is not a content hash"))
        };
        // The session's hash is known: the base is not hashed again.
        let mesh = correction::apply_known(mesh, hash(&base_hash)?, &bytes, hash(&expected)?)
            .map_err(|e| format!("{url}: {e}"))?;
        Ok((CurrentMesh { mesh: Arc::new(mesh), hash: expected.to_ascii_lowercase() }, bytes))
    })
    .await
    .unwrap_or_else(|e| Err(e.to_string()));
    let apply_ms = millis(started.elapsed());
    let result = match applied {
        Ok((next, bytes)) => {
            let name = meshes::correction_name(&bytes);
            host.blobs
                .put(&name, Arc::new(bytes))
                .await
                .map(|stored| (next, name, stored))
                .map_err(|e| e.to_string())
        }
        Err(reason) => Err(reason),
    };
    Attempt { bytes: size, download_ms, apply_ms, result }
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

    let edits = output.log.iter().map(|op| op.edit_count()).sum();
    let result = output.mesh.expect("a filter returns a mesh");
    let base_hash = ContentHash::from_hex(&input.hash).ok_or_else(|| {
        ApiError::internal(format!("session hash `{}` is not a hash", input.hash))
    })?;
    let (next, correction) = tokio::task::spawn_blocking(move || {
        correction::encode_known(input.mesh, base_hash, &output.log, &result).map(
            |(bytes, hash)| (CurrentMesh { mesh: Arc::new(result), hash: hash.to_hex() }, bytes),
        )
    })
    .await?
    .map_err(|e| ApiError::internal(format!("encoding the correction: {e}")))?;
    let correction_name = meshes::correction_name(&correction);
    let correction_bytes = correction.len() as u64;
    let stored = host.blobs.put(&correction_name, Arc::new(correction)).await?;
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
        full: FullRef { url: host.blob_url(&full_name), hash: next.hash.clone() },
    };
    session.commit(next, correction_name)?;
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
