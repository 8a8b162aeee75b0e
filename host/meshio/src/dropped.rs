//! What a file held beyond positions and triangles. The mesh keeps only those two, so a
//! load says what it left behind (colours, normals, quality, texture coordinates, other
//! properties and elements, the precision of double coordinates) instead of dropping it
//! without a word.

use meshflow_mesh::MeshData;

/// A mesh as loaded, with what the file held that the mesh does not keep.
#[derive(Clone, Debug)]
pub struct Loaded {
    pub mesh: MeshData,
    pub dropped: Dropped,
}

/// PLY property names that together are one attribute, as writers name them.
const PLY_GROUPS: [(&str, &[&str]); 3] = [
    ("colour", &["red", "green", "blue", "alpha", "diffuse_red", "diffuse_green", "diffuse_blue"]),
    ("normal", &["nx", "ny", "nz", "normal_x", "normal_y", "normal_z"]),
    (
        "texture coordinate",
        &["u", "v", "s", "t", "texture_u", "texture_v", "texture_s", "texture_t"],
    ),
];

/// What a load left behind.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Dropped {
    /// What each left-behind attribute or element is, in file order:
    /// `vertex colour (red, green, blue, alpha)`, `vertex property 'flags'`.
    pub attributes: Vec<String>,
    /// Coordinates stored as doubles were rounded to f32: the largest absolute change.
    pub rounding: Option<f64>,
}

impl Dropped {
    pub fn is_empty(&self) -> bool {
        self.attributes.is_empty() && self.rounding.is_none()
    }

    /// One line per thing left behind, for a warning or `meshflow info`.
    pub fn lines(&self) -> Vec<String> {
        let mut lines = self.attributes.clone();
        if let Some(error) = self.rounding {
            lines
                .push(format!("double coordinates, rounded to float (largest change {error:.3e})"));
        }
        lines
    }

    pub(crate) fn add(&mut self, what: String) {
        if !self.attributes.contains(&what) {
            self.attributes.push(what);
        }
    }

    /// Records that a double `exact` became `rounded`.
    pub(crate) fn rounded(&mut self, exact: f64, rounded: f32) {
        let change = (exact - f64::from(rounded)).abs();
        let largest = self.rounding.get_or_insert(0.0);
        *largest = largest.max(change);
    }

    /// Names the properties of PLY element `element` other than those the mesh takes,
    /// grouped into what they are: colours, normals, texture coordinates; others by name.
    pub(crate) fn ply_properties<'a>(
        &mut self,
        element: &str,
        names: impl IntoIterator<Item = &'a str>,
    ) {
        let names: Vec<&str> = names.into_iter().collect();
        let owner = if element == "face" { "face" } else { "vertex" };
        for (group, members) in PLY_GROUPS {
            let found: Vec<&str> = names.iter().copied().filter(|n| members.contains(n)).collect();
            if !found.is_empty() {
                self.add(format!("{owner} {group} ({})", found.join(", ")));
            }
        }
        let grouped = |n: &&str| PLY_GROUPS.iter().any(|(_, members)| members.contains(n));
        for name in names.iter().filter(|n| !grouped(n)) {
            match *name {
                "texcoord" | "texcoords" => {
                    self.add(format!("corner texture coordinates ('{name}')"))
                }
                _ => self.add(format!("{element} property '{name}'")),
            }
        }
    }
}
