//! Talking to an engine from the command line: upload the input, submit the workflow,
//! follow its progress, fetch the record and the result.

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, bail};
use clap::ValueEnum;
use futures_util::StreamExt;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use serde_json::{Value as Json, json};

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum TransferMode {
    Auto,
    Correction,
    Full,
}

pub struct Submission {
    pub engine: String,
    pub workflow: PathBuf,
    pub input: Option<String>,
    pub transfer: Option<TransferMode>,
    pub output: Option<PathBuf>,
    pub report: Option<PathBuf>,
    pub json: bool,
}

impl Submission {
    pub async fn execute(self, wait: bool) -> anyhow::Result<()> {
        let http = reqwest::Client::new();
        let workflow = self.read_workflow()?;
        let input = match &self.input {
            Some(url) if url.starts_with("http://") || url.starts_with("https://") => {
                Some(url.clone())
            }
            Some(file) => Some(upload_input(&http, &self.engine, Path::new(file)).await?),
            None => None,
        };
        let answer = http
            .post(format!("{}/runs", self.engine))
            .json(&json!({"workflow": workflow, "input": input}))
            .send()
            .await
            .with_context(|| format!("submitting to {}", self.engine))?;
        let body = json_body(answer).await.context("the engine refused the workflow")?;
        let id = body["id"].as_str().context("the engine gave no run id")?.to_owned();
        if !wait {
            match self.json {
                true => println!("{}", json!({"id": id})),
                false => println!("{id}"),
            }
            return Ok(());
        }
        follow(&http, &self.engine, &id, !self.json).await?;
        let record =
            json_body(http.get(format!("{}/runs/{id}", self.engine)).send().await?).await?;
        if let Some(path) = &self.report {
            let text = serde_json::to_string_pretty(&record)?;
            crate::commands::pack::write_atomically(path, text.as_bytes())?;
        }
        if record["status"] != "completed" {
            bail!("run {id} failed: {}", record["error"].as_str().unwrap_or("no reason given"));
        }
        if let Some(path) = &self.output {
            let bytes = download(&http, &format!("{}/runs/{id}/result", self.engine)).await?;
            let mesh = meshflow_codec::pack::decode(&bytes).context("decoding the result")?;
            crate::commands::pack::save_mesh(path, &mesh)?;
        }
        match self.json {
            true => println!("{}", serde_json::to_string_pretty(&record)?),
            false => print_summary(&record, self.output.as_deref()),
        }
        Ok(())
    }

