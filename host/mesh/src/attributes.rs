//! What a mesh carries beyond positions and triangles: per-vertex colours, normals, quality
//! and texture coordinates, per-corner texture coordinates with their materials, and any
//! other per-vertex or per-face number a file held, kept by name.
//!
//! An [`Attribute`] is one named array of `components` numbers per element of its
//! [`Domain`]. Values keep the number type they came in ([`Values`]); the store moves, copies
//! and blends them through `f64`, which holds every one of those types exactly, so a copied
//! value is the same bits and a blended one is rounded once, the same way on every host.
//!
//! ```
//! use meshflow_mesh::{MeshData, attributes::{Attribute, Domain, Values}};
//! let mut mesh = MeshData::new(vec![0.0; 9], vec![0, 1, 2]);
//! mesh.attributes
//!     .insert(Attribute::quality(vec![0.5, 1.0, 0.25]), mesh.positions.len() / 3, 1)
//!     .unwrap();
//! assert_eq!(mesh.attributes.get(Domain::Vertex, "quality").unwrap().values,
//!            Values::F32(vec![0.5, 1.0, 0.25]));
//! ```

use thiserror::Error;

/// Per-vertex colour: RGBA, one byte each.
pub const COLOR: &str = "color";
/// Per-vertex normal: `x y z` as f32. Recomputed by the store where a step changed the
/// geometry around a vertex, unless the step set it.
pub const NORMAL: &str = "normal";
/// Per-vertex quality (a scanner's confidence, a curvature): one f32.
pub const QUALITY: &str = "quality";
/// Per-vertex or per-corner texture coordinate: `u v` as f32.
pub const TEXCOORD: &str = "texcoord";
/// Per-face material: an index into [`Materials::names`], as u32.
pub const MATERIAL: &str = "material";

/// At most this many attributes on one mesh: a hostile file or plugin cannot make every
/// edit pay for thousands of arrays.
pub const MAX_ATTRIBUTES: usize = 32;
/// At most this many bytes in an attribute's, material's or texture's name.
pub const MAX_NAME_BYTES: usize = 64;
/// At most this many material names, libraries and textures, each.
pub const MAX_MATERIALS: usize = 1024;

/// The elements an attribute has a value for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Domain {
    /// One value per vertex.
    Vertex,
    /// One value per triangle.
    Face,
    /// One value per triangle corner (`3 * t + k`), as textured meshes need where a vertex
    /// lies on a seam between two charts.
    Corner,
}

impl Domain {
    pub fn name(self) -> &'static str {
        match self {
            Domain::Vertex => "vertex",
            Domain::Face => "face",
            Domain::Corner => "corner",
        }
    }

    /// How many values of this domain a mesh of `vertices` and `triangles` has.
    pub fn len(self, vertices: usize, triangles: usize) -> usize {
        match self {
            Domain::Vertex => vertices,
            Domain::Face => triangles,
            Domain::Corner => 3 * triangles,
        }
    }
}

/// The numbers of an attribute, in the type they came in: PLY's `uchar` stays `U8`, its
/// `char`, `short` and `int` become `I32`, `ushort` and `uint` `U32`.
#[derive(Clone, Debug, PartialEq)]
pub enum Values {
    U8(Vec<u8>),
    I32(Vec<i32>),
    U32(Vec<u32>),
    F32(Vec<f32>),
    F64(Vec<f64>),
}

/// The number type of [`Values`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NumberType {
    U8,
    I32,
    U32,
    F32,
    F64,
}

impl NumberType {
    pub const ALL: [NumberType; 5] =
        [NumberType::U8, NumberType::I32, NumberType::U32, NumberType::F32, NumberType::F64];

