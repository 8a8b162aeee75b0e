//! Which PLY properties become which attributes, decided from the header before the body is
//! read, and the attributes made from the values read.
//!
//! Vertex `red green blue [alpha]` (or `diffuse_…`) become `color`, `nx ny nz` `normal`,
//! `quality` `quality`, `texture_u texture_v` (or `u v`, `s t`, `texture_s texture_t`)
//! `texcoord`; face `red green blue [alpha]` a face `color`, the face list `texcoord`
//! corner texture coordinates, `texnumber` the `material` (an index into the
//! `comment TextureFile` names, as MeshLab writes them). Every other scalar property, and
//! every list whose records all hold the same 1 to 4 numbers, is kept by its name with its
//! type. What cannot be kept is named in the [`Dropped`] report.

use std::collections::HashSet;

use meshflow_mesh::attributes::{
    self as model, Attribute, Attributes, Domain, MAX_ATTRIBUTES, NumberType, Values,
};

use super::header::{Element, Header, Kind, Scalar};
use crate::dropped::Dropped;
use crate::keep::{
    Kept, MaterialList, MaterialNames, expand_polygons, fan_corners, interleave, to_f32,
    unit_to_u8, usable_name,
};

/// Where one property's values go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Role {
    Skip,
    /// A vertex coordinate: 0, 1, 2 for x, y, z.
    Axis(usize),
    /// The face's corner list.
    Corners,
    /// A column of [`Plan::columns`].
    Column(usize),
}

/// The values of one property, in the model's type for the PLY type.
pub(super) struct Column {
    pub values: Values,
    /// Lists: each record's length.
    pub lengths: Vec<u32>,
    /// A list kept as an attribute of that many components must have one length, 1 to 4,
    /// in every record; once one differs, its values are no longer kept.
    even: bool,
    uneven: bool,
}

impl Column {
    fn new(ty: Scalar, even: bool) -> Self {
        Self { values: Values::empty(number_type(ty)), lengths: Vec::new(), even, uneven: false }
    }

    /// Notes a record's list length; whether its values are to be kept.
    pub fn record(&mut self, n: usize) -> bool {
        if self.uneven {
            return false;
        }
        let first = self.lengths.first().map_or(n, |&f| f as usize);
        if self.even && (n == 0 || n > 4 || n != first) {
            self.uneven = true;
            self.values = Values::empty(self.values.number_type());
            self.lengths = Vec::new();
            return false;
        }
        self.lengths.push(u32::try_from(n).unwrap_or(u32::MAX));
        true
    }
}

/// The model's type for a PLY type: `uchar` stays a byte, signed integers become `i32`,
/// unsigned ones `u32`.
pub(super) fn number_type(ty: Scalar) -> NumberType {
    match ty {
        Scalar::U8 => NumberType::U8,
        Scalar::I8 | Scalar::I16 | Scalar::I32 => NumberType::I32,
        Scalar::U16 | Scalar::U32 => NumberType::U32,
        Scalar::F32 => NumberType::F32,
        Scalar::F64 => NumberType::F64,
    }
}

/// How one attribute is made from columns.
enum Build {
    Color { domain: Domain, rgba: [Option<usize>; 4], what: String },
    Normal { xyz: [usize; 3], what: String },
    Quality(usize),
    Texcoord { uv: [usize; 2], what: String },
    CornerTexcoord { column: usize, name: String },
    Material(usize),
    Plain { domain: Domain, name: String, column: usize, list: bool },
}

/// Names of the PLY colour properties writers use.
const COLOUR_NAMES: [[&str; 4]; 2] = [
    ["red", "green", "blue", "alpha"],
    ["diffuse_red", "diffuse_green", "diffuse_blue", "diffuse_alpha"],
];
const NORMAL_NAMES: [[&str; 3]; 2] = [["nx", "ny", "nz"], ["normal_x", "normal_y", "normal_z"]];
/// In the order a reader prefers them when a file has several; the writer uses the first of
/// each group, so an attribute named like another set's members stays what it is.
const TEXCOORD_NAMES: [[&str; 2]; 4] =
    [["texture_u", "texture_v"], ["u", "v"], ["s", "t"], ["texture_s", "texture_t"]];
