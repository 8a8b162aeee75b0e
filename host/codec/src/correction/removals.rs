//! Id lists of removals and flips, coded by what they remove rather than id by id.
//!
//! A filter that deletes small pieces of a raw scan removes whole edge-connected components,
//! whose ids are scattered over the id space when the scanner interleaved them: listing them
//! costs bytes per id. Such a list is coded as one seed triangle per component (its smallest
//! id), whichever plugin made it and in whatever order the ids lie. And the vertices a
//! triangle removal left without triangles, removed right after it (what every cleaning
//! filter does), are coded as just that: one symbol. Anything else is an explicit list.
//!
//! Encoder and decoder keep the same [`Removals`] state, updated around every applied op.

use std::collections::HashSet;

use meshflow_mesh::store::{MeshStore, Op, OpKind};

use super::coding::model::AdaptiveModel;
use super::coding::stream::{CorruptStream, SymbolReader, SymbolWriter};
use super::lists::IdListCoder;

/// The list as it is (ascending or not).
const LIST: usize = 0;
/// The union of the components of these seed triangles: their triangles for a triangle
/// list, their corners for a vertex list.
const COMPONENTS: usize = 1;
/// The vertices the previous op, a triangle removal, left without triangles.
const ORPHANS: usize = 2;
const FORMS: usize = 3;

pub(super) struct Removals {
    form: AdaptiveModel,
    /// What [`ORPHANS`] stands for at the current op.
    orphans: Vec<u32>,
}

impl Removals {
    pub(super) fn new() -> Self {
        Self { form: AdaptiveModel::new(FORMS), orphans: Vec::new() }
    }

    /// Codes the ids of a `remove-vertices`, `remove-triangles` or `flip-triangles` op
    /// about to be applied to `store`.
    pub(super) fn write(
        &mut self,
        store: &mut MeshStore,
        lists: &mut IdListCoder,
        w: &mut SymbolWriter,
        kind: OpKind,
        ids: &[u32],
    ) {
        let ascending = ids.windows(2).all(|p| p[0] < p[1]);
        if ascending && kind == OpKind::RemoveVertices && !ids.is_empty() && ids == self.orphans {
            w.symbol(&mut self.form, ORPHANS);
            return;
        }
        let seeds = match kind {
            _ if !ascending || ids.is_empty() => None,
            OpKind::RemoveVertices => vertex_seeds(store, ids),
            _ => triangle_seeds(store, ids),
        };
        match seeds {
            Some(seeds) => {
                w.symbol(&mut self.form, COMPONENTS);
                lists.write(w, &seeds);
            }
            None => {
                w.symbol(&mut self.form, LIST);
                lists.write(w, ids);
            }
        }
    }

    /// Reads what [`write`](Self::write) wrote: at most `limit` ids.
    pub(super) fn read(
        &mut self,
        store: &mut MeshStore,
        lists: &mut IdListCoder,
        r: &mut SymbolReader,
        kind: OpKind,
        limit: u64,
    ) -> Result<Vec<u32>, CorruptStream> {
        match r.symbol(&mut self.form)? {
            LIST => lists.read(r, limit),
            ORPHANS if kind == OpKind::RemoveVertices && !self.orphans.is_empty() => {
                Ok(self.orphans.clone())
            }
            COMPONENTS => {
                let seeds = lists.read(r, limit)?;
                if kind != OpKind::RemoveVertices {
                    return component_triangles(store, &seeds, limit);
                }
                // A vertex list's components may have more triangles than it has vertices.
                let all = u64::from(store.triangle_slots());
                let triangles = component_triangles(store, &seeds, all)?;
                let vertices = corners_of(store, &triangles);
                if vertices.len() as u64 > limit {
                    return Err(CorruptStream);
                }
                Ok(vertices)
            }
            _ => Err(CorruptStream),
        }
    }

    /// Called with each op before it is applied; returns what [`applied`](Self::applied)
    /// needs afterwards: the corners of the triangles a triangle removal takes.
    pub(super) fn before(store: &MeshStore, op: &Op) -> Vec<u32> {
        match op {
            Op::RemoveTriangles { ids } => corners_of(store, ids),
            _ => Vec::new(),
        }
    }

    /// Called after each op was applied, with what [`before`](Self::before) returned.
    pub(super) fn applied(&mut self, store: &mut MeshStore, corners: Vec<u32>) {
        let mut orphans = corners;
        orphans.retain(|&v| store.is_vertex_live(v) && store.triangles_around(v).is_empty());
        self.orphans = orphans;
    }
}

