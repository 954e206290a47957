//! The per-user cache: where fxshade keeps what it can recompute (simulator
//! builds, searched test-vector rows, synthesis and exploration results),
//! and the rules that keep a cache from forging a result.
//!
//! A cache entry is trusted only when nobody but the user could have
//! written it:
//!
//! * **The root is the user's own.** `$FXSHADE_CACHE_DIR` (made absolute),
//!   else `$XDG_CACHE_HOME/fxshade` (when absolute), else
//!   `$HOME/.cache/fxshade`, else the home directory of the user's entry in
//!   the password database, else `<temporary directory>/fxshade-cache-<uid>`.
//!   There is no shared fallback. Whichever it is, it is created with mode
//!   0700 when missing, and it must be a directory (not a symbolic link)
//!   owned by the user and writable by nobody else, or every command that
//!   would use it stops with [`CacheError::Unsafe`] naming it and the fix.
//! * **Every entry is checked before it is used** ([`check_private`]): a
//!   file or directory owned by someone else, or writable by others, is
//!   refused, not read.
//! * **Executables are verified.** A built simulator is recorded with the
//!   SHA-256 of its binary when it is complete ([`Seal`]); a cache hit
//!   recomputes the hash and rebuilds on any difference, so a truncated or
//!   replaced binary is never run.
//! * **Whole or nothing.** Entries are written in a staging path, synced,
//!   and renamed into place; the mark that an entry is complete is written
//!   last. A full file system is reported as such
//!   ([`CacheError::Full`]), never marked complete.
//!
//! **Installed by the program, never found by the library.** This crate
//! reads no environment variable: a program's edge (the `fxshade` CLI's
//! `env` module) reads `FXSHADE_CACHE_DIR`, `XDG_CACHE_HOME` and `HOME`
//! once into an [`Env`] and [`install`]s it. Until then there is no cache:
//! [`root`] is [`CacheError::NotInstalled`], and the library's own caches
//! (analyses, searched corner rows) compute instead of reading or writing
//! (a library caller, a unit test, the C ABI and the Python module touch
//! no disk unless they install one).

use std::io::{Read, Write};
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};

/// Why the cache cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    /// A directory or entry someone else could have written.
    #[error(
        "the cache {path} is not safe to use: {why}; fxshade trusts only a cache \
         that is the user's own (set FXSHADE_CACHE_DIR to a private directory, \
         or fix its owner and mode: chmod 700)"
    )]
    Unsafe {
        /// The path refused.
        path: PathBuf,
        /// Why.
        why: String,
    },
    /// The file system holding the cache is full.
    #[error(
        "{path}: the file system holding the cache is full (no space left on device); \
         nothing was marked complete: free space, or set FXSHADE_CACHE_DIR elsewhere"
    )]
    Full {
        /// The path that could not be written.
        path: PathBuf,
    },
    /// No program installed a cache ([`install`]): callers that can
    /// compute instead do; the CLI always installs one.
    #[error("no cache is installed (a program installs one with fxshade_model::cache::install)")]
    NotInstalled,
    /// Any other I/O error.
    #[error("{path}: {reason}")]
    Io {
        /// The path.
        path: PathBuf,
        /// The OS error.
        reason: std::io::Error,
    },
}

impl CacheError {
    /// An I/O error about `path`, told apart as [`CacheError::Full`] when
    /// the device is full.
    pub fn io(path: &Path, reason: std::io::Error) -> CacheError {
        if reason.raw_os_error() == Some(libc::ENOSPC)
            || reason.raw_os_error() == Some(libc::EDQUOT)
        {
            CacheError::Full {
                path: path.to_path_buf(),
            }
        } else {
            CacheError::Io {
                path: path.to_path_buf(),
                reason,
            }
        }
    }
}

/// What the cache root is resolved from: the process environment, read by
/// the program's edge (the CLI's `env` module) and [`install`]ed, or given
/// by a test.
#[derive(Clone, Debug, Default)]
pub struct Env {
    /// `$FXSHADE_CACHE_DIR`.
    pub fxshade_cache_dir: Option<PathBuf>,
    /// `$XDG_CACHE_HOME`.
    pub xdg_cache_home: Option<PathBuf>,
    /// `$HOME`.
    pub home: Option<PathBuf>,
    /// The home directory of the user's password-database entry.
    pub passwd_home: Option<PathBuf>,
    /// The system's temporary directory (`$TMPDIR` or `/tmp`).
    pub temp_dir: PathBuf,
    /// The effective user id.
    pub uid: u32,
}

