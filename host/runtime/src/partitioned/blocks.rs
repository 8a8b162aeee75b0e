//! Runs block by block (issue 33): a filter whose `blocks.block-triangles` says `n` for its
//! parameters (quadric decimation with a ratio target) runs on a mesh of more than `n`
//! triangles as its definition says: on each block of about `n` triangles
//! ([`Partitioning::blocks`]) as a mesh of its own, each in a sandbox of its own, as many at
//! once as there are run slots. A block's edits must keep the vertices it shares with other
//! blocks (not moved, not removed): then no two blocks' edits meet, and they are placed in
//! the whole mesh ([`Placement`]) block after block, as one recorded step. The blocks depend
//! on the mesh and `n` alone, never on a host's limits, so every host reaches the same hash.
//!
//! [`Partitioning::blocks`]: meshflow_mesh::partition::Partitioning::blocks

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use wasmtime::component::{Component, ComponentExportIndex};

use super::{
    Partitions, Plugin, RunError, RunOutput, Runtime, capture_output, optional_export, permits,
};
use crate::MIN_BLOCK_TRIANGLES;
use crate::bindings::Param;
use crate::work_queue::{End, WorkQueue};
use meshflow_mesh::MeshData;
use meshflow_mesh::partition::{Block, Blocks, Partitioning, Placement};
use meshflow_mesh::store::{MeshStore, Op};

/// The optional export a `block-plugin` has.
const BLOCKS_INTERFACE: &str = "meshflow:geometry/blocks@0.1.0";

/// `blocks.block-triangles` of a component that exports it.
pub(crate) fn blocks_export(component: &Component) -> Option<ComponentExportIndex> {
    optional_export(component, BLOCKS_INTERFACE, "block-triangles")
}

/// What one block's run left: its edits and where its elements are in the mesh.
struct BlockRun {
    log: Vec<Op>,
    vertices: Vec<u32>,
    triangles: Vec<u32>,
    report: String,
}

/// What the blocks' runs have produced so far.
struct Ran {
    blocks: Vec<Option<BlockRun>>,
    stdout: String,
    stderr: String,
    guest_peak_bytes: usize,
    largest: usize,
    /// The first block's failure: it fails the step.
    error: Option<RunError>,
}

impl Runtime {
    /// Runs filter `service` of `plugin` on the blocks of `mesh` of about `block_triangles`
    /// triangles each and records their edits as one step.
    pub(crate) fn run_in_blocks(
        &self,
        plugin: &Plugin,
        service: &str,
        mesh: &Arc<MeshData>,
        params: &[Param],
        block_triangles: usize,
    ) -> Result<RunOutput, RunError> {
        let started = Instant::now();
        if block_triangles < MIN_BLOCK_TRIANGLES {
            let message = format!(
                "declared blocks of {block_triangles} triangles; a block needs at least \
                 {MIN_BLOCK_TRIANGLES}"
            );
            return Err(RunError::Failed { service: service.to_owned(), message });
        }
        let cut = Partitioning::new(mesh, block_triangles);
        let blocks = cut.blocks();
        let (slot, queued) = self.acquire_slot(service)?;
        let ran = Mutex::new(Ran {
            blocks: (0..blocks.len()).map(|_| None).collect(),
            stdout: String::new(),
            stderr: String::new(),
            guest_peak_bytes: 0,
            largest: 0,
            error: None,
        });
        let work = BlockWork {
            runtime: self,
            plugin,
            service,
            params,
            mesh,
            blocks: &blocks,
            queue: WorkQueue::new(blocks.len()),
            ends: started + self.limits.deadline,
            ran: &ran,
        };
        let workers = self.workers_for(blocks.len());
        self.with_helpers(&slot, workers, &work.queue, |slot, end| work.run(slot, end));
        drop(slot);
        let ran = ran.into_inner().unwrap_or_else(|e| e.into_inner());
        if let Some(error) = ran.error {
            return Err(error);
        }
        let failed = |message: String| RunError::Failed { service: service.to_owned(), message };
        let mut store = MeshStore::new(Arc::clone(mesh));
        let mut reports = Vec::new();
        for (index, block) in ran.blocks.into_iter().enumerate() {
            let Some(block) = block else {
                return Err(failed(format!("block {} did not run", index + 1)));
            };
            let placement = Placement::new(&block.vertices, &block.triangles, mesh)
                .after(store.vertex_slots(), store.triangle_slots());
            for op in block.log {
                let op = placement.to_whole(op).map_err(|e| RunError::NotLocal {
                    service: format!("{service} (block {} of {})", index + 1, blocks.len()),
                    edit: e.edit,
                })?;
                store.apply(op).map_err(|e| failed(format!("block {}: {e}", index + 1)))?;
            }
            reports.push(block.report);
        }
        let (edited, log) = store.finish();
        let report = format!(
            "{} (in {} blocks of about {block_triangles} triangles, the {} vertices they share \
             kept: {} → {} triangles)",
            reports.first().map_or("", String::as_str),
            blocks.len(),
            blocks.shared_count(),
            mesh.triangle_count(),
            edited.triangle_count()
        );
        Ok(RunOutput {
            mesh: Some(edited),
            log,
            value: None,
            report,
            stdout: ran.stdout,
            stderr: ran.stderr,
            duration: started.elapsed(),
            queued,
            guest_peak_bytes: ran.guest_peak_bytes,
            partitions: Some(Partitions {
                count: blocks.len(),
                rings: 0,
                core_triangles: block_triangles,
                largest: ran.largest,
            }),
        })
    }
}

