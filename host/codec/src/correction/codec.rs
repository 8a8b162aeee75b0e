//! What encoder and decoder share: the four output sections and every adaptive model, each
//! starting from the same state on both sides.

use super::attributes::AttributeCoder;
use super::coding::corners::CornerCoder;
use super::coding::integer::{BUCKETS, int_model};
use super::coding::model::AdaptiveModel;
use super::coding::residual::{CLASSES, ResidualCoder};
use super::lists::{ElementCoder, IdListCoder};
use super::removals::Removals;
use crate::quantize::Grid;
use meshflow_mesh::store::OpKind;

/// The kind alphabet: every op kind, then "no further op".
pub(super) const END: usize = super::header::KINDS;

/// One coder per section, in `SECTIONS` order.
pub(super) struct Sections<T> {
    /// Op kinds, counts, single-element ids, flags.
    pub(super) ops: T,
    /// Id lists of bulk ops.
    pub(super) ids: T,
    /// Corners of added triangles.
    pub(super) connectivity: T,
    /// Coordinates, transforms.
    pub(super) geometry: T,
}

pub(super) struct Models {
    pub(super) kind: AdaptiveModel,
    pub(super) count: AdaptiveModel,
    pub(super) has_point: AdaptiveModel,
    pub(super) extend_vertex: AdaptiveModel,
    /// A `set-positions` vertex's [`motion`] symbol, in the [`motion`] context of the
    /// previous vertex.
    pub(super) motion: [AdaptiveModel; motion::CONTEXTS],
    pub(super) elements: ElementCoder,
    pub(super) lists: IdListCoder,
    pub(super) removals: Removals,
    pub(super) corners: CornerCoder,
    pub(super) new_points: ResidualCoder,
    pub(super) moves: ResidualCoder,
    pub(super) smoothing: ResidualCoder,
    pub(super) split_points: ResidualCoder,
    pub(super) last_extend_vertex: u32,
    pub(super) attributes: AttributeCoder,
    /// The grid the mesh is on, if coordinates are coded as grid steps.
    pub(super) grid: Option<Grid>,
}

impl Models {
    /// Fresh models; coordinates are coded as grid steps when the mesh is on `grid`.
    pub(super) fn new(grid: Option<Grid>) -> Self {
        Self {
            kind: AdaptiveModel::new(END + 1),
            count: int_model(),
            has_point: AdaptiveModel::new(2),
            extend_vertex: int_model(),
            motion: std::array::from_fn(|_| AdaptiveModel::new(motion::SYMBOLS)),
            elements: ElementCoder::new(),
            lists: IdListCoder::new(),
            removals: Removals::new(),
            corners: CornerCoder::new(),
            new_points: ResidualCoder::new(grid),
            moves: ResidualCoder::new(grid),
            smoothing: ResidualCoder::new(grid),
            split_points: ResidualCoder::new(grid),
            last_extend_vertex: 0,
            attributes: AttributeCoder::new(),
            grid,
        }
    }
}

pub(super) fn kind_symbol(kind: OpKind) -> usize {
    super::header::kind_index(kind)
}

/// How a vertex fared under `set-positions`: one symbol covers the common cases, so an
/// exactly predicted smoothing step costs one cheap symbol per vertex, and a residual's
/// first bucket is that symbol too (three per vertex, not four).
pub(super) mod motion {
    use super::{BUCKETS, CLASSES};

    /// The vertex kept its position.
    pub(crate) const STILL: usize = 0;
    /// The vertex is exactly where the smoothing prediction puts it.
    pub(crate) const PREDICTED: usize = 1;
    /// This and the symbols after it: a residual from the prediction follows, the symbol
    /// less `RESIDUAL` being the bucket of its first axis.
    pub(crate) const RESIDUAL: usize = 2;
    pub(crate) const SYMBOLS: usize = RESIDUAL + BUCKETS;
    /// The previous vertex's symbol, still or predicted, else `RESIDUAL` plus the magnitude
    /// class of its last residual.
    pub(crate) const CONTEXTS: usize = RESIDUAL + CLASSES;
}