/// The home directory of `uid` in the password database, if it has one
/// (for [`Env::passwd_home`]).
pub fn passwd_home(uid: u32) -> Option<PathBuf> {
    use std::ffi::CStr;
    use std::os::unix::ffi::OsStrExt;
    let mut buf = vec![0u8; 16 * 1024];
    // SAFETY: a zeroed passwd is a valid out-parameter; getpwuid_r writes
    // into `pwd` and `buf` (its length passed) and sets `result`.
    let mut pwd: libc::passwd = unsafe { std::mem::zeroed() };
    let mut result: *mut libc::passwd = std::ptr::null_mut();
    let rc = unsafe {
        libc::getpwuid_r(
            uid,
            &mut pwd,
            buf.as_mut_ptr().cast(),
            buf.len(),
            &mut result,
        )
    };
    if rc != 0 || result.is_null() || pwd.pw_dir.is_null() {
        return None;
    }
    // SAFETY: pw_dir points into `buf`, NUL-terminated by getpwuid_r.
    let dir = unsafe { CStr::from_ptr(pwd.pw_dir) };
    let p = PathBuf::from(std::ffi::OsStr::from_bytes(dir.to_bytes()));
    (p.is_absolute() && p.is_dir()).then_some(p)
}

/// The candidate cache root for `env`, before any check: see the module
/// documentation for the order.
pub fn candidate(env: &Env) -> PathBuf {
    if let Some(d) = &env.fxshade_cache_dir {
        return std::path::absolute(d).unwrap_or_else(|_| d.clone());
    }
    if let Some(x) = env.xdg_cache_home.as_ref().filter(|x| x.is_absolute()) {
        return x.join("fxshade");
    }
    if let Some(h) = env.home.as_ref().or(env.passwd_home.as_ref()) {
        return h.join(".cache").join("fxshade");
    }
    env.temp_dir.join(format!("fxshade-cache-{}", env.uid))
}

/// Resolve, create (mode 0700) and check the cache root for `env`.
///
/// # Errors
///
/// As [`ensure_private_dir`] for the [`candidate`] root.
pub fn resolve(env: &Env) -> Result<PathBuf, CacheError> {
    let root = candidate(env);
    ensure_private_dir(&root, env.uid)?;
    Ok(root)
}

static INSTALLED: std::sync::OnceLock<(Env, Result<PathBuf, String>)> = std::sync::OnceLock::new();

/// Install the process's cache: the root is [`resolve`]d from `env` once,
/// here, and every later [`root`] returns that outcome. The first call
/// wins; it returns `false` when a cache was installed before (and `env`
/// is ignored).
pub fn install(env: Env) -> bool {
    let mut first = false;
    INSTALLED.get_or_init(|| {
        first = true;
        let r = resolve(&env).map_err(|e| e.to_string());
        (env, r)
    });
    first
}

/// The cache root of this process: the installed [`Env`]'s, [`resolve`]d
/// once by [`install`].
///
/// # Errors
///
/// [`CacheError::NotInstalled`] before [`install`]; [`CacheError::Unsafe`] naming the
/// [`candidate`] root, with the message of the error of [`resolve`] as its reason, when
/// the installed root could not be used (every call fails alike).
pub fn root() -> Result<PathBuf, CacheError> {
    match INSTALLED.get() {
        None => Err(CacheError::NotInstalled),
        Some((_, Ok(p))) => Ok(p.clone()),
        Some((env, Err(e))) => Err(CacheError::Unsafe {
            path: candidate(env),
            why: e.clone(),
        }),
    }
}

/// The effective user id.
pub fn uid() -> u32 {
    // SAFETY: geteuid has no preconditions.
    unsafe { libc::geteuid() }
}

/// Refuse `path` unless it is owned by `uid` and writable by nobody else
/// (a symbolic link is judged by itself, not followed). A missing path is
/// an I/O error of kind `NotFound`.
///
/// # Errors
///
/// [`CacheError::Io`] when the metadata of `path` cannot be read (of kind `NotFound` when it
/// is missing); [`CacheError::Unsafe`] when `path` is a symbolic link, is owned by another
/// user than `uid`, or is writable by its group or by others.
pub fn check_private(path: &Path, uid: u32) -> Result<(), CacheError> {
    let m = std::fs::symlink_metadata(path).map_err(|e| CacheError::io(path, e))?;
    let unsafe_ = |why: String| CacheError::Unsafe {
        path: path.to_path_buf(),
        why,
    };
    if m.file_type().is_symlink() {
        return Err(unsafe_("it is a symbolic link".into()));
    }
    if m.uid() != uid {
        return Err(unsafe_(format!(
            "it is owned by uid {}, not by this user (uid {uid})",
            m.uid()
        )));
    }
    let mode = m.permissions().mode();
    if mode & 0o022 != 0 {
        return Err(unsafe_(format!(
            "others can write to it (mode {:03o})",
            mode & 0o777
        )));
    }
    Ok(())
}

