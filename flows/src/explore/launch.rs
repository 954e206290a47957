//! `explore --launcher CMD`: every point's evaluation runs as a process of
//! its own, started through a cluster's launcher (`srun -N1 -n1 --quiet`,
//! `bsub -K -q short`, `qrsh -now no`, a script that runs a Kubernetes
//! Job), so a sweep or an `--optimize` search spreads its points over a
//! cluster, `--jobs` at a time.
//!
//! The evaluation is the hidden subcommand `fxshade explore-point JOB
//! RESULT`: `JOB` holds the point's whole configuration (as TOML) and the
//! sweep's options; `RESULT` receives the metrics or the evaluation's
//! error, written whole. Both live in a directory the launched process
//! must see (`--launch-dir`, default a private directory in the current
//! one): on a cluster, a shared file system, as is the fxshade executable.
//! A point whose launch fails (the launcher is missing, the job was
//! killed) is an error of that point, never cached; a point the model
//! could not evaluate is cached like a local one.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use anyhow::{bail, Context};
use fxshade_model::Config;

use super::eval::{self, Options};

/// What `explore-point` reads.
#[derive(serde::Serialize, serde::Deserialize)]
struct Job {
    /// fxshade's version (the launched executable must be the same).
    fxshade_version: String,
    /// The point's whole configuration.
    config: String,
    /// The sweep's options.
    options: Options,
}

/// What `explore-point` writes. Metrics are text (Rust's shortest
/// round-trip form, `inf` and `NaN` included: JSON numbers cannot hold
/// them), read back bit for bit.
#[derive(serde::Serialize, serde::Deserialize)]
struct Outcome {
    metrics: BTreeMap<String, String>,
    error: Option<String>,
    /// The error is the node's (a mesh it cannot read, a configuration it
    /// cannot parse), not the model's verdict on the point: not cached.
    #[serde(default)]
    environment: bool,
}

/// Points whose launch failed, with why (`explore` fails at the end when
/// there are any: their rows would otherwise read as the model's).
static FAILED: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());

/// The launch failures so far.
pub fn failures() -> Vec<String> {
    FAILED.lock().unwrap_or_else(|e| e.into_inner()).clone()
}

/// Record a failed launch.
pub fn record_failure(why: String) {
    FAILED.lock().unwrap_or_else(|e| e.into_inner()).push(why);
}

/// A launcher: the command prefix and the directory of job files.
pub struct Launcher {
    argv: Vec<String>,
    dir: tempfile::TempDir,
    exe: PathBuf,
    line: String,
}

static LAUNCHER: OnceLock<Launcher> = OnceLock::new();

/// The launcher in use, if `--launcher` was given.
pub fn get() -> Option<&'static Launcher> {
    LAUNCHER.get()
}

/// Use `line` (split as a shell would, without running a shell) to start
/// every point's evaluation; job files go into a private directory made in
/// `dir` (default: the current directory).
///
/// # Errors
///
/// `line` is not a command line (`shlex`), names no program, or `dir` cannot be created.
pub fn install(line: &str, dir: Option<&Path>) -> anyhow::Result<()> {
    let argv = shlex::split(line)
        .filter(|v| !v.is_empty())
        .ok_or_else(|| {
            crate::UsageError(format!(
                "--launcher {line:?}: not a command (quote it as a shell would: \
             --launcher 'srun -N1 -n1 --quiet')"
            ))
        })?;
    // Absolute: a launcher may start the command in another directory.
    let parent = std::path::absolute(dir.unwrap_or(Path::new(".")))
        .context("--launch-dir: cannot resolve it")?;
    let dir = tempfile::Builder::new()
        .prefix(".fxshade-launch-")
        .tempdir_in(&parent)
        .with_context(|| {
            format!(
                "--launch-dir {}: cannot make a directory in it",
                parent.display()
            )
        })?;
    let exe = std::env::current_exe().context("cannot find the fxshade executable")?;
    let l = Launcher {
        argv,
        dir,
        exe,
        line: line.to_string(),
    };
    LAUNCHER
        .set(l)
        .map_err(|_| anyhow::anyhow!("the launcher is set twice"))
}

/// Remove the launcher's job directory (a static is never dropped).
pub fn cleanup() {
    if let Some(l) = LAUNCHER.get() {
        let _ = std::fs::remove_dir_all(l.dir.path());
    }
}

