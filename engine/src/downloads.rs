//! Meshes leave the system in the user's format (DESIGN §6): a run's result, a step's output
//! or its input, fetched packed from the host that holds it, checked against the hash in
//! the run record (a mismatch is never served), decoded and written as PLY, OBJ, OFF, STL,
//! the packed `.mfm` itself, or `raw` arrays for the browser's viewer.
//!
//! The engine runs no plugins. It links the pure-Rust codec and mesh file crates for this,
//! which DESIGN §1 does not allow (see docs/architecture.md).

use std::sync::Arc;

use meshflow_api::{ClientError, HostClient};
use meshflow_mesh::{MeshData, as_le_bytes_f32};
use meshflow_meshio::Format;
use tokio::sync::Semaphore;

use crate::limits::{
    DOWNLOAD_FETCH_TIMEOUT, MAX_CONCURRENT_CONVERSIONS, MAX_DOWNLOAD_FETCH_BYTES,
    MAX_INPUT_DECODE_BYTES,
};
use crate::record::{RunRecord, Status};

/// What a download is written as.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    File(Format),
    /// The packed mesh as the host holds it.
    Mfm,
    /// For the viewer: [`RAW_MAGIC`], vertex and triangle counts (u32 LE), then the
    /// positions (f32 LE) and the triangles' corners (u32 LE). No text to parse, so a
    /// million vertices reach the GPU in one copy.
    Raw,
}

/// The first four bytes of a `raw` answer; its header is 12 bytes, so the arrays that follow
/// are 4-byte aligned.
pub const RAW_MAGIC: &[u8; 4] = b"MFR1";

impl MeshFormat {
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "mfm" => Some(Self::Mfm),
            "raw" => Some(Self::Raw),
            other => Format::from_name(other).map(Self::File),
        }
    }

    pub fn extension(self) -> &'static str {
        match self {
            Self::File(format) => format.extension(),
            Self::Mfm => "mfm",
            Self::Raw => "raw",
        }
    }
}

/// Which mesh of a run.
#[derive(Clone, Copy, Debug)]
pub enum Which {
    Input,
    Result,
    Step(usize),
}

/// Why a download cannot be served; each maps to one HTTP status.
#[derive(Debug, thiserror::Error)]
pub enum DownloadError {
    #[error("unknown format \"{0}\": use ply, obj, off, stl, mfm or raw")]
    BadFormat(String),
    #[error("run {0} is still going: its result is not there yet")]
    NotFinished(String),
    #[error("the run ended {status} without a result: {reason}")]
    NoResult { status: String, reason: String },
    #[error("run {run} has no step {index}")]
    NoStep { run: String, index: usize },
    #[error("step {index} ({service}) is a check: it has no output mesh")]
    NotAFilter { index: usize, service: String },
    #[error("{0}")]
    NoInput(String),
    #[error(
        "step {index}'s output is no longer held by {host} (hosts keep a run's intermediate \
         meshes only while they hold its sessions and recent outputs): run the workflow again"
    )]
    Gone { index: usize, host: String },
    #[error("fetching the mesh from its host failed: {0}")]
    Fetch(ClientError),
    #[error("{0}: not on a registered host")]
    UnknownHost(String),
    #[error(
        "the mesh from {url} has content hash {actual}, but the run record says {expected}: \
         not served"
    )]
    HashMismatch { url: String, expected: String, actual: String },
    #[error("the mesh from {url} does not decode: {message}")]
    Corrupt { url: String, message: String },
    #[error("writing the mesh as {format}: {message}")]
    Convert { format: &'static str, message: String },
}

/// A converted mesh and the file name it is offered under.
pub struct Download {
    pub bytes: Vec<u8>,
    pub file_name: String,
}

/// Fetches and converts meshes, at most [`MAX_CONCURRENT_CONVERSIONS`] at a time.
pub struct Downloads {
    slots: Arc<Semaphore>,
}

impl Default for Downloads {
    fn default() -> Self {
        Self { slots: Arc::new(Semaphore::new(MAX_CONCURRENT_CONVERSIONS)) }
    }
}

/// The client that may fetch a host's blob URL (the registered host's, with the cluster
/// token), or none for a URL on no registered host.
pub type HostClients<'a> = dyn Fn(&str) -> Option<HostClient> + Sync + 'a;

/// Where a mesh is and what hash it must have.
struct Source {
    location: Location,
    hash: String,
    label: String,
}

