//! `meshflow plugin`: publish plugins on a running host, and make C/C++ ones components.

use crate::output::out;
use std::path::PathBuf;

use anyhow::Context;
use clap::Subcommand;
use meshflow_api::HostClient;
use meshflow_runtime::{Limits, Runtime};

#[derive(Subcommand)]
pub enum PluginCommand {
    /// Upload a plugin component (.wasm) to a host; prints its digest and services.
    Upload {
        /// The host's URL, e.g. http://127.0.0.1:7070.
        #[arg(long, value_name = "URL")]
        host: String,
        file: PathBuf,
        /// The host's upload token (its --token).
        #[arg(long, env = "MESHFLOW_UPLOAD_TOKEN", hide_env_values = true, value_name = "TOKEN")]
        token: Option<String>,
        /// Read the upload token from this file.
        #[arg(long, value_name = "PATH")]
        token_file: Option<PathBuf>,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Turn a wasm32-wasip1 core module (C, C++: clang with wasi-libc) into a plugin
    /// component, with the WASI preview-1 adapter; checked as a host checks an upload.
    Componentize {
        /// The core module, linked with the world's type object
        /// (sdk/cpp/generated/plugin_component_type.o).
        core: PathBuf,
        /// Where to write the component.
        #[arg(short, long, value_name = "PLUGIN.wasm")]
        output: PathBuf,
    },
}

pub fn run(command: PluginCommand) -> anyhow::Result<()> {
    match command {
        PluginCommand::Upload { host, file, token, token_file, json } => {
            let token = super::tokens::read(token.as_deref(), token_file.as_deref())?.context(
                "give the host's upload token: --token, MESHFLOW_UPLOAD_TOKEN or --token-file",
            )?;
            let wasm = crate::plugins::read_plugin_file(&file)?;
            let client = HostClient::new(&host);
            let uploaded = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()?
                .block_on(client.upload_plugin(wasm, Some(&token)))
                .with_context(|| format!("uploading {}", file.display()))?;
            if json {
                out!("{}", serde_json::to_string_pretty(&uploaded)?);
                return Ok(());
            }
            out!("plugin {}", uploaded.digest);
            for service in &uploaded.services {
                super::services::print(service, &uploaded.digest);
            }
            Ok(())
        }
        PluginCommand::Componentize { core, output } => {
            let bytes = crate::plugins::read_plugin_file(&core)?;
            let runtime = Runtime::new(Limits::default(), crate::plugins::cache_dir().as_deref())?;
            let (component, plugin) = crate::componentize::componentize(&runtime, &bytes)
                .with_context(|| format!("componentizing {}", core.display()))?;
            std::fs::write(&output, component)
                .with_context(|| format!("writing {}", output.display()))?;
            out!("wrote {}: plugin {}", output.display(), plugin.digest);
            for service in &plugin.services {
                super::services::print(service, &plugin.digest);
            }
            Ok(())
        }
    }
}
