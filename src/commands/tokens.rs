//! Secrets on the command line: each from a flag, an environment variable (`MESHFLOW_*`) or
//! a file (`--…-file`, which wins), so none need appear in argv; and fresh ones for the
//! embedded default.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;

/// Random bytes in a generated token.
const TOKEN_BYTES: usize = 32;

/// A shorter token is refused: it could be guessed.
pub const MIN_TOKEN_CHARS: usize = 16;

/// The engine's API token: what users send.
#[derive(Args, Clone, Debug, Default)]
pub struct ApiTokenArgs {
    /// API token: every engine route but /health and the UI page needs it.
    #[arg(long, env = "MESHFLOW_API_TOKEN", hide_env_values = true, value_name = "TOKEN")]
    api_token: Option<String>,
    /// Read the API token from this file.
    #[arg(long, value_name = "PATH")]
    api_token_file: Option<PathBuf>,
}

/// The cluster token: what the engine and its hosts send each other.
#[derive(Args, Clone, Debug, Default)]
pub struct ClusterTokenArgs {
    /// Cluster token, shared by the engine and its hosts.
    #[arg(long, env = "MESHFLOW_CLUSTER_TOKEN", hide_env_values = true, value_name = "TOKEN")]
    cluster_token: Option<String>,
    /// Read the cluster token from this file.
    #[arg(long, value_name = "PATH")]
    cluster_token_file: Option<PathBuf>,
}

/// The metrics token: what a Prometheus server elsewhere than the loopback sends to read
/// `/metrics`.
#[derive(Args, Clone, Debug, Default)]
pub struct MetricsTokenArgs {
    /// Metrics token: clients not on the loopback need it as a bearer token to read /metrics
    /// (without it, only loopback clients may).
    #[arg(long, env = "MESHFLOW_METRICS_TOKEN", hide_env_values = true, value_name = "TOKEN")]
    metrics_token: Option<String>,
    /// Read the metrics token from this file.
    #[arg(long, value_name = "PATH")]
    metrics_token_file: Option<PathBuf>,
}

impl MetricsTokenArgs {
    pub fn get(&self) -> anyhow::Result<Option<String>> {
        warn_if_in_argv("--metrics-token", "--metrics-token-file", "MESHFLOW_METRICS_TOKEN");
        read(self.metrics_token.as_deref(), self.metrics_token_file.as_deref())
    }
}

/// The hosts' upload token: what plugin authors send.
#[derive(Args, Clone, Debug, Default)]
pub struct UploadTokenArgs {
    /// Upload token of the hosts: `meshflow plugin upload` needs it.
    #[arg(long, env = "MESHFLOW_UPLOAD_TOKEN", hide_env_values = true, value_name = "TOKEN")]
    upload_token: Option<String>,
    /// Read the upload token from this file.
    #[arg(long, value_name = "PATH")]
    upload_token_file: Option<PathBuf>,
}

impl UploadTokenArgs {
    pub fn get(&self) -> anyhow::Result<Option<String>> {
        warn_if_in_argv("--upload-token", "--upload-token-file", "MESHFLOW_UPLOAD_TOKEN");
        read(self.upload_token.as_deref(), self.upload_token_file.as_deref())
    }
}

/// What the engine and its hosts share: the cluster token, and the origins run inputs may
/// come from besides the cluster.
#[derive(Args, Clone, Debug, Default)]
pub struct ClusterArgs {
    #[command(flatten)]
    pub token: ClusterTokenArgs,
    /// An origin (scheme://host[:port]) run inputs may come from besides the engine and
    /// its hosts; repeat for more.
    #[arg(long, value_name = "ORIGIN")]
    pub allow_input_from: Vec<String>,
}

impl ApiTokenArgs {
    pub fn get(&self) -> anyhow::Result<Option<String>> {
        warn_if_in_argv("--api-token", "--api-token-file", "MESHFLOW_API_TOKEN");
        read(self.api_token.as_deref(), self.api_token_file.as_deref())
    }
}

impl ClusterTokenArgs {
    pub fn get(&self) -> anyhow::Result<Option<String>> {
        warn_if_in_argv("--cluster-token", "--cluster-token-file", "MESHFLOW_CLUSTER_TOKEN");
        read(self.cluster_token.as_deref(), self.cluster_token_file.as_deref())
    }
}

/// A token from its file (first line, trimmed) or its flag / environment variable.
pub fn read(value: Option<&str>, file: Option<&Path>) -> anyhow::Result<Option<String>> {
    let token = match file {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading the token file {}", path.display()))?;
            text.lines().next().unwrap_or_default().trim().to_owned()
        }
        None => match value {
            Some(value) => value.trim().to_owned(),
            None => return Ok(None),
        },
    };
    anyhow::ensure!(!token.is_empty(), "an empty token was given");
    anyhow::ensure!(
        token.chars().count() >= MIN_TOKEN_CHARS,
        "a token of {} characters was given; at least {MIN_TOKEN_CHARS} are needed \
         (`openssl rand -hex 32` makes one)",
        token.chars().count()
    );
    Ok(Some(token))
}

/// Tokens given as flags show in `ps` and shell history: say so, and where they belong.
/// `flags` are the flag and its file twin (`--api-token`, `--api-token-file`).
pub fn warn_if_in_argv(flag: &str, file_flag: &str, env: &str) {
    let given = std::env::args().any(|arg| arg == flag || arg.starts_with(&format!("{flag}=")));
    if given {
        eprintln!(
            "warning: {flag} puts the token where other users can read it (ps, shell history); \
             use {env} or {file_flag} instead"
        );
    }
}

/// A new random token: 32 bytes from the operating system, in hex.
pub fn fresh() -> anyhow::Result<String> {
    let mut bytes = [0u8; TOKEN_BYTES];
    getrandom::fill(&mut bytes).map_err(|e| anyhow::anyhow!("no randomness for a token: {e}"))?;
    Ok(hex::encode(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_wins_and_fresh_tokens_differ() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("token");
        std::fs::write(&path, "from-file-0123456789\n").unwrap();
        let flag = Some("from-flag-0123456789");
        assert_eq!(read(flag, Some(&path)).unwrap().as_deref(), Some("from-file-0123456789"));
        assert_eq!(read(flag, None).unwrap().as_deref(), flag);
        assert_eq!(read(None, None).unwrap(), None);
        assert!(read(Some(" "), None).is_err());
        let short = read(Some("sesame"), None).unwrap_err().to_string();
        assert!(short.contains("at least 16"), "{short}");
        let (a, b) = (fresh().unwrap(), fresh().unwrap());
        assert_eq!(a.len(), 64);
        assert_ne!(a, b);
    }
}