    pub fn name(self) -> &'static str {
        match self {
            NumberType::U8 => "u8",
            NumberType::I32 => "i32",
            NumberType::U32 => "u32",
            NumberType::F32 => "f32",
            NumberType::F64 => "f64",
        }
    }

    /// Bytes per number.
    pub fn size(self) -> usize {
        match self {
            NumberType::U8 => 1,
            NumberType::I32 | NumberType::U32 | NumberType::F32 => 4,
            NumberType::F64 => 8,
        }
    }

    /// The value `x` rounds to in this type: nearest, ties away from zero, saturating.
    fn round(self, x: f64) -> f64 {
        match self {
            NumberType::U8 => x.round().clamp(0.0, 255.0),
            NumberType::I32 => x.round().clamp(f64::from(i32::MIN), f64::from(i32::MAX)),
            NumberType::U32 => x.round().clamp(0.0, f64::from(u32::MAX)),
            NumberType::F32 => f64::from(x as f32),
            NumberType::F64 => x,
        }
    }
}

macro_rules! each_values {
    ($values:expr, $v:ident => $body:expr) => {
        match $values {
            Values::U8($v) => $body,
            Values::I32($v) => $body,
            Values::U32($v) => $body,
            Values::F32($v) => $body,
            Values::F64($v) => $body,
        }
    };
}

impl Values {
    /// An empty array of `ty`.
    pub fn empty(ty: NumberType) -> Self {
        match ty {
            NumberType::U8 => Values::U8(Vec::new()),
            NumberType::I32 => Values::I32(Vec::new()),
            NumberType::U32 => Values::U32(Vec::new()),
            NumberType::F32 => Values::F32(Vec::new()),
            NumberType::F64 => Values::F64(Vec::new()),
        }
    }

    pub fn number_type(&self) -> NumberType {
        match self {
            Values::U8(_) => NumberType::U8,
            Values::I32(_) => NumberType::I32,
            Values::U32(_) => NumberType::U32,
            Values::F32(_) => NumberType::F32,
            Values::F64(_) => NumberType::F64,
        }
    }

