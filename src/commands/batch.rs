//! `meshflow run | submit WORKFLOW IN… --out-dir DIR`: one workflow over many meshes as an
//! engine batch (`POST /batches`, a few runs at a time), with a progress bar per mesh and
//! one overall; `DIR/summary.csv` and `summary.json` hold a row per input. One failing
//! mesh never stops the others.

use crate::output::out;

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::Context;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use meshflow_api::EngineClient;
use meshflow_api::engine::{Status, SubmitBatch, SummaryRow};
use meshflow_engine::summary;
use serde_json::Value as Json;

use super::remote::{VerifiedResult, upload_input};

/// How often a mesh's bar asks the engine how its run is going.
const POLL_EVERY: Duration = Duration::from_millis(200);

/// The options `meshflow run` and `submit` share for batches.
#[derive(clap::Args)]
pub struct BatchArgs {
    /// A file naming inputs, one path or URL a line.
    #[arg(long = "inputs", value_name = "LIST")]
    pub inputs_list: Option<PathBuf>,
    /// Run every input as a batch: results as DIR/<name>.<format>, records under
    /// DIR/records/, and DIR/summary.csv and summary.json with a row per input.
    #[arg(long, value_name = "DIR")]
    pub out_dir: Option<PathBuf>,
    /// The format of a batch's results.
    #[arg(long, default_value = "ply", value_parser = ["ply", "obj", "off", "stl"])]
    pub format: String,
    /// How many meshes of a batch run at once (the engine allows at most 4).
    #[arg(long, default_value_t = 2)]
    pub jobs: usize,
}

impl BatchArgs {
    /// `given` and those of the list, in that order.
    pub fn inputs(&self, given: &[String]) -> anyhow::Result<Vec<String>> {
        let mut inputs = given.to_vec();
        if let Some(list) = &self.inputs_list {
            inputs.extend(read_list(list)?);
        }
        Ok(inputs)
    }

    /// Runs `workflow` over `inputs` on `engine` into `out_dir`; fails, after writing the
    /// summaries, if any input failed.
    pub async fn run(
        &self,
        engine: EngineClient,
        workflow: Json,
        inputs: Vec<String>,
        out_dir: PathBuf,
        json: bool,
    ) -> anyhow::Result<()> {
        anyhow::ensure!(!inputs.is_empty(), "no inputs given");
        let batch = Batch {
            engine,
            workflow,
            inputs,
            out_dir,
            format: self.format.clone(),
            jobs: self.jobs,
            show: !json,
        };
        let rows = batch.execute().await?;
        if json {
            out!("{}", serde_json::to_string_pretty(&rows)?);
        }
        let failed: Vec<&str> =
            rows.iter().filter(|r| r.status != "completed").map(|r| r.name.as_str()).collect();
        anyhow::ensure!(
            failed.is_empty(),
            "{} of {} inputs failed: {}; see {}",
            failed.len(),
            rows.len(),
            failed.join(", "),
            batch.out_dir.join("summary.csv").display()
        );
        Ok(())
    }
}

struct Batch {
    engine: EngineClient,
    workflow: Json,
    /// Paths or URLs, in the order of the summary's rows.
    inputs: Vec<String>,
    out_dir: PathBuf,
    /// Extension of each result file (ply, obj, off, stl).
    format: String,
    jobs: usize,
    /// Draw progress bars (not with --json).
    show: bool,
}

/// The inputs of `--inputs LIST`: one path or URL a line; blank lines and `#` comments
/// skipped. Relative paths are relative to the list's folder.
fn read_list(list: &Path) -> anyhow::Result<Vec<String>> {
    let text =
        std::fs::read_to_string(list).with_context(|| format!("reading {}", list.display()))?;
    let folder = list.parent().unwrap_or(Path::new(""));
    Ok(text
        .lines()
        .map(str::trim)
        .filter(|line| !line.is_empty() && !line.starts_with('#'))
        .map(|line| match is_url(line) {
            true => line.to_owned(),
            false => folder.join(line).display().to_string(),
        })
        .collect())
}

