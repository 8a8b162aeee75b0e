//! Runs on partitions (issue 33): a filter that declares itself local (`locality.reach`)
//! runs on a mesh larger than [`Limits::partition_triangles`] one partition at a time, each
//! in a sandbox of its own (as many at once as there are run slots), and is recorded as one
//! step: one edit log, one replay and one result hash, equal to the whole-mesh run's when
//! the declaration holds.
//!
//! - A service that only moves vertices (smoothing) keeps each partition's result for its
//!   core vertices: one `set-positions` on the whole mesh. The declaration is audited on
//!   every such run: a patch of the first partition's core (its first [`AUDIT_VERTICES`]
//!   vertices in Morton order) runs a second time with one ring more, and must come out the
//!   same bit for bit, or the step fails (a service that reads more of the mesh than it
//!   declared, or depends on the mesh's size, would make the result depend on the cut).
//! - A service that edits connectivity (degenerate repair) is run again on one region
//!   around every vertex the partitions changed ([`region`]): the numbering of what it adds
//!   follows the order of all its edits, which only one run over all of them has.
//!
//! [`Limits::partition_triangles`]: crate::Limits::partition_triangles

mod blocks;
mod region;

pub(crate) use blocks::blocks_export;

use std::sync::Arc;
use std::sync::Mutex;
use std::time::Instant;

use wasmtime::Store;
use wasmtime::component::{Component, ComponentExportIndex, Instance, TypedFunc};

use super::Plugin;
use super::bindings::Param;
use super::state::RunState;
use super::work_queue::{End, WorkQueue};
use super::{MAX_PARTITION_GROWTH, RunError, RunOutput, Runtime, captured, permits};
use meshflow_mesh::MeshData;
use meshflow_mesh::partition::{Partition, Partitioning, Placement, Whole};
use meshflow_mesh::store::{MeshStore, Op, OpKind};
use meshflow_params::ServiceInfo;

/// The optional export a `local-plugin` has.
const LOCALITY_INTERFACE: &str = "meshflow:geometry/locality@0.1.0";

/// Vertices of partition 1's core the audit runs again with one ring more: a patch, so
/// the audit costs a small share of the step however few partitions there are.
const AUDIT_VERTICES: usize = 50_000;

/// `locality.reach` and `blocks.block-triangles`: a number a service declares for a
/// service name and its parameters.
type DeclarationFunc = TypedFunc<(String, Vec<Param>), (Option<u32>,)>;

/// How a run on partitions cut the mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Partitions {
    /// Partitions the mesh was cut into.
    pub count: usize,
    /// Rings of overlap around each core (the service's reach).
    pub rings: u32,
    /// Triangles of a core at most ([`Limits::partition_triangles`](crate::Limits)).
    pub core_triangles: usize,
    /// The most triangles one partition held, its overlap included.
    pub largest: usize,
}

/// `locality.reach` of a component that exports it.
pub(crate) fn reach_export(component: &Component) -> Option<ComponentExportIndex> {
    optional_export(component, LOCALITY_INTERFACE, "reach")
}

/// Function `name` of interface `interface`, when the component exports it.
fn optional_export(
    component: &Component,
    interface: &str,
    name: &str,
) -> Option<ComponentExportIndex> {
    let interface = component.get_export_index(None, interface)?;
    component.get_export_index(Some(&interface), name)
}

/// The typed declaration (`reach`, `block-triangles`) of an instance: fails when the
/// export has another signature.
pub(crate) fn declaration_func(
    store: &mut Store<RunState>,
    instance: &Instance,
    index: &ComponentExportIndex,
) -> wasmtime::Result<DeclarationFunc> {
    instance.get_typed_func(store, index)
}

