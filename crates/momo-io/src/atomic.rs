//! Atomic file replacement: write to a temporary file in the target's directory, flush and sync
//! it, then rename it over the target. On any error (or a drop without [`AtomicFile::commit`])
//! the temporary file is removed and the target is left as it was.

use crate::error::{IoError, IoErrorKind};
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use tempfile::NamedTempFile;

/// A file being written atomically (public for other writers of the workspace, e.g. the
/// odometry driver's diagnostics): [`create`](Self::create) opens a temporary file beside the
/// target, [`writer`](Self::writer) writes into it, [`commit`](Self::commit) flushes, syncs and
/// renames it over the target. Dropped without `commit`, the temporary file is removed and the
/// target is untouched.
///
/// ```
/// use std::io::Write;
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let dir = tempfile::tempdir()?;
/// let path = dir.path().join("out.txt");
/// let mut f = momo_io::AtomicFile::create(&path)?;
/// writeln!(f.writer(), "hello")?;
/// assert!(!path.exists());
/// f.commit()?;
/// assert_eq!(std::fs::read_to_string(&path)?, "hello\n");
/// # Ok(())
/// # }
/// ```
pub struct AtomicFile {
    path: PathBuf,
    writer: BufWriter<NamedTempFile>,
}

impl AtomicFile {
    /// Creates the temporary file next to `path`.
    pub fn create(path: &Path) -> Result<Self, IoError> {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        let name = path.file_name().ok_or_else(|| {
            IoError::file(
                path,
                IoErrorKind::InvalidData("the path does not name a file".into()),
            )
        })?;
        let mut prefix = std::ffi::OsString::from(".");
        prefix.push(name);
        prefix.push(".");
        let tmp = tempfile::Builder::new()
            .prefix(&prefix)
            .suffix(".tmp")
            .tempfile_in(dir)
            .map_err(|e| IoError::io(path, e))?;
        Ok(Self {
            path: path.to_owned(),
            writer: BufWriter::new(tmp),
        })
    }

    /// The target path (for error messages).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The buffered writer into the temporary file.
    pub fn writer(&mut self) -> &mut BufWriter<NamedTempFile> {
        &mut self.writer
    }

    /// Maps a write error to an [`IoError`] on the target path.
    pub fn err(&self, e: std::io::Error) -> IoError {
        IoError::file(&self.path, IoErrorKind::Io(e))
    }

    /// Flushes, syncs and renames the temporary file over the target.
    pub fn commit(self) -> Result<(), IoError> {
        let path = self.path;
        let tmp = self
            .writer
            .into_inner()
            .map_err(|e| IoError::file(&path, IoErrorKind::Io(e.into_error())))?;
        // Temporary files are created 0600; a finished output gets ordinary permissions.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            tmp.as_file()
                .set_permissions(std::fs::Permissions::from_mode(0o644))
                .map_err(|e| IoError::file(&path, IoErrorKind::Io(e)))?;
        }
        tmp.as_file()
            .sync_all()
            .map_err(|e| IoError::file(&path, IoErrorKind::Io(e)))?;
        tmp.persist(&path)
            .map_err(|e| IoError::file(&path, IoErrorKind::Io(e.error)))?;
        Ok(())
    }
}

/// Writes a whole file atomically with `body`.
pub(crate) fn write_atomic(
    path: &Path,
    body: impl FnOnce(&mut AtomicFile) -> Result<(), IoError>,
) -> Result<(), IoError> {
    let mut f = AtomicFile::create(path)?;
    body(&mut f)?;
    f.commit()
}

/// `write!` into an [`AtomicFile`], mapping the error.
macro_rules! put {
    ($file:expr, $($arg:tt)*) => {{
        let f: &mut $crate::atomic::AtomicFile = $file;
        match ::std::io::Write::write_fmt(f.writer(), ::std::format_args!($($arg)*)) {
            Ok(()) => Ok(()),
            Err(e) => Err(f.err(e)),
        }
    }};
}
pub(crate) use put;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_leaves_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("x.txt");
        std::fs::write(&target, "old").unwrap();
        let r = write_atomic(&target, |f| {
            put!(f, "new")?;
            Err(IoError::file(
                f.path(),
                IoErrorKind::InvalidData("boom".into()),
            ))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        write_atomic(&target, |f| put!(f, "new")).unwrap();
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
