//! The host HTTP server end to end: real HTTP on 127.0.0.1, hosts on ephemeral ports, each
//! with its own data folder, inputs served by a tiny file server.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use meshflow_api::host::{RunRequest, RunResult, SessionState, Transfer, Update};
use meshflow_api::{ClientError, HostClient};
use meshflow_host::{HostConfig, HostHandle, start};
use meshflow_mesh::MeshData;
use meshflow_meshio as io;
use meshflow_runtime::Limits;
use meshflow_runtime::{Catalog, Runtime};

const TOKEN: &str = "sesame-upload-token";

fn bunny_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data/bunny.obj")
}

fn bunny() -> MeshData {
    io::load(&bunny_path()).unwrap()
}

/// Compiled components shared by every host of every test, as one machine's would be.
fn shared_cache() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("host-components")
}

fn config(data: &Path) -> HostConfig {
    HostConfig {
        builtins: meshflow_builtin_plugins::PLUGINS.iter().map(|p| p.wasm).collect(),
        artefact_cache: Some(shared_cache()),
        ..HostConfig::new(data)
    }
}

async fn start_host(config: HostConfig) -> (HostHandle, HostClient) {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let handle = start(config, listener).await.unwrap();
    let client = HostClient::new(&handle.url);
    (handle, client)
}

/// Serves `files` (name -> bytes) over HTTP; returns the base URL.
async fn serve_files(files: Vec<(&str, Vec<u8>)>) -> String {
    use axum::extract::{Path, State};
    use axum::http::StatusCode;
    let files: Arc<HashMap<String, Vec<u8>>> =
        Arc::new(files.into_iter().map(|(n, b)| (n.to_owned(), b)).collect());
    let app =
        axum::Router::new()
            .route(
                "/{*name}",
                axum::routing::get(
                    |State(files): State<Arc<HashMap<String, Vec<u8>>>>,
                     Path(name): Path<String>| async move {
                        files.get(&name).cloned().ok_or(StatusCode::NOT_FOUND)
                    },
                ),
            )
            .with_state(files);
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let url = format!("http://{}", listener.local_addr().unwrap());
    tokio::spawn(async move { axum::serve(listener, app).await });
    url
}

async fn bunny_url() -> String {
    let base = serve_files(vec![("bunny.obj", std::fs::read(bunny_path()).unwrap())]).await;
    format!("{base}/bunny.obj")
}

async fn ready_session(client: &HostClient, url: &str) -> String {
    let created = client.create_session(url, None).await.unwrap();
    assert_eq!(created.state, SessionState::Loading);
    let status = client.wait_ready(&created.id).await.unwrap();
    assert_eq!(status.state, SessionState::Ready, "{:?}", status.error);
    created.id
}

fn request(service: &str, params: serde_json::Value) -> RunRequest {
    let serde_json::Value::Object(params) = params else { panic!("params must be an object") };
    RunRequest { service: service.into(), params, plugin: None }
}

async fn filter(
    client: &HostClient,
    id: &str,
    service: &str,
    params: serde_json::Value,
) -> meshflow_api::host::FilterResult {
    match client.run(id, &request(service, params)).await.unwrap() {
        RunResult::Filter(result) => result,
        other => panic!("expected a filter result, got {other:?}"),
    }
}

fn api_error(result: Result<impl std::fmt::Debug, ClientError>) -> (u16, String, String) {
    match result.expect_err("the host should refuse") {
        ClientError::Refused { status, code, message, .. }
        | ClientError::Server { status, code, message, .. } => (status, code, message),
        other => panic!("expected an HTTP error, got {other}"),
    }
}

