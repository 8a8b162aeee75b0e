//! Meshes leave the system in the user's format (DESIGN §6): a run's result, a step's output
//! or its input, written by a host, which checks the mesh against the run record's hash
//! before it writes a byte (`POST /meshes/convert`). The `raw` arrays the viewer reads are
//! checked again here, by hashing them. The engine links no mesh codec (DESIGN §1): a step's
//! output and the result are written by the host that holds them, an input by a host of the
//! run (else any host that is up), which fetches it from where the run read it.

use std::sync::Arc;

use meshflow_api::host::{ConvertMesh, MeshFileFormat};
use meshflow_api::{ClientError, HostClient, raw_mesh};
use tokio::sync::Semaphore;

use crate::limits::{DOWNLOAD_FETCH_TIMEOUT, MAX_CONCURRENT_DOWNLOADS, MAX_DOWNLOAD_FETCH_BYTES};
use crate::record::{RunRecord, Status};
use crate::verified;

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
    #[error("writing the mesh on {host} failed: {error}")]
    Fetch { host: String, error: ClientError },
    #[error("{0}: not a registered host")]
    UnknownHost(String),
    #[error("no registered host is up to write the input")]
    NoHost,
    #[error(
        "the mesh from {host} has content hash {actual}, but the run record says {expected}: \
         not served"
    )]
    HashMismatch { host: String, expected: String, actual: String },
    #[error("the mesh from {host} is not a raw mesh: {error}")]
    Corrupt { host: String, error: raw_mesh::RawMeshError },
    #[error("the mesh from {host} could not be kept: {message}")]
    Spool { host: String, message: String },
}

impl DownloadError {
    /// The host holding the mesh failed it (gone, unknown, down, lying): another copy may do.
    fn is_holder_failure(&self) -> bool {
        match self {
            Self::Fetch { error, .. } => {
                error.is_host_failure() || matches!(error, ClientError::Refused { status: 404, .. })
            }
            Self::UnknownHost(_) | Self::Gone { .. } | Self::HashMismatch { .. } => true,
            Self::Corrupt { .. } | Self::Spool { .. } => true,
            _ => false,
        }
    }
}

/// A converted mesh and the file name it is offered under.
/// Checked before it is offered (see `crate::verified`); on disk, deleted when dropped.
pub struct Download {
    pub file: tempfile::TempPath,
    pub bytes: u64,
    pub file_name: String,
    /// What the mesh carries that this file does not (see [`verified::Written`]).
    pub not_kept: Vec<String>,
}

/// Asks hosts for meshes, at most [`MAX_CONCURRENT_DOWNLOADS`] at a time.
pub struct Downloads {
    slots: Arc<Semaphore>,
    /// Where hosts' answers are spooled and files written (`DATA/spool`).
    dir: std::path::PathBuf,
}

impl Default for Downloads {
    fn default() -> Self {
        Self::spooling_in(std::env::temp_dir().join("meshflow-engine-spool"))
    }
}

impl Downloads {
    /// Spooling under `dir` (made when first needed).
    pub fn spooling_in(dir: std::path::PathBuf) -> Self {
        Self { slots: Arc::new(Semaphore::new(MAX_CONCURRENT_DOWNLOADS)), dir }
    }
}

/// The hosts a download may ask: by URL, a registered host's client (with the cluster
/// token and origins); and the registered hosts that are up, for an input.
pub trait Hosts: Sync {
    fn registered(&self, url: &str) -> Option<HostClient>;
    fn up(&self) -> Vec<HostClient>;
}

/// Where a mesh is and what hash it must have.
#[derive(Clone)]
struct Source {
    /// The host holding it; for an input, none (any host fetches it from `from`).
    holder: Option<String>,
    from: Option<String>,
    step: Option<usize>,
    hash: String,
    label: String,
    /// The grid a quantised run's input was snapped onto: `hash` names the snapped mesh.
    grid: Option<[i32; 3]>,
}

impl Downloads {
    /// The mesh `which` of the run `record` as `format`; `stem` names the download.
    pub async fn mesh(
        &self,
        record: &RunRecord,
        which: Which,
        format: MeshFileFormat,
        stem: &str,
        hosts: &dyn Hosts,
    ) -> Result<Download, DownloadError> {
        let source = locate(record, which)?;
        // The result falls back to its copies on other hosts when its producer fails.
        let copies = match (which, &record.result) {
            (Which::Result, Some(result)) if source.holder.is_some() => result.copies.clone(),
            _ => Vec::new(),
        };
        let mut outcome = self.mesh_from(record, &source, format, stem, hosts).await;
        for copy in copies {
            match &outcome {
                Err(error) if error.is_holder_failure() => {
                    let elsewhere = Source { holder: Some(copy), ..source.clone() };
                    outcome = self.mesh_from(record, &elsewhere, format, stem, hosts).await;
                }
                _ => break,
            }
        }
        outcome
    }

