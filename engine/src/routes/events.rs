//! `GET /runs/{id}/events`: a run's progress as server-sent events.

use std::convert::Infallible;
use std::sync::Arc;

use axum::Extension;
use axum::extract::{Path, State};
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use futures_util::{Stream, StreamExt, stream};
use serde_json::json;
use tokio_stream::wrappers::BroadcastStream;

use super::error::ApiResult;
use super::runs::find;
use crate::engine::Engine;
use crate::record::Status;
use crate::users::User;

/// First the whole record (`record`), then each change (`status`, `broadcast`, `step`,
/// `transfer`, ...); the stream ends once the run has settled (`settled`, after a completed
/// run's `status`; with the `status` of any other end).
pub async fn stream(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
    Extension(user): Extension<User>,
) -> ApiResult<Sse<impl Stream<Item = Result<SseEvent, Infallible>>>> {
    let run = find(&engine, &id, &user)?;
    // Subscribe before taking the snapshot, so no change falls between the two.
    let live = BroadcastStream::new(run.subscribe());
    let snapshot = run.record();
    let finished = snapshot.is_settled();
    let first = stream::once(async move {
        Ok(SseEvent::default().event("record").json_data(&snapshot).expect("a record is JSON"))
    });
    // Each change as it happens, ending after the one that settles the run (at once for a
    // run that had settled). A subscriber that fell behind gets the whole record again.
    let changes = stream::unfold((live, finished), move |(mut live, ended)| {
        let run = run.clone();
        async move {
            if ended {
                return None;
            }
            let (kind, data) = match live.next().await? {
                Ok(event) => (event.kind, event.data),
                Err(_lagged) => ("record", json!(run.record())),
            };
            let last = match kind {
                "status" => serde_json::from_value::<Status>(data["status"].clone())
                    .is_ok_and(|status| status.is_final() && status != Status::Completed),
                "settled" => true,
                "record" => run.is_settled(),
                _ => false,
            };
            let event = SseEvent::default().event(kind).json_data(&data).expect("events are JSON");
            Some((Ok(event), (live, last)))
        }
    });
    Ok(Sse::new(first.chain(changes)).keep_alive(KeepAlive::default()))
}
