//! `POST /workflows/validate`: the checks of `POST /runs` without the run.

use std::sync::Arc;

use axum::Json;
use axum::body::Bytes;
use axum::extract::State;
use axum::extract::rejection::BytesRejection;
use serde_json::{Value, json};

use super::error::{ApiResult, rejected};
use super::runs::read_submission;
use crate::engine::Engine;

/// The workbench validates as the user types with the engine's own rules: 200
/// `{"valid": true}` or the same 400 `invalid-workflow` (with the step path) that
/// submitting would give.
pub async fn validate(
    State(engine): State<Arc<Engine>>,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<Json<Value>> {
    let (workflow, _) = read_submission(&body.map_err(rejected)?)?;
    engine.check_workflow(&workflow)?;
    Ok(Json(json!({"valid": true})))
}
