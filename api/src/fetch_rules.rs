//! Where a server may fetch from (DESIGN §10). Never: anything but http(s), link-local
//! addresses (169.254.0.0/16, fe80::/10), carrier-grade NAT (100.64.0.0/10) and the cloud
//! metadata endpoints, also inside an IPv6 address that embeds an IPv4 one, whether named in
//! the URL or reached by resolving its name ([`GuardedResolver`], so DNS rebinding cannot get
//! around it). Beyond that, a [`FetchScope`] says which origins are allowed and which of them
//! get the cluster token; [`fetch_compressible`](crate::fetch_compressible) checks every redirect hop against it.

use std::collections::BTreeSet;
use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr};
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
    #[error("{0}: link-local, carrier-grade NAT and cloud metadata addresses are never fetched")]
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

/// Whether an address is never connected to: link-local (which holds 169.254.169.254),
/// carrier-grade NAT `100.64.0.0/10` (which holds Alibaba's metadata, 100.100.100.200) or a
/// metadata address; an IPv6 address that carries an IPv4 one (IPv4-mapped `::ffff:a.b.c.d`,
/// IPv4-compatible `::a.b.c.d`, NAT64 `64:ff9b::/96`, 6to4 `2002::/16`, Teredo
/// `2001::/32`) is judged by that IPv4 address as well.
pub fn is_forbidden(ip: IpAddr) -> bool {
    match ip {
        IpAddr::V4(v4) => is_forbidden_v4(v4),
        IpAddr::V6(v6) => {
            embedded_v4(v6).is_some_and(is_forbidden_v4)
                || v6.is_unicast_link_local()
                || v6 == METADATA_V6
        }
    }
}

fn is_forbidden_v4(v4: Ipv4Addr) -> bool {
    let [a, b, ..] = v4.octets();
    // 100.64.0.0/10: carrier-grade NAT, where some clouds put their metadata service.
    let shared = a == 100 && (b & 0xc0) == 64;
    v4.is_link_local() || shared
}

/// The IPv4 address an IPv6 address carries, by the usual embeddings.
fn embedded_v4(v6: Ipv6Addr) -> Option<Ipv4Addr> {
    let s = v6.segments();
    let v4 = |hi: u16, lo: u16| Ipv4Addr::from(((hi as u32) << 16) | lo as u32);
    if let Some(mapped) = v6.to_ipv4_mapped() {
        return Some(mapped);
    }
    match s {
        // IPv4-compatible `::a.b.c.d` (not `::` and `::1`).
        [0, 0, 0, 0, 0, 0, hi, lo] if hi != 0 => Some(v4(hi, lo)),
        // NAT64, the well-known prefix `64:ff9b::/96`.
        [0x64, 0xff9b, 0, 0, 0, 0, hi, lo] => Some(v4(hi, lo)),
        // 6to4: `2002:AABB:CCDD::/48`.
        [0x2002, hi, lo, ..] => Some(v4(hi, lo)),
        // Teredo `2001:0::/32`: the client's address, bit-inverted, in the last 32 bits.
        [0x2001, 0, .., hi, lo] => Some(v4(!hi, !lo)),
        _ => None,
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
/// redirect by itself ([`fetch_compressible`](crate::fetch_compressible) re-checks each hop), with the process's TLS
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
            "http://[::a9fe:a9fe]/",
            "http://[64:ff9b::a9fe:a9fe]/",
            "http://[2002:a9fe:a9fe::1]/",
            "http://[2001:0:4136:e378:8000:63bf:5601:5601]/",
            "http://100.100.100.200/latest/meta-data/",
            "http://100.64.0.1/",
            "http://100.127.255.254/",
            "http://metadata.google.internal/computeMetadata/v1/",
            "http://METADATA.google.internal./",
        ] {
            assert!(check_address(&url(bad)).is_err(), "{bad} passed");
        }
        for good in [
            "http://127.0.0.1:7000/inputs/x.ply",
            "https://data.example.org/a.obj",
            "http://10.1.2.3/a.ply",
            "http://100.63.255.255/",
            "http://100.128.0.1/",
            "http://[::1]:7000/",
            "http://[::ffff:10.0.0.1]/",
            "http://[64:ff9b::a01:203]/",
            "http://[2002:a01:203::1]/",
            "http://[2001:db8::1]/",
            "http://[2606:4700::1111]/",
        ] {
            check_address(&url(good)).unwrap();
        }
    }

    #[test]
    fn origins_are_normalised_and_compared_whole() {
        assert_eq!(check_origin("HTTP://Data.Example.org:80").unwrap(), "http://data.example.org");
        assert!(check_origin("http://data.example.org/path").is_err());
        assert!(check_origin("http://169.254.169.254").is_err());
        let allowed = Origins::of([check_origin("http://127.0.0.1:7000").unwrap()]);
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
