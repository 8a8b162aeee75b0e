//! The files a mesh names beside it (OBJ material libraries, texture images): a mesh saved
//! somewhere else needs copies beside it too.

use std::path::{Path, PathBuf};

use meshflow_mesh::attributes::Materials;

use crate::error::SaveError;
use crate::keep::{MaterialList, acceptable};
use crate::{Format, atomic};

/// What [`copy_companion_files`] did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Companions {
    /// The files written beside the output.
    pub copied: Vec<PathBuf>,
    /// The names not copied, each with why: `skin.png: not beside scan.obj`.
    pub skipped: Vec<String>,
}

/// Copies the material libraries and textures `materials` names (and, for an OBJ source,
/// the textures its libraries name) from beside `from_mesh` to
/// beside `to_mesh`, when `to_mesh`'s format holds them (OBJ, PLY). Only plain file names
/// are followed (the rules of `Materials::check`: never `../x` or `a/b`); a name that is
/// not a regular file beside `from_mesh` is skipped and named. Nothing is copied when both
/// meshes are in the same folder. Each copy is atomic, like [`save`](crate::save).
pub fn copy_companion_files(
    from_mesh: &Path,
    to_mesh: &Path,
    materials: &Materials,
) -> Result<Companions, SaveError> {
    let mut done = Companions::default();
    if !matches!(Format::from_path(to_mesh), Some(Format::Obj | Format::Ply)) {
        return Ok(done);
    }
    let folder = |path: &Path| match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let (from_dir, to_dir) = (folder(from_mesh), folder(to_mesh));
    if let (Ok(a), Ok(b)) = (from_dir.canonicalize(), to_dir.canonicalize())
        && a == b
    {
        return Ok(done);
    }
    // An OBJ's textures are named in its libraries, read here beside the source.
    let (library_textures, notes) = match Format::from_path(from_mesh) {
        Some(Format::Obj) => crate::obj::library_textures(&from_dir, &materials.libraries),
        _ => (Vec::new(), Vec::new()),
    };
    done.skipped.extend(notes);
    let names = (materials.libraries.iter().map(|n| (MaterialList::Libraries, n)))
        .chain(materials.textures.iter().map(|n| (MaterialList::Textures, n)))
        .chain(library_textures.iter().map(|n| (MaterialList::Textures, n)));
    let mut seen = Vec::new();
    for (list, name) in names {
        if seen.contains(&name) {
            continue;
        }
        seen.push(name);
        if !acceptable(list, name) {
            let shown: String = name.chars().take(80).collect();
            done.skipped.push(format!("{shown:?}: leaves the mesh's folder; it is never followed"));
            continue;
        }
        let source = from_dir.join(name);
        if !std::fs::metadata(&source).is_ok_and(|m| m.is_file()) {
            done.skipped.push(format!("{name}: not beside {}", from_mesh.display()));
            continue;
        }
        let target = to_dir.join(name);
        if let Some(folder) = target.parent() {
            std::fs::create_dir_all(folder).map_err(|cause| SaveError::Io {
                name: folder.display().to_string(),
                action: "creating the folder failed",
                cause,
            })?;
        }
        atomic::write_file(&target, |out| {
            let mut file = std::fs::File::open(&source)?;
            std::io::copy(&mut file, out).map(drop)
        })?;
        done.copied.push(target);
    }
    Ok(done)
}
