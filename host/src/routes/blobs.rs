//! `GET` and `HEAD /blobs/{name}`: a stored blob, or an output mesh packed on first request.

use std::sync::Arc;

use axum::body::Body;
use axum::extract::{Path, State};
use axum::http::{HeaderMap, Method, StatusCode, header};
use axum::response::{IntoResponse, Response};

use super::error::ApiError;
use crate::meshes::{self, PACKED};
use crate::state::Host;
use meshflow_codec::pack;

/// `GET` and `HEAD /blobs/{name}`.
pub async fn serve(
    State(host): State<Arc<Host>>,
    Path(name): Path<String>,
    method: Method,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    if !meshes::is_blob_name(&name) {
        return Err(ApiError::not_found("blob", &name));
    }
    let etag = format!("\"{name}\"");
    let path = host.blobs.path(&name);
    if !path.exists() {
        pack_full_mesh(&host, &name).await?;
    }
    let file = match tokio::fs::File::open(&path).await {
        Ok(file) => file,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(ApiError::not_found("blob", &name));
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

/// Makes the full blob of an output mesh this host still holds (a recent output or a
/// session's current mesh); does nothing for any other name.
async fn pack_full_mesh(host: &Host, name: &str) -> Result<(), ApiError> {
    let Some(hash) = name.strip_suffix(&format!(".{PACKED}")) else { return Ok(()) };
    let Some(mesh) = host.blobs.recent(name).or_else(|| host.sessions.mesh_with_hash(hash)) else {
        return Ok(());
    };
    let packed = tokio::task::spawn_blocking(move || pack::encode(&mesh))
        .await?
        .map_err(|e| ApiError::internal(format!("packing {name}: {e}")))?;
    let _writing = host.blobs.writing().await;
    Ok(host.blobs.put(name, Arc::new(packed)).await?)
}
