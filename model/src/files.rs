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

/// A directory being filled: files go into a hidden sibling staging
/// directory, and [`StagedDir::commit`] swaps it into place. Dropped without
/// commit (an error, an interrupt), the staging directory is removed and the
/// target is left as it was.
#[derive(Debug)]
pub struct StagedDir {
    target: PathBuf,
    staging: PathBuf,
    committed: bool,
}

impl StagedDir {
    /// Start staging `target` (its parent must exist and be writable).
    pub fn new(target: &Path) -> Result<Self, WriteError> {
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
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "out".into());
        let staging = parent.join(format!(".{name}.staging-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&staging);
        std::fs::create_dir_all(&staging).map_err(io(&staging))?;
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
    /// Replace the target directory with the staged one.
    pub fn commit(mut self) -> Result<PathBuf, WriteError> {
        if self.target.exists() {
            let old = self.staging.with_extension("old");
            let _ = std::fs::remove_dir_all(&old);
            std::fs::rename(&self.target, &old).map_err(io(&self.target))?;
            std::fs::rename(&self.staging, &self.target).map_err(io(&self.target))?;
            let _ = std::fs::remove_dir_all(&old);
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
}