    async fn mesh_from(
        &self,
        record: &RunRecord,
        source: &Source,
        format: MeshFileFormat,
        stem: &str,
        hosts: &dyn Hosts,
    ) -> Result<Download, DownloadError> {
        let writer = match &source.holder {
            Some(url) => {
                hosts.registered(url).ok_or_else(|| DownloadError::UnknownHost(url.clone()))?
            }
            None => input_writer(record, hosts).ok_or(DownloadError::NoHost)?,
        };
        // A slot before the request: disk and connections stay bounded by the slots.
        let _slot = self.slots.acquire().await.expect("the semaphore is never closed");
        let host = writer.base_url().to_owned();
        let verified::Written { path: file, bytes, not_kept } =
            tokio::time::timeout(DOWNLOAD_FETCH_TIMEOUT, self.verified(&writer, source, format))
                .await
                .unwrap_or_else(|_| {
                    let message = format!("no whole answer in {DOWNLOAD_FETCH_TIMEOUT:?}");
                    let error = ClientError::Timeout { url: host.clone(), message };
                    Err(DownloadError::Fetch { host, error })
                })?;
        let file_name = format!("{stem}-{}.{}", source.label, format.extension());
        Ok(Download { file, bytes, file_name, not_kept })
    }

    /// The mesh as `format`, on disk, its hash checked: the host's `raw` answer hashed as it
    /// is spooled, then PLY/OBJ/OFF/STL written here from it, or `.mfm` taken from the same
    /// host once its `raw` proved it holds the mesh (see `crate::verified`).
    async fn verified(
        &self,
        writer: &HostClient,
        source: &Source,
        format: MeshFileFormat,
    ) -> Result<verified::Written, DownloadError> {
        let host = writer.base_url().to_owned();
        let raw = self.spooled(writer, source, MeshFileFormat::Raw).await?;
        let actual = raw.hash.clone().expect("a raw answer is hashed");
        if actual != source.hash {
            let expected = source.hash.clone();
            return Err(DownloadError::HashMismatch { host, expected, actual });
        }
        match format {
            MeshFileFormat::Raw => {
                Ok(verified::Written { path: raw.path, bytes: raw.bytes, not_kept: Vec::new() })
            }
            MeshFileFormat::Mfm => {
                let packed = self.spooled(writer, source, format).await?;
                let (path, bytes) = (packed.path, packed.bytes);
                Ok(verified::Written { path, bytes, not_kept: Vec::new() })
            }
            _ => verified::write_format(&raw.path, format, &self.dir)
                .await
                .map_err(|e| DownloadError::Spool { host, message: e.to_string() }),
        }
    }

    /// The host's answer for `format`, spooled under the cap (and hashed, for `raw`).
    async fn spooled(
        &self,
        writer: &HostClient,
        source: &Source,
        format: MeshFileFormat,
    ) -> Result<verified::Spooled, DownloadError> {
        let host = writer.base_url().to_owned();
        let failed = |error| match (error, source.step) {
            (ClientError::Refused { status: 404, .. }, Some(index)) => {
                DownloadError::Gone { index, host: host.clone() }
            }
            (error, _) => DownloadError::Fetch { host: host.clone(), error },
        };
        let request = ConvertMesh {
            hash: source.hash.clone(),
            from: source.from.clone(),
            format,
            grid: source.grid,
        };
        let response = writer.convert_response(request).await.map_err(failed)?;
        let raw = format == MeshFileFormat::Raw;
        let limit = MAX_DOWNLOAD_FETCH_BYTES;
        verified::spool(response, &host, &self.dir, limit, raw).await.map_err(|e| match e {
            verified::SpoolError::Fetch(error) => failed(error),
            verified::SpoolError::NotRaw(error) => {
                DownloadError::Corrupt { host: host.clone(), error }
            }
            other => DownloadError::Spool { host: host.clone(), message: other.to_string() },
        })
    }
}

/// Who writes a run's input: a host the run used that is still up, else any host that is up.
fn input_writer(record: &RunRecord, hosts: &dyn Hosts) -> Option<HostClient> {
    let up = hosts.up();
    let used = record
        .steps
        .iter()
        .find_map(|step| up.iter().find(|client| client.base_url() == step.host.as_str()).cloned());
    used.or_else(|| up.into_iter().next())
}

