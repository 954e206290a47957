//! `fxshade merge <rtl-check JSON | DIR>…`: add up the shards of one
//! regression, refuse a mix, and say which shards to run again in the
//! scheduler's own terms.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::bail;
use clap::Args;

use super::rtl_check::{RunError, RunSummary};
use crate::output::{emit, OutputArgs, Table, UsageError};
use crate::shard::Scheduler;

/// `fxshade merge`
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The results of `fxshade rtl-check --shard K/N` (its `--json` output
    /// or the file `--result DIR` writes), or directories holding them
    /// (every `*.json` in it is read), one per shard — all N of them.
    #[arg(required = true, value_name = "FILE|DIR")]
    files: Vec<PathBuf>,
    /// How many shards the run has, when no shard's result says so (every
    /// task died before writing one).
    #[arg(long, value_name = "N")]
    shards: Option<usize>,
    #[command(flatten)]
    out: OutputArgs,
}

/// The merged verdict.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Merged {
    /// Unit.
    pub unit: String,
    /// Variant.
    pub variant: String,
    /// Configuration hash.
    pub config_hash: String,
    /// SHA-256 of the simulated design and testbench.
    pub design_fingerprint: String,
    /// Simulator and its version.
    pub simulator: String,
    /// fxshade's version.
    pub fxshade_version: String,
    /// Seed.
    pub seed: u64,
    /// Shards.
    pub shards: usize,
    /// Vectors in the stream.
    pub total: usize,
    /// Passed, all shards.
    pub passed: u64,
    /// Failed, all shards.
    pub failed: u64,
    /// Shards with failing vectors, as `K/N`.
    pub failed_shards: Vec<String>,
    /// Shards that stopped with an error, as `K/N`, with the error.
    pub error_shards: Vec<(String, String)>,
    /// Shards with no result, as `K/N`.
    pub missing_shards: Vec<String>,
    /// How to run the missing and stopped shards again.
    pub resubmit: Option<String>,
}

/// Most shards a merge takes (a run has at most 2^32 vectors; a million
/// shards is far more than any scheduler runs).
const MAX_SHARDS: usize = 1 << 20;

/// A result file, its `(K, N)` and its scheduler.
pub type ShardOf = (PathBuf, Option<(usize, usize)>, Option<Scheduler>);

/// Check that `shards` (file, its `(K, N)`, its scheduler) are every shard
/// of one split, each once: errors name the files, and missing shards are
/// named with the scheduler's resubmit line. Returns N.
pub fn check_shards(shards: &[ShardOf]) -> anyhow::Result<usize> {
    let Some((f0, first, _)) = shards.first() else {
        bail!("no shard given");
    };
    let Some((_, n)) = *first else {
        bail!("{}: a run without --shard", f0.display());
    };
    let keyed: Vec<(&Path, Option<(usize, usize)>)> =
        shards.iter().map(|(f, s, _)| (f.as_path(), *s)).collect();
    let missing = missing_of(&keyed, n)?;
    if !missing.is_empty() {
        let sched = shards.iter().find_map(|(_, _, s)| s.clone());
        bail!("{}", missing_line(&missing, n, sched.as_ref()));
    }
    Ok(n)
}

/// The shards of `0..n` no file holds, after checking that every file
/// (its `(K, N)`) is a shard of `n`, each once; errors name the files.
fn missing_of(shards: &[(&Path, Option<(usize, usize)>)], n: usize) -> anyhow::Result<Vec<usize>> {
    if n == 0 || n > MAX_SHARDS {
        bail!("{n} shards: a run has 1 to {MAX_SHARDS}");
    }
    let mut seen = vec![None::<&Path>; n];
    for &(f, shard) in shards {
        let Some((k, nk)) = shard else {
            bail!("{}: a run without --shard", f.display());
        };
        if k >= nk {
            bail!("{}: shard {k}/{nk} cannot be (0 ≤ K < N)", f.display());
        }
        if nk != n {
            bail!(
                "{}: shard {k}/{nk}, but the others are shards of {n}",
                f.display()
            );
        }
        if let Some(prev) = seen[k] {
            bail!(
                "shard {k}/{n} given twice: {} and {}",
                prev.display(),
                f.display()
            );
        }
        seen[k] = Some(f);
    }
    Ok((0..n).filter(|&k| seen[k].is_none()).collect())
}

/// `missing 3/8 and 7/8: resubmit with sbatch --array=3,7 …`.
fn missing_line(missing: &[usize], n: usize, sched: Option<&Scheduler>) -> String {
    let names: Vec<String> = missing.iter().map(|k| format!("{k}/{n}")).collect();
    let list = match names.as_slice() {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    };
    let fallback = Scheduler {
        kind: "flag".into(),
        base: 0,
        step: 1,
    };
    format!(
        "missing {list}: {}",
        sched.unwrap_or(&fallback).resubmit(missing, n)
    )
}

/// One file's result.
enum Outcome {
    Ran(Box<RunSummary>),
    Stopped(RunError),
}

