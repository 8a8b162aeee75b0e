//! `meshflow apply`: one filter on one mesh file, locally.

use crate::output::out;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::Args;
use meshflow_codec::{correction, quantize, replay};
use meshflow_runtime::ServiceKind;

use super::{millis, parse_params};
use crate::PluginArgs;

#[derive(Args)]
pub struct ApplyArgs {
    /// The filter to run.
    service: String,
    /// Input mesh (OBJ, PLY, OFF, STL).
    input: PathBuf,
    /// Output mesh (PLY, OBJ, OFF, by extension); written atomically. The material
    /// libraries and textures the mesh names are copied beside it.
    #[arg(short, long)]
    output: PathBuf,
    /// Refuse (write nothing) when the output's format cannot hold an attribute of the
    /// mesh (colours in STL, quality in OBJ, …), instead of warning and saving without it.
    #[arg(long)]
    strict: bool,
    /// A parameter, NAME=VALUE; repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    params: Vec<String>,
    /// Also write the step's correction, atomically: its edit log (.mfc) or the step
    /// named for a re-run (.mfr), as `--correction-kind` says.
    #[arg(long, value_name = "OUT")]
    correction: Option<PathBuf>,
    /// `edits`: the edit log; `replay`: plugin digest, service, resolved parameters and
    /// hashes (a few hundred bytes; applied by re-running the plugin); `auto`: the smaller.
    #[arg(long, value_enum, default_value_t = CorrectionKind::Edits)]
    correction_kind: CorrectionKind,
    /// Snap the input to a grid of at most 2^BITS cells per axis over its bounding box
    /// (1-24), and the result back onto that grid after the filter.
    #[arg(long, value_name = "BITS")]
    quantize: Option<u32>,
    #[command(flatten)]
    plugins: PluginArgs,
    /// Print a JSON summary.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CorrectionKind {
    Edits,
    Replay,
    Auto,
}

pub fn run(args: &ApplyArgs) -> anyhow::Result<()> {
    if args.quantize.is_some() && args.correction_kind != CorrectionKind::Edits {
        bail!(
            "--quantize snaps the plugin's result, which a re-run would not: use --correction-kind edits"
        );
    }
    let params = parse_params(&args.params)?;
    let (runtime, catalog) = crate::plugins::load(&args.plugins)?;
    let (plugin, info) = catalog.find(&args.service)?;
    if info.kind != ServiceKind::Filter {
        bail!("`{}` is a check, not a filter: use `meshflow check`", args.service);
    }

    let started = Instant::now();
    let mut mesh = super::pack::load_mesh(&args.input)?;
    let grid = args.quantize.map(|bits| quantize::quantize(&mut mesh, bits)).transpose()?;
    let load_time = started.elapsed();

    // Shared with the run, which copies it at its first edit: the input is kept for the
    // correction without a copy of its own.
    let mesh = Arc::new(mesh);
    let output = runtime.run(plugin, &args.service, Arc::clone(&mesh), &params)?;
    crate::plugins::show_output(&args.plugins, &output);
    let result = output.mesh.expect("a filter returns a mesh");
    // The plugin computes freely; the step's result goes back onto the grid here.
    let (result, log) = match &grid {
        Some(grid) => quantize::snap_step(grid, &mesh, result, output.log)
            .context("snapping the result to the grid")?,
        None => (result, output.log),
    };
    let result = &result;

    let started = Instant::now();
    super::pack::save_mesh_from(&args.output, result, args.strict, Some(&args.input))?;
    let save_time = started.elapsed();

    let started = Instant::now();
    let correction_bytes = match &args.correction {
        Some(path) => {
            let edits = || correction::encode(&mesh, &log, result);
            let named = || {
                let (base, hash) = (mesh.content_hash(), result.content_hash());
                meshflow_host::replay::name(plugin, info, &params, base, result, hash)
                    .map(|step| replay::encode(&step))
                    .map_err(anyhow::Error::msg)
            };
            let bytes = match args.correction_kind {
                CorrectionKind::Edits => edits()?,
                CorrectionKind::Replay => named()?,
                CorrectionKind::Auto => {
                    let (edits, named) = (edits()?, named()?);
                    if named.len() < edits.len() { named } else { edits }
                }
            };
            super::pack::write_atomically(path, &bytes)?;
            Some(bytes.len())
        }
        None => None,
    };
    let correction_time = started.elapsed();

    let edits: usize = log.iter().map(|op| op.edit_count()).sum();
    if args.json {
        let summary = serde_json::json!({
            "service": args.service,
            "input_hash": mesh.content_hash().to_hex(),
            "output_hash": result.content_hash().to_hex(),
            "vertices": result.vertex_count(),
            "triangles": result.triangle_count(),
            "edits": edits,
            "timings_ms": {
                "load": millis(load_time),
                "run": millis(output.duration),
                "save": millis(save_time),
                "correction": millis(correction_time),
            },
            "correction_bytes": correction_bytes,
            "quantize_bits": args.quantize,
            "guest_peak_bytes": output.guest_peak_bytes,
            "report": output.report,
            "partitions": output.partitions.map(|p| serde_json::json!({
                "count": p.count,
                "rings": p.rings,
                "core_triangles": p.core_triangles,
                "largest": p.largest,
            })),
        });
        out!("{summary}");
    } else {
        if !output.report.is_empty() {
            out!("{}: {}", args.service, output.report);
        }
        out!(
            "{} vertices, {} triangles, {edits} edits -> {}",
            result.vertex_count(),
            result.triangle_count(),
            args.output.display()
        );
    }
    Ok(())
}
