//! A finished run's result held by a second host (issue 30 item 5): a host of the run that
//! already holds the final mesh in a session (a replica), or that takes it cheaply — the
//! last step's edit log when it is smaller than the mesh, else the full mesh. The run ends
//! once it holds the result (hash checked); it packs and stores it after (`finish::Keeping`),
//! so the result outlives its producer; result downloads fall back to it
//! (`crate::downloads`).

use meshflow_api::HostClient;
use meshflow_api::host::{FullRef, Transfer as Use, Update};

use super::Executor;

impl Executor {
    /// A second host of the run holding the result in its session, and the URL it will
    /// serve it packed at, if one could take it.
    pub(super) async fn second_copy(&mut self) -> Option<(HostClient, String)> {
        let producer = self.current.producer.clone()?;
        let hash = self.current.hash.clone();
        let full = FullRef { url: self.current.full.url.clone(), hash: hash.clone() };
        // On a slow link the edit log of the last step (often a few hundred bytes) is what
        // keeps this off the run's end; the host falls back to the full mesh by itself.
        let full_bytes = self.current.last_full.estimate(self.current.vertices);
        let correction = self.current.correction.clone().filter(|log| log.bytes < full_bytes);
        let use_ = if correction.is_some() { Use::Correction } else { Use::Full };
        // Cheapest first: a host that holds the result already, then one that holds the last
        // step's input (its edit log applies there), then any other (the full mesh).
        let last_input = self.run.record().steps.iter().rev().find_map(|step| {
            (step.output_hash.as_deref() == Some(hash.as_str())).then(|| step.input_hash.clone())
        });
        let cost = |known: &str| match known {
            _ if known == hash => 0,
            _ if last_input.as_deref() == Some(known) => 1,
            _ => 2,
        };
        self.replicas.sort_by_key(|replica| cost(&replica.hash));
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
            return Some((replica.host.client.clone(), url));
        }
        None
    }
}
