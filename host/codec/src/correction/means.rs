//! The neighbour means the `set-positions` prediction is made from: most of the work of
//! encoding or applying a move of every vertex (a smoothing step), and a function of the
//! mesh alone. So a host can gather them before the edit log exists: the producer while
//! the plugin runs, a receiver while the log downloads ([`NeighbourMeans`]).

use meshflow_mesh::{ContentHash, MeshData};

use super::predict::Neighbours;

/// Per vertex slot, [`Neighbours::mean`]: 25 bytes a vertex where `Option<[f64; 3]>` took
/// 32 (the encoder's largest array while it codes a move of every vertex).
pub(crate) struct Means {
    means: Vec<[f64; 3]>,
    has: Vec<bool>,
}

impl Means {
    /// The means of `vertex_slots` vertices at `positions` over triangle slots `triangles`.
    /// Each depends on nothing but the mesh: the second half of the slots is gathered on a
    /// thread of its own (as the decoder predicts on two), the same values.
    pub(crate) fn of(positions: &[f32], triangles: &[u32], vertex_slots: u32) -> Self {
        Self::gather(positions, triangles, vertex_slots, 2)
    }

    /// [`Means::of`] on `threads` threads (1 or 2).
    fn gather(positions: &[f32], triangles: &[u32], vertex_slots: u32, threads: u32) -> Self {
        let neighbours = Neighbours::new(vertex_slots, triangles);
        let mut means = vec![[0.0; 3]; vertex_slots as usize];
        let mut has = vec![false; vertex_slots as usize];
        let half = if threads > 1 { vertex_slots / 2 } else { vertex_slots };
        let gather = |first: u32, means: &mut [[f64; 3]], has: &mut [bool]| {
            let mut around = Vec::new();
            for ((v, mean), has) in (first..).zip(means.iter_mut()).zip(has.iter_mut()) {
                let found = neighbours.mean(positions, v, &mut around);
                (*mean, *has) = (found.unwrap_or_default(), found.is_some());
            }
        };
        let (first_means, second_means) = means.split_at_mut(half as usize);
        let (first_has, second_has) = has.split_at_mut(half as usize);
        std::thread::scope(|s| {
            if !second_has.is_empty() {
                s.spawn(|| gather(half, second_means, second_has));
            }
            gather(0, first_means, first_has);
        });
        Self { means, has }
    }

    pub(crate) fn get(&self, v: u32) -> Option<[f64; 3]> {
        self.has[v as usize].then(|| self.means[v as usize])
    }

    fn vertex_slots(&self) -> usize {
        self.has.len()
    }
}

/// Where a vertex's mean comes from while a `set-positions` is decoded: the means gathered
/// before, or its neighbours, gathered as it is reached.
pub(crate) enum MeanSource<'a> {
    Prepared(&'a Means),
    Gathered(Neighbours<'a>),
}

impl MeanSource<'_> {
    /// `v`'s neighbour mean in `positions` (which the prepared means were gathered from).
    pub(crate) fn mean(
        &self,
        positions: &[f32],
        v: u32,
        around: &mut Vec<u32>,
    ) -> Option<[f64; 3]> {
        match self {
            Self::Prepared(means) => means.get(v),
            Self::Gathered(neighbours) => neighbours.mean(positions, v, around),
        }
    }
}

/// A mesh's neighbour means, gathered ahead of the edit log that needs them and named by
/// the mesh's hash. [`encode_known`](super::encode_known) and
/// [`apply_known`](super::apply_known) take them for a log whose first op sets every
/// position on that mesh; any other log (or mesh) ignores them, with the same bytes or
/// result as without.
///
/// ```
/// use meshflow_codec::correction::{self, NeighbourMeans};
/// use meshflow_mesh::{MeshData, store::{MeshStore, Op}};
/// let base = MeshData::new(
///     vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.5],
///     vec![0, 1, 2, 1, 3, 2],
/// );
/// let hash = base.content_hash();
/// let means = NeighbourMeans::of(&base, hash);
/// let mut store = MeshStore::new(base.clone());
/// let xyz = base.positions.iter().map(|x| x * 0.5).collect();
/// store.apply(Op::SetPositions { xyz }).unwrap();
/// let (result, log) = store.finish();
/// let result_hash = result.content_hash();
/// let bytes =
///     correction::encode_known(base.clone().into(), hash, &log, &result, result_hash, Some(&means))
///         .unwrap();
/// assert_eq!(bytes, correction::encode(&base, &log, &result).unwrap());
/// let applied = correction::apply_known(base, hash, &bytes, result_hash, Some(&means)).unwrap();
/// assert_eq!(applied, result);
/// ```
pub struct NeighbourMeans {
    mesh: ContentHash,
    means: Means,
}

impl NeighbourMeans {
    /// The means of `mesh`, whose content hash is `hash` (the caller's to get right: means
    /// of another mesh would decode a log into another result, which its hash check then
    /// refuses), on two threads: for a caller with nothing else to do meanwhile.
    pub fn of(mesh: &MeshData, hash: ContentHash) -> Self {
        Self::gathered(mesh, hash, 2)
    }

    /// [`NeighbourMeans::of`] on the calling thread alone: for gathering beside other work
    /// (a plugin's run), which a second thread would slow.
    pub fn beside(mesh: &MeshData, hash: ContentHash) -> Self {
        Self::gathered(mesh, hash, 1)
    }

    fn gathered(mesh: &MeshData, hash: ContentHash, threads: u32) -> Self {
        let slots = mesh.vertex_count() as u32;
        Self { mesh: hash, means: Means::gather(&mesh.positions, &mesh.triangles, slots, threads) }
    }

    /// The means, if they are those of the mesh `hash` with `vertex_slots` vertices.
    pub(crate) fn of_mesh(&self, hash: ContentHash, vertex_slots: u32) -> Option<&Means> {
        (self.mesh == hash && self.means.vertex_slots() == vertex_slots as usize)
            .then_some(&self.means)
    }
}
