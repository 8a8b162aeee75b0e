//! How far the engine believes each host (DESIGN §10): an admin's trust level per host
//! (`trusted`, `spot-check`, `untrusted`; `PATCH /hosts`, `--host-trust`), the share of a
//! spot-checked host's steps replayed elsewhere (`--spot-check`), and each host's suspicion
//! and last clearing, kept in the `host_verdicts` table so a restart keeps them.

use rusqlite::{Connection, OptionalExtension, params};
use serde::{Deserialize, Serialize};

use crate::store::StoreError;

/// The share of a `spot-check` host's steps replayed on another host, unless
/// `--spot-check` says otherwise.
pub const DEFAULT_SPOT_CHECK: f64 = 0.1;

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Trust {
    /// Believed as far as hashes check; disagreements are arbitrated.
    #[default]
    Trusted,
    /// A share of its steps is replayed on another host, off the critical path.
    SpotCheck,
    /// Every result is replayed on another host before anyone builds on it.
    Untrusted,
}

impl Trust {
    pub fn parse(text: &str) -> Option<Self> {
        match text {
            "trusted" => Some(Self::Trusted),
            "spot-check" => Some(Self::SpotCheck),
            "untrusted" => Some(Self::Untrusted),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::Trusted => "trusted",
            Self::SpotCheck => "spot-check",
            Self::Untrusted => "untrusted",
        }
    }
}

/// Why a `--host-trust` value was refused.
#[derive(Debug, thiserror::Error)]
pub enum AssignmentError {
    #[error("{0:?} is not URL=LEVEL")]
    NotAnAssignment(String),
    #[error("{0:?} is not trusted, spot-check or untrusted")]
    UnknownLevel(String),
}

/// `--host-trust URL=LEVEL`: the URL and the level, or why not.
pub fn parse_assignment(text: &str) -> Result<(String, Trust), AssignmentError> {
    let (url, level) =
        text.rsplit_once('=').ok_or_else(|| AssignmentError::NotAnAssignment(text.to_owned()))?;
    let trust =
        Trust::parse(level).ok_or_else(|| AssignmentError::UnknownLevel(level.to_owned()))?;
    Ok((url.trim_end_matches('/').to_owned(), trust))
}

/// Whether step `index` of run `run_id` is one of the `share` of steps a spot-checked host
/// has replayed: decided from the two alone (FNV-1a), so a run's choice is reproducible.
pub fn spot_checked(run_id: &str, index: usize, share: f64) -> bool {
    if share <= 0.0 {
        return false;
    }
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for byte in run_id.bytes().chain(index.to_le_bytes()) {
        hash ^= u64::from(byte);
        hash = hash.wrapping_mul(0x0100_0000_01b3);
    }
    // The top 53 bits as a fraction in [0, 1).
    ((hash >> 11) as f64 / (1u64 << 53) as f64) < share
}

/// What the database keeps of a host's standing.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Standing {
    pub trust: Trust,
    /// Why the host is suspect, and since when (Unix seconds).
    pub suspect: Option<(String, i64)>,
    /// The last verdict that proved it right.
    pub cleared: Option<String>,
}

/// The stored standing of the host at `url` (the default for one never judged).
pub fn load(connection: &mut Connection, url: &str) -> Result<Standing, StoreError> {
    let row = connection
        .query_row(
            "SELECT trust, suspect, suspect_unix, cleared FROM host_verdicts WHERE url = ?1",
            [url],
            |row| {
                Ok((
                    row.get::<_, String>(0)?,
                    row.get::<_, Option<String>>(1)?,
                    row.get::<_, Option<i64>>(2)?,
                    row.get::<_, Option<String>>(3)?,
                ))
            },
        )
        .optional()?;
    Ok(match row {
        None => Standing::default(),
        Some((trust, suspect, since, cleared)) => Standing {
            // A level this build does not know is read as the strictest.
            trust: Trust::parse(&trust).unwrap_or(Trust::Untrusted),
            suspect: suspect.zip(since),
            cleared,
        },
    })
}

/// Keeps the standing of the host at `url`, replacing what was kept.
pub fn save(connection: &mut Connection, url: &str, standing: &Standing) -> Result<(), StoreError> {
    let (suspect, since) = standing.suspect.clone().unzip();
    connection.execute(
        "INSERT INTO host_verdicts (url, trust, suspect, suspect_unix, cleared)
         VALUES (?1, ?2, ?3, ?4, ?5)
         ON CONFLICT (url) DO UPDATE SET trust = ?2, suspect = ?3, suspect_unix = ?4,
             cleared = ?5",
        params![url, standing.trust.name(), suspect, since, standing.cleared],
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spot_checks_are_a_reproducible_share() {
        let chosen = (0..10_000).filter(|&i| spot_checked("run-1", i, 0.1)).count();
        assert!((800..1200).contains(&chosen), "{chosen}");
        assert_eq!(spot_checked("run-1", 7, 0.1), spot_checked("run-1", 7, 0.1));
        assert!((0..100).all(|i| spot_checked("r", i, 1.0)));
        assert!(!(0..100).any(|i| spot_checked("r", i, 0.0)));
    }

    #[test]
    fn assignments_and_standings_read_back() {
        assert_eq!(
            parse_assignment("http://127.0.0.1:7101/=untrusted").unwrap(),
            ("http://127.0.0.1:7101".to_owned(), Trust::Untrusted)
        );
        assert!(parse_assignment("http://h=maybe").is_err());
        assert!(parse_assignment("http://h").is_err());
        let dir = tempfile::tempdir().unwrap();
        let store = crate::store::Store::open(&dir.path().join("e.sqlite3")).unwrap();
        let standing =
            Standing { trust: Trust::SpotCheck, suspect: Some(("lied".into(), 12)), cleared: None };
        store.now(|c| save(c, "http://h", &standing)).unwrap();
        assert_eq!(store.now(|c| load(c, "http://h")).unwrap(), standing);
        assert_eq!(store.now(|c| load(c, "http://other")).unwrap(), Standing::default());
    }
}