impl Runtime {
    /// Runs filter `info` of `plugin` on partitions of `mesh` if the plugin says it reaches a
    /// bounded number of rings with these parameters; `None` if it does not, or if its
    /// reach would give partitions of most of the mesh (it then runs whole).
    pub(crate) fn run_partitioned(
        &self,
        plugin: &Plugin,
        info: &ServiceInfo,
        mesh: &Arc<MeshData>,
        params: &[Param],
    ) -> Result<Option<RunOutput>, RunError> {
        let Some(reach_index) = plugin.reach.as_ref() else { return Ok(None) };
        let service = info.name.as_str();
        let started = Instant::now();
        let (slot, queued) = self.acquire_slot(service)?;
        let deadline = self.limits.deadline;
        let (rings, _) = self.call(
            &slot,
            &plugin.pre,
            service,
            Arc::default(),
            true,
            deadline,
            |store, _, instance, _| {
                let reach = declaration_func(store, instance, reach_index)?;
                Ok(reach.call(store, (service.to_owned(), params.to_vec()))?.0)
            },
        )?;
        let Some(rings) = rings else { return Ok(None) };
        let core_triangles = self.limits.partition_triangles();
        let cut = Partitioning::new(mesh, core_triangles);
        if cut.len() < 2 {
            return Ok(None);
        }
        let Some(first) = cut.partition(0, rings, MAX_PARTITION_GROWTH * core_triangles) else {
            return Ok(None);
        };
        let merged = Mutex::new(Merged {
            positions: mesh.positions.clone(),
            changed: Vec::new(),
            edits_connectivity: false,
            reports: vec![String::new(); cut.len()],
            stdout: String::new(),
            stderr: String::new(),
            largest: 0,
            guest_peak_bytes: 0,
            error: None,
            audit: Vec::new(),
        });
        let work = Work {
            runtime: self,
            plugin,
            service,
            params,
            mesh,
            cut: &cut,
            rings,
            core_triangles,
            first: Mutex::new(Some(first)),
            // The partitions, then the audit.
            queue: WorkQueue::new(cut.len() + 1),
            ends: started + deadline,
            merged: &merged,
        };
        let workers = self.workers_for(cut.len());
        // The first slot was taken within the queue's bound; helpers wait for one only
        // while work is left (other runs may hold every slot for long).
        self.with_helpers(&slot, workers, &work.queue, |slot, _| work.run(slot));
        // The workers are done: nothing else takes the lock.
        let mut merged = merged.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(error) = merged.error.take() {
            return Err(error);
        }
        let (edited, log, report, region) = if merged.edits_connectivity {
            let changed = merged.all_changed(mesh);
            let region = work.run_region(&slot, changed)?;
            drop(slot);
            merged.add_output(&region.state);
            let (edited, log) = region.edited.finish();
            let note = format!(
                "; its edits made again on one region of {} triangles around the {} vertices \
                 they change",
                region.triangles, region.changed
            );
            (edited, log, region.report, note)
        } else {
            drop(slot);
            let same = |(at, p): &(usize, [f32; 3])| {
                (0..3).all(|k| merged.positions[at + k].to_bits() == p[k].to_bits())
            };
            if !merged.audit.iter().all(same) {
                return Err(RunError::ReachExceeded { service: service.to_owned(), rings });
            }
            let mut store = MeshStore::new(Arc::clone(mesh));
            let moved = Op::SetPositions { xyz: std::mem::take(&mut merged.positions) };
            store.apply(moved).map_err(|e| RunError::Failed {
                service: service.to_owned(),
                message: e.to_string(),
            })?;
            let (edited, log) = store.finish();
            (edited, log, std::mem::take(&mut merged.reports[0]), String::new())
        };
        let partitions =
            Partitions { count: cut.len(), rings, core_triangles, largest: merged.largest };
        let report = format!(
            "{report} (on {} partitions of at most {} core triangles and {} rings of overlap, \
             the largest {} triangles{region})",
            partitions.count, core_triangles, rings, partitions.largest
        );
        Ok(Some(RunOutput {
            mesh: Some(edited),
            log,
            value: None,
            report,
            stdout: std::mem::take(&mut merged.stdout),
            stderr: std::mem::take(&mut merged.stderr),
            duration: started.elapsed(),
            queued,
            guest_peak_bytes: merged.guest_peak_bytes,
            partitions: Some(partitions),
        }))
    }
}

