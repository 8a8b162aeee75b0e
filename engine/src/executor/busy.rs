//! A host whose run slots and queue are full answers 429: that is no fault of the host or
//! of the step, so the engine asks again a few times, pausing as the host asks (or longer,
//! doubling), before the task moves to another host.

use std::time::Duration;

use meshflow_api::host::{RunRequest, RunResult};
use meshflow_api::{ClientError, HostClient};

use crate::limits::{BUSY_FIRST_PAUSE, BUSY_MAX_PAUSE, BUSY_RETRIES};

/// Runs `request` on the session, asking again while the host is busy; the answer and the
/// time spent waiting for the host to take it.
pub async fn run_when_free(
    client: &HostClient,
    session: &str,
    request: &RunRequest,
) -> (Result<RunResult, ClientError>, Duration) {
    let mut waited = Duration::ZERO;
    let mut pause = BUSY_FIRST_PAUSE;
    let mut retries = 0;
    loop {
        match client.run(session, request).await {
            Err(ClientError::Busy { retry_after, .. }) if retries < BUSY_RETRIES => {
                let wait = retry_after.unwrap_or_default().max(pause).min(BUSY_MAX_PAUSE);
                tracing::info!(host = client.base_url(), "busy; asking again in {wait:?}");
                tokio::time::sleep(wait).await;
                waited += wait;
                pause = (pause * 2).min(BUSY_MAX_PAUSE);
                retries += 1;
            }
            outcome => return (outcome, waited),
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicUsize, Ordering};

    use axum::http::{StatusCode, header};
    use axum::response::IntoResponse;
    use serde_json::json;

    use super::*;

    /// A host whose run route answers 429 (`Retry-After: 0`) `busy_times` times, then a
    /// check's result; returns its URL and how often it was asked.
    async fn busy_host(busy_times: usize) -> (String, Arc<AtomicUsize>) {
        let asked = Arc::new(AtomicUsize::new(0));
        let counter = asked.clone();
        let route = axum::routing::post(move || {
            let counter = counter.clone();
            async move {
                if counter.fetch_add(1, Ordering::SeqCst) < busy_times {
                    let body = json!({"error": {"code": "busy", "message": "all slots taken"}});
                    let headers = [(header::RETRY_AFTER, "0")];
                    return (StatusCode::TOO_MANY_REQUESTS, headers, axum::Json(body))
                        .into_response();
                }
                axum::Json(json!({"kind": "check", "service": "c", "plugin": "p", "value": true,
                                  "compute_ms": 1.0, "queue_ms": 0.0, "report": ""}))
                .into_response()
            }
        });
        let app = axum::Router::new().route("/sessions/{id}/run", route);
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let url = format!("http://{}", listener.local_addr().unwrap());
        tokio::spawn(async move { axum::serve(listener, app).await });
        (url, asked)
    }

    #[tokio::test]
    async fn a_busy_host_is_asked_again_after_growing_pauses_and_the_wait_is_counted() {
        let (url, asked) = busy_host(2).await;
        let client = HostClient::new(&url);
        let request = RunRequest { service: "c".into(), ..RunRequest::default() };
        let (outcome, waited) = run_when_free(&client, "s", &request).await;
        assert!(matches!(outcome, Ok(RunResult::Check(_))), "{outcome:?}");
        assert_eq!(asked.load(Ordering::SeqCst), 3);
        // `Retry-After: 0` is no reason to ask at once: the pauses were 250 and 500 ms.
        assert!(waited >= BUSY_FIRST_PAUSE * 3, "{waited:?}");
        assert!(waited < Duration::from_secs(2), "{waited:?}");
    }
}