/// What a material index is called in the face element (MeshLab).
pub(crate) const TEXNUMBER: &str = "texnumber";
/// The face list of corner texture coordinates (MeshLab).
pub(crate) const CORNER_TEXCOORD: &str = "texcoord";
/// Comments meshflow writes for what PLY has no place for: `comment meshflow material
/// NAME`, `comment meshflow library NAME`.
pub(crate) const MESHFLOW_COMMENT: &str = "meshflow";

/// The PLY property names a reader always takes for something else than an attribute of
/// that name, per domain: an attribute of such a name cannot be written as a property.
pub(crate) fn reserved(domain: Domain, name: &str) -> bool {
    match domain {
        Domain::Vertex => ["x", "y", "z"].contains(&name),
        Domain::Face => ["vertex_indices", "vertex_index", TEXNUMBER, CORNER_TEXCOORD, "texcoords"]
            .contains(&name),
        Domain::Corner => true,
    }
}

/// The sets of PLY names a reader takes together as one attribute of a domain, in the
/// order it prefers them: each set, how many of its first names it needs, the
/// attribute it makes, and whether it takes the number type.
pub(crate) fn groups(domain: Domain) -> Vec<Group> {
    let colour = |ty: NumberType| matches!(ty, NumberType::U8 | NumberType::F32 | NumberType::F64);
    let any = |_: NumberType| true;
    let mut groups: Vec<Group> = COLOUR_NAMES
        .iter()
        .map(|set| Group { names: &set[..], needed: 3, attribute: model::COLOR, takes: colour })
        .collect();
    if domain == Domain::Vertex {
        groups.extend(NORMAL_NAMES.iter().map(|set| Group {
            names: &set[..],
            needed: 3,
            attribute: model::NORMAL,
            takes: any,
        }));
        groups.extend(TEXCOORD_NAMES.iter().map(|set| Group {
            names: &set[..],
            needed: 2,
            attribute: model::TEXCOORD,
            takes: any,
        }));
    }
    groups
}

/// PLY properties a reader takes together (see [`groups`]).
pub(crate) struct Group {
    pub names: &'static [&'static str],
    pub needed: usize,
    pub attribute: &'static str,
    pub takes: fn(NumberType) -> bool,
}

/// The attributes to be made, the columns their values are read into and each property's
/// role.
pub(super) struct Plan {
    pub vertex_roles: Vec<Role>,
    pub face_roles: Vec<Role>,
    pub columns: Vec<Column>,
    builds: Vec<Build>,
    materials: MaterialNames,
    /// Material names are the textures' (MeshLab's `texnumber` indexes `TextureFile`s),
    /// unless the file names them (`comment meshflow material`).
    names_from_textures: bool,
}

impl Plan {
    /// Whether face records need their corner counts (face values are per polygon).
    pub fn face_columns(&self) -> bool {
        self.face_roles.iter().any(|r| matches!(r, Role::Column(_)))
    }
}

