//! Talking to an engine from the command line: upload the input, submit the workflow,
//! follow its progress, fetch the record and the result.

use crate::output::out;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, bail};
use clap::ValueEnum;
use futures_util::StreamExt;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use meshflow_api::EngineClient;
use meshflow_api::engine::{RunRecord, Status, StepRecord, SubmitRun};
use serde_json::{Value as Json, json};

use super::options::RunOutputArgs;

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum TransferMode {
    /// Per receiving host, the way the cost model expects to be quickest.
    Auto,
    /// The edit log.
    Correction,
    /// The step re-run on the receiver (the edit log as fallback).
    Replay,
    /// The whole mesh, packed.
    Full,
}

pub struct Submission {
    pub engine: EngineClient,
    pub workflow: PathBuf,
    pub input: Option<String>,
    pub transfer: Option<TransferMode>,
    pub out: RunOutputArgs,
}

impl Submission {
    pub async fn execute(self, wait: bool) -> anyhow::Result<()> {
        let workflow = self.read_workflow()?;
        if !wait {
            let id = self.start(workflow).await?;
            match self.out.json {
                true => out!("{}", json!({"id": id})),
                false => out!("{id}"),
            }
            return Ok(());
        }
        let record = self.run_to_end(workflow).await?;
        self.deliver(&record).await
    }

    /// Uploads the input if it is a file, submits `workflow`; returns the run's id.
    async fn start(&self, workflow: Json) -> anyhow::Result<String> {
        let engine = &self.engine;
        let input = match &self.input {
            Some(url) if url.starts_with("http://") || url.starts_with("https://") => {
                Some(url.clone())
            }
            Some(file) => Some(upload_input(engine, Path::new(file)).await?),
            None => None,
        };
        let submitted = engine
            .submit(&SubmitRun { workflow, input })
            .await
            .context("the engine refused the workflow")?;
        Ok(submitted.id)
    }

    /// Runs `workflow`, following its progress, and returns its record (written to
    /// `report` if asked), however the run ended.
    pub async fn run_to_end(&self, workflow: Json) -> anyhow::Result<RunRecord> {
        let id = self.start(workflow).await?;
        follow(&self.engine, &id, !self.out.json).await?;
        let record = self.engine.run(&id).await?;
        if let Some(path) = &self.out.report {
            let text = serde_json::to_string_pretty(&record)?;
            super::pack::write_atomically(path, text.as_bytes())?;
        }
        Ok(record)
    }

    /// A completed run's result to `output`, and its summary (or record, `--json`); an
    /// error for a run that did not complete.
    async fn deliver(&self, record: &RunRecord) -> anyhow::Result<()> {
        self.save_result(record).await?;
        match self.out.json {
            true => out!("{}", serde_json::to_string_pretty(record)?),
            false => print_summary(record, self.out.output.as_deref()),
        }
        Ok(())
    }

    /// Writes a completed run's verified result to `output`, if one was asked for.
    pub async fn save_result(&self, record: &RunRecord) -> anyhow::Result<()> {
        if record.status != Status::Completed {
            let status = json!(record.status);
            let reason = record.error.as_deref().unwrap_or("no reason given");
            bail!("run {} {}: {reason}", record.id, status.as_str().unwrap_or("ended"));
        }
        if let Some(path) = &self.out.output {
            VerifiedResult::download(&self.engine, record).await?.save(path)?;
        }
        Ok(())
    }

    /// The workflow file as JSON, with `--transfer` applied.
    pub fn read_workflow(&self) -> anyhow::Result<Json> {
        let name = self.workflow.display();
        let text =
            std::fs::read_to_string(&self.workflow).with_context(|| format!("reading {name}"))?;
        let mut workflow: Json =
            serde_json::from_str(&text).with_context(|| format!("{name} is not valid JSON"))?;
        if let Some(mode) = self.transfer {
            let mode = format!("{mode:?}").to_lowercase();
            if workflow.is_array() {
                workflow = json!({"steps": workflow});
            }
            if let Some(object) = workflow.as_object_mut() {
                object.insert("transfer".into(), mode.into());
            }
        }
        Ok(workflow)
    }
}

/// A run's final mesh as the engine served it (`.mfm` bytes) and decoded, its content
/// hash checked against the record.
pub(super) struct VerifiedResult {
    packed: Vec<u8>,
    mesh: meshflow_mesh::MeshData,
}

impl VerifiedResult {
    /// Downloads and decodes the run's final mesh; it must be the mesh the record names
    /// (`result.hash`): whoever serves it is trusted no further than that.
    pub(super) async fn download(
        engine: &EngineClient,
        record: &RunRecord,
    ) -> anyhow::Result<Self> {
        let expected = &record.result.as_ref().context("the run record names no result")?.hash;
        let packed = engine.result(&record.id).await?;
        let mesh = meshflow_codec::pack::decode(&packed).context("decoding the result")?;
        let actual = mesh.content_hash().to_hex();
        if &actual != expected {
            bail!(
                "the result downloaded for run {} is mesh {actual}, not the recorded {expected}; \
                 nothing was written",
                record.id
            );
        }
        Ok(Self { packed, mesh })
    }

