//! API errors: an HTTP status with a kebab-case code and a human message, sent as
//! `{"error": {"code", "message"}}`.

use axum::Json;
use axum::http::StatusCode;

use crate::blobs::BlobError;
use crate::config::BUSY_RETRY_AFTER;
use crate::conversions::{ConvertError, PackOutputError};
use crate::downloads::{PeersError, UrlError};
use crate::meshes::MeshError;
use crate::plugins::PluginSetError;
use crate::sessions::SessionError;
use crate::spool::SpoolError;
use crate::steps::StepError;
use meshflow_api::ClientError;
use meshflow_runtime::RunError;

pub use meshflow_api::server::ApiError;

/// No such resource: 404 `not-found`, naming it.
pub fn not_found(what: &str, name: &str) -> ApiError {
    ApiError::new(StatusCode::NOT_FOUND, "not-found", format!("no {what} `{name}`"))
}

fn unprocessable(code: &'static str, message: impl Into<String>) -> ApiError {
    ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, code, message)
}

fn upstream(message: impl Into<String>) -> ApiError {
    ApiError::new(StatusCode::BAD_GATEWAY, "download-failed", message)
}

/// A caller's mistake (unknown service, bad parameters) is 400; a full run queue is 429;
/// anything the plugin did is 422.
fn run_refused(error: RunError) -> ApiError {
    match error {
        RunError::Busy { .. } => ApiError::busy("busy", error.to_string(), BUSY_RETRY_AFTER),
        RunError::UnknownService { .. } => {
            ApiError::bad_request("unknown-service", error.to_string())
        }
        RunError::Params(_) => ApiError::bad_request("bad-params", error.to_string()),
        _ => unprocessable("plugin-failed", error.to_string()),
    }
}

impl From<SessionError> for ApiError {
    fn from(error: SessionError) -> Self {
        let message = error.to_string();
        match error {
            SessionError::NotFound(_) => Self::new(StatusCode::NOT_FOUND, "not-found", message),
            SessionError::Busy(_) => Self::conflict("session-busy", message),
            SessionError::Loading(_) => Self::conflict("not-ready", message),
            SessionError::Failed { .. } => Self::conflict("session-failed", message),
            SessionError::Save { .. } => Self::internal(message),
        }
    }
}

impl From<PluginSetError> for ApiError {
    fn from(error: PluginSetError) -> Self {
        match error {
            PluginSetError::Run(error) => run_refused(error),
            PluginSetError::NotFound(_) | PluginSetError::NotFoundBecause(..) => {
                Self::new(StatusCode::NOT_FOUND, "not-found", error.to_string())
            }
            PluginSetError::NoSuchService { .. } => {
                Self::bad_request("unknown-service", error.to_string())
            }
            PluginSetError::Collides { .. } => {
                Self::new(StatusCode::CONFLICT, "services-taken", error.to_string())
            }
            PluginSetError::Builtin => {
                Self::new(StatusCode::FORBIDDEN, "builtin", error.to_string())
            }
            PluginSetError::Storage(message) => Self::internal(message),
            PluginSetError::Compress(_) => Self::internal(error.to_string()),
            PluginSetError::Invalid(error) => unprocessable("invalid-plugin", error.to_string()),
            PluginSetError::Task(error) => task_failed(error),
        }
    }
}

impl From<BlobError> for ApiError {
    fn from(error: BlobError) -> Self {
        Self::internal(error)
    }
}

/// A peer the request names that is not an origin.
impl From<PeersError> for ApiError {
    fn from(error: PeersError) -> Self {
        Self::bad_request("bad-peers", error.to_string())
    }
}

/// A URL the request names for this host to fetch.
impl From<UrlError> for ApiError {
    fn from(error: UrlError) -> Self {
        match error {
            UrlError::TooLong | UrlError::NotAUrl(_) => {
                Self::bad_request("bad-url", error.to_string())
            }
            UrlError::Peers(error) => error.into(),
            UrlError::NotAllowed(_) => Self::bad_request("url-not-allowed", error.to_string()),
        }
    }
}

/// Mesh bytes a request pointed to that are no mesh (422); a failed decoding task is ours.
impl From<MeshError> for ApiError {
    fn from(error: MeshError) -> Self {
        match error {
            MeshError::Task(error) => task_failed(error),
            _ => unprocessable("bad-mesh", error.to_string()),
        }
    }
}

impl From<StepError> for ApiError {
    fn from(error: StepError) -> Self {
        match error {
            StepError::Peers(error) => error.into(),
            StepError::Session(error) => error.into(),
            StepError::Plugins(error) => error.into(),
            StepError::Params(error) => Self::bad_request("bad-params", error.to_string()),
            StepError::Run(error) => run_refused(error),
            StepError::Download(error) => download_failed(error),
            StepError::Mesh(error) => error.into(),
            StepError::HashMismatch { .. } => unprocessable("hash-mismatch", error.to_string()),
            StepError::Blob(error) => error.into(),
            StepError::Task(error) => task_failed(error),
            StepError::SessionHash(_) | StepError::Snap(_) | StepError::Name(_) => {
                Self::internal(error)
            }
        }
    }
}

/// A mesh this host does not hold is 404; a source that fails or serves another mesh, 502.
impl From<ConvertError> for ApiError {
    fn from(error: ConvertError) -> Self {
        let message = error.to_string();
        match error {
            ConvertError::NotHeld(_) => Self::new(StatusCode::NOT_FOUND, "not-found", message),
            ConvertError::Download(_) | ConvertError::Decode(_) => upstream(message),
            ConvertError::HashMismatch { .. } => {
                Self::new(StatusCode::BAD_GATEWAY, "hash-mismatch", message)
            }
            ConvertError::Write { .. } => Self::internal(message),
        }
    }
}

impl From<PackOutputError> for ApiError {
    fn from(error: PackOutputError) -> Self {
        Self::internal(error)
    }
}

/// A download a request pointed to: a URL the fetch rules refuse is the request's fault
/// (403); any other failure is the source's (502).
fn download_failed(error: SpoolError) -> ApiError {
    match error {
        SpoolError::Fetch(ClientError::NotAllowed(refusal)) => {
            ApiError::new(StatusCode::FORBIDDEN, "url-not-allowed", refusal.to_string())
        }
        SpoolError::Cancelled { .. } => ApiError::conflict("cancelled", error.to_string()),
        _ => upstream(error.to_string()),
    }
}

/// A blocking task that panicked or was cancelled.
fn task_failed(error: tokio::task::JoinError) -> ApiError {
    ApiError::internal(format!("background task failed: {error}"))
}

/// `axum::Json` whose rejection (malformed or mistyped JSON) is an [`ApiError`].
pub struct ApiJson<T>(pub T);

impl<S: Send + Sync, T: serde::de::DeserializeOwned> axum::extract::FromRequest<S> for ApiJson<T> {
    type Rejection = ApiError;

    async fn from_request(request: axum::extract::Request, state: &S) -> Result<Self, ApiError> {
        Json::<T>::from_request(request, state).await.map(|Json(value)| ApiJson(value)).map_err(
            |rejection| match rejection.status() {
                // Over the body limit: 413, as the documented shape says.
                StatusCode::PAYLOAD_TOO_LARGE => {
                    ApiError::new(StatusCode::PAYLOAD_TOO_LARGE, "too-large", rejection.body_text())
                }
                _ => ApiError::bad_request(
                    "bad-json",
                    meshflow_api::params::clip(&rejection.body_text()),
                ),
            },
        )
    }
}