/// Decides the plan for a header whose vertex element has its coordinates at `axes` and
/// whose face element has its corner list at `corners`.
pub(super) fn plan(
    header: &Header,
    axes: Option<[usize; 3]>,
    corners: Option<usize>,
    dropped: &mut Dropped,
) -> Plan {
    let mut p = Planner {
        plan: Plan {
            vertex_roles: Vec::new(),
            face_roles: Vec::new(),
            columns: Vec::new(),
            builds: Vec::new(),
            materials: MaterialNames::default(),
            names_from_textures: true,
        },
        claimed: HashSet::new(),
        bad_texture: false,
    };
    p.comments(&header.comments, dropped);
    let vertex = header.elements.iter().find(|e| e.name == "vertex");
    let face = header.elements.iter().find(|e| e.name == "face");
    if let Some(v) = vertex {
        p.plan.vertex_roles = vec![Role::Skip; v.properties.len()];
        for (k, axis) in axes.into_iter().flatten().enumerate() {
            p.plan.vertex_roles[axis] = Role::Axis(k);
        }
    }
    if let Some(f) = face {
        p.plan.face_roles = vec![Role::Skip; f.properties.len()];
        if let Some(c) = corners {
            p.plan.face_roles[c] = Role::Corners;
        }
    }
    if let Some(v) = vertex {
        p.colour(v, Domain::Vertex);
        p.normal(v);
        p.quality(v);
        p.texcoord(v);
    }
    if let Some(f) = face {
        p.colour(f, Domain::Face);
        p.corner_texcoord(f);
        p.material(f);
    }
    for (element, domain) in [(vertex, Domain::Vertex), (face, Domain::Face)] {
        if let Some(element) = element {
            p.plain(element, domain, dropped);
        }
    }
    for element in header.elements.iter().filter(|e| e.count > 0) {
        if !["vertex", "face"].contains(&element.name.as_str()) {
            dropped.add(format!("element '{}' ({} records)", element.name, element.count));
        }
    }
    p.plan
}

struct Planner {
    plan: Plan,
    /// Attribute names taken, per domain.
    claimed: HashSet<(Domain, String)>,
    /// A `TextureFile` was refused, so `texnumber` no longer indexes the kept names.
    bad_texture: bool,
}

impl Planner {
    fn comments(&mut self, comments: &[String], dropped: &mut Dropped) {
        let materials = &mut self.plan.materials;
        for comment in comments {
            let (head, rest) =
                comment.split_once(|c: char| c.is_ascii_whitespace()).unwrap_or((comment, ""));
            let rest = rest.trim_ascii();
            if head.eq_ignore_ascii_case("TextureFile") {
                self.bad_texture |= materials.add(MaterialList::Textures, rest, dropped).is_none();
            } else if head == MESHFLOW_COMMENT {
                let (what, name) =
                    rest.split_once(|c: char| c.is_ascii_whitespace()).unwrap_or((rest, ""));
                let list = match what {
                    "material" => MaterialList::Names,
                    "library" => MaterialList::Libraries,
                    _ => continue,
                };
                if list == MaterialList::Names {
                    self.plan.names_from_textures = false;
                }
                materials.add(list, name.trim_ascii(), dropped);
            }
        }
    }

    fn roles(&mut self, domain: Domain) -> &mut Vec<Role> {
        match domain {
            Domain::Face => &mut self.plan.face_roles,
            _ => &mut self.plan.vertex_roles,
        }
    }

    /// The index of a scalar property of this name not taken yet, with its type.
    fn free_scalar(
        &mut self,
        element: &Element,
        domain: Domain,
        name: &str,
    ) -> Option<(usize, Scalar)> {
        let p = element.property(name)?;
        match (self.roles(domain)[p], element.properties[p].kind) {
            (Role::Skip, Kind::Scalar(ty)) => Some((p, ty)),
            _ => None,
        }
    }

    fn column(&mut self, domain: Domain, property: usize, ty: Scalar, even: bool) -> usize {
        let index = self.plan.columns.len();
        self.plan.columns.push(Column::new(ty, even));
        self.roles(domain)[property] = Role::Column(index);
        index
    }

    /// Claims an attribute name; false when the mesh is full or the name is taken.
    fn claim(&mut self, domain: Domain, name: &str) -> bool {
        self.plan.builds.len() < MAX_ATTRIBUTES && self.claimed.insert((domain, name.to_owned()))
    }

