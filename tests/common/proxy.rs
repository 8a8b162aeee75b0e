//! A reverse proxy in front of a real in-process host, forwarding everything and
//! misbehaving as told: altering a filter's announced result, accusing honest receivers,
//! or answering slowly.

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use axum::Router;
use axum::body::Body;
use axum::extract::{Request, State};
use axum::http::{Method, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde_json::{Value as Json, json};
use tokio::net::TcpListener;

/// What the proxy does besides forwarding.
#[derive(Clone, Default)]
pub struct Lies {
    /// Announce this mesh (hash, packed bytes) as every filter's result, and serve it.
    pub result: Option<(String, Vec<u8>)>,
    /// Answer every update with 502 `hash-mismatch`.
    pub accuse: bool,
    /// Say a session is ready (`?wait=ready`) only this much later: a host on a slow link.
    pub slow_ready: Option<Duration>,
}

pub struct Proxy {
    real: String,
    me: String,
    lies: Lies,
    http: reqwest::Client,
    /// Downloads of the fake result.
    pub served_fake: AtomicUsize,
}

pub async fn start_proxy(real: &str, lies: Lies) -> (String, Arc<Proxy>) {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let me = format!("http://{}", listener.local_addr().unwrap());
    let proxy = Arc::new(Proxy {
        real: real.to_owned(),
        me: me.clone(),
        lies,
        http: reqwest::Client::new(),
        served_fake: AtomicUsize::new(0),
    });
    let app = Router::new().fallback(forward).with_state(proxy.clone());
    tokio::spawn(async move { axum::serve(listener, app).await });
    (me, proxy)
}

async fn forward(State(proxy): State<Arc<Proxy>>, request: Request) -> Response {
    let path = request.uri().path_and_query().map(|p| p.as_str().to_owned()).unwrap_or_default();
    let method = request.method().clone();
    if let Some(delay) = proxy.lies.slow_ready
        && method == Method::GET
        && path.ends_with("?wait=ready")
    {
        tokio::time::sleep(delay).await;
    }
    if proxy.lies.accuse && method == Method::POST && path.ends_with("/update") {
        let error = json!({"error": {"code": "hash-mismatch", "message": "the mesh is not the announced one"}});
        return (StatusCode::BAD_GATEWAY, axum::Json(error)).into_response();
    }
    if let Some((hash, bytes)) = &proxy.lies.result
        && path == format!("/blobs/{hash}.mfm")
    {
        proxy.served_fake.fetch_add(1, Ordering::SeqCst);
        return bytes.clone().into_response();
    }
    let headers = request.headers().clone();
    let body = axum::body::to_bytes(request.into_body(), 1 << 30).await.unwrap();
    let mut outgoing = proxy.http.request(method.clone(), format!("{}{path}", proxy.real));
    for name in [header::AUTHORIZATION, header::CONTENT_TYPE] {
        if let Some(value) = headers.get(&name) {
            outgoing = outgoing.header(name, value);
        }
    }
    let Ok(answer) = outgoing.body(body.to_vec()).send().await else {
        return StatusCode::BAD_GATEWAY.into_response();
    };
    let status = answer.status();
    let content_type = answer.headers().get(header::CONTENT_TYPE).cloned();
    let bytes = answer.bytes().await.unwrap_or_default();
    let is_json =
        content_type.as_ref().is_some_and(|t| t.as_bytes().starts_with(b"application/json"));
    let mut body = bytes.to_vec();
    if is_json {
        let text = String::from_utf8_lossy(&bytes).replace(&proxy.real, &proxy.me);
        let mut answer: Json = serde_json::from_str(&text).unwrap_or(Json::Null);
        if let (Some((hash, _)), true) = (&proxy.lies.result, path.ends_with("/run"))
            && answer["kind"] == "filter"
        {
            answer["output_hash"] = json!(hash);
            answer["full"] = json!({"hash": hash, "url": format!("{}/blobs/{hash}.mfm", proxy.me)});
        }
        body = match answer {
            Json::Null => text.into_bytes(),
            answer => serde_json::to_vec(&answer).unwrap(),
        };
    }
    let mut response = Response::new(Body::from(body));
    *response.status_mut() = status;
    if let Some(content_type) = content_type {
        response.headers_mut().insert(header::CONTENT_TYPE, content_type);
    }
    response
}