/// Create `dir` (and missing parents) with mode 0700 where missing, then
/// [`check_private`] it.
///
/// # Errors
///
/// [`CacheError::Io`] ([`CacheError::Full`] when the device or the quota is full) when the
/// metadata of `dir` cannot be read, or `dir` or its missing parents cannot be created; the
/// errors of [`check_private`] for `dir`; [`CacheError::Unsafe`] when `dir` is not a
/// directory.
pub fn ensure_private_dir(dir: &Path, uid: u32) -> Result<(), CacheError> {
    match std::fs::symlink_metadata(dir) {
        Ok(_) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            use std::os::unix::fs::DirBuilderExt;
            if let Some(p) = dir.parent() {
                if !p.exists() {
                    std::fs::DirBuilder::new()
                        .recursive(true)
                        .mode(0o700)
                        .create(p)
                        .map_err(|e| CacheError::io(p, e))?;
                }
            }
            match std::fs::DirBuilder::new().mode(0o700).create(dir) {
                Ok(()) => {}
                // Another process made it meanwhile: checked below.
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
                Err(e) => return Err(CacheError::io(dir, e)),
            }
        }
        Err(e) => return Err(CacheError::io(dir, e)),
    }
    check_private(dir, uid)?;
    if !std::fs::metadata(dir).is_ok_and(|m| m.is_dir()) {
        return Err(CacheError::Unsafe {
            path: dir.to_path_buf(),
            why: "it is not a directory".into(),
        });
    }
    Ok(())
}

/// A subdirectory `rel` of the cache root, created private and checked
/// (`synth`, `explore`, `corners`, …).
///
/// # Errors
///
/// As [`root`], then as [`ensure_private_dir`] for the subdirectory.
pub fn subdir(rel: &str) -> Result<PathBuf, CacheError> {
    let d = root()?.join(rel);
    ensure_private_dir(&d, uid())?;
    Ok(d)
}

/// Read a cache file, refusing it unless it and its directory are
/// private to this user; `Ok(None)` when it does not exist.
///
/// # Errors
///
/// [`CacheError::Io`] when the metadata of `path` cannot be read (for another reason than
/// `NotFound`) or its contents cannot be read; the errors of [`check_private`] for its
/// parent directory and for `path` itself.
pub fn read(path: &Path) -> Result<Option<Vec<u8>>, CacheError> {
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(CacheError::io(path, e)),
        Ok(_) => {}
    }
    if let Some(dir) = path.parent() {
        check_private(dir, uid())?;
    }
    check_private(path, uid())?;
    std::fs::read(path)
        .map(Some)
        .map_err(|e| CacheError::io(path, e))
}