    fn colour(&mut self, element: &Element, domain: Domain) {
        for names in COLOUR_NAMES {
            let usable = |ty: Scalar| matches!(ty, Scalar::U8 | Scalar::F32 | Scalar::F64);
            let found: Vec<Option<(usize, Scalar)>> = names
                .iter()
                .map(|n| self.free_scalar(element, domain, n).filter(|&(_, ty)| usable(ty)))
                .collect();
            if found[..3].iter().any(Option::is_none) || !self.claim(domain, model::COLOR) {
                continue;
            }
            let mut rgba = [None; 4];
            let mut shown = Vec::new();
            for (k, f) in found.iter().enumerate() {
                if let Some((p, ty)) = *f {
                    rgba[k] = Some(self.column(domain, p, ty, false));
                    shown.push(names[k]);
                }
            }
            let what = format!("{} colour ({})", domain.name(), shown.join(", "));
            self.plan.builds.push(Build::Color { domain, rgba, what });
            return;
        }
    }

    fn normal(&mut self, element: &Element) {
        let domain = Domain::Vertex;
        for names in NORMAL_NAMES {
            let found: Vec<_> =
                names.iter().filter_map(|n| self.free_scalar(element, domain, n)).collect();
            if found.len() == 3 && self.claim(domain, model::NORMAL) {
                let xyz = [0, 1, 2].map(|k| self.column(domain, found[k].0, found[k].1, false));
                let what = format!("vertex normal ({})", names.join(", "));
                self.plan.builds.push(Build::Normal { xyz, what });
                return;
            }
        }
    }

    fn quality(&mut self, element: &Element) {
        let domain = Domain::Vertex;
        if let Some((p, ty)) = self.free_scalar(element, domain, model::QUALITY)
            && self.claim(domain, model::QUALITY)
        {
            let column = self.column(domain, p, ty, false);
            self.plan.builds.push(Build::Quality(column));
        }
    }

    fn texcoord(&mut self, element: &Element) {
        let domain = Domain::Vertex;
        for names in TEXCOORD_NAMES {
            let found: Vec<_> =
                names.iter().filter_map(|n| self.free_scalar(element, domain, n)).collect();
            if found.len() == 2 && self.claim(domain, model::TEXCOORD) {
                let uv = [0, 1].map(|k| self.column(domain, found[k].0, found[k].1, false));
                let what = format!("vertex texture coordinate ({})", names.join(", "));
                self.plan.builds.push(Build::Texcoord { uv, what });
                return;
            }
        }
    }

    fn corner_texcoord(&mut self, element: &Element) {
        for name in [CORNER_TEXCOORD, "texcoords"] {
            let Some(p) = element.property(name) else { continue };
            let Kind::List { item: item @ (Scalar::F32 | Scalar::F64), .. } =
                element.properties[p].kind
            else {
                continue;
            };
            if self.plan.face_roles[p] == Role::Skip && self.claim(Domain::Corner, model::TEXCOORD)
            {
                let column = self.column(Domain::Face, p, item, false);
                let name = name.to_owned();
                self.plan.builds.push(Build::CornerTexcoord { column, name });
                return;
            }
        }
    }

    fn material(&mut self, element: &Element) {
        let names = &self.plan.materials.materials;
        let has_names = if self.plan.names_from_textures {
            !names.textures.is_empty() && !self.bad_texture
        } else {
            !names.names.is_empty()
        };
        let domain = Domain::Face;
        if let Some((p, ty)) = self.free_scalar(element, domain, TEXNUMBER)
            && ty.is_integer()
            && has_names
            && self.claim(domain, model::MATERIAL)
        {
            let column = self.column(domain, p, ty, false);
            self.plan.builds.push(Build::Material(column));
        }
    }

