//! The correction vocabulary: every way a mesh can change during a step.
//!
//! An [`Op`] is both what a plugin asks the store to do and what the store records, so
//! replaying a log through another store reproduces the step exactly. Bulk variants carry
//! lists; the store merges consecutive single edits of one kind into one bulk op.

use crate::attributes::{Domain, Values};

/// A row-major 3x4 affine map: `[r00 r01 r02 t0  r10 r11 r12 t1  r20 r21 r22 t2]`.
pub type Affine = [f32; 12];

#[derive(Clone, Debug, PartialEq)]
pub enum Op {
    /// Append `xyz.len() / 3` vertices.
    AddVertices { xyz: Vec<f32> },
    /// Move `ids[i]` to `xyz[3i..3i+3]`.
    MoveVertices { ids: Vec<u32>, xyz: Vec<f32> },
    /// Move every vertex slot (`3 * vertex_slots` values; removed slots ignored).
    SetPositions { xyz: Vec<f32> },
    /// Remove vertices and every triangle using them.
    RemoveVertices { ids: Vec<u32> },
    /// Append `abc.len() / 3` triangles.
    AddTriangles { abc: Vec<u32> },
    /// Remove triangles; their vertices stay.
    RemoveTriangles { ids: Vec<u32> },
    /// Swap corners 1 and 2 of each triangle.
    FlipTriangles { ids: Vec<u32> },
    /// Split a triangle into three around a new vertex (`at`, or the centroid).
    SplitTriangle { triangle: u32, at: Option<[f32; 3]> },
    /// Add the triangle `b a vertex` on the far side of half-edge `a -> b`.
    ExtendEdge { edge: u32, vertex: u32 },
    /// Split an edge and the triangles on it at a new vertex (`at`, or the midpoint).
    SplitEdge { edge: u32, at: Option<[f32; 3]> },
    /// Replace the two triangles on a manifold interior edge by the other diagonal.
    SwapEdge { edge: u32 },
    /// Merge the edge's end vertex into its start vertex.
    CollapseEdge { edge: u32 },
    /// Remove the edge-connected component of a triangle and the vertices it leaves unused.
    RemoveComponent { triangle: u32 },
    /// Apply an affine map to the vertices of a triangle's edge-connected component.
    TransformComponent { triangle: u32, matrix: Affine },
    /// Apply an affine map to every vertex.
    Transform { matrix: Affine },
    /// Remove everything.
    Clear,
    /// Set an attribute at `ids` (at every slot of its domain when `None`: `values` then
    /// cover removed slots too) to `values`, `components` numbers an element; an attribute
    /// the mesh does not have yet is made, every other element at its default.
    SetAttribute {
        domain: Domain,
        name: String,
        components: u8,
        ids: Option<Vec<u32>>,
        values: Values,
    },
    /// Drop an attribute.
    RemoveAttribute { domain: Domain, name: String },
}

impl Op {
    /// The op's name as used in reports and `correction inspect`.
    pub fn kind(&self) -> OpKind {
        match self {
            Op::AddVertices { .. } => OpKind::AddVertices,
            Op::MoveVertices { .. } => OpKind::MoveVertices,
            Op::SetPositions { .. } => OpKind::SetPositions,
            Op::RemoveVertices { .. } => OpKind::RemoveVertices,
            Op::AddTriangles { .. } => OpKind::AddTriangles,
            Op::RemoveTriangles { .. } => OpKind::RemoveTriangles,
            Op::FlipTriangles { .. } => OpKind::FlipTriangles,
            Op::SplitTriangle { .. } => OpKind::SplitTriangle,
            Op::ExtendEdge { .. } => OpKind::ExtendEdge,
            Op::SplitEdge { .. } => OpKind::SplitEdge,
            Op::SwapEdge { .. } => OpKind::SwapEdge,
            Op::CollapseEdge { .. } => OpKind::CollapseEdge,
            Op::RemoveComponent { .. } => OpKind::RemoveComponent,
            Op::TransformComponent { .. } => OpKind::TransformComponent,
            Op::Transform { .. } => OpKind::Transform,
            Op::Clear => OpKind::Clear,
            Op::SetAttribute { .. } => OpKind::SetAttribute,
            Op::RemoveAttribute { .. } => OpKind::RemoveAttribute,
        }
    }