    /// How many numbers (not elements).
    pub fn len(&self) -> usize {
        each_values!(self, v => v.len())
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number `i`, exactly.
    pub fn get(&self, i: usize) -> f64 {
        match self {
            Values::U8(v) => f64::from(v[i]),
            Values::I32(v) => f64::from(v[i]),
            Values::U32(v) => f64::from(v[i]),
            Values::F32(v) => f64::from(v[i]),
            Values::F64(v) => v[i],
        }
    }

    /// Sets number `i` to `x` rounded to the type (see [`NumberType`]).
    pub fn set(&mut self, i: usize, x: f64) {
        let x = self.number_type().round(x);
        match self {
            Values::U8(v) => v[i] = x as u8,
            Values::I32(v) => v[i] = x as i32,
            Values::U32(v) => v[i] = x as u32,
            Values::F32(v) => v[i] = x as f32,
            Values::F64(v) => v[i] = x,
        }
    }

    /// Appends `x` rounded to the type.
    pub fn push(&mut self, x: f64) {
        let x = self.number_type().round(x);
        match self {
            Values::U8(v) => v.push(x as u8),
            Values::I32(v) => v.push(x as i32),
            Values::U32(v) => v.push(x as u32),
            Values::F32(v) => v.push(x as f32),
            Values::F64(v) => v.push(x),
        }
    }

    /// Keeps the elements (runs of `components` numbers) whose `keep` is true, in order.
    pub fn retain_elements(&mut self, components: usize, keep: &[bool]) {
        each_values!(self, v => {
            let mut kept = 0;
            for (e, &k) in keep.iter().enumerate() {
                if k {
                    v.copy_within(components * e..components * (e + 1), kept);
                    kept += components;
                }
            }
            v.truncate(kept);
        })
    }

    /// The elements (runs of `components` numbers) at `elements`, in that order.
    pub fn gather(&self, components: usize, elements: impl Iterator<Item = usize>) -> Values {
        fn pick<T: Copy>(from: &[T], c: usize, elements: impl Iterator<Item = usize>) -> Vec<T> {
            elements.flat_map(|e| from[c * e..c * (e + 1)].iter().copied()).collect()
        }
        match self {
            Values::U8(v) => Values::U8(pick(v, components, elements)),
            Values::I32(v) => Values::I32(pick(v, components, elements)),
            Values::U32(v) => Values::U32(pick(v, components, elements)),
            Values::F32(v) => Values::F32(pick(v, components, elements)),
            Values::F64(v) => Values::F64(pick(v, components, elements)),
        }
    }

    /// Appends `other`'s numbers; they must be of the same type.
    pub fn extend(&mut self, other: &Values) {
        match (self, other) {
            (Values::U8(a), Values::U8(b)) => a.extend_from_slice(b),
            (Values::I32(a), Values::I32(b)) => a.extend_from_slice(b),
            (Values::U32(a), Values::U32(b)) => a.extend_from_slice(b),
            (Values::F32(a), Values::F32(b)) => a.extend_from_slice(b),
            (Values::F64(a), Values::F64(b)) => a.extend_from_slice(b),
            (a, b) => panic!("extending {:?} values with {:?}", a.number_type(), b.number_type()),
        }
    }

    /// Reserves room for `more` numbers.
    pub fn reserve(&mut self, more: usize) {
        each_values!(self, v => v.reserve(more))
    }

    /// Drops everything from number `len` on.
    pub fn truncate(&mut self, len: usize) {
        each_values!(self, v => v.truncate(len))
    }

    /// The little-endian bytes of every number, in order.
    pub fn to_le_bytes(&self) -> Vec<u8> {
        self.le_bytes().into_owned()
    }

    /// [`to_le_bytes`](Self::to_le_bytes), borrowed on little-endian machines: what the
    /// content hash reads on every step, without copying the arrays.
    pub fn le_bytes(&self) -> std::borrow::Cow<'_, [u8]> {
        match self {
            Values::U8(v) => std::borrow::Cow::Borrowed(v),
            Values::F32(v) => crate::as_le_bytes_f32(v),
            Values::U32(v) => crate::as_le_bytes_u32(v),
            Values::I32(v) if cfg!(target_endian = "little") => {
                // SAFETY: i32 has no padding and any byte is a valid u8.
                let bytes =
                    unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<u8>(), v.len() * 4) };
                std::borrow::Cow::Borrowed(bytes)
            }
            Values::F64(v) if cfg!(target_endian = "little") => {
                // SAFETY: f64 has no padding and any byte is a valid u8.
                let bytes =
                    unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<u8>(), v.len() * 8) };
                std::borrow::Cow::Borrowed(bytes)
            }
            Values::I32(v) => {
                std::borrow::Cow::Owned(v.iter().flat_map(|x| x.to_le_bytes()).collect())
            }
            Values::F64(v) => {
                std::borrow::Cow::Owned(v.iter().flat_map(|x| x.to_le_bytes()).collect())
            }
        }
    }

    /// The first non-finite number, where the type has any.
    pub fn first_non_finite(&self) -> Option<usize> {
        match self {
            Values::F32(v) => v.iter().position(|x| !x.is_finite()),
            Values::F64(v) => v.iter().position(|x| !x.is_finite()),
            _ => None,
        }
    }
}

/// One named array of values over a domain.
#[derive(Clone, Debug, PartialEq)]
pub struct Attribute {
    pub domain: Domain,
    pub name: String,
    /// Numbers per element, 1 to 4.
    pub components: u8,
    pub values: Values,
}

impl Attribute {
    /// Per-vertex RGBA colours, 4 bytes a vertex.
    pub fn color(rgba: Vec<u8>) -> Self {
        Self { domain: Domain::Vertex, name: COLOR.into(), components: 4, values: Values::U8(rgba) }
    }

    /// Per-vertex normals, `x y z` a vertex.
    pub fn normal(xyz: Vec<f32>) -> Self {
        Self {
            domain: Domain::Vertex,
            name: NORMAL.into(),
            components: 3,
            values: Values::F32(xyz),
        }
    }

    /// Per-vertex quality, one a vertex.
    pub fn quality(q: Vec<f32>) -> Self {
        Self { domain: Domain::Vertex, name: QUALITY.into(), components: 1, values: Values::F32(q) }
    }

    /// Texture coordinates, `u v` per vertex or per corner.
    pub fn texcoord(domain: Domain, uv: Vec<f32>) -> Self {
        Self { domain, name: TEXCOORD.into(), components: 2, values: Values::F32(uv) }
    }

