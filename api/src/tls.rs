//! TLS as a client (DESIGN §11): every client of this process trusts the system's roots,
//! the webpki roots and the CA files an operator names (a lab's private CA), and refuses
//! to send a token over plain http beyond loopback unless the operator allows it.
//!
//! The policy is the process's, as `SSL_CERT_FILE` is for other tools: set once at start
//! ([`ClientPolicy::install`]) and read by every client built after.

use std::net::IpAddr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, RwLock};

/// The flag that lets tokens travel over plain http to other machines.
pub const PLAIN_HTTP_FLAG: &str = "--insecure-plain-http";

/// A CA file larger than this is not a CA file.
const MAX_CA_FILE_BYTES: u64 = 4 << 20;

#[derive(Debug, thiserror::Error)]
pub enum TlsError {
    #[error("reading {path}: {source}")]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{path} is {size} bytes; a CA file has at most {MAX_CA_FILE_BYTES}")]
    TooLarge { path: PathBuf, size: u64 },
    #[error("{path} holds no PEM certificate ({message})")]
    NoCertificate { path: PathBuf, message: String },
    #[error("{path} holds no PEM private key")]
    NoKey { path: PathBuf },
    #[error("the certificate in {cert} does not go with the key in {key}: {message}")]
    Mismatch { cert: PathBuf, key: PathBuf, message: String },
}

/// Who this process's clients trust, and whether tokens may cross plain http.
#[derive(Clone, Debug, Default)]
pub struct ClientPolicy {
    roots: Vec<reqwest::Certificate>,
    plain_http: bool,
}

static POLICY: RwLock<Option<Arc<ClientPolicy>>> = RwLock::new(None);

impl ClientPolicy {
    /// Also trusts every certificate of the PEM file at `path` as a root.
    pub fn with_ca_file(mut self, path: &Path) -> Result<Self, TlsError> {
        let pem = read_bounded(path)?;
        let roots = reqwest::Certificate::from_pem_bundle(&pem).map_err(|e| {
            TlsError::NoCertificate { path: path.to_owned(), message: e.to_string() }
        })?;
        if roots.is_empty() {
            let message = "no BEGIN CERTIFICATE block".to_owned();
            return Err(TlsError::NoCertificate { path: path.to_owned(), message });
        }
        self.roots.extend(roots);
        Ok(self)
    }

    /// Lets tokens travel over plain http to addresses beyond loopback.
    pub fn allow_plain_http(mut self, allowed: bool) -> Self {
        self.plain_http = allowed;
        self
    }

    /// Makes this the policy of every client built from now on.
    pub fn install(self) {
        *POLICY.write().unwrap_or_else(|e| e.into_inner()) = Some(Arc::new(self));
    }

    /// The policy installed now (the default if none was), to extend and install again.
    pub fn installed() -> ClientPolicy {
        ClientPolicy::current().as_ref().clone()
    }

    fn current() -> Arc<ClientPolicy> {
        POLICY.read().unwrap_or_else(|e| e.into_inner()).clone().unwrap_or_default()
    }
}

/// A client builder with rustls and the process's trust: system roots, webpki roots and
/// the installed CA files.
pub fn client_builder() -> reqwest::ClientBuilder {
    let policy = ClientPolicy::current();
    let builder = reqwest::Client::builder()
        .use_rustls_tls()
        .tls_built_in_native_certs(true)
        .tls_built_in_webpki_certs(true);
    policy.roots.iter().cloned().fold(builder, reqwest::ClientBuilder::add_root_certificate)
}

/// Why a token may not go to `url`: plain http to an address that is not loopback, unless
/// the installed policy allows it. Every client that sends a token asks this first.
pub fn plain_http_refusal(url: &reqwest::Url) -> Option<String> {
    token_over_plain_http(url, ClientPolicy::current().plain_http)
}

fn token_over_plain_http(url: &reqwest::Url, allowed: bool) -> Option<String> {
    if allowed || url.scheme() != "http" || is_loopback(url) {
        return None;
    }
    Some(format!(
        "refusing to send a token over plain http to {}: use https, or pass {PLAIN_HTTP_FLAG} \
         if the network between is trusted",
        url.host_str().unwrap_or("?")
    ))
}

fn is_loopback(url: &reqwest::Url) -> bool {
    match url.host() {
        Some(url::Host::Domain(name)) => name.eq_ignore_ascii_case("localhost"),
        Some(url::Host::Ipv4(ip)) => IpAddr::V4(ip).is_loopback(),
        Some(url::Host::Ipv6(ip)) => IpAddr::V6(ip).is_loopback(),
        None => false,
    }
}

pub(crate) fn read_bounded(path: &Path) -> Result<Vec<u8>, TlsError> {
    let read_error = |source| TlsError::Read { path: path.to_owned(), source };
    let size = std::fs::metadata(path).map_err(read_error)?.len();
    if size > MAX_CA_FILE_BYTES {
        return Err(TlsError::TooLarge { path: path.to_owned(), size });
    }
    std::fs::read(path).map_err(read_error)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(url: &str, allowed: bool) -> bool {
        token_over_plain_http(&url.parse().unwrap(), allowed).is_some()
    }

    #[test]
    fn tokens_cross_plain_http_only_on_loopback_or_by_flag() {
        assert!(refused("http://engine.lab.example:7000/runs", false));
        assert!(refused("http://10.1.2.3:7070/sessions", false));
        assert!(refused("http://[2001:db8::1]:7070/", false));
        assert!(!refused("http://127.0.0.1:7000/runs", false));
        assert!(!refused("http://127.0.0.12:7070/", false));
        assert!(!refused("http://localhost:7000/", false));
        assert!(!refused("http://[::1]:7000/", false));
        assert!(!refused("https://engine.lab.example/runs", false));
        assert!(!refused("http://engine.lab.example:7000/runs", true));
        let message = token_over_plain_http(&"http://a.example/".parse().unwrap(), false).unwrap();
        assert!(message.contains(PLAIN_HTTP_FLAG), "{message}");
    }

    #[test]
    fn a_ca_file_without_certificates_is_refused() {
        let dir = std::env::temp_dir().join(format!("meshflow-tls-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("ca.pem");
        std::fs::write(&path, "not a certificate\n").unwrap();
        let error = ClientPolicy::default().with_ca_file(&path).unwrap_err();
        assert!(matches!(error, TlsError::NoCertificate { .. }), "{error}");
        let missing = ClientPolicy::default().with_ca_file(&dir.join("absent.pem")).unwrap_err();
        assert!(matches!(missing, TlsError::Read { .. }), "{missing}");
    }
}
