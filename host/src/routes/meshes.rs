//! `POST /meshes/convert`: a mesh this host holds or fetches, written in a file format.

use std::sync::Arc;

use axum::extract::State;
use axum::http::header;
use axum::response::{IntoResponse, Response};

use super::error::{ApiError, ApiJson};
use crate::conversions::{self, Held};
use crate::meshes;
use crate::state::Host;
use meshflow_api::host::{ConvertMesh, Vouched};
use meshflow_codec::quantize::Grid;

/// `POST /meshes/convert`.
pub async fn convert(
    State(host): State<Arc<Host>>,
    ApiJson(Vouched { body: request, peers }): ApiJson<Vouched<ConvertMesh>>,
) -> Result<Response, ApiError> {
    if !meshes::is_blob_name(&meshes::full_mesh_name(&request.hash)) {
        return Err(ApiError::bad_request("bad-hash", "hash: 64 lower-case hex digits"));
    }
    let from = match &request.from {
        Some(url) => Some(super::allowed_url(&host, url, &peers)?),
        None => None,
    };
    let grid = match request.grid {
        Some(exponents) => Some(Grid::from_exponents(exponents).ok_or_else(|| {
            ApiError::bad_request(
                "bad-grid",
                format!("grid exponents {exponents:?} are out of range"),
            )
        })?),
        None => None,
    };
    let scope = host.downloads.scope(&peers)?;
    let source = conversions::Source { hash: &request.hash, from: from.as_deref(), grid };
    let held = Held { blobs: &host.blobs, sessions: &host.sessions };
    let bytes =
        host.conversions.convert(held, &host.downloads, source, &scope, request.format).await?;
    let headers = [(header::CONTENT_TYPE, "application/octet-stream")];
    Ok((headers, bytes).into_response())
}
