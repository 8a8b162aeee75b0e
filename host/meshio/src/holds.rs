//! What each format can hold of a mesh's attributes: [`unsupported`] names what a save
//! would leave out, so a command can warn or refuse before it writes.

use meshflow_mesh::MeshData;
use meshflow_mesh::attributes::Attribute;

use crate::{Format, obj, off, ply};

/// Each attribute (and material list) of `mesh` that a file of `format` cannot hold, as
/// `Attributes::describe` names it: `vertex color (4 × u8)`. Empty when a save keeps
/// everything: loading the file back then gives a mesh of the same content hash (OBJ:
/// with its material library beside it, see [`copy_companion_files`](crate::copy_companion_files)).
pub fn unsupported(mesh: &MeshData, format: Format) -> Vec<String> {
    match format {
        Format::Ply => ply::unsupported(mesh),
        Format::Obj => obj::unsupported(mesh),
        Format::Off => off::unsupported(mesh),
        Format::Stl => {
            let mut lines: Vec<String> = mesh.attributes.iter().map(describe).collect();
            lines.extend(materials(mesh, true, true, true));
            lines
        }
    }
}

/// One attribute as `Attributes::describe` names it.
pub(crate) fn describe(a: &Attribute) -> String {
    format!("{} {} ({} × {})", a.domain.name(), a.name, a.components, a.values.number_type().name())
}

/// The material lists of the mesh a format cannot hold: names, libraries, textures.
pub(crate) fn materials(
    mesh: &MeshData,
    names: bool,
    libraries: bool,
    textures: bool,
) -> Vec<String> {
    let m = &mesh.attributes.materials;
    let mut lines = Vec::new();
    if names && !m.names.is_empty() {
        lines.push(format!("materials ({})", m.names.join(", ")));
    }
    if libraries && !m.libraries.is_empty() {
        lines.push(format!("material libraries ({})", m.libraries.join(", ")));
    }
    if textures && !m.textures.is_empty() {
        lines.push(format!("textures ({})", m.textures.join(", ")));
    }
    lines
}
