//! Saving is atomic: a failed save leaves no file (and no temporary file), a successful one
//! replaces the target whole.

use std::io::Write;
use std::path::Path;

use meshflow_mesh::MeshData;
use meshflow_meshio::{self as io, Format, SaveError};

fn triangle() -> MeshData {
    MeshData::new(vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], vec![0, 1, 2])
}

fn entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn saving_into_a_missing_directory_fails_and_creates_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("missing").join("mesh.ply");
    let err = io::save(&path, &triangle()).unwrap_err();
    assert!(matches!(err, SaveError::Io { .. }), "{err}");
    assert!(err.to_string().starts_with(&path.display().to_string()), "{err}");
    assert!(!path.exists());
    assert!(entries(dir.path()).is_empty());
}

#[test]
fn an_unknown_extension_fails_before_touching_the_directory() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["mesh.xyz", "mesh", "mesh.ply.tmp"] {
        let err = io::save(&dir.path().join(name), &triangle()).unwrap_err();
        assert!(matches!(err, SaveError::UnknownFormat { .. }), "{err}");
        assert!(err.to_string().contains("unknown mesh format"), "{err}");
    }
    assert!(entries(dir.path()).is_empty());
}

#[test]
fn an_invalid_mesh_is_refused_and_an_existing_file_survives() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mesh.obj");
    std::fs::write(&path, "previous content").unwrap();
    let bad_meshes = [
        MeshData::new(vec![0.0, 0.0, 0.0], vec![0, 0, 1]),
        MeshData::new(vec![0.0, f32::NAN, 0.0], vec![]),
        MeshData::new(vec![0.0, 0.0], vec![]),
        MeshData::new(vec![0.0, 0.0, 0.0], vec![0, 0]),
    ];
    for mesh in bad_meshes {
        let err = io::save(&path, &mesh).unwrap_err();
        assert!(matches!(err, SaveError::InvalidMesh { .. }), "{err}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "previous content");
        assert!(io::write_to(Vec::new(), &mesh, Format::Ply).is_err());
    }
    let err = io::save(&path, &MeshData::new(vec![0.0; 3], vec![0, 0, 1])).unwrap_err();
    assert!(
        err.to_string().contains("triangle 0 uses vertex 1, but there are only 1 vertices"),
        "{err}"
    );
    assert_eq!(entries(dir.path()), ["mesh.obj"]);
}

#[test]
fn a_failed_rename_removes_the_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    // The target is a non-empty directory, so the final rename fails after all data was written.
    let path = dir.path().join("taken.ply");
    std::fs::create_dir(&path).unwrap();
    std::fs::write(path.join("inside"), "x").unwrap();
    let err = io::save(&path, &triangle()).unwrap_err();
    assert!(matches!(err, SaveError::Io { .. }), "{err}");
    assert_eq!(entries(dir.path()), ["taken.ply"]);
    assert_eq!(entries(&path), ["inside"]);
}

#[test]
fn saving_replaces_an_existing_file_and_leaves_no_temporary_files() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mesh.off");
    std::fs::write(&path, "old").unwrap();
    io::save(&path, &triangle()).unwrap();
    assert_eq!(io::load(&path).unwrap(), triangle());
    assert_eq!(entries(dir.path()), ["mesh.off"]);
}

#[cfg(unix)]
#[test]
fn saved_files_get_the_usual_permissions_not_the_temporary_files_0600() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let saved = dir.path().join("mesh.ply");
    io::save(&saved, &triangle()).unwrap();
    let plain = dir.path().join("plain");
    std::fs::File::create(&plain).unwrap();
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode(&saved), mode(&plain));
}

#[test]
fn a_relative_path_without_a_directory_saves_in_the_current_directory() {
    // Runs in a fresh directory so the test does not litter the crate.
    let dir = tempfile::tempdir().unwrap();
    let previous = std::env::current_dir().unwrap();
    std::env::set_current_dir(dir.path()).unwrap();
    let result = io::save(Path::new("here.obj"), &triangle());
    std::env::set_current_dir(previous).unwrap();
    result.unwrap();
    assert_eq!(entries(dir.path()), ["here.obj"]);
}

/// A writer that fails after some bytes, like a full disk.
struct FailingWriter(usize);

impl Write for FailingWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.0 < buf.len() {
            return Err(std::io::Error::other("disk full"));
        }
        self.0 -= buf.len();
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn write_errors_are_reported() {
    for format in Format::ALL {
        let err = io::write_to(FailingWriter(10), &triangle(), format).unwrap_err();
        assert!(matches!(err, SaveError::Io { .. }), "{err}");
        assert!(err.to_string().contains("disk full"), "{err}");
    }
}
