//! Mesh files: loading OBJ, PLY (ascii and binary), OFF and STL into a [`MeshData`] with
//! the attributes they carry (colours, normals, quality, texture coordinates, materials,
//! other numbers by name), and saving meshes atomically with every attribute the format
//! can hold; [`unsupported`] names the others before a save leaves them out.
//!
//! Loading keeps raw scans as they are: non-manifold edges, unreferenced vertices and
//! degenerate faces load unchanged, polygons are fan-triangulated. What cannot be a mesh is
//! rejected with a [`LoadError`] naming the file, the line or byte and the reason: garbage
//! or truncated files, an index out of range, a non-finite coordinate, a face of fewer than 3
//! corners, header counts the file cannot hold.
//!
//! This crate must not depend on codecs, the runtime or HTTP; it knows only `meshflow-mesh`.

mod atomic;
mod build;
mod companions;
mod dropped;
mod error;
mod holds;
mod keep;
mod obj;
mod off;
mod ply;
mod stl;
mod text;

use std::fmt;
use std::io::Write;
use std::path::Path;

use meshflow_mesh::MeshData;

pub use atomic::{write_file, write_private_file};
pub use companions::{Companions, copy_companion_files};
pub use dropped::{Dropped, Loaded};
pub use error::{LoadError, MeshDefect, Position, SaveError};
pub use holds::unsupported;

/// A mesh file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// Wavefront OBJ (text).
    Obj,
    /// Stanford PLY (ascii, binary little or big endian).
    Ply,
    /// Object File Format (text).
    Off,
    /// Stereolithography (ascii or binary); has no shared vertices.
    Stl,
}

impl Format {
    /// All formats, in a stable order.
    pub const ALL: [Format; 4] = [Format::Obj, Format::Ply, Format::Off, Format::Stl];

    /// The format named by a file's extension (case-insensitive), if it is a known one.
    pub fn from_path(path: &Path) -> Option<Format> {
        Format::from_name(path.extension()?.to_str()?)
    }

    /// The format with this name or extension, case-insensitive, with or without a leading
    /// dot: `"ply"`, `"PLY"` and `".ply"` all give [`Format::Ply`]. For command lines.
    pub fn from_name(name: &str) -> Option<Format> {
        let name = name.strip_prefix('.').unwrap_or(name);
        Format::ALL.into_iter().find(|f| f.extension().eq_ignore_ascii_case(name))
    }

    /// The format's name as people write it: `PLY`, `OBJ`, `OFF`, `STL`.
    pub fn display_name(self) -> &'static str {
        match self {
            Format::Obj => "OBJ",
            Format::Ply => "PLY",
            Format::Off => "OFF",
            Format::Stl => "STL",
        }
    }

    /// The usual file extension, lower case and without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Obj => "obj",
            Format::Ply => "ply",
            Format::Off => "off",
            Format::Stl => "stl",
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.extension())
    }
}

/// How the PLY writer encodes the body. Other formats ignore it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum PlyEncoding {
    /// Text; readable but large and slow.
    Ascii,
    /// The default: compact, and what nearly every tool reads fastest.
    #[default]
    BinaryLittleEndian,
    BinaryBigEndian,
}

/// Loads a mesh, choosing the format by the file extension.
pub fn load(path: &Path) -> Result<MeshData, LoadError> {
    load_reporting(path).map(|loaded| loaded.mesh)
}

/// Loads a mesh, choosing the format by the file extension, with what the file held that
/// the mesh does not keep (for a warning).
pub fn load_reporting(path: &Path) -> Result<Loaded, LoadError> {
    let name = path.display().to_string();
    let format = Format::from_path(path).ok_or(LoadError::UnknownFormat { name })?;
    load_as_reporting(path, format)
}

/// Loads a mesh in the given format, whatever the file is called.
pub fn load_as(path: &Path, format: Format) -> Result<MeshData, LoadError> {
    load_as_reporting(path, format).map(|loaded| loaded.mesh)
}

/// [`load_as`], with what the file held that the mesh does not keep.
pub fn load_as_reporting(path: &Path, format: Format) -> Result<Loaded, LoadError> {
    let name = path.display().to_string();
    // One read of the whole file: every reader works on a byte slice, which is the fastest
    // way to parse and lets binary readers check counts against the remaining size.
    let bytes = std::fs::read(path).map_err(|cause| LoadError::Io { name: name.clone(), cause })?;
    // The mesh is what the file holds, wherever it lies: an OBJ's libraries are named, and
    // the textures they name are found when the libraries are copied (see
    // `copy_companion_files`), so a mesh loaded from a path hashes as one loaded from bytes.
    load_bytes_reporting(&bytes, format, &name)
}

