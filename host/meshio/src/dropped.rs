//! What a file held that the mesh does not keep. The mesh keeps positions, triangles and
//! the attributes of `meshflow_mesh::attributes` (colours, normals, quality, texture
//! coordinates, materials, other numbers by name); a load says what else it left behind
//! (other elements, list properties it cannot hold, names the model refuses, the precision
//! of double coordinates) instead of dropping it without a word.

use meshflow_mesh::MeshData;

/// A mesh as loaded, with what the file held that the mesh does not keep.
#[derive(Clone, Debug)]
pub struct Loaded {
    pub mesh: MeshData,
    pub dropped: Dropped,
}

/// At most this many lines name what a load left behind; the rest are counted.
const MAX_LINES: usize = 64;

/// What a load left behind.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Dropped {
    /// What each left-behind attribute or element is, in file order:
    /// `vertex property 'flags' (…)`, `element 'edge' (2 records)`; also what a load had
    /// to change to keep an attribute (`normals … averaged per vertex`).
    pub attributes: Vec<String>,
    /// Coordinates stored as doubles were rounded to f32: the largest absolute change.
    pub rounding: Option<f64>,
    /// Lines beyond [`MAX_LINES`], counted only (a hostile header may name millions).
    more: usize,
}

impl Dropped {
    pub fn is_empty(&self) -> bool {
        self.attributes.is_empty() && self.rounding.is_none()
    }

    /// One line per thing left behind, for a warning or `meshflow info`.
    pub fn lines(&self) -> Vec<String> {
        let mut lines = self.attributes.clone();
        if self.more > 0 {
            lines.push(format!("and {} more", self.more));
        }
        if let Some(error) = self.rounding {
            lines
                .push(format!("double coordinates, rounded to float (largest change {error:.3e})"));
        }
        lines
    }

    pub(crate) fn add(&mut self, what: String) {
        if self.attributes.contains(&what) {
            return;
        }
        if self.attributes.len() < MAX_LINES {
            self.attributes.push(what);
        } else {
            self.more += 1;
        }
    }

    /// Records that a double `exact` became `rounded`.
    pub(crate) fn rounded(&mut self, exact: f64, rounded: f32) {
        let change = (exact - f64::from(rounded)).abs();
        let largest = self.rounding.get_or_insert(0.0);
        *largest = largest.max(change);
    }
}
