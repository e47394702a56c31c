//! Safe outputs.
//!
//! - [`AtomicFile`]: write to a temporary file in the target's directory, flush and sync it,
//!   then rename it over the target. On any error (or a drop without [`AtomicFile::commit`]) the
//!   temporary file is removed and the target is left as it was. On Linux the temporary file
//!   is anonymous (`O_TMPFILE`) until the commit links it into the directory, so that even a
//!   process killed by SIGKILL (or aborted by an allocation failure) while writing leaves
//!   nothing; elsewhere, or where the file system does not support it, it is a named
//!   `.NAME.XXXXXX.tmp`. [`commit_all`] commits several
//!   outputs of one command together: all of them or none.
//! - [`check_outputs`]: refuses outputs that are also inputs (compared by device and inode, so
//!   links and other spellings are caught), an output given twice, outputs that exist but are
//!   not regular files (directories, FIFOs, devices), and outputs in a missing directory.
//! - [`OutputDir`]: an output directory that must be empty (unless forced) and is removed again
//!   if the command that created it fails.
//! - [`remove_temporaries`]: removes every temporary file (and every output directory created
//!   but not yet kept) of the process; the command line calls it on SIGINT / SIGTERM.

use crate::error::{IoError, IoErrorKind};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use tempfile::TempPath;

/// Longest part of the target's file name kept in a temporary name (bytes); the rest of the
/// temporary name is `.` + this + `.XXXXXX.tmp`, well within NAME_MAX (255) for any target.
const TEMP_NAME_KEEP: usize = 100;

/// What to remove on a signal: temporary files (`false`) and created directories (`true`).
static CLEANUP: Mutex<BTreeMap<u64, (PathBuf, bool)>> = Mutex::new(BTreeMap::new());
static NEXT_ID: AtomicU64 = AtomicU64::new(0);

/// Registers a path for [`remove_temporaries`]; dropping the guard unregisters it.
struct CleanupGuard(u64);

impl CleanupGuard {
    fn new(path: PathBuf, dir: bool) -> Self {
        let id = NEXT_ID.fetch_add(1, Ordering::Relaxed);
        if let Ok(mut m) = CLEANUP.lock() {
            m.insert(id, (path, dir));
        }
        Self(id)
    }
}

impl Drop for CleanupGuard {
    fn drop(&mut self) {
        if let Ok(mut m) = CLEANUP.lock() {
            m.remove(&self.0);
        }
    }
}

/// Removes every temporary file of an [`AtomicFile`] not yet committed and every directory an
/// [`OutputDir`] created and has not kept. For signal handlers: the process must exit right
/// after (the writers still hold their files). Returns how many paths were removed.
pub fn remove_temporaries() -> usize {
    let entries: Vec<(PathBuf, bool)> = match CLEANUP.lock() {
        Ok(mut m) => std::mem::take(&mut *m).into_values().collect(),
        Err(p) => std::mem::take(&mut *p.into_inner()).into_values().collect(),
    };
    let mut removed = 0;
    // Files first, then directories (a created directory holds the temporaries written in it).
    for (path, _) in entries.iter().filter(|(_, d)| !d) {
        removed += usize::from(std::fs::remove_file(path).is_ok());
    }
    for (path, _) in entries.iter().filter(|(_, d)| *d) {
        removed += usize::from(std::fs::remove_dir_all(path).is_ok());
    }
    removed
}

/// The directory of `path` (`.` for a bare file name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

fn refused(path: &Path, reason: String) -> IoError {
    IoError::file(path, IoErrorKind::OutputRefused(reason))
}

/// Refuses an existing target that is not a regular file (a directory, a FIFO, a device node):
/// renaming over it would replace it.
fn check_regular(path: &Path) -> Result<(), IoError> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => Err(refused(path, "is a directory".into())),
        Ok(m) if !m.is_file() => Err(refused(
            path,
            "exists and is not a regular file (a FIFO, a socket or a device); it is not replaced"
                .into(),
        )),
        _ => Ok(()),
    }
}

