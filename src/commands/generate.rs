//! `meshflow generate`: deterministic test meshes.

use crate::output::out;
use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Subcommand};
use meshflow_generate::{ScanSpec, scan};
use meshflow_meshio as io;

#[derive(Subcommand)]
pub enum GenerateCommand {
    /// A scan-like mesh: smooth closed surface, depth noise, holes, spurious pieces, and a
    /// few degenerate and non-manifold spots. Same arguments, same bytes.
    Scan(ScanArgs),
}

#[derive(Args)]
pub struct ScanArgs {
    /// Vertices of the main surface, before holes (approximate).
    #[arg(long, default_value_t = 100_000)]
    vertices: usize,
    /// Spurious small components.
    #[arg(long, default_value_t = 0)]
    components: usize,
    /// Holes punched into the surface.
    #[arg(long, default_value_t = 0)]
    holes: usize,
    /// Depth noise as a fraction of the mean edge length.
    #[arg(long, default_value_t = 0.1)]
    noise: f64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output mesh (PLY, OBJ, OFF by extension).
    #[arg(short, long)]
    output: PathBuf,
}

pub fn run(command: &GenerateCommand) -> anyhow::Result<()> {
    match command {
        GenerateCommand::Scan(args) => {
            anyhow::ensure!(args.noise.is_finite() && args.noise >= 0.0, "--noise must be ≥ 0");
            let spec = ScanSpec {
                vertices: args.vertices,
                components: args.components,
                holes: args.holes,
                noise: args.noise,
                seed: args.seed,
            };
            let mesh = scan(&spec);
            io::save(&args.output, &mesh)
                .with_context(|| format!("writing {}", args.output.display()))?;
            out!(
                "{} vertices, {} triangles -> {}",
                mesh.vertex_count(),
                mesh.triangle_count(),
                args.output.display()
            );
            Ok(())
        }
    }
}
