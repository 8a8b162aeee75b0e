//! The error a service returns: a message the host shows to the user.

use crate::bindings::meshflow::geometry::types::{EditError, EditErrorKind};

/// Why a service failed. Edits refused by the host convert into it, so `?` works on them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error(pub String);

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Error {}

impl From<String> for Error {
    fn from(message: String) -> Self {
        Error(message)
    }
}

impl From<&str> for Error {
    fn from(message: &str) -> Self {
        Error(message.to_owned())
    }
}

impl From<EditError> for Error {
    fn from(e: EditError) -> Self {
        let kind = match e.kind {
            EditErrorKind::InvalidVertex => "invalid vertex",
            EditErrorKind::InvalidTriangle => "invalid triangle",
            EditErrorKind::InvalidEdge => "invalid edge",
            EditErrorKind::RepeatedVertex => "repeated vertex",
            EditErrorKind::InvalidArgument => "invalid argument",
            EditErrorKind::NotApplicable => "not applicable",
            EditErrorKind::ReadOnly => "read-only mesh",
        };
        Error(format!("edit refused ({kind}): {}", e.message))
    }
}
