//! `meshflow plugin`: publish plugins on a running host, and make C/C++ ones components.

use crate::output::out;
use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Subcommand};
use meshflow_api::host::PluginEntry;
use meshflow_api::{EngineClient, HostClient};
use meshflow_runtime::{Limits, Runtime};

mod new;

#[derive(Subcommand)]
pub enum PluginCommand {
    /// Upload a plugin component (.wasm) to a host; prints its digest and which services
    /// are new, replaced or already present. With --engine the upload goes through the
    /// engine (its API token from MESHFLOW_API_TOKEN), which offers the services at once.
    Upload {
        #[command(flatten)]
        host: HostArg,
        file: PathBuf,
        /// Upload through this engine, to its registered host --host.
        #[arg(long, value_name = "URL")]
        engine: Option<String>,
        /// The engine's API token (with --engine).
        #[arg(long, env = "MESHFLOW_API_TOKEN", hide_env_values = true, value_name = "TOKEN")]
        api_token: Option<String>,
        /// Serve services another plugin already offers from this one (the other stays
        /// for runs pinned to its digest until deleted); without it such an upload is
        /// refused.
        #[arg(long)]
        replace: bool,
        #[command(flatten)]
        token: UploadToken,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// List a host's plugins: digest, built-in or uploaded, services (those another
    /// plugin replaced marked "pinned only"). Takes the upload token or the cluster token.
    List {
        #[command(flatten)]
        host: HostArg,
        #[command(flatten)]
        token: UploadToken,
        /// The host's cluster token, when it has one (instead of the upload token).
        #[arg(long, env = "MESHFLOW_CLUSTER_TOKEN", hide_env_values = true, value_name = "T")]
        cluster_token: Option<String>,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// Delete an uploaded plugin from a host (by its digest, or a prefix of 12 or more
    /// hex digits that names one plugin, as workflows pin them).
    Delete {
        #[command(flatten)]
        host: HostArg,
        digest: String,
        #[command(flatten)]
        token: UploadToken,
    },
    /// Write a new plugin project (Rust, C++ or Python) that builds anywhere with one command.
    New(new::NewArgs),
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

#[derive(Args)]
pub struct HostArg {
    /// The host's URL, e.g. http://127.0.0.1:7070.
    #[arg(long = "host", value_name = "URL")]
    url: String,
}

#[derive(Args)]
pub struct UploadToken {
    /// The host's upload token (its --token).
    #[arg(long, env = "MESHFLOW_UPLOAD_TOKEN", hide_env_values = true, value_name = "TOKEN")]
    token: Option<String>,
    /// Read the upload token from this file.
    #[arg(long, value_name = "PATH")]
    token_file: Option<PathBuf>,
}

impl UploadToken {
    fn get(&self) -> anyhow::Result<String> {
        self.given()?
            .context("give the host's upload token: --token, MESHFLOW_UPLOAD_TOKEN or --token-file")
    }

    fn given(&self) -> anyhow::Result<Option<String>> {
        super::tokens::warn_if_in_argv("--token", "--token-file", "MESHFLOW_UPLOAD_TOKEN");
        super::tokens::read(self.token.as_deref(), self.token_file.as_deref())
    }
}

/// The shortest digest prefix a workflow may pin, and so the shortest `delete` takes.
const MIN_DIGEST_PREFIX: usize = 12;

/// The one uploaded plugin whose digest starts with `prefix`.
fn resolve_digest(prefix: &str, plugins: &[PluginEntry]) -> anyhow::Result<String> {
    let prefix = prefix.to_ascii_lowercase();
    anyhow::ensure!(
        prefix.len() >= MIN_DIGEST_PREFIX && prefix.chars().all(|c| c.is_ascii_hexdigit()),
        "`{prefix}` is not a digest or a prefix of at least {MIN_DIGEST_PREFIX} hex digits"
    );
    let matching: Vec<&PluginEntry> =
        plugins.iter().filter(|p| !p.builtin && p.digest.starts_with(&prefix)).collect();
    match matching.as_slice() {
        [one] => Ok(one.digest.clone()),
        [] => anyhow::bail!("no uploaded plugin's digest starts with {prefix}"),
        many => {
            anyhow::bail!("{} uploaded plugins start with {prefix}: give more digits", many.len())
        }
    }
}

pub fn run(command: PluginCommand) -> anyhow::Result<()> {
    let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    match command {
        PluginCommand::Upload { host, file, engine, api_token, replace, token, json } => {
            let token = token.get()?;
            let wasm = crate::plugins::read_plugin_file(&file)?;
            let upload = async {
                match &engine {
                    Some(engine) => {
                        let mut client = EngineClient::new(engine.trim_end_matches('/'));
                        if let Some(api) = super::tokens::read(api_token.as_deref(), None)? {
                            client = client.with_token(&api);
                        }
                        anyhow::Ok(client.upload_plugin(&host.url, wasm, &token, replace).await?)
                    }
                    None => Ok(HostClient::new(&host.url)
                        .upload_plugin(wasm, Some(&token), replace)
                        .await?),
                }
            };
            let uploaded = runtime
                .block_on(upload)
                .with_context(|| format!("uploading {}", file.display()))?;
            if json {
                out!("{}", serde_json::to_string_pretty(&uploaded)?);
                return Ok(());
            }
            out!("plugin {}", uploaded.digest);
            for (what, names) in [
                ("new", &uploaded.new),
                ("replaced", &uploaded.replaced),
                ("already present", &uploaded.present),
            ] {
                if !names.is_empty() {
                    out!("  {what}: {}", names.join(", "));
                }
            }
            for service in &uploaded.services {
                super::services::print(service, &uploaded.digest);
            }
            Ok(())
        }
        PluginCommand::List { host, token, cluster_token, json } => {
            let mut client = HostClient::new(&host.url);
            if let Some(token) = cluster_token.or(token.given()?) {
                client = client.with_token(&token);
            }
            let (plugins, services) = runtime
                .block_on(async { tokio::try_join!(client.plugins(), client.services()) })
                .with_context(|| format!("asking {} for its plugins", host.url))?;
            if json {
                out!("{}", serde_json::to_string_pretty(&plugins)?);
                return Ok(());
            }
            for plugin in plugins {
                let origin = if plugin.builtin { "built-in" } else { "uploaded" };
                out!("{} ({origin})", plugin.digest);
                for name in &plugin.services {
                    let pinned_only = services.iter().any(|s| {
                        s.plugin == plugin.digest && &s.info.name == name && s.pinned_only
                    });
                    let note = if pinned_only { " (pinned only: replaced)" } else { "" };
                    out!("  {name}{note}");
                }
            }
            Ok(())
        }
        PluginCommand::Delete { host, digest: given, token } => {
            let token = token.get()?;
            let client = HostClient::new(&host.url);
            let digest = runtime.block_on(async {
                let plugins = client.clone().with_token(&token).plugins().await?;
                let digest = resolve_digest(&given, &plugins)?;
                client.delete_plugin(&digest, Some(&token)).await?;
                anyhow::Ok(digest)
            });
            let digest =
                digest.with_context(|| format!("deleting plugin {given} from {}", host.url))?;
            out!("deleted {digest}");
            Ok(())
        }
        PluginCommand::New(args) => new::run(args),
        PluginCommand::Componentize { core, output } => {
            let bytes = std::fs::read(&core).with_context(|| {
                format!(
                    "reading {}: build the core module first (the C/C++ template's `make` \
                     does, with clang --target=wasm32-wasi)",
                    core.display()
                )
            })?;
            let sandbox = Runtime::new(Limits::default(), crate::plugins::cache_dir().as_deref())?;
            let (component, plugin) = crate::componentize::componentize(&sandbox, &bytes)
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
