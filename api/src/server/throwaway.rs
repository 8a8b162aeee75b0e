//! A certificate authority made for one start only, and a certificate it signs for the
//! loopback names: `meshflow up --tls` runs the embedded default over TLS with it, and the
//! tests and benches make their clusters' certificates the same way.

use std::path::{Path, PathBuf};

use rcgen::{BasicConstraints, CertificateParams, DnType, IsCa, Issuer, KeyPair, KeyUsagePurpose};

use super::TlsFiles;

/// The names the embedded engine and hosts are reached at.
const LOOPBACK_NAMES: [&str; 3] = ["localhost", "127.0.0.1", "::1"];

/// The files of a throwaway authority: its certificate (for clients' `--ca-file`) and the
/// servers' certificate and key.
pub struct ThrowawayTls {
    pub ca: PathBuf,
    pub server: TlsFiles,
}

/// Why a throwaway authority could not be made.
#[derive(Debug, thiserror::Error)]
pub enum ThrowawayError {
    #[error("making a certificate: {0}")]
    Certificate(#[from] rcgen::Error),
    #[error("writing {path}: {source}")]
    Write { path: PathBuf, source: std::io::Error },
}

/// Makes a fresh authority named `name` and a loopback certificate under `dir` (created
/// 0700, the files written 0600).
pub fn make(dir: &Path, name: &str) -> Result<ThrowawayTls, ThrowawayError> {
    create_private_dir(dir)?;
    let mut ca_params = CertificateParams::new(Vec::<String>::new())?;
    ca_params.is_ca = IsCa::Ca(BasicConstraints::Constrained(0));
    ca_params.distinguished_name.push(DnType::CommonName, format!("{name} throwaway CA"));
    ca_params.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
    let ca_key = KeyPair::generate()?;
    let ca_cert = ca_params.self_signed(&ca_key)?;
    let issuer = Issuer::new(ca_params, ca_key);

    let names: Vec<String> = LOOPBACK_NAMES.iter().map(|n| n.to_string()).collect();
    let mut params = CertificateParams::new(names)?;
    params.distinguished_name.push(DnType::CommonName, "meshflow on loopback");
    let key = KeyPair::generate()?;
    let cert = params.signed_by(&key, &issuer)?;

    let files = ThrowawayTls {
        ca: dir.join("ca.pem"),
        server: TlsFiles { cert: dir.join("server.pem"), key: dir.join("server-key.pem") },
    };
    write_private(&files.ca, ca_cert.pem().as_bytes())?;
    write_private(&files.server.cert, cert.pem().as_bytes())?;
    write_private(&files.server.key, key.serialize_pem().as_bytes())?;
    Ok(files)
}

fn create_private_dir(dir: &Path) -> Result<(), ThrowawayError> {
    use std::os::unix::fs::DirBuilderExt;
    let failed = |source| ThrowawayError::Write { path: dir.to_owned(), source };
    std::fs::DirBuilder::new().recursive(true).mode(0o700).create(dir).map_err(failed)
}

fn write_private(path: &Path, bytes: &[u8]) -> Result<(), ThrowawayError> {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    let failed = |source| ThrowawayError::Write { path: path.to_owned(), source };
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(0o600)
        .open(path)
        .map_err(failed)?;
    file.write_all(bytes).map_err(failed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_server_certificate_is_signed_by_the_ca_and_the_key_is_private() {
        use std::os::unix::fs::PermissionsExt;
        let dir = std::env::temp_dir().join(format!("meshflow-throwaway-{}", std::process::id()));
        let made = make(&dir.join("tls"), "test").unwrap();
        assert!(made.server.server_config().is_ok(), "the certificate and key go together");
        let mode = std::fs::metadata(&made.server.key).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o600);
        let dir_mode = std::fs::metadata(dir.join("tls")).unwrap().permissions().mode();
        assert_eq!(dir_mode & 0o777, 0o700);
        // openssl, where installed, checks the chain as any TLS client would.
        let verified = std::process::Command::new("openssl")
            .args(["verify", "-CAfile"])
            .arg(&made.ca)
            .arg(&made.server.cert)
            .output();
        if let Ok(output) = verified {
            assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
