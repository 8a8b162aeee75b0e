//! Errors of mesh loading and saving, and the position type both report.

use std::fmt;
use std::path::PathBuf;

/// Where in a file a problem was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Position {
    /// A 1-based line number, for text formats and text headers.
    Line(usize),
    /// A 0-based byte offset, for binary formats.
    Byte(u64),
}

impl fmt::Display for Position {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Position::Line(line) => write!(f, "line {line}"),
            Position::Byte(offset) => write!(f, "byte {offset}"),
        }
    }
}

/// Why a mesh file could not be loaded.
///
/// The message always starts with the file name, then the position when there is one:
/// `bunny.ply: byte 1234: face 17 uses vertex 5000, but there are only 2503 vertices`.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read at all.
    // The I/O error is said in the message and not also as the source, so a chain of
    // causes (`{:#}`) does not repeat it.
    #[error("{name}: cannot read: {cause}")]
    Io { name: String, cause: std::io::Error },
    /// The file name does not tell which format it has.
    #[error("{name}: unknown mesh format (expected .obj, .ply, .off or .stl)")]
    UnknownFormat { name: String },
    /// The content is not a valid mesh of its format: garbage, truncated, inconsistent
    /// counts, an index out of range, a non-finite coordinate, a face of fewer than 3 corners.
    #[error("{name}: {}{reason}", at_prefix(.at))]
    Invalid { name: String, at: Option<Position>, reason: String },
}

/// Why a mesh could not be saved. A failed save leaves no output file behind.
#[derive(Debug, thiserror::Error)]
pub enum SaveError {
    /// The file name does not tell which format to write.
    #[error("{}: unknown mesh format (expected .obj, .ply, .off or .stl)", .path.display())]
    UnknownFormat { path: PathBuf },
    /// The mesh breaks its own invariants, so the file could not be loaded back.
    #[error("{name}: refusing to save an invalid mesh: {reason}")]
    InvalidMesh { name: String, reason: MeshDefect },
    /// Creating, writing or renaming the file failed.
    #[error("{name}: {action}: {cause}")]
    Io { name: String, action: &'static str, cause: std::io::Error },
}

/// What makes a mesh impossible to save: a file written from it would not load back.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeshDefect {
    #[error("{values} position values is not a whole number of vertices")]
    PartialVertex { values: usize },
    #[error("{corners} corner indices is not a whole number of triangles")]
    PartialTriangle { corners: usize },
    #[error("{vertices} vertices do not fit u32 ids")]
    TooManyVertices { vertices: usize },
    #[error("vertex {vertex} has a non-finite coordinate {value}")]
    NonFinite { vertex: usize, value: f32 },
    #[error("triangle {triangle} uses vertex {vertex}, but there are only {vertices} vertices")]
    VertexOutOfRange { triangle: usize, vertex: u32, vertices: usize },
    #[error("{0}")]
    Attributes(String),
}

fn at_prefix(at: &Option<Position>) -> String {
    at.map(|p| format!("{p}: ")).unwrap_or_default()
}

/// A format reader's error before the file name is known: a position and a reason.
#[derive(Debug)]
pub(crate) struct Invalid {
    pub at: Option<Position>,
    pub reason: String,
}

impl Invalid {
    pub fn at(at: Position, reason: impl Into<String>) -> Self {
        Self { at: Some(at), reason: reason.into() }
    }

    pub fn line(line: usize, reason: impl Into<String>) -> Self {
        Self::at(Position::Line(line), reason)
    }

    pub fn byte(offset: usize, reason: impl Into<String>) -> Self {
        Self::at(Position::Byte(offset as u64), reason)
    }

    /// An error about the file as a whole (e.g. its size).
    pub fn whole(reason: impl Into<String>) -> Self {
        Self { at: None, reason: reason.into() }
    }

    /// Prefixes the reason with what was being read, e.g. `vertex 17`.
    pub fn context(mut self, what: impl std::fmt::Display) -> Self {
        self.reason = format!("{what}: {}", self.reason);
        self
    }

    pub fn named(self, name: &str) -> LoadError {
        LoadError::Invalid { name: name.to_owned(), at: self.at, reason: self.reason }
    }
}

/// Result of the format readers.
pub(crate) type ReadResult<T> = Result<T, Invalid>;