/// An identity of a file that different spellings and links share.
#[derive(Clone, Debug, PartialEq, Eq)]
enum FileKey {
    /// An existing file: device and inode (unix) or the canonical path.
    Existing(u64, u64, PathBuf),
    /// A file to be created: its directory's identity and its name.
    New(Box<FileKey>, std::ffi::OsString),
}

fn file_key(path: &Path) -> Option<FileKey> {
    let meta = std::fs::metadata(path).ok()?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let _ = &meta;
        Some(FileKey::Existing(meta.dev(), meta.ino(), PathBuf::new()))
    }
    #[cfg(not(unix))]
    {
        let _ = meta;
        Some(FileKey::Existing(0, 0, std::fs::canonicalize(path).ok()?))
    }
}

/// Checks a command's outputs before anything is read or written: every output must be a
/// regular file or not exist yet, its directory must exist, no output may be one of `inputs`
/// (compared by device and inode, so hard links, symbolic links and other spellings of the
/// same file are caught) and no output may be given twice. Inputs that do not exist are
/// ignored. Errors are [`IoErrorKind::OutputRefused`] on the output (an input error).
pub fn check_outputs(inputs: &[&Path], outputs: &[&Path]) -> Result<(), IoError> {
    let input_keys: Vec<(FileKey, &Path)> = inputs
        .iter()
        .filter_map(|p| file_key(p).map(|k| (k, *p)))
        .collect();
    let mut seen: Vec<(FileKey, &Path)> = Vec::new();
    for &out in outputs {
        check_regular(out)?;
        let key = match file_key(out) {
            Some(k) => k,
            None => {
                let dir = parent_dir(out);
                let name = out
                    .file_name()
                    .ok_or_else(|| refused(out, "does not name a file".into()))?;
                match std::fs::metadata(dir) {
                    Ok(m) if m.is_dir() => {}
                    Ok(_) => {
                        return Err(refused(
                            out,
                            format!("{} is not a directory", dir.display()),
                        ));
                    }
                    Err(_) => {
                        return Err(refused(
                            out,
                            format!("the directory {} does not exist", dir.display()),
                        ));
                    }
                }
                let dir_key = file_key(dir).ok_or_else(|| {
                    refused(
                        out,
                        format!("the directory {} cannot be read", dir.display()),
                    )
                })?;
                FileKey::New(Box::new(dir_key), name.to_owned())
            }
        };
        if let Some((_, input)) = input_keys.iter().find(|(k, _)| *k == key) {
            return Err(refused(
                out,
                format!(
                    "is also an input ({}); refusing to overwrite it",
                    input.display()
                ),
            ));
        }
        if let Some((_, other)) = seen.iter().find(|(k, _)| *k == key) {
            return Err(refused(
                out,
                format!("is given twice as an output (also as {})", other.display()),
            ));
        }
        seen.push((key, out));
    }
    Ok(())
}

/// A file being written atomically (public for other writers of the workspace, e.g. the
/// odometry driver's diagnostics): [`create`](Self::create) opens a temporary file beside the
/// target, [`writer`](Self::writer) writes into it, [`commit`](Self::commit) flushes, syncs and
/// renames it over the target. Dropped without `commit`, the temporary file is removed and the
/// target is untouched; on SIGINT / SIGTERM the command line removes it
/// ([`remove_temporaries`]). On Linux the temporary file has no name until the commit
/// (`O_TMPFILE`): a killed process leaves nothing behind (see the module).
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
    writer: BufWriter<File>,
    temp: Temp,
}

/// Where the temporary file of an [`AtomicFile`] lives.
enum Temp {
    /// An anonymous file (`O_TMPFILE`) in this directory, given a name only at the commit.
    #[cfg(target_os = "linux")]
    Anonymous(PathBuf),
    /// A named temporary file (removed on drop), registered for [`remove_temporaries`].
    Named(TempPath, CleanupGuard),
}

