//! What the readers share to keep a file's attributes: adding an attribute the model's
//! checks accept or naming it in the [`Dropped`] report instead, checking material and
//! texture names, and the conversions formats need (colours, floats, faces of polygons).

use meshflow_mesh::attributes::{
    Attribute, AttributeError, Attributes, MAX_ATTRIBUTES, MAX_MATERIALS, Materials, Values,
    check_name,
};

use crate::dropped::Dropped;

/// The attributes a reader has kept so far, for a mesh of known size.
pub(crate) struct Kept {
    pub attributes: Attributes,
    vertices: usize,
    triangles: usize,
}

impl Kept {
    pub fn new(vertices: usize, triangles: usize) -> Self {
        Self { attributes: Attributes::default(), vertices, triangles }
    }

    /// Keeps `attribute`, or names it (`what`, as the file called it) in `dropped` with the
    /// reason the model refused it: a name it cannot hold, too many attributes, a value that
    /// is not finite.
    pub fn keep(&mut self, attribute: Attribute, what: &str, dropped: &mut Dropped) {
        if let Err(error) = self.attributes.insert(attribute, self.vertices, self.triangles) {
            dropped.add(format!("{what} ({})", refusal(&error)));
        }
    }
}

/// Why the model refused an attribute, for a [`Dropped`] line.
pub(crate) fn refusal(error: &AttributeError) -> String {
    match error {
        AttributeError::Name(_) => {
            "its name is not one meshflow keeps: 1 to 64 letters, digits, '_', '-' or '.'".into()
        }
        AttributeError::TooMany => format!("a mesh holds at most {MAX_ATTRIBUTES} attributes"),
        AttributeError::NotFinite { element, .. } => format!("element {element} is not finite"),
        other => other.to_string(),
    }
}

/// Whether an attribute of this name can be kept at all (see [`check_name`]); if not,
/// names it in `dropped`.
pub(crate) fn usable_name(name: &str, what: &str, dropped: &mut Dropped) -> bool {
    match check_name(name) {
        Ok(()) => true,
        Err(error) => {
            dropped.add(format!("{what} ({})", refusal(&error)));
            false
        }
    }
}

/// The lists of [`Materials`], checked name by name as they are read.
#[derive(Default)]
pub(crate) struct MaterialNames {
    pub materials: Materials,
}

/// Which list of [`Materials`] a name goes to.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum MaterialList {
    Names,
    Libraries,
    Textures,
}

impl MaterialList {
    fn what(self) -> &'static str {
        match self {
            MaterialList::Names => "material",
            MaterialList::Libraries => "material library",
            MaterialList::Textures => "texture",
        }
    }
}

impl MaterialNames {
    /// Adds `name` to `list` (once) and returns its index, or names it in `dropped` and
    /// returns `None` when [`Materials::check`] would refuse it: a file name that leaves the
    /// mesh's folder (`../../etc/passwd`, `textures/a.png`), control characters, too long,
    /// or one name too many.
    pub fn add(&mut self, list: MaterialList, name: &str, dropped: &mut Dropped) -> Option<usize> {
        let what = list.what();
        let shown: String = name.chars().take(80).collect();
        let target = match list {
            MaterialList::Names => &mut self.materials.names,
            MaterialList::Libraries => &mut self.materials.libraries,
            MaterialList::Textures => &mut self.materials.textures,
        };
        if let Some(i) = target.iter().position(|n| n == name) {
            return Some(i);
        }
        if !acceptable(list, name) {
            let reason = match list {
                MaterialList::Names => "empty, too long or with control characters",
                _ => "a name that leaves the mesh's folder; it is never followed",
            };
            dropped.add(format!("{what} {shown:?} ({reason})"));
            return None;
        }
        if target.len() >= MAX_MATERIALS {
            dropped.add(format!("{what} {shown:?} (a mesh names at most {MAX_MATERIALS})"));
            return None;
        }
        target.push(name.to_owned());
        Some(target.len() - 1)
    }
}

/// Whether [`Materials::check`] accepts `name` in `list`.
pub(crate) fn acceptable(list: MaterialList, name: &str) -> bool {
    let mut one = Materials::default();
    match list {
        MaterialList::Names => one.names.push(name.to_owned()),
        MaterialList::Libraries => one.libraries.push(name.to_owned()),
        MaterialList::Textures => one.textures.push(name.to_owned()),
    }
    one.check().is_ok()
}

/// A colour channel given as a float from 0 to 1, as 0 to 255 (nearest, clamped).
#[inline]
pub(crate) fn unit_to_u8(x: f64) -> u8 {
    if x.is_nan() { 0 } else { (x * 255.0).round().clamp(0.0, 255.0) as u8 }
}

