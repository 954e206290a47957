//! Writing outputs atomically: a file appears whole or not at all, and a
//! directory of outputs is replaced in one rename.

use std::io::Write;
use std::path::{Path, PathBuf};

/// Why an output could not be written.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// An I/O error, with the path it concerns.
    #[error("{path}: {reason}")]
    Io {
        /// The path.
        path: PathBuf,
        /// The OS error (not chained as a source: the message says it once).
        reason: std::io::Error,
    },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> WriteError + '_ {
    move |reason| WriteError::Io {
        path: path.to_path_buf(),
        reason,
    }
}

/// Bytes of memory available to a new allocation (`MemAvailable` of
/// `/proc/meminfo`), where the system says.
pub fn memory_available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The most bytes fxshade reads from a text input it parses whole (a
/// configuration, a sweep file, a JSON result to merge): 64 MiB.
pub const MAX_TEXT_INPUT: u64 = 64 << 20;

/// Read a text file of at most [`MAX_TEXT_INPUT`] bytes: a larger file, or
/// an endless one (`/dev/zero`), is refused after reading one byte more
/// than the limit, a directory or a device with a clear reason.
pub fn read_text_limited(path: &Path) -> Result<String, String> {
    use std::io::Read;
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if meta.is_dir() {
        return Err("is a directory".into());
    }
    let f = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut buf = Vec::new();
    f.take(MAX_TEXT_INPUT + 1)
        .read_to_end(&mut buf)
        .map_err(|e| e.to_string())?;
    if buf.len() as u64 > MAX_TEXT_INPUT {
        return Err(format!(
            "larger than {} MiB: not a file fxshade reads",
            MAX_TEXT_INPUT >> 20
        ));
    }
    String::from_utf8(buf).map_err(|e| {
        format!(
            "not UTF-8 text (byte {} is not valid)",
            e.utf8_error().valid_up_to()
        )
    })
}

/// Write `contents` to `path` through a temporary file in the same
/// directory, synced and renamed into place.
pub fn write_atomic(path: &Path, contents: &[u8]) -> Result<(), WriteError> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp).map_err(io(&tmp))?;
        f.write_all(contents).map_err(io(&tmp))?;
        f.sync_all().map_err(io(&tmp))?;
        std::fs::rename(&tmp, path).map_err(io(path))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// The marker file every output directory fxshade writes holds: a
/// directory with it is fxshade's to replace; a non-empty one without it is
/// the user's, and is never replaced unless forced.
pub const MARKER: &str = ".fxshade-output";

/// A directory being filled: files go into a hidden sibling staging
/// directory, and [`StagedDir::commit`] swaps it into place. Dropped without
/// commit (an error, an interrupt), the staging directory is removed and the
/// target is left as it was.
///
/// The target must be missing, empty, or a directory fxshade wrote (it holds
/// [`MARKER`], or a vector manifest written by an older fxshade); anything
/// else is refused unless [`StagedDir::new_forced`] is used. The commit is
/// one atomic exchange of the two directories (Linux `renameat2` with
/// `RENAME_EXCHANGE`), so at every instant the target holds either the old
/// set or the new one, and concurrent runs to one target never share a
/// temporary name. Staging directories left by killed runs (their process
/// gone) are removed when the next run starts.
#[derive(Debug)]
pub struct StagedDir {
    target: PathBuf,
    staging: PathBuf,
    committed: bool,
}

/// Whether fxshade wrote `dir` (or it is empty).
fn ours_or_empty(dir: &Path) -> bool {
    if dir.join(MARKER).is_file() {
        return true;
    }
    let manifest = std::fs::read_to_string(dir.join("manifest.json")).unwrap_or_default();
    if manifest.contains("\"generator\": \"fxshade") {
        return true;
    }
    std::fs::read_dir(dir).is_ok_and(|mut d| d.next().is_none())
}

