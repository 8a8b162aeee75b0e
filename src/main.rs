//! `meshflow`: run sandboxed mesh-processing plugins locally, and (later) distribute
//! workflows of them over hosts.

mod commands;
mod componentize;
mod embedded;
mod mlx;
mod output;
mod plugins;

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
pub use commands::options::SandboxArgs;

#[derive(Parser)]
#[command(
    name = "meshflow",
    version,
    about = "Triangle-mesh workflows from sandboxed WebAssembly plugins"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    #[command(flatten)]
    client_tls: commands::options::ClientTlsArgs,
}

#[derive(Subcommand)]
enum Command {
    /// List the services on offer, with their parameters.
    Services {
        #[command(flatten)]
        plugins: PluginArgs,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Run one filter on a mesh file, locally.
    Apply(commands::apply::ApplyArgs),
    /// Run one check on a mesh file, locally, and print its value.
    Check(commands::check::CheckArgs),
    /// Print the canonical content hash of a mesh as loaded.
    Hash {
        /// Mesh file (OBJ, PLY, OFF, STL).
        input: PathBuf,
    },
    /// Make a deterministic test mesh.
    #[command(subcommand)]
    Generate(commands::generate::GenerateCommand),
    /// Apply or inspect corrections (.mfc): the coded edit log of one step.
    #[command(subcommand)]
    Correction(commands::correction::CorrectionCommand),
    /// Pack a mesh into the compact lossless .mfm format.
    Pack {
        input: PathBuf,
        #[arg(short, long)]
        output: PathBuf,
        /// Snap the mesh to a grid of at most 2^BITS cells per axis over its bounding box
        /// (1-24) before packing.
        #[arg(long, value_name = "BITS")]
        quantize: Option<u32>,
        #[arg(long)]
        json: bool,
    },
    /// Unpack a .mfm mesh into a mesh file (format by extension).
    Unpack {
        input: PathBuf,
        #[arg(short, long)]
        output: PathBuf,
        /// Refuse (write nothing) when the output's format cannot hold an attribute of
        /// the mesh, instead of warning and saving without it.
        #[arg(long)]
        strict: bool,
        #[arg(long)]
        json: bool,
    },
    /// Print vertex and triangle counts, the bounding box and the attributes of a mesh, and
    /// what its file held that meshflow does not keep.
    Info {
        input: PathBuf,
        #[arg(long)]
        json: bool,
    },
    /// Serve the host HTTP API: sessions, services, plugin upload, blobs.
    Host(commands::host::HostArgs),
    /// Manage the plugins of a running host.
    #[command(subcommand)]
    Plugin(commands::plugin::PluginCommand),
    /// Serve the engine HTTP API and web UI: workflows over hosts.
    Engine(commands::engine::EngineArgs),
    /// Start an engine and N hosts on loopback in one process (the embedded default).
    Up(commands::up::UpArgs),
    /// Run a workflow on a mesh through an embedded engine and hosts.
    Run(commands::run::RunArgs),
    /// Submit a workflow to a running engine.
    Submit(commands::submit::SubmitArgs),
    /// Run a recorded run again (pinned plugins, recorded parameters) and say whether the
    /// result is bit-identical or where it diverged.
    Rerun(commands::rerun::RerunArgs),
    /// Convert MeshLab filter scripts (.mlx) to workflows and back.
    #[command(subcommand)]
    Workflow(commands::workflow::WorkflowCommand),
    /// Stop a run on a running engine.
    Cancel(commands::submit::CancelArgs),
}

/// Plugins to load besides the built-in ones.
#[derive(Args, Default)]
pub struct PluginArgs {
    /// A plugin component (.wasm); its services shadow built-in ones of the same name.
    #[arg(long = "plugin", value_name = "FILE.wasm")]
    pub plugins: Vec<PathBuf>,
    /// Show what the plugin printed (stdout, stderr; 64 KiB each at most) after the run,
    /// on stderr. A failed run shows its stderr anyway.
    #[arg(long)]
    pub plugin_output: bool,
    #[command(flatten)]
    pub sandbox: SandboxArgs,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = cli.client_tls.install().and_then(|()| match cli.command {
        Command::Services { plugins, json } => commands::services::run(&plugins, json),
        Command::Apply(args) => commands::apply::run(&args),
        Command::Check(args) => commands::check::run(&args),
        Command::Generate(command) => commands::generate::run(&command),
        Command::Hash { input } => commands::inspect::hash(&input),
        Command::Info { input, json } => commands::inspect::info(&input, json),
        Command::Correction(command) => commands::correction::run(&command),
        Command::Pack { input, output, quantize, json } => {
            commands::pack::pack(&input, &output, quantize, json)
        }
        Command::Unpack { input, output, strict, json } => {
            commands::pack::unpack(&input, &output, strict, json)
        }
        Command::Host(args) => commands::host::run(args),
        Command::Plugin(command) => commands::plugin::run(command),
        Command::Engine(args) => commands::engine::run(args),
        Command::Up(args) => commands::up::run(args),
        Command::Run(args) => commands::run::run(args),
        Command::Submit(args) => commands::submit::run(args),
        Command::Cancel(args) => commands::submit::cancel(args),
        Command::Rerun(args) => commands::rerun::run(args),
        Command::Workflow(command) => commands::workflow::run(command),
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            // Not eprintln!: a closed stderr must not turn an error into a panic.
            let _ = writeln!(std::io::stderr(), "error: {error:#}");
            ExitCode::FAILURE
        }
    }
}
