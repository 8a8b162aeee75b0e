//! Bringing a session's mesh into being in the background: download and decode the input
//! (a new session), or read the stored input and replay the steps (after a restart).

use std::sync::Arc;

use meshflow_api::host::{GridSpec, millis};
use meshflow_codec::correction::{self, CorrectionError};
use meshflow_codec::quantize::{self, Grid, QuantizeError};
use meshflow_codec::replay::{self, ReplayError};
use meshflow_mesh::MeshData;

use super::blobs::{BlobError, Stored};
use super::downloads::PeersError;
use super::meshes::{self, CORRECTION, CurrentMesh, MeshEncoding, MeshError, REPLAY, hashed};
use super::replay::{PluginSource, ReplayFailure};
use super::sessions::{LoadReport, SessionError, SessionRecord};
use super::spool::SpoolError;
use super::state::Host;

/// Why a session's mesh could not be loaded; the session fails with this message.
#[derive(Debug, thiserror::Error)]
pub enum RebuildError {
    #[error(transparent)]
    Peers(#[from] PeersError),
    #[error(transparent)]
    Download(#[from] SpoolError),
    #[error(transparent)]
    Blob(#[from] BlobError),
    #[error(transparent)]
    Mesh(#[from] MeshError),
    #[error("{url}: the mesh has content hash {found}, not the expected {expected}")]
    HashMismatch { url: String, found: String, expected: String },
    #[error(transparent)]
    Quantize(#[from] QuantizeError),
    #[error("grid exponents {0:?} are out of range")]
    GridExponents([i32; 3]),
    #[error("replaying {name}: {source}")]
    Correction {
        name: String,
        #[source]
        source: CorrectionError,
    },
    #[error("{name}: {source}")]
    UnreadableReplay {
        name: String,
        #[source]
        source: ReplayError,
    },
    #[error("replaying {name}: {source}")]
    Replay {
        name: String,
        #[source]
        source: ReplayFailure,
    },
    #[error(transparent)]
    Task(#[from] tokio::task::JoinError),
}

/// Adds a session on `record` (its input not yet loaded) and starts loading it in the
/// background.
pub fn start(host: &Arc<Host>, id: String, record: SessionRecord) -> Result<(), SessionError> {
    host.sessions.insert(&id, record.clone())?;
    tokio::spawn(load(host.clone(), id, record));
    Ok(())
}

/// Loads session `id` from its record; on failure the session is failed with the reason.
pub async fn load(host: Arc<Host>, id: String, record: SessionRecord) {
    let cancel = host.sessions.cancel_token(&id);
    match build(&host, &record, &cancel).await {
        // The new input blob stays safe from eviction until the session record names it.
        Ok((input, current, grid, times, _stored)) => {
            host.sessions.loaded(&id, input, current, grid, times)
        }
        Err(error) => host.sessions.fail(&id, error.to_string()),
    }
}

type Built<'a> = (String, CurrentMesh, Option<Grid>, LoadReport, Option<Stored<'a>>);

async fn build<'a>(
    host: &'a Host,
    record: &SessionRecord,
    cancel: &tokio_util::sync::CancellationToken,
) -> Result<Built<'a>, RebuildError> {
    let (input, mut current, times, stored) = match &record.input {
        Some(name) => {
            let mesh = read_mesh_blob(host, name).await?;
            let current = hashed(mesh).await?;
            (name.clone(), current, LoadReport::default(), None)
        }
        None => {
            let (name, current, times, stored) = download_input(host, record, cancel).await?;
            (name, current, times, Some(stored))
        }
    };
    let grid = match record.grid {
        None => None,
        Some(spec) => {
            let (mesh, grid) = on_grid(Arc::unwrap_or_clone(current.mesh), spec).await?;
            current = hashed(mesh).await?;
            expect_hash(record, &current.hash)?;
            Some(grid)
        }
    };
    for step in &record.steps {
        let step = match unwritten_log_replay(host, record, step).await {
            Some(replay) => replay,
            None => step.clone(),
        };
        let mesh = apply_blob(host, Arc::unwrap_or_clone(current.mesh), &step, grid).await?;
        current = hashed(mesh).await?;
    }
    Ok((input, current, grid, times, stored))
}

/// The loaded input must be the mesh the engine named, when it named one.
fn expect_hash(record: &SessionRecord, hash: &str) -> Result<(), RebuildError> {
    match &record.input_hash {
        Some(expected) if !expected.eq_ignore_ascii_case(hash) => Err(RebuildError::HashMismatch {
            url: record.input_url.clone(),
            found: hash.to_owned(),
            expected: expected.clone(),
        }),
        _ => Ok(()),
    }
}

/// The input snapped onto the session's grid (DESIGN §4: a workflow's `quantize`).
async fn on_grid(mut mesh: MeshData, spec: GridSpec) -> Result<(MeshData, Grid), RebuildError> {
    tokio::task::spawn_blocking(move || {
        let grid = match spec {
            GridSpec::Bits(bits) => quantize::quantize(&mut mesh, bits)?,
            GridSpec::Exponents(exponents) => {
                let grid = Grid::from_exponents(exponents)
                    .ok_or(RebuildError::GridExponents(exponents))?;
                grid.snap_all(&mut mesh.positions);
                grid
            }
        };
        Ok((mesh, grid))
    })
    .await?
}

async fn download_input<'a>(
    host: &'a Host,
    record: &SessionRecord,
    cancel: &tokio_util::sync::CancellationToken,
) -> Result<(String, CurrentMesh, LoadReport, Stored<'a>), RebuildError> {
    let scope = host.downloads.scope(&record.peers)?;
    // On disk as it comes, kept as the blob by renaming; a packed input decoded meanwhile.
    let fetched = host.downloads.mesh::<RebuildError>(&record.input_url, &scope, cancel).await?;
    let (spooled, current, encoding) = (fetched.spooled, fetched.mesh, fetched.encoding);
    let hash = &current.hash;
    // On a grid, the expected hash is the snapped mesh's: checked once it is snapped.
    if record.grid.is_none() {
        expect_hash(record, hash)?;
    }
    let times = LoadReport {
        download_ms: Some(millis(fetched.download)),
        load_ms: Some(millis(fetched.load)),
        input_bytes: Some(spooled.bytes),
        not_kept: fetched.not_kept,
    };
    let name = meshes::blob_name(&spooled.digest, encoding, hash);
    let stored = host.blobs.adopt(&name, spooled.path).await?;
    Ok((name, current, times, stored))
}

/// A stored mesh blob, decoded by its extension.
async fn read_mesh_blob(host: &Host, name: &str) -> Result<MeshData, RebuildError> {
    let bytes = host.blobs.read(name).await?;
    let encoding = MeshEncoding::of_blob(name)?;
    let name = name.to_owned();
    let decoded = tokio::task::spawn_blocking(move || meshes::decode(&bytes, encoding, &name));
    Ok(decoded.await??)
}

/// One replayed step: a correction applied to `mesh`, a named step run again, or a full
/// mesh replacing it.
async fn apply_blob(
    host: &Host,
    mesh: MeshData,
    name: &str,
    grid: Option<Grid>,
) -> Result<MeshData, RebuildError> {
    if name.ends_with(&format!(".{REPLAY}")) {
        return rerun_blob(host, mesh, name, grid).await;
    }
    if !name.ends_with(&format!(".{CORRECTION}")) {
        return read_mesh_blob(host, name).await;
    }
    let bytes = host.blobs.read(name).await?;
    let name = name.to_owned();
    tokio::task::spawn_blocking(move || {
        correction::apply(mesh, &bytes).map_err(|source| RebuildError::Correction { name, source })
    })
    .await?
}

/// A step this host re-ran from a replay correction: run again with the same plugin (one it
/// offers or fetched for that replay; nothing is fetched now).
async fn rerun_blob(
    host: &Host,
    mesh: MeshData,
    name: &str,
    grid: Option<Grid>,
) -> Result<MeshData, RebuildError> {
    let bytes = host.blobs.read(name).await?;
    let step = replay::decode(&bytes)
        .map_err(|source| RebuildError::UnreadableReplay { name: name.to_owned(), source })?;
    let scope = host.downloads.scope(&[])?;
    let failed = |source| RebuildError::Replay { name: name.to_owned(), source };
    let source = PluginSource { scope: &scope, producer: None };
    let replays = &host.replay_plugins;
    let plugin =
        replays.plugin_for(&host.plugins, source, &step.plugin_hex()).await.map_err(failed)?;
    replays.rerun_off_thread(plugin, step, Arc::new(mesh), grid).await.map_err(failed)
}

/// For a step whose edit log was never written (the host stopped between answering the step
/// and encoding its log, DESIGN §10: a restart loses nothing), the replay this host made of
/// the same step: the one it offered whose base and result hashes the log is named by.
/// Re-running it must reach that result hash, as any replay must.
async fn unwritten_log_replay(host: &Host, record: &SessionRecord, step: &str) -> Option<String> {
    if !step.ends_with(&format!(".{CORRECTION}")) || host.blobs.path(step).exists() {
        return None;
    }
    for offered in record.offered.iter().filter(|name| name.ends_with(&format!(".{REPLAY}"))) {
        let Ok(bytes) = host.blobs.read(offered).await else { continue };
        let names_step =
            |named: replay::Replay| meshes::edit_log_name(named.base, named.result) == step;
        if replay::decode(&bytes).is_ok_and(names_step) {
            tracing::warn!("edit log {step} was never written: the step is re-run from {offered}");
            return Some(offered.clone());
        }
    }
    None
}