/// The files named, directories expanded into their `*.json` files
/// (sorted).
fn expand(paths: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut in_dir: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(|e| UsageError(format!("{}: cannot read: {e}", p.display())))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| f.extension().is_some_and(|x| x == "json") && f.is_file())
                .collect();
            in_dir.sort();
            if in_dir.is_empty() {
                return Err(UsageError(format!(
                    "{}: no *.json result in it (did every task die before writing one? \
                     rtl-check --result DIR writes them)",
                    p.display()
                ))
                .into());
            }
            files.extend(in_dir);
        } else {
            files.push(p.clone());
        }
    }
    Ok(files)
}

fn read(f: &Path) -> anyhow::Result<Outcome> {
    let text = fxshade_model::files::read_text_limited(f)
        .map_err(|e| UsageError(format!("{}: cannot read: {e}", f.display())))?;
    if text.trim().is_empty() {
        bail!(
            "{}: empty (its task stopped before printing a result; rtl-check --result DIR \
             records errors too)",
            f.display()
        );
    }
    if let Ok(r) = serde_json::from_str::<RunSummary>(&text) {
        return Ok(Outcome::Ran(Box::new(r)));
    }
    if let Ok(e) = serde_json::from_str::<RunError>(&text) {
        if e.outcome == "error" {
            return Ok(Outcome::Stopped(e));
        }
    }
    let why = serde_json::from_str::<RunSummary>(&text)
        .err()
        .map_or(String::new(), |e| e.to_string());
    bail!(
        "{}: not the result of `fxshade rtl-check --shard K/N` of this fxshade ({why}; a result \
         without a design fingerprint was written by an older fxshade: run it again)",
        f.display()
    )
}

/// The value most shards have for a field, and the files that differ.
fn odd_ones(
    runs: &[(PathBuf, RunSummary)],
    field: impl Fn(&RunSummary) -> String,
) -> Option<(String, Vec<&PathBuf>, String)> {
    let mut count: BTreeMap<String, usize> = BTreeMap::new();
    for (_, r) in runs {
        *count.entry(field(r)).or_default() += 1;
    }
    if count.len() < 2 {
        return None;
    }
    // The majority; a tie goes to the value of the first file.
    let first = field(&runs[0].1);
    let best = count
        .iter()
        .max_by_key(|(v, c)| (**c, **v == first))
        .map(|(v, _)| v.clone())?;
    let odd: Vec<&PathBuf> = runs
        .iter()
        .filter(|(_, r)| field(r) != best)
        .map(|(f, _)| f)
        .collect();
    let theirs = field(&runs.iter().find(|(_, r)| field(r) != best)?.1);
    Some((best, odd, theirs))
}

