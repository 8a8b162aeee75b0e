//! The engine's durable state in one SQLite file (`DATA/engine.sqlite3`, readable by its
//! owner only): runs with their workflow, input, user and record (its steps one row each, so a long run's record is
//! written step by step, not whole every time); the host sessions each run opened;
//! registered hosts; uploaded inputs and who uploaded them. A restart reads it back
//! (DESIGN §10). [`backup`] copies it while the engine runs.
//!
//! Calls are short (one statement or one transaction of them); the async callers run them
//! on the blocking pool through [`Store::call`], never while holding another lock.

use std::path::Path;
use std::sync::{Arc, Mutex};

use rusqlite::{Connection, OptionalExtension, params};

use crate::measured::Snapshot;
use crate::record::{RunRecord, Status};
use crate::run::{Changes, OpenSession};

mod batches;
mod inputs;
pub use batches::*;
pub use inputs::*;

/// Bumped when the schema changes; an older file is migrated, a newer one refused.
const SCHEMA_VERSION: i64 = 2;

const SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS runs (
    id TEXT PRIMARY KEY,
    seq INTEGER NOT NULL,
    created_unix INTEGER NOT NULL,
    owner TEXT NOT NULL,
    workflow TEXT NOT NULL,
    input TEXT NOT NULL,
    status TEXT NOT NULL,
    record TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS runs_by_seq ON runs (seq);
CREATE TABLE IF NOT EXISTS steps (
    run_id TEXT NOT NULL,
    idx INTEGER NOT NULL,
    step TEXT NOT NULL,
    PRIMARY KEY (run_id, idx)
);
CREATE TABLE IF NOT EXISTS sessions (
    run_id TEXT NOT NULL,
    host TEXT NOT NULL,
    session TEXT NOT NULL,
    PRIMARY KEY (run_id, host, session)
);
CREATE TABLE IF NOT EXISTS hosts (
    url TEXT PRIMARY KEY,
    added_unix INTEGER NOT NULL
);
CREATE TABLE IF NOT EXISTS inputs (
    file TEXT PRIMARY KEY,
    bytes INTEGER NOT NULL,
    stored_unix INTEGER NOT NULL
);
CREATE TABLE IF NOT EXISTS batches (
    id TEXT PRIMARY KEY,
    seq INTEGER NOT NULL,
    owner TEXT NOT NULL,
    workflow TEXT NOT NULL,
    concurrency INTEGER NOT NULL
);
CREATE TABLE IF NOT EXISTS batch_entries (
    batch_id TEXT NOT NULL,
    idx INTEGER NOT NULL,
    input TEXT NOT NULL,
    run_id TEXT,
    error TEXT,
    PRIMARY KEY (batch_id, idx)
);
CREATE TABLE IF NOT EXISTS input_names (
    file TEXT PRIMARY KEY,
    name TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS input_users (
    file TEXT NOT NULL,
    user TEXT NOT NULL,
    PRIMARY KEY (file, user)
);
CREATE TABLE IF NOT EXISTS measurements (
    only INTEGER PRIMARY KEY CHECK (only = 1),
    snapshot TEXT NOT NULL
);
-- How far each host is trusted and why it is suspect (`trust.rs`); an older database gains
-- the table empty: every host trusted, none suspect.
CREATE TABLE IF NOT EXISTS host_verdicts (
    url TEXT PRIMARY KEY,
    trust TEXT NOT NULL DEFAULT 'trusted',
    suspect TEXT,
    suspect_unix INTEGER,
    cleared TEXT
);
";

/// Schema 1 → 2: runs and batches name their user (older ones are `default`'s, as everything
/// was on an engine without users), and so do inputs.
const TO_VERSION_2: &str = "
ALTER TABLE runs ADD COLUMN user TEXT NOT NULL DEFAULT 'default';
ALTER TABLE batches ADD COLUMN user TEXT NOT NULL DEFAULT 'default';
INSERT OR IGNORE INTO input_users (file, user) SELECT file, 'default' FROM inputs;
";

#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("engine database: {0}")]
    Sql(#[from] rusqlite::Error),
    #[error("engine database: a stored record does not read back: {0}")]
    Record(#[from] serde_json::Error),
    #[error(
        "engine database was written by a newer meshflow (schema {0}, this one knows {SCHEMA_VERSION})"
    )]
    NewerSchema(i64),
    #[error("engine database: the blocking task failed: {0}")]
    Join(#[from] tokio::task::JoinError),
    #[error("engine database {path}: {source}")]
    File { path: std::path::PathBuf, source: std::io::Error },
}

/// A run as stored: what is needed to show it, and to resume it after a restart. Its
/// workflow as submitted is `record.workflow`, written to a column of its own (the
/// `record` column holds it as null, as every later write of the record does).
#[derive(Debug, Clone)]
pub struct StoredRun {
    pub id: String,
    /// The user whose run it is.
    pub user: String,
    pub input: String,
    pub record: RunRecord,
    pub sessions: Vec<OpenSession>,
}

#[derive(Clone)]
pub struct Store {
    connection: Arc<Mutex<Connection>>,
}

impl Store {
    /// Opens (or creates) the database at `path`, readable and writable by this user only
    /// (SQLite gives its `-wal` and `-shm` files the same permissions).
    pub fn open(path: &Path) -> Result<Self, StoreError> {
        let file = |source| StoreError::File { path: path.to_owned(), source };
        let mut options = std::fs::OpenOptions::new();
        options.create(true).append(true);
        #[cfg(unix)]
        std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
        options.open(path).map_err(file)?;
        crate::files::owner_only(path, false).map_err(file)?;
        let connection = Connection::open(path)?;
        // WAL: readers never wait for the writer; NORMAL is durable across a process kill
        // (only a power loss may lose the last transactions).
        connection.pragma_update(None, "journal_mode", "WAL")?;
        connection.pragma_update(None, "synchronous", "NORMAL")?;
        connection.busy_timeout(std::time::Duration::from_secs(5))?;
        let mut connection = connection;
        let version: i64 = connection.pragma_query_value(None, "user_version", |r| r.get(0))?;
        if version > SCHEMA_VERSION {
            return Err(StoreError::NewerSchema(version));
        }
        let transaction = connection.transaction()?;
        transaction.execute_batch(SCHEMA)?;
        if version < 2 {
            transaction.execute_batch(TO_VERSION_2)?;
        }
        transaction.pragma_update(None, "user_version", SCHEMA_VERSION)?;
        transaction.commit()?;
        Ok(Self { connection: Arc::new(Mutex::new(connection)) })
    }

    /// Runs `work` on the connection on the blocking pool.
    pub async fn call<T: Send + 'static>(
        &self,
        work: impl FnOnce(&mut Connection) -> Result<T, StoreError> + Send + 'static,
    ) -> Result<T, StoreError> {
        let connection = self.connection.clone();
        tokio::task::spawn_blocking(move || work(&mut connection.lock().unwrap())).await?
    }

    /// Runs `work` on the connection in the calling thread (start-up, tests).
    pub fn now<T>(
        &self,
        work: impl FnOnce(&mut Connection) -> Result<T, StoreError>,
    ) -> Result<T, StoreError> {
        work(&mut self.connection.lock().unwrap())
    }
}

pub fn unix_now() -> i64 {
    let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH);
    now.map_or(0, |d| d.as_secs() as i64)
}

