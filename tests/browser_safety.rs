//! Browser safety without tokens (issue 36, DESIGN §11): a tokenless engine on loopback
//! trusts its network, so a page of another site must not use it, neither by a cross-site
//! request that needs no preflight nor through a rebound DNS name; its UI ships a strict
//! CSP. Real HTTP on 127.0.0.1.

mod common;

use reqwest::header::{CONTENT_TYPE, HOST, ORIGIN};
use serde_json::{Value as Json, json};
use tokio::net::TcpListener;

const EVIL: &str = "http://evil.example";

async fn tokenless_engine(dir: &std::path::Path) -> meshflow_engine::EngineHandle {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let access = meshflow_engine::Access::default();
    meshflow_engine::start(dir.join("engine"), None, &[], access, listener).await.unwrap()
}

async fn answer(request: reqwest::RequestBuilder) -> (u16, Json) {
    let answer = request.send().await.unwrap();
    let status = answer.status().as_u16();
    (status, answer.json().await.unwrap_or(Json::Null))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn pages_of_other_sites_and_rebound_names_cannot_use_a_tokenless_engine() {
    let dir = tempfile::tempdir().unwrap();
    let engine = tokenless_engine(dir.path()).await;
    let url = |path: &str| format!("{}{path}", engine.url);
    let http = reqwest::Client::new();
    let workflow = json!({"workflow": {"steps": [{"run": "is-manifold"}]},
                          "input": "http://127.0.0.1:9/x.ply"});

    // A cross-site form or text/plain fetch needs no preflight: refused before anything runs.
    let cross_site = [
        ("/runs", workflow.to_string()),
        ("/hosts", json!({"url": "http://127.0.0.1:9"}).to_string()),
        ("/inputs?name=a.ply", "ply\n".to_owned()),
        ("/batches", json!({"workflow": workflow["workflow"], "inputs": ["x"]}).to_string()),
    ];
    for (path, body) in cross_site {
        let request =
            http.post(url(path)).header(ORIGIN, EVIL).header(CONTENT_TYPE, "text/plain").body(body);
        let (status, refusal) = answer(request).await;
        assert_eq!((status, &refusal["error"]["code"]), (403, &json!("bad-origin")), "{path}");
    }
    // Fetch metadata without an Origin: still a page of another site.
    let request = http.post(url("/runs/x/cancel")).header("sec-fetch-site", "cross-site");
    assert_eq!(answer(request).await.0, 403);
    let (status, runs) = answer(http.get(url("/runs"))).await;
    assert_eq!((status, runs), (200, json!([])), "no run was made");
    let (_, hosts) = answer(http.get(url("/hosts"))).await;
    assert_eq!(hosts, json!([]), "no host was registered");

    // DNS rebinding: the page's name resolves to 127.0.0.1, its Host header gives it away.
    let (status, refusal) =
        answer(http.get(url("/runs")).header(HOST, "rebind.evil.example")).await;
    assert_eq!((status, &refusal["error"]["code"]), (403, &json!("bad-host")));
    let port = engine.url.rsplit(':').next().unwrap();
    let (status, _) =
        answer(http.get(url("/runs")).header(HOST, format!("localhost:{port}"))).await;
    assert_eq!(status, 200, "localhost is a name the engine answers to");

    // The engine's own page may: JSON to JSON routes, bytes to uploads.
    let own = engine.url.clone();
    let request = http
        .post(url("/runs"))
        .header(ORIGIN, &own)
        .header(CONTENT_TYPE, "application/json")
        .body(workflow.to_string());
    let (status, refusal) = answer(request).await;
    // Read and judged by the engine (no host offers the service), not refused at the door.
    assert_eq!((status, &refusal["error"]["code"]), (400, &json!("invalid-workflow")));
    let request = http.post(url("/inputs?name=a.obj")).header(ORIGIN, &own).body("v 0 0 0\n");
    let (status, uploaded) = answer(request).await;
    assert_eq!(status, 201, "{uploaded}");
    let request = http
        .post(url("/runs"))
        .header(ORIGIN, &own)
        .header(CONTENT_TYPE, "text/plain")
        .body(workflow.to_string());
    assert_eq!(answer(request).await.1["error"]["code"], "not-json");
    // Clients that are not browsers send no Origin and are not affected.
    let (status, _) = answer(http.post(url("/runs")).body(workflow.to_string())).await;
    assert_eq!(status, 400);

    // The UI: a strict CSP, no framing, no sniffing, no referrer.
    let page = http.get(url("/")).send().await.unwrap();
    assert_eq!(page.status(), 200);
    let header = |name: &str| page.headers()[name].to_str().unwrap().to_owned();
    let csp = header("content-security-policy");
    assert!(csp.contains("frame-ancestors 'none'"), "{csp}");
    assert!(csp.contains("script-src 'self'") && !csp.contains("unsafe-inline"), "{csp}");
    assert_eq!(header("x-frame-options"), "DENY");
    assert_eq!(header("x-content-type-options"), "nosniff");
    assert_eq!(header("referrer-policy"), "no-referrer");
    let html = page.text().await.unwrap();
    assert!(!html.contains("<style"), "no inline style: {html}");
    for script in html.split("<script").skip(1) {
        assert!(script.split('>').next().unwrap().contains("src="), "inline script: {html}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn allowed_origins_and_the_public_name_pass() {
    let dir = tempfile::tempdir().unwrap();
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let access = meshflow_engine::Access {
        allow_origins: vec!["https://portal.lab.example".into()],
        ..Default::default()
    };
    let public = Some("http://engine.lab.example".to_owned());
    let data = dir.path().join("engine");
    let engine = meshflow_engine::start(data, public, &[], access, listener).await.unwrap();
    let address = listener_address(&engine);
    let http = reqwest::Client::new();
    let url = |path: &str| format!("http://{address}{path}");
    let (status, _) = answer(http.get(url("/runs")).header(HOST, "engine.lab.example")).await;
    assert_eq!(status, 200);
    let request = http
        .post(url("/inputs?name=a.obj"))
        .header(HOST, "engine.lab.example")
        .header(ORIGIN, "https://portal.lab.example")
        .body("v 0 0 0\n");
    assert_eq!(answer(request).await.0, 201);
    let request = http.post(url("/inputs?name=a.obj")).header(ORIGIN, EVIL).body("v 0 0 0\n");
    assert_eq!(answer(request).await.0, 403);
    // Probes too answer only names the engine answers to.
    let (status, _) = answer(http.get(url("/health")).header(HOST, "engine.monitoring")).await;
    assert_eq!(status, 403);
    assert_eq!(answer(http.get(url("/health"))).await.0, 200);
}

/// Where the engine listens (its public URL names another host).
fn listener_address(engine: &meshflow_engine::EngineHandle) -> String {
    engine.address.to_string()
}
