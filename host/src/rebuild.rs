//! Bringing a session's mesh into being in the background: download and decode the input
//! (a new session), or read the stored input and replay the steps (after a restart).

use std::sync::Arc;
use std::time::Instant;

use super::blobs::Stored;
use super::meshes::{self, CORRECTION, MeshEncoding, REPLAY};
use super::sessions::{CurrentMesh, LoadTimes, SessionRecord};
use super::state::Host;
use meshflow_api::fetch_rules::FetchScope;
use meshflow_api::host::GridSpec;
use meshflow_api::host::millis;
use meshflow_codec::quantize::{self, Grid};
use meshflow_codec::{correction, replay};
use meshflow_mesh::MeshData;

/// Loads session `id` from its record; on failure the session is failed with the reason.
pub async fn load(host: Arc<Host>, id: String, record: SessionRecord) {
    match build(&host, &record).await {
        // The new input blob stays safe from eviction until the session record names it.
        Ok((input, current, grid, times, _stored)) => {
            host.sessions.loaded(&id, input, current, grid, times)
        }
        Err(error) => host.sessions.fail(&id, error),
    }
}

type Built<'a> = (String, CurrentMesh, Option<Grid>, LoadTimes, Option<Stored<'a>>);

async fn build<'a>(host: &'a Host, record: &SessionRecord) -> Result<Built<'a>, String> {
    let (input, mut current, times, stored) = match &record.input {
        Some(name) => {
            let mesh = read_mesh_blob(host, name).await?;
            let current = hashed(mesh).await.map_err(|e| e.to_string())?;
            (name.clone(), current, LoadTimes::default(), None)
        }
        None => {
            let (name, current, times, stored) = download_input(host, record).await?;
            (name, current, times, Some(stored))
        }
    };
    let grid = match record.grid {
        None => None,
        Some(spec) => {
            let (mesh, grid) = on_grid(Arc::unwrap_or_clone(current.mesh), spec).await?;
            current = hashed(mesh).await.map_err(|e| e.to_string())?;
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
        current = hashed(mesh).await.map_err(|e| e.to_string())?;
    }
    Ok((input, current, grid, times, stored))
}

/// The loaded input must be the mesh the engine named, when it named one.
fn expect_hash(record: &SessionRecord, hash: &str) -> Result<(), String> {
    match &record.input_hash {
        Some(expected) if !expected.eq_ignore_ascii_case(hash) => Err(format!(
            "{}: the mesh has content hash {hash}, not the expected {expected}",
            record.input_url
        )),
        _ => Ok(()),
    }
}

/// The input snapped onto the session's grid (DESIGN §4: a workflow's `quantize`).
async fn on_grid(mut mesh: MeshData, spec: GridSpec) -> Result<(MeshData, Grid), String> {
    tokio::task::spawn_blocking(move || {
        let grid = match spec {
            GridSpec::Bits(bits) => {
                quantize::quantize(&mut mesh, bits).map_err(|e| e.to_string())?
            }
            GridSpec::Exponents(exponents) => {
                let grid = Grid::from_exponents(exponents)
                    .ok_or_else(|| format!("grid exponents {exponents:?} are out of range"))?;
                grid.snap_all(&mut mesh.positions);
                grid
            }
        };
        Ok((mesh, grid))
    })
    .await
    .map_err(|e| e.to_string())?
}

async fn download_input<'a>(
    host: &'a Host,
    record: &SessionRecord,
) -> Result<(String, CurrentMesh, LoadTimes, Stored<'a>), String> {
    let started = Instant::now();
    let fetched = fetch_mesh(host, &record.input_url, &host.scope(&record.peers)?).await?;
    let download_ms = fetched.download_ms;
    let input_bytes = fetched.bytes.len() as u64;
    let (current, bytes, encoding) = (fetched.mesh, fetched.bytes, fetched.encoding);
    let hash = &current.hash;
    // On a grid, the expected hash is the snapped mesh's: checked once it is snapped.
    if record.grid.is_none() {
        expect_hash(record, hash)?;
    }
    let load_ms = millis(started.elapsed()) - download_ms;
    let name = meshes::blob_name(&bytes, encoding, hash);
    let stored = host.blobs.put(&name, Arc::new(bytes)).await.map_err(|e| e.to_string())?;
    let times = LoadTimes {
        download_ms: Some(download_ms),
        load_ms: Some(load_ms),
        input_bytes: Some(input_bytes),
    };
    Ok((name, current, times, stored))
}