fn status_text(status: Status) -> String {
    serde_json::to_value(status)
        .ok()
        .and_then(|v| v.as_str().map(str::to_owned))
        .unwrap_or_default()
}

/// Keeps what the cost model measured (links, host speeds), replacing the last.
pub fn save_measurements(
    connection: &mut Connection,
    snapshot: &Snapshot,
) -> Result<(), StoreError> {
    connection.execute(
        "INSERT OR REPLACE INTO measurements (only, snapshot) VALUES (1, ?1)",
        params![serde_json::to_string(snapshot)?],
    )?;
    Ok(())
}

/// What the cost model measured before the last stop, if anything.
pub fn load_measurements(connection: &mut Connection) -> Result<Option<Snapshot>, StoreError> {
    let text: Option<String> = connection
        .query_row("SELECT snapshot FROM measurements WHERE only = 1", [], |row| row.get(0))
        .optional()?;
    Ok(text.map(|text| serde_json::from_str(&text)).transpose()?)
}

pub fn insert_run(connection: &mut Connection, run: &StoredRun) -> Result<(), StoreError> {
    let head = RunRecord { workflow: serde_json::Value::Null, ..run.record.clone() };
    connection.execute(
        "INSERT INTO runs (id, seq, created_unix, owner, user, workflow, input, status, record)
         VALUES (?1, (SELECT COALESCE(MAX(seq), 0) + 1 FROM runs), ?2, ?3, ?3, ?4, ?5, ?6, ?7)",
        params![
            run.id,
            unix_now(),
            run.user,
            run.record.workflow.to_string(),
            run.input,
            status_text(run.record.status),
            serde_json::to_string(&head)?,
        ],
    )?;
    Ok(())
}