    /// Per-face material indices into [`Materials::names`].
    pub fn material(indices: Vec<u32>) -> Self {
        Self {
            domain: Domain::Face,
            name: MATERIAL.into(),
            components: 1,
            values: Values::U32(indices),
        }
    }

    /// How many elements the values cover.
    pub fn element_count(&self) -> usize {
        self.values.len() / usize::from(self.components.max(1))
    }

    /// The shape a well-known name must have (`None` for other names).
    pub fn required_shape(domain: Domain, name: &str) -> Option<(NumberType, u8)> {
        match (domain, name) {
            (Domain::Vertex, COLOR) => Some((NumberType::U8, 4)),
            (Domain::Vertex, NORMAL) => Some((NumberType::F32, 3)),
            (Domain::Vertex, QUALITY) => Some((NumberType::F32, 1)),
            (Domain::Vertex | Domain::Corner, TEXCOORD) => Some((NumberType::F32, 2)),
            (Domain::Face, MATERIAL) => Some((NumberType::U32, 1)),
            _ => None,
        }
    }

    /// The value an element gets when nothing gives it one: opaque white for colours, zero
    /// for the rest (a normal is recomputed, a material is the first).
    pub fn default_value(&self) -> f64 {
        match (self.domain, self.name.as_str()) {
            (Domain::Vertex, COLOR) => 255.0,
            _ => 0.0,
        }
    }

    /// Checks the name, shape and values, for an attribute over `elements` elements.
    pub fn check(&self, elements: usize) -> Result<(), AttributeError> {
        check_name(&self.name)?;
        if !(1..=4).contains(&self.components) {
            return Err(AttributeError::Components {
                name: self.name.clone(),
                components: self.components,
            });
        }
        if let Some((ty, components)) = Self::required_shape(self.domain, &self.name)
            && (ty != self.values.number_type() || components != self.components)
        {
            return Err(AttributeError::Shape {
                domain: self.domain,
                name: self.name.clone(),
                expected: format!("{components} × {}", ty.name()),
                got: format!("{} × {}", self.components, self.values.number_type().name()),
            });
        }
        let expected = elements * usize::from(self.components);
        if self.values.len() != expected {
            return Err(AttributeError::Length {
                domain: self.domain,
                name: self.name.clone(),
                expected,
                got: self.values.len(),
            });
        }
        if let Some(i) = self.values.first_non_finite() {
            return Err(AttributeError::NotFinite {
                name: self.name.clone(),
                element: i / usize::from(self.components),
            });
        }
        Ok(())
    }
}

/// The materials faces name by index, and the files they come from.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Materials {
    /// Material names (OBJ `usemtl`), indexed by the face attribute [`MATERIAL`].
    pub names: Vec<String>,
    /// Material library files (OBJ `mtllib`), relative to the mesh file.
    pub libraries: Vec<String>,
    /// Texture image files (PLY `comment TextureFile`, the libraries' maps), relative to the
    /// mesh file.
    pub textures: Vec<String>,
}

impl Materials {
    pub fn is_empty(&self) -> bool {
        self.names.is_empty() && self.libraries.is_empty() && self.textures.is_empty()
    }

    /// Checks every list's length and every name. File names stay in the mesh's folder or
    /// below it (`skin.png`, `textures/skin.png`): relative, `/`-separated, no empty, `.` or
    /// `..` part, no `\` or `:` (no Windows paths or drives), so no writer that copies
    /// them can be led outside.
    pub fn check(&self) -> Result<(), AttributeError> {
        for (what, list) in
            [("material", &self.names), ("library", &self.libraries), ("texture", &self.textures)]
        {
            if list.len() > MAX_MATERIALS {
                return Err(AttributeError::TooManyMaterials { what, count: list.len() });
            }
            for name in list {
                let is_file = what != "material";
                let bad = name.is_empty()
                    || name.len() > 4 * MAX_NAME_BYTES
                    || name.chars().any(char::is_control)
                    || (is_file && !stays_below(name));
                if bad {
                    return Err(AttributeError::MaterialName {
                        what,
                        name: name.chars().take(80).collect(),
                    });
                }
            }
        }
        Ok(())
    }
}