impl Launcher {
    /// Evaluate `cfg` through the launcher. `Ok(Ok(metrics))` or
    /// `Ok(Err(evaluation error))` is the model's verdict (cacheable);
    /// `Err` is a failed launch (not cached).
    ///
    /// # Errors
    ///
    /// A job file cannot be written, the launcher cannot be started, or it exits without
    /// writing a result; a point the model could not evaluate is an `Ok` outcome with its
    /// error.
    pub fn evaluate(
        &self,
        cfg: &Config,
        o: &Options,
    ) -> anyhow::Result<Result<BTreeMap<String, f64>, String>> {
        let job = Job {
            fxshade_version: env!("CARGO_PKG_VERSION").into(),
            config: cfg.to_toml(),
            options: o.clone(),
        };
        let file = tempfile::Builder::new()
            .prefix("point-")
            .suffix(".job.json")
            .tempfile_in(self.dir.path())
            .context("cannot write a job file")?;
        std::fs::write(file.path(), serde_json::to_vec(&job)?)
            .context("cannot write a job file")?;
        let result = file.path().with_extension("").with_extension("result.json");
        let mut cmd = Command::new(&self.argv[0]);
        cmd.args(&self.argv[1..])
            .arg(&self.exe)
            .arg("explore-point")
            .arg(file.path())
            .arg(&result);
        let what = format!("the launcher `{}`", self.line);
        let out = crate::proc::run(&mut cmd, &what, crate::proc::Limit::launch(), None);
        let read = std::fs::read(&result);
        let _ = std::fs::remove_file(&result);
        let out = out?;
        match read
            .ok()
            .and_then(|b| serde_json::from_slice::<Outcome>(&b).ok())
        {
            Some(Outcome {
                error: Some(e),
                environment: true,
                ..
            }) => bail!("{what}: the launched evaluation could not run: {e}"),
            Some(Outcome { error: Some(e), .. }) => Ok(Err(e)),
            Some(Outcome { metrics, .. }) if out.status.success() => {
                let mut m = BTreeMap::new();
                for (k, v) in metrics {
                    let x: f64 = v.parse().map_err(|_| {
                        anyhow::anyhow!("{what}: metric {k} = {v:?} is not a number")
                    })?;
                    m.insert(k, x);
                }
                Ok(Ok(m))
            }
            _ => {
                let tail: Vec<&str> = out.stderr.lines().rev().take(5).collect();
                let tail: Vec<&str> = tail.into_iter().rev().collect();
                bail!(
                    "{what} {} and wrote no result{}",
                    match out.status.code() {
                        Some(c) => format!("exited with status {c}"),
                        None => "was killed".into(),
                    },
                    if tail.is_empty() {
                        String::new()
                    } else {
                        format!(": {}", tail.join(" / "))
                    }
                )
            }
        }
    }
}

/// Evaluate the point of the job file `job` (what `explore --launcher`
/// wrote): its metrics, or the evaluation's error, written whole to
/// `result`.
///
/// # Errors
///
/// A job that cannot be read ([`crate::UsageError`]) or is not a job of
/// this fxshade version; a result that cannot be written; the point's own
/// error when the model could not evaluate it (after writing it).
pub fn run_point(job: &Path, result: &Path) -> anyhow::Result<()> {
    let text = fxshade_model::files::read_text_limited(job)
        .map_err(|e| crate::UsageError(format!("{}: cannot read: {e}", job.display())))?;
    let j: Job = serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: not a job of `fxshade explore --launcher`",
            job.display()
        )
    })?;
    if j.fxshade_version != env!("CARGO_PKG_VERSION") {
        bail!(
            "{}: written by fxshade {}, and this is {}: run the same fxshade on every node",
            job.display(),
            j.fxshade_version,
            env!("CARGO_PKG_VERSION")
        );
    }
    let node_error = |e: String| Outcome {
        metrics: BTreeMap::new(),
        error: Some(e),
        environment: true,
    };
    let outcome = match Config::parse(&j.config, &job.display().to_string()) {
        Err(e) => node_error(e.to_string().trim().replace('\n', "; ")),
        Ok(cfg) => match super::load_meshes(&j.options) {
            Err(e) => node_error(format!("{e:#}")),
            Ok(meshes) => match eval::evaluate(&cfg, &j.options, &meshes) {
                Ok(metrics) => Outcome {
                    metrics: metrics
                        .into_iter()
                        .map(|(k, v)| (k, v.to_string()))
                        .collect(),
                    error: None,
                    environment: false,
                },
                Err(e) => Outcome {
                    metrics: BTreeMap::new(),
                    error: Some(format!("{e:#}")),
                    environment: false,
                },
            },
        },
    };
    let dir = result.parent().unwrap_or(Path::new("."));
    let mut t = tempfile::NamedTempFile::new_in(dir)
        .with_context(|| format!("cannot write {}", result.display()))?;
    use std::io::Write;
    t.write_all(&serde_json::to_vec(&outcome)?)
        .and_then(|()| t.as_file().sync_all())
        .with_context(|| format!("cannot write {}", result.display()))?;
    t.persist(result)
        .map_err(|e| e.error)
        .with_context(|| format!("cannot write {}", result.display()))?;
    if let Some(e) = outcome.error {
        bail!("{e}");
    }
    Ok(())
}
