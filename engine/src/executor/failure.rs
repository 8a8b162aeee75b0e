//! Why a task could not run on its host, and what that makes of the host: down, suspect,
//! only busy, or blameless when the step itself failed.

use meshflow_api::ClientError;

use super::verify;
use crate::registry::HostEntry;

/// Why a task could not run on its host.
pub(super) enum Failure {
    /// The host is unreachable or broken: try another one.
    Host(String),
    /// The host's answer cannot be true: distrust it and try another one.
    Suspect(String),
    /// The host stayed busy (429) however often it was asked: try another one.
    Busy(String),
    /// The step itself failed (plugin error, bad parameters): the run ends.
    Step(String),
}

/// A step's own failure, with its message: it would fail the same way on another host.
pub(super) struct StepFailed(pub String);

/// A host that cannot be reached, times out or breaks is down and the task moves on; so
/// does a busy one (without blame); a refused request is the step's own fault and would
/// fail the same way elsewhere.
impl From<ClientError> for Failure {
    fn from(error: ClientError) -> Self {
        match error {
            ClientError::Busy { .. } => Failure::Busy(error.to_string()),
            _ if error.is_host_failure() => Failure::Host(error.to_string()),
            _ => Failure::Step(error.to_string()),
        }
    }
}

impl From<verify::FalseClaim> for Failure {
    fn from(claim: verify::FalseClaim) -> Self {
        Failure::Suspect(claim.to_string())
    }
}

impl Failure {
    /// Marks `host` as this failure says — down, suspect, or (busy) neither — and returns
    /// what to tell about it; [`StepFailed`] for a step's own failure.
    pub fn set_aside(self, host: &HostEntry) -> Result<String, StepFailed> {
        match self {
            Failure::Host(message) => {
                tracing::warn!(host = %host.url, "marking host down: {message}");
                host.mark_down(message.clone());
                Ok(message)
            }
            Failure::Suspect(message) => {
                let message = format!("suspect: {message}");
                tracing::warn!(host = %host.url, "{message}");
                host.mark_suspect(message.clone());
                Ok(message)
            }
            Failure::Busy(message) => Ok(message),
            Failure::Step(message) => Err(StepFailed(message)),
        }
    }
}
