//! TLS as a server: a certificate and key from PEM files, read again when either file
//! changes, so an operator renews a certificate (certbot, a lab CA) without a restart.

use std::fmt;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime};

use rustls::crypto::ring::sign::any_supported_type;
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};
use rustls::server::{ClientHello, ResolvesServerCert};
use rustls::sign::CertifiedKey;

use crate::tls::{TlsError, read_bounded};

/// The files are looked at (their modification times) at most this often.
const RELOAD_CHECK_EVERY: Duration = Duration::from_secs(1);

/// Where a server's certificate chain and private key live (PEM).
#[derive(Clone, Debug)]
pub struct TlsFiles {
    pub cert: PathBuf,
    pub key: PathBuf,
}

impl TlsFiles {
    /// A rustls server configuration (HTTP/1.1, ring) that serves these files and re-reads
    /// them when they change; fails now if they cannot be used.
    pub fn server_config(&self) -> Result<Arc<rustls::ServerConfig>, TlsError> {
        let resolver = Reloading::new(self.clone())?;
        let provider = Arc::new(rustls::crypto::ring::default_provider());
        let mut config = rustls::ServerConfig::builder_with_provider(provider)
            .with_safe_default_protocol_versions()
            .expect("ring supports the default protocol versions")
            .with_no_client_auth()
            .with_cert_resolver(Arc::new(resolver));
        config.alpn_protocols = vec![b"http/1.1".to_vec()];
        Ok(Arc::new(config))
    }

    fn modified(&self) -> Option<(SystemTime, SystemTime)> {
        let time = |path: &PathBuf| std::fs::metadata(path).and_then(|m| m.modified()).ok();
        Some((time(&self.cert)?, time(&self.key)?))
    }

    fn load(&self) -> Result<CertifiedKey, TlsError> {
        let cert_pem = read_bounded(&self.cert)?;
        let chain: Vec<CertificateDer<'static>> =
            CertificateDer::pem_slice_iter(&cert_pem).collect::<Result<_, _>>().map_err(|e| {
                TlsError::NoCertificate { path: self.cert.clone(), message: e.to_string() }
            })?;
        if chain.is_empty() {
            let message = "no BEGIN CERTIFICATE block".to_owned();
            return Err(TlsError::NoCertificate { path: self.cert.clone(), message });
        }
        let key_pem = read_bounded(&self.key)?;
        let key = PrivateKeyDer::from_pem_slice(&key_pem)
            .map_err(|_| TlsError::NoKey { path: self.key.clone() })?;
        let mismatch = |message: String| TlsError::Mismatch {
            cert: self.cert.clone(),
            key: self.key.clone(),
            message,
        };
        let signing = any_supported_type(&key).map_err(|e| mismatch(e.to_string()))?;
        let certified = CertifiedKey::new(chain, signing);
        certified.keys_match().map_err(|e| mismatch(e.to_string()))?;
        Ok(certified)
    }
}

/// Serves the last good certificate; a change to the files that cannot be used is logged
/// and the old certificate stays.
struct Reloading {
    files: TlsFiles,
    state: Mutex<Loaded>,
}

struct Loaded {
    key: Arc<CertifiedKey>,
    modified: Option<(SystemTime, SystemTime)>,
    checked: Instant,
}

impl Reloading {
    fn new(files: TlsFiles) -> Result<Self, TlsError> {
        let modified = files.modified();
        let key = Arc::new(files.load()?);
        Ok(Self { files, state: Mutex::new(Loaded { key, modified, checked: Instant::now() }) })
    }
}

impl fmt::Debug for Reloading {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Reloading").field("files", &self.files).finish()
    }
}

impl ResolvesServerCert for Reloading {
    fn resolve(&self, _hello: ClientHello<'_>) -> Option<Arc<CertifiedKey>> {
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if state.checked.elapsed() >= RELOAD_CHECK_EVERY {
            state.checked = Instant::now();
            let modified = self.files.modified();
            if modified.is_some() && modified != state.modified {
                state.modified = modified;
                match self.files.load() {
                    Ok(key) => {
                        tracing::info!(
                            "TLS certificate reloaded from {}",
                            self.files.cert.display()
                        );
                        state.key = Arc::new(key);
                    }
                    Err(error) => tracing::warn!("TLS certificate not reloaded: {error}"),
                }
            }
        }
        Some(state.key.clone())
    }
}