/// Whether a relative file name stays in its folder or below it.
fn stays_below(name: &str) -> bool {
    !name.contains(['\\', ':']) && name.split('/').all(|part| !matches!(part, "" | "." | ".."))
}

/// Every attribute of a mesh, in canonical order (domain, then name), and its materials.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Attributes {
    list: Vec<Attribute>,
    pub materials: Materials,
}

impl Attributes {
    pub fn is_empty(&self) -> bool {
        self.list.is_empty() && self.materials.is_empty()
    }

    /// The attributes in canonical order: by domain, then by name.
    pub fn iter(&self) -> impl Iterator<Item = &Attribute> {
        self.list.iter()
    }

    pub fn len(&self) -> usize {
        self.list.len()
    }

    pub fn get(&self, domain: Domain, name: &str) -> Option<&Attribute> {
        self.position(domain, name).ok().map(|i| &self.list[i])
    }

    pub fn get_mut(&mut self, domain: Domain, name: &str) -> Option<&mut Attribute> {
        self.position(domain, name).ok().map(|i| &mut self.list[i])
    }

    /// The attributes of one domain, mutable, for the store to extend and compact.
    pub fn of_domain_mut(&mut self, domain: Domain) -> impl Iterator<Item = &mut Attribute> {
        self.list.iter_mut().filter(move |a| a.domain == domain)
    }

    pub fn has_domain(&self, domain: Domain) -> bool {
        self.list.iter().any(|a| a.domain == domain)
    }

    /// Adds or replaces an attribute after [`Attribute::check`] against a mesh of `vertices`
    /// and `triangles`.
    pub fn insert(
        &mut self,
        attribute: Attribute,
        vertices: usize,
        triangles: usize,
    ) -> Result<(), AttributeError> {
        attribute.check(attribute.domain.len(vertices, triangles))?;
        match self.position(attribute.domain, &attribute.name) {
            Ok(i) => self.list[i] = attribute,
            Err(i) => {
                if self.list.len() >= MAX_ATTRIBUTES {
                    return Err(AttributeError::TooMany);
                }
                self.list.insert(i, attribute);
            }
        }
        Ok(())
    }

    pub fn remove(&mut self, domain: Domain, name: &str) -> Option<Attribute> {
        self.position(domain, name).ok().map(|i| self.list.remove(i))
    }

    /// The attributes of the sub-mesh made of the elements `vertices` and `triangles` (ids
    /// into this mesh, in the sub-mesh's order), and the same materials.
    pub fn gather(&self, vertices: &[u32], triangles: &[u32]) -> Attributes {
        let list = self
            .list
            .iter()
            .map(|a| {
                let components = usize::from(a.components);
                let values = match a.domain {
                    Domain::Vertex => {
                        a.values.gather(components, vertices.iter().map(|&v| v as usize))
                    }
                    Domain::Face => {
                        a.values.gather(components, triangles.iter().map(|&t| t as usize))
                    }
                    Domain::Corner => a.values.gather(
                        components,
                        triangles.iter().flat_map(|&t| (0..3).map(move |k| 3 * t as usize + k)),
                    ),
                };
                Attribute {
                    domain: a.domain,
                    name: a.name.clone(),
                    components: a.components,
                    values,
                }
            })
            .collect();
        Attributes { list, materials: self.materials.clone() }
    }

    /// Checks every attribute against a mesh of `vertices` and `triangles`, and the
    /// materials: what a loaded or received mesh must pass before anything uses it.
    pub fn check(&self, vertices: usize, triangles: usize) -> Result<(), AttributeError> {
        if self.list.len() > MAX_ATTRIBUTES {
            return Err(AttributeError::TooMany);
        }
        for pair in self.list.windows(2) {
            if (pair[0].domain, &pair[0].name) >= (pair[1].domain, &pair[1].name) {
                return Err(AttributeError::Order);
            }
        }
        for a in &self.list {
            a.check(a.domain.len(vertices, triangles))?;
        }
        self.materials.check()
    }

