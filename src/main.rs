//! `meshflow`: run sandboxed mesh-processing plugins locally, and (later) distribute
//! workflows of them over hosts.

mod commands;
mod plugins;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "meshflow",
    version,
    about = "Triangle-mesh workflows from sandboxed WebAssembly plugins"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
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
        #[arg(long)]
        json: bool,
    },
    /// Unpack a .mfm mesh into a mesh file (format by extension).
    Unpack {
        input: PathBuf,
        #[arg(short, long)]
        output: PathBuf,
        #[arg(long)]
        json: bool,
    },
    /// Print vertex and triangle counts and the bounding box of a mesh.
    Info {
        input: PathBuf,
        #[arg(long)]
        json: bool,
    },
}

/// Plugins to load besides the built-in ones.
#[derive(Args, Default)]
pub struct PluginArgs {
    /// A plugin component (.wasm); its services shadow built-in ones of the same name.
    #[arg(long = "plugin", value_name = "FILE.wasm")]
    pub plugins: Vec<PathBuf>,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Services { plugins, json } => commands::services::run(&plugins, json),
        Command::Apply(args) => commands::apply::run(&args),
        Command::Check(args) => commands::check::run(&args),
        Command::Generate(command) => commands::generate::run(&command),
        Command::Hash { input } => commands::inspect::hash(&input),
        Command::Info { input, json } => commands::inspect::info(&input, json),
        Command::Correction(command) => commands::correction::run(&command),
        Command::Pack { input, output, json } => commands::pack::pack(&input, &output, json),
        Command::Unpack { input, output, json } => commands::pack::unpack(&input, &output, json),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error:#}");
            ExitCode::FAILURE
        }
    }
}
