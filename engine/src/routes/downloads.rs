//! A run's meshes in the user's format: `GET /runs/{id}/result`, `/input` and
//! `/steps/{index}/output`, each `?format=` (see `crate::downloads`).

use std::sync::Arc;

use axum::Extension;
use axum::extract::{Path, Query, State};
use axum::http::header;
use axum::response::{IntoResponse, Response};
use futures_util::StreamExt;
use meshflow_api::host::MeshFileFormat;
use serde::Deserialize;

use super::error::ApiResult;

/// Names what a downloaded file leaves out of the mesh it was written from.
const NOT_KEPT_HEADER: &str = "x-meshflow-not-kept";
/// A header line stays short whatever the mesh holds.
const MAX_NOT_KEPT_HEADER_CHARS: usize = 2000;
use super::runs::find;
use crate::downloads::{DownloadError, Which};
use crate::engine::Engine;
use crate::record::RunRecord;
use crate::users::User;

#[derive(Deserialize)]
pub struct FormatQuery {
    format: Option<String>,
}

/// `GET /runs/{id}/result[?format=]`: the final mesh, fetched from its host with the cluster
/// token (a user holds none, so a redirect would not do), served only if it is the mesh the
/// record names (its content hash checked), in the asked format (`.mfm` by default).
pub async fn result(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
    Query(query): Query<FormatQuery>,
    Extension(user): Extension<User>,
) -> ApiResult<Response> {
    let record = find(&engine, &id, &user)?.record();
    // `.mfm` unless asked otherwise: the CLI decodes it (and checks it once more).
    mesh(&engine, &record, Which::Result, query.format).await
}

/// `GET /runs/{id}/input?format=`: the run's input, if it was uploaded to this engine.
pub async fn input(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
    Query(query): Query<FormatQuery>,
    Extension(user): Extension<User>,
) -> ApiResult<Response> {
    let record = find(&engine, &id, &user)?.record();
    mesh(&engine, &record, Which::Input, query.format).await
}

/// `GET /runs/{id}/steps/{index}/output?format=`: a filter step's output, while its host
/// still holds it.
pub async fn step_output(
    State(engine): State<Arc<Engine>>,
    Path((id, index)): Path<(String, usize)>,
    Query(query): Query<FormatQuery>,
    Extension(user): Extension<User>,
) -> ApiResult<Response> {
    let record = find(&engine, &id, &user)?.record();
    mesh(&engine, &record, Which::Step(index), query.format).await
}

async fn mesh(
    engine: &Engine,
    record: &RunRecord,
    which: Which,
    format: Option<String>,
) -> ApiResult<Response> {
    let name = format.unwrap_or_else(|| "mfm".into());
    let format = MeshFileFormat::parse(&name)
        .ok_or_else(|| DownloadError::BadFormat(name.chars().take(16).collect()))?;
    let download = engine.download(record, which, format).await?;
    let headers = [
        (header::CONTENT_TYPE, "application/octet-stream".to_owned()),
        (header::CONTENT_DISPOSITION, format!("attachment; filename=\"{}\"", download.file_name)),
        (header::CONTENT_LENGTH, download.bytes.to_string()),
    ];
    // What the mesh carries that this format, as written, leaves out; header-safe text only.
    let not_kept: String = download
        .not_kept
        .join("; ")
        .chars()
        .map(|c| if c.is_ascii_graphic() || c == ' ' { c } else { '?' })
        .take(MAX_NOT_KEPT_HEADER_CHARS)
        .collect();
    let not_kept = (!not_kept.is_empty()).then_some([(NOT_KEPT_HEADER, not_kept)]);
    // Checked already; streamed from its file, which goes once the stream ends.
    let file = tokio::fs::File::open(&download.file).await.map_err(super::error::internal)?;
    let spool = download.file;
    let stream = tokio_util::io::ReaderStream::with_capacity(file, 64 << 10).map(move |chunk| {
        let _kept = &spool;
        chunk
    });
    Ok((headers, not_kept, axum::body::Body::from_stream(stream)).into_response())
}
