//! Batches: one workflow over many inputs (`POST /batches`). The workflow is checked once;
//! each input becomes a run of its own, at most [`MAX_BATCH_RUNS_AT_ONCE`] going at a time, so
//! one failing input never stops the others. Batches live in the store, so a restart goes
//! on with the inputs not yet started (the runs in flight resume by themselves).

use std::sync::Arc;

use crate::batch_drivers::{CANCELLED_ENTRY, Driver};
use crate::engine::{Engine, SubmitError, new_run_id};
use crate::limits::{
    BATCH_POLL, CANCEL_WAIT, MAX_ACTIVE_BATCHES_PER_USER, MAX_BATCH_INPUTS, MAX_BATCH_RUNS_AT_ONCE,
};
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
        let id = new_batch_id();
        let driver = self
            .batch_drivers
            .add(&id, user, MAX_ACTIVE_BATCHES_PER_USER)
            .ok_or(SubmitError::TooManyBatches(MAX_ACTIVE_BATCHES_PER_USER))?;
        let batch = StoredBatch {
            id: id.clone(),
            user: user.to_owned(),
            workflow: workflow_json,
            concurrency: concurrency
                .unwrap_or(MAX_BATCH_RUNS_AT_ONCE)
                .clamp(1, MAX_BATCH_RUNS_AT_ONCE),
            entries,
        };
        let row = batch.clone();
        if let Err(error) = self.store.call(move |c| store::insert_batch(c, &row)).await {
            self.batch_drivers.remove(&id);
            return Err(error.into());
        }
        tokio::spawn(drive(self.clone(), batch, driver));
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
        let cancelled = batch.entries.iter().any(|e| e.error.as_deref() == Some(CANCELLED_ENTRY));
        let status = match (finished, cancelled) {
            (false, _) => "running",
            (true, false) => "completed",
            (true, true) => "cancelled",
        };
        Ok(Some(BatchStatus { id: batch.id, status: status.into(), entries: batch.entries, rows }))
    }

    /// An input's row: its run's, or why it has none.
    fn row(&self, name: &str, entry: &BatchEntry, finished: &mut bool) -> SummaryRow {
        if let Some(error) = &entry.error {
            let mut row = summary::failed_row(name, error.clone());
            if error == CANCELLED_ENTRY {
                row.status = "cancelled".into();
            }
            return row;
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
                        let driver = self.batch_drivers.resume(&batch.id, &batch.user);
                        tokio::spawn(drive(self.clone(), batch, driver));
                    }
                }
            }
            Err(error) => tracing::error!("reading batches: {error}"),
        }
    }
}

/// Starts a run per input in order, keeping at most its concurrency going; a client
/// over its run limit waits. Each start (or refusal) is stored before the next. Cancelled,
/// it starts no more (the inputs left are stored as [`CANCELLED_ENTRY`]) and cancels the
/// runs going. It ends once every run has, so the batch counts against its user till then.
async fn drive(engine: Arc<Engine>, batch: StoredBatch, driver: Driver) {
    let mut entries = batch.entries;
    let stop = &driver.cancel;
    for index in 0..entries.len() {
        if entries[index].run.is_some() || entries[index].error.is_some() {
            continue;
        }
        while !stop.is_cancelled() && going(&engine, &entries) >= batch.concurrency {
            pause(stop).await;
        }
        let outcome = loop {
            if stop.is_cancelled() {
                break None;
            }
            let input = Some(entries[index].input.clone());
            match engine.submit(batch.workflow.clone(), input, &batch.user).await {
                Err(SubmitError::Busy(_)) => pause(stop).await,
                other => break Some(other),
            }
        };
        match outcome {
            Some(Ok(run)) => {
                // Cancelled while it was being started: it stops at once.
                if stop.is_cancelled() {
                    run.cancel();
                }
                entries[index].run = Some(run.id.clone())
            }
            Some(Err(error)) => entries[index].error = Some(error.to_string()),
            None => entries[index].error = Some(CANCELLED_ENTRY.into()),
        }
        let (id, entry) = (batch.id.clone(), entries[index].clone());
        if let Err(error) =
            engine.store.call(move |c| store::set_batch_entry(c, &id, index, &entry)).await
        {
            tracing::error!("saving batch {}: {error}", batch.id);
        }
    }
    driver.done.cancel();
    while !stop.is_cancelled() && going(&engine, &entries) > 0 {
        pause(stop).await;
    }
    engine.batch_drivers.remove(&batch.id);
}

/// [`BATCH_POLL`], or less if the batch is cancelled meanwhile.
async fn pause(stop: &tokio_util::sync::CancellationToken) {
    tokio::select! {
        () = tokio::time::sleep(BATCH_POLL) => {}
        () = stop.cancelled() => {}
    }
}

impl Engine {
    /// `POST /batches/{id}/cancel`: no more of the batch's runs start and those going are
    /// cancelled; the batch as it then stands (none for an unknown id or another user's).
    pub async fn cancel_batch(
        &self,
        id: &str,
        user: &User,
    ) -> Result<Option<BatchStatus>, SubmitError> {
        if self.batch(id, user).await?.is_none() {
            return Ok(None);
        }
        if let Some(driver) = self.batch_drivers.get(id) {
            driver.cancel.cancel();
            // Its inputs not started are stored as cancelled before it says it is done.
            let _ = tokio::time::timeout(CANCEL_WAIT, driver.done.cancelled()).await;
        }
        let only = id.to_owned();
        let found = self.store.call(move |c| store::load_batches(c, Some(&only))).await?.pop();
        let runs: Vec<_> = found
            .iter()
            .flat_map(|batch| &batch.entries)
            .filter_map(|entry| entry.run.as_ref().and_then(|run| self.run(run)))
            .filter(|run| !run.is_finished())
            .collect();
        runs.iter().for_each(|run| run.cancel());
        for run in &runs {
            crate::routes::ended(run).await;
        }
        self.batch(id, user).await
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