/// A colour channel given as an integer (0 to 255, clamped).
#[inline]
pub(crate) fn int_to_u8(x: f64) -> u8 {
    if x.is_nan() { 0 } else { x.round().clamp(0.0, 255.0) as u8 }
}

/// The values as `f32`, and whether any changed on the way (doubles beyond f32's
/// precision, integers beyond 2^24).
pub(crate) fn to_f32(values: &Values) -> (Vec<f32>, bool) {
    match values {
        Values::F32(v) => (v.clone(), false),
        other => {
            let mut changed = false;
            let out = (0..other.len())
                .map(|i| {
                    let x = other.get(i);
                    let y = x as f32;
                    changed |= f64::from(y) != x && !x.is_nan();
                    y
                })
                .collect();
            (out, changed)
        }
    }
}

/// Interleaves equally long columns: `[a0 b0 c0 a1 b1 c1 …]`.
pub(crate) fn interleave<T: Copy>(columns: &[&[T]]) -> Vec<T> {
    let n = columns.first().map_or(0, |c| c.len());
    let mut out = Vec::with_capacity(n * columns.len());
    for i in 0..n {
        out.extend(columns.iter().map(|c| c[i]));
    }
    out
}

/// Per-face values (`components` numbers a face) given once per polygon, repeated for each
/// triangle of the polygon's fan (`fans[f]` triangles). `None` for all-triangle files.
pub(crate) fn expand_polygons(values: Values, components: usize, fans: Option<&[u32]>) -> Values {
    let Some(fans) = fans else { return values };
    let mut out = Values::empty(values.number_type());
    out.reserve(fans.iter().map(|&n| n as usize).sum::<usize>() * components);
    for (face, &n) in fans.iter().enumerate() {
        for _ in 0..n {
            for k in 0..components {
                out.push(values.get(face * components + k));
            }
        }
    }
    out
}

/// Per-corner values of polygons (`components` numbers a corner, `corners[f]` corners a
/// polygon, in order), as the corners of their fans `(c0, ci, ci+1)`.
pub(crate) fn fan_corners(values: &[f32], components: usize, corners: &[u32]) -> Vec<f32> {
    let mut out = Vec::new();
    let mut start = 0;
    for &n in corners {
        let n = n as usize;
        let corner = |k: usize| &values[(start + k) * components..(start + k + 1) * components];
        for i in 1..n.saturating_sub(1) {
            for k in [0, i, i + 1] {
                out.extend_from_slice(corner(k));
            }
        }
        start += n;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hostile_file_names_are_refused_and_named() {
        let mut names = MaterialNames::default();
        let mut dropped = Dropped::default();
        assert_eq!(names.add(MaterialList::Textures, "skin.png", &mut dropped), Some(0));
        assert_eq!(names.add(MaterialList::Textures, "skin.png", &mut dropped), Some(0));
        for bad in [
            "../../etc/passwd",
            "a/../../b.png",
            "/etc/passwd",
            "a//b",
            "..",
            "c:\\x.png",
            "a\u{7}",
        ] {
            assert_eq!(names.add(MaterialList::Textures, bad, &mut dropped), None, "{bad}");
        }
        // Below the mesh's folder is fine: textures often sit in a folder of their own.
        assert_eq!(names.add(MaterialList::Textures, "textures/b.png", &mut dropped), Some(1));
        assert_eq!(names.materials.textures, ["skin.png", "textures/b.png"]);
        assert!(
            dropped.attributes[0].starts_with("texture \"../../etc/passwd\" (a name that leaves")
        );
        // Material names may hold spaces, but no control characters.
        assert_eq!(names.add(MaterialList::Names, "my skin", &mut dropped), Some(0));
    }

    #[test]
    fn polygons_spread_their_values_over_their_fans() {
        let v = expand_polygons(Values::U8(vec![1, 2, 3]), 1, Some(&[1, 2, 0]));
        assert_eq!(v, Values::U8(vec![1, 2, 2]));
        // A quad's corners 0..4 with u = corner: fans (0,1,2), (0,2,3).
        let uv: Vec<f32> = (0..4).flat_map(|c| [c as f32, 0.0]).collect();
        let fan = fan_corners(&uv, 2, &[4]);
        assert_eq!(fan.iter().step_by(2).copied().collect::<Vec<_>>(), [0., 1., 2., 0., 2., 3.]);
    }

    #[test]
    fn colours_convert_by_rounding_and_clamping() {
        assert_eq!(unit_to_u8(1.0), 255);
        assert_eq!(unit_to_u8(0.5), 128);
        assert_eq!(unit_to_u8(-2.0), 0);
        assert_eq!(int_to_u8(300.0), 255);
        for c in 0..=255u8 {
            assert_eq!(unit_to_u8(f64::from(f32::from(c) / 255.0)), c);
        }
    }
}