    /// Every other property of the element, by its name.
    fn plain(&mut self, element: &Element, domain: Domain, dropped: &mut Dropped) {
        let mut over = Vec::new();
        let owner = domain.name();
        for (p, property) in element.properties.iter().enumerate() {
            if self.roles(domain)[p] != Role::Skip {
                continue;
            }
            let name = property.name.as_str();
            let (list, ty) = match property.kind {
                Kind::Scalar(ty) => (false, ty),
                Kind::List { item, .. } => (true, item),
            };
            let what = match list {
                false => format!("{owner} property '{name}'"),
                true => format!("{owner} list '{name}'"),
            };
            if element.count > 0 && !usable_name(name, &what, dropped) {
                continue;
            }
            // A `texnumber` that indexes no textures stays the number it is.
            let taken = reserved(domain, name) && name != TEXNUMBER;
            if Attribute::required_shape(domain, name).is_some() || taken {
                if element.count > 0 {
                    dropped.add(format!("{what} (a name meshflow reads as something else)"));
                }
                continue;
            }
            if self.plan.builds.len() >= MAX_ATTRIBUTES {
                over.push(name);
                continue;
            }
            if !self.claim(domain, name) {
                continue;
            }
            let column = self.column(domain, p, ty, list);
            let name = name.to_owned();
            self.plan.builds.push(Build::Plain { domain, name, column, list });
        }
        if !over.is_empty() && element.count > 0 {
            const SHOWN: usize = 3;
            let named: Vec<String> = over.iter().take(SHOWN).map(|n| format!("'{n}'")).collect();
            let mut named = named.join(", ");
            if over.len() > SHOWN {
                named += &format!(" and {} more", over.len() - SHOWN);
            }
            dropped.add(format!(
                "{owner} properties {named} (a mesh holds at most {MAX_ATTRIBUTES} attributes)"
            ));
        }
    }
}