enum Location {
    /// A packed mesh on a host.
    Host { url: String, step: Option<(usize, String)> },
    /// An input stored by the engine.
    Stored { path: std::path::PathBuf, format: Option<Format> },
}

impl Downloads {
    /// The mesh `which` of the run `record` as `format`; `stem` names the download,
    /// `stored_input` finds an input the engine stored by the file name in its URL.
    pub async fn mesh(
        &self,
        record: &RunRecord,
        which: Which,
        format: MeshFormat,
        stem: &str,
        stored_input: &(dyn Fn(&str) -> Option<std::path::PathBuf> + Sync),
        hosts: &HostClients<'_>,
    ) -> Result<Download, DownloadError> {
        let source = locate(record, which, stored_input)?;
        // A slot before the fetch: memory stays bounded by the slots, not the requests.
        let _slot = self.slots.acquire().await.expect("the semaphore is never closed");
        let (mesh, packed) = match &source.location {
            Location::Host { url, step } => {
                let packed = fetch(hosts, url, step.as_ref()).await?;
                let mesh = decode_packed(&packed, url)?;
                (mesh, Some(packed))
            }
            Location::Stored { path, format } => {
                let (path, format) = (path.clone(), *format);
                let read = tokio::task::spawn_blocking(move || read_stored(&path, format));
                read.await.expect("reading an input does not panic")?
            }
        };
        let actual = mesh.content_hash().to_hex();
        if actual != source.hash {
            let url = match &source.location {
                Location::Host { url, .. } => url.clone(),
                Location::Stored { path, .. } => path.display().to_string(),
            };
            return Err(DownloadError::HashMismatch { url, expected: source.hash, actual });
        }
        let bytes = match (format, packed) {
            (MeshFormat::Mfm, Some(packed)) => packed,
            _ => tokio::task::spawn_blocking(move || encode(&mesh, format))
                .await
                .expect("encoding a mesh does not panic")?,
        };
        let file_name = format!("{stem}-{}.{}", source.label, format.extension());
        Ok(Download { bytes, file_name })
    }
}

/// A host's packed mesh, from a registered host only, bounded in size and time.
async fn fetch(
    hosts: &HostClients<'_>,
    url: &str,
    step: Option<&(usize, String)>,
) -> Result<Vec<u8>, DownloadError> {
    let client = hosts(url).ok_or_else(|| DownloadError::UnknownHost(url.to_owned()))?;
    let download = client.download_at_most(url, MAX_DOWNLOAD_FETCH_BYTES);
    let fetched =
        tokio::time::timeout(DOWNLOAD_FETCH_TIMEOUT, download).await.unwrap_or_else(|_| {
            let message = format!("no whole answer in {DOWNLOAD_FETCH_TIMEOUT:?}");
            Err(ClientError::Timeout { url: url.to_owned(), message })
        });
    fetched.map_err(|e| match (e, step) {
        (ClientError::Refused { status: 404, .. }, Some((index, host))) => {
            DownloadError::Gone { index: *index, host: host.clone() }
        }
        (e, _) => DownloadError::Fetch(e),
    })
}

fn locate(
    record: &RunRecord,
    which: Which,
    stored_input: &(dyn Fn(&str) -> Option<std::path::PathBuf> + Sync),
) -> Result<Source, DownloadError> {
    match which {
        Which::Result => match (&record.result, record.status) {
            (Some(result), Status::Completed) => Ok(Source {
                location: Location::Host { url: result.url.clone(), step: None },
                hash: result.hash.clone(),
                label: "result".into(),
            }),
            (_, status) if !status.is_final() => Err(DownloadError::NotFinished(record.id.clone())),
            (_, status) => Err(DownloadError::NoResult {
                status: format!("{status:?}").to_lowercase(),
                reason: record.error.clone().unwrap_or_else(|| "no reason given".into()),
            }),
        },
        Which::Step(index) => {
            let step = record
                .steps
                .iter()
                .find(|s| s.index == index)
                .ok_or_else(|| DownloadError::NoStep { run: record.id.clone(), index })?;
            let hash = step.output_hash.clone().ok_or_else(|| DownloadError::NotAFilter {
                index,
                service: step.service.clone(),
            })?;
            let url = format!("{}/blobs/{hash}.mfm", step.host.trim_end_matches('/'));
            Ok(Source {
                location: Location::Host { url, step: Some((index, step.host.clone())) },
                hash,
                label: format!("step{index}-{}", step.service),
            })
        }
        Which::Input => {
            let input = record.input.as_ref().ok_or_else(|| {
                DownloadError::NoInput(format!("run {} has not loaded its input yet", record.id))
            })?;
            let file = input.url.rsplit_once("/inputs/").map(|(_, file)| file).unwrap_or("");
            let path = stored_input(file).ok_or_else(|| {
                DownloadError::NoInput(format!(
                    "the input {} is not stored on this engine (only uploaded inputs are shown)",
                    input.url
                ))
            })?;
            let format = match file.rsplit_once('.').map(|(_, ext)| ext) {
                Some("mfm") => None,
                ext => Some(ext.and_then(Format::from_name).ok_or_else(|| {
                    DownloadError::NoInput(format!("the input {file} has no mesh extension"))
                })?),
            };
            Ok(Source {
                location: Location::Stored { path, format },
                hash: input.hash.clone(),
                label: "input".into(),
            })
        }
    }
}

