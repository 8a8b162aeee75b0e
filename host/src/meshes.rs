//! Mesh bytes as they travel: packed (`.mfm`) or any file format `io` reads; how to tell
//! which, decode them, and the blob name they are kept under; a decoded mesh with its
//! content hash ([`CurrentMesh`]).

use std::sync::Arc;

use meshflow_codec::pack::{self, PackError};
use meshflow_mesh::{ContentHash, MeshData};
use meshflow_meshio::{self as io, Format, LoadError};

/// Why mesh bytes could not be read as a mesh.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("{url}: cannot tell the mesh format from the name or the first bytes")]
    UnknownFormat { url: String },
    #[error("blob {0} is not a mesh")]
    NotAMesh(String),
    #[error("{name}: {source}")]
    Packed {
        name: String,
        #[source]
        source: PackError,
    },
    #[error(transparent)]
    File(#[from] LoadError),
    /// The blocking task decoding or hashing it panicked or was cancelled.
    #[error(transparent)]
    Task(#[from] tokio::task::JoinError),
}

/// A mesh in memory with its content hash (computed once): a session's, or one just
/// decoded or made.
#[derive(Clone)]
pub struct CurrentMesh {
    pub mesh: Arc<MeshData>,
    pub hash: String,
}

/// Mesh bytes decoded, with how they were encoded and the bytes themselves (kept as a blob).
pub struct Decoded {
    pub mesh: CurrentMesh,
    pub bytes: Vec<u8>,
    pub encoding: MeshEncoding,
    /// What the file held that the mesh does not keep (nothing for packed meshes).
    pub not_kept: Vec<String>,
}

const PACKED_MAGIC: &[u8] = b"MFM\x1a";
/// Extension of packed full meshes and of corrections.
pub const PACKED: &str = "mfm";
pub const CORRECTION: &str = "mfc";
/// Extension of replay corrections (a step named, DESIGN §4).
pub const REPLAY: &str = "mfr";

/// How a mesh's bytes are encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshEncoding {
    Packed,
    File(Format),
}

impl MeshEncoding {
    pub fn from_extension(extension: &str) -> Option<Self> {
        if extension.eq_ignore_ascii_case(PACKED) {
            return Some(MeshEncoding::Packed);
        }
        Format::from_name(extension).map(MeshEncoding::File)
    }

    /// By the extension of the URL's path.
    pub fn by_url(url: &str) -> Option<Self> {
        let url = reqwest::Url::parse(url).ok()?;
        let (_, extension) = url.path_segments()?.next_back()?.rsplit_once('.')?;
        MeshEncoding::from_extension(extension)
    }

    /// By the extension of the URL's path, else by the first bytes.
    pub fn detect(url: &str, bytes: &[u8]) -> Result<Self, MeshError> {
        Self::by_url(url)
            .or_else(|| sniff(bytes))
            .ok_or_else(|| MeshError::UnknownFormat { url: url.to_owned() })
    }

    /// By a blob's extension.
    pub fn of_blob(name: &str) -> Result<Self, MeshError> {
        let extension = name.rsplit_once('.').map(|(_, e)| e).unwrap_or_default();
        Self::from_extension(extension).ok_or_else(|| MeshError::NotAMesh(name.to_owned()))
    }
}

fn sniff(bytes: &[u8]) -> Option<MeshEncoding> {
    let file = |format| Some(MeshEncoding::File(format));
    if bytes.starts_with(PACKED_MAGIC) {
        return Some(MeshEncoding::Packed);
    }
    if bytes.starts_with(b"ply") {
        return file(Format::Ply);
    }
    if bytes.starts_with(b"OFF") {
        return file(Format::Off);
    }
    if bytes.starts_with(b"solid") || is_binary_stl(bytes) {
        return file(Format::Stl);
    }
    let head = &bytes[..bytes.len().min(4096)];
    let obj_line = |line: &[u8]| line.starts_with(b"v ") || line.starts_with(b"f ");
    if head.split(|&b| b == b'\n').any(obj_line) {
        return file(Format::Obj);
    }
    None
}

/// An 80-byte header, a triangle count, and exactly 50 bytes per triangle.
fn is_binary_stl(bytes: &[u8]) -> bool {
    bytes.get(80..84).is_some_and(|count| {
        let count = u32::from_le_bytes(count.try_into().expect("four bytes")) as u64;
        84 + 50 * count == bytes.len() as u64
    })
}

/// Decodes mesh bytes; errors name `name` (a URL or blob).
pub fn decode(bytes: &[u8], encoding: MeshEncoding, name: &str) -> Result<MeshData, MeshError> {
    match encoding {
        MeshEncoding::Packed => pack::decode(bytes)
            .map_err(|source| MeshError::Packed { name: name.to_owned(), source }),
        MeshEncoding::File(format) => Ok(io::load_bytes(bytes, format, name)?),
    }
}