/// What the partitions' runs have produced so far.
struct Merged {
    /// The mesh's positions, each core's overwritten by its partition's result.
    positions: Vec<f32>,
    /// Whether a partition's edits changed connectivity: the step is then made on a region.
    edits_connectivity: bool,
    /// The mesh's vertices such partitions changed (each partition's ascending).
    changed: Vec<u32>,
    reports: Vec<String>,
    stdout: String,
    stderr: String,
    largest: usize,
    guest_peak_bytes: usize,
    /// The first partition's failure: it fails the step.
    error: Option<RunError>,
    /// The audit's patch of partition 0's core as it computed it (one ring more):
    /// (coordinate index, position), to be equal bit for bit to what partition 0 gave.
    audit: Vec<(usize, [f32; 3])>,
}

impl Merged {
    /// Every vertex a partition changed, ascending: those a partition that edited
    /// connectivity changed, and those moved.
    fn all_changed(&mut self, mesh: &MeshData) -> Vec<u32> {
        let mut changed = std::mem::take(&mut self.changed);
        let (now, before) = (self.positions.chunks_exact(3), mesh.positions.chunks_exact(3));
        let moved =
            now.zip(before).map(|(a, b)| a.iter().zip(b).any(|(a, b)| a.to_bits() != b.to_bits()));
        changed.extend((0u32..).zip(moved).filter(|&(_, moved)| moved).map(|(v, _)| v));
        changed.sort_unstable();
        changed.dedup();
        changed
    }

    /// A run's output, up to the capture's bound, and its peak.
    fn add_output(&mut self, state: &RunState) {
        self.guest_peak_bytes = self.guest_peak_bytes.max(state.memory.peak_bytes);
        capture_output(&mut self.stdout, &mut self.stderr, state);
    }
}

/// Appends a run's captured output to a step's, up to the capture's bound.
fn capture_output(stdout: &mut String, stderr: &mut String, state: &RunState) {
    for (into, pipe) in [(stdout, &state.stdout), (stderr, &state.stderr)] {
        let text = captured(pipe);
        if !text.is_empty() && into.len() < super::OUTPUT_CAPTURE_BYTES {
            into.push_str(&text);
        }
    }
}

/// The partitions, handed out one at a time to the workers.
struct Work<'a> {
    runtime: &'a Runtime,
    /// The whole mesh.
    mesh: &'a Arc<MeshData>,
    plugin: &'a Plugin,
    service: &'a str,
    params: &'a [Param],
    cut: &'a Partitioning<'a>,
    rings: u32,
    /// Triangles of a core at most.
    core_triangles: usize,
    /// Partition 0, built already to decide whether to partition at all.
    first: Mutex<Option<Partition>>,
    queue: WorkQueue,
    /// The whole step's deadline: every partition runs within what is left of it.
    ends: Instant,
    merged: &'a Mutex<Merged>,
}