/// The prefix `.NAME.` of a temporary name, with NAME cut so that the whole stays within
/// NAME_MAX.
fn temp_prefix(name: &std::ffi::OsStr) -> String {
    let mut kept = String::new();
    for c in name.to_string_lossy().chars() {
        if kept.len() + c.len_utf8() > TEMP_NAME_KEEP {
            break;
        }
        kept.push(c);
    }
    format!(".{kept}.")
}

/// Opens an anonymous temporary file in `dir` (`O_TMPFILE`); `None` where the kernel or the
/// file system does not support it (the caller falls back to a named temporary file).
#[cfg(target_os = "linux")]
fn open_anonymous(dir: &Path) -> Option<File> {
    use std::os::unix::fs::OpenOptionsExt;
    std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .mode(0o600)
        .custom_flags(rustix::fs::OFlags::TMPFILE.bits() as i32)
        .open(dir)
        .ok()
}

/// Gives the anonymous file `file` a temporary name `.NAME.XXXXXX.tmp` in `dir`: a hard link
/// through `/proc/self/fd` (`linkat` with `AT_SYMLINK_FOLLOW`, which needs no privilege).
/// Without `/proc`, the content is copied into a named temporary file instead.
#[cfg(target_os = "linux")]
fn name_anonymous(file: &mut File, dir: &Path, prefix: &str) -> std::io::Result<TempPath> {
    use std::os::fd::AsRawFd;
    let proc_path = format!("/proc/self/fd/{}", file.as_raw_fd());
    let linked = tempfile::Builder::new()
        .prefix(prefix)
        .suffix(".tmp")
        .make_in(dir, |name| {
            rustix::fs::linkat(
                rustix::fs::CWD,
                proc_path.as_str(),
                rustix::fs::CWD,
                name,
                rustix::fs::AtFlags::SYMLINK_FOLLOW,
            )
            .map_err(std::io::Error::from)
        });
    match linked {
        Ok(named) => Ok(named.into_temp_path()),
        Err(_) => {
            use std::io::{Seek, SeekFrom};
            let mut copy = tempfile::Builder::new()
                .prefix(prefix)
                .suffix(".tmp")
                .tempfile_in(dir)?;
            file.seek(SeekFrom::Start(0))?;
            std::io::copy(file, copy.as_file_mut())?;
            copy.as_file()
                .set_permissions(file.metadata()?.permissions())?;
            copy.as_file().sync_all()?;
            Ok(copy.into_temp_path())
        }
    }
}

impl AtomicFile {
    /// Creates the temporary file next to `path`. Refuses a target that exists and is not a
    /// regular file (a directory, a FIFO, a device node: renaming over it would replace it).
    pub fn create(path: &Path) -> Result<Self, IoError> {
        check_regular(path)?;
        let dir = parent_dir(path);
        let name = path.file_name().ok_or_else(|| {
            IoError::file(
                path,
                IoErrorKind::InvalidData("the path does not name a file".into()),
            )
        })?;
        #[cfg(target_os = "linux")]
        if let Some(file) = open_anonymous(dir) {
            return Ok(Self {
                path: path.to_owned(),
                writer: BufWriter::new(file),
                temp: Temp::Anonymous(dir.to_owned()),
            });
        }
        // `.NAME.XXXXXX.tmp`, with NAME cut so that the whole stays within NAME_MAX.
        let tmp = tempfile::Builder::new()
            .prefix(&temp_prefix(name))
            .suffix(".tmp")
            .tempfile_in(dir)
            .map_err(|e| IoError::io(path, e))?;
        let (file, tmp_path) = tmp.into_parts();
        let guard = CleanupGuard::new(tmp_path.to_path_buf(), false);
        Ok(Self {
            path: path.to_owned(),
            writer: BufWriter::new(file),
            temp: Temp::Named(tmp_path, guard),
        })
    }

    /// Whether the temporary file is anonymous until the commit (`O_TMPFILE`, Linux): then a
    /// killed process leaves no file behind.
    pub fn is_anonymous(&self) -> bool {
        !matches!(self.temp, Temp::Named(..))
    }

    /// The target path (for error messages).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The buffered writer into the temporary file.
    pub fn writer(&mut self) -> &mut BufWriter<File> {
        &mut self.writer
    }