/// The same filter run locally, as `meshflow apply` would.
fn local_filter(
    mesh: &MeshData,
    service: &str,
    params: &[(&str, meshflow_runtime::Value)],
) -> MeshData {
    let runtime = Runtime::new(Limits::default(), Some(&shared_cache())).unwrap();
    let mut catalog = Catalog::new();
    for builtin in meshflow_builtin_plugins::PLUGINS {
        catalog.add(runtime.load(builtin.wasm).unwrap());
    }
    let (plugin, _) = catalog.find(service).unwrap();
    let params: Vec<_> = params.iter().map(|(k, v)| (k.to_string(), v.clone())).collect();
    runtime.run(plugin, service, mesh.clone(), &params).unwrap().mesh.unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn filters_and_checks_run_and_other_hosts_follow_by_correction_or_full_mesh() {
    let dirs = [(); 3].map(|()| tempfile::tempdir().unwrap());
    let (_a, a) = start_host(config(dirs[0].path())).await;
    let (_b, b) = start_host(config(dirs[1].path())).await;
    let (_c, c) = start_host(config(dirs[2].path())).await;
    let url = bunny_url().await;
    let input = bunny();

    let on_a = ready_session(&a, &url).await;
    let status = a.session(&on_a).await.unwrap();
    assert_eq!(status.hash.as_deref(), Some(input.content_hash().to_hex().as_str()));
    assert_eq!((status.vertices, status.triangles), (Some(1839), Some(3674)));
    assert_eq!(status.input_bytes, Some(std::fs::metadata(bunny_path()).unwrap().len()));
    let on_b = ready_session(&b, &url).await;
    let on_c = ready_session(&c, &url).await;
    assert_eq!(a.health().await.unwrap().sessions, 1);

    let step = filter(&a, &on_a, "laplacian-smoothing", serde_json::json!({"iterations": 2})).await;
    let expected = local_filter(
        &input,
        "laplacian-smoothing",
        &[("iterations", meshflow_runtime::Value::Integer(2))],
    );
    assert_eq!(step.input_hash, input.content_hash().to_hex());
    assert_eq!(step.output_hash, expected.content_hash().to_hex());
    assert_eq!((step.vertices, step.edits), (1839, 1839));
    assert_eq!(a.session(&on_a).await.unwrap().hash.as_deref(), Some(step.output_hash.as_str()));
    // The edit log is written after the answer: asked for at once, it is waited for, and it
    // rebuilds the step bit for bit.
    let log = a.download(&step.correction.url).await.unwrap();
    let rebuilt = meshflow_codec::correction::apply(input.clone(), &log).unwrap();
    assert_eq!(rebuilt.content_hash().to_hex(), step.output_hash);
    // It sets every position: a receiver gathers the prediction while it downloads.
    assert!(step.correction.sets_positions && !step.replay.sets_positions);

    let RunResult::Check(check) =
        a.run(&on_a, &request("vertex-count", serde_json::json!({}))).await.unwrap()
    else {
        panic!("vertex-count is a check")
    };
    assert_eq!(check.value, 1839);

    // B replays the correction; C takes the full mesh, packed on first request.
    let update = |use_| Update {
        correction: Some(step.correction.clone()),
        replay: None,
        full: step.full.clone(),
        use_,
    };
    let by_correction = b.update(&on_b, &update(Transfer::Correction)).await.unwrap();
    assert_eq!(by_correction.via, Transfer::Correction);
    assert_eq!(by_correction.fallback, None);
    assert_eq!(by_correction.hash, step.output_hash);
    assert_eq!(by_correction.bytes, log.len() as u64);
    let full = c.update(&on_c, &update(Transfer::Full)).await.unwrap();
    assert_eq!((full.via, full.hash.as_str()), (Transfer::Full, step.output_hash.as_str()));
    assert_eq!(full.bytes, a.blob_size(&step.full.url).await.unwrap());
    assert!(full.bytes > log.len() as u64, "{} vs {}", full.bytes, log.len());
    for (host, id) in [(&b, &on_b), (&c, &on_c)] {
        assert_eq!(
            host.session(id).await.unwrap().hash.as_deref(),
            Some(step.output_hash.as_str())
        );
    }
    // B's next step starts from the same bits as A's would.
    let next_on_b =
        filter(&b, &on_b, "add-noise", serde_json::json!({"amount": 0.5, "seed": 7})).await;
    let next_on_a =
        filter(&a, &on_a, "add-noise", serde_json::json!({"amount": 0.5, "seed": 7})).await;
    assert_eq!(next_on_a.output_hash, next_on_b.output_hash);
    assert_ne!(next_on_a.output_hash, step.output_hash);
    // A smoothing step again: A learned that it sets every position and gathered the
    // prediction while the plugin ran; B gathers it while the log downloads. Same bits.
    let again =
        filter(&a, &on_a, "laplacian-smoothing", serde_json::json!({"iterations": 2})).await;
    let update = Update {
        correction: Some(again.correction.clone()),
        replay: None,
        full: again.full.clone(),
        use_: Transfer::Correction,
    };
    let updated = b.update(&on_b, &update).await.unwrap();
    assert_eq!((updated.via, updated.fallback), (Transfer::Correction, None));
    assert_eq!(updated.hash, again.output_hash);
}

/// A plugin goes to a host that replays its steps compressed when that host accepts zstd
/// (a third of the bytes over a slow link), and `GET /services` says how many bytes that
/// is; a client that does not ask gets the component as it is. Either way the bytes are
/// the component the digest names.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_plugin_is_sent_compressed_to_a_host_that_accepts_zstd() {
    let dir = tempfile::tempdir().unwrap();
    let (handle, host) = start_host(config(dir.path())).await;
    let services = host.services().await.unwrap();
    let smoothing = services.iter().find(|s| s.info.name == "laplacian-smoothing").unwrap();
    let (component, sent) = (smoothing.plugin_bytes.unwrap(), smoothing.plugin_sent_bytes.unwrap());
    let url = format!("{}/plugins/{}/wasm", handle.url, smoothing.plugin);
    let http = reqwest::Client::new();

    let compressed = http.get(&url).header("accept-encoding", "gzip, zstd").send().await.unwrap();
    assert_eq!(compressed.headers()["content-encoding"], "zstd");
    let body = compressed.bytes().await.unwrap();
    assert_eq!(body.len() as u64, sent);
    assert!(sent * 2 < component, "{sent} B sent for a {component} B component");
    let unpacked = zstd::decode_all(&body[..]).unwrap();
    assert_eq!(unpacked.len() as u64, component);
    assert_eq!(meshflow_runtime::digest(&unpacked), smoothing.plugin);

    for accept in [None, Some("gzip"), Some("zstd;q=0")] {
        let mut request = http.get(&url);
        if let Some(accept) = accept {
            request = request.header("accept-encoding", accept);
        }
        let plain = request.send().await.unwrap();
        assert!(plain.headers().get("content-encoding").is_none(), "{accept:?}");
        let body = plain.bytes().await.unwrap();
        assert_eq!(meshflow_runtime::digest(&body), smoothing.plugin, "{accept:?}");
    }
}