/// Write a cache file whole or not at all: a private temporary file in the
/// same directory, synced, renamed into place. A full device is
/// [`CacheError::Full`].
///
/// # Errors
///
/// [`CacheError::Io`] ([`CacheError::Full`] when the device or the quota is full) when the
/// temporary file (`.NAME.tmp-PID` beside `path`, which must not exist yet) cannot be
/// created, written, synced or renamed to `path`, or the directory cannot be synced
/// ([`sync_dir`]); the temporary file is then removed.
pub fn write(path: &Path, contents: &[u8]) -> Result<(), CacheError> {
    use std::os::unix::fs::OpenOptionsExt;
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let result = (|| {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(0o600)
            .open(&tmp)
            .map_err(|e| CacheError::io(&tmp, e))?;
        f.write_all(contents).map_err(|e| CacheError::io(&tmp, e))?;
        f.sync_all().map_err(|e| CacheError::io(&tmp, e))?;
        std::fs::rename(&tmp, path).map_err(|e| CacheError::io(path, e))?;
        sync_dir(dir)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// fsync a directory (its entries' renames reach the disk).
///
/// # Errors
///
/// [`CacheError::Io`] ([`CacheError::Full`] when the device or the quota is full) when
/// `dir` cannot be opened or synced.
pub fn sync_dir(dir: &Path) -> Result<(), CacheError> {
    std::fs::File::open(dir)
        .and_then(|d| d.sync_all())
        .map_err(|e| CacheError::io(dir, e))
}

/// The SHA-256 of a file, as 64 lowercase hex digits.
///
/// # Errors
///
/// [`CacheError::Io`] when `path` cannot be opened or read.
pub fn sha256_file(path: &Path) -> Result<String, CacheError> {
    use sha2::Digest;
    let mut f = std::fs::File::open(path).map_err(|e| CacheError::io(path, e))?;
    let mut h = sha2::Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = f.read(&mut buf).map_err(|e| CacheError::io(path, e))?;
        if n == 0 {
            break;
        }
        h.update(&buf[..n]);
    }
    Ok(hex(&h.finalize()))
}

/// SHA-256 of the running program's executable, computed once: a cache
/// entry whose result depends on the code that computed it carries it in
/// its key, so a rebuilt program never reads an older program's result.
/// `None` when the executable cannot be read (the caller then does not
/// cache).
pub fn program_fingerprint() -> Option<&'static str> {
    static FP: std::sync::OnceLock<Option<String>> = std::sync::OnceLock::new();
    FP.get_or_init(|| {
        let exe = std::env::current_exe().ok()?;
        sha256_file(&exe).ok()
    })
    .as_deref()
}

/// The SHA-256 of `bytes`, as 64 lowercase hex digits (what `sha256sum`
/// prints).
pub fn sha256_bytes(bytes: &[u8]) -> String {
    use sha2::Digest;
    hex(&sha2::Sha256::digest(bytes))
}

/// The SHA-256 of `parts` (each length-prefixed, so the split is part of
/// the hash), as 64 lowercase hex digits: the key of a cache entry.
pub fn sha256_key(parts: &[&[u8]]) -> String {
    use sha2::Digest;
    let mut h = sha2::Sha256::new();
    for p in parts {
        h.update((p.len() as u64).to_le_bytes());
        h.update(p);
    }
    hex(&h.finalize())
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// The mark that a directory entry is complete: the SHA-256 of each of its
/// files that will be executed or loaded, written last (`done`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Seal {
    /// `(path relative to the entry, SHA-256)`.
    pub files: Vec<(String, String)>,
}

/// The first line of a [`Seal`] file.
const SEAL_HEADER: &str = "fxshade cache entry 2";

impl Seal {
    /// The name of the seal file inside an entry.
    pub const FILE: &'static str = "done";

    /// Hash `files` (relative to `entry`), sync them and the entry, and
    /// write the seal last. Any failure (a full device among them) leaves
    /// the entry unsealed.
    ///
    /// # Errors
    ///
    /// [`CacheError::Io`] ([`CacheError::Full`] when the device or the quota is full) when a
    /// file of `files` cannot be opened, synced or read; the errors of
    /// [`cache::write`](fn@write) for the seal file.
    pub fn write(entry: &Path, files: &[&str]) -> Result<Seal, CacheError> {
        let mut seal = Seal { files: Vec::new() };
        for rel in files {
            let p = entry.join(rel);
            std::fs::File::open(&p)
                .and_then(|f| f.sync_all())
                .map_err(|e| CacheError::io(&p, e))?;
            seal.files.push((rel.to_string(), sha256_file(&p)?));
        }
        let mut text = format!("{SEAL_HEADER}\n");
        for (rel, h) in &seal.files {
            text += &format!("sha256 {h} {rel}\n");
        }
        text += "end\n";
        write(&entry.join(Self::FILE), text.as_bytes())?;
        Ok(seal)
    }

    /// Whether `entry` is a complete, private entry whose recorded files
    /// still hash to what was recorded. `Ok(false)`: not sealed, or
    /// something differs (rebuild it); an error: someone else could have
    /// written it (refuse).
    ///
    /// # Errors
    ///
    /// The errors of [`check_private`] for `entry` and for each recorded path that is a file,
    /// and of [`read`] for the seal file; [`CacheError::Io`] when a recorded file cannot be
    /// read to hash it.
    pub fn verify(entry: &Path) -> Result<bool, CacheError> {
        let seal_path = entry.join(Self::FILE);
        if !seal_path.exists() {
            return Ok(false);
        }
        check_private(entry, uid())?;
        let Some(bytes) = read(&seal_path)? else {
            return Ok(false);
        };
        let text = String::from_utf8_lossy(&bytes);
        let mut lines = text.lines();
        if lines.next() != Some(SEAL_HEADER) {
            return Ok(false);
        }
        let mut ended = false;
        let mut any = false;
        for l in lines {
            if l == "end" {
                ended = true;
                break;
            }
            let mut w = l.splitn(3, ' ');
            let (Some("sha256"), Some(h), Some(rel)) = (w.next(), w.next(), w.next()) else {
                return Ok(false);
            };
            let p = entry.join(rel);
            if !p.is_file() {
                return Ok(false);
            }
            check_private(&p, uid())?;
            if sha256_file(&p)? != h {
                return Ok(false);
            }
            any = true;
        }
        Ok(ended && any)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The library finds no cache by itself: nothing in this crate's tests
    /// installs one, so the root is `NotInstalled` whatever `HOME` and
    /// `FXSHADE_CACHE_DIR` say, and a subdirectory is not created.
    #[test]
    fn without_an_installed_cache_there_is_none() {
        assert!(matches!(root(), Err(CacheError::NotInstalled)));
        assert!(matches!(subdir("corners"), Err(CacheError::NotInstalled)));
    }

    fn env(tmp: &Path) -> Env {
        Env {
            temp_dir: tmp.to_path_buf(),
            uid: uid(),
            ..Env::default()
        }
    }

    #[test]
    fn the_root_follows_the_variables_and_never_a_shared_place() {
        let t = tempfile_dir("order");
        let mut e = env(&t);
        // Nothing set: a per-user directory, never `fxshade-cache` alone.
        assert_eq!(candidate(&e), t.join(format!("fxshade-cache-{}", uid())));
        e.passwd_home = Some(t.join("pw"));
        assert_eq!(candidate(&e), t.join("pw/.cache/fxshade"));
        e.home = Some(t.join("home"));
        assert_eq!(candidate(&e), t.join("home/.cache/fxshade"));
        e.xdg_cache_home = Some(PathBuf::from("relative"));
        assert_eq!(
            candidate(&e),
            t.join("home/.cache/fxshade"),
            "XDG needs an absolute path"
        );
        e.xdg_cache_home = Some(t.join("xdg"));
        assert_eq!(candidate(&e), t.join("xdg/fxshade"));
        e.fxshade_cache_dir = Some(t.join("mine"));
        assert_eq!(candidate(&e), t.join("mine"));
        std::fs::remove_dir_all(&t).unwrap();
    }

    fn tempfile_dir(tag: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("fxshade-cache-test-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_root_others_can_write_is_refused_and_a_new_one_is_private() {
        let t = tempfile_dir("mode");
        let e = env(&t);
        let root = resolve(&e).unwrap();
        let mode = std::fs::metadata(&root).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o700, "created private");
        std::fs::set_permissions(&root, std::fs::Permissions::from_mode(0o777)).unwrap();
        let err = resolve(&e).unwrap_err().to_string();
        assert!(
            err.contains("others can write") && err.contains("777"),
            "{err}"
        );
        std::fs::set_permissions(&root, std::fs::Permissions::from_mode(0o755)).unwrap();
        resolve(&e).unwrap();
        // A symbolic link is not followed into someone else's directory.
        std::fs::remove_dir_all(&root).unwrap();
        std::os::unix::fs::symlink(&t, &root).unwrap();
        let err = resolve(&e).unwrap_err().to_string();
        assert!(err.contains("symbolic link"), "{err}");
        // Another user's directory (when this test can make one).
        if uid() == 0 {
            std::fs::remove_file(&root).unwrap();
            std::fs::create_dir(&root).unwrap();
            std::os::unix::fs::chown(&root, Some(65534), Some(65534)).unwrap();
            let err = resolve(&e).unwrap_err().to_string();
            assert!(err.contains("owned by uid 65534"), "{err}");
        }
        std::fs::remove_dir_all(&t).unwrap();
    }

    #[test]
    fn a_seal_detects_a_changed_or_truncated_file() {
        let t = tempfile_dir("seal");
        let entry = t.join("e");
        std::fs::create_dir(&entry).unwrap();
        std::fs::write(entry.join("sim"), b"#!/bin/sh\necho 200 passed, 0 failed\n").unwrap();
        assert!(!Seal::verify(&entry).unwrap(), "not sealed yet");
        Seal::write(&entry, &["sim"]).unwrap();
        assert!(Seal::verify(&entry).unwrap());
        std::fs::write(entry.join("sim"), b"#!/bin/sh\necho 200 passed, 0 failed").unwrap();
        assert!(!Seal::verify(&entry).unwrap(), "one byte less");
        Seal::write(&entry, &["sim"]).unwrap();
        // A seal cut short (no `end`) is not a seal.
        let s = std::fs::read_to_string(entry.join("done")).unwrap();
        std::fs::write(entry.join("done"), s.trim_end_matches("end\n")).unwrap();
        assert!(!Seal::verify(&entry).unwrap());
        std::fs::remove_dir_all(&t).unwrap();
    }
}