    /// One line per attribute, for `meshflow info` and reports: `vertex color (4 × u8)`.
    pub fn describe(&self) -> Vec<String> {
        let mut lines: Vec<String> = self
            .list
            .iter()
            .map(|a| {
                format!(
                    "{} {} ({} × {})",
                    a.domain.name(),
                    a.name,
                    a.components,
                    a.values.number_type().name()
                )
            })
            .collect();
        let m = &self.materials;
        if !m.names.is_empty() {
            lines.push(format!("materials: {}", m.names.join(", ")));
        }
        if !m.libraries.is_empty() {
            lines.push(format!("material libraries: {}", m.libraries.join(", ")));
        }
        if !m.textures.is_empty() {
            lines.push(format!("textures: {}", m.textures.join(", ")));
        }
        lines
    }

    fn position(&self, domain: Domain, name: &str) -> Result<usize, usize> {
        self.list.binary_search_by(|a| (a.domain, a.name.as_str()).cmp(&(domain, name)))
    }
}

/// Names are what files and plugins use to find an attribute again: short, printable,
/// without spaces (PLY property names cannot hold them).
pub fn check_name(name: &str) -> Result<(), AttributeError> {
    let ok = !name.is_empty()
        && name.len() <= MAX_NAME_BYTES
        && name.bytes().all(|b| b.is_ascii_alphanumeric() || b"_-.".contains(&b));
    if ok { Ok(()) } else { Err(AttributeError::Name(name.chars().take(80).collect())) }
}

#[derive(Debug, Error, Clone, PartialEq)]
pub enum AttributeError {
    #[error(
        "attribute name {0:?}: names are 1 to {MAX_NAME_BYTES} letters, digits, '_', '-' or '.'"
    )]
    Name(String),
    #[error("attribute {name}: {components} components; an attribute has 1 to 4")]
    Components { name: String, components: u8 },
    #[error("{} attribute {name} must be {expected}, got {got}", domain.name())]
    Shape { domain: Domain, name: String, expected: String, got: String },
    #[error("{} attribute {name}: expected {expected} numbers, got {got}", domain.name())]
    Length { domain: Domain, name: String, expected: usize, got: usize },
    #[error("attribute {name}: element {element} is not finite")]
    NotFinite { name: String, element: usize },
    #[error("a mesh holds at most {MAX_ATTRIBUTES} attributes")]
    TooMany,
    #[error("attributes out of canonical order or repeated")]
    Order,
    #[error("{count} {what} names; a mesh holds at most {MAX_MATERIALS}")]
    TooManyMaterials { what: &'static str, count: usize },
    #[error(
        "{what} name {name:?} is empty, too long, has control characters, or leaves the mesh's folder"
    )]
    MaterialName { what: &'static str, name: String },
}

/// The canonical bytes of the attributes: what the content hash covers after positions and
/// triangles, and what a `raw` mesh carries after its arrays. `"attributes-v1"`, the count
/// (u32 LE), then per attribute in canonical order its domain, number type and component
/// count (a byte each, in [`Domain`] and [`NumberType::ALL`] order), its name (u32 LE length,
/// bytes), its number count (u64 LE) and numbers (LE); then the material names, libraries
/// and textures, each a u32 LE count of length-prefixed strings.
pub fn write_canonical(attributes: &Attributes, out: &mut impl FnMut(&[u8])) {
    let string = |out: &mut dyn FnMut(&[u8]), s: &str| {
        out(&(s.len() as u32).to_le_bytes());
        out(s.as_bytes());
    };
    out(CANONICAL_TAG);
    out(&(attributes.list.len() as u32).to_le_bytes());
    for a in &attributes.list {
        out(&[a.domain as u8, a.values.number_type() as u8, a.components]);
        string(out, &a.name);
        out(&(a.values.len() as u64).to_le_bytes());
        out(&a.values.le_bytes());
    }
    let m = &attributes.materials;
    for list in [&m.names, &m.libraries, &m.textures] {
        out(&(list.len() as u32).to_le_bytes());
        for s in list {
            string(out, s);
        }
    }
}

/// What the canonical attribute bytes start with.
pub const CANONICAL_TAG: &[u8] = b"attributes-v1";
