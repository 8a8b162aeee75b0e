//! Uploaded inputs in the store: their names and who uploaded them.

use rusqlite::{Connection, OptionalExtension, params};

use super::{StoreError, unix_now};

/// Records an uploaded input, the name it was uploaded under (the last name wins when the
/// same bytes come again), which downloads are named after, and that `user` uploaded it.
pub fn add_input(
    connection: &mut Connection,
    file: &str,
    name: &str,
    bytes: u64,
    user: &str,
) -> Result<(), StoreError> {
    connection.execute(
        "INSERT INTO inputs (file, bytes, stored_unix) VALUES (?1, ?2, ?3)
         ON CONFLICT (file) DO UPDATE SET stored_unix = excluded.stored_unix",
        params![file, bytes as i64, unix_now()],
    )?;
    connection.execute(
        "INSERT INTO input_names (file, name) VALUES (?1, ?2)
         ON CONFLICT (file) DO UPDATE SET name = excluded.name",
        params![file, name],
    )?;
    connection.execute(
        "INSERT OR IGNORE INTO input_users (file, user) VALUES (?1, ?2)",
        params![file, user],
    )?;
    Ok(())
}

/// Whether `user` uploaded the input `file`.
pub fn input_is_users(
    connection: &mut Connection,
    file: &str,
    user: &str,
) -> Result<bool, StoreError> {
    let mut statement =
        connection.prepare_cached("SELECT 1 FROM input_users WHERE file = ?1 AND user = ?2")?;
    Ok(statement.exists(params![file, user])?)
}

/// The name an input was uploaded under.
pub fn input_name(connection: &mut Connection, file: &str) -> Result<Option<String>, StoreError> {
    let mut statement = connection.prepare("SELECT name FROM input_names WHERE file = ?1")?;
    Ok(statement.query_row([file], |row| row.get(0)).optional()?)
}

/// Upload names by input file.
pub type InputNames = std::collections::HashMap<String, String>;

/// The names the given files were uploaded under, for those that were (one transaction for
/// a whole batch's table).
pub fn input_names(
    connection: &mut Connection,
    files: &[String],
) -> Result<InputNames, StoreError> {
    let mut statement =
        connection.prepare_cached("SELECT name FROM input_names WHERE file = ?1")?;
    let mut names = InputNames::new();
    for file in files {
        if let Some(name) = statement.query_row([file], |row| row.get(0)).optional()? {
            names.insert(file.clone(), name);
        }
    }
    Ok(names)
}

/// Inputs stored before `before` that no kept run names (by their file name in its input
/// URL); they are removed from the table and returned for deletion from disk.
pub fn take_unused_inputs(
    connection: &mut Connection,
    before: i64,
) -> Result<Vec<String>, StoreError> {
    let transaction = connection.transaction()?;
    let files: Vec<String> = {
        let mut statement = transaction.prepare(
            "SELECT file FROM inputs WHERE stored_unix < ?1 AND NOT EXISTS
             (SELECT 1 FROM runs WHERE runs.input LIKE '%/inputs/' || inputs.file)
             AND NOT EXISTS (SELECT 1 FROM batch_entries WHERE batch_entries.run_id IS NULL
               AND batch_entries.error IS NULL
               AND batch_entries.input LIKE '%/inputs/' || inputs.file)",
        )?;
        let rows = statement.query_map([before], |row| row.get(0))?;
        rows.collect::<Result<_, _>>()?
    };
    for file in &files {
        transaction.execute("DELETE FROM inputs WHERE file = ?1", [file])?;
        transaction.execute("DELETE FROM input_names WHERE file = ?1", [file])?;
        transaction.execute("DELETE FROM input_users WHERE file = ?1", [file])?;
    }
    transaction.commit()?;
    Ok(files)
}