fn is_url(input: &str) -> bool {
    input.starts_with("http://") || input.starts_with("https://")
}

impl Batch {
    /// Uploads the file inputs, starts the batch on the engine (`POST /batches`), follows
    /// it, saves each result and record as its run ends, and writes the summaries.
    async fn execute(&self) -> anyhow::Result<Vec<SummaryRow>> {
        std::fs::create_dir_all(self.out_dir.join("records"))
            .with_context(|| format!("creating {}", self.out_dir.display()))?;
        let names = unique_stems(&self.inputs);
        let bars = MultiProgress::new();
        if !self.show {
            bars.set_draw_target(indicatif::ProgressDrawTarget::hidden());
        }
        let overall = bars.add(ProgressBar::new(self.inputs.len() as u64));
        overall.set_style(
            ProgressStyle::with_template("{bar:30} {pos}/{len} meshes {msg}")
                .expect("a valid template"),
        );
        let mesh_bars: Vec<ProgressBar> = names
            .iter()
            .map(|name| {
                let bar = bars.insert_before(&overall, ProgressBar::new_spinner());
                bar.set_style(
                    ProgressStyle::with_template("{spinner} {prefix}: {msg}")
                        .expect("a valid template"),
                );
                bar.set_prefix(name.clone());
                bar.set_message("waiting");
                bar
            })
            .collect();
        // A file that cannot be uploaded is that input's failure; the others go on.
        let mut rows: Vec<Option<SummaryRow>> = vec![None; self.inputs.len()];
        let mut urls = Vec::new();
        let mut in_batch = Vec::new();
        for (index, input) in self.inputs.iter().enumerate() {
            if is_url(input) {
                urls.push(input.clone());
                in_batch.push(index);
                continue;
            }
            mesh_bars[index].set_message("uploading");
            match upload_input(&self.engine, Path::new(input)).await {
                Ok(url) => {
                    urls.push(url);
                    in_batch.push(index);
                }
                Err(error) => {
                    let row = summary::failed_row(&display_name(input), format!("{error:#}"));
                    finish(&mesh_bars[index], &overall, &row);
                    rows[index] = Some(row);
                }
            }
        }
        if !urls.is_empty() {
            let request = SubmitBatch {
                workflow: self.workflow.clone(),
                inputs: urls,
                concurrency: Some(self.jobs),
            };
            let started =
                self.engine.submit_batch(&request).await.context("the engine refused the batch")?;
            let bars = Bars { meshes: &mesh_bars, overall: &overall };
            self.follow(&started.id, &in_batch, &names, &bars, &mut rows).await?;
        }
        overall.finish_with_message("done");
        let rows: Vec<SummaryRow> = rows.into_iter().flatten().collect();
        write_summaries(&self.out_dir, &rows)?;
        Ok(rows)
    }

    /// Polls the batch until every run has ended; each run is saved as it ends.
    async fn follow(
        &self,
        id: &str,
        in_batch: &[usize],
        names: &[String],
        bars: &Bars<'_>,
        rows: &mut [Option<SummaryRow>],
    ) -> anyhow::Result<()> {
        loop {
            let status = self.engine.batch(id).await?;
            for (k, (entry, row)) in status.entries.iter().zip(&status.rows).enumerate() {
                let index = in_batch[k];
                if rows[index].is_some() {
                    continue;
                }
                if matches!(row.status.as_str(), "waiting" | "queued" | "running") {
                    bars.meshes[index].set_message(row.status.clone());
                    bars.meshes[index].tick();
                    continue;
                }
                let mut row = row.clone();
                row.name = display_name(&self.inputs[index]);
                if let Some(run) = &entry.run
                    && let Err(error) = self.save(run, &names[index]).await
                {
                    row.error = Some(format!("{error:#}"));
                    row.status = "failed".into();
                }
                finish(&bars.meshes[index], bars.overall, &row);
                rows[index] = Some(row);
            }
            if in_batch.iter().all(|&i| rows[i].is_some()) {
                return Ok(());
            }
            tokio::time::sleep(POLL_EVERY).await;
        }
    }

