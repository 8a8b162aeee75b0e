//! A host's answers are claims. Before the executor uses one it checks its form: hashes
//! are content hashes, blob URLs lie on the answering host and name what they announce,
//! counts and sizes are within limits and agree with the step's input, a check's value has
//! its service's declared type. The engine cannot hash meshes (it links no codec); what it
//! cannot check here, receivers check when they apply a result (their answer must name the
//! announced hash) and the CLI checks when it downloads one.

use meshflow_api::host::{CheckResult, FilterResult, SessionStatus, Updated};
use meshflow_api::params::ValueType;

use crate::limits::{MAX_CORRECTION_BYTES, MAX_REPLAY_BYTES, MAX_TRIANGLES, MAX_VERTICES};
use crate::validate::{json_fits, json_type_name, value_type_name};

/// Characters of a host's text repeated in an error.
const SHOWN_CHARS: usize = 80;

/// An answer that cannot be true: the host that gave it is suspect.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum FalseClaim {
    #[error("{field} {value} is not a content hash (64 lowercase hex digits)")]
    NotAHash { field: &'static str, value: String },
    #[error("{field} {url} is not {expected}")]
    WrongUrl { field: &'static str, url: String, expected: String },
    #[error("{field} = {value} is over the limit of {limit}")]
    OverLimit { field: &'static str, value: u64, limit: u64 },
    #[error("{0}")]
    Inconsistent(String),
}

/// A pinned task must have run the pinned plugin: a host naming another digest did not
/// run what it was asked to.
pub fn ran_pinned(plugin: &str, pin: Option<&str>) -> Result<(), FalseClaim> {
    match pin {
        Some(pin) if !plugin.starts_with(pin) => Err(FalseClaim::Inconsistent(format!(
            "ran plugin {} where plugin {pin} was asked for",
            shown(plugin)
        ))),
        _ => Ok(()),
    }
}

/// A host's text as an error may repeat it: quoted, escaped and cut short.
fn shown(text: &str) -> String {
    let kept: String = text.chars().take(SHOWN_CHARS).collect();
    let cut = if kept.len() < text.len() { "…" } else { "" };
    format!("{kept:?}{cut}")
}

/// Whether `text` can name a mesh (or a plugin): 64 lowercase hex digits.
pub fn is_content_hash(text: &str) -> bool {
    text.len() == 64 && text.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f'))
}

fn content_hash(field: &'static str, value: &str) -> Result<(), FalseClaim> {
    match is_content_hash(value) {
        true => Ok(()),
        false => Err(FalseClaim::NotAHash { field, value: shown(value) }),
    }
}

/// Where a host serves the packed mesh of content hash `hash`.
pub fn full_mesh_url(host: &str, hash: &str) -> String {
    format!("{host}/blobs/{hash}.mfm")
}

fn at_most(field: &'static str, value: u64, limit: u64) -> Result<(), FalseClaim> {
    match value <= limit {
        true => Ok(()),
        false => Err(FalseClaim::OverLimit { field, value, limit }),
    }
}

fn counts(vertices: u64, triangles: u64) -> Result<(), FalseClaim> {
    at_most("vertices", vertices, MAX_VERTICES)?;
    at_most("triangles", triangles, MAX_TRIANGLES)
}

fn timing(field: &'static str, ms: f64) -> Result<(), FalseClaim> {
    match ms.is_finite() && ms >= 0.0 {
        true => Ok(()),
        false => Err(FalseClaim::Inconsistent(format!("{field} = {ms} is no duration"))),
    }
}

/// What the engine knows about a step before a host answers it.
pub struct Asked<'a> {
    /// The answering host's base URL, as registered.
    pub host: &'a str,
    pub service: &'a str,
    /// The mesh the host's session held when it was asked, and its counts.
    pub input_hash: &'a str,
    pub input_counts: (u64, u64),
}

impl Asked<'_> {
    fn common(
        &self,
        service: &str,
        plugin: &str,
        compute_ms: f64,
        queue_ms: f64,
    ) -> Result<(), FalseClaim> {
        if service != self.service {
            let message =
                format!("answered for service {}, asked for {:?}", shown(service), self.service);
            return Err(FalseClaim::Inconsistent(message));
        }
        // A plugin is named by the SHA-256 of its bytes: as long as a content hash.
        content_hash("plugin", plugin)?;
        timing("compute_ms", compute_ms)?;
        timing("queue_ms", queue_ms)
    }

    /// A filter's answer: its mesh, correction and full-mesh URL.
    pub fn filter(&self, answer: &FilterResult) -> Result<(), FalseClaim> {
        self.common(&answer.service, &answer.plugin, answer.compute_ms, answer.queue_ms)?;
        content_hash("input_hash", &answer.input_hash)?;
        content_hash("output_hash", &answer.output_hash)?;
        content_hash("full.hash", &answer.full.hash)?;
        if answer.input_hash != self.input_hash {
            let message =
                format!("ran on mesh {}, the session held {}", answer.input_hash, self.input_hash);
            return Err(FalseClaim::Inconsistent(message));
        }
        if answer.full.hash != answer.output_hash {
            let message =
                format!("full.hash {} is not output_hash {}", answer.full.hash, answer.output_hash);
            return Err(FalseClaim::Inconsistent(message));
        }
        let full = full_mesh_url(self.host, &answer.output_hash);
        if answer.full.url != full {
            return Err(FalseClaim::WrongUrl {
                field: "full.url",
                url: shown(&answer.full.url),
                expected: full,
            });
        }
        self.blob_url("correction.url", &answer.correction.url, "mfc")?;
        at_most("correction.bytes", answer.correction.bytes, MAX_CORRECTION_BYTES)?;
        self.blob_url("replay.url", &answer.replay.url, "mfr")?;
        at_most("replay.bytes", answer.replay.bytes, MAX_REPLAY_BYTES)?;
        let (vertices, triangles) = (answer.vertices as u64, answer.triangles as u64);
        counts(vertices, triangles)?;
        // The same mesh has the same counts; no edit leaves the same mesh.
        let unchanged = answer.output_hash == answer.input_hash;
        if unchanged && (vertices, triangles) != self.input_counts {
            let message = format!(
                "output_hash is the input's, but {vertices} vertices and {triangles} triangles \
                 are not the input's {} and {}",
                self.input_counts.0, self.input_counts.1
            );
            return Err(FalseClaim::Inconsistent(message));
        }
        if !unchanged && answer.edits == 0 {
            return Err(FalseClaim::Inconsistent("a new mesh from no edits".into()));
        }
        Ok(())
    }

    /// `<host>/blobs/<blake3 of its bytes>.<extension>` (a correction or a replay): the
    /// bytes cannot be checked here, the name can (and a receiver checks the bytes against
    /// the announced result).
    fn blob_url(&self, field: &'static str, url: &str, extension: &str) -> Result<(), FalseClaim> {
        let name = url.strip_prefix(self.host).and_then(|rest| rest.strip_prefix("/blobs/"));
        let digest = name
            .and_then(|name| name.strip_suffix(extension))
            .and_then(|name| name.strip_suffix('.'));
        match digest {
            Some(digest) if is_content_hash(digest) => Ok(()),
            _ => Err(FalseClaim::WrongUrl {
                field,
                url: shown(url),
                expected: format!("{}/blobs/<blake3>.{extension}", self.host),
            }),
        }
    }

    /// A check's answer: its value must have the declared result type (non-finite reals
    /// travel as `null`).
    pub fn check(&self, answer: &CheckResult, result_type: ValueType) -> Result<(), FalseClaim> {
        self.common(&answer.service, &answer.plugin, answer.compute_ms, answer.queue_ms)?;
        let nan = result_type == ValueType::Real && answer.value.is_null();
        if json_fits(result_type, &answer.value) || nan {
            return Ok(());
        }
        Err(FalseClaim::Inconsistent(format!(
            "{} returns {}, the answer was {}",
            self.service,
            value_type_name(result_type),
            json_type_name(&answer.value)
        )))
    }
}