/// Decodes a mesh held in memory; `name` is what error messages call it.
pub fn load_bytes(bytes: &[u8], format: Format, name: &str) -> Result<MeshData, LoadError> {
    load_bytes_reporting(bytes, format, name).map(|loaded| loaded.mesh)
}

/// [`load_bytes`], with what the bytes held that the mesh does not keep.
pub fn load_bytes_reporting(bytes: &[u8], format: Format, name: &str) -> Result<Loaded, LoadError> {
    let read = match format {
        Format::Obj => obj::read,
        Format::Ply => ply::read,
        Format::Off => off::read,
        Format::Stl => stl::read,
    };
    read(bytes).map_err(|e| e.named(name))
}

/// Saves a mesh, choosing the format by the file extension; PLY is written binary little
/// endian. Attributes the format cannot hold ([`unsupported`]) are left out: check first. Atomic: the data goes to a temporary file in the same directory that is renamed
/// over `path` only when complete, so a failure leaves no partial and no new file.
pub fn save(path: &Path, mesh: &MeshData) -> Result<(), SaveError> {
    let format =
        Format::from_path(path).ok_or_else(|| SaveError::UnknownFormat { path: path.into() })?;
    save_as(path, mesh, format, PlyEncoding::default())
}

/// Saves a mesh in the given format (and PLY encoding), atomically like [`save`].
///
/// STL is lossy: it keeps only the referenced vertices, in the order triangles use them.
pub fn save_as(
    path: &Path,
    mesh: &MeshData,
    format: Format,
    ply_encoding: PlyEncoding,
) -> Result<(), SaveError> {
    let name = path.display().to_string();
    // Checked before the temporary file exists, so a bad mesh touches no file at all.
    validate(mesh).map_err(|reason| SaveError::InvalidMesh { name, reason })?;
    atomic::write_file(path, |out| encode(out, mesh, format, ply_encoding))
}

/// Encodes a mesh into any writer (e.g. a `Vec<u8>`); PLY is binary little endian. Errors
/// name the target `<writer>`.
pub fn write_to<W: Write>(writer: W, mesh: &MeshData, format: Format) -> Result<(), SaveError> {
    write_as(writer, mesh, format, PlyEncoding::default())
}

/// Like [`write_to`], with a choice of PLY encoding.
pub fn write_as<W: Write>(
    writer: W,
    mesh: &MeshData,
    format: Format,
    ply_encoding: PlyEncoding,
) -> Result<(), SaveError> {
    const NAME: &str = "<writer>";
    validate(mesh).map_err(|reason| SaveError::InvalidMesh { name: NAME.to_owned(), reason })?;
    let mut out = std::io::BufWriter::with_capacity(1 << 16, writer);
    encode(&mut out, mesh, format, ply_encoding)
        .and_then(|()| out.flush())
        .map_err(|cause| SaveError::Io { name: NAME.to_owned(), action: "write failed", cause })
}

fn encode(
    out: &mut dyn Write,
    mesh: &MeshData,
    format: Format,
    ply_encoding: PlyEncoding,
) -> std::io::Result<()> {
    match format {
        Format::Obj => obj::write(out, mesh),
        Format::Ply => ply::write(out, mesh, ply_encoding),
        Format::Off => off::write(out, mesh),
        Format::Stl => stl::write(out, mesh),
    }
}

/// The invariants a written file needs to load back: whole vertices and triangles, finite
/// coordinates, indices in range, ids that fit `u32`.
fn validate(mesh: &MeshData) -> Result<(), MeshDefect> {
    if !mesh.positions.len().is_multiple_of(3) {
        return Err(MeshDefect::PartialVertex { values: mesh.positions.len() });
    }
    if !mesh.triangles.len().is_multiple_of(3) {
        return Err(MeshDefect::PartialTriangle { corners: mesh.triangles.len() });
    }
    let vertices = mesh.vertex_count();
    if u32::try_from(vertices).is_err() {
        return Err(MeshDefect::TooManyVertices { vertices });
    }
    if let Some(i) = mesh.positions.iter().position(|c| !c.is_finite()) {
        return Err(MeshDefect::NonFinite { vertex: i / 3, value: mesh.positions[i] });
    }
    if let Some(i) = mesh.triangles.iter().position(|&v| v as usize >= vertices) {
        let (triangle, vertex) = (i / 3, mesh.triangles[i]);
        return Err(MeshDefect::VertexOutOfRange { triangle, vertex, vertices });
    }
    let attributes = &mesh.attributes;
    attributes
        .check(vertices, mesh.triangle_count())
        .map_err(|e| MeshDefect::Attributes(e.to_string()))
}