/// The blocks, handed out one at a time to the workers.
struct BlockWork<'a> {
    runtime: &'a Runtime,
    plugin: &'a Plugin,
    service: &'a str,
    params: &'a [Param],
    mesh: &'a MeshData,
    blocks: &'a Blocks<'a>,
    queue: WorkQueue,
    /// The step's deadline: every block runs within what is left of it.
    ends: Instant,
    ran: &'a Mutex<Ran>,
}

impl BlockWork<'_> {
    /// Runs blocks until none is left or one has failed.
    fn run(&self, slot: &permits::Permit<'_>, end: End) {
        while let Some(index) = self.queue.take(end) {
            if let Err(error) = self.run_one(slot, index) {
                self.queue.stop();
                let mut ran = self.ran.lock().unwrap_or_else(|e| e.into_inner());
                ran.error.get_or_insert(error);
                return;
            }
        }
    }

    fn run_one(&self, slot: &permits::Permit<'_>, index: usize) -> Result<(), RunError> {
        let label = format!("{} (block {} of {})", self.service, index + 1, self.blocks.len());
        let left = self.ends.saturating_duration_since(Instant::now());
        if left == Duration::ZERO {
            let deadline = self.runtime.limits.deadline;
            return Err(RunError::Deadline { service: label, deadline });
        }
        let Block { mesh, vertices, triangles, shared } = self.blocks.block(index);
        let triangle_count = mesh.triangle_count();
        let (outcome, mut state) = self.runtime.call(
            slot,
            &self.plugin.pre,
            &label,
            Arc::new(mesh),
            false,
            left,
            |store, p, _, mesh| {
                p.meshflow_geometry_service().call_run(store, self.service, mesh, self.params)
            },
        )?;
        let report =
            outcome.map_err(|message| RunError::Failed { service: label.clone(), message })?.report;
        // The border the blocks share stays where it is: else two blocks' edits could meet.
        let positions = state.mesh.positions();
        let moved = shared.iter().find(|&&v| {
            let whole = 3 * vertices[v as usize] as usize;
            let (now, before) =
                (&positions[3 * v as usize..][..3], &self.mesh.positions[whole..][..3]);
            !state.mesh.is_vertex_live(v)
                || now.iter().zip(before).any(|(a, b)| a.to_bits() != b.to_bits())
        });
        if let Some(&v) = moved {
            let message = format!(
                "moved or removed vertex {}, which it shares with another block; a service \
                 declared to run in blocks must keep its input's border",
                vertices[v as usize]
            );
            return Err(RunError::Failed { service: label, message });
        }
        let mut guard = self.ran.lock().unwrap_or_else(|e| e.into_inner());
        let ran = &mut *guard;
        ran.largest = ran.largest.max(triangle_count);
        ran.guest_peak_bytes = ran.guest_peak_bytes.max(state.memory.peak_bytes);
        capture_output(&mut ran.stdout, &mut ran.stderr, &state);
        ran.blocks[index] =
            Some(BlockRun { log: state.mesh.take_log(), vertices, triangles, report });
        Ok(())
    }
}
