//! What each service needed of guest memory per input triangle on a runtime's earlier runs,
//! so that a run stopped at the memory limit can say the largest mesh the service takes
//! (issue 33: a service global by nature says so in its refusal). A service's need is
//! linear in the triangles (measured at 2M, 10M and 40M triangles, docs/benchmarks.md); only
//! runs that grew the guest's memory past its initial size tell it.

use std::collections::HashMap;
use std::sync::Mutex;

use super::{MAX_REMEMBERED_FOOTPRINTS, RunError};

#[derive(Default)]
pub(crate) struct Footprints {
    /// Bytes per triangle, the most seen, by (plugin digest, service).
    learned: Mutex<HashMap<(String, String), f64>>,
}

impl Footprints {
    /// A run of `service` that grew its memory to `peak_bytes` on `triangles` triangles.
    pub(crate) fn learn(&self, digest: &str, service: &str, peak_bytes: usize, triangles: usize) {
        if triangles == 0 {
            return;
        }
        let bytes = peak_bytes as f64 / triangles as f64;
        let mut learned = self.learned.lock().unwrap_or_else(|e| e.into_inner());
        let full = learned.len() >= MAX_REMEMBERED_FOOTPRINTS;
        let key = (digest.to_owned(), service.to_owned());
        match learned.get_mut(&key) {
            Some(known) => *known = known.max(bytes),
            None if !full => {
                learned.insert(key, bytes);
            }
            None => {}
        }
    }

    /// `error`, with what earlier runs of `service` needed when it is a stop at the limit.
    pub(crate) fn explain(&self, error: RunError, digest: &str, service: &str) -> RunError {
        match error {
            RunError::Memory { service: label, limit_mib, fit: Some(mut fit) } => {
                let learned = self.learned.lock().unwrap_or_else(|e| e.into_inner());
                fit.learned_bytes_per_triangle =
                    learned.get(&(digest.to_owned(), service.to_owned())).copied();
                RunError::Memory { service: label, limit_mib, fit: Some(fit) }
            }
            other => other,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MemoryFit;

    #[test]
    fn the_most_a_service_needed_is_what_a_refusal_says() {
        let footprints = Footprints::default();
        footprints.learn("d", "fill-holes", 590 << 20, 10_000_000);
        footprints.learn("d", "fill-holes", 300 << 20, 10_000_000);
        footprints.learn("other", "fill-holes", 2000 << 20, 10_000_000);
        let stopped = |service: &str| RunError::Memory {
            service: service.to_owned(),
            limit_mib: 2048,
            fit: Some(MemoryFit { triangles: 44_000_000, learned_bytes_per_triangle: None }),
        };
        let error = footprints.explain(stopped("fill-holes"), "d", "fill-holes");
        let RunError::Memory { fit: Some(fit), .. } = &error else { panic!("{error}") };
        assert_eq!(fit.learned_bytes_per_triangle, Some((590 << 20) as f64 / 1e7));
        let said = error.to_string();
        // 2048 MiB over 44M triangles is 48.8 bytes each; 590 MiB over 10M is 61.9.
        assert!(said.contains("44000000 triangles it needed more than 49 bytes a triangle"));
        let fits = |mib: usize| ((mib << 20) as f64 / ((590 << 20) as f64 / 1e7)) as u64;
        let expected = format!(
            "needed 62 bytes a triangle, so it takes meshes of up to about {} triangles under \
             this limit and {} under 4096 MiB",
            fits(2048),
            fits(4096)
        );
        assert!(said.contains(&expected), "{said}");
        assert_eq!(fits(2048), 34_711_864, "2048 MiB / (590 MiB / 10M)");
        assert!(said.ends_with("(raise it with --memory-cap, at most 4096)"), "{said}");
        // Nothing learned of this service: only what this run tells.
        let said = footprints.explain(stopped("holes"), "d", "holes").to_string();
        assert!(!said.contains("earlier runs") && said.contains("more than 49 bytes"), "{said}");
    }
}
