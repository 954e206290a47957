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

/// Whether two paths name the same file: the same device and inode when
/// both exist, else the same absolute path (`a/../b` and `b` alike).
pub fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
        return x.dev() == y.dev() && x.ino() == y.ino();
    }
    let norm = |p: &Path| {
        let abs = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
        let mut out = PathBuf::new();
        for c in abs.components() {
            match c {
                std::path::Component::ParentDir => {
                    out.pop();
                }
                std::path::Component::CurDir => {}
                c => out.push(c),
            }
        }
        out
    };
    norm(a) == norm(b)
}

/// Bytes of memory available to a new allocation (`MemAvailable` of
/// `/proc/meminfo`), where the system says.
pub fn memory_available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

pub use fxshade_units::input::{read_text_limited, MAX_TEXT_INPUT};

/// Write `contents` to `path` through a temporary file in the same
/// directory, synced and renamed into place.
///
/// # Errors
///
/// [`WriteError::Io`] when the temporary file (`.NAME.tmp-PID` beside `path`) cannot be
/// created, written or synced, or cannot be renamed to `path`; the temporary file is then
/// removed.
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

/// The record of the files fxshade wrote into a directory it shares with
/// other files (`fxshade rtl --out DIR`): `DIR/.fxshade-files`, one
/// `sha256 <hex> <name>` line per file. A file is replaced only when it is
/// missing, already holds the new text, or still holds what fxshade wrote
/// (its hash is the recorded one); a file someone edited or wrote is never
/// replaced without `force`.
#[derive(Debug)]
pub struct FilesRecord {
    dir: PathBuf,
    hashes: std::collections::BTreeMap<String, String>,
}

/// The name of a [`FilesRecord`].
pub const FILES_RECORD: &str = ".fxshade-files";

fn sha256(bytes: &[u8]) -> String {
    crate::cache::sha256_bytes(bytes)
}

impl FilesRecord {
    /// The record of `dir` (empty when it has none).
    pub fn open(dir: &Path) -> FilesRecord {
        let mut hashes = std::collections::BTreeMap::new();
        if let Ok(text) = std::fs::read_to_string(dir.join(FILES_RECORD)) {
            for l in text.lines() {
                let mut w = l.splitn(3, ' ');
                if let (Some("sha256"), Some(h), Some(n)) = (w.next(), w.next(), w.next()) {
                    hashes.insert(n.to_string(), h.to_string());
                }
            }
        }
        FilesRecord {
            dir: dir.to_path_buf(),
            hashes,
        }
    }

    /// Why `name` may not be replaced by `new` (`None`: it may).
    pub fn blocks(&self, name: &str, new: &[u8]) -> Option<String> {
        let p = self.dir.join(name);
        let Ok(old) = std::fs::read(&p) else {
            return (p.exists() || p.is_symlink())
                .then(|| format!("{} exists and cannot be read", p.display()));
        };
        if old == new {
            return None;
        }
        match self.hashes.get(name) {
            Some(h) if *h == sha256(&old) => None,
            Some(_) => Some(format!(
                "{} was changed since fxshade wrote it",
                p.display()
            )),
            None => Some(format!("{} was not written by fxshade", p.display())),
        }
    }

    /// Write `name` atomically and record it.
    ///
    /// # Errors
    ///
    /// As [`write_atomic`] for `name` in the directory; `name` is then not recorded.
    pub fn write(&mut self, name: &str, contents: &[u8]) -> Result<(), WriteError> {
        write_atomic(&self.dir.join(name), contents)?;
        self.hashes.insert(name.to_string(), sha256(contents));
        Ok(())
    }

