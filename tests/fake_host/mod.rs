//! A host that lies: it speaks enough of the host API for an engine to plan on it and send
//! it steps, but never touches a mesh. It claims whatever session and run answers a test
//! scripts, serves the blobs it is given (also as the meshes it is asked to write), and counts
//! the runs it is asked for.

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use axum::extract::{Path, State};
use axum::http::StatusCode;
use axum::routing::{get, post};
use axum::{Json, Router};
use serde_json::{Value as Json_, json};
use tokio::net::TcpListener;

/// What the fake claims.
pub struct Script {
    /// `GET /services`: copied from a real host, so the fake offers what it offers.
    pub services: Json_,
    /// The content hash and counts every session claims to hold once "loaded".
    pub session: (String, usize, usize),
    /// The answer to every `POST /sessions/{id}/run`.
    pub run: Json_,
    /// Served as `/blobs/{name}`, and `{hash}.{format}` as the answer to
    /// `POST /meshes/convert`.
    pub blobs: HashMap<String, Vec<u8>>,
}

pub struct FakeHost {
    pub url: String,
    /// `POST /sessions/{id}/run` requests so far.
    pub runs: Arc<AtomicUsize>,
}

struct Shared {
    script: Script,
    runs: Arc<AtomicUsize>,
}

impl FakeHost {
    /// Serves the script `write` makes knowing the fake's own base URL.
    pub async fn start(write: impl FnOnce(&str) -> Script) -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let url = format!("http://{}", listener.local_addr().unwrap());
        let runs = Arc::new(AtomicUsize::new(0));
        let shared = Arc::new(Shared { script: write(&url), runs: runs.clone() });
        let app = Router::new()
            .route("/health", get(|| async { Json(health()) }))
            .route(
                "/services",
                get(|State(s): State<Arc<Shared>>| async move { Json(s.script.services.clone()) }),
            )
            .route(
                "/sessions",
                post(|| async {
                    (StatusCode::CREATED, Json(json!({"id": "s-1", "state": "loading"})))
                }),
            )
            .route("/sessions/{id}", get(session).delete(|| async { StatusCode::NO_CONTENT }))
            .route("/sessions/{id}/run", post(run))
            .route("/blobs/{name}", get(blob))
            .route("/meshes/convert", post(convert))
            .with_state(shared);
        tokio::spawn(async move { axum::serve(listener, app).await });
        Self { url, runs }
    }

    pub fn runs(&self) -> usize {
        self.runs.load(Ordering::SeqCst)
    }
}

fn health() -> Json_ {
    json!({"status": "ok", "version": "fake", "running": 0, "sessions": 0})
}

async fn session(State(shared): State<Arc<Shared>>, Path(id): Path<String>) -> Json<Json_> {
    let (hash, vertices, triangles) = &shared.script.session;
    Json(json!({
        "id": id, "state": "ready", "hash": hash, "vertices": vertices, "triangles": triangles,
        "error": null, "download_ms": 1.0, "load_ms": 1.0, "input_bytes": 1000
    }))
}

async fn run(State(shared): State<Arc<Shared>>) -> Json<Json_> {
    shared.runs.fetch_add(1, Ordering::SeqCst);
    Json(shared.script.run.clone())
}

async fn blob(
    State(shared): State<Arc<Shared>>,
    Path(name): Path<String>,
) -> Result<Vec<u8>, StatusCode> {
    shared.script.blobs.get(&name).cloned().ok_or(StatusCode::NOT_FOUND)
}

async fn convert(
    State(shared): State<Arc<Shared>>,
    Json(request): Json<Json_>,
) -> Result<Vec<u8>, StatusCode> {
    let name = format!(
        "{}.{}",
        request["hash"].as_str().unwrap_or(""),
        request["format"].as_str().unwrap_or("")
    );
    shared.script.blobs.get(&name).cloned().ok_or(StatusCode::NOT_FOUND)
}
