//! A finished run's result held by a second host (issue 30 item 5): a host of the run that
//! already holds the final mesh in a session (a replica), or that takes it cheaply — the
//! last step's edit log when it is smaller than the mesh, else the full mesh — packs and
//! stores it too, so the result outlives its producer; result downloads fall back to it
//! (`crate::downloads`).

use meshflow_api::host::{FullRef, Transfer as Use, Update};

use super::Executor;

impl Executor {
    /// The URL of the result packed on a second host of the run, if one could take it.
    pub(super) async fn second_copy(&mut self) -> Option<String> {
        let producer = self.current.producer.clone()?;
        let hash = self.current.hash.clone();
        let full = FullRef { url: self.current.full.url.clone(), hash: hash.clone() };
        // On a slow link the edit log of the last step (often a few hundred bytes) is what
        // keeps this off the run's end; the host falls back to the full mesh by itself.
        let full_bytes = self.current.last_full.estimate(self.current.vertices);
        let correction = self.current.correction.clone().filter(|log| log.bytes < full_bytes);
        let use_ = if correction.is_some() { Use::Correction } else { Use::Full };
        for replica in self.replicas.iter_mut().filter(|r| r.host.url != producer) {
            if !replica.settle(&hash).await {
                let (correction, full) = (correction.clone(), full.clone());
                let update = Update { correction, replay: None, full, use_ };
                match replica.host.client.update(&replica.session, &update).await {
                    Ok(updated) if updated.hash.eq_ignore_ascii_case(&hash) => {
                        replica.hash = hash.clone()
                    }
                    _ => continue,
                }
            }
            let url = format!("{}/blobs/{hash}.mfm", replica.host.url);
            match replica.host.client.packed_size(&url).await {
                Ok(_) => return Some(url),
                Err(error) => tracing::debug!("a second copy of the result on {url}: {error}"),
            }
        }
        None
    }
}
