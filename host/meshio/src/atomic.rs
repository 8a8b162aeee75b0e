//! Atomic file replacement: write a temporary file next to the target, rename it into place.

use std::io::{self, BufWriter, Write};
use std::path::Path;

use super::error::SaveError;

/// Runs `write` into a temporary file in `path`'s directory and renames it to `path` only
/// after everything was written and synced. On any error the temporary file is deleted
/// (when `NamedTempFile` drops), so `path` is either untouched or complete. The file's
/// mode is what the umask leaves of 0666, as for any new file a user saves.
pub fn write_file(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), SaveError> {
    write_with_mode(path, 0o666, write)
}

/// [`write_file`] for a server's own data (blobs, plugins, records): readable and writable
/// by its owner only (0600), whatever the umask.
pub fn write_private_file(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), SaveError> {
    write_with_mode(path, 0o600, write)
}

fn write_with_mode(
    path: &Path,
    #[cfg_attr(not(unix), allow(unused_variables))] mode: u32,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), SaveError> {
    let name = path.display().to_string();
    let fail = |action: &'static str| {
        let name = name.clone();
        move |cause: io::Error| SaveError::Io { name, action, cause }
    };
    // Same directory, so the final rename never crosses file systems.
    let dir = match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(".meshflow-").suffix(".tmp");
    // tempfile creates 0600 files; ask for `mode`, of which the umask takes its part.
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(mode));
    let mut tmp = builder
        .tempfile_in(dir)
        .map_err(fail("cannot create a temporary file in the target directory"))?;

    let mut out = BufWriter::with_capacity(1 << 20, tmp.as_file_mut());
    write(&mut out).and_then(|()| out.flush()).map_err(fail("write failed"))?;
    drop(out);
    // Without the sync a crash soon after the rename could leave an empty or torn file.
    tmp.as_file().sync_all().map_err(fail("sync failed"))?;
    tmp.persist(path)
        .map_err(|e| e.error)
        .map_err(fail("cannot move the finished file into place"))?;
    Ok(())
}