/// A loaded session: its hash well formed (and the one asked for, if any), counts in limits.
pub fn loaded(status: &SessionStatus, expected: Option<&str>) -> Result<(), FalseClaim> {
    let hash = status.hash.as_deref().unwrap_or_default();
    content_hash("hash", hash)?;
    if let Some(expected) = expected.filter(|&e| e != hash) {
        return Err(FalseClaim::Inconsistent(format!("loaded mesh {hash}, asked for {expected}")));
    }
    counts(status.vertices.unwrap_or(0) as u64, status.triangles.unwrap_or(0) as u64)
}

/// An applied update: the host must now hold the announced mesh.
pub fn updated(answer: &Updated, announced: &str) -> Result<(), FalseClaim> {
    match answer.hash == announced {
        true => Ok(()),
        false => Err(FalseClaim::Inconsistent(format!(
            "applied an update to mesh {announced} and answered {}",
            shown(&answer.hash)
        ))),
    }
}

#[cfg(test)]
mod tests {
    use meshflow_api::host::{BlobRef, FullRef, SessionState, Transfer};
    use serde_json::json;

    use super::*;

    const HOST: &str = "http://127.0.0.1:7101";

    fn hash(byte: char) -> String {
        byte.to_string().repeat(64)
    }

    fn asked(input: &str) -> Asked<'_> {
        Asked { host: HOST, service: "smooth", input_hash: input, input_counts: (10, 16) }
    }

    /// What an honest host answers for a smoothing step on mesh `a…a`.
    fn honest() -> FilterResult {
        FilterResult {
            service: "smooth".into(),
            plugin: hash('e'),
            input_hash: hash('a'),
            output_hash: hash('b'),
            vertices: 10,
            triangles: 16,
            edits: 10,
            attributes: Vec::new(),
            compute_ms: 1.5,
            queue_ms: 0.0,
            report: String::new(),
            resolved_params: Default::default(),
            correction: BlobRef::new(format!("{HOST}/blobs/{}.mfc", hash('c')), 120),
            replay: BlobRef::new(format!("{HOST}/blobs/{}.mfr", hash('f')), 190),
            full: FullRef { url: format!("{HOST}/blobs/{}.mfm", hash('b')), hash: hash('b') },
        }
    }

    fn refused(change: impl FnOnce(&mut FilterResult)) -> String {
        let mut answer = honest();
        change(&mut answer);
        let input = hash('a');
        asked(&input).filter(&answer).expect_err("a false answer was taken").to_string()
    }

    #[test]
    fn an_honest_filter_answer_passes() {
        let input = hash('a');
        assert_eq!(asked(&input).filter(&honest()), Ok(()));
        // Moving every vertex back where it was: edits, and the same mesh.
        let same = FilterResult {
            output_hash: hash('a'),
            full: FullRef { url: format!("{HOST}/blobs/{}.mfm", hash('a')), hash: hash('a') },
            ..honest()
        };
        assert_eq!(asked(&input).filter(&same), Ok(()));
    }

    #[test]
    fn false_filter_answers_are_refused_saying_why() {
        assert!(
            refused(|a| a.output_hash = "not-a-hash".into()).contains("output_hash \"not-a-hash\"")
        );
        assert!(refused(|a| a.output_hash = hash('B')).contains("not a content hash"));
        assert!(refused(|a| a.plugin = "x".into()).contains("plugin"));
        assert!(refused(|a| a.input_hash = hash('d')).contains("the session held"));
        assert!(refused(|a| a.full.hash = hash('d')).contains("is not output_hash"));
        let elsewhere =
            refused(|a| a.full.url = format!("http://evil.example/blobs/{}.mfm", hash('b')));
        assert!(elsewhere.contains("full.url") && elsewhere.contains(HOST), "{elsewhere}");
        let other_mesh = refused(|a| a.full.url = format!("{HOST}/blobs/{}.mfm", hash('d')));
        assert!(other_mesh.contains("full.url"), "{other_mesh}");
        for url in [
            format!("http://evil.example/blobs/{}.mfc", hash('c')),
            format!("{HOST}/blobs/x.mfc"),
            format!("{HOST}/blobs/{}.mfm", hash('c')),
            format!("{HOST}/blobs/../{}.mfc", hash('c')),
            format!("{HOST}:8080/blobs/{}.mfc", hash('c')),
        ] {
            assert!(
                refused(|a| a.correction.url = url.clone()).contains("correction.url"),
                "{url}"
            );
        }
        let replay_elsewhere =
            refused(|a| a.replay.url = format!("http://evil.example/blobs/{}.mfr", hash('f')));
        assert!(replay_elsewhere.contains("replay.url"), "{replay_elsewhere}");
        assert!(refused(|a| a.replay.bytes = u64::MAX).contains("replay.bytes"));
        assert!(refused(|a| a.vertices = 123_456_789).contains("vertices = 123456789"));
        assert!(refused(|a| a.triangles = usize::MAX).contains("triangles"));
        assert!(refused(|a| a.correction.bytes = u64::MAX).contains("correction.bytes"));
        assert!(refused(|a| a.compute_ms = f64::NAN).contains("compute_ms"));
        assert!(refused(|a| a.queue_ms = -1.0).contains("queue_ms"));
        assert!(refused(|a| a.service = "other".into()).contains("asked for"));
        assert!(refused(|a| a.edits = 0).contains("no edits"));
        let grown = refused(|a| {
            a.output_hash = hash('a');
            a.full = FullRef { url: format!("{HOST}/blobs/{}.mfm", hash('a')), hash: hash('a') };
            a.vertices = 11;
        });
        assert!(grown.contains("not the input's"), "{grown}");
        // A host's text is cut short and quoted in the error.
        let long = refused(|a| a.output_hash = "<script>".repeat(1000));
        assert!(long.len() < 200 && long.contains('…'), "{long}");
    }

    #[test]
    fn a_pinned_task_must_name_the_pinned_plugin() {
        assert_eq!(ran_pinned(&hash('e'), None), Ok(()));
        assert_eq!(ran_pinned(&hash('e'), Some("eeeeeeeeeeee")), Ok(()));
        assert!(ran_pinned(&hash('e'), Some(&hash('f'))).is_err());
    }

    #[test]
    fn a_check_answer_must_have_the_declared_type() {
        let input = hash('a');
        let answer = |value| CheckResult {
            service: "smooth".into(),
            plugin: hash('e'),
            value,
            compute_ms: 0.1,
            queue_ms: 0.0,
            report: String::new(),
            resolved_params: Default::default(),
        };
        let asked = asked(&input);
        assert_eq!(asked.check(&answer(json!(true)), ValueType::Boolean), Ok(()));
        assert_eq!(asked.check(&answer(json!(2.5)), ValueType::Real), Ok(()));
        assert_eq!(asked.check(&answer(json!(null)), ValueType::Real), Ok(()));
        assert_eq!(asked.check(&answer(json!(3)), ValueType::Integer), Ok(()));
        for (value, ty) in [
            (json!("yes"), ValueType::Boolean),
            (json!(2.5), ValueType::Integer),
            (json!(null), ValueType::Boolean),
            (json!([1]), ValueType::Real),
        ] {
            assert!(asked.check(&answer(value.clone()), ty).is_err(), "{value} as {ty:?}");
        }
    }

    #[test]
    fn loaded_sessions_and_updates_must_name_the_right_mesh() {
        let status = |hash: &str, vertices| SessionStatus {
            grid: None,
            id: "s".into(),
            state: SessionState::Ready,
            hash: Some(hash.into()),
            vertices: Some(vertices),
            triangles: Some(4),
            error: None,
            download_ms: None,
            load_ms: None,
            input_bytes: None,
            not_kept: Vec::new(),
            attributes: Vec::new(),
        };
        assert_eq!(loaded(&status(&hash('a'), 4), None), Ok(()));
        assert_eq!(loaded(&status(&hash('a'), 4), Some(&hash('a'))), Ok(()));
        assert!(loaded(&status(&hash('a'), 4), Some(&hash('b'))).is_err());
        assert!(loaded(&status("nope", 4), None).is_err());
        assert!(loaded(&status(&hash('a'), 1 << 40), None).is_err());
        let update = |hash: String| Updated {
            hash,
            via: Transfer::Correction,
            bytes: 1,
            download_ms: 0.0,
            apply_ms: 0.0,
            fallback: None,
            disagreed: None,
            plugin_wait_ms: None,
        };
        assert_eq!(updated(&update(hash('b')), &hash('b')), Ok(()));
        assert!(updated(&update(hash('c')), &hash('b')).is_err());
    }
}