    /// The workflow file as JSON, with `--transfer` applied.
    fn read_workflow(&self) -> anyhow::Result<Json> {
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

async fn upload_input(http: &reqwest::Client, engine: &str, path: &Path) -> anyhow::Result<String> {
    let bytes =
        tokio::fs::read(path).await.with_context(|| format!("reading {}", path.display()))?;
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("input");
    let answer = http
        .post(format!("{engine}/inputs"))
        .query(&[("name", name)])
        .body(bytes)
        .send()
        .await
        .with_context(|| format!("uploading {} to {engine}", path.display()))?;
    let body = json_body(answer).await.with_context(|| format!("uploading {}", path.display()))?;
    Ok(body["url"].as_str().context("the engine gave no input URL")?.to_owned())
}

/// The JSON body of a successful answer, or the engine's error message.
async fn json_body(answer: reqwest::Response) -> anyhow::Result<Json> {
    let status = answer.status();
    let body: Json = answer.json().await.context("the answer is not JSON")?;
    if !status.is_success() {
        let message = body["error"]["message"].as_str().unwrap_or("no message");
        bail!("{status}: {message}");
    }
    Ok(body)
}

async fn download(http: &reqwest::Client, url: &str) -> anyhow::Result<Vec<u8>> {
    let answer = http.get(url).send().await.with_context(|| format!("fetching {url}"))?;
    if !answer.status().is_success() {
        let status = answer.status();
        let body: Json = answer.json().await.unwrap_or_default();
        bail!("{url}: {status}: {}", body["error"]["message"].as_str().unwrap_or(""));
    }
    Ok(answer.bytes().await?.to_vec())
}

/// Follows the run's events until it ends, with a line per finished step.
async fn follow(http: &reqwest::Client, engine: &str, id: &str, show: bool) -> anyhow::Result<()> {
    let bars = MultiProgress::new();
    if !show {
        bars.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let status = bars.add(ProgressBar::new_spinner());
    status.set_style(ProgressStyle::with_template("{spinner} {msg} [{elapsed}]")?);
    status.enable_steady_tick(Duration::from_millis(100));
    status.set_message(format!("run {id}: starting"));
    let answer = http.get(format!("{engine}/runs/{id}/events")).send().await?;
    let mut events = answer.bytes_stream();
    let mut buffer = String::new();
    while let Some(chunk) = events.next().await {
        buffer.push_str(&String::from_utf8_lossy(&chunk?));
        while let Some(end) = buffer.find("\n\n") {
            let block: String = buffer.drain(..end + 2).collect();
            let (kind, data) = parse_event(&block);
            let Ok(data) = serde_json::from_str::<Json>(&data) else { continue };
            match kind.as_str() {
                "broadcast" => {
                    let line = format!(
                        "input on {} hosts in {:.0} ms",
                        data["hosts"].as_array().map_or(0, Vec::len),
                        data["ms"].as_f64().unwrap_or(0.0)
                    );
                    finished_bar(&bars, &status, line);
                }
                "step" => finished_bar(&bars, &status, step_line(&data)),
                "status" => {
                    let state = data["status"].as_str().unwrap_or("");
                    status.set_message(format!("run {id}: {state}"));
                    if matches!(state, "completed" | "failed") {
                        status.finish_and_clear();
                        return Ok(());
                    }
                }
                _ => {}
            }
        }
    }
    status.finish_and_clear();
    Ok(())
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

fn step_line(step: &Json) -> String {
    let mut line = format!(
        "{} {} on {} — {:.0} ms",
        step["path"].as_str().unwrap_or(""),
        step["service"].as_str().unwrap_or(""),
        step["host"].as_str().unwrap_or(""),
        step["compute_ms"].as_f64().unwrap_or(0.0)
    );
    if let Some(bytes) = step["correction_bytes"].as_u64() {
        line.push_str(&format!(", correction {:.1} KB", bytes as f64 / 1024.0));
    }
    if !step["value"].is_null() {
        line.push_str(&format!(", value {}", step["value"]));
    }
    line
}

fn print_summary(record: &Json, output: Option<&Path>) {
    let steps = record["steps"].as_array().map(Vec::as_slice).unwrap_or_default();
    if let Some(broadcast) = record.get("broadcast").filter(|b| !b.is_null()) {
        let hosts = broadcast["hosts"].as_array().map_or(0, Vec::len);
        println!(
            "input broadcast to {hosts} hosts in {:.0} ms",
            broadcast["ms"].as_f64().unwrap_or(0.0)
        );
    }
    for step in steps {
        let transfers: Vec<String> = step["transfers"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|t| {
                let kb = t["bytes"].as_f64().unwrap_or(0.0) / 1024.0;
                format!(
                    "{} {kb:.1} KB in {:.0} ms",
                    t["via"].as_str().unwrap_or(""),
                    t["finished_ms"].as_f64().unwrap_or(0.0)
                        - t["started_ms"].as_f64().unwrap_or(0.0)
                )
            })
            .collect();
        let forwarded = match transfers.is_empty() {
            true => String::new(),
            false => format!("; sent on: {}", transfers.join(", ")),
        };
        println!("  {}{forwarded}", step_line(step));
    }
    let result = &record["result"];
    println!(
        "run {} completed: {} steps in {:.2} s; result {} vertices, {} triangles, hash {}",
        record["id"].as_str().unwrap_or(""),
        steps.len(),
        record["total_ms"].as_f64().unwrap_or(0.0) / 1e3,
        result["vertices"],
        result["triangles"],
        result["hash"].as_str().unwrap_or("")
    );
    for warning in record["warnings"].as_array().into_iter().flatten() {
        println!("warning: {}", warning.as_str().unwrap_or(""));
    }
    if let Some(path) = output {
        println!("wrote {}", path.display());
    }
}
