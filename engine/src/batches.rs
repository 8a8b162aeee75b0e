//! Batches: one workflow over many inputs (`POST /batches`). The workflow is checked once;
//! each input becomes a run of its own, at most [`MAX_BATCH_RUNS_AT_ONCE`] going at a time, so
//! one failing input never stops the others. Batches live in the store, so a restart goes
//! on with the inputs not yet started (the runs in flight resume by themselves).

use std::sync::Arc;

use crate::engine::{Engine, SubmitError, new_run_id};
use crate::limits::{BATCH_POLL, MAX_BATCH_INPUTS, MAX_BATCH_RUNS_AT_ONCE};
use crate::record::{BatchEntry, BatchStatus, SubmitBatch, SummaryRow};
use crate::store::{self, StoredBatch};
use crate::users::User;
use crate::workflow::{Workflow, WorkflowError};
use crate::{summary, validate};

impl Engine {
    /// Checks the workflow and every input's origin, stores the batch and starts it; an
    /// input the engine will not fetch is recorded as failed, the others run.
    pub async fn submit_batch(
        self: &Arc<Self>,
        request: SubmitBatch,
        user: &str,
    ) -> Result<BatchStatus, SubmitError> {
        let SubmitBatch { workflow: workflow_json, inputs, concurrency } = request;
        if inputs.is_empty() || inputs.len() > MAX_BATCH_INPUTS {
            let message =
                format!("a batch has 1 to {MAX_BATCH_INPUTS} inputs, not {}", inputs.len());
            return Err(WorkflowError::new("inputs", message).into());
        }
        let mut workflow = Workflow::from_json(&workflow_json)?;
        validate::validate(&mut workflow, &*self.registry)?;
        let hosts: Vec<String> = self.registry.hosts().iter().map(|h| h.url.clone()).collect();
        let entries = inputs
            .into_iter()
            .map(|input| {
                let refused =
                    self.access.check_input(&input, &self.public_url, hosts.iter().cloned());
                BatchEntry { error: refused.err().map(|e| format!("input: {e}")), input, run: None }
            })
            .collect();
        let batch = StoredBatch {
            id: new_batch_id(),
            user: user.to_owned(),
            workflow: workflow_json,
            concurrency: concurrency
                .unwrap_or(MAX_BATCH_RUNS_AT_ONCE)
                .clamp(1, MAX_BATCH_RUNS_AT_ONCE),
            entries,
        };
        let row = batch.clone();
        self.store.call(move |c| store::insert_batch(c, &row)).await?;
        let id = batch.id.clone();
        tokio::spawn(drive(self.clone(), batch));
        let owner = User { name: user.to_owned(), role: crate::users::Role::User };
        Ok(self.batch(&id, &owner).await?.expect("the batch was just stored"))
    }

    /// A batch's entries and summary rows as they stand; none for an unknown id or another
    /// user's batch (an admin sees every batch).
    pub async fn batch(&self, id: &str, user: &User) -> Result<Option<BatchStatus>, SubmitError> {
        let only = id.to_owned();
        let found = self.store.call(move |c| store::load_batches(c, Some(&only))).await?.pop();
        let Some(batch) = found.filter(|batch| user.may_see(&batch.user)) else {
            return Ok(None);
        };
        let files: Vec<String> =
            batch.entries.iter().map(|e| file_of(&e.input).to_owned()).collect();
        let lookup = files.clone();
        let names = self.store.call(move |c| store::input_names(c, &lookup)).await?;
        let mut finished = true;
        let rows = batch
            .entries
            .iter()
            .zip(&files)
            .map(|(entry, file)| {
                let name = names.get(file).unwrap_or(file);
                self.row(name, entry, &mut finished)
            })
            .collect();
        let status = if finished { "completed" } else { "running" };
        Ok(Some(BatchStatus { id: batch.id, status: status.into(), entries: batch.entries, rows }))
    }

    /// An input's row: its run's, or why it has none.
    fn row(&self, name: &str, entry: &BatchEntry, finished: &mut bool) -> SummaryRow {
        if let Some(error) = &entry.error {
            return summary::failed_row(name, error.clone());
        }
        let Some(run) = entry.run.as_ref().and_then(|id| self.run(id)) else {
            *finished &= entry.run.is_some();
            let mut row = summary::failed_row(name, String::new());
            row.status = if entry.run.is_some() { "forgotten" } else { "waiting" }.into();
            row.error = entry.run.as_ref().map(|id| format!("run {id} is no longer kept"));
            return row;
        };
        let record = run.record();
        *finished &= record.status.is_final();
        summary::row(name, &record)
    }

    /// Goes on with every stored batch that has inputs not yet started.
    pub(crate) async fn resume_batches(self: &Arc<Self>) {
        match self.store.call(|c| store::load_batches(c, None)).await {
            Ok(batches) => {
                for batch in batches {
                    if batch.entries.iter().any(|e| e.run.is_none() && e.error.is_none()) {
                        tracing::info!("resuming batch {}", batch.id);
                        tokio::spawn(drive(self.clone(), batch));
                    }
                }
            }
            Err(error) => tracing::error!("reading batches: {error}"),
        }
    }
}

/// Starts a run per input in order, keeping at most its concurrency going; a client
/// over its run limit waits. Each start (or refusal) is stored before the next.
async fn drive(engine: Arc<Engine>, batch: StoredBatch) {
    let mut entries = batch.entries;
    for index in 0..entries.len() {
        if entries[index].run.is_some() || entries[index].error.is_some() {
            continue;
        }
        while going(&engine, &entries) >= batch.concurrency {
            tokio::time::sleep(BATCH_POLL).await;
        }
        let input = Some(entries[index].input.clone());
        let outcome = loop {
            match engine.submit(batch.workflow.clone(), input.clone(), &batch.user).await {
                Err(SubmitError::Busy(_)) => tokio::time::sleep(BATCH_POLL).await,
                other => break other,
            }
        };
        match outcome {
            Ok(run) => entries[index].run = Some(run.id.clone()),
            Err(error) => entries[index].error = Some(error.to_string()),
        }
        let (id, entry) = (batch.id.clone(), entries[index].clone());
        if let Err(error) =
            engine.store.call(move |c| store::set_batch_entry(c, &id, index, &entry)).await
        {
            tracing::error!("saving batch {}: {error}", batch.id);
        }
    }
}

/// The batch's runs that have not ended.
fn going(engine: &Engine, entries: &[BatchEntry]) -> usize {
    let unfinished = |id: &String| engine.run(id).is_some_and(|run| !run.is_finished());
    entries.iter().filter_map(|e| e.run.as_ref()).filter(|id| unfinished(id)).count()
}

/// The last segment of an input URL: the stored file of an uploaded input.
fn file_of(url: &str) -> &str {
    url.rsplit('/').next().unwrap_or(url)
}

fn new_batch_id() -> String {
    format!("b-{}", new_run_id())
}
