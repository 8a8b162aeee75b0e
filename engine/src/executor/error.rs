//! Why a run ends without its result. The run's record says it in words
//! (`Run::set_status`), so each message is the one the record has always had.

use std::collections::BTreeSet;

use serde_json::Value as Json;

use crate::limits::MAX_STEPS_PER_RUN;
use crate::workflow::WorkflowError;

/// A host's message without the input URL it starts with (the error names it once).
fn without_url<'a>(message: &'a str, url: &str) -> &'a str {
    message.strip_prefix(url).and_then(|rest| rest.strip_prefix(": ")).unwrap_or(message)
}

#[derive(Debug, thiserror::Error)]
pub enum ExecError {
    /// No plan: some task's service is offered by no host.
    #[error(transparent)]
    Plan(#[from] WorkflowError),
    /// The input could not be loaded, for a reason of its own (not a host's).
    #[error("input {input}: {}", without_url(.message, .input))]
    Input { input: String, message: String },
    #[error("input {input}: hosts decoded it differently ({hashes:?})")]
    InputDecodedDifferently { input: String, hashes: BTreeSet<String> },
    #[error("{path}: host {host} failed and no other host offers \"{service}\"")]
    NoReplacement { path: String, host: String, service: String },
    #[error("{path}: the run has executed {max} steps, the most one run may", max = MAX_STEPS_PER_RUN)]
    TooManySteps { path: String },
    /// Every host offering the task's service failed; `reasons` says how, host by host.
    #[error("{path}: no host left for \"{service}\" (failed: {reasons})")]
    NoHostLeft { path: String, service: String, reasons: String },
    /// The step itself failed (plugin error, bad parameters): it would fail elsewhere too.
    #[error("{path} ({service} on {host}): {message}")]
    Step { path: String, service: String, host: String, message: String },
    #[error("{path}: {service} returned a check value, not a mesh")]
    NotAMesh { path: String, service: String },
    #[error("{path}: {service} is not a check")]
    NotACheck { path: String, service: String },
    #[error("{path}: {source}")]
    Condition { path: String, source: CompareError },
    /// A resumed run: the recorded check has no outcome.
    #[error("{0}: no recorded outcome")]
    NoRecordedOutcome(String),
    /// A resumed run: the recorded steps do not follow the workflow.
    #[error("the record has {recorded_kind} {recorded_path} where the workflow has {kind} {path}")]
    RecordMismatch { recorded_kind: String, recorded_path: String, kind: String, path: String },
    #[error("the record has steps but no input")]
    NoRecordedInput,
    /// Hosts disagree about the step and no uninvolved host could replay it.
    #[error(
        "{path}: hosts disagree about the step and no uninvolved host could replay it: {claims}"
    )]
    Unsettled { path: String, claims: String },
    /// An untrusted host's result that no other host could replay.
    #[error(
        "{path}: untrusted host {host} announced {claimed} and no other host could replay the step"
    )]
    Unverified { path: String, host: String, claimed: String },
    /// A replay contradicted a result later steps were built on.
    #[error("{path}: {message}")]
    Contradicted { path: String, message: String },
    /// A spot check contradicted a step's result before the run completed.
    #[error("{0}")]
    SpotCheck(String),
    /// A resumed run: a recorded filter has no output hash.
    #[error("{0}: no output hash")]
    NoOutputHash(String),
}

/// Why a check's value and a condition's cannot be compared.
#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    #[error("cannot compare {0} with {1}")]
    Unordered(f64, f64),
    #[error("the check returned {actual}, which cannot be compared with {expected}")]
    Mismatch { actual: Json, expected: Json },
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The record says these in words, as it always has.
    #[test]
    fn messages_read_as_the_record_has_them() {
        let steps = ExecError::TooManySteps { path: "steps[1]".into() };
        let steps_text = "steps[1]: the run has executed 20000 steps, the most one run may";
        assert_eq!(steps.to_string(), steps_text);
        let hashes = ["b".to_owned(), "a".to_owned()].into_iter().collect();
        let decoded = ExecError::InputDecodedDifferently { input: "http://in".into(), hashes };
        let decoded_text = "input http://in: hosts decoded it differently ({\"a\", \"b\"})";
        assert_eq!(decoded.to_string(), decoded_text);
        let source = CompareError::Unordered(f64::NAN, 1.0);
        let condition = ExecError::Condition { path: "steps[0].while".into(), source };
        assert_eq!(condition.to_string(), "steps[0].while: cannot compare NaN with 1");
    }
}
