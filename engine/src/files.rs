//! The engine's files are readable by its own user only (DESIGN §10): the data folder and
//! the folders in it are created 0700, the database and stored inputs are 0600, whatever
//! the umask, and set again at every start (an older engine may have made them wider).

use std::io;
use std::path::Path;

/// Creates `dir` (and its parents) if missing, and makes it its owner's only.
pub fn private_dir(dir: &Path) -> io::Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::DirBuilderExt;
        std::fs::DirBuilder::new().recursive(true).mode(0o700).create(dir)?;
    }
    #[cfg(not(unix))]
    std::fs::create_dir_all(dir)?;
    owner_only(dir, true)
}

/// Makes a file (0600) or a folder (0700) readable and writable by its owner only.
pub fn owner_only(path: &Path, dir: bool) -> io::Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = if dir { 0o700 } else { 0o600 };
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))?;
    }
    #[cfg(not(unix))]
    let _ = (path, dir);
    Ok(())
}
