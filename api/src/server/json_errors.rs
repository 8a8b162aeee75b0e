//! Every error answer in the documented shape, `{"error": {"code", "message"}}`: axum's own
//! rejections (a body over `DefaultBodyLimit`, a path segment that does not parse, a wrong
//! method) answer plain text; this middleware rewrites them, repeating at most
//! [`MAX_ECHO_BYTES`](crate::params::MAX_ECHO_BYTES) of what they said (which may quote the
//! request).

use axum::extract::Request;
use axum::http::{StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use super::ApiError;

/// How much of a plain-text error body is read to be rewritten.
const READ_BYTES: usize = 4 << 10;

/// `axum::middleware::from_fn(json_errors)`: an error status whose body is not JSON gets
/// the JSON envelope, its text clipped; other answers pass as they are.
pub async fn json_errors(request: Request, next: Next) -> Response {
    let response = next.run(request).await;
    let status = response.status();
    let is_json = response
        .headers()
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.starts_with("application/json"));
    if !(status.is_client_error() || status.is_server_error()) || is_json {
        return response;
    }
    let (parts, body) = response.into_parts();
    let text = match axum::body::to_bytes(body, READ_BYTES).await {
        Ok(bytes) => String::from_utf8_lossy(&bytes).into_owned(),
        Err(_) => String::new(),
    };
    let message = match text.trim() {
        "" => status.canonical_reason().unwrap_or("error").to_owned(),
        text => crate::params::clip(text),
    };
    let mut rewritten = ApiError::new(status, code_of(status), message).into_response();
    for (name, value) in &parts.headers {
        if name != header::CONTENT_TYPE && name != header::CONTENT_LENGTH {
            rewritten.headers_mut().insert(name.clone(), value.clone());
        }
    }
    rewritten
}

fn code_of(status: StatusCode) -> &'static str {
    match status {
        StatusCode::PAYLOAD_TOO_LARGE => "too-large",
        StatusCode::BAD_REQUEST => "bad-request",
        StatusCode::NOT_FOUND => "not-found",
        StatusCode::METHOD_NOT_ALLOWED => "method-not-allowed",
        StatusCode::UNSUPPORTED_MEDIA_TYPE => "unsupported-media-type",
        StatusCode::UNPROCESSABLE_ENTITY => "bad-body",
        StatusCode::REQUEST_TIMEOUT => "timeout",
        s if s.is_server_error() => "internal",
        _ => "error",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::Router;
    use axum::extract::{DefaultBodyLimit, Path};
    use axum::routing::{get, post};

    async fn call(app: Router, method: &str, path: &str, body: Vec<u8>) -> (u16, String) {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let url = format!("http://{}{path}", listener.local_addr().unwrap());
        tokio::spawn(async move { axum::serve(listener, app).await });
        let method = reqwest::Method::from_bytes(method.as_bytes()).unwrap();
        let response = reqwest::Client::new().request(method, url).body(body).send().await.unwrap();
        (response.status().as_u16(), response.text().await.unwrap())
    }

    #[tokio::test]
    async fn rejections_become_the_json_envelope_and_echo_little() {
        let app = Router::new()
            .route("/n/{n}", get(|Path(n): Path<u32>| async move { n.to_string() }))
            .route("/up", post(|_: axum::body::Bytes| async { "ok" }))
            .layer(DefaultBodyLimit::max(10))
            .layer(axum::middleware::from_fn(json_errors));
        let long = "x".repeat(50_000);
        let (status, body) = call(app.clone(), "GET", &format!("/n/{long}"), vec![]).await;
        assert_eq!(status, 400);
        let json: serde_json::Value = serde_json::from_str(&body).unwrap();
        assert_eq!(json["error"]["code"], "bad-request");
        assert!(body.len() < 600, "{}", body.len());
        let (status, body) = call(app.clone(), "POST", "/up", vec![0; 100]).await;
        assert_eq!(status, 413);
        let json: serde_json::Value = serde_json::from_str(&body).unwrap();
        assert_eq!(json["error"]["code"], "too-large");
        let (status, body) = call(app, "GET", "/n/7", vec![]).await;
        assert_eq!((status, body.as_str()), (200, "7"));
    }
}