    /// How many elementary edits the op stands for (a bulk op of n ids counts n).
    pub fn edit_count(&self) -> usize {
        match self {
            Op::AddVertices { xyz } | Op::SetPositions { xyz } => xyz.len() / 3,
            Op::MoveVertices { ids, .. }
            | Op::RemoveVertices { ids }
            | Op::RemoveTriangles { ids }
            | Op::FlipTriangles { ids } => ids.len(),
            Op::AddTriangles { abc } => abc.len() / 3,
            Op::SetAttribute { ids: Some(ids), .. } => ids.len(),
            Op::SetAttribute { ids: None, components, values, .. } => {
                values.len() / usize::from((*components).max(1))
            }
            _ => 1,
        }
    }

    /// Appends `next` to `self` when both are bulk ops of one kind, so a plugin that edits
    /// one element at a time still produces a compact log. Returns `next` back otherwise.
    pub(crate) fn absorb(&mut self, next: Op) -> Option<Op> {
        match (self, next) {
            (Op::AddVertices { xyz }, Op::AddVertices { xyz: more }) => xyz.extend(more),
            (Op::AddTriangles { abc }, Op::AddTriangles { abc: more }) => abc.extend(more),
            (Op::MoveVertices { ids, xyz }, Op::MoveVertices { ids: i, xyz: p }) => {
                ids.extend(i);
                xyz.extend(p);
            }
            (Op::RemoveVertices { ids }, Op::RemoveVertices { ids: more })
            | (Op::RemoveTriangles { ids }, Op::RemoveTriangles { ids: more })
            | (Op::FlipTriangles { ids }, Op::FlipTriangles { ids: more }) => ids.extend(more),
            // Each set-positions replaces every live position, so only the last one counts.
            (Op::SetPositions { xyz }, Op::SetPositions { xyz: later }) => *xyz = later,
            (
                Op::SetAttribute { domain, name, components, ids: Some(ids), values },
                Op::SetAttribute { domain: d, name: n, components: c, ids: Some(more), values: v },
            ) if (*domain, &*name, *components, values.number_type())
                == (d, &n, c, v.number_type()) =>
            {
                ids.extend(more);
                values.extend(&v);
            }
            (_, next) => return Some(next),
        }
        None
    }
}

/// The kinds of [`Op`], for counting and reporting.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum OpKind {
    AddVertices,
    MoveVertices,
    SetPositions,
    RemoveVertices,
    AddTriangles,
    RemoveTriangles,
    FlipTriangles,
    SplitTriangle,
    ExtendEdge,
    SplitEdge,
    SwapEdge,
    CollapseEdge,
    RemoveComponent,
    TransformComponent,
    Transform,
    Clear,
    SetAttribute,
    RemoveAttribute,
}

impl OpKind {
    pub const ALL: [OpKind; 18] = [
        OpKind::AddVertices,
        OpKind::MoveVertices,
        OpKind::SetPositions,
        OpKind::RemoveVertices,
        OpKind::AddTriangles,
        OpKind::RemoveTriangles,
        OpKind::FlipTriangles,
        OpKind::SplitTriangle,
        OpKind::ExtendEdge,
        OpKind::SplitEdge,
        OpKind::SwapEdge,
        OpKind::CollapseEdge,
        OpKind::RemoveComponent,
        OpKind::TransformComponent,
        OpKind::Transform,
        OpKind::Clear,
        OpKind::SetAttribute,
        OpKind::RemoveAttribute,
    ];

    pub fn name(self) -> &'static str {
        match self {
            OpKind::AddVertices => "add-vertices",
            OpKind::MoveVertices => "move-vertices",
            OpKind::SetPositions => "set-positions",
            OpKind::RemoveVertices => "remove-vertices",
            OpKind::AddTriangles => "add-triangles",
            OpKind::RemoveTriangles => "remove-triangles",
            OpKind::FlipTriangles => "flip-triangles",
            OpKind::SplitTriangle => "split-triangle",
            OpKind::ExtendEdge => "extend-edge",
            OpKind::SplitEdge => "split-edge",
            OpKind::SwapEdge => "swap-edge",
            OpKind::CollapseEdge => "collapse-edge",
            OpKind::RemoveComponent => "remove-component",
            OpKind::TransformComponent => "transform-component",
            OpKind::Transform => "transform",
            OpKind::Clear => "clear",
            OpKind::SetAttribute => "set-attribute",
            OpKind::RemoveAttribute => "remove-attribute",
        }
    }
}
