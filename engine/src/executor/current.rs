//! The mesh as of the last finished filter, and where it can be had.

use std::sync::Arc;

use meshflow_api::host::{BlobRef, FilterResult, FullRef, SessionStatus};

use super::verify::full_mesh_url;
use crate::record::{InputRecord, StepRecord};

/// The mesh as of the last finished filter, and how to get it.
pub(super) struct Current {
    pub hash: String,
    pub full: FullRef,
    pub correction: Option<BlobRef>,
    pub vertices: u64,
    pub triangles: u64,
    /// The size of the last full mesh seen and its vertex count, from which the cost model
    /// estimates the current one's; shared with the forwarded updates, which see it first.
    pub last_full: LastFull,
    /// The host whose filter made this mesh (none for the input).
    pub producer: Option<String>,
    /// A quantised run's grid (step exponents), for hosts that join from this mesh.
    pub grid: Option<[i32; 3]>,
}

impl Current {
    /// The input at `url`, as the first host that loaded it tells it.
    pub fn loaded(url: &str, status: &SessionStatus) -> Self {
        let hash = status.hash.clone().unwrap_or_default();
        let (vertices, triangles) =
            (status.vertices.unwrap_or(0) as u64, status.triangles.unwrap_or(0) as u64);
        Self {
            full: FullRef { url: url.to_owned(), hash: hash.clone() },
            hash,
            correction: None,
            vertices,
            triangles,
            last_full: LastFull::new(status.input_bytes, vertices),
            producer: None,
            grid: status.grid,
        }
    }

    /// The input at `url` as the record has it (a resumed run).
    pub fn recorded(url: &str, input: InputRecord) -> Self {
        Self {
            full: FullRef { url: url.to_owned(), hash: input.hash.clone() },
            hash: input.hash,
            correction: None,
            vertices: input.vertices,
            triangles: input.triangles,
            last_full: LastFull::new(None, input.vertices),
            producer: None,
            grid: input.grid,
        }
    }

    /// What the input record says of it.
    pub fn input_record(&self, url: &str) -> InputRecord {
        InputRecord {
            url: url.to_owned(),
            hash: self.hash.clone(),
            vertices: self.vertices,
            triangles: self.triangles,
            grid: self.grid,
            not_kept: Vec::new(),
            attributes: Vec::new(),
        }
    }

    /// A filter's output, made by `producer`, becomes the current mesh.
    pub fn advance(&mut self, filter: &FilterResult, producer: &str) {
        self.hash = filter.output_hash.clone();
        self.producer = Some(producer.to_owned());
        self.full = filter.full.clone();
        self.correction = Some(filter.correction.clone());
        self.vertices = filter.vertices as u64;
        self.triangles = filter.triangles as u64;
    }

    /// A filter done before a restart, with output `hash`, becomes the current mesh: its
    /// producer serves it whole.
    pub fn restore(&mut self, step: &StepRecord, hash: String) {
        self.full = FullRef { url: full_mesh_url(&step.host, &hash), hash: hash.clone() };
        self.hash = hash;
        self.producer = Some(step.host.clone());
        self.correction = None;
        self.vertices = step.vertices.unwrap_or(0);
        self.triangles = step.triangles.unwrap_or(0);
        if let (Some(bytes), Some(vertices)) = (step.full_bytes, step.vertices) {
            self.last_full.seen(bytes, vertices);
        }
    }
}

/// The last full mesh size seen in the run, with the vertex count it had; shared by the
/// executor and its forwarded updates.
#[derive(Clone)]
pub(crate) struct LastFull(Arc<std::sync::Mutex<Option<(u64, u64)>>>);

impl LastFull {
    pub(super) fn new(bytes: Option<u64>, vertices: u64) -> Self {
        Self(Arc::new(std::sync::Mutex::new(bytes.map(|b| (b, vertices)))))
    }

    pub(crate) fn seen(&self, bytes: u64, vertices: u64) {
        *self.0.lock().expect("last full lock") = Some((bytes, vertices));
    }

    /// The full size of a mesh of `vertices`, scaled from the last one seen (unknown: so
    /// large that a full transfer is never expected to be quickest).
    pub(super) fn estimate(&self, vertices: u64) -> u64 {
        match *self.0.lock().expect("last full lock") {
            Some((bytes, seen)) if seen > 0 => {
                (bytes as f64 * vertices as f64 / seen as f64).round() as u64
            }
            Some((bytes, _)) => bytes,
            None => u64::MAX / 4,
        }
    }
}