/// Run it: exit status 0 only when every shard is there, they belong to
/// one run, and every vector passed. Missing, stopped and failing shards
/// are all reported, each by its number; the missing and stopped ones with
/// the line that runs them again.
pub fn run(a: &MergeArgs) -> anyhow::Result<()> {
    let files = expand(&a.files)?;
    let mut runs: Vec<(PathBuf, RunSummary)> = Vec::new();
    let mut stopped: Vec<(PathBuf, RunError)> = Vec::new();
    for f in &files {
        match read(f)? {
            Outcome::Ran(r) => runs.push((f.clone(), *r)),
            Outcome::Stopped(e) => stopped.push((f.clone(), e)),
        }
    }
    for (f, r) in &runs {
        if r.shard.is_none() {
            bail!(
                "{}: a run without --shard; merge takes the shards of one run",
                f.display()
            );
        }
    }
    // Every shard must be of one run: the same design, configuration,
    // stream, simulator and fxshade. The odd one is named.
    type Field = (&'static str, fn(&RunSummary) -> String);
    let fields: [Field; 8] = [
        ("unit", |r| r.unit.clone()),
        ("variant", |r| r.variant.clone()),
        ("design", |r| r.design_fingerprint.clone()),
        ("configuration", |r| r.config_hash.clone()),
        ("seed and vector count", |r| {
            format!("seed {}, {} vectors", r.seed, r.total)
        }),
        ("simulator", |r| {
            format!("{} ({})", r.sim, r.simulator_version)
        }),
        ("fxshade version", |r| r.fxshade_version.clone()),
        ("shard count", |r| {
            format!("{} shards", r.shard.map_or(0, |s| s.1))
        }),
    ];
    for (what, field) in fields {
        if let Some((best, odd, theirs)) = odd_ones(&runs, field) {
            let names: Vec<String> = odd.iter().map(|f| f.display().to_string()).collect();
            bail!(
                "{}: {what} {theirs}, but the other shards have {best}: not shards of one run \
                 (the odd {} made by another run: remove {} or run {} again)",
                names.join(", "),
                if odd.len() == 1 {
                    "one was"
                } else {
                    "ones were"
                },
                if odd.len() == 1 { "it" } else { "them" },
                if odd.len() == 1 { "it" } else { "them" },
            );
        }
    }
    // A stopped shard's record holds only its unit and shard: it must at
    // least be of this run's unit.
    let unit = runs
        .first()
        .map(|(_, r)| r.unit.clone())
        .or_else(|| stopped.first().map(|(_, e)| e.unit.clone()));
    for (f, e) in &stopped {
        if Some(&e.unit) != unit.as_ref() {
            bail!(
                "{}: a stopped run of {}, but the other shards are of {}: not shards of one run",
                f.display(),
                e.unit,
                unit.unwrap_or_default()
            );
        }
    }
    let n = runs
        .iter()
        .filter_map(|(_, r)| r.shard.map(|s| s.1))
        .chain(stopped.iter().filter_map(|(_, e)| e.shard.map(|s| s.1)))
        .next()
        .or(a.shards)
        .ok_or_else(|| {
            UsageError("no shard's result says how many shards: give --shards N".into())
        })?;
    if n == 0 || n > MAX_SHARDS {
        return Err(UsageError(format!("{n} shards: give 1 to {MAX_SHARDS}")).into());
    }
    if let Some(s) = a.shards {
        if s != n {
            return Err(
                UsageError(format!("--shards {s}, but the results are shards of {n}")).into(),
            );
        }
    }
    let keyed: Vec<(&Path, Option<(usize, usize)>)> = runs
        .iter()
        .map(|(f, r)| (f.as_path(), r.shard))
        .chain(stopped.iter().map(|(f, e)| (f.as_path(), e.shard)))
        .collect();
    let missing = missing_of(&keyed, n)?;
    let sched = runs
        .iter()
        .find_map(|(_, r)| r.scheduler.clone())
        .or_else(|| stopped.iter().find_map(|(_, e)| e.scheduler.clone()));
    let mut again = missing.clone();
    again.extend(stopped.iter().filter_map(|(_, e)| e.shard.map(|s| s.0)));
    again.sort_unstable();
    let failed_shards: Vec<String> = runs
        .iter()
        .filter(|(_, r)| r.failed > 0 || r.passed != r.count as u64)
        .filter_map(|(_, r)| r.shard.map(|(k, n)| format!("{k}/{n}")))
        .collect();
    let r0 = runs.first().map(|(_, r)| r);
    let checked: usize = runs.iter().map(|(_, r)| r.count).sum();
    let m = Merged {
        unit: r0.map_or_else(|| stopped[0].1.unit.clone(), |r| r.unit.clone()),
        variant: r0.map_or(String::new(), |r| r.variant.clone()),
        config_hash: r0.map_or(String::new(), |r| r.config_hash.clone()),
        design_fingerprint: r0.map_or(String::new(), |r| r.design_fingerprint.clone()),
        simulator: r0.map_or(String::new(), |r| {
            format!("{} ({})", r.sim, r.simulator_version)
        }),
        fxshade_version: r0.map_or(String::new(), |r| r.fxshade_version.clone()),
        seed: r0.map_or(0, |r| r.seed),
        shards: n,
        total: r0.map_or(0, |r| r.total),
        passed: runs.iter().map(|(_, r)| r.passed).sum(),
        failed: runs.iter().map(|(_, r)| r.failed).sum(),
        failed_shards,
        error_shards: stopped
            .iter()
            .map(|(_, e)| {
                (
                    e.shard.map_or("?".into(), |(k, n)| format!("{k}/{n}")),
                    e.error.clone(),
                )
            })
            .collect(),
        missing_shards: missing.iter().map(|k| format!("{k}/{n}")).collect(),
        resubmit: (!again.is_empty())
            .then(|| missing_line(&again, n, sched.as_ref()))
            .map(|l| l.split_once(": ").map_or(l.clone(), |(_, r)| r.to_string())),
    };
    let mut t = Table::new([
        "unit", "variant", "shards", "vectors", "checked", "passed", "failed",
    ])
    .titled(format!(
        "merged rtl-check, configuration {}, design {}, seed {}",
        m.config_hash,
        m.design_fingerprint.chars().take(16).collect::<String>(),
        m.seed
    ));
    t.row([
        m.unit.clone(),
        m.variant.clone(),
        n.to_string(),
        m.total.to_string(),
        checked.to_string(),
        m.passed.to_string(),
        m.failed.to_string(),
    ]);
    emit(a.out, &[t], &serde_json::to_value(&m)?)?;
    let mut problems = Vec::new();
    if !m.failed_shards.is_empty() {
        problems.push(format!(
            "{} of {} vectors failed, in shard{} {}",
            m.failed,
            m.total,
            if m.failed_shards.len() == 1 { "" } else { "s" },
            m.failed_shards.join(", ")
        ));
    }
    for (k, e) in &m.error_shards {
        problems.push(format!("shard {k} stopped with an error: {e}"));
    }
    if !again.is_empty() {
        let mut line = missing_line(&again, n, sched.as_ref());
        if !stopped.is_empty() {
            line = line.replacen("missing", "missing or stopped", 1);
        }
        problems.push(line);
    }
    if problems.is_empty() && (checked != m.total || m.passed != m.total as u64) {
        problems.push(format!("the shards cover {checked} vectors of {}", m.total));
    }
    if !problems.is_empty() {
        bail!("{}", problems.join("\n"));
    }
    Ok(())
}