/// Remove `.NAME.staging-PID` siblings whose process is gone and which hold
/// fxshade's marker.
fn remove_stale_staging(parent: &Path, name: &str) {
    let prefix = format!(".{name}.staging-");
    let Ok(rd) = std::fs::read_dir(parent) else {
        return;
    };
    for e in rd.flatten() {
        let file = e.file_name().to_string_lossy().into_owned();
        let Some(pid) = file
            .strip_prefix(&prefix)
            .and_then(|p| p.parse::<u32>().ok())
        else {
            continue;
        };
        let alive = Path::new("/proc").join(pid.to_string()).exists();
        if !alive && e.path().join(MARKER).is_file() {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// Exchange two paths atomically; `false` when the file system cannot.
fn exchange(a: &Path, b: &Path) -> std::io::Result<bool> {
    #[cfg(target_os = "linux")]
    {
        use std::ffi::CString;
        use std::os::unix::ffi::OsStrExt;
        let ca = CString::new(a.as_os_str().as_bytes())?;
        let cb = CString::new(b.as_os_str().as_bytes())?;
        // SAFETY: two valid NUL-terminated paths; renameat2 only reads them.
        let r = unsafe {
            libc::renameat2(
                libc::AT_FDCWD,
                ca.as_ptr(),
                libc::AT_FDCWD,
                cb.as_ptr(),
                libc::RENAME_EXCHANGE,
            )
        };
        if r == 0 {
            return Ok(true);
        }
        let e = std::io::Error::last_os_error();
        match e.raw_os_error() {
            Some(libc::EINVAL) | Some(libc::ENOSYS) => Ok(false),
            _ => Err(e),
        }
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = (a, b);
        Ok(false)
    }
}

impl StagedDir {
    /// Start staging `target` (its parent must exist and be writable);
    /// refuses a non-empty directory fxshade did not write.
    pub fn new(target: &Path) -> Result<Self, WriteError> {
        Self::open(target, false)
    }

    /// As [`StagedDir::new`], replacing whatever directory `target` is
    /// (`--force`).
    pub fn new_forced(target: &Path) -> Result<Self, WriteError> {
        Self::open(target, true)
    }

    fn open(target: &Path, force: bool) -> Result<Self, WriteError> {
        let parent = target
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        if !parent.is_dir() {
            return Err(WriteError::Io {
                path: parent.to_path_buf(),
                reason: std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    "the parent directory does not exist",
                ),
            });
        }
        if target.exists() && !target.is_dir() {
            return Err(WriteError::Io {
                path: target.to_path_buf(),
                reason: std::io::Error::new(
                    std::io::ErrorKind::AlreadyExists,
                    "exists and is not a directory",
                ),
            });
        }
        if target.is_dir() && !force && !ours_or_empty(target) {
            return Err(WriteError::Io {
                path: target.to_path_buf(),
                reason: std::io::Error::new(
                    std::io::ErrorKind::AlreadyExists,
                    "is not empty and was not written by fxshade; nothing was changed \
                     (choose another directory, or pass --force to replace it)",
                ),
            });
        }
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "out".into());
        remove_stale_staging(parent, &name);
        let staging = parent.join(format!(".{name}.staging-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&staging);
        std::fs::create_dir_all(&staging).map_err(io(&staging))?;
        let marker = staging.join(MARKER);
        std::fs::write(
            &marker,
            format!(
                "written by {}; fxshade replaces this directory as a whole\n",
                crate::vectors::GENERATOR
            ),
        )
        .map_err(io(&marker))?;
        Ok(StagedDir {
            target: target.to_path_buf(),
            staging,
            committed: false,
        })
    }
    /// Where to write a file named `rel` (subdirectories are created).
    pub fn path(&self, rel: &str) -> Result<PathBuf, WriteError> {
        let p = self.staging.join(rel);
        if let Some(d) = p.parent() {
            std::fs::create_dir_all(d).map_err(io(d))?;
        }
        Ok(p)
    }
    /// Write a file named `rel`.
    pub fn write(&self, rel: &str, contents: &[u8]) -> Result<(), WriteError> {
        let p = self.path(rel)?;
        std::fs::write(&p, contents).map_err(io(&p))
    }
    /// Replace the target directory with the staged one: one atomic exchange
    /// where the file system supports it (then the old set, now in the
    /// staging path, is removed), else two renames.
    pub fn commit(mut self) -> Result<PathBuf, WriteError> {
        if self.target.exists() {
            if exchange(&self.staging, &self.target).map_err(io(&self.target))? {
                // The staging path now holds the previous set.
                let _ = std::fs::remove_dir_all(&self.staging);
            } else {
                let old = self.staging.with_extension("old");
                let _ = std::fs::remove_dir_all(&old);
                std::fs::rename(&self.target, &old).map_err(io(&self.target))?;
                std::fs::rename(&self.staging, &self.target).map_err(io(&self.target))?;
                let _ = std::fs::remove_dir_all(&old);
            }
        } else {
            std::fs::rename(&self.staging, &self.target).map_err(io(&self.target))?;
        }
        self.committed = true;
        Ok(self.target.clone())
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn staged_dir_replaces_whole_or_not_at_all() {
        let base = std::env::temp_dir().join(format!("fxshade-files-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        std::fs::create_dir_all(&base).unwrap();
        let target = base.join("out");
        let s = StagedDir::new(&target).unwrap();
        s.write("a/b.txt", b"one").unwrap();
        s.commit().unwrap();
        assert_eq!(std::fs::read(target.join("a/b.txt")).unwrap(), b"one");
        {
            let s = StagedDir::new(&target).unwrap();
            s.write("c.txt", b"two").unwrap();
            // dropped: an error happened
        }
        assert!(!target.join("c.txt").exists());
        assert!(target.join("a/b.txt").exists());
        assert_eq!(
            std::fs::read_dir(&base).unwrap().count(),
            1,
            "no staging left behind"
        );
        write_atomic(&base.join("f"), b"x").unwrap();
        assert_eq!(std::fs::read(base.join("f")).unwrap(), b"x");
        std::fs::remove_dir_all(&base).unwrap();
    }

    #[test]
    fn a_directory_fxshade_did_not_write_is_never_replaced_unless_forced() {
        let base = std::env::temp_dir().join(format!("fxshade-user-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        let mine = base.join("mytb");
        std::fs::create_dir_all(&mine).unwrap();
        std::fs::write(mine.join("tb.sv"), b"my testbench").unwrap();
        let e = StagedDir::new(&mine).unwrap_err().to_string();
        assert!(
            e.contains("not written by fxshade") && e.contains("--force"),
            "{e}"
        );
        assert_eq!(std::fs::read(mine.join("tb.sv")).unwrap(), b"my testbench");
        // Forced: replaced as a whole, marked as fxshade's from then on.
        let s = StagedDir::new_forced(&mine).unwrap();
        s.write("x", b"1").unwrap();
        s.commit().unwrap();
        assert!(!mine.join("tb.sv").exists() && mine.join(MARKER).is_file());
        let s = StagedDir::new(&mine).unwrap();
        s.write("y", b"2").unwrap();
        s.commit().unwrap();
        assert!(mine.join("y").is_file() && !mine.join("x").exists());
        // A staging directory of a killed run (no such process) is removed,
        // one of a live process (this one) or without the marker is kept.
        let dead = base.join(".mytb.staging-999999999");
        std::fs::create_dir_all(&dead).unwrap();
        std::fs::write(dead.join(MARKER), b"").unwrap();
        let foreign = base.join(".mytb.staging-999999998");
        std::fs::create_dir_all(&foreign).unwrap();
        drop(StagedDir::new(&mine).unwrap());
        assert!(!dead.exists(), "stale staging removed");
        assert!(
            foreign.exists(),
            "a directory without the marker is not ours"
        );
        std::fs::remove_dir_all(&base).unwrap();
    }
}
