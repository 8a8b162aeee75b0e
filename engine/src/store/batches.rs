//! Batches in the store: their workflow and each input's run or error.

use rusqlite::{Connection, params};

use super::StoreError;
use crate::record::BatchEntry;

/// A batch as stored: its workflow and each input's run or error.
#[derive(Debug, Clone)]
pub struct StoredBatch {
    pub id: String,
    /// The user whose batch it is.
    pub user: String,
    pub workflow: serde_json::Value,
    /// How many of its runs may go at once.
    pub concurrency: usize,
    pub entries: Vec<BatchEntry>,
}

pub fn insert_batch(connection: &mut Connection, batch: &StoredBatch) -> Result<(), StoreError> {
    let transaction = connection.transaction()?;
    transaction.execute(
        "INSERT INTO batches (id, seq, owner, user, workflow, concurrency)
         VALUES (?1, (SELECT COALESCE(MAX(seq), 0) + 1 FROM batches), ?2, ?2, ?3, ?4)",
        params![
            batch.id,
            batch.user,
            serde_json::to_string(&batch.workflow)?,
            batch.concurrency as i64
        ],
    )?;
    for (index, entry) in batch.entries.iter().enumerate() {
        transaction.execute(
            "INSERT INTO batch_entries (batch_id, idx, input, run_id, error) VALUES (?1, ?2, ?3, ?4, ?5)",
            params![batch.id, index as i64, entry.input, entry.run, entry.error],
        )?;
    }
    transaction.commit()?;
    Ok(())
}

/// Records the run an entry became, or why it did not.
pub fn set_batch_entry(
    connection: &mut Connection,
    batch_id: &str,
    index: usize,
    entry: &BatchEntry,
) -> Result<(), StoreError> {
    connection.execute(
        "UPDATE batch_entries SET run_id = ?3, error = ?4 WHERE batch_id = ?1 AND idx = ?2",
        params![batch_id, index as i64, entry.run, entry.error],
    )?;
    Ok(())
}

/// Every batch, oldest first, or the one with `only` as its id.
pub fn load_batches(
    connection: &mut Connection,
    only: Option<&str>,
) -> Result<Vec<StoredBatch>, StoreError> {
    let mut statement = connection.prepare(
        "SELECT id, user, workflow, concurrency FROM batches WHERE ?1 IS NULL OR id = ?1
         ORDER BY seq",
    )?;
    let heads: Vec<(String, String, String, i64)> = statement
        .query_map([only], |row| Ok((row.get(0)?, row.get(1)?, row.get(2)?, row.get(3)?)))?
        .collect::<Result<_, _>>()?;
    let mut entries_of = connection.prepare(
        "SELECT input, run_id, error FROM batch_entries WHERE batch_id = ?1 ORDER BY idx",
    )?;
    let mut batches = Vec::with_capacity(heads.len());
    for (id, user, workflow, concurrency) in heads {
        let rows = entries_of.query_map([&id], |row| {
            Ok(BatchEntry { input: row.get(0)?, run: row.get(1)?, error: row.get(2)? })
        })?;
        let entries = rows.collect::<Result<_, _>>()?;
        let workflow = serde_json::from_str(&workflow)?;
        let concurrency = concurrency.max(1) as usize;
        batches.push(StoredBatch { id, user, workflow, concurrency, entries });
    }
    Ok(batches)
}