/// Writes what changed in runs, in one transaction.
pub fn save_runs(connection: &mut Connection, runs: &[Changes]) -> Result<(), StoreError> {
    let transaction = connection.transaction()?;
    {
        let mut head =
            transaction.prepare_cached("UPDATE runs SET status = ?2, record = ?3 WHERE id = ?1")?;
        let mut cut =
            transaction.prepare_cached("DELETE FROM steps WHERE run_id = ?1 AND idx >= ?2")?;
        let mut step = transaction.prepare_cached(
            "INSERT OR REPLACE INTO steps (run_id, idx, step) VALUES (?1, ?2, ?3)",
        )?;
        let mut forget = transaction.prepare_cached("DELETE FROM sessions WHERE run_id = ?1")?;
        let mut keep = transaction.prepare_cached(
            "INSERT OR IGNORE INTO sessions (run_id, host, session) VALUES (?1, ?2, ?3)",
        )?;
        for run in runs {
            let id = &run.head.id;
            head.execute(params![
                id,
                status_text(run.head.status),
                serde_json::to_string(&run.head)?
            ])?;
            cut.execute(params![id, run.step_count as i64])?;
            for changed in &run.steps {
                step.execute(params![id, changed.index as i64, serde_json::to_string(changed)?])?;
            }
            forget.execute([id])?;
            for open in &run.sessions {
                keep.execute(params![id, open.host, open.session])?;
            }
        }
    }
    transaction.commit()?;
    Ok(())
}

/// Every kept run, oldest first.
pub fn load_runs(connection: &mut Connection) -> Result<Vec<StoredRun>, StoreError> {
    let mut statement =
        connection.prepare("SELECT id, user, workflow, input, record FROM runs ORDER BY seq")?;
    let rows = statement.query_map([], |row| {
        Ok((
            row.get::<_, String>(0)?,
            row.get::<_, String>(1)?,
            row.get::<_, String>(2)?,
            row.get::<_, String>(3)?,
            row.get::<_, String>(4)?,
        ))
    })?;
    let rows: Vec<_> = rows.collect::<Result<_, _>>()?;
    let mut sessions =
        connection.prepare("SELECT host, session FROM sessions WHERE run_id = ?1")?;
    let mut steps = connection.prepare("SELECT step FROM steps WHERE run_id = ?1 ORDER BY idx")?;
    let mut runs = Vec::new();
    for (id, user, workflow, input, record) in rows {
        let open = sessions
            .query_map([&id], |row| Ok(OpenSession { host: row.get(0)?, session: row.get(1)? }))?
            .collect::<Result<_, _>>()?;
        let mut record: RunRecord = serde_json::from_str(&record)?;
        record.workflow = serde_json::from_str(&workflow)?;
        record.user = Some(user.clone());
        for step in steps.query_map([&id], |row| row.get::<_, String>(0))? {
            let step: String = step?;
            record.steps.push(serde_json::from_str(&step)?);
        }
        runs.push(StoredRun { id, user, input, record, sessions: open });
    }
    Ok(runs)
}

/// The ids of every stored run.
pub fn run_ids(connection: &mut Connection) -> Result<Vec<String>, StoreError> {
    let mut statement = connection.prepare("SELECT id FROM runs")?;
    let rows = statement.query_map([], |row| row.get(0))?;
    Ok(rows.collect::<Result<_, _>>()?)
}

pub fn delete_run(connection: &mut Connection, id: &str) -> Result<(), StoreError> {
    let transaction = connection.transaction()?;
    transaction.execute("DELETE FROM sessions WHERE run_id = ?1", [id])?;
    transaction.execute("DELETE FROM steps WHERE run_id = ?1", [id])?;
    transaction.execute("DELETE FROM runs WHERE id = ?1", [id])?;
    transaction.commit()?;
    Ok(())
}

pub fn add_host(connection: &mut Connection, url: &str) -> Result<(), StoreError> {
    connection.execute(
        "INSERT OR IGNORE INTO hosts (url, added_unix) VALUES (?1, ?2)",
        params![url, unix_now()],
    )?;
    Ok(())
}

