//! Why the store refused an edit.

/// The classes of refusal, mirrored one to one by the WIT `edit-error-kind`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EditErrorKind {
    InvalidVertex,
    InvalidTriangle,
    InvalidEdge,
    RepeatedVertex,
    InvalidArgument,
    NotApplicable,
    ReadOnly,
}

/// A refused edit. The store is unchanged by it.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct EditError {
    pub kind: EditErrorKind,
    pub message: String,
}

impl EditError {
    pub fn new(kind: EditErrorKind, message: impl Into<String>) -> Self {
        Self { kind, message: message.into() }
    }

    pub(crate) fn argument(message: impl Into<String>) -> Self {
        Self::new(EditErrorKind::InvalidArgument, message)
    }

    pub(crate) fn not_applicable(message: impl Into<String>) -> Self {
        Self::new(EditErrorKind::NotApplicable, message)
    }
}