fn decode_packed(packed: &[u8], url: &str) -> Result<MeshData, DownloadError> {
    meshflow_codec::pack::decode(packed)
        .map_err(|e| DownloadError::Corrupt { url: url.to_owned(), message: e.to_string() })
}

/// An input stored by the engine, decoded (`format` `None`: packed), with its packed bytes
/// when it is packed.
fn read_stored(
    path: &std::path::Path,
    format: Option<Format>,
) -> Result<(MeshData, Option<Vec<u8>>), DownloadError> {
    let name = path.display().to_string();
    let corrupt = |message: String| DownloadError::Corrupt { url: name.clone(), message };
    let size = std::fs::metadata(path).map_err(|e| corrupt(e.to_string()))?.len();
    if size > MAX_INPUT_DECODE_BYTES {
        return Err(corrupt(format!("{size} bytes is over the limit of {MAX_INPUT_DECODE_BYTES}")));
    }
    let bytes = std::fs::read(path).map_err(|e| corrupt(e.to_string()))?;
    match format {
        Some(format) => meshflow_meshio::load_bytes(&bytes, format, &name)
            .map(|mesh| (mesh, None))
            .map_err(|e| corrupt(e.to_string())),
        None => decode_packed(&bytes, &name).map(|mesh| (mesh, Some(bytes))),
    }
}

fn encode(mesh: &MeshData, format: MeshFormat) -> Result<Vec<u8>, DownloadError> {
    let failed = |message: String| DownloadError::Convert { format: format.extension(), message };
    match format {
        MeshFormat::File(file_format) => {
            let mut bytes = Vec::new();
            meshflow_meshio::write_to(&mut bytes, mesh, file_format)
                .map_err(|e| failed(e.to_string()))?;
            Ok(bytes)
        }
        MeshFormat::Mfm => meshflow_codec::pack::encode(mesh).map_err(|e| failed(e.to_string())),
        MeshFormat::Raw => Ok(raw(mesh)),
    }
}

fn raw(mesh: &MeshData) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(12 + 4 * (mesh.positions.len() + mesh.triangles.len()));
    bytes.extend_from_slice(RAW_MAGIC);
    bytes.extend_from_slice(&(mesh.vertex_count() as u32).to_le_bytes());
    bytes.extend_from_slice(&(mesh.triangle_count() as u32).to_le_bytes());
    bytes.extend_from_slice(&as_le_bytes_f32(&mesh.positions));
    bytes.extend(mesh.triangles.iter().flat_map(|t| t.to_le_bytes()));
    bytes
}