    /// Maps a write error to an [`IoError`] on the target path.
    pub fn err(&self, e: std::io::Error) -> IoError {
        IoError::file(&self.path, IoErrorKind::Io(e))
    }

    /// Flushes and syncs the temporary file, gives it ordinary permissions and (if anonymous)
    /// a temporary name: everything of a commit but the rename.
    fn prepare(self) -> Result<Prepared, IoError> {
        let path = self.path;
        let io = |e| IoError::file(&path, IoErrorKind::Io(e));
        #[cfg_attr(not(target_os = "linux"), allow(unused_mut))]
        let mut file = self
            .writer
            .into_inner()
            .map_err(|e| IoError::file(&path, IoErrorKind::Io(e.into_error())))?;
        // Temporary files are created 0600; a finished output gets ordinary permissions.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            file.set_permissions(std::fs::Permissions::from_mode(0o644))
                .map_err(io)?;
        }
        file.sync_all().map_err(io)?;
        let (tmp, guard) = match self.temp {
            Temp::Named(tmp, guard) => (tmp, guard),
            #[cfg(target_os = "linux")]
            Temp::Anonymous(dir) => {
                let name = path.file_name().unwrap_or_default();
                let tmp = name_anonymous(&mut file, &dir, &temp_prefix(name)).map_err(io)?;
                let guard = CleanupGuard::new(tmp.to_path_buf(), false);
                (tmp, guard)
            }
        };
        Ok(Prepared {
            path,
            tmp,
            _guard: guard,
        })
    }

    /// Flushes, syncs and renames the temporary file over the target.
    pub fn commit(self) -> Result<(), IoError> {
        commit_all(vec![self])
    }
}

/// A flushed and synced temporary file waiting for its rename.
struct Prepared {
    path: PathBuf,
    tmp: TempPath,
    _guard: CleanupGuard,
}

/// Commits several outputs of one command together: all are flushed and synced first (a full
/// disk fails here, before any target is touched), then renamed over their targets. Should a
/// rename fail, the outputs already renamed are taken back: a target that existed before gets
/// its old content back (it was kept as a hard link), a new one is removed. On error nothing
/// of this commit is left and every temporary file is removed.
pub fn commit_all(files: Vec<AtomicFile>) -> Result<(), IoError> {
    let mut prepared = Vec::with_capacity(files.len());
    for f in files {
        prepared.push(f.prepare()?);
    }
    if prepared.len() == 1 {
        let p = prepared.remove(0);
        let path = p.path;
        let _guard = p._guard;
        return p
            .tmp
            .persist(&path)
            .map_err(|e| IoError::file(&path, IoErrorKind::Io(e.error)));
    }
    let paths: Vec<PathBuf> = prepared.iter().map(|p| p.path.clone()).collect();
    // Keep every existing target under a temporary name until all renames succeeded.
    let mut backups: Vec<Option<(PathBuf, CleanupGuard)>> = Vec::with_capacity(prepared.len());
    for p in &prepared {
        let mut backup = None;
        if std::fs::symlink_metadata(&p.path).is_ok() {
            let b = p.tmp.with_extension("bak");
            if std::fs::hard_link(&p.path, &b).is_ok() {
                let g = CleanupGuard::new(b.clone(), false);
                backup = Some((b, g));
            }
        }
        backups.push(backup);
    }
    let mut renamed = 0;
    let mut failure = None;
    for p in prepared {
        let path = p.path;
        let _guard = p._guard;
        match p.tmp.persist(&path) {
            Ok(()) => renamed += 1,
            Err(e) => {
                failure = Some(IoError::file(&path, IoErrorKind::Io(e.error)));
                break;
            }
        }
    }
    if failure.is_some() {
        // Take back what was renamed: the old content where there was one, else nothing.
        for (path, backup) in paths.iter().zip(&backups).take(renamed) {
            match backup {
                Some((b, _)) => {
                    let _ = std::fs::rename(b, path);
                }
                None => {
                    let _ = std::fs::remove_file(path);
                }
            }
        }
    }
    for (b, _g) in backups.into_iter().flatten() {
        let _ = std::fs::remove_file(&b);
    }
    match failure {
        Some(err) => Err(err),
        None => Ok(()),
    }
}