fn locate(record: &RunRecord, which: Which) -> Result<Source, DownloadError> {
    match which {
        Which::Result => match (&record.result, record.status) {
            // No filter ran (a WHILE false at once): the result is the input, written as one.
            (Some(result), Status::Completed)
                if record.input.as_ref().is_some_and(|input| input.url == result.url) =>
            {
                let input = record.input.as_ref().expect("checked just above");
                Ok(Source {
                    holder: None,
                    from: Some(input.url.clone()),
                    step: None,
                    hash: result.hash.clone(),
                    label: "result".into(),
                    grid: input.grid,
                })
            }
            (Some(result), Status::Completed) => Ok(Source {
                // A blob URL of the host that holds it.
                holder: Some(result.url.clone()),
                from: None,
                step: None,
                hash: result.hash.clone(),
                label: "result".into(),
                grid: None,
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
            Ok(Source {
                holder: Some(step.host.clone()),
                from: None,
                step: Some(index),
                hash,
                label: format!("step{index}-{}", step.service),
                grid: None,
            })
        }
        Which::Input => {
            let input = record.input.as_ref().ok_or_else(|| {
                DownloadError::NoInput(format!("run {} has not loaded its input yet", record.id))
            })?;
            Ok(Source {
                holder: None,
                from: Some(input.url.clone()),
                step: None,
                hash: input.hash.clone(),
                label: "input".into(),
                grid: input.grid,
            })
        }
    }
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
        assert_eq!(MeshFileFormat::parse("ply"), Some(MeshFileFormat::Ply));
        assert_eq!(MeshFileFormat::parse("mfm"), Some(MeshFileFormat::Mfm));
        assert_eq!(MeshFileFormat::parse("exe"), None);
        assert_eq!(stem_of("scans/bunny.obj"), "bunny");
        assert_eq!(stem_of("a b\"<x>.ply"), "abx");
        assert_eq!(stem_of("..."), "mesh");
    }

    /// One triangle as a `raw` mesh, and its content hash.
    fn triangle() -> (Vec<u8>, String) {
        let mut raw = raw_mesh::MAGIC.to_vec();
        raw.extend([3u32, 1].iter().flat_map(|v| v.to_le_bytes()));
        raw.extend([0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|v| v.to_le_bytes()));
        raw.extend([0u32, 1, 2].iter().flat_map(|v| v.to_le_bytes()));
        let hash = raw_mesh::content_hash(&raw).unwrap();
        (raw, hash)
    }

    /// A stand-in host: writes `raw` for any request but one naming `from` a URL ending in
    /// `/missing`, and holds nothing it is not told where to fetch when `holds` is false;
    /// each request it took is kept.
    async fn host_serving(
        raw: Vec<u8>,
        holds: bool,
    ) -> (String, Arc<std::sync::Mutex<Vec<ConvertMesh>>>) {
        use axum::http::StatusCode;
        let seen = Arc::new(std::sync::Mutex::new(Vec::new()));
        let log = seen.clone();
        let app = axum::Router::new().route(
            "/meshes/convert",
            axum::routing::post(move |axum::Json(request): axum::Json<ConvertMesh>| async move {
                log.lock().unwrap().push(request.clone());
                match (&request.from, holds) {
                    (None, false) => Err(StatusCode::NOT_FOUND),
                    (Some(from), _) if from.ends_with("/missing") => Err(StatusCode::BAD_GATEWAY),
                    _ => Ok(raw.clone()),
                }
            }),
        );
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let url = format!("http://{}", listener.local_addr().unwrap());
        tokio::spawn(async move { axum::serve(listener, app).await });
        (url, seen)
    }

    /// Registered hosts, all up.
    struct Cluster(Vec<String>);

    impl Hosts for Cluster {
        fn registered(&self, url: &str) -> Option<HostClient> {
            let base = self.0.iter().find(|base| url.starts_with(base.as_str()))?;
            Some(HostClient::new(base))
        }

        fn up(&self) -> Vec<HostClient> {
            self.0.iter().map(|base| HostClient::new(base)).collect()
        }
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
            copies: Vec::new(),
        });
        record
    }

    fn step_on(host: &str, output_hash: &str) -> meshflow_api::engine::StepRecord {
        serde_json::from_value(serde_json::json!({
            "index": 0, "path": "steps[0]", "kind": "filter", "service": "fill-holes",
            "host": host, "plugin": "p", "params": {}, "started_ms": 0.0, "finished_ms": 1.0,
            "compute_ms": 1.0, "wait_ms": 0.0, "overhead_ms": 0.0, "input_hash": "i",
            "output_hash": output_hash, "report": "", "failed_hosts": [], "transfers": []
        }))
        .unwrap()
    }

    #[tokio::test]
    async fn raw_arrays_whose_hash_is_not_the_records_are_never_served() {
        let (raw, hash) = triangle();
        let (host, seen) = host_serving(raw.clone(), true).await;
        let cluster = Cluster(vec![host.clone()]);
        let downloads = Downloads::default();
        let good = completed(format!("{host}/blobs/{hash}.mfm"), hash.clone());
        let raw_format = MeshFileFormat::Raw;
        let served = downloads.mesh(&good, Which::Result, raw_format, "tri", &cluster).await;
        let served = served.unwrap();
        assert_eq!(served.file_name, "tri-result.raw");
        assert_eq!(std::fs::read(&served.file).unwrap(), raw);
        assert_eq!(
            seen.lock().unwrap()[0],
            ConvertMesh { hash: hash.clone(), from: None, format: raw_format, grid: None }
        );

        let forged = completed(format!("{host}/blobs/{hash}.mfm"), "00".repeat(32));
        let refused = downloads.mesh(&forged, Which::Result, raw_format, "tri", &cluster).await;
        assert!(matches!(refused, Err(DownloadError::HashMismatch { .. })), "{:?}", refused.err());

        let elsewhere = completed(format!("http://127.0.0.1:9/blobs/{hash}.mfm"), hash);
        let unknown = downloads.mesh(&elsewhere, Which::Result, raw_format, "tri", &cluster).await;
        assert!(matches!(unknown, Err(DownloadError::UnknownHost(_))), "{:?}", unknown.err());
    }

    #[tokio::test]
    async fn a_step_output_its_host_no_longer_holds_is_gone() {
        let (raw, hash) = triangle();
        let (host, _) = host_serving(raw, false).await;
        let mut record = completed(format!("{host}/blobs/{hash}.mfm"), hash.clone());
        record.steps.push(step_on(&host, &hash));
        let cluster = Cluster(vec![host]);
        let downloads = Downloads::default();
        let gone =
            downloads.mesh(&record, Which::Step(0), MeshFileFormat::Ply, "m", &cluster).await;
        assert!(matches!(gone, Err(DownloadError::Gone { index: 0, .. })), "{:?}", gone.err());
    }

    #[tokio::test]
    async fn an_input_is_written_by_a_host_of_the_run_from_where_the_run_read_it() {
        let (raw, hash) = triangle();
        let (other, other_seen) = host_serving(raw.clone(), false).await;
        let (used, used_seen) = host_serving(raw, false).await;
        let mut record = completed(format!("{used}/blobs/{hash}.mfm"), hash.clone());
        record.steps.push(step_on(&used, &hash));
        let input_url = "http://127.0.0.1:7100/inputs/bunny.obj".to_owned();
        record.input = Some(meshflow_api::engine::InputRecord {
            url: input_url.clone(),
            hash: hash.clone(),
            vertices: 3,
            triangles: 1,
            grid: None,
            not_kept: Vec::new(),
            attributes: Vec::new(),
        });
        let cluster = Cluster(vec![other, used]);
        let downloads = Downloads::default();
        let ply = MeshFileFormat::Ply;
        let served = downloads.mesh(&record, Which::Input, ply, "bunny", &cluster).await.unwrap();
        assert_eq!(served.file_name, "bunny-input.ply");
        let written = std::fs::read(&served.file).unwrap();
        assert!(written.starts_with(b"ply\nformat binary_little_endian 1.0\nelement vertex 3\n"));
        assert!(other_seen.lock().unwrap().is_empty());
        let asked = used_seen.lock().unwrap().clone();
        // Asked for the arrays, which are hashed here; the PLY is written from them.
        let raw_format = MeshFileFormat::Raw;
        let request = ConvertMesh {
            hash: hash.clone(),
            from: Some(input_url),
            format: raw_format,
            grid: None,
        };
        assert_eq!(asked, std::slice::from_ref(&request));

        // A quantised run's input hash names the mesh on the run's grid: the host is told
        // the grid, to snap what it fetches before checking it.
        record.input.as_mut().unwrap().grid = Some([-10, -12, -9]);
        downloads.mesh(&record, Which::Input, ply, "bunny", &cluster).await.unwrap();
        let asked = used_seen.lock().unwrap().last().cloned();
        assert_eq!(asked, Some(ConvertMesh { grid: Some([-10, -12, -9]), ..request }));

        record.input.as_mut().unwrap().url = "http://127.0.0.1:7100/inputs/missing".into();
        let failed = downloads.mesh(&record, Which::Input, ply, "bunny", &cluster).await;
        assert!(matches!(failed, Err(DownloadError::Fetch { .. })), "{:?}", failed.err());
        assert!(matches!(
            downloads.mesh(&record, Which::Input, ply, "bunny", &Cluster(vec![])).await,
            Err(DownloadError::NoHost)
        ));
    }
}