/// DESIGN §4: a receiver re-runs the named step in its own sandbox, fetching the plugin it
/// lacks from the producer; a replay that reaches another mesh falls back to the edit log;
/// a restart re-runs it again from the stored plugin.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_replayed_step_reaches_the_same_mesh_and_a_diverging_one_falls_back() {
    let dirs = [(); 2].map(|()| tempfile::tempdir().unwrap());
    let (_a, a) = start_host(config(dirs[0].path())).await;
    // B has no plugins at all: it must fetch the one the step names.
    let bare = HostConfig { builtins: Vec::new(), ..config(dirs[1].path()) };
    let (b_handle, b) = start_host(bare.clone()).await;
    let url = bunny_url().await;
    let (on_a, on_b) = (ready_session(&a, &url).await, ready_session(&b, &url).await);
    let params = serde_json::json!({"iterations": 2, "weights": "cotangent"});
    let step = filter(&a, &on_a, "laplacian-smoothing", params).await;

    // The replay names plugin, service and every parameter, defaults filled in.
    let named =
        meshflow_codec::replay::decode(&a.download(&step.replay.url).await.unwrap()).unwrap();
    assert!(step.replay.bytes <= 300, "{} B", step.replay.bytes);
    assert_eq!(
        (named.plugin_hex(), named.service.as_str()),
        (step.plugin.clone(), "laplacian-smoothing")
    );
    let resolved: serde_json::Value = serde_json::from_str(&named.params).unwrap();
    assert_eq!(
        (resolved["iterations"].clone(), resolved["weights"].clone()),
        (2.into(), "cotangent".into())
    );
    assert!(resolved.as_object().unwrap().len() > 2, "defaults filled in: {resolved}");
    let edit_log = a.blob_size(&step.correction.url).await.unwrap();
    assert!(edit_log > 20 * step.replay.bytes, "{edit_log} B edit log");

    let replay = Update {
        correction: Some(step.correction.clone()),
        replay: Some(step.replay.clone()),
        full: step.full.clone(),
        use_: Transfer::Replay,
    };
    let updated = b.update(&on_b, &replay).await.unwrap();
    assert_eq!((updated.via, updated.fallback.as_deref()), (Transfer::Replay, None));
    assert_eq!(updated.hash, step.output_hash);
    assert_eq!(updated.bytes, step.replay.bytes);
    let fetched = dirs[1].path().join("replay-plugins").join(format!("{}.wasm", step.plugin));
    assert!(fetched.exists(), "the plugin was fetched and kept");
    assert!(b.services().await.unwrap().is_empty(), "a fetched plugin is not offered");

    // A replay naming other parameters reaches another mesh: the edit log is used instead.
    let mut forged = named.clone();
    forged.params = forged.params.replace("\"iterations\":2", "\"iterations\":3");
    assert_ne!(forged.params, named.params);
    let files = serve_files(vec![("forged.mfr", meshflow_codec::replay::encode(&forged))]).await;
    let on_b2 = ready_session(&b, &url).await;
    let mut diverging = replay.clone();
    diverging.replay.as_mut().unwrap().url = format!("{files}/forged.mfr");
    let updated = b.update(&on_b2, &diverging).await.unwrap();
    assert_eq!(
        (updated.via, updated.hash.as_str()),
        (Transfer::Correction, step.output_hash.as_str())
    );
    let reason = updated.fallback.unwrap();
    assert!(reason.contains("replay") && reason.contains("reached mesh"), "{reason}");

    // A producer answering with other bytes than the digest named: nothing is loaded or
    // kept, and the edit log is used, saying why.
    let impostor = serve_files(vec![
        ("step.mfr", a.download(&step.replay.url).await.unwrap()),
        (
            &format!("plugins/{}/wasm", step.plugin),
            meshflow_builtin_plugins::fixture("hostile").to_vec(),
        ),
    ])
    .await;
    let dir_c = tempfile::tempdir().unwrap();
    let (_c, c) = start_host(HostConfig { builtins: Vec::new(), ..config(dir_c.path()) }).await;
    let on_c = ready_session(&c, &url).await;
    let mut impostor_replay = replay.clone();
    impostor_replay.replay.as_mut().unwrap().url = format!("{impostor}/step.mfr");
    let updated = c.update(&on_c, &impostor_replay).await.unwrap();
    assert_eq!(
        (updated.via, updated.hash.as_str()),
        (Transfer::Correction, step.output_hash.as_str())
    );
    let reason = updated.fallback.unwrap();
    assert!(reason.contains("have digest"), "{reason}");
    let kept = dir_c.path().join("replay-plugins");
    assert!(!kept.exists() || std::fs::read_dir(&kept).unwrap().next().is_none());

    // After a restart, B rebuilds its session by re-running the step with the kept plugin,
    // and it tells the engine it restarted.
    let first_life = b.health().await.unwrap().instance;
    b_handle.shutdown().await.unwrap();
    let (_b, b) = start_host(bare).await;
    let status = b.wait_ready(&on_b).await.unwrap();
    assert_eq!(status.hash.as_deref(), Some(step.output_hash.as_str()), "{:?}", status.error);
    let second_life = b.health().await.unwrap().instance;
    assert!(first_life.is_some() && second_life.is_some() && first_life != second_life);
    // A step the engine moves here, pinned to the plugin fetched before the restart, runs
    // from the kept copy; a pin to a plugin never fetched, or no digest, is refused.
    let mut moved = request("laplacian-smoothing", serde_json::json!({"iterations": 1}));
    moved.plugin = Some(step.plugin.clone());
    assert!(matches!(b.run(&on_b, &moved).await.unwrap(), RunResult::Filter(_)));
    for pin in ["0".repeat(64), "../../x".to_owned()] {
        moved.plugin = Some(pin);
        let (status, _, message) = api_error(b.run(&on_b, &moved).await);
        assert_eq!(status, 404, "{message}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn blobs_have_a_length_and_an_etag_that_answers_304() {
    let dir = tempfile::tempdir().unwrap();
    let (_host, client) = start_host(config(dir.path())).await;
    let id = ready_session(&client, &bunny_url().await).await;
    let step = filter(&client, &id, "add-noise", serde_json::json!({"seed": 1})).await;
    let http = reqwest::Client::new();
    // A HEAD of an output not packed yet answers without packing it (nor a length).
    let full_name = step.full.url.rsplit('/').next().unwrap();
    let head = http.head(&step.full.url).send().await.unwrap();
    assert_eq!(head.status(), 200);
    assert!(head.headers().get("content-length").is_none(), "{head:?}");
    assert!(!dir.path().join("blobs").join(full_name).exists(), "a HEAD packed the mesh");
    for url in [&step.correction.url, &step.full.url] {
        let name = url.rsplit('/').next().unwrap();
        let got = http.get(url).send().await.unwrap();
        assert_eq!(got.status(), 200);
        assert_eq!(got.headers()["etag"], format!("\"{name}\"").as_str());
        let length: u64 = got.headers()["content-length"].to_str().unwrap().parse().unwrap();
        assert_eq!(got.bytes().await.unwrap().len() as u64, length);
        let head = http.head(url).send().await.unwrap();
        assert_eq!(head.headers()["content-length"], length.to_string().as_str());
        let cached =
            http.get(url).header("if-none-match", format!("\"{name}\"")).send().await.unwrap();
        assert_eq!(cached.status(), 304);
        let stale = http.get(url).header("if-none-match", "\"other\"").send().await.unwrap();
        assert_eq!(stale.status(), 200);
    }
    let full = client.download(&step.full.url).await.unwrap();
    assert_eq!(
        meshflow_codec::pack::decode(&full).unwrap().content_hash().to_hex(),
        step.output_hash
    );
    let missing = format!("{}/blobs/{}.mfc", client.base_url(), "0".repeat(64));
    assert_eq!(api_error(client.blob_size(&missing).await).0, 404);
    assert_eq!(
        api_error(client.download(&format!("{}/blobs/..%2Fsessions", client.base_url())).await).0,
        404
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn meshes_are_written_in_a_users_format_only_as_the_mesh_their_hash_names() {
    use meshflow_api::host::{ConvertMesh, MeshFileFormat};
    const LIMIT: u64 = 1 << 30;
    let (one, other) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let (_holder, holder) = start_host(config(one.path())).await;
    let (_writer, writer) = start_host(config(other.path())).await;
    let input = bunny_url().await;
    let id = ready_session(&holder, &input).await;
    let step = filter(&holder, &id, "add-noise", serde_json::json!({"seed": 1})).await;
    let hash = step.output_hash.clone();
    let ask = |hash: &str, from: Option<&str>, format| ConvertMesh {
        hash: hash.to_owned(),
        from: from.map(str::to_owned),
        format,
        grid: None,
    };

    // The holder writes the mesh it holds, in every format, as that very mesh.
    let ply = holder.convert(ask(&hash, None, MeshFileFormat::Ply), LIMIT).await.unwrap();
    assert_eq!(io::load_bytes(&ply, io::Format::Ply, "ply").unwrap().content_hash().to_hex(), hash);
    let raw = holder.convert(ask(&hash, None, MeshFileFormat::Raw), LIMIT).await.unwrap();
    assert_eq!(meshflow_api::raw_mesh::content_hash(&raw).unwrap(), hash);
    let mfm = holder.convert(ask(&hash, None, MeshFileFormat::Mfm), LIMIT).await.unwrap();
    assert_eq!(meshflow_codec::pack::decode(&mfm).unwrap().content_hash().to_hex(), hash);

    // A host that does not hold it says so, unless told where to fetch it.
    let (status, code, _) =
        api_error(writer.convert(ask(&hash, None, MeshFileFormat::Obj), LIMIT).await);
    assert_eq!((status, code.as_str()), (404, "not-found"));
    let fetched = ask(&hash, Some(&step.full.url), MeshFileFormat::Obj);
    let obj = writer.convert(fetched, LIMIT).await.unwrap();
    assert_eq!(io::load_bytes(&obj, io::Format::Obj, "obj").unwrap().content_hash().to_hex(), hash);

    // What is fetched must be the mesh the hash names; nonsense is refused before any fetch.
    let (status, code, message) =
        api_error(writer.convert(ask(&hash, Some(&input), MeshFileFormat::Ply), LIMIT).await);
    assert_eq!((status, code.as_str()), (502, "hash-mismatch"), "{message}");
    let (status, code, _) =
        api_error(writer.convert(ask("../x", Some(&input), MeshFileFormat::Ply), LIMIT).await);
    assert_eq!((status, code.as_str()), (400, "bad-hash"));
    let (status, code, _) = api_error(
        writer.convert(ask(&hash, Some("file:///etc/passwd"), MeshFileFormat::Ply), LIMIT).await,
    );
    assert_eq!((status, code.as_str()), (400, "url-not-allowed"));
    // A quantised run's input: its hash names the mesh snapped onto the run's grid, so the
    // fetched file is snapped before it is checked; a grid out of range is refused.
    let mut on_grid = io::load(&bunny_path()).unwrap();
    let exponents = [-10, -12, -9];
    meshflow_codec::quantize::Grid::from_exponents(exponents)
        .unwrap()
        .snap_all(&mut on_grid.positions);
    let snapped_hash = on_grid.content_hash().to_hex();
    let (status, code, _) = api_error(
        writer.convert(ask(&snapped_hash, Some(&input), MeshFileFormat::Ply), LIMIT).await,
    );
    assert_eq!((status, code.as_str()), (502, "hash-mismatch"), "unsnapped, it is another mesh");
    let snapped = ConvertMesh {
        grid: Some(exponents),
        ..ask(&snapped_hash, Some(&input), MeshFileFormat::Ply)
    };
    let ply = writer.convert(snapped.clone(), LIMIT).await.unwrap();
    assert_eq!(io::load_bytes(&ply, io::Format::Ply, "ply").unwrap(), on_grid);
    let off_range = ConvertMesh { grid: Some([-10, 400, -9]), ..snapped };
    let (status, code, _) = api_error(writer.convert(off_range, LIMIT).await);
    assert_eq!((status, code.as_str()), (400, "bad-grid"));
    // A client's limit holds, whatever the host would send.
    let capped = holder.convert(ask(&hash, None, MeshFileFormat::Obj), 1000).await;
    assert!(matches!(capped, Err(ClientError::TooLarge { .. })), "{capped:?}");

    // Once packed, the `.mfm` is the stored blob itself, not packed again.
    let blob = holder.download(&step.full.url).await.unwrap();
    let mfm = holder.convert(ask(&hash, None, MeshFileFormat::Mfm), LIMIT).await.unwrap();
    assert_eq!(mfm, blob);

    // Sources that drip hold no conversion slot: more of them than slots stall nobody else.
    let mut drips = Vec::new();
    for _ in 0..3 {
        let (slow, drip) = dripping_url(Duration::from_secs(40)).await;
        let request = ask(&"0".repeat(64), Some(&slow), MeshFileFormat::Ply);
        let writer = writer.clone();
        drips.push((tokio::spawn(async move { writer.convert(request, LIMIT).await }), drip));
    }
    tokio::time::sleep(Duration::from_millis(500)).await;
    let quick = holder.convert(ask(&hash, None, MeshFileFormat::Raw), LIMIT);
    let quick = tokio::time::timeout(Duration::from_secs(20), quick).await;
    assert!(quick.is_ok_and(|r| r.is_ok()), "a conversion waited for the dripping ones");
    let fetched = ask(&hash, Some(&step.full.url), MeshFileFormat::Off);
    let other = tokio::time::timeout(Duration::from_secs(20), writer.convert(fetched, LIMIT)).await;
    assert!(other.is_ok_and(|r| r.is_ok()), "a conversion waited for the dripping ones");
    for (call, drip) in drips {
        call.abort();
        drip.abort();
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_correction_that_does_not_apply_falls_back_to_the_full_mesh_and_says_why() {
    let dirs = [(); 2].map(|()| tempfile::tempdir().unwrap());
    let (_a, a) = start_host(config(dirs[0].path())).await;
    let (_b, b) = start_host(config(dirs[1].path())).await;
    let url = bunny_url().await;
    let (on_a, on_b) = (ready_session(&a, &url).await, ready_session(&b, &url).await);
    filter(&a, &on_a, "add-noise", serde_json::json!({"seed": 1})).await;
    let second = filter(&a, &on_a, "add-noise", serde_json::json!({"seed": 2})).await;

    // The second step's correction applies to the first step's result, not to the input.
    let update = Update {
        correction: Some(second.correction.clone()),
        replay: None,
        full: second.full.clone(),
        use_: Transfer::Correction,
    };
    let updated = b.update(&on_b, &update).await.unwrap();
    assert_eq!((updated.via, updated.hash.as_str()), (Transfer::Full, second.output_hash.as_str()));
    let reason = updated.fallback.unwrap();
    assert!(reason.contains("applies to mesh"), "{reason}");

    // A corrupt correction, then one that cannot be downloaded.
    let mut corrupt = a.download(&second.correction.url).await.unwrap();
    let middle = corrupt.len() / 2;
    corrupt[middle] ^= 0x55;
    let files = serve_files(vec![("bad.mfc", corrupt)]).await;
    let on_b2 = ready_session(&b, &url).await;
    let mut bad = update.clone();
    bad.full = filter(&a, &on_a, "add-noise", serde_json::json!({"seed": 3})).await.full;
    bad.correction.as_mut().unwrap().url = format!("{files}/bad.mfc");
    let reason = b.update(&on_b2, &bad).await.unwrap().fallback.unwrap();
    assert!(reason.contains("corrupt") && reason.contains("bad.mfc"), "{reason}");
    bad.correction.as_mut().unwrap().url = format!("{files}/missing.mfc");
    let on_b3 = ready_session(&b, &url).await;
    let reason = b.update(&on_b3, &bad).await.unwrap().fallback.unwrap();
    assert!(reason.contains("missing.mfc") && reason.contains("404"), "{reason}");

    // A full mesh whose hash is not the announced one is refused; the session is unharmed.
    let before = b.session(&on_b3).await.unwrap().hash;
    let mut lying = bad.clone();
    lying.use_ = Transfer::Full;
    lying.full.hash = "ab".repeat(32);
    let (status, code, message) = api_error(b.update(&on_b3, &lying).await);
    assert_eq!((status, code.as_str()), (422, "hash-mismatch"), "{message}");
    let after = b.session(&on_b3).await.unwrap();
    assert_eq!((after.state, after.hash), (SessionState::Ready, before));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn inputs_that_cannot_be_had_fail_the_session_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let (_host, client) = start_host(config(dir.path())).await;
    let files = serve_files(vec![
        ("noise.bin", vec![0, 1, 2, 3, 255, 254]),
        ("cut.obj", b"v 0 0 0\nf 1 2 3\n".to_vec()),
    ])
    .await;
    let hash = bunny().content_hash().to_hex();
    let cases = [
        ("http://127.0.0.1:1/in.obj".to_owned(), None, "http://127.0.0.1:1/in.obj"),
        (format!("{files}/gone.obj"), None, "404"),
        (format!("{files}/noise.bin"), None, "cannot tell the mesh format"),
        (format!("{files}/cut.obj"), None, "cut.obj"),
        (bunny_url().await, Some("cd".repeat(32)), &*hash),
    ];
    for (url, expected_hash, words) in cases {
        let created = client.create_session(&url, expected_hash.as_deref()).await.unwrap();
        let status = client.wait_ready(&created.id).await.unwrap();
        assert_eq!(status.state, SessionState::Failed, "{url}");
        let error = status.error.unwrap();
        assert!(error.contains(words), "{url}: {error}");
        let (code, name, _) = api_error(
            client.run(&created.id, &request("vertex-count", serde_json::json!({}))).await,
        );
        assert_eq!((code, name.as_str()), (409, "session-failed"));
    }
    let (status, code, _) = api_error(client.create_session("not a url", None).await);
    assert_eq!((status, code.as_str()), (400, "bad-url"));
    assert_eq!(api_error(client.session("nope").await).0, 404);
    let raw = reqwest::Client::new()
        .post(format!("{}/sessions", client.base_url()))
        .body("{")
        .header("content-type", "application/json")
        .send()
        .await
        .unwrap();
    assert_eq!(raw.status(), 400);
    let body: serde_json::Value = raw.json().await.unwrap();
    assert_eq!(body["error"]["code"], "bad-json");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn plugins_upload_with_the_token_only_and_a_failing_plugin_leaves_the_session_working() {
    let dirs = [(); 2].map(|()| tempfile::tempdir().unwrap());
    let hostile = meshflow_builtin_plugins::fixture("hostile").to_vec();
    let (_closed, closed) = start_host(config(dirs[0].path())).await;
    let (status, _, message) =
        api_error(closed.upload_plugin(hostile.clone(), Some(TOKEN), false).await);
    assert_eq!(status, 403);
    assert!(message.contains("--token"), "{message}");

    let (_host, client) = start_host(HostConfig {
        token: Some(TOKEN.into()),
        limits: Limits { deadline: Duration::from_secs(2), ..Limits::default() },
        ..config(dirs[1].path())
    })
    .await;
    assert_eq!(api_error(client.upload_plugin(hostile.clone(), None, false).await).0, 401);
    assert_eq!(api_error(client.upload_plugin(hostile.clone(), Some("wrong"), false).await).0, 401);
    let (status, code, message) =
        api_error(client.upload_plugin(b"\0asm but not really".to_vec(), Some(TOKEN), false).await);
    assert_eq!((status, code.as_str()), (422, "invalid-plugin"), "{message}");
    let uploaded = client.upload_plugin(hostile.clone(), Some(TOKEN), false).await.unwrap();
    assert!(uploaded.services.iter().any(|s| s.name == "ignore-bad-edits"));
    let again = client.upload_plugin(hostile.clone(), Some(TOKEN), false).await.unwrap();
    assert_eq!(again.digest, uploaded.digest);
    let services = client.services().await.unwrap();
    let trap = services.iter().find(|s| s.info.name == "trap").unwrap();
    assert_eq!((trap.plugin.as_str(), trap.builtin), (uploaded.digest.as_str(), false));
    assert!(services.iter().any(|s| s.info.name == "laplacian-smoothing" && s.builtin));

    let id = ready_session(&client, &bunny_url().await).await;
    let step = filter(&client, &id, "ignore-bad-edits", serde_json::json!({})).await;
    assert_eq!((step.plugin.as_str(), step.edits), (uploaded.digest.as_str(), 1));
    for (service, words) in [("trap", "crashed"), ("fail", "fail"), ("bad-edit", "bad-edit")] {
        let (status, code, message) =
            api_error(client.run(&id, &request(service, serde_json::json!({}))).await);
        assert_eq!((status, code.as_str()), (422, "plugin-failed"), "{service}: {message}");
        assert!(message.contains(words), "{service}: {message}");
        let status = client.session(&id).await.unwrap();
        assert_eq!(
            (status.state, status.hash.as_deref()),
            (SessionState::Ready, Some(step.output_hash.as_str()))
        );
    }
    let (status, code, message) =
        api_error(client.run(&id, &request("smooth-everything", serde_json::json!({}))).await);
    assert_eq!((status, code.as_str()), (400, "unknown-service"));
    assert!(message.contains("laplacian-smoothing"), "{message}");
    let bad = request("laplacian-smoothing", serde_json::json!({"iterations": "many"}));
    assert_eq!(api_error(client.run(&id, &bad).await).1, "bad-params");

    // A run in progress makes the session busy; the deadline then stops the plugin.
    let looping = {
        let (client, id) = (client.clone(), id.clone());
        tokio::spawn(async move {
            client.run(&id, &request("loop-forever", serde_json::json!({}))).await
        })
    };
    while client.session(&id).await.unwrap().state != SessionState::Busy {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    assert_eq!(client.health().await.unwrap().running, 1);
    let (status, code, _) =
        api_error(client.run(&id, &request("vertex-count", serde_json::json!({}))).await);
    assert_eq!((status, code.as_str()), (409, "session-busy"));
    let (status, _, message) = api_error(looping.await.unwrap());
    assert!(status == 422 && message.contains("deadline"), "{message}");
    filter(&client, &id, "add-noise", serde_json::json!({})).await;

    let builtin = services.iter().find(|s| s.builtin).unwrap().plugin.clone();
    assert_eq!(api_error(client.delete_plugin(&builtin, Some(TOKEN)).await).0, 403);
    assert_eq!(api_error(client.delete_plugin(&uploaded.digest, None).await).0, 401);
    client.delete_plugin(&uploaded.digest, Some(TOKEN)).await.unwrap();
    assert_eq!(api_error(client.delete_plugin(&uploaded.digest, Some(TOKEN)).await).0, 404);
    assert!(!client.plugins().await.unwrap().iter().any(|p| p.digest == uploaded.digest));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_restarted_host_keeps_its_plugins_blobs_and_sessions() {
    let dir = tempfile::tempdir().unwrap();
    let host_config = || HostConfig { token: Some(TOKEN.into()), ..config(dir.path()) };
    let (handle, client) = start_host(host_config()).await;
    let uploaded = client
        .upload_plugin(meshflow_builtin_plugins::fixture("hostile").to_vec(), Some(TOKEN), false)
        .await
        .unwrap();
    let id = ready_session(&client, &bunny_url().await).await;
    filter(&client, &id, "laplacian-smoothing", serde_json::json!({})).await;
    let step = filter(&client, &id, "ignore-bad-edits", serde_json::json!({})).await;
    handle.shutdown().await.unwrap();

    // The input's file server is gone too: the session is rebuilt from stored blobs.
    let (_handle, client) = start_host(host_config()).await;
    assert!(client.plugins().await.unwrap().iter().any(|p| p.digest == uploaded.digest));
    let status = client.wait_ready(&id).await.unwrap();
    assert_eq!(
        (status.state, status.hash.as_deref()),
        (SessionState::Ready, Some(step.output_hash.as_str()))
    );
    let correction = step.correction.url.rsplit('/').next().unwrap();
    let local = format!("{}/blobs/{correction}", client.base_url());
    // Written before the first host stopped, though the step was answered before it.
    assert!(client.blob_size(&local).await.unwrap() > 0);
    let full = format!("{}/blobs/{}.mfm", client.base_url(), step.output_hash);
    let packed = client.download(&full).await.unwrap();
    let unpacked = meshflow_codec::pack::decode(&packed).unwrap();
    assert_eq!(unpacked.content_hash().to_hex(), step.output_hash);
    assert_eq!(client.blob_size(&full).await.unwrap(), packed.len() as u64);
    let next = filter(&client, &id, "ignore-bad-edits", serde_json::json!({})).await;
    assert_eq!(next.input_hash, step.output_hash);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_host_killed_before_writing_edit_logs_rebuilds_those_steps_from_their_replays() {
    let dir = tempfile::tempdir().unwrap();
    let (handle, client) = start_host(config(dir.path())).await;
    let id = ready_session(&client, &bunny_url().await).await;
    let first = filter(&client, &id, "add-noise", serde_json::json!({"seed": 3})).await;
    let second = filter(&client, &id, "laplacian-smoothing", serde_json::json!({})).await;
    handle.shutdown().await.unwrap();
    // As if killed after answering both steps and before their logs reached the disk.
    for step in [&first, &second] {
        let log = step.correction.url.rsplit('/').next().unwrap();
        std::fs::remove_file(dir.path().join("blobs").join(log)).unwrap();
    }

    let (_handle, client) = start_host(config(dir.path())).await;
    let status = client.wait_ready(&id).await.unwrap();
    assert_eq!(
        (status.state, status.hash.as_deref(), status.error),
        (SessionState::Ready, Some(second.output_hash.as_str()), None)
    );
    let next = filter(&client, &id, "laplacian-smoothing", serde_json::json!({})).await;
    assert_eq!(next.input_hash, second.output_hash);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn blobs_over_the_budget_are_evicted_unless_a_session_needs_them() {
    let dir = tempfile::tempdir().unwrap();
    let (_handle, client) =
        start_host(HostConfig { blob_budget_bytes: 1, ..config(dir.path()) }).await;
    let url = bunny_url().await;
    let (first, second) = (ready_session(&client, &url).await, ready_session(&client, &url).await);
    let gone = filter(&client, &first, "add-noise", serde_json::json!({"seed": 1})).await;
    let kept = filter(&client, &second, "add-noise", serde_json::json!({"seed": 2})).await;
    assert!(client.blob_size(&gone.correction.url).await.unwrap() > 0);
    client.delete_session(&first).await.unwrap();
    assert_eq!(api_error(client.session(&first).await).0, 404);
    let last = filter(&client, &second, "add-noise", serde_json::json!({"seed": 3})).await;
    for evicted in [&gone.correction, &gone.replay] {
        assert_eq!(api_error(client.blob_size(&evicted.url).await).0, 404);
    }
    // The live session's replays stay too: other hosts fetch them to re-run its steps.
    for needed in [&kept.replay, &last.replay] {
        assert_eq!(client.blob_size(&needed.url).await.unwrap(), needed.bytes);
    }
    for needed in [&kept.correction, &last.correction] {
        assert!(client.blob_size(&needed.url).await.unwrap() > 0);
    }
    let blobs = std::fs::read_dir(dir.path().join("blobs")).unwrap().count();
    assert_eq!(blobs, 5, "the input and the live session's two corrections and two replays");
}

#[test]
fn the_cli_serves_a_host_and_uploads_a_plugin_to_it() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let meshflow = env!("CARGO_BIN_EXE_meshflow");
    let mut host = std::process::Command::new(meshflow)
        .args(["host", "--listen", "127.0.0.1:0", "--token", TOKEN, "--data"])
        .arg(dir.path())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut log = std::io::BufReader::new(host.stderr.take().unwrap()).lines();
    let url = log
        .by_ref()
        .map_while(Result::ok)
        .find_map(|line| Some(line.split("reached at ").nth(1)?.trim().to_owned()))
        .expect("the host logs its URL");
    let wasm = dir.path().join("hostile.wasm");
    std::fs::write(&wasm, meshflow_builtin_plugins::fixture("hostile")).unwrap();
    let upload = |token: &str| {
        std::process::Command::new(meshflow)
            .args(["plugin", "upload", "--host", &url, "--token", token])
            .arg(&wasm)
            .output()
            .unwrap()
    };
    let refused = upload("wrong-token-0123456789");
    let uploaded = upload(TOKEN);
    host.kill().unwrap();
    host.wait().unwrap();
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("401"));
    let stdout = String::from_utf8(uploaded.stdout).unwrap();
    assert!(uploaded.status.success(), "{}", String::from_utf8_lossy(&uploaded.stderr));
    let digest = meshflow_runtime::digest(meshflow_builtin_plugins::fixture("hostile"));
    assert!(stdout.starts_with(&format!("plugin {digest}")), "{stdout}");
    assert!(stdout.contains("loop-forever (filter"), "{stdout}");
}

/// An HTTP server on 127.0.0.1 that announces a large body and sends one byte of it every
/// 200 ms, for at most `for_at_most` (a hostile or very slow input).
async fn dripping_url(for_at_most: Duration) -> (String, tokio::task::JoinHandle<()>) {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let url = format!("http://{}/slow.ply", listener.local_addr().unwrap());
    let server = tokio::spawn(async move {
        let Ok((mut socket, _)) = listener.accept().await else { return };
        let mut request = [0u8; 4096];
        let _ = socket.read(&mut request).await;
        let head = "HTTP/1.1 200 OK\r\nContent-Length: 1000000\r\n\r\n";
        if socket.write_all(head.as_bytes()).await.is_err() {
            return;
        }
        let until = tokio::time::Instant::now() + for_at_most;
        while tokio::time::Instant::now() < until {
            if socket.write_all(b"p").await.is_err() {
                return;
            }
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
    });
    (url, server)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_dripping_input_does_not_hold_up_other_sessions() {
    let dir = tempfile::tempdir().unwrap();
    let (_host, client) = start_host(config(dir.path())).await;
    let ready = ready_session(&client, &bunny_url().await).await;
    let (slow_url, drip) = dripping_url(Duration::from_secs(40)).await;
    let slow = client.create_session(&slow_url, None).await.unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!(client.session(&slow.id).await.unwrap().state, SessionState::Loading);
    // Each run ends by enforcing the blob budget, which must not wait for the drip (it once
    // did, for the whole download, and every session with it).
    for seed in 0..3 {
        let run = filter(&client, &ready, "add-noise", serde_json::json!({"seed": seed}));
        let done = tokio::time::timeout(Duration::from_secs(20), run).await;
        assert!(done.is_ok(), "run {seed} waited for another session's download");
    }
    client.delete_session(&slow.id).await.unwrap();
    drip.abort();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_input_answering_an_error_is_not_echoed() {
    let dir = tempfile::tempdir().unwrap();
    let (_host, client) = start_host(config(dir.path())).await;
    let app = axum::Router::new()
        .fallback(|| async { (axum::http::StatusCode::FORBIDDEN, "TOP-SECRET internal page") });
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let url = format!("http://{}/scan.ply", listener.local_addr().unwrap());
    tokio::spawn(async move { axum::serve(listener, app).await });
    let created = client.create_session(&url, None).await.unwrap();
    let status = client.wait_ready(&created.id).await.unwrap();
    assert_eq!(status.state, SessionState::Failed);
    let error = status.error.unwrap_or_default();
    assert!(error.contains("403"), "{error}");
    assert!(!error.contains("TOP-SECRET"), "the error repeats the fetched body: {error}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_host_that_hangs_or_is_gone_is_told_apart_in_bounded_time() {
    // Accepts connections and never answers.
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let hung = format!("http://{}", listener.local_addr().unwrap());
    let hold = tokio::spawn(async move {
        let mut held = Vec::new();
        while let Ok((socket, _)) = listener.accept().await {
            held.push(socket);
        }
    });
    let bound = meshflow_api::QUERY_TIMEOUT * 3;
    let answer = tokio::time::timeout(bound, HostClient::new(&hung).health()).await;
    assert!(matches!(answer, Ok(Err(ClientError::Timeout { .. }))), "{answer:?}");
    hold.abort();

    let closed = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let gone = format!("http://{}", closed.local_addr().unwrap());
    drop(closed);
    let answer = tokio::time::timeout(bound, HostClient::new(&gone).services()).await;
    assert!(matches!(answer, Ok(Err(ClientError::Unreachable { .. }))), "{answer:?}");
}

/// Polls `GET /health` until the host counts `runs` runs in progress (queued included).
async fn wait_running(client: &HostClient, runs: usize) {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(20);
    while client.health().await.unwrap().running < runs {
        assert!(tokio::time::Instant::now() < deadline, "never {runs} runs in progress");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    // Counted means admitted; give the run a moment to take its slot or its place in line.
    tokio::time::sleep(Duration::from_millis(300)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn beyond_the_run_slots_and_queue_a_run_gets_429_and_queueing_is_not_compute_time() {
    let data = tempfile::tempdir().unwrap();
    let mut config = config(data.path());
    config.builtins.push(meshflow_builtin_plugins::fixture("hostile"));
    // One slot, one place in line; the looping run holds the slot until its deadline.
    let deadline = Duration::from_secs(3);
    config.limits = Limits { concurrent_runs: 1, queued_runs: 1, deadline, ..Limits::default() };
    let (_host, client) = start_host(config).await;
    let url = bunny_url().await;
    let mut sessions = Vec::new();
    for _ in 0..3 {
        sessions.push(ready_session(&client, &url).await);
    }
    let run = |session: &String, service: &str| {
        let (client, session, request) =
            (client.clone(), session.clone(), request(service, serde_json::json!({})));
        tokio::spawn(async move { client.run(&session, &request).await })
    };
    let looping = run(&sessions[0], "loop-forever");
    wait_running(&client, 1).await;
    let queued = run(&sessions[1], "vertex-count");
    wait_running(&client, 2).await;

    // The third: slot and queue are full. 429, a code and when to come back.
    let answer = reqwest::Client::new()
        .post(format!("{}/sessions/{}/run", client.base_url(), sessions[2]))
        .json(&request("vertex-count", serde_json::json!({})))
        .send()
        .await
        .unwrap();
    assert_eq!(answer.status(), 429);
    assert_eq!(answer.headers()["retry-after"], "1");
    let body: serde_json::Value = answer.json().await.unwrap();
    assert_eq!(body["error"]["code"], "busy", "{body}");
    // The client tells it apart from a refusal, so the engine can come back later.
    let refused = client.run(&sessions[2], &request("vertex-count", serde_json::json!({}))).await;
    assert!(
        matches!(refused, Err(ClientError::Busy { retry_after: Some(d), .. }) if d == Duration::from_secs(1)),
        "{refused:?}"
    );

    let (status, code, _) = api_error(looping.await.unwrap());
    assert_eq!((status, code.as_str()), (422, "plugin-failed"));
    let RunResult::Check(check) = queued.await.unwrap().unwrap() else { panic!("a check") };
    assert_eq!(check.value, serde_json::json!(1839));
    // It waited for most of the looping run's deadline, and its compute time is its own.
    assert!(check.queue_ms > 1500.0, "queue_ms {}", check.queue_ms);
    assert!(check.compute_ms < 1000.0, "compute_ms {} counts the queue", check.compute_ms);
    // Once the slot is free the session that was refused runs normally.
    assert!(
        client.run(&sessions[2], &request("vertex-count", serde_json::json!({}))).await.is_ok()
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_second_version_of_a_service_replaces_it_only_when_asked_and_the_first_stays_for_pinned_runs()
 {
    let dir = tempfile::tempdir().unwrap();
    let host_config = || HostConfig { token: Some(TOKEN.into()), ..config(dir.path()) };
    let (host, client) = start_host(host_config()).await;
    let v2 = meshflow_builtin_plugins::fixture("smoothing-v2").to_vec();
    let builtin = meshflow_runtime::digest(
        meshflow_builtin_plugins::PLUGINS.iter().find(|p| p.name == "smoothing").unwrap().wasm,
    );

    let (status, code, message) =
        api_error(client.upload_plugin(v2.clone(), Some(TOKEN), false).await);
    assert_eq!((status, code.as_str()), (409, "services-taken"), "{message}");
    assert!(message.contains(&format!("laplacian-smoothing (plugin {builtin})")), "{message}");
    let uploaded = client.upload_plugin(v2.clone(), Some(TOKEN), true).await.unwrap();
    assert_eq!(
        (uploaded.replaced.as_slice(), uploaded.new.len()),
        (&["laplacian-smoothing".to_owned()][..], 0)
    );
    let again = client.upload_plugin(v2.clone(), Some(TOKEN), false).await.unwrap();
    assert_eq!(again.present, ["laplacian-smoothing"]);

    let offers = |services: Vec<meshflow_api::host::ServiceEntry>| {
        let mut offers: Vec<(String, bool)> = services
            .into_iter()
            .filter(|s| s.info.name == "laplacian-smoothing")
            .map(|s| (s.plugin, s.pinned_only))
            .collect();
        offers.sort();
        offers
    };
    let mut expected = vec![(builtin.clone(), true), (uploaded.digest.clone(), false)];
    expected.sort();
    assert_eq!(offers(client.services().await.unwrap()), expected);

    let id = ready_session(&client, &bunny_url().await).await;
    let unpinned = filter(&client, &id, "laplacian-smoothing", serde_json::json!({})).await;
    assert_eq!(unpinned.plugin, uploaded.digest);
    let mut pinned = request("laplacian-smoothing", serde_json::json!({}));
    pinned.plugin = Some(builtin.clone());
    let RunResult::Filter(old) = client.run(&id, &pinned).await.unwrap() else { panic!() };
    assert_eq!(old.plugin, builtin);
    assert_eq!(
        old.resolved_params,
        serde_json::json!({"iterations": 1, "keep-boundary": true, "weights": "uniform"})
            .as_object()
            .unwrap()
            .clone()
    );

    // After a restart the newest upload still serves the name.
    host.shutdown().await.unwrap();
    let (_host, client) = start_host(host_config()).await;
    assert_eq!(offers(client.services().await.unwrap()), expected);
    let (status, code, _) = api_error(client.delete_plugin(&builtin, Some(TOKEN)).await);
    assert_eq!((status, code.as_str()), (403, "builtin"));
    client.delete_plugin(&uploaded.digest, Some(TOKEN)).await.unwrap();
    assert_eq!(offers(client.services().await.unwrap()), [(builtin, false)]);
}