/// A file-name stem from an input's name: its stem, kept to letters, digits, `-`, `_` and
/// `.`, at most 64 characters ("mesh" when nothing is left).
pub fn stem_of(name: &str) -> String {
    let base = name.rsplit(['/', '\\']).next().unwrap_or(name);
    let stem = base.rsplit_once('.').map_or(base, |(stem, _)| stem);
    let clean: String = stem
        .chars()
        .filter(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
        .take(64)
        .collect();
    if clean.trim_matches('.').is_empty() { "mesh".into() } else { clean }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_and_stems() {
        assert_eq!(MeshFormat::parse("ply"), Some(MeshFormat::File(Format::Ply)));
        assert_eq!(MeshFormat::parse("mfm"), Some(MeshFormat::Mfm));
        assert_eq!(MeshFormat::parse("exe"), None);
        assert_eq!(stem_of("scans/bunny.obj"), "bunny");
        assert_eq!(stem_of("a b\"<x>.ply"), "abx");
        assert_eq!(stem_of("..."), "mesh");
    }

    /// A stand-in host serving one packed mesh under any `.mfm` name but `missing.mfm`.
    async fn host_serving(mesh: &MeshData) -> String {
        use axum::extract::Path;
        use axum::http::StatusCode;
        let packed = meshflow_codec::pack::encode(mesh).unwrap();
        let app = axum::Router::new().route(
            "/blobs/{name}",
            axum::routing::get(move |Path(name): Path<String>| async move {
                match name.as_str() {
                    "missing.mfm" => Err(StatusCode::NOT_FOUND),
                    _ => Ok(packed.clone()),
                }
            }),
        );
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let url = format!("http://{}", listener.local_addr().unwrap());
        tokio::spawn(async move { axum::serve(listener, app).await });
        url
    }

    fn completed(url: String, hash: String) -> RunRecord {
        let mut record = RunRecord::new("r-1".into(), crate::workflow::Transfer::Auto);
        record.status = Status::Completed;
        record.result = Some(meshflow_api::engine::ResultRecord {
            url,
            hash,
            bytes: None,
            vertices: 3,
            triangles: 1,
        });
        record
    }

    #[tokio::test]
    async fn a_mesh_whose_hash_is_not_the_records_is_never_served() {
        let mesh = MeshData::new(vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], vec![0, 1, 2]);
        let host = host_serving(&mesh).await;
        let downloads = Downloads::default();
        let none = |_: &str| None;
        let any_host = |url: &str| Some(HostClient::new(url));
        let good = completed(format!("{host}/blobs/a.mfm"), mesh.content_hash().to_hex());
        let ply = MeshFormat::File(Format::Ply);
        let served =
            downloads.mesh(&good, Which::Result, ply, "tri", &none, &any_host).await.unwrap();
        assert_eq!(served.file_name, "tri-result.ply");
        let back = meshflow_meshio::load_bytes(&served.bytes, Format::Ply, "x").unwrap();
        assert_eq!(back.content_hash(), mesh.content_hash());

        let forged = completed(format!("{host}/blobs/a.mfm"), "00".repeat(32));
        let refused = downloads.mesh(&forged, Which::Result, ply, "tri", &none, &any_host).await;
        assert!(matches!(refused, Err(DownloadError::HashMismatch { .. })), "{:?}", refused.err());
    }

    #[tokio::test]
    async fn a_step_output_its_host_no_longer_holds_is_gone() {
        let mesh = MeshData::new(vec![0.0; 9], vec![0, 1, 2]);
        let host = host_serving(&mesh).await;
        let mut record = completed(format!("{host}/blobs/a.mfm"), mesh.content_hash().to_hex());
        let step: meshflow_api::engine::StepRecord = serde_json::from_value(serde_json::json!({
            "index": 0, "path": "steps[0]", "kind": "filter", "service": "fill-holes",
            "host": host, "plugin": "p", "params": {}, "started_ms": 0.0, "finished_ms": 1.0,
            "compute_ms": 1.0, "wait_ms": 0.0, "overhead_ms": 0.0, "input_hash": "i",
            "output_hash": "missing", "report": "", "failed_hosts": [], "transfers": []
        }))
        .unwrap();
        record.steps.push(step);
        let none = |_: &str| None;
        let any_host = |url: &str| Some(HostClient::new(url));
        let downloads = Downloads::default();
        let gone =
            downloads.mesh(&record, Which::Step(0), MeshFormat::Raw, "m", &none, &any_host).await;
        assert!(matches!(gone, Err(DownloadError::Gone { index: 0, .. })), "{:?}", gone.err());
    }

    #[test]
    fn raw_is_a_header_then_the_arrays() {
        let mesh = MeshData::new(vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0], vec![0, 1, 2]);
        let bytes = raw(&mesh);
        assert_eq!(&bytes[..4], RAW_MAGIC);
        assert_eq!(bytes[4..8], 3u32.to_le_bytes());
        assert_eq!(bytes[8..12], 1u32.to_le_bytes());
        assert_eq!(bytes[16..20], 1f32.to_le_bytes());
        assert_eq!(bytes[bytes.len() - 4..], 2u32.to_le_bytes());
        assert_eq!(bytes.len(), 12 + 9 * 4 + 3 * 4);
    }
}
