//! Opening a session on a host: from the run's input, or from a copy of the current mesh
//! (a host joining the run or catching up).

use std::sync::Arc;

use meshflow_api::host::{CreateSession, GridSpec, InputRef, SessionState, SessionStatus};

use super::failure::Failure;
use super::verify;
use crate::registry::HostEntry;
use crate::run::Run;

/// Opens a session on `host` from `url` (the run deletes it when it ends) and waits until
/// it is loaded.
pub(super) async fn load_input(
    run: &Run,
    host: Arc<HostEntry>,
    url: &str,
    hash: Option<String>,
    grid: Option<GridSpec>,
) -> Result<(String, SessionStatus), Failure> {
    let input = InputRef { url: url.to_owned(), hash: hash.clone() };
    let created = host.client.create_session_with(CreateSession { input, grid }).await?;
    run.session_opened(&host.url, &created.id);
    let status = host.client.wait_ready(&created.id).await?;
    match status.state {
        SessionState::Failed => Err(Failure::Step(
            status.error.unwrap_or_else(|| "the host could not load it".to_owned()),
        )),
        _ => {
            verify::loaded(&status, hash.as_deref())?;
            Ok((created.id, status))
        }
    }
}