    /// Save the record (atomically).
    ///
    /// # Errors
    ///
    /// As [`write_atomic`] for [`FILES_RECORD`] in the directory.
    pub fn save(&self) -> Result<(), WriteError> {
        let mut text = format!(
            "# files {} wrote here; it replaces one only while it holds what was written\n",
            crate::vectors::GENERATOR
        );
        for (n, h) in &self.hashes {
            text += &format!("sha256 {h} {n}\n");
        }
        write_atomic(&self.dir.join(FILES_RECORD), text.as_bytes())
    }
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

/// The first line of a [`MARKER`] that lists the files fxshade wrote.
const MARKER_HEADER: &str = "fxshade output 2";

/// Files up to this size are recorded in a [`MARKER`] by content
/// (SHA-256), larger ones by modification time.
const HASHED_UP_TO: u64 = 64 << 20;

/// Every file under `dir` (relative paths, `/`-separated), the marker
/// excepted, with its size and its identity: `sha256:<hex>` of its content
/// up to [`HASHED_UP_TO`] bytes (so a checkout elsewhere still matches),
/// else `mtime:<ns>`.
fn listing(dir: &Path) -> std::io::Result<Vec<(String, u64, String)>> {
    fn walk(base: &Path, rel: &str, out: &mut Vec<(String, u64, String)>) -> std::io::Result<()> {
        let here = if rel.is_empty() {
            base.to_path_buf()
        } else {
            base.join(rel)
        };
        let mut names: Vec<_> = std::fs::read_dir(&here)?
            .map(|e| e.map(|e| e.file_name()))
            .collect::<Result<_, _>>()?;
        names.sort();
        for n in names {
            let n = n.to_string_lossy().into_owned();
            let r = if rel.is_empty() {
                n.clone()
            } else {
                format!("{rel}/{n}")
            };
            if r == MARKER {
                continue;
            }
            let m = std::fs::symlink_metadata(base.join(&r))?;
            if m.is_dir() {
                walk(base, &r, out)?;
            } else {
                let id = if m.len() <= HASHED_UP_TO && m.is_file() {
                    format!("sha256:{}", sha256(&std::fs::read(base.join(&r))?))
                } else {
                    let t = m
                        .modified()
                        .ok()
                        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
                        .map_or(0, |d| d.as_nanos());
                    format!("mtime:{t}")
                };
                out.push((r, m.len(), id));
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, "", &mut out)?;
    Ok(out)
}

/// Why fxshade may not replace `dir` (`None`: it may: empty, or holding
/// exactly the files fxshade wrote there, unchanged). A file fxshade did
/// not write, or one changed since (another size or modification time),
/// is named.
fn not_ours(dir: &Path) -> Option<String> {
    let files = match listing(dir) {
        Ok(f) => f,
        Err(e) => return Some(format!("cannot be listed ({e})")),
    };
    let marker = std::fs::read_to_string(dir.join(MARKER)).ok();
    let Some(marker) = marker else {
        if files.is_empty() {
            return None;
        }
        // A vector set written by an fxshade older than the marker.
        let manifest = std::fs::read_to_string(dir.join("manifest.json")).unwrap_or_default();
        if manifest.contains("\"generator\": \"fxshade") {
            return None;
        }
        return Some("is not empty and was not written by fxshade".into());
    };
    let mut lines = marker.lines();
    if lines.next() != Some(MARKER_HEADER) {
        // The marker of an older fxshade, which did not list its files.
        return None;
    }
    let mut written = std::collections::BTreeMap::new();
    for l in lines {
        let mut w = l.splitn(4, ' ');
        if let (Some("file"), Some(size), Some(id), Some(name)) =
            (w.next(), w.next(), w.next(), w.next())
        {
            if let Ok(size) = size.parse::<u64>() {
                written.insert(name.to_string(), (size, id.to_string()));
            }
        }
    }
    for (name, size, id) in files {
        match written.get(&name) {
            None => return Some(format!("holds {name}, which fxshade did not write")),
            Some((s, wid)) if *s != size || *wid != id => {
                return Some(format!("holds {name}, changed since fxshade wrote it"))
            }
            Some(_) => {}
        }
    }
    None
}

/// Whether `pid` is a live process.
fn alive(pid: u32) -> bool {
    Path::new("/proc").join(pid.to_string()).exists()
}

/// Remove the staging directories (`.NAME.staging-PID`, any NAME) in
/// `parent` of processes that are gone and that hold fxshade's marker: what
/// a killed run left.
fn remove_stale_staging(parent: &Path) {
    let Ok(rd) = std::fs::read_dir(parent) else {
        return;
    };
    for e in rd.flatten() {
        let file = e.file_name().to_string_lossy().into_owned();
        let Some(pid) = file
            .strip_prefix('.')
            .and_then(|f| f.rsplit_once(".staging-"))
            .and_then(|(_, p)| p.parse::<u32>().ok())
        else {
            continue;
        };
        if !alive(pid) && e.path().join(MARKER).is_file() {
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
    ///
    /// # Errors
    ///
    /// [`WriteError::Io`] when the parent of `target` is not a directory (`NotFound`), when
    /// `target` exists and is not a directory (`AlreadyExists`), when `target` is a directory
    /// fxshade may not replace or cannot list (`AlreadyExists`, saying why), or when the staging
    /// directory or its marker cannot be created.
    pub fn new(target: &Path) -> Result<Self, WriteError> {
        Self::open(target, false)
    }

    /// As [`StagedDir::new`], replacing whatever directory `target` is
    /// (`--force`).
    ///
    /// # Errors
    ///
    /// As [`StagedDir::new`], less the check of what an existing directory holds.
    pub fn new_forced(target: &Path) -> Result<Self, WriteError> {
        Self::open(target, true)
    }

    /// Whether [`StagedDir::new`] (`force`: [`StagedDir::new_forced`])
    /// would accept `target`, without creating anything: for commands
    /// that check their output before long work.
    ///
    /// # Errors
    ///
    /// As [`StagedDir::new`] (`force`: [`StagedDir::new_forced`]), less the errors of creating
    /// the staging directory and its marker.
    pub fn check(target: &Path, force: bool) -> Result<(), WriteError> {
        Self::checked_parent(target, force).map(|_| ())
    }

    /// The checks of [`StagedDir::open`]; the parent directory.
    fn checked_parent(target: &Path, force: bool) -> Result<&Path, WriteError> {
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
        if target.is_dir() && !force {
            if let Some(why) = not_ours(target) {
                return Err(WriteError::Io {
                    path: target.to_path_buf(),
                    reason: std::io::Error::new(
                        std::io::ErrorKind::AlreadyExists,
                        format!(
                            "{why}; nothing was changed (choose another directory, or pass \
                             --force to replace it as a whole)"
                        ),
                    ),
                });
            }
        }
        Ok(parent)
    }

    fn open(target: &Path, force: bool) -> Result<Self, WriteError> {
        let parent = Self::checked_parent(target, force)?;
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "out".into());
        remove_stale_staging(parent);
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
    ///
    /// # Errors
    ///
    /// [`WriteError::Io`] when the directory that is to hold `rel` cannot be created.
    pub fn path(&self, rel: &str) -> Result<PathBuf, WriteError> {
        let p = self.staging.join(rel);
        if let Some(d) = p.parent() {
            std::fs::create_dir_all(d).map_err(io(d))?;
        }
        Ok(p)
    }
    /// Write a file named `rel`.
    ///
    /// # Errors
    ///
    /// As [`StagedDir::path`]; [`WriteError::Io`] when the file cannot be written.
    pub fn write(&self, rel: &str, contents: &[u8]) -> Result<(), WriteError> {
        let p = self.path(rel)?;
        std::fs::write(&p, contents).map_err(io(&p))
    }
    /// Replace the target directory with the staged one: one atomic exchange
    /// where the file system supports it (then the old set, now in the
    /// staging path, is removed), else two renames.
    ///
    /// # Errors
    ///
    /// [`WriteError::Io`] when the staged files cannot be listed or read, the marker cannot be
    /// written ([`write_atomic`]), or the exchange or a rename into the target fails.
    pub fn commit(mut self) -> Result<PathBuf, WriteError> {
        // The marker lists every file written, so a file added or changed
        // later is never replaced without --force.
        let files = listing(&self.staging).map_err(io(&self.staging))?;
        let mut text = format!(
            "{MARKER_HEADER}\n# written by {}; fxshade replaces this directory as a whole while it \
             holds exactly these files, unchanged\n",
            crate::vectors::GENERATOR
        );
        for (name, size, id) in files {
            text += &format!("file {size} {id} {name}\n");
        }
        write_atomic(&self.staging.join(MARKER), text.as_bytes())?;
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