/// Decodes mesh bytes from `url` (by its extension or their first bytes) and hashes the
/// mesh, on a blocking thread; the bytes come back with it, not copied.
pub async fn decode_hashed(url: &str, bytes: Vec<u8>) -> Result<Decoded, MeshError> {
    let encoding = MeshEncoding::detect(url, &bytes)?;
    let url = url.to_owned();
    tokio::task::spawn_blocking(move || {
        let (mesh, not_kept) = match encoding {
            MeshEncoding::File(format) => {
                let loaded = io::load_bytes_reporting(&bytes, format, &url)?;
                (loaded.mesh, loaded.dropped.lines())
            }
            MeshEncoding::Packed => (decode(&bytes, encoding, &url)?, Vec::new()),
        };
        let hash = mesh.content_hash().to_hex();
        let mesh = CurrentMesh { mesh: Arc::new(mesh), hash };
        Ok(Decoded { mesh, bytes, encoding, not_kept })
    })
    .await?
}

/// Decodes a packed mesh from `chunks` as a download delivers them ([`pack::decode_from`]),
/// on a blocking thread; the download's end (its sender dropped) is the stream's end.
pub fn decode_arriving(
    url: &str,
    chunks: std::sync::mpsc::Receiver<Vec<u8>>,
) -> tokio::task::JoinHandle<Result<CurrentMesh, MeshError>> {
    let name = url.to_owned();
    tokio::task::spawn_blocking(move || {
        let source = Chunks { chunks, current: Vec::new(), at: 0 };
        let (mesh, hash) =
            pack::decode_from(source).map_err(|source| MeshError::Packed { name, source })?;
        Ok(CurrentMesh { mesh: Arc::new(mesh), hash: hash.to_hex() })
    })
}

/// A reader over the chunks a download hands on.
struct Chunks {
    chunks: std::sync::mpsc::Receiver<Vec<u8>>,
    current: Vec<u8>,
    at: usize,
}

impl std::io::Read for Chunks {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        while self.at == self.current.len() {
            match self.chunks.recv() {
                Ok(chunk) => (self.current, self.at) = (chunk, 0),
                Err(_) => return Ok(0),
            }
        }
        let n = buf.len().min(self.current.len() - self.at);
        buf[..n].copy_from_slice(&self.current[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

/// A mesh with its content hash, hashed off the async threads.
pub async fn hashed(mesh: MeshData) -> Result<CurrentMesh, tokio::task::JoinError> {
    tokio::task::spawn_blocking(move || {
        let hash = mesh.content_hash().to_hex();
        CurrentMesh { mesh: Arc::new(mesh), hash }
    })
    .await
}

/// The blob a mesh's bytes are kept as: a packed mesh under its content hash (so it is the
/// full mesh other hosts ask for), a file under `digest`, the BLAKE3 of its bytes (taken as
/// they were downloaded).
pub fn blob_name(digest: &blake3::Hash, encoding: MeshEncoding, content_hash: &str) -> String {
    match encoding {
        MeshEncoding::Packed => full_mesh_name(content_hash),
        MeshEncoding::File(format) => format!("{}.{}", digest.to_hex(), format.extension()),
    }
}

pub fn full_mesh_name(content_hash: &str) -> String {
    format!("{content_hash}.{PACKED}")
}

pub fn correction_name(bytes: &[u8]) -> String {
    format!("{}.{CORRECTION}", blake3::hash(bytes).to_hex())
}

/// A step's own edit log, named before it is encoded: by the hashes it leads from and to.
pub fn edit_log_name(base: ContentHash, result: ContentHash) -> String {
    let mut hasher = blake3::Hasher::new();
    hasher.update(b"meshflow edit log\0").update(&base.0).update(&result.0);
    format!("{}.{CORRECTION}", hasher.finalize().to_hex())
}

pub fn replay_name(bytes: &[u8]) -> String {
    format!("{}.{REPLAY}", blake3::hash(bytes).to_hex())
}

/// A name this host could have given a blob: 64 hex digits and a known extension. Anything
/// else (a path, a temporary file) is not a blob.
pub fn is_blob_name(name: &str) -> bool {
    name.split_once('.').is_some_and(|(hash, extension)| {
        hash.len() == 64
            && hash.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
            && (extension == CORRECTION
                || extension == REPLAY
                || MeshEncoding::from_extension(extension).is_some())
            && extension.bytes().all(|b| b.is_ascii_lowercase())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn format_comes_from_the_url_then_from_the_bytes() {
        let detect = MeshEncoding::detect;
        assert_eq!(detect("http://h/a/b.PLY?x=1", b"").unwrap(), MeshEncoding::File(Format::Ply));
        assert_eq!(detect("http://h/blobs/x.mfm", b"").unwrap(), MeshEncoding::Packed);
        assert_eq!(detect("http://h/in", b"MFM\x1a..").unwrap(), MeshEncoding::Packed);
        assert_eq!(
            detect("http://h/in", b"# c\nv 0 0 0\n").unwrap(),
            MeshEncoding::File(Format::Obj)
        );
        assert_eq!(detect("http://h/in", b"OFF\n3 1 0").unwrap(), MeshEncoding::File(Format::Off));
        let error = detect("http://h/in", b"\x00\x01garbage").unwrap_err().to_string();
        assert!(error.contains("http://h/in") && error.contains("cannot tell"), "{error}");
    }

    #[test]
    fn only_hash_named_blobs_are_blobs() {
        let hash = "ab".repeat(32);
        assert!(is_blob_name(&format!("{hash}.mfc")));
        assert!(is_blob_name(&format!("{hash}.obj")));
        assert!(!is_blob_name(&format!("{hash}.exe")));
        assert!(!is_blob_name("../../etc/passwd"));
        assert!(!is_blob_name(".meshflow-x.tmp"));
    }
}