    /// Writes a finished run's record, and its result if it completed (hash checked).
    async fn save(&self, run: &str, name: &str) -> anyhow::Result<()> {
        let record = self.engine.run(run).await?;
        let text = serde_json::to_string_pretty(&record)?;
        let record_path = self.out_dir.join("records").join(format!("{name}.json"));
        super::pack::write_atomically(&record_path, text.as_bytes())?;
        if record.status == Status::Completed {
            let result = VerifiedResult::download(&self.engine, &record).await?;
            result.save(&self.out_dir.join(format!("{name}.{}", self.format)))?;
        }
        Ok(())
    }
}

struct Bars<'a> {
    meshes: &'a [ProgressBar],
    overall: &'a ProgressBar,
}

fn finish(bar: &ProgressBar, overall: &ProgressBar, row: &SummaryRow) {
    bar.finish_with_message(match &row.error {
        None => format!("{} {}", row.status, row.result_hash.as_deref().unwrap_or("")),
        Some(error) => format!("{}: {error}", row.status),
    });
    overall.inc(1);
}

/// `summary.csv` (fixed columns, then one per check) and `summary.json` (the rows).
fn write_summaries(dir: &Path, rows: &[SummaryRow]) -> anyhow::Result<()> {
    let checks = summary::check_columns(rows);
    let mut csv = csv::Writer::from_writer(Vec::new());
    let header = summary::COLUMNS.iter().map(|c| c.to_string()).chain(checks.iter().cloned());
    csv.write_record(header.collect::<Vec<_>>())?;
    for row in rows {
        csv.write_record(summary::cells(row, &checks))?;
    }
    let bytes = csv.into_inner().context("writing the summary table")?;
    super::pack::write_atomically(&dir.join("summary.csv"), &bytes)?;
    let json = serde_json::to_string_pretty(rows)?;
    super::pack::write_atomically(&dir.join("summary.json"), json.as_bytes())
}

/// An input's name in the summary: the file name, or the URL.
fn display_name(input: &str) -> String {
    match is_url(input) {
        true => input.to_owned(),
        false => Path::new(input).file_name().map_or(input.into(), |n| n.to_string_lossy().into()),
    }
}

/// A file stem per input for its result and record, made unique (`scan`, `scan-2`) when
/// two inputs share one.
fn unique_stems(inputs: &[String]) -> Vec<String> {
    let mut stems: Vec<String> = Vec::with_capacity(inputs.len());
    for input in inputs {
        let last = input.rsplit('/').next().unwrap_or(input);
        let base = Path::new(last)
            .file_stem()
            .map_or("input".into(), |s| s.to_string_lossy().into_owned());
        let mut stem = base.clone();
        let mut n = 2;
        while stems.contains(&stem) {
            stem = format!("{base}-{n}");
            n += 1;
        }
        stems.push(stem);
    }
    stems
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inputs_with_the_same_stem_get_distinct_names() {
        let inputs =
            ["a/scan.ply", "b/scan.obj", "http://x/scan.ply?v=1", "bunny.obj"].map(String::from);
        assert_eq!(unique_stems(&inputs), ["scan", "scan-2", "scan-3", "bunny"]);
    }

    #[test]
    fn a_list_names_paths_relative_to_itself_and_urls() {
        let dir = tempfile::tempdir().unwrap();
        let list = dir.path().join("inputs.txt");
        std::fs::write(&list, "# meshes\none.ply\n\n  http://h/two.ply \n").unwrap();
        let inputs = read_list(&list).unwrap();
        assert_eq!(
            inputs,
            [dir.path().join("one.ply").display().to_string(), "http://h/two.ply".into()]
        );
    }
}
