//! Forgetting what nobody needs: sessions idle past their TTL, then the oldest blobs no
//! session needs while the total is over the budget.

use std::sync::Arc;

use super::config::EVICTION_INTERVAL;
use super::state::Host;

/// Deletes idle sessions, then enforces the blob budget; every `EVICTION_INTERVAL`.
pub async fn run_periodically(host: Arc<Host>) {
    let mut ticks = tokio::time::interval(EVICTION_INTERVAL);
    loop {
        ticks.tick().await;
        for id in host.sessions.idle_longer_than(host.config.session_ttl) {
            tracing::info!(
                "session {id} idle for longer than {:?}: deleted",
                host.config.session_ttl
            );
            host.sessions.remove(&id);
        }
        enforce_budget(&host).await;
    }
}

/// Evicts the oldest blobs no session needs until the total is within the budget. A
/// failure is logged: it costs disk space, not correctness.
pub async fn enforce_budget(host: &Host) {
    match host.blobs.evict(host.sessions.needed_blobs()).await {
        Ok(evicted) if !evicted.is_empty() => tracing::info!("evicted {} blobs", evicted.len()),
        Ok(_) => {}
        Err(e) => tracing::warn!("blob eviction failed: {e}"),
    }
}