/// Distinct corners of live triangles, ascending (dead or unknown ids are skipped: the store
/// refuses the op that names them).
fn corners_of(store: &MeshStore, triangles: &[u32]) -> Vec<u32> {
    let mut corners: Vec<u32> =
        triangles.iter().filter_map(|&t| store.triangle(t).ok()).flatten().collect();
    corners.sort_unstable();
    corners.dedup();
    corners
}

/// The seeds of the components whose union is exactly `ids` (ascending live triangles), or
/// `None`. A walk stops at the first triangle outside `ids`, so a list that is not such a
/// union costs at most a walk over its own triangles.
fn triangle_seeds(store: &mut MeshStore, ids: &[u32]) -> Option<Vec<u32>> {
    let listed: HashSet<u32> = ids.iter().copied().collect();
    let mut reached = HashSet::with_capacity(ids.len());
    let mut seeds = Vec::new();
    for &t in ids {
        if reached.contains(&t) {
            continue;
        }
        // `ids` ascend, so `t` is the smallest triangle of its component that is listed.
        seeds.push(t);
        if !walk(store, t, &mut reached, |t, _| listed.contains(&t))? {
            return None;
        }
    }
    Some(seeds)
}

/// The seeds of the components whose corners are exactly `ids` (ascending live vertices),
/// or `None`: every listed vertex must lie on a triangle, and every component touching one
/// must have all its corners listed.
fn vertex_seeds(store: &mut MeshStore, ids: &[u32]) -> Option<Vec<u32>> {
    let listed: HashSet<u32> = ids.iter().copied().collect();
    let mut reached = HashSet::new();
    let mut seeds = Vec::new();
    for &v in ids {
        if !store.is_vertex_live(v) {
            return None;
        }
        let around = store.triangles_around(v);
        if around.is_empty() {
            return None;
        }
        for t in around {
            if reached.contains(&t) {
                continue;
            }
            let start = reached.len();
            let mut smallest = t;
            let inside = |t: u32, corners: [u32; 3]| {
                smallest = smallest.min(t);
                corners.iter().all(|c| listed.contains(c))
            };
            if !walk(store, t, &mut reached, inside)? {
                return None;
            }
            debug_assert!(reached.len() > start);
            seeds.push(smallest);
        }
    }
    seeds.sort_unstable();
    Some(seeds)
}

/// The ascending triangles of the components of `seeds`, each seed in its own component,
/// at most `limit` of them (checked after the walks, which a forged seed list cannot make
/// reach more than the mesh).
fn component_triangles(
    store: &mut MeshStore,
    seeds: &[u32],
    limit: u64,
) -> Result<Vec<u32>, CorruptStream> {
    let mut reached = HashSet::new();
    for &seed in seeds {
        if reached.contains(&seed) || !store.is_triangle_live(seed) {
            return Err(CorruptStream);
        }
        walk(store, seed, &mut reached, |_, _| true).ok_or(CorruptStream)?;
    }
    if reached.len() as u64 > limit {
        return Err(CorruptStream);
    }
    let mut triangles: Vec<u32> = reached.into_iter().collect();
    triangles.sort_unstable();
    Ok(triangles)
}

/// Walks the edge-connected component of the live triangle `seed` (triangles sharing two
/// distinct corners, as `remove-component` defines it), adding each triangle to `reached`
/// and asking `admit(triangle, corners)` of it. `Some(false)` as soon as one is not
/// admitted, `None` if `seed` is not a live triangle.
fn walk(
    store: &mut MeshStore,
    seed: u32,
    reached: &mut HashSet<u32>,
    mut admit: impl FnMut(u32, [u32; 3]) -> bool,
) -> Option<bool> {
    let corners = store.triangle(seed).ok()?;
    reached.insert(seed);
    if !admit(seed, corners) {
        return Some(false);
    }
    let mut stack = vec![(seed, corners)];
    while let Some((_, c)) = stack.pop() {
        for k in 0..3 {
            let (a, b) = (c[k], c[(k + 1) % 3]);
            if a == b {
                continue;
            }
            for t in store.triangles_around(a) {
                let Ok(other) = store.triangle(t) else { continue };
                if reached.contains(&t) || !other.contains(&b) {
                    continue;
                }
                reached.insert(t);
                if !admit(t, other) {
                    return Some(false);
                }
                stack.push((t, other));
            }
        }
    }
    Some(true)
}