/// A mesh downloaded and decoded, with its content hash.
pub struct FetchedMesh {
    pub mesh: CurrentMesh,
    /// As they came, and how they are encoded.
    pub bytes: Vec<u8>,
    pub encoding: MeshEncoding,
    pub download_ms: f64,
}

/// Downloads `url` within `scope` and decodes it by its extension or its first bytes.
pub async fn fetch_mesh(host: &Host, url: &str, scope: &FetchScope) -> Result<FetchedMesh, String> {
    let started = Instant::now();
    let bytes = host.download(url, scope).await.map_err(|e| e.to_string())?;
    let download_ms = millis(started.elapsed());
    Ok(FetchedMesh { download_ms, ..decode_fetched(url, bytes).await? })
}

/// Decodes mesh bytes downloaded from `url` by its extension or their first bytes.
pub async fn decode_fetched(url: &str, bytes: Vec<u8>) -> Result<FetchedMesh, String> {
    let encoding = MeshEncoding::detect(url, &bytes)?;
    let url = url.to_owned();
    let (mesh, bytes) = tokio::task::spawn_blocking(move || {
        let mesh = meshes::decode(&bytes, encoding, &url)?;
        let hash = mesh.content_hash().to_hex();
        Ok::<_, String>((CurrentMesh { mesh: Arc::new(mesh), hash }, bytes))
    })
    .await
    .map_err(|e| e.to_string())??;
    Ok(FetchedMesh { mesh, bytes, encoding, download_ms: 0.0 })
}

/// A stored mesh blob, decoded by its extension.
pub async fn read_mesh_blob(host: &Host, name: &str) -> Result<MeshData, String> {
    let bytes = host.blobs.read(name).await?;
    let encoding = encoding_of(name)?;
    let name = name.to_owned();
    tokio::task::spawn_blocking(move || meshes::decode(&bytes, encoding, &name))
        .await
        .map_err(|e| e.to_string())?
}

/// One replayed step: a correction applied to `mesh`, a named step run again, or a full
/// mesh replacing it.
async fn apply_blob(
    host: &Host,
    mesh: MeshData,
    name: &str,
    grid: Option<Grid>,
) -> Result<MeshData, String> {
    if name.ends_with(&format!(".{REPLAY}")) {
        return rerun_blob(host, mesh, name, grid).await;
    }
    if !name.ends_with(&format!(".{CORRECTION}")) {
        return read_mesh_blob(host, name).await;
    }
    let bytes = host.blobs.read(name).await?;
    let name = name.to_owned();
    tokio::task::spawn_blocking(move || {
        correction::apply(mesh, &bytes).map_err(|e| format!("replaying {name}: {e}"))
    })
    .await
    .map_err(|e| e.to_string())?
}

/// A step this host re-ran from a replay correction: run again with the same plugin (one it
/// offers or fetched for that replay; nothing is fetched now).
async fn rerun_blob(
    host: &Host,
    mesh: MeshData,
    name: &str,
    grid: Option<Grid>,
) -> Result<MeshData, String> {
    let bytes = host.blobs.read(name).await?;
    let step = replay::decode(&bytes).map_err(|e| format!("{name}: {e}"))?;
    let scope = host.scope(&[])?;
    let plugin = crate::replay::plugin_for(host, &scope, None, &step.plugin_hex())
        .await
        .map_err(|e| format!("replaying {name}: {e}"))?;
    crate::replay::rerun_off_thread(host.runtime.clone(), plugin, step, Arc::new(mesh), grid)
        .await
        .map_err(|e| format!("replaying {name}: {e}"))
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

fn encoding_of(name: &str) -> Result<MeshEncoding, String> {
    let extension = name.rsplit_once('.').map(|(_, e)| e).unwrap_or_default();
    MeshEncoding::from_extension(extension).ok_or_else(|| format!("blob {name} is not a mesh"))
}

/// A mesh with its content hash, hashed off the async threads.
pub async fn hashed(mesh: MeshData) -> Result<CurrentMesh, tokio::task::JoinError> {
    tokio::task::spawn_blocking(move || {
        let hash = mesh.content_hash().to_hex();
        CurrentMesh { mesh: Arc::new(mesh), hash }
    })
    .await
}
