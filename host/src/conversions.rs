//! Meshes written for people and other tools (DESIGN §6): a mesh this host holds, or fetches
//! where the request says, as PLY, OBJ, OFF, STL, packed or `raw`, its content hash checked
//! before a byte is written. The engine serves its downloads from here: it links no mesh
//! codec (DESIGN §1). Also the packing of an output mesh on its first request.

use std::sync::Arc;

use tokio::sync::Semaphore;

use meshflow_api::fetch_rules::FetchScope;
use meshflow_api::host::MeshFileFormat;
use meshflow_api::raw_mesh;
use meshflow_codec::pack::{self, PackError};
use meshflow_codec::quantize::Grid;
use meshflow_mesh::attributes::write_canonical;
use meshflow_mesh::{MeshData, as_le_bytes_f32, as_le_bytes_u32};
use meshflow_meshio::{self as io, Format};

use crate::blobs::{BlobError, BlobStore};
use crate::config::MAX_CONCURRENT_CONVERSIONS;
use crate::downloads::Downloads;
use crate::meshes::{self, MeshEncoding, MeshError, PACKED};
use crate::sessions::Sessions;

/// Why a mesh cannot be written.
#[derive(Debug, thiserror::Error)]
pub enum ConvertError {
    #[error("this host holds no mesh with content hash {0}")]
    NotHeld(String),
    #[error("fetching the mesh: {0}")]
    Download(#[source] crate::spool::SpoolError),
    #[error("fetching the mesh: {0}")]
    Decode(#[source] MeshError),
    #[error("the mesh from {url} has content hash {actual}, not {expected}")]
    HashMismatch { url: String, expected: String, actual: String },
    #[error("writing the mesh as {format}: {message}")]
    Write { format: &'static str, message: String },
}

/// Why an output mesh could not be packed as its full blob.
#[derive(Debug, thiserror::Error)]
pub enum PackOutputError {
    #[error("packing {name}: {source}")]
    Pack {
        name: String,
        #[source]
        source: PackError,
    },
    #[error(transparent)]
    Blob(#[from] BlobError),
    #[error("background task failed: {0}")]
    Task(#[from] tokio::task::JoinError),
}

/// The mesh a conversion writes: its content hash, where to fetch it if this host does not
/// hold it, and the grid a fetched mesh is snapped onto before its hash is checked.
pub struct Source<'a> {
    pub hash: &'a str,
    pub from: Option<&'a str>,
    pub grid: Option<Grid>,
}

/// Where this host holds meshes: its blobs (recent outputs in memory, packed ones on disk)
/// and its sessions' current meshes.
#[derive(Clone, Copy)]
pub struct Held<'a> {
    pub blobs: &'a BlobStore,
    pub sessions: &'a Sessions,
}

impl Held<'_> {
    /// The mesh with content hash `hash` decoded in memory here: a recent output or a
    /// session's.
    fn in_memory(self, hash: &str) -> Option<Arc<MeshData>> {
        let name = meshes::full_mesh_name(hash);
        self.blobs.recent(&name).or_else(|| self.sessions.mesh_with_hash(hash))
    }

    /// The mesh behind a full-mesh blob name that is not packed yet: a recent output or a
    /// session's current mesh.
    pub fn unpacked_output(self, name: &str) -> Option<Arc<MeshData>> {
        let hash = name.strip_suffix(&format!(".{PACKED}"))?;
        self.blobs.recent(name).or_else(|| self.sessions.mesh_with_hash(hash))
    }

    /// This host's packed blob of mesh `hash`, if its header states that hash.
    async fn stored_packed(self, hash: &str) -> Option<Vec<u8>> {
        let packed = self.blobs.read(&meshes::full_mesh_name(hash)).await.ok()?;
        let stated = pack::stated_hash(&packed).ok()?;
        (stated.to_hex() == hash).then_some(packed)
    }

    /// The mesh with content hash `hash` if this host has it: in memory, or packed in its
    /// blob store, decoded (which checks the hash) here.
    async fn mesh(self, hash: &str) -> Option<(Arc<MeshData>, Option<Vec<u8>>)> {
        if let Some(mesh) = self.in_memory(hash) {
            return Some((mesh, None));
        }
        let packed = self.stored_packed(hash).await?;
        let decoded = tokio::task::spawn_blocking(move || {
            let mesh = pack::decode(&packed).ok()?;
            Some((Arc::new(mesh), Some(packed)))
        });
        decoded.await.ok().flatten()
    }
}

/// Meshes being written in a file format: at most [`MAX_CONCURRENT_CONVERSIONS`] at once.
pub struct Conversions {
    slots: Semaphore,
}

impl Default for Conversions {
    fn default() -> Self {
        Self { slots: Semaphore::new(MAX_CONCURRENT_CONVERSIONS) }
    }
}

impl Conversions {
    /// Mesh `source.hash` as `format`: from what this host `held`s, else downloaded from
    /// `source.from` within `scope`.
    pub async fn convert(
        &self,
        held: Held<'_>,
        downloads: &Downloads,
        source: Source<'_>,
        scope: &FetchScope,
        format: MeshFileFormat,
    ) -> Result<Vec<u8>, ConvertError> {
        let Source { hash, from, grid } = source;
        // The packed blob as stored, not packed again (a run's result is packed as the run
        // ends): its sealed header states the hash, which every reader's decode holds it to.
        if format == MeshFileFormat::Mfm
            && let Some(packed) = held.stored_packed(hash).await
        {
            return Ok(packed);
        }
        // No slot is held over a download: a slow source must not stall other conversions.
        let on_disk = held.blobs.path(&meshes::full_mesh_name(hash)).exists();
        let fetched = match from {
            Some(url) if !on_disk && held.in_memory(hash).is_none() => {
                Some((url, downloads.get(url, scope).await))
            }
            _ => None,
        };
        // A slot before decoding and writing: memory stays bounded by the slots.
        let _slot = self.slots.acquire().await.expect("the semaphore is never closed");
        let (mesh, packed) = match fetched {
            Some((url, bytes)) => {
                let bytes = bytes.map_err(ConvertError::Download)?;
                let fetched =
                    meshes::decode_hashed(url, bytes).await.map_err(ConvertError::Decode)?;
                let (mesh, actual, packed) = match grid {
                    // Snapped, it is no longer the mesh its packed bytes hold.
                    Some(grid) => {
                        let (mesh, hash) = snapped(fetched.mesh.mesh, grid).await;
                        (mesh, hash, None)
                    }
                    None => {
                        let packed = fetched.encoding == MeshEncoding::Packed;
                        (fetched.mesh.mesh, fetched.mesh.hash, packed.then_some(fetched.bytes))
                    }
                };
                if actual != hash {
                    let (url, expected) = (url.to_owned(), hash.to_owned());
                    return Err(ConvertError::HashMismatch { url, expected, actual });
                }
                (mesh, packed)
            }
            None => held.mesh(hash).await.ok_or_else(|| ConvertError::NotHeld(hash.to_owned()))?,
        };
        tokio::task::spawn_blocking(move || write(&mesh, packed, format))
            .await
            .expect("writing a mesh does not panic")
    }
}

/// Packs an output mesh and stores it as its full blob `name`.
pub async fn pack_output(
    blobs: &BlobStore,
    name: &str,
    mesh: Arc<MeshData>,
) -> Result<(), PackOutputError> {
    let _turn = blobs.packing(name).await;
    if blobs.path(name).exists() {
        return Ok(());
    }
    let packed = tokio::task::spawn_blocking(move || pack::encode(&mesh))
        .await?
        .map_err(|source| PackOutputError::Pack { name: name.to_owned(), source })?;
    // No session record names a packed output: nothing to hold against eviction.
    drop(blobs.put(name, Arc::new(packed)).await?);
    Ok(())
}

/// `mesh` on `grid`, with its content hash.
async fn snapped(mesh: Arc<MeshData>, grid: Grid) -> (Arc<MeshData>, String) {
    tokio::task::spawn_blocking(move || {
        let mut mesh = Arc::unwrap_or_clone(mesh);
        grid.snap_all(&mut mesh.positions);
        let hash = mesh.content_hash().to_hex();
        (Arc::new(mesh), hash)
    })
    .await
    .expect("snapping a mesh does not panic")
}

/// `mesh` written as `format`; `packed` is its packed form when it came packed.
fn write(
    mesh: &MeshData,
    packed: Option<Vec<u8>>,
    format: MeshFileFormat,
) -> Result<Vec<u8>, ConvertError> {
    let failed = |message: String| ConvertError::Write { format: format.extension(), message };
    let file = |format: Format| {
        let mut bytes = Vec::new();
        io::write_to(&mut bytes, mesh, format).map_err(|e| failed(e.to_string()))?;
        Ok(bytes)
    };
    match format {
        MeshFileFormat::Ply => file(Format::Ply),
        MeshFileFormat::Obj => file(Format::Obj),
        MeshFileFormat::Off => file(Format::Off),
        MeshFileFormat::Stl => file(Format::Stl),
        MeshFileFormat::Mfm => match packed {
            Some(packed) => Ok(packed),
            None => pack::encode(mesh).map_err(|e| failed(e.to_string())),
        },
        MeshFileFormat::Raw => Ok(raw(mesh)),
    }
}

/// `mesh` in the `raw` format ([`raw_mesh`]).
pub fn raw(mesh: &MeshData) -> Vec<u8> {
    let arrays = 4 * (mesh.positions.len() + mesh.triangles.len());
    let mut bytes = Vec::with_capacity(raw_mesh::HEADER_BYTES + arrays);
    bytes.extend_from_slice(raw_mesh::MAGIC);
    bytes.extend_from_slice(&(mesh.vertex_count() as u32).to_le_bytes());
    bytes.extend_from_slice(&(mesh.triangle_count() as u32).to_le_bytes());
    bytes.extend_from_slice(&as_le_bytes_f32(&mesh.positions));
    bytes.extend_from_slice(&as_le_bytes_u32(&mesh.triangles));
    if !mesh.attributes.is_empty() {
        write_canonical(&mesh.attributes, &mut |more| bytes.extend_from_slice(more));
    }
    bytes
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> MeshData {
        let positions = vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.5, 0.0, 1.0, -0.25];
        MeshData::new(positions, vec![0, 1, 2, 0, 2, 3])
    }

    #[test]
    fn a_raw_mesh_has_the_content_hash_of_the_mesh_it_holds() {
        let mesh = square();
        let raw = raw(&mesh);
        assert_eq!(raw_mesh::counts(&raw), Ok((4, 2)));
        assert_eq!(raw_mesh::content_hash(&raw).unwrap(), mesh.content_hash().to_hex());

        let mut coloured = square();
        let colours = vec![255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 9, 9, 9, 128];
        let attribute = meshflow_mesh::attributes::Attribute::color(colours);
        coloured.attributes.insert(attribute, 4, 2).unwrap();
        let raw = super::raw(&coloured);
        assert_eq!(raw_mesh::counts(&raw), Ok((4, 2)));
        assert_eq!(raw_mesh::content_hash(&raw).unwrap(), coloured.content_hash().to_hex());
        assert_ne!(coloured.content_hash(), mesh.content_hash());
    }

    #[test]
    fn every_format_reads_back_as_the_same_mesh() {
        let mesh = square();
        for format in MeshFileFormat::ALL {
            let bytes = write(&mesh, None, format).unwrap();
            let back = match format {
                MeshFileFormat::Raw => {
                    assert_eq!(
                        raw_mesh::content_hash(&bytes).unwrap(),
                        mesh.content_hash().to_hex()
                    );
                    continue;
                }
                MeshFileFormat::Mfm => pack::decode(&bytes).unwrap(),
                other => {
                    let format = Format::from_name(other.extension()).unwrap();
                    io::load_bytes(&bytes, format, "x").unwrap()
                }
            };
            assert_eq!(back.content_hash(), mesh.content_hash(), "{format:?}");
        }
    }
}
