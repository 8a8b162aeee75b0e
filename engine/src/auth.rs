//! The engine's secrets, how it is reached, and which input URLs a run may name (DESIGN
//! §10–11). Which route takes which token is `routes/auth.rs`; users are `users.rs`.

use std::path::PathBuf;

use meshflow_api::fetch_rules::{OriginError, Origins, Refusal, check_origin, origin};
use meshflow_api::server::TlsFiles;

/// The engine's secrets and what it lets runs fetch.
#[derive(Clone, Debug, Default)]
pub struct Access {
    /// The API's single token, the user `default` (an admin): submit, upload inputs, read
    /// runs.
    pub api_token: Option<String>,
    /// The API's named users and their tokens (see `users.rs`), besides `api_token`'s.
    pub users_file: Option<PathBuf>,
    /// The engine and its hosts: registration, and everything the engine asks of hosts.
    pub cluster_token: Option<String>,
    /// Origins (`scheme://host[:port]`) run inputs may come from besides the engine and its
    /// hosts.
    pub allow_input_from: Vec<String>,
    /// Listen on a non-loopback address without both tokens.
    pub insecure_no_auth: bool,
    /// Origins (`scheme://host[:port]`) besides the engine's own whose pages may change its
    /// state (`--allow-origin`).
    pub allow_origins: Vec<String>,
    /// Serve https with this certificate and key.
    pub tls: Option<TlsFiles>,
    /// What a client not on the loopback sends to read `/metrics`; without it only loopback
    /// clients may.
    pub metrics_token: Option<String>,
}

/// Why an engine will not start with this access.
#[derive(Debug, thiserror::Error)]
pub enum AccessError {
    #[error(
        "an API token (or --users) needs a cluster token too: hosts fetch uploaded inputs with it"
    )]
    ApiWithoutCluster,
    #[error("--allow-input-from: {0}")]
    Origin(OriginError),
    #[error("--allow-origin: {0}")]
    BrowserOrigin(OriginError),
}

impl Access {
    /// Checks the combination and normalises the allowed origins.
    pub fn validated(mut self) -> Result<Self, AccessError> {
        if self.has_api_tokens() && self.cluster_token.is_none() {
            return Err(AccessError::ApiWithoutCluster);
        }
        self.allow_origins = self
            .allow_origins
            .iter()
            .map(|text| check_origin(text).map_err(AccessError::BrowserOrigin))
            .collect::<Result<_, _>>()?;
        self.allow_input_from = self
            .allow_input_from
            .iter()
            .map(|text| check_origin(text).map_err(AccessError::Origin))
            .collect::<Result<_, _>>()?;
        Ok(self)
    }

    /// Whether the API takes tokens: the single API token or a users file.
    pub fn has_api_tokens(&self) -> bool {
        self.api_token.is_some() || self.users_file.is_some()
    }

    /// The tokens a server on a public address must have, that this one lacks.
    pub fn missing(&self) -> Vec<&'static str> {
        let mut missing = Vec::new();
        if !self.has_api_tokens() {
            missing.push("an API token");
        }
        if self.cluster_token.is_none() {
            missing.push("a cluster token");
        }
        missing
    }

    /// Which origins a run's input may come from, given the engine's own (its uploads) and
    /// its hosts'. With no tokens and no allow-list (a loopback engine among friends), any
    /// origin; the address rules hold in every case.
    pub fn input_origins(&self, own: &str, hosts: impl Iterator<Item = String>) -> Origins {
        if !self.has_api_tokens()
            && self.cluster_token.is_none()
            && self.allow_input_from.is_empty()
        {
            return Origins::any();
        }
        let own = reqwest::Url::parse(own).map(|url| origin(&url)).into_iter();
        let hosts = hosts.filter_map(|url| reqwest::Url::parse(&url).ok()).map(|u| origin(&u));
        Origins::of(own.chain(hosts).chain(self.allow_input_from.iter().cloned()))
    }

    /// Checks an input URL a run names.
    pub fn check_input(
        &self,
        url: &str,
        own: &str,
        hosts: impl Iterator<Item = String>,
    ) -> Result<(), Refusal> {
        let parsed = reqwest::Url::parse(url)
            .map_err(|_| Refusal::NotAUrl(meshflow_api::fetch_rules::quoted(url)))?;
        self.input_origins(own, hosts).check(&parsed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inputs_come_from_the_engine_its_hosts_and_allowed_origins() {
        let access = Access {
            api_token: Some("a".into()),
            cluster_token: Some("c".into()),
            allow_input_from: vec!["https://data.example.org".into()],
            ..Access::default()
        }
        .validated()
        .unwrap();
        let own = "http://127.0.0.1:7000";
        let hosts = || vec!["http://127.0.0.1:7101".to_owned()].into_iter();
        for good in [
            "http://127.0.0.1:7000/inputs/x.ply",
            "http://127.0.0.1:7101/blobs/y.mfm",
            "https://data.example.org/scan.obj",
        ] {
            access.check_input(good, own, hosts()).unwrap();
        }
        for bad in ["http://127.0.0.1:7999/secret", "http://169.254.169.254/", "file:///etc/passwd"]
        {
            assert!(access.check_input(bad, own, hosts()).is_err(), "{bad}");
        }
        let open = Access::default();
        open.check_input("http://10.0.0.9/scan.obj", own, hosts()).unwrap();
        assert!(open.check_input("http://169.254.169.254/", own, hosts()).is_err());
    }

    #[test]
    fn an_api_token_needs_a_cluster_token() {
        let access = Access { api_token: Some("a".into()), ..Access::default() };
        assert!(matches!(access.validated(), Err(AccessError::ApiWithoutCluster)));
    }
}
