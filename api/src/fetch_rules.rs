//! Where a server may fetch from (DESIGN §10). Never: anything but http(s), link-local
//! addresses (169.254.0.0/16, fe80::/10) and the cloud metadata endpoints, whether named in
//! the URL or reached by resolving its name ([`GuardedResolver`], so DNS rebinding cannot get
//! around it). Beyond that, a [`FetchScope`] says which origins are allowed and which of them
//! get the cluster token; [`fetch`](crate::fetch) checks every redirect hop against it.

use std::collections::BTreeSet;
use std::net::{IpAddr, Ipv6Addr, SocketAddr};
use std::sync::Arc;

use reqwest::Url;
use reqwest::dns::{Addrs, Name, Resolve, Resolving};

/// Names that are metadata services whatever they resolve to.
const METADATA_NAMES: [&str; 1] = ["metadata.google.internal"];
/// AWS's IPv6 metadata address (the IPv4 one, 169.254.169.254, is link-local).
const METADATA_V6: Ipv6Addr = Ipv6Addr::new(0xfd00, 0xec2, 0, 0, 0, 0, 0, 0x254);
/// How much of a URL an error message quotes.
const QUOTED_URL_CHARS: usize = 120;

/// Why a URL is not fetched.
#[derive(Clone, Debug, thiserror::Error)]
pub enum Refusal {
    #[error("{0} is not a URL")]
    NotAUrl(String),
    #[error("{0}: only http and https URLs are fetched")]
    Scheme(String),
    #[error("{0}: link-local and cloud metadata addresses are never fetched")]
    Internal(String),
    #[error("{0}: its origin is not one this server fetches from")]
    Origin(String),
}

/// A URL as error messages quote it: at most [`QUOTED_URL_CHARS`] characters, control and
/// non-ASCII characters escaped, so a hostile URL cannot forge or flood a message.
pub fn quoted(url: &str) -> String {
    let mut text: String =
        url.chars().take(QUOTED_URL_CHARS).flat_map(char::escape_default).collect();
    if url.chars().nth(QUOTED_URL_CHARS).is_some() {
        text.push('…');
    }
    text
}

/// Whether an address is never connected to: link-local (which holds 169.254.169.254) or a
/// metadata address, also when written as an IPv4-mapped IPv6 address.
pub fn is_forbidden(ip: IpAddr) -> bool {
    match ip {
        IpAddr::V4(v4) => v4.is_link_local(),
        IpAddr::V6(v6) => match v6.to_ipv4_mapped() {
            Some(v4) => v4.is_link_local(),
            None => v6.is_unicast_link_local() || v6 == METADATA_V6,
        },
    }
}

/// The rules every fetched URL obeys, on its text alone: http(s), and no forbidden address
/// or metadata name as its host. (Names are checked again once resolved.)
pub fn check_address(url: &Url) -> Result<(), Refusal> {
    if !matches!(url.scheme(), "http" | "https") {
        return Err(Refusal::Scheme(quoted(url.as_str())));
    }
    let forbidden = match url.host() {
        Some(url::Host::Ipv4(ip)) => is_forbidden(ip.into()),
        Some(url::Host::Ipv6(ip)) => is_forbidden(ip.into()),
        Some(url::Host::Domain(name)) => is_metadata_name(name),
        None => true,
    };
    match forbidden {
        true => Err(Refusal::Internal(quoted(url.as_str()))),
        false => Ok(()),
    }
}

fn is_metadata_name(name: &str) -> bool {
    let name = name.trim_end_matches('.').to_ascii_lowercase();
    METADATA_NAMES.contains(&name.as_str())
}

/// A URL's origin, `scheme://host[:port]` (default ports left out), as origins are compared.
pub fn origin(url: &Url) -> String {
    url.origin().ascii_serialization()
}

/// Why an operator's origin was refused.
#[derive(Clone, Debug, thiserror::Error)]
pub enum OriginError {
    #[error("{0} is not an origin")]
    NotAnOrigin(String),
    /// An address no server fetches from.
    #[error(transparent)]
    Refused(#[from] Refusal),
    #[error("{0}: give only scheme://host[:port]")]
    NotBare(String),
}

/// An origin given by an operator (`--allow-input-from`): `scheme://host[:port]`, nothing
/// more, normalised.
pub fn check_origin(text: &str) -> Result<String, OriginError> {
    let url = Url::parse(text).map_err(|_| OriginError::NotAnOrigin(quoted(text)))?;
    check_address(&url)?;
    let bare = url.path() == "/" && url.query().is_none() && url.fragment().is_none();
    if !bare || !url.username().is_empty() || url.password().is_some() {
        return Err(OriginError::NotBare(quoted(text)));
    }
    Ok(origin(&url))
}

/// [`check_origin`] with its error as a message, for the callers that still keep it as
/// text (`engine/src/auth.rs`, `host/src/downloads.rs`, `host/src/state.rs`); they can move
/// to [`check_origin`] and this goes.
pub fn parse_origin(text: &str) -> Result<String, String> {
    check_origin(text).map_err(|e| e.to_string())
}

/// Allowed origins: a set, or any origin.
#[derive(Clone, Debug, Default)]
pub struct Origins {
    any: bool,
    set: BTreeSet<String>,
}

impl Origins {
    /// Every origin (the address rules still hold).
    pub fn any() -> Self {
        Self { any: true, set: BTreeSet::new() }
    }

