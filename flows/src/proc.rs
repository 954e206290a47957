//! Every external process fxshade runs — version probes, simulator builds,
//! simulations, Yosys, nextpnr, yosys-smtbmc, z3 — runs here: in a process
//! group of its own, under a time limit, and with a guard that kills the
//! whole group if fxshade itself dies (even by SIGKILL), so no tool is
//! left behind and no hung tool (a licence server, a stale NFS mount) hangs
//! fxshade.
//!
//! A limit only turns a hang into an error that names the tool and the
//! variable that raises the limit; it never changes a result. The limits
//! are read from the environment here, in one place ([`Limit`]).

use fxshade_model::convert::narrow;
use std::io::{Read, Write};
use std::path::Path;
use std::process::{Command, ExitStatus, Stdio};
use std::time::Duration;

use anyhow::{bail, Context};

/// A time limit and the variable that sets it.
#[derive(Clone, Copy, Debug)]
pub struct Limit {
    /// The limit.
    pub time: Duration,
    /// The environment variable that sets it, in seconds (for errors).
    pub var: &'static str,
}

impl Limit {
    fn from_env(var: &'static str, default_s: u64) -> Limit {
        let s = crate::settings::get()
            .timeouts
            .get(var)
            .copied()
            .unwrap_or(default_s);
        Limit {
            time: Duration::from_secs(s),
            var,
        }
    }
    /// A version or presence probe (`tool -V`): `$FXSHADE_PROBE_TIMEOUT`,
    /// else 60 s.
    pub fn probe() -> Limit {
        Self::from_env("FXSHADE_PROBE_TIMEOUT", 60)
    }
    /// A simulator build, or a Yosys read of one module:
    /// `$FXSHADE_BUILD_TIMEOUT`, else 900 s.
    pub fn build() -> Limit {
        Self::from_env("FXSHADE_BUILD_TIMEOUT", 900)
    }
    /// A proof step (Yosys's formal model, yosys-smtbmc, z3):
    /// `$FXSHADE_FORMAL_TIMEOUT`, else 900 s.
    pub fn formal() -> Limit {
        Self::from_env("FXSHADE_FORMAL_TIMEOUT", 900)
    }
    /// Synthesis or place and route of one design:
    /// `$FXSHADE_SYNTH_TIMEOUT`, else 7200 s.
    pub fn synth() -> Limit {
        Self::from_env("FXSHADE_SYNTH_TIMEOUT", 7200)
    }
    /// One point's evaluation started through `explore --launcher` (which
    /// may wait in a cluster's queue): `$FXSHADE_LAUNCH_TIMEOUT`, else
    /// 86400 s.
    pub fn launch() -> Limit {
        Self::from_env("FXSHADE_LAUNCH_TIMEOUT", 86_400)
    }
    /// A simulation that reads nothing for this long is stopped:
    /// `$FXSHADE_SIM_IDLE_TIMEOUT`, else 600 s (the simulation itself may
    /// run as long as it keeps reading vectors).
    pub fn sim_idle() -> Limit {
        Self::from_env("FXSHADE_SIM_IDLE_TIMEOUT", 600)
    }
}

/// A process group being watched: the guard process that kills it if
/// fxshade dies, and a way to kill it now.
pub struct Group {
    pgid: i32,
    guard: Option<std::process::Child>,
}

impl Group {
    /// Watch the group led by the child `pid` (spawned with
    /// `process_group(0)`).
    pub fn watch(pid: u32) -> Group {
        let pgid = narrow::<i32, _>(pid);
        // The guard waits on a pipe only fxshade holds: when it closes
        // (fxshade finished or was killed, even by SIGKILL), the guard
        // kills the whole group.
        let guard = Command::new("sh")
            .arg("-c")
            .arg(format!("read _ ; kill -KILL -{pgid} 2>/dev/null"))
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .ok();
        Group { pgid, guard }
    }
    /// Kill every process of the group.
    pub fn kill(&self) {
        // SAFETY: signalling a process group fxshade created.
        unsafe {
            libc::kill(-self.pgid, libc::SIGKILL);
        }
    }
}

impl Drop for Group {
    fn drop(&mut self) {
        // The leader has been reaped: stop the guard before its `kill`
        // could reach a reused group id.
        if let Some(g) = self.guard.as_mut() {
            let _ = g.kill();
            let _ = g.wait();
        }
    }
}

/// What a finished tool gave.
#[derive(Debug)]
pub struct Output {
    /// Its exit status.
    pub status: ExitStatus,
    /// Its standard output.
    pub stdout: String,
    /// Its standard error.
    pub stderr: String,
}

impl Output {
    /// Standard output, then standard error.
    pub fn text(&self) -> String {
        self.stdout.clone() + &self.stderr
    }
}