impl Work<'_> {
    /// Runs partitions until none is left or one has failed.
    fn run(&self, slot: &permits::Permit<'_>) {
        // In order: partition 0 was cut already, the audit is last.
        while let Some(index) = self.queue.take(End::Front) {
            if let Err(error) = self.run_one(slot, index) {
                self.queue.stop();
                let mut merged = self.merged.lock().unwrap_or_else(|e| e.into_inner());
                merged.error.get_or_insert(error);
                return;
            }
        }
    }

    /// The most triangles a partition or region may hold. Partition 1 decided that the
    /// reach keeps partitions within MAX_PARTITION_GROWTH times their cores; a denser part
    /// of the mesh may take twice that, no more, so the host's memory stays bounded whatever
    /// a plugin declares.
    fn most_triangles(&self) -> usize {
        2 * MAX_PARTITION_GROWTH * self.core_triangles
    }

    /// Runs partition `index`, or for `index == len()` the audit: a patch of partition 0's
    /// core again with one ring more, which must come out the same.
    fn run_one(&self, slot: &permits::Permit<'_>, index: usize) -> Result<(), RunError> {
        let count = self.cut.len();
        let audit = index == count;
        let label = match audit {
            false => format!("{} (partition {} of {count})", self.service, index + 1),
            true => format!("{} (a patch of partition 1 with one ring more)", self.service),
        };
        let bound = self.most_triangles();
        let part = match index {
            0 => self.first.lock().unwrap_or_else(|e| e.into_inner()).take(),
            _ if audit => Some(self.cut.sample(0, AUDIT_VERTICES, self.rings + 1)),
            _ => self.cut.partition(index, self.rings, bound),
        };
        let Some(part) = part else {
            let message = format!(
                "with {} rings of overlap the partition holds more than {bound} triangles; \
                 the service reaches too far to run on partitions of this mesh",
                self.rings
            );
            return Err(RunError::Failed { service: label, message });
        };
        let Partition { mesh, vertices, triangles, core } = part;
        let triangle_count = mesh.triangle_count();
        let (report, state) = self.run_on(slot, &label, mesh, self.cut.whole(vertices))?;
        // The partition's ids went to its store (the plugin may read them) and are read
        // back there to place its core: not copied.
        let vertices = &state.mesh.whole().expect("its whole was set before the run").ids;
        let edits_connectivity = state.mesh.log().iter().any(|op| !moves_only(op.kind()));
        let changed = match edits_connectivity {
            // The region's run stands in for the audit.
            true if audit => return Ok(()),
            true => Placement::new(vertices, &triangles, self.mesh)
                .changed_vertices(&state.mesh)
                .map_err(|e| RunError::NotLocal { service: label, edit: e.edit })?,
            false => Vec::new(),
        };
        let positions = state.mesh.positions();
        let cores = core.iter().map(|&c| (3 * c as usize, 3 * vertices[c as usize] as usize));
        let mut guard = self.merged.lock().unwrap_or_else(|e| e.into_inner());
        let merged = &mut *guard;
        if audit {
            merged.audit = cores
                .map(|(local, global)| (global, [0, 1, 2].map(|k| positions[local + k])))
                .collect();
            return Ok(());
        }
        for (local, global) in cores {
            merged.positions[global..global + 3].copy_from_slice(&positions[local..local + 3]);
        }
        merged.edits_connectivity |= edits_connectivity;
        merged.changed.extend(changed);
        merged.reports[index] = report;
        merged.largest = merged.largest.max(triangle_count);
        merged.add_output(&state);
        Ok(())
    }

    /// Runs the service on `mesh`, a partition of `whole`, within what is left of the
    /// step's deadline: its report and the run's state (its store holds the edits).
    fn run_on(
        &self,
        slot: &permits::Permit<'_>,
        label: &str,
        mesh: MeshData,
        whole: Whole,
    ) -> Result<(String, RunState), RunError> {
        let left = self.ends.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(RunError::Deadline {
                service: label.to_owned(),
                deadline: self.runtime.limits.deadline,
            });
        }
        let (outcome, state) = self.runtime.call(
            slot,
            &self.plugin.pre,
            label,
            Arc::new(mesh),
            false,
            left,
            |store, p, _, mesh| {
                store.data_mut().mesh.set_whole(whole);
                p.meshflow_geometry_service().call_run(store, self.service, mesh, self.params)
            },
        )?;
        let outcome =
            outcome.map_err(|message| RunError::Failed { service: label.to_owned(), message })?;
        Ok((outcome.report, state))
    }
}

/// The edits a local service may make: moves of vertices.
fn moves_only(kind: OpKind) -> bool {
    matches!(kind, OpKind::MoveVertices | OpKind::SetPositions | OpKind::Transform)
}