    pub fn of(origins: impl IntoIterator<Item = String>) -> Self {
        Self { any: false, set: origins.into_iter().collect() }
    }

    pub fn add(&mut self, origin: String) {
        self.set.insert(origin);
    }

    pub fn allows(&self, url: &Url) -> bool {
        self.any || self.set.contains(&origin(url))
    }

    /// The address rules and then the origin rule.
    pub fn check(&self, url: &Url) -> Result<(), Refusal> {
        check_address(url)?;
        match self.allows(url) {
            true => Ok(()),
            false => Err(Refusal::Origin(quoted(url.as_str()))),
        }
    }
}

/// What one download may reach: the allowed origins, and the cluster's origins (a subset),
/// which alone are sent the cluster token.
#[derive(Clone, Debug, Default)]
pub struct FetchScope {
    pub allowed: Origins,
    pub cluster: BTreeSet<String>,
    pub token: Option<String>,
}

impl FetchScope {
    /// The bearer token for `url`: the cluster token, to cluster origins only.
    pub fn token_for(&self, url: &Url) -> Option<&str> {
        self.token.as_deref().filter(|_| self.cluster.contains(&origin(url)))
    }
}

/// Resolves names with the system resolver and drops forbidden addresses; a name with no
/// other address fails to resolve.
#[derive(Debug, Default)]
pub struct GuardedResolver;

impl Resolve for GuardedResolver {
    fn resolve(&self, name: Name) -> Resolving {
        let host = name.as_str().to_owned();
        Box::pin(async move {
            if is_metadata_name(&host) {
                return Err(format!("{host} is a metadata service").into());
            }
            let found: Vec<SocketAddr> = tokio::net::lookup_host((host.as_str(), 0))
                .await?
                .filter(|address| !is_forbidden(address.ip()))
                .collect();
            if found.is_empty() {
                return Err(format!("{host} resolves to no address that may be fetched").into());
            }
            Ok(Box::new(found.into_iter()) as Addrs)
        })
    }
}

/// A client builder whose names resolve through [`GuardedResolver`] and which follows no
/// redirect by itself ([`fetch`](crate::fetch) re-checks each hop), with the process's TLS
/// trust ([`crate::tls`]).
pub fn guarded_client() -> reqwest::ClientBuilder {
    crate::tls::client_builder()
        .dns_resolver(Arc::new(GuardedResolver))
        .redirect(reqwest::redirect::Policy::none())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn url(text: &str) -> Url {
        Url::parse(text).unwrap()
    }

    #[test]
    fn link_local_metadata_and_other_schemes_are_never_fetched() {
        for bad in [
            "file:///etc/passwd",
            "ftp://example.org/x",
            "http://169.254.169.254/latest/meta-data/",
            "http://169.254.1.2:8080/",
            "http://[fe80::1]/",
            "http://[fd00:ec2::254]/",
            "http://[::ffff:169.254.169.254]/",
            "http://metadata.google.internal/computeMetadata/v1/",
            "http://METADATA.google.internal./",
        ] {
            assert!(check_address(&url(bad)).is_err(), "{bad} passed");
        }
        for good in ["http://127.0.0.1:7000/inputs/x.ply", "https://data.example.org/a.obj"] {
            check_address(&url(good)).unwrap();
        }
    }

    #[test]
    fn origins_are_normalised_and_compared_whole() {
        assert_eq!(parse_origin("HTTP://Data.Example.org:80").unwrap(), "http://data.example.org");
        assert!(parse_origin("http://data.example.org/path").is_err());
        assert!(parse_origin("http://169.254.169.254").is_err());
        let allowed = Origins::of([parse_origin("http://127.0.0.1:7000").unwrap()]);
        allowed.check(&url("http://127.0.0.1:7000/inputs/a.ply")).unwrap();
        assert!(matches!(
            allowed.check(&url("http://127.0.0.1:7001/secret")),
            Err(Refusal::Origin(_))
        ));
        Origins::any().check(&url("http://10.1.2.3/a.ply")).unwrap();
    }

    #[test]
    fn quoted_urls_are_short_and_escaped() {
        let long = format!("http://h/{}", "a".repeat(500));
        assert!(quoted(&long).chars().count() <= QUOTED_URL_CHARS + 1);
        assert_eq!(quoted("http://h/\n\u{1b}[31m"), "http://h/\\n\\u{1b}[31m");
    }

    #[tokio::test]
    async fn names_resolving_only_to_forbidden_addresses_fail() {
        let name: Name = "localhost".parse().unwrap();
        assert!(GuardedResolver.resolve(name).await.is_ok());
        let metadata: Name = "metadata.google.internal".parse().unwrap();
        assert!(GuardedResolver.resolve(metadata).await.is_err());
    }
}
