//! What each service needed of guest memory per input triangle on a runtime's earlier runs,
//! so that a run stopped at the memory limit can say the largest mesh the service takes
//! (issue 33: a service global by nature says so in its refusal), and a local service is
//! cut into partitions at once where it is known not to fit. A service's need is linear in
//! the triangles (measured at 2M, 10M and 40M triangles, docs/benchmarks.md); only runs
//! that grew the guest's memory past its initial size tell it.

use std::collections::HashMap;
use std::sync::Mutex;

use super::{MAX_REMEMBERED_FOOTPRINTS, RunError};

#[derive(Default)]
pub(crate) struct Footprints {
    /// By (plugin digest, service).
    known: Mutex<HashMap<(String, String), Footprint>>,
}

#[derive(Clone, Copy, Default)]
struct Footprint {
    /// The most bytes per triangle a run needed.
    bytes_per_triangle: Option<f64>,
    /// The fewest triangles a run stopped at this runtime's memory limit on.
    stopped_at: Option<usize>,
}

impl Footprints {
    /// Updates what is known of `service` (nothing once `MAX_REMEMBERED_FOOTPRINTS` pairs
    /// are known and it is not one of them).
    fn update(&self, digest: &str, service: &str, f: impl FnOnce(&mut Footprint)) {
        let mut known = self.known.lock().unwrap_or_else(|e| e.into_inner());
        let key = (digest.to_owned(), service.to_owned());
        if let Some(footprint) = known.get_mut(&key) {
            f(footprint);
        } else if known.len() < MAX_REMEMBERED_FOOTPRINTS {
            f(known.entry(key).or_default());
        }
    }

    fn get(&self, digest: &str, service: &str) -> Footprint {
        let known = self.known.lock().unwrap_or_else(|e| e.into_inner());
        known.get(&(digest.to_owned(), service.to_owned())).copied().unwrap_or_default()
    }

    /// A run of `service` that grew its memory to `peak_bytes` on `triangles` triangles.
    pub(crate) fn learn(&self, digest: &str, service: &str, peak_bytes: usize, triangles: usize) {
        if triangles == 0 {
            return;
        }
        let bytes = peak_bytes as f64 / triangles as f64;
        self.update(digest, service, |known| {
            known.bytes_per_triangle =
                Some(known.bytes_per_triangle.map_or(bytes, |b| b.max(bytes)));
        });
    }

    /// A run of `service` on `triangles` triangles stopped at the memory limit.
    pub(crate) fn stopped(&self, digest: &str, service: &str, triangles: usize) {
        self.update(digest, service, |known| {
            known.stopped_at = Some(known.stopped_at.map_or(triangles, |t| t.min(triangles)));
        });
    }

    /// Whether earlier runs show that `service` needs more than `limit_bytes` on
    /// `triangles` triangles: one as large stopped at the limit, or the most it needed a
    /// triangle says so. Nothing known: `false`.
    pub(crate) fn known_not_to_fit(
        &self,
        digest: &str,
        service: &str,
        triangles: usize,
        limit_bytes: usize,
    ) -> bool {
        let known = self.get(digest, service);
        known.stopped_at.is_some_and(|stopped| triangles >= stopped)
            || known.bytes_per_triangle.is_some_and(|b| b * triangles as f64 > limit_bytes as f64)
    }

    /// `error`, with what earlier runs of `service` needed when it is a stop at the limit.
    pub(crate) fn explain(&self, error: RunError, digest: &str, service: &str) -> RunError {
        match error {
            RunError::Memory { service: label, limit_mib, fit: Some(mut fit) } => {
                fit.learned_bytes_per_triangle = self.get(digest, service).bytes_per_triangle;
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

    #[test]
    fn a_service_is_known_not_to_fit_by_its_need_or_by_a_stop_on_a_mesh_as_large() {
        let footprints = Footprints::default();
        let limit = 2048 << 20;
        assert!(!footprints.known_not_to_fit("d", "smooth", 100_000_000, limit), "unknown");
        // 62 bytes a triangle: 34.7M triangles fit 2048 MiB.
        footprints.learn("d", "smooth", 620_000_000, 10_000_000);
        assert!(!footprints.known_not_to_fit("d", "smooth", 34_000_000, limit));
        assert!(footprints.known_not_to_fit("d", "smooth", 35_000_000, limit));
        // A stop on 20M triangles: that many and more are not tried whole again.
        footprints.stopped("d", "noise", 20_000_000);
        assert!(footprints.known_not_to_fit("d", "noise", 20_000_000, limit));
        assert!(!footprints.known_not_to_fit("d", "noise", 19_999_999, limit));
        assert!(!footprints.known_not_to_fit("other", "noise", 20_000_000, limit));
        // A stop tells no need a triangle: a refusal says only what it measured.
        let said = footprints
            .explain(
                RunError::Memory {
                    service: "noise".into(),
                    limit_mib: 2048,
                    fit: Some(MemoryFit {
                        triangles: 20_000_000,
                        learned_bytes_per_triangle: None,
                    }),
                },
                "d",
                "noise",
            )
            .to_string();
        assert!(!said.contains("earlier runs"), "{said}");
    }
}