pub fn remove_host(connection: &mut Connection, url: &str) -> Result<(), StoreError> {
    connection.execute("DELETE FROM hosts WHERE url = ?1", [url])?;
    Ok(())
}

pub fn load_hosts(connection: &mut Connection) -> Result<Vec<String>, StoreError> {
    let mut statement = connection.prepare("SELECT url FROM hosts ORDER BY added_unix, url")?;
    let rows = statement.query_map([], |row| row.get(0))?;
    Ok(rows.collect::<Result<_, _>>()?)
}

/// Copies the database at `from` to `to` with SQLite's online backup, page by page, so an
/// engine may go on writing meanwhile; the copy is readable by this user only. `to` is
/// written whole or not at all.
pub fn backup(from: &Path, to: &Path) -> Result<(), StoreError> {
    use rusqlite::OpenFlags;
    // Read-write (a WAL database needs it to read), but never created: a wrong folder fails.
    let source = Connection::open_with_flags(from, OpenFlags::SQLITE_OPEN_READ_WRITE)?;
    source.busy_timeout(std::time::Duration::from_secs(5))?;
    let folder = to.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let file = |source| StoreError::File { path: to.to_owned(), source };
    let partial = tempfile::Builder::new()
        .prefix(".backup-")
        .tempfile_in(folder)
        .map_err(file)?
        .into_temp_path();
    {
        let mut copy = Connection::open(&partial)?;
        let backup = rusqlite::backup::Backup::new(&source, &mut copy)?;
        backup.run_to_completion(256, std::time::Duration::from_millis(10), None)?;
    }
    crate::files::owner_only(&partial, false).map_err(file)?;
    partial.persist(to).map_err(|e| file(e.error))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What schema 1 made of a run: no user column.
    const VERSION_1_RUNS: &str = "
    CREATE TABLE runs (id TEXT PRIMARY KEY, seq INTEGER NOT NULL, created_unix INTEGER NOT NULL,
        owner TEXT NOT NULL, workflow TEXT NOT NULL, input TEXT NOT NULL, status TEXT NOT NULL,
        record TEXT NOT NULL);
    CREATE TABLE batches (id TEXT PRIMARY KEY, seq INTEGER NOT NULL, owner TEXT NOT NULL,
        workflow TEXT NOT NULL, concurrency INTEGER NOT NULL);
    CREATE TABLE inputs (file TEXT PRIMARY KEY, bytes INTEGER NOT NULL,
        stored_unix INTEGER NOT NULL);
    PRAGMA user_version = 1;
    ";

    #[test]
    fn an_older_database_reads_back_its_runs_as_defaults_and_backs_up() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("engine.sqlite3");
        let record = RunRecord::new("r-1".into(), crate::record::Transfer::Full);
        {
            let old = Connection::open(&path).unwrap();
            old.execute_batch(VERSION_1_RUNS).unwrap();
            old.execute(
                "INSERT INTO runs VALUES ('r-1', 1, 0, 'token:abc', '{}', 'http://x/a.ply',
                 'completed', ?1)",
                [serde_json::to_string(&record).unwrap()],
            )
            .unwrap();
            old.execute("INSERT INTO inputs VALUES ('f.ply', 3, 0)", []).unwrap();
        }
        let store = Store::open(&path).unwrap();
        let runs = store.now(load_runs).unwrap();
        assert_eq!(
            (runs[0].user.as_str(), runs[0].record.user.as_deref()),
            ("default", Some("default"))
        );
        assert!(store.now(|c| input_is_users(c, "f.ply", "default")).unwrap());
        let mut new = StoredRun { id: "r-2".into(), user: "anna".into(), ..runs[0].clone() };
        new.record.id = "r-2".into();
        store.now(|c| insert_run(c, &new)).unwrap();

        let copy = dir.path().join("copy.sqlite3");
        backup(&path, &copy).unwrap();
        let restored = Store::open(&copy).unwrap();
        let users: Vec<String> =
            restored.now(load_runs).unwrap().into_iter().map(|run| run.user).collect();
        assert_eq!(users, ["default", "anna"]);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            for file in [&path, &copy] {
                let mode = std::fs::metadata(file).unwrap().permissions().mode() & 0o777;
                assert_eq!(mode, 0o600, "{}", file.display());
            }
        }
        assert!(backup(&dir.path().join("missing.sqlite3"), &copy).is_err());
    }
}