    /// Writes the mesh in the format `path` names; a `.mfm` as it was received.
    pub(super) fn save(&self, path: &Path) -> anyhow::Result<()> {
        match super::pack::is_packed(path) {
            true => super::pack::write_atomically(path, &self.packed),
            false => super::pack::save_mesh(path, &self.mesh),
        }
    }
}

pub(super) async fn upload_input(engine: &EngineClient, path: &Path) -> anyhow::Result<String> {
    // A missing or wrong token is told before any upload: the engine refuses an upload
    // from its headers and closes the connection while a large body is still being sent,
    // which can reset it before the client reads the refusal.
    engine.services().await.with_context(|| format!("reaching {}", engine.base_url()))?;
    let bytes =
        tokio::fs::read(path).await.with_context(|| format!("reading {}", path.display()))?;
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("input");
    let uploaded = engine
        .upload_input(name, bytes)
        .await
        .with_context(|| format!("uploading {} to {}", path.display(), engine.base_url()))?;
    Ok(uploaded.url)
}

/// How long `follow` keeps trying to reach the engine again after losing it (an engine
/// restart takes seconds; the run resumes there).
const RECONNECT_FOR: Duration = Duration::from_secs(120);
const RECONNECT_PAUSE: Duration = Duration::from_secs(1);

