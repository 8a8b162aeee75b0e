//! `GET` and `HEAD /blobs/{name}`: a stored blob, an edit log once encoded, or an output mesh
//! packed on first request.

use std::sync::Arc;

use axum::body::Body;
use axum::extract::{Path, State};
use axum::http::{HeaderMap, Method, StatusCode, header};
use axum::response::{IntoResponse, Response};

use super::error::{self, ApiError};
use crate::conversions::{self, Held};
use crate::meshes;
use crate::state::Host;

/// `GET` and `HEAD /blobs/{name}`.
pub async fn serve(
    State(host): State<Arc<Host>>,
    Path(name): Path<String>,
    method: Method,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    if !meshes::is_blob_name(&name) {
        return Err(error::not_found("blob", &name));
    }
    // A step's edit log is written shortly after the step was answered.
    host.edit_logs.wait_for(&name).await;
    let etag = format!("\"{name}\"");
    let path = host.blobs.path(&name);
    let held = Held { blobs: &host.blobs, sessions: &host.sessions };
    if !path.exists()
        && let Some(mesh) = held.unpacked_output(&name)
    {
        // A HEAD asks for headers only: it must not cost a packing, so its answer has no
        // length until someone GETs the mesh.
        if method == Method::HEAD {
            let unknown_length = futures_util::stream::empty::<Result<Vec<u8>, std::io::Error>>();
            let body = Body::from_stream(unknown_length);
            return Ok((StatusCode::OK, [(header::ETAG, etag)], body).into_response());
        }
        conversions::pack_output(&host.blobs, &name, mesh).await?;
    }
    let file = match tokio::fs::File::open(&path).await {
        Ok(file) => file,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(error::not_found("blob", &name));
        }
        Err(e) => return Err(ApiError::internal(format!("blob {name}: {e}"))),
    };
    let unchanged = headers
        .get_all(header::IF_NONE_MATCH)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
        .any(|tag| matches!(tag.trim(), "*") || tag.trim() == etag);
    if unchanged {
        return Ok((StatusCode::NOT_MODIFIED, [(header::ETAG, etag)]).into_response());
    }
    let length = file.metadata().await.map_err(ApiError::internal)?.len();
    let content_headers = [
        (header::ETAG, etag),
        (header::CONTENT_LENGTH, length.to_string()),
        (header::CONTENT_TYPE, "application/octet-stream".to_owned()),
        (header::CACHE_CONTROL, "public, max-age=31536000, immutable".to_owned()),
    ];
    let body = if method == Method::HEAD {
        Body::empty()
    } else {
        Body::from_stream(tokio_util::io::ReaderStream::new(file))
    };
    Ok((content_headers, body).into_response())
}