/// An output directory (`momo simulate`, `momo match`, `momo import-kitti`):
/// [`prepare`](Self::prepare) refuses a path that is not a directory and a directory that is
/// not empty (unless forced), and creates it (with missing parents) if it does not exist;
/// dropped without [`keep`](Self::keep) (the command failed), or on SIGINT / SIGTERM, what it
/// created is removed again. A directory that existed before is never removed; dropped without
/// `keep`, the entries that appeared in it since [`prepare`](Self::prepare) are removed (files
/// that `--force` replaced stay replaced).
pub struct OutputDir {
    path: PathBuf,
    /// The topmost directory this created, with its cleanup registration.
    created: Option<(PathBuf, CleanupGuard)>,
    /// The entries of a directory that existed before (`None` once kept or if created).
    before: Option<Vec<std::ffi::OsString>>,
}

impl OutputDir {
    /// Prepares `path` as an output directory (see the type). `force` allows a non-empty one
    /// (files of the same names are then replaced, others are left).
    pub fn prepare(path: &Path, force: bool) -> Result<Self, IoError> {
        match std::fs::metadata(path) {
            Ok(m) if !m.is_dir() => Err(refused(
                path,
                "exists and is not a directory; the output directory must be a directory".into(),
            )),
            Ok(_) => {
                let entries: Vec<std::ffi::OsString> = std::fs::read_dir(path)
                    .map_err(|e| IoError::io(path, e))?
                    .filter_map(|e| e.ok().map(|e| e.file_name()))
                    .collect();
                if !force && !entries.is_empty() {
                    return Err(refused(
                        path,
                        "the output directory is not empty; give --force to write into it \
                         (files of the same names are replaced)"
                            .into(),
                    ));
                }
                Ok(Self {
                    path: path.to_owned(),
                    created: None,
                    before: Some(entries),
                })
            }
            Err(_) => {
                // The topmost ancestor that does not exist yet is what this creates.
                let mut top = path.to_path_buf();
                while let Some(parent) = top.parent() {
                    if parent.as_os_str().is_empty() || std::fs::symlink_metadata(parent).is_ok() {
                        break;
                    }
                    top = parent.to_path_buf();
                }
                std::fs::create_dir_all(path).map_err(|e| IoError::io(path, e))?;
                let guard = CleanupGuard::new(top.clone(), true);
                Ok(Self {
                    path: path.to_owned(),
                    created: Some((top, guard)),
                    before: None,
                })
            }
        }
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The command succeeded: keep the directory.
    pub fn keep(mut self) {
        self.created = None;
        self.before = None;
    }
}

impl Drop for OutputDir {
    fn drop(&mut self) {
        if let Some((top, _guard)) = self.created.take() {
            let _ = std::fs::remove_dir_all(&top);
        }
        if let Some(before) = self.before.take()
            && let Ok(entries) = std::fs::read_dir(&self.path)
        {
            for e in entries.flatten() {
                if !before.contains(&e.file_name()) {
                    let p = e.path();
                    let _ = if p.is_dir() {
                        std::fs::remove_dir_all(&p)
                    } else {
                        std::fs::remove_file(&p)
                    };
                }
            }
        }
    }
}

/// Writes a whole file atomically with `body`.
pub(crate) fn write_atomic(
    path: &Path,
    body: impl FnOnce(&mut AtomicFile) -> Result<(), IoError>,
) -> Result<(), IoError> {
    stage_atomic(path, body)?.commit()
}

/// Writes a whole temporary file with `body` and returns it uncommitted (for [`commit_all`]).
pub(crate) fn stage_atomic(
    path: &Path,
    body: impl FnOnce(&mut AtomicFile) -> Result<(), IoError>,
) -> Result<AtomicFile, IoError> {
    let mut f = AtomicFile::create(path)?;
    body(&mut f)?;
    Ok(f)
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