/// Run `cmd` to the end in a process group of its own under `limit`, with
/// `input` on its standard input (none: `/dev/null`). On timeout the whole
/// group is killed and the error names `what` and the limit's variable.
///
/// # Errors
///
/// The program cannot be started, or it runs past `limit` (the error names the limit's
/// variable); a non-zero exit is in the `Output`.
///
/// # Panics
///
/// Never: standard output and error are piped before the child is taken.
pub fn run(
    cmd: &mut Command,
    what: &str,
    limit: Limit,
    input: Option<&[u8]>,
) -> anyhow::Result<Output> {
    use std::os::unix::process::CommandExt;
    let mut child = cmd
        .process_group(0)
        .stdin(if input.is_some() {
            Stdio::piped()
        } else {
            Stdio::null()
        })
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .with_context(|| format!("cannot run {what}"))?;
    let group = Group::watch(child.id());
    let (tx, rx) = std::sync::mpsc::channel::<()>();
    let timed_out = std::sync::atomic::AtomicBool::new(false);
    let mut stdin = child.stdin.take();
    let mut out_pipe = child.stdout.take().expect("piped");
    let mut err_pipe = child.stderr.take().expect("piped");
    let (stdout, stderr, status) = std::thread::scope(|s| {
        let group = &group;
        let timed_out = &timed_out;
        s.spawn(move || {
            if rx.recv_timeout(limit.time).is_err() {
                timed_out.store(true, std::sync::atomic::Ordering::SeqCst);
                group.kill();
            }
        });
        if let (Some(mut i), Some(data)) = (stdin.take(), input) {
            s.spawn(move || {
                // A tool that exits without reading all of it closes the pipe.
                let _ = i.write_all(data);
            });
        }
        let err = s.spawn(move || {
            let mut b = Vec::new();
            let _ = err_pipe.read_to_end(&mut b);
            b
        });
        let mut out = Vec::new();
        let _ = out_pipe.read_to_end(&mut out);
        let err = err.join().unwrap_or_default();
        let status = child.wait();
        let _ = tx.send(());
        (out, err, status)
    });
    let status = status.with_context(|| format!("cannot run {what}"))?;
    if timed_out.load(std::sync::atomic::Ordering::SeqCst) {
        bail!(
            "{what} did not finish within {} s and was stopped with every process it started \
             (set {} to allow more)",
            limit.time.as_secs(),
            limit.var
        );
    }
    Ok(Output {
        status,
        stdout: String::from_utf8_lossy(&stdout).into_owned(),
        stderr: String::from_utf8_lossy(&stderr).into_owned(),
    })
}

/// Run `cmd` under `limit`; fail with its output when it fails.
///
/// # Errors
///
/// As [`run`], and when the program exits non-zero (its output in the error).
pub fn run_ok(cmd: &mut Command, what: &str, limit: Limit) -> anyhow::Result<String> {
    let o = run(cmd, what, limit, None)?;
    if !o.status.success() {
        bail!("{what} failed ({}):\n{}", o.status, o.text().trim_end());
    }
    Ok(o.text())
}

/// Write `script` to `dir/name` and run it with Yosys (`yosys -q -s
/// name`, in `dir`) under the formal tools' limit; `what` names the run in
/// errors. The caller reads the status and the output.
///
/// # Errors
///
/// The script cannot be written to `dir`, or Yosys cannot be run ([`run`]).
pub fn yosys_script(dir: &Path, name: &str, script: &str, what: &str) -> anyhow::Result<Output> {
    std::fs::write(dir.join(name), script).context("cannot write the Yosys script")?;
    let mut y = Command::new("yosys");
    y.current_dir(dir).args(["-q", "-s", name]);
    run(&mut y, what, Limit::formal(), None)
}

/// Whether `tool` is installed: `tool arg` run as a probe. `Ok(None)` when
/// it is not on the `PATH`; its output when it ran (whatever its status);
/// an error when it hung past [`Limit::probe`] or could not be run.
///
/// # Errors
///
/// The program runs past the probe limit; a program that is missing is `Ok(None)`.
pub fn probe(tool: &str, arg: &str) -> anyhow::Result<Option<Output>> {
    match run(
        Command::new(tool).arg(arg),
        &format!("`{tool} {arg}`"),
        Limit::probe(),
        None,
    ) {
        Ok(o) => Ok(Some(o)),
        Err(e)
            if e.chain().any(|c| {
                c.downcast_ref::<std::io::Error>()
                    .is_some_and(|io| io.kind() == std::io::ErrorKind::NotFound)
            }) =>
        {
            Ok(None)
        }
        Err(e) => Err(e),
    }
}

/// Whether `tool` answers a probe (a hung or missing tool is `false`).
pub fn has(tool: &str, arg: &str) -> bool {
    matches!(probe(tool, arg), Ok(Some(_)))
}

/// The first line a tool prints for `arg` (its version), if it runs.
pub fn version(tool: &str, arg: &str) -> Option<String> {
    let o = probe(tool, arg).ok()??;
    o.text().lines().next().map(|l| l.trim().to_string())
}

/// Fail with `how` (the install command) when `tool` is missing, and with
/// the probe's error when `tool arg` hangs.
///
/// # Errors
///
/// The program does not answer `arg`: the error says how to install it (`how`).
pub fn require(tool: &str, arg: &str, how: &str) -> anyhow::Result<()> {
    match probe(tool, arg)? {
        Some(_) => Ok(()),
        None => bail!("{tool} is not installed: {how}"),
    }
}

/// `f(item, dir)` for every item on `jobs` threads, each in a scratch
/// directory of its own (under one temporary directory named `prefix…`,
/// removed afterwards); the results in the items' order.
///
/// # Errors
///
/// No temporary directory, scratch directory or worker threads, or the
/// first error of `f`.
pub fn in_scratch_dirs<T: Sync, R: Send>(
    prefix: &str,
    jobs: usize,
    items: &[T],
    f: impl Fn(&T, &Path) -> anyhow::Result<R> + Sync,
) -> anyhow::Result<Vec<R>> {
    use rayon::prelude::*;
    let dir = tempfile::Builder::new()
        .prefix(prefix)
        .tempdir()
        .context("cannot create a temporary directory")?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .context("cannot start the worker threads")?;
    pool.install(|| {
        items
            .par_iter()
            .enumerate()
            .map(|(k, item)| {
                let sub = dir.path().join(k.to_string());
                std::fs::create_dir(&sub).context("cannot create a scratch directory")?;
                f(item, &sub)
            })
            .collect()
    })
}
