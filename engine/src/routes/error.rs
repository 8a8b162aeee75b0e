//! The engine API's errors: the servers' one envelope ([`ApiError`]: an HTTP status with a
//! kebab-case code and a human message, sent as `{"error": {"code", "message"}}`, a 429 also
//! saying when to come back). Every refusal of a route is made here, from the error that
//! caused it.

use axum::extract::rejection::BytesRejection;
use axum::http::StatusCode;

use crate::downloads::DownloadError;
use crate::engine::SubmitError;
use crate::inputs::InputError;
use crate::limits::RETRY_AFTER;
use crate::registry::RegisterError;
use crate::workflow::WorkflowError;

pub use meshflow_api::server::ApiError;

pub type ApiResult<T> = Result<T, ApiError>;

/// 404 `not-found`: `no {what} "{id}"`.
pub fn not_found(what: &str, id: &str) -> ApiError {
    ApiError::new(StatusCode::NOT_FOUND, "not-found", format!("no {what} \"{id}\""))
}

/// A failure of the engine itself, logged.
pub fn internal(error: impl std::fmt::Display) -> ApiError {
    tracing::error!("{error}");
    ApiError::internal(error)
}

/// A body over its route's limit, or one that broke off (`body.map_err(rejected)?`).
pub fn rejected(rejection: BytesRejection) -> ApiError {
    let status = rejection.status();
    let code = if status == StatusCode::PAYLOAD_TOO_LARGE { "too-large" } else { "bad-body" };
    ApiError::new(status, code, rejection.body_text())
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
            SubmitError::Busy(_) => Self::busy("too-many-runs", e.to_string(), RETRY_AFTER),
            SubmitError::InputRefused(_) => Self::bad_request("input-not-allowed", e.to_string()),
            SubmitError::Store(error) => internal(error),
            SubmitError::NotRerunnable(_) => Self::conflict("not-rerunnable", e.to_string()),
            SubmitError::NotYourInput(_) => {
                Self::new(StatusCode::NOT_FOUND, "not-found", e.to_string())
            }
            SubmitError::TooManyBatches(_) => {
                Self::busy("too-many-batches", e.to_string(), RETRY_AFTER)
            }
        }
    }
}

impl From<RegisterError> for ApiError {
    fn from(e: RegisterError) -> Self {
        match e {
            RegisterError::BadUrl(_) => Self::bad_request("bad-url", e.to_string()),
            RegisterError::Full => Self::conflict("too-many-hosts", e.to_string()),
            RegisterError::Store(error) => internal(error),
        }
    }
}

impl From<InputError> for ApiError {
    fn from(e: InputError) -> Self {
        match e {
            InputError::TooLarge(_) => {
                Self::new(StatusCode::PAYLOAD_TOO_LARGE, "too-large", e.to_string())
            }
            InputError::Io(error) => internal(error),
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
            E::Fetch { .. } | E::UnknownHost(_) | E::Corrupt { .. } | E::Spool { .. } => {
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
