//! The engine API's errors: an HTTP status with a kebab-case code and a human message, sent
//! as `{"error": {"code", "message"}}` (a 429 also says when to come back). Every refusal
//! of a route is made here, from the error that caused it.

use axum::Json;
use axum::extract::rejection::BytesRejection;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use meshflow_api::host::{ErrorBody, ErrorDetail};

use crate::downloads::DownloadError;
use crate::engine::SubmitError;
use crate::inputs::InputError;
use crate::limits::RETRY_AFTER;
use crate::registry::RegisterError;
use crate::workflow::WorkflowError;

#[derive(Debug)]
pub struct ApiError {
    pub status: StatusCode,
    pub code: &'static str,
    pub message: String,
}

pub type ApiResult<T> = Result<T, ApiError>;

impl ApiError {
    pub fn new(status: StatusCode, code: &'static str, message: impl Into<String>) -> Self {
        Self { status, code, message: message.into() }
    }

    pub fn bad_request(code: &'static str, message: impl Into<String>) -> Self {
        Self::new(StatusCode::BAD_REQUEST, code, message)
    }

    pub fn not_found(what: &str, id: &str) -> Self {
        Self::new(StatusCode::NOT_FOUND, "not-found", format!("no {what} \"{id}\""))
    }

    pub fn conflict(code: &'static str, message: impl Into<String>) -> Self {
        Self::new(StatusCode::CONFLICT, code, message)
    }

    /// A failure of the engine itself, logged.
    pub fn internal(error: impl std::fmt::Display) -> Self {
        tracing::error!("{error}");
        Self::new(StatusCode::INTERNAL_SERVER_ERROR, "internal", error.to_string())
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body =
            ErrorBody { error: ErrorDetail { code: self.code.to_owned(), message: self.message } };
        let mut response = (self.status, Json(body)).into_response();
        if self.status == StatusCode::TOO_MANY_REQUESTS {
            response.headers_mut().insert(header::RETRY_AFTER, RETRY_AFTER.as_secs().into());
        }
        response
    }
}

/// A body over its route's limit, or one that broke off.
impl From<BytesRejection> for ApiError {
    fn from(rejection: BytesRejection) -> Self {
        let status = rejection.status();
        let code = if status == StatusCode::PAYLOAD_TOO_LARGE { "too-large" } else { "bad-body" };
        Self::new(status, code, rejection.body_text())
    }
}

impl From<WorkflowError> for ApiError {
    fn from(error: WorkflowError) -> Self {
        Self::bad_request("invalid-workflow", error.to_string())
    }
}

/// Why a run (or a batch) was not started.
impl From<SubmitError> for ApiError {
    fn from(e: SubmitError) -> Self {
        match e {
            SubmitError::Invalid(error) => error.into(),
            SubmitError::NoInput => Self::bad_request("no-input", e.to_string()),
            SubmitError::Busy(_) => {
                Self::new(StatusCode::TOO_MANY_REQUESTS, "too-many-runs", e.to_string())
            }
            SubmitError::InputRefused(_) => Self::bad_request("input-not-allowed", e.to_string()),
            SubmitError::Store(error) => Self::internal(error),
            SubmitError::NotRerunnable(_) => Self::conflict("not-rerunnable", e.to_string()),
        }
    }
}

impl From<RegisterError> for ApiError {
    fn from(e: RegisterError) -> Self {
        match e {
            RegisterError::BadUrl(_) => Self::bad_request("bad-url", e.to_string()),
            RegisterError::Full => Self::conflict("too-many-hosts", e.to_string()),
            RegisterError::Store(error) => Self::internal(error),
        }
    }
}

impl From<InputError> for ApiError {
    fn from(e: InputError) -> Self {
        match e {
            InputError::TooLarge(_) => {
                Self::new(StatusCode::PAYLOAD_TOO_LARGE, "too-large", e.to_string())
            }
            InputError::Io(error) => Self::internal(error),
            _ => Self::bad_request("bad-input", e.to_string()),
        }
    }
}

impl From<DownloadError> for ApiError {
    fn from(error: DownloadError) -> Self {
        use DownloadError as E;
        let (status, code) = match &error {
            E::BadFormat(_) => (StatusCode::BAD_REQUEST, "bad-format"),
            E::NotFinished(_) => (StatusCode::CONFLICT, "not-finished"),
            E::NoResult { .. } => (StatusCode::CONFLICT, "run-failed"),
            E::NoStep { .. } | E::NotAFilter { .. } | E::NoInput(_) => {
                (StatusCode::NOT_FOUND, "not-found")
            }
            E::Gone { .. } => (StatusCode::GONE, "gone"),
            E::Fetch { .. } | E::UnknownHost(_) | E::Corrupt { .. } => {
                (StatusCode::BAD_GATEWAY, "download-failed")
            }
            E::NoHost => (StatusCode::SERVICE_UNAVAILABLE, "no-host"),
            E::HashMismatch { .. } => (StatusCode::BAD_GATEWAY, "hash-mismatch"),
        };
        Self::new(status, code, error.to_string())
    }
}

/// What a host answered to a forwarded plugin upload (`POST /plugins`), from `host`.
pub fn host_refused(host: &str, error: meshflow_api::ClientError) -> ApiError {
    match error {
        // The host's 401 is 403 here: a 401 from the engine means its own API token.
        meshflow_api::ClientError::Refused { status: 401, code, message, .. } => ApiError::new(
            StatusCode::FORBIDDEN,
            "host-unauthorized",
            format!("{host} refused the upload token ({code}: {message})"),
        ),
        meshflow_api::ClientError::Refused { status, code, message, .. } => {
            let status = StatusCode::from_u16(status).unwrap_or(StatusCode::BAD_GATEWAY);
            ApiError::new(status, "host-refused", format!("{host} answered {code}: {message}"))
        }
        other => ApiError::new(StatusCode::BAD_GATEWAY, "host-failed", other.to_string()),
    }
}
