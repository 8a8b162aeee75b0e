//! `meshflow plugin`: manage the plugins of a running host.

use std::path::PathBuf;

use anyhow::Context;
use clap::Subcommand;
use meshflow_api::HostClient;

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
}

pub fn run(command: PluginCommand) -> anyhow::Result<()> {
    match command {
        PluginCommand::Upload { host, file, token, token_file, json } => {
            let token = super::tokens::read(token.as_deref(), token_file.as_deref())?.context(
                "give the host's upload token: --token, MESHFLOW_UPLOAD_TOKEN or --token-file",
            )?;
            let wasm =
                std::fs::read(&file).with_context(|| format!("reading {}", file.display()))?;
            let client = HostClient::new(&host);
            let uploaded = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()?
                .block_on(client.upload_plugin(wasm, Some(&token)))
                .with_context(|| format!("uploading {}", file.display()))?;
            if json {
                println!("{}", serde_json::to_string_pretty(&uploaded)?);
                return Ok(());
            }
            println!("plugin {}", uploaded.digest);
            for service in &uploaded.services {
                super::services::print(service, &uploaded.digest);
            }
            Ok(())
        }
    }
}
