//! Named users (issue 36, DESIGN §10): tokens from a users file, each user with their own
//! runs, batches, inputs and run slots; admins see everyone's. Also the engine's files
//! (owner-only modes) and its online backup, read back by a second engine. Real HTTP on
//! 127.0.0.1.

mod common;

use std::path::Path;
use std::time::Duration;

use common::{CLUSTER_TOKEN, EngineApi, Input, bearer_client, start_hosts};
use meshflow_engine::limits::{MAX_ACTIVE_RUNS_PER_CLIENT, MAX_QUEUED_RUNS_PER_CLIENT};
use serde_json::{Value as Json, json};
use tokio::net::TcpListener;

const ANNA: &str = "anna-token-0123456789";
const BERT: &str = "bert-token-0123456789";
const BOSS: &str = "boss-token-0123456789";

/// An origin that accepts connections and never answers: runs reading from it stay going.
async fn silent_origin() -> String {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let origin = format!("http://{}", listener.local_addr().unwrap());
    tokio::spawn(async move {
        let mut held = Vec::new();
        while let Ok((socket, _)) = listener.accept().await {
            held.push(socket);
        }
    });
    origin
}

fn as_user(base: &str, token: &str) -> EngineApi {
    EngineApi { base: base.to_owned(), http: bearer_client(token) }
}

async fn status_of(answer: reqwest::Response) -> (u16, Json) {
    let status = answer.status().as_u16();
    (status, answer.json().await.unwrap_or(Json::Null))
}

async fn get(api: &EngineApi, path: &str) -> (u16, Json) {
    status_of(api.http.get(api.url(path)).send().await.unwrap()).await
}

async fn post(api: &EngineApi, path: &str, body: &Json) -> (u16, Json) {
    status_of(api.http.post(api.url(path)).json(body).send().await.unwrap()).await
}