/// Follows the run's events until it ends and settles, with a line per finished step. A dropped
/// connection is re-attached: the engine starts every stream with the whole record, so
/// nothing is missed.
async fn follow(engine: &EngineClient, id: &str, show: bool) -> anyhow::Result<()> {
    let bars = MultiProgress::new();
    if !show {
        bars.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let status = bars.add(ProgressBar::new_spinner());
    status.set_style(ProgressStyle::with_template("{spinner} {msg} [{elapsed}]")?);
    status.enable_steady_tick(Duration::from_millis(100));
    status.set_message(format!("run {id}: starting"));
    let mut shown = Shown::default();
    let mut lost_since: Option<std::time::Instant> = None;
    loop {
        let ended = match engine.events(id).await {
            Ok(answer) => {
                lost_since = None;
                watch(answer, id, &bars, &status, &mut shown).await
            }
            Err(error) if error.is_host_failure() => Err(error.into()),
            Err(error) => return Err(error.into()),
        };
        match ended {
            Ok(true) => break,
            Ok(false) => {}
            Err(error) => {
                let since = *lost_since.get_or_insert_with(std::time::Instant::now);
                if since.elapsed() > RECONNECT_FOR {
                    return Err(error.context(format!("lost the engine for {RECONNECT_FOR:?}")));
                }
                status.set_message(format!("run {id}: reconnecting ({error:#})"));
            }
        }
        tokio::time::sleep(RECONNECT_PAUSE).await;
    }
    status.finish_and_clear();
    Ok(())
}

/// What `follow` has printed already, so a re-attached stream does not repeat it.
#[derive(Default)]
struct Shown {
    broadcast: bool,
    steps: usize,
}

/// Reads one event stream; true when the run ended, false when the stream closed early.
async fn watch(
    answer: reqwest::Response,
    id: &str,
    bars: &MultiProgress,
    status: &ProgressBar,
    shown: &mut Shown,
) -> anyhow::Result<bool> {
    let mut events = answer.bytes_stream();
    let mut buffer = String::new();
    while let Some(chunk) = events.next().await {
        buffer.push_str(&String::from_utf8_lossy(&chunk?));
        while let Some(end) = buffer.find("\n\n") {
            let block: String = buffer.drain(..end + 2).collect();
            let (kind, data) = parse_event(&block);
            let Ok(data) = serde_json::from_str::<Json>(&data) else { continue };
            let mut show = |broadcast: Option<&Json>, steps: &[StepRecord], state| {
                show(bars, status, shown, id, broadcast, steps, state)
            };
            let ended = match kind.as_str() {
                // The whole record, first on every stream: what is new in it is shown.
                "record" => {
                    let Ok(record) = serde_json::from_value::<RunRecord>(data) else { continue };
                    let broadcast = record.broadcast.as_ref().map(|b| json!(b));
                    show(broadcast.as_ref(), &record.steps, Some(record.status));
                    record.is_settled()
                }
                "broadcast" => {
                    show(Some(&data), &[], None);
                    false
                }
                "step" => {
                    let Ok(step) = serde_json::from_value::<StepRecord>(data) else { continue };
                    show(None, &[step], None);
                    false
                }
                // A completed run goes on until its result is packed where it is held.
                "status" => {
                    let state = serde_json::from_value::<Status>(data["status"].clone()).ok();
                    show(None, &[], state);
                    state.is_some_and(|state| state.is_final() && state != Status::Completed)
                }
                "settled" => true,
                _ => false,
            };
            if ended {
                return Ok(true);
            }
        }
    }
    Ok(false)
}

/// Prints the broadcast and the steps not shown yet, and the run's state.
fn show(
    bars: &MultiProgress,
    status: &ProgressBar,
    shown: &mut Shown,
    id: &str,
    broadcast: Option<&Json>,
    steps: &[StepRecord],
    state: Option<Status>,
) {
    if let Some(data) = broadcast.filter(|_| !shown.broadcast) {
        let line = format!(
            "input on {} hosts in {:.0} ms",
            data["hosts"].as_array().map_or(0, Vec::len),
            data["ms"].as_f64().unwrap_or(0.0)
        );
        finished_bar(bars, status, line);
        shown.broadcast = true;
    }
    for step in steps {
        if step.index >= shown.steps {
            finished_bar(bars, status, step_line(step));
            shown.steps = step.index + 1;
        }
    }
    if let Some(state) = state {
        status.set_message(format!("run {id}: {}", json!(state).as_str().unwrap_or("")));
    }
}

fn finished_bar(bars: &MultiProgress, status: &ProgressBar, line: String) {
    let bar = bars.insert_before(status, ProgressBar::new(1));
    if let Ok(style) = ProgressStyle::with_template("  [{bar:10}] {msg}") {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(line);
    bar.finish();
}

/// `event:` and `data:` of one server-sent event block.
fn parse_event(block: &str) -> (String, String) {
    let (mut kind, mut data) = (String::from("message"), String::new());
    for line in block.lines() {
        if let Some(value) = line.strip_prefix("event:") {
            kind = value.trim().to_owned();
        } else if let Some(value) = line.strip_prefix("data:") {
            data.push_str(value.strip_prefix(' ').unwrap_or(value));
        }
    }
    (kind, data)
}

fn step_line(step: &StepRecord) -> String {
    let mut line =
        format!("{} {} on {} — {:.0} ms", step.path, step.service, step.host, step.compute_ms);
    if let Some(bytes) = step.correction_bytes {
        let about = if step.correction_estimated { "about " } else { "" };
        line.push_str(&format!(", correction {about}{:.1} KB", bytes as f64 / 1024.0));
    }
    if let Some(value) = &step.value {
        line.push_str(&format!(", value {value}"));
    }
    line
}

fn print_summary(record: &RunRecord, output: Option<&Path>) {
    if let Some(broadcast) = &record.broadcast {
        out!("input broadcast to {} hosts in {:.0} ms", broadcast.hosts.len(), broadcast.ms);
    }
    // Plugins fetched beside the broadcast; those already there are not news.
    for prefetch in record.prefetches.iter().filter(|p| p.outcome != "present") {
        let digest: String = prefetch.plugin.chars().take(12).collect();
        let error = prefetch.error.as_deref().map(|e| format!(": {e}")).unwrap_or_default();
        out!(
            "plugin {digest} prefetched by {}: {} in {:.0} ms{error}",
            prefetch.host,
            prefetch.outcome,
            prefetch.ms
        );
    }
    for step in &record.steps {
        let transfers: Vec<String> = step
            .transfers
            .iter()
            .map(|t| {
                let kb = t.bytes as f64 / 1024.0;
                let waited = match t.plugin_wait_ms {
                    Some(ms) if ms >= 1.0 => format!(" (waited {ms:.0} ms for its plugin)"),
                    _ => String::new(),
                };
                format!("{} {kb:.1} KB in {:.0} ms{waited}", t.via, t.finished_ms - t.started_ms)
            })
            .collect();
        let forwarded = match transfers.is_empty() {
            true => String::new(),
            false => format!("; sent on: {}", transfers.join(", ")),
        };
        out!("  {}{forwarded}", step_line(step));
    }
    if let Some(result) = &record.result {
        out!(
            "run {} completed: {} steps in {:.2} s; result {} vertices, {} triangles, hash {}",
            record.id,
            record.steps.len(),
            record.total_ms.unwrap_or(0.0) / 1e3,
            result.vertices,
            result.triangles,
            result.hash
        );
    }
    for warning in &record.warnings {
        out!("warning: {warning}");
    }
    for dropped in record.input.iter().flat_map(|input| &input.not_kept) {
        out!("warning: the input's {dropped} was not kept");
    }
    let last_filter = record.steps.iter().rev().find(|s| s.kind == "filter");
    let carried: &[String] = match last_filter {
        Some(step) => &step.attributes,
        None => record.input.as_ref().map_or(&[], |input| &input.attributes),
    };
    if record.result.is_some() && !carried.is_empty() {
        out!("the result carries {}", carried.join(", "));
    }
    if let Some(path) = output {
        out!("wrote {}", path.display());
    }
}
