//! `POST /inputs?name=` (an upload, streamed to disk and kept by its digest) and
//! `GET /inputs/{file}` (what hosts fetch).

use std::sync::Arc;

use axum::body::Body;
use axum::extract::{Path, Query, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::{Extension, Json};
use meshflow_api::engine::InputUploaded;
use serde::Deserialize;

use super::error::{ApiError, ApiResult, internal, not_found};
use crate::engine::Engine;
use crate::users::User;

#[derive(Deserialize)]
pub struct InputQuery {
    name: Option<String>,
}

pub async fn upload(
    State(engine): State<Arc<Engine>>,
    Query(query): Query<InputQuery>,
    Extension(user): Extension<User>,
    body: Body,
) -> ApiResult<(StatusCode, Json<InputUploaded>)> {
    let name = query.name.ok_or_else(|| {
        ApiError::bad_request("bad-request", "give the file name, e.g. POST /inputs?name=bunny.ply")
    })?;
    let (url, bytes) = engine.put_input(&name, body.into_data_stream(), &user.name).await?;
    Ok((StatusCode::CREATED, Json(InputUploaded { url, bytes })))
}

/// Streams a stored input (inputs may be gigabytes: never read whole): to hosts (the cluster
/// token, no user) any, to a user their own uploads (an admin: any).
pub async fn download(
    State(engine): State<Arc<Engine>>,
    Path(file): Path<String>,
    user: Option<Extension<User>>,
) -> ApiResult<Response> {
    let path = match user {
        None => engine.inputs.path(&file),
        Some(Extension(user)) => engine.input_of(&file, &user).await,
    };
    let path = path.ok_or_else(|| not_found("input", &file))?;
    let opened = tokio::fs::File::open(&path).await.map_err(internal)?;
    let length = opened.metadata().await.map_err(internal)?.len();
    let body = Body::from_stream(tokio_util::io::ReaderStream::new(opened));
    let headers = [
        (header::CONTENT_TYPE, "application/octet-stream".to_owned()),
        (header::CONTENT_LENGTH, length.to_string()),
    ];
    Ok((headers, body).into_response())
}