#[cfg(unix)]
fn mode(path: &Path) -> u32 {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(path).unwrap().permissions().mode() & 0o777
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn users_see_their_own_runs_and_have_their_own_slots() {
    let dir = tempfile::tempdir().unwrap();
    let silent = silent_origin().await;
    let hosts = start_hosts(&[&["cleanup"]], dir.path(), std::slice::from_ref(&silent)).await;
    let users = dir.path().join("users");
    let boss_digest = meshflow_engine::users::hashed(BOSS);
    std::fs::write(
        &users,
        format!(
            "# name role token\nanna user {ANNA}\n\nbert user {BERT}  # the other lab\n\
             boss admin {boss_digest}\n"
        ),
    )
    .unwrap();
    let data = dir.path().join("engine");
    let access = meshflow_engine::Access {
        users_file: Some(users.clone()),
        cluster_token: Some(CLUSTER_TOKEN.into()),
        allow_input_from: vec![silent.clone()],
        ..Default::default()
    };
    let urls: Vec<String> = hosts.iter().map(|h| h.url.clone()).collect();
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let engine = meshflow_engine::start(data.clone(), None, &urls, access, listener).await.unwrap();
    let (anna, bert, boss) =
        (as_user(&engine.url, ANNA), as_user(&engine.url, BERT), as_user(&engine.url, BOSS));

    // Each token names its user; no token, or another, is refused.
    for (api, name, role) in
        [(&anna, "anna", "user"), (&bert, "bert", "user"), (&boss, "boss", "admin")]
    {
        assert_eq!(get(api, "/me").await, (200, json!({"name": name, "role": role})));
    }
    assert_eq!(get(&as_user(&engine.url, "nobody-0123456789"), "/me").await.0, 401);

    // Anna's run, on her upload.
    let input = anna.upload(&Input::bunny()).await;
    let file = input.rsplit('/').next().unwrap().to_owned();
    let workflow = json!({"steps": [{"run": "remove-degenerate-triangles"}]});
    let run = anna.submit(&workflow, &input).await;
    let record = anna.finished(&run).await;
    assert_eq!(record["status"], "completed", "{record:#}");
    assert_eq!(record["user"], "anna");
    let (status, batch) =
        post(&anna, "/batches", &json!({"workflow": workflow, "inputs": [input]})).await;
    assert_eq!(status, 202, "{batch}");
    let batch = batch["id"].as_str().unwrap().to_owned();

    // To Bert, none of it exists.
    for path in [
        format!("/runs/{run}"),
        format!("/runs/{run}/result"),
        format!("/runs/{run}/events"),
        format!("/runs/{run}/input"),
        format!("/runs/{run}/workflow"),
        format!("/runs/{run}/steps/0/output"),
        format!("/batches/{batch}"),
        format!("/inputs/{file}"),
    ] {
        let (status, answer) = get(&bert, &path).await;
        assert_eq!((status, &answer["error"]["code"]), (404, &json!("not-found")), "{path}");
    }
    for path in [format!("/runs/{run}/cancel"), format!("/runs/{run}/rerun")] {
        let (status, answer) = post(&bert, &path, &json!({})).await;
        assert_eq!(status, 404, "{path}: {answer}");
    }
    let (status, answer) =
        post(&bert, "/runs", &json!({"workflow": workflow, "input": input})).await;
    assert_eq!((status, &answer["error"]["code"]), (404, &json!("not-found")), "{answer}");
    assert_eq!(get(&bert, "/runs").await, (200, json!([])));

    // Anna sees hers; the admin sees everyone's, and may re-run them.
    assert_eq!(get(&anna, &format!("/inputs/{file}")).await.0, 200);
    assert_eq!(get(&anna, &format!("/batches/{batch}")).await.0, 200);
    assert_eq!(get(&boss, &format!("/runs/{run}")).await.1["user"], "anna");
    assert_eq!(get(&boss, &format!("/batches/{batch}")).await.0, 200);
    let (status, rerun) = post(&boss, &format!("/runs/{run}/rerun"), &json!({})).await;
    assert_eq!(status, 202, "{rerun}");
    let rerun = rerun["id"].as_str().unwrap().to_owned();
    assert_eq!(boss.finished(&rerun).await["user"], "boss");
    let ids = |list: Json| -> Vec<String> {
        list.as_array().unwrap().iter().map(|r| r["id"].as_str().unwrap().to_owned()).collect()
    };
    let everyone = ids(get(&boss, "/runs").await.1);
    assert!(everyone.contains(&run) && everyone.contains(&rerun), "{everyone:?}");
    let annas = ids(get(&anna, "/runs").await.1);
    assert!(annas.contains(&run) && !annas.contains(&rerun), "{annas:?}");

    // Files are the engine user's only.
    #[cfg(unix)]
    {
        assert_eq!(mode(&data), 0o700);
        assert_eq!(mode(&data.join("engine.sqlite3")), 0o600);
        assert_eq!(mode(&data.join("inputs")), 0o700);
        assert_eq!(mode(&data.join("inputs").join(&file)), 0o600);
    }

    // An online backup, taken while the engine runs, reads back in another engine (once
    // the engine has written the finished run: it writes changes every PERSIST_INTERVAL).
    tokio::time::sleep(meshflow_engine::limits::PERSIST_INTERVAL * 5).await;
    let copy = dir.path().join("backup.sqlite3");
    meshflow_engine::backup(&data, &copy).unwrap();
    #[cfg(unix)]
    assert_eq!(mode(&copy), 0o600);
    let restored = dir.path().join("restored");
    std::fs::create_dir(&restored).unwrap();
    std::fs::copy(&copy, restored.join("engine.sqlite3")).unwrap();
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let access = meshflow_engine::Access::default();
    let second = meshflow_engine::start(restored, None, &[], access, listener).await.unwrap();
    let (status, back) = get(&EngineApi::new(&second.url), &format!("/runs/{run}")).await;
    assert_eq!(status, 200, "{back}");
    assert_eq!((&back["status"], &back["user"]), (&json!("completed"), &json!("anna")), "{back:#}");
    assert_eq!(back["steps"], record["steps"]);

    // Slots are per user: Anna filling hers leaves Bert his.
    let stuck = json!({"workflow": workflow, "input": format!("{silent}/never.ply")});
    let limit = MAX_ACTIVE_RUNS_PER_CLIENT + MAX_QUEUED_RUNS_PER_CLIENT;
    for n in 0..limit {
        let (status, answer) = post(&anna, "/runs", &stuck).await;
        assert_eq!(status, 202, "run {n}: {answer}");
    }
    let answer = anna.http.post(anna.url("/runs")).json(&stuck).send().await.unwrap();
    assert_eq!(answer.status(), 429);
    assert!(answer.headers().contains_key("retry-after"));
    let (status, answer) = post(&bert, "/runs", &stuck).await;
    assert_eq!(status, 202, "Bert has slots of his own: {answer}");

    // A users file that changes is read again; a bad change keeps the users.
    tokio::time::sleep(Duration::from_millis(1100)).await;
    std::fs::write(&users, format!("bert user {BERT}\nboss admin {BOSS}\n")).unwrap();
    set_modified_later(&users);
    tokio::time::sleep(Duration::from_millis(1100)).await;
    assert_eq!(get(&anna, "/me").await.0, 401, "Anna was removed");
    assert_eq!(get(&boss, "/me").await.1["name"], "boss");
    std::fs::write(&users, "bert user short\n").unwrap();
    set_modified_later(&users);
    tokio::time::sleep(Duration::from_millis(1100)).await;
    assert_eq!(get(&bert, "/me").await.1["name"], "bert", "a bad file keeps the old users");
}

/// Moves a file's modification time on, so a rewrite within the same clock tick is seen.
fn set_modified_later(path: &Path) {
    let file = std::fs::File::options().write(true).open(path).unwrap();
    let later = std::time::SystemTime::now() + Duration::from_secs(2);
    file.set_modified(later).unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_users_file_with_a_bad_line_stops_the_start() {
    let dir = tempfile::tempdir().unwrap();
    let users = dir.path().join("users");
    std::fs::write(&users, format!("anna user {ANNA}\nbert admin short\n")).unwrap();
    let access = meshflow_engine::Access {
        users_file: Some(users),
        cluster_token: Some(CLUSTER_TOKEN.into()),
        ..Default::default()
    };
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let error = meshflow_engine::start(dir.path().join("engine"), None, &[], access, listener)
        .await
        .err()
        .expect("it started")
        .to_string();
    assert!(error.contains("line 2") && error.contains("at least 16"), "{error}");
}