impl Plan {
    /// The attributes of a mesh of `vertices` and `triangles` read with this plan;
    /// `corners` holds each face's corner count (when [`Plan::face_columns`]).
    pub fn assemble(
        self,
        vertices: usize,
        triangles: usize,
        corners: &[u32],
        dropped: &mut Dropped,
    ) -> Attributes {
        let fans: Option<Vec<u32>> = corners
            .iter()
            .any(|&n| n != 3)
            .then(|| corners.iter().map(|&n| n.saturating_sub(2)).collect());
        let fans = fans.as_deref();
        let mut columns: Vec<Option<Column>> = self.columns.into_iter().map(Some).collect();
        let mut take = |c: usize| columns[c].take().expect("each column is used once");
        let mut kept = Kept::new(vertices, triangles);
        let mut material_kept = false;
        for build in self.builds {
            match build {
                Build::Color { domain, rgba, what } => {
                    let mut lossy = false;
                    let channels: Vec<Option<Vec<u8>>> =
                        rgba.iter().map(|c| c.map(|c| bytes(take(c).values, &mut lossy))).collect();
                    let n = channels[0].as_ref().map_or(0, Vec::len);
                    let alpha = vec![255; n];
                    let refs: Vec<&[u8]> =
                        channels.iter().map(|c| c.as_deref().unwrap_or(&alpha)).collect();
                    let values =
                        expand_polygons(Values::U8(interleave(&refs)), 4, fans_of(domain, fans));
                    if lossy {
                        dropped.add(format!("{what}: floats from 0 to 1 kept as 8-bit values"));
                    }
                    let colour =
                        Attribute { domain, name: model::COLOR.into(), components: 4, values };
                    kept.keep(colour, &what, dropped);
                }
                Build::Normal { xyz, what } => {
                    let values = floats(xyz.map(&mut take), &what, dropped);
                    kept.keep(Attribute::normal(values), &what, dropped);
                }
                Build::Quality(c) => {
                    let what = "vertex property 'quality'";
                    let values = floats([take(c)], what, dropped);
                    kept.keep(Attribute::quality(values), what, dropped);
                }
                Build::Texcoord { uv, what } => {
                    let values = floats(uv.map(&mut take), &what, dropped);
                    kept.keep(Attribute::texcoord(Domain::Vertex, values), &what, dropped);
                }
                Build::CornerTexcoord { column, name } => {
                    let what = format!("corner texture coordinates (face list '{name}')");
                    let column = take(column);
                    let fits = column.lengths.len() == corners.len()
                        && column.lengths.iter().zip(corners).all(|(&l, &n)| l == 2 * n);
                    if !fits {
                        dropped.add(format!("{what}: a face's list does not hold u v per corner"));
                        continue;
                    }
                    let (uv, lossy) = to_f32(&column.values);
                    if lossy {
                        dropped.add(format!("{what}: doubles rounded to float"));
                    }
                    let uv = fan_corners(&uv, 2, corners);
                    kept.keep(Attribute::texcoord(Domain::Corner, uv), &what, dropped);
                }
                Build::Material(c) => {
                    let column = take(c);
                    let names = &self.materials.materials;
                    let count = if self.names_from_textures {
                        names.textures.len()
                    } else {
                        names.names.len()
                    };
                    let values = &column.values;
                    let in_range =
                        (0..values.len()).all(|i| (0.0..count as f64).contains(&values.get(i)));
                    if in_range {
                        let indices: Vec<u32> =
                            (0..values.len()).map(|i| values.get(i) as u32).collect();
                        let values = expand_polygons(Values::U32(indices), 1, fans);
                        let Values::U32(indices) = values else { unreachable!() };
                        let what = format!("face property '{TEXNUMBER}'");
                        let before = kept.attributes.len();
                        kept.keep(Attribute::material(indices), &what, dropped);
                        material_kept = kept.attributes.len() > before;
                    } else {
                        // Not an index into the names: kept as the number it is.
                        let values = expand_polygons(column.values, 1, fans);
                        let plain = Attribute {
                            domain: Domain::Face,
                            name: TEXNUMBER.into(),
                            components: 1,
                            values,
                        };
                        kept.keep(plain, &format!("face property '{TEXNUMBER}'"), dropped);
                    }
                }
                Build::Plain { domain, name, column, list } => {
                    let column = take(column);
                    let what = match list {
                        false => format!("{} property '{name}'", domain.name()),
                        true => format!("{} list '{name}'", domain.name()),
                    };
                    let components = match list {
                        false => 1,
                        true if column.uneven => {
                            dropped.add(format!(
                                "{what} (lists not of one length from 1 to 4 in every record)"
                            ));
                            continue;
                        }
                        true => column.lengths.first().map_or(1, |&n| n as u8),
                    };
                    let values = expand_polygons(
                        column.values,
                        usize::from(components),
                        fans_of(domain, fans),
                    );
                    let attribute = Attribute { domain, name, components, values };
                    kept.keep(attribute, &what, dropped);
                }
            }
        }
        let mut attributes = kept.attributes;
        let mut materials = self.materials.materials;
        if self.names_from_textures {
            materials.names = if material_kept { materials.textures.clone() } else { Vec::new() };
        }
        attributes.materials = materials;
        attributes
    }
}

fn fans_of(domain: Domain, fans: Option<&[u32]>) -> Option<&[u32]> {
    match domain {
        Domain::Face => fans,
        _ => None,
    }
}

/// A colour channel as bytes: `uchar` as it is, floats from 0 to 1 scaled; `lossy` when a
/// float was not one of the 256 values a byte holds.
fn bytes(values: Values, lossy: &mut bool) -> Vec<u8> {
    match values {
        Values::U8(v) => v,
        other => (0..other.len())
            .map(|i| {
                let x = other.get(i);
                let b = unit_to_u8(x);
                *lossy |= f32::from(b) / 255.0 != x as f32;
                b
            })
            .collect(),
    }
}

/// Columns as interleaved f32, naming a loss of precision.
fn floats<const N: usize>(columns: [Column; N], what: &str, dropped: &mut Dropped) -> Vec<f32> {
    let mut lossy = false;
    let converted: Vec<Vec<f32>> = columns
        .iter()
        .map(|c| {
            let (v, changed) = to_f32(&c.values);
            lossy |= changed;
            v
        })
        .collect();
    if lossy {
        dropped.add(format!("{what}: rounded to float"));
    }
    let refs: Vec<&[f32]> = converted.iter().map(Vec::as_slice).collect();
    interleave(&refs)
}
