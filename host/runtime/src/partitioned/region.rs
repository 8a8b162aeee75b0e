//! The second pass for a local service that edits connectivity. What such a service adds
//! (a vertex where it splits an edge) takes the next free id, so the ids follow the order
//! of all its edits over the mesh, which no partition alone has. The partitions' runs tell
//! where the edits are; the service then runs once more on one region: every triangle
//! within its reach plus one ring of a vertex the partitions changed. Its edits, renamed to
//! the mesh's ids ([`Placement`]), are the step.
//!
//! The region's run is trusted only if every vertex it changed is at most one edge from a
//! vertex it was grown around: the triangles within the reach of such a vertex are all in
//! the region, so it saw what a run on the whole mesh sees there. If the run changed
//! vertices beyond (a cascade the partitions ended elsewhere), the region grows around
//! them too and runs again, up to [`REGION_ROUNDS`] times.

use std::sync::Arc;

use meshflow_mesh::partition::{Placement, Unplaceable};
use meshflow_mesh::store::MeshStore;

use super::{RunError, RunState, Work, permits};

/// Runs on a region before a service whose edits keep spreading is refused.
const REGION_ROUNDS: usize = 4;

/// The step, made on a region.
pub(super) struct RegionRun {
    /// The whole mesh with the region's edits placed in it.
    pub(super) edited: MeshStore,
    pub(super) report: String,
    /// The region's run (its output and peak).
    pub(super) state: RunState,
    /// Triangles of the last region, and vertices it was grown around.
    pub(super) triangles: usize,
    pub(super) changed: usize,
}

impl Work<'_> {
    /// Runs the service on the region around `changed` (the mesh's vertices the partitions
    /// changed, ascending) and places its edits in the whole mesh.
    pub(super) fn run_region(
        &self,
        slot: &permits::Permit<'_>,
        mut changed: Vec<u32>,
    ) -> Result<RegionRun, RunError> {
        let bound = self.most_triangles();
        for round in 1..=REGION_ROUNDS {
            let label = format!("{} (the region of its edits, round {round})", self.service);
            let Some(region) = self.cut.region(changed.clone(), self.rings + 1, bound) else {
                let message = format!(
                    "its edits change {} vertices, and the region within its reach of them \
                     holds more than {bound} triangles; run it on a mesh of at most the \
                     partition size",
                    changed.len()
                );
                return Err(RunError::Failed { service: label, message });
            };
            let triangles = region.triangles;
            let region_triangles = region.mesh.triangle_count();
            let whole = self.cut.whole(region.vertices);
            let (report, mut state) = self.run_on(slot, &label, region.mesh, whole)?;
            let log = state.mesh.take_log();
            let vertices = &state.mesh.whole().expect("its whole was set before the run").ids;
            let placement = Placement::new(vertices, &triangles, self.mesh);
            let not_local =
                |e: Unplaceable| RunError::NotLocal { service: label.clone(), edit: e.edit };
            let made = placement.changed_vertices(&state.mesh).map_err(not_local)?;
            let within = self.cut.neighbourhood(&changed);
            let beyond: Vec<u32> =
                made.iter().copied().filter(|v| within.binary_search(v).is_err()).collect();
            if !beyond.is_empty() {
                changed.extend(beyond);
                changed.sort_unstable();
                continue;
            }
            let mut edited = MeshStore::new(Arc::clone(self.mesh));
            for op in log {
                let op = placement.to_whole(op).map_err(not_local)?;
                edited.apply(op).map_err(|e| RunError::Failed {
                    service: label.clone(),
                    message: format!("its edits do not apply to the whole mesh: {e}"),
                })?;
            }
            return Ok(RegionRun {
                edited,
                report,
                state,
                triangles: region_triangles,
                changed: changed.len(),
            });
        }
        Err(RunError::ReachExceeded { service: self.service.to_owned(), rings: self.rings })
    }
}
