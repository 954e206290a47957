//! `--shard K/N` and `--shard auto`: which slice of a run this process
//! takes, given by hand or read from the job-array variables of the
//! scheduler that started it (Slurm, LSF, Grid Engine, Kubernetes Indexed
//! Jobs) or from `FXSHADE_SHARD=K/N`. Shards are 0-based here whatever the
//! scheduler counts from; a result records how its scheduler numbers the
//! task ([`Scheduler`]), so a merge can name missing shards in the
//! scheduler's own terms (`sbatch --array=3,7`).

use fxshade_model::convert::narrow;
use std::collections::BTreeMap;

/// The scheduler a shard came from, and how it numbers array tasks:
/// task index = `base + K·step`.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Scheduler {
    /// `slurm`, `lsf`, `sge`, `kubernetes`, `env` (FXSHADE_SHARD) or
    /// `flag` (`--shard K/N`).
    pub kind: String,
    /// The task index of shard 0.
    pub base: i64,
    /// Between the task indices of consecutive shards.
    pub step: i64,
}

impl Scheduler {
    fn new(kind: &str, base: i64, step: i64) -> Scheduler {
        Scheduler {
            kind: kind.into(),
            base,
            step,
        }
    }

    /// The task index of shard `k`.
    pub fn task(&self, k: usize) -> i64 {
        self.base + narrow::<i64, _>(k) * self.step
    }

    /// How to run shards `ks` of `n` again, in the scheduler's own terms:
    /// the subset as an array whose task ids keep their shard numbers
    /// (`FXSHADE_SHARDS=N` makes `--shard auto` number from the ids).
    pub fn resubmit(&self, ks: &[usize], n: usize) -> String {
        let first = match self.kind.as_str() {
            "lsf" | "sge" => 1,
            _ => 0,
        };
        let base = if self.base != first {
            format!(",FXSHADE_SHARD_BASE={}", self.base)
        } else {
            String::new()
        };
        let ids: Vec<String> = ks
            .iter()
            .map(|&k| (self.base + narrow::<i64, _>(k)).to_string())
            .collect();
        let list = ids.join(",");
        match self.kind.as_str() {
            "slurm" => format!(
                "resubmit with sbatch --array={list} --export=ALL,FXSHADE_SHARDS={n}{base} \
                 <shard script>"
            ),
            "lsf" => format!(
                "resubmit with bsub -J \"<name>[{list}]\" -env \"all,FXSHADE_SHARDS={n}{base}\" \
                 <shard script>"
            ),
            "sge" => format!(
                "resubmit each with qsub -t I-I -v FXSHADE_SHARDS={n}{base} <shard script>, \
                 I in {list}"
            ),
            "kubernetes" => {
                format!(
                    "run them again as plain Jobs (not Indexed) with FXSHADE_SHARD=K/{n} and \
                     --shard auto without --shards, K in {list}"
                )
            }
            _ => format!(
                "run again with {}",
                ks.iter()
                    .map(|k| format!("--shard {k}/{n}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
    }
}

/// A shard: `(K, N)` and where it came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This process's slice, 0-based.
    pub k: usize,
    /// Slices in the run.
    pub n: usize,
    /// Where `K` and `N` came from.
    pub scheduler: Scheduler,
}

/// `K/N` with `K < N` (0-based).
///
/// # Errors
///
/// `Err` when `s` is not `K/N` with 0 ≤ K < N.
pub fn parse_kn(s: &str) -> Result<(usize, usize), String> {
    let bad = || format!("`{s}`: write K/N with 0 ≤ K < N (shard K of N, 0-based), or auto");
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let (k, n): (usize, usize) = (
        k.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if n == 0 || k >= n {
        return Err(bad());
    }
    Ok((k, n))
}

/// What `--shard` was given.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ShardArg {
    /// `K/N`.
    Given(usize, usize),
    /// `auto`: from the environment ([`detect`]).
    Auto,
}

/// The parser of `--shard`.
///
/// # Errors
///
/// `Err` when `s` is neither `auto` nor `K/N` ([`parse_kn`]).
pub fn parse_arg(s: &str) -> Result<ShardArg, String> {
    if s.trim() == "auto" {
        return Ok(ShardArg::Auto);
    }
    parse_kn(s).map(|(k, n)| ShardArg::Given(k, n))
}

/// The shard this process takes: `--shard K/N` as given, or with
/// `--shard auto` the one the environment names ([`detect`]; `shards` is
/// `--shards N` or `FXSHADE_SHARDS`).
///
/// # Errors
///
/// `Err` when `auto` finds no job array, or the array's task is no shard of N ([`detect`]).
pub fn resolve(arg: Option<&ShardArg>, shards: Option<usize>) -> Result<Option<Shard>, String> {
    match arg {
        None => Ok(None),
        Some(ShardArg::Given(k, n)) => Ok(Some(Shard {
            k: *k,
            n: *n,
            scheduler: Scheduler::new("flag", 0, 1),
        })),
        Some(ShardArg::Auto) => detect(&crate::settings::get().job_array, shards).map(Some),
    }
}

/// Read the shard from job-array variables (`env`: name to value):
///
/// * `FXSHADE_SHARD=K/N`;
/// * Slurm: `SLURM_ARRAY_TASK_ID`, `SLURM_ARRAY_TASK_COUNT`,
///   `SLURM_ARRAY_TASK_MIN` (and `SLURM_ARRAY_TASK_MAX`, `_STEP`): the
///   array must be evenly spaced (`--array=0-7`, `--array=1-8`);
/// * LSF: `LSB_JOBINDEX` (1-based), `LSB_JOBINDEX_END`, and
///   `LSB_JOBINDEX_STEP` where set: an array `[1-N]`;
/// * Grid Engine: `SGE_TASK_ID`, `SGE_TASK_FIRST`, `SGE_TASK_LAST`,
///   `SGE_TASK_STEPSIZE`;
/// * Kubernetes Indexed Jobs: `JOB_COMPLETION_INDEX` (0-based), with
///   `shards` (`--shards N`, the Job's `completions`).
///
/// With `shards` (`--shards N`, or `FXSHADE_SHARDS=N` in the environment)
/// the array's extent is not read: shard K is task `base + K`, `base`
/// being the scheduler's first index (Slurm and Kubernetes 0, LSF and
/// Grid Engine 1; `FXSHADE_SHARD_BASE` overrides it). That is how a
/// resubmitted subset (`sbatch --array=3,7`) keeps its shard numbers.
///
/// An error when none is set, when a set is incomplete or inconsistent,
/// or when two disagree.
///
/// # Errors
///
/// `Err` when no scheduler's variables are set, two disagree, a value is not a number, or the
/// task is not a shard of N.
///
/// # Panics
///
/// Never: `shards` is read only on the path where it is `Some`.
pub fn detect(env: &BTreeMap<String, String>, shards: Option<usize>) -> Result<Shard, String> {
    // Grid Engine sets SGE_TASK_ID=undefined outside an array job: unset.
    let get = |k: &str| {
        env.get(k)
            .map(|v| v.trim().to_string())
            .filter(|v| !v.is_empty() && v != "undefined")
    };
    let num = |k: &str| -> Result<Option<i64>, String> {
        match get(k) {
            None => Ok(None),
            // Bounded, so the index arithmetic below cannot overflow.
            Some(v) => match v.parse::<i64>() {
                Ok(n) if (-(1i64 << 40)..=1i64 << 40).contains(&n) => Ok(Some(n)),
                Ok(_) => Err(format!("{k}={v}: out of range")),
                Err(_) => Err(format!("{k}={v}: not a whole number")),
            },
        }
    };
    if shards.is_some_and(|n| !(1..=1 << 40).contains(&n)) {
        return Err("--shards N: give 1 ≤ N".into());
    }
    let shards = match (shards, num("FXSHADE_SHARDS")?) {
        (Some(a), Some(b)) if narrow::<i64, _>(a) != b => {
            return Err(format!("--shards {a} and FXSHADE_SHARDS={b} disagree"))
        }
        (Some(a), _) => Some(narrow::<i64, _>(a)),
        (None, b) => b,
    };
    if shards.is_some_and(|n| n < 1) {
        return Err("FXSHADE_SHARDS: give at least 1".into());
    }
    let base_override = num("FXSHADE_SHARD_BASE")?;
    let mut found: Vec<Shard> = Vec::new();
    let shard = |k: i64, n: i64, s: Scheduler, what: &str| -> Result<Shard, String> {
        if n < 1 || k < 0 || k >= n {
            return Err(format!(
                "{what}: task {} is shard {k} of {n}: not 0 ≤ K < N",
                s.task(narrow::<usize, _>(k.max(0)))
            ));
        }
        Ok(Shard {
            k: narrow::<usize, _>(k),
            n: narrow::<usize, _>(n),
            scheduler: s,
        })
    };
    // With --shards N: task id − base, whatever the array's extent.
    let fixed = |id: i64, kind: &str, base: i64, what: &str| -> Result<Shard, String> {
        let base = base_override.unwrap_or(base);
        let n = shards.expect("only with --shards");
        shard(id - base, n, Scheduler::new(kind, base, 1), what)
    };
    if let Some(v) = get("FXSHADE_SHARD") {
        let (k, n) = parse_kn(&v).map_err(|e| format!("FXSHADE_SHARD: {e}"))?;
        if let Some(m) = shards.filter(|&m| m != narrow::<i64, _>(n)) {
            return Err(format!(
                "FXSHADE_SHARD={v} names {n} shards, but --shards or FXSHADE_SHARDS says {m}"
            ));
        }
        found.push(Shard {
            k,
            n,
            scheduler: Scheduler::new("env", 0, 1),
        });
    }
    if let Some(id) = num("SLURM_ARRAY_TASK_ID")? {
        if shards.is_some() {
            found.push(fixed(id, "slurm", 0, "Slurm")?);
        } else {
            let min = num("SLURM_ARRAY_TASK_MIN")?
                .ok_or("SLURM_ARRAY_TASK_ID is set without SLURM_ARRAY_TASK_MIN")?;
            let count = num("SLURM_ARRAY_TASK_COUNT")?
                .ok_or("SLURM_ARRAY_TASK_ID is set without SLURM_ARRAY_TASK_COUNT")?;
            let step = num("SLURM_ARRAY_TASK_STEP")?.unwrap_or(1).max(1);
            if let Some(max) = num("SLURM_ARRAY_TASK_MAX")? {
                if (max - min) / step + 1 != count || (max - min) % step != 0 {
                    return Err(format!(
                        "the Slurm array {min}-{max}:{step} holds {count} tasks: not evenly \
                         spaced; submit --array={min}-{}, or give --shards N (FXSHADE_SHARDS) \
                         to number shards from the task ids",
                        min + count - 1
                    ));
                }
            }
            if (id - min) % step != 0 {
                return Err(format!("Slurm task {id} is not on the array's step {step}"));
            }
            found.push(shard(
                (id - min) / step,
                count,
                Scheduler::new("slurm", min, step),
                "Slurm",
            )?);
        }
    }
    if let Some(id) = num("LSB_JOBINDEX")? {
        // LSB_JOBINDEX=0: not an array job.
        if id != 0 && shards.is_some() {
            found.push(fixed(id, "lsf", 1, "LSF")?);
        } else if id != 0 {
            let end =
                num("LSB_JOBINDEX_END")?.ok_or("LSB_JOBINDEX is set without LSB_JOBINDEX_END")?;
            let step = num("LSB_JOBINDEX_STEP")?.unwrap_or(1).max(1);
            // LSF numbers from 1: `[1-N]`.
            if (id - 1) % step != 0 {
                return Err(format!("LSF task {id} is not on the array's step {step}"));
            }
            found.push(shard(
                (id - 1) / step,
                (end - 1) / step + 1,
                Scheduler::new("lsf", 1, step),
                "LSF",
            )?);
        }
    }
    if let Some(id) = num("SGE_TASK_ID")? {
        if shards.is_some() {
            found.push(fixed(id, "sge", 1, "Grid Engine")?);
        } else {
            let first =
                num("SGE_TASK_FIRST")?.ok_or("SGE_TASK_ID is set without SGE_TASK_FIRST")?;
            let last = num("SGE_TASK_LAST")?.ok_or("SGE_TASK_ID is set without SGE_TASK_LAST")?;
            let step = num("SGE_TASK_STEPSIZE")?.unwrap_or(1).max(1);
            if (id - first) % step != 0 {
                return Err(format!(
                    "Grid Engine task {id} is not on the array's step {step}"
                ));
            }
            found.push(shard(
                (id - first) / step,
                (last - first) / step + 1,
                Scheduler::new("sge", first, step),
                "Grid Engine",
            )?);
        }
    }
    if let Some(idx) = num("JOB_COMPLETION_INDEX")? {
        if shards.is_none() {
            return Err(
                "JOB_COMPLETION_INDEX (a Kubernetes Indexed Job) is set: give --shards N (or \
                 FXSHADE_SHARDS), the Job's completions"
                    .into(),
            );
        }
        found.push(fixed(idx, "kubernetes", 0, "Kubernetes")?);
    }
    match found.as_slice() {
        [] => Err(
            "--shard auto: no job array is set: none of FXSHADE_SHARD, SLURM_ARRAY_TASK_ID, \
             LSB_JOBINDEX, SGE_TASK_ID, JOB_COMPLETION_INDEX; give --shard K/N"
                .into(),
        ),
        [one] => Ok(one.clone()),
        [first, rest @ ..] => {
            for s in rest {
                if (s.k, s.n) != (first.k, first.n) {
                    return Err(format!(
                        "--shard auto: {} says shard {}/{}, {} says {}/{}: they disagree",
                        first.scheduler.kind, first.k, first.n, s.scheduler.kind, s.k, s.n
                    ));
                }
            }
            // A scheduler's numbering is worth more than FXSHADE_SHARD's.
            Ok(rest
                .iter()
                .chain([first])
                .find(|s| s.scheduler.kind != "env")
                .unwrap_or(first)
                .clone())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(pairs: &[(&str, &str)]) -> BTreeMap<String, String> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    #[test]
    fn each_scheduler_numbers_its_tasks_its_own_way() {
        // Slurm, 0-based and 1-based arrays.
        let s = detect(
            &env(&[
                ("SLURM_ARRAY_TASK_ID", "3"),
                ("SLURM_ARRAY_TASK_MIN", "0"),
                ("SLURM_ARRAY_TASK_MAX", "7"),
                ("SLURM_ARRAY_TASK_COUNT", "8"),
            ]),
            None,
        )
        .unwrap();
        assert_eq!((s.k, s.n, s.scheduler.kind.as_str()), (3, 8, "slurm"));
        let s = detect(
            &env(&[
                ("SLURM_ARRAY_TASK_ID", "1"),
                ("SLURM_ARRAY_TASK_MIN", "1"),
                ("SLURM_ARRAY_TASK_COUNT", "4"),
            ]),
            None,
        )
        .unwrap();
        assert_eq!((s.k, s.n), (0, 4));
        assert_eq!(
            s.scheduler.resubmit(&[0, 3], 4),
            "resubmit with sbatch --array=1,4 --export=ALL,FXSHADE_SHARDS=4,FXSHADE_SHARD_BASE=1 \
             <shard script>"
        );
        // LSF counts from 1.
        let s = detect(
            &env(&[("LSB_JOBINDEX", "8"), ("LSB_JOBINDEX_END", "8")]),
            None,
        )
        .unwrap();
        assert_eq!((s.k, s.n), (7, 8));
        assert!(s.scheduler.resubmit(&[7], 8).contains("[8]"));
        // Grid Engine with a step.
        let s = detect(
            &env(&[
                ("SGE_TASK_ID", "5"),
                ("SGE_TASK_FIRST", "1"),
                ("SGE_TASK_LAST", "9"),
                ("SGE_TASK_STEPSIZE", "2"),
            ]),
            None,
        )
        .unwrap();
        assert_eq!((s.k, s.n), (2, 5));
        // Kubernetes needs --shards.
        assert!(detect(&env(&[("JOB_COMPLETION_INDEX", "2")]), None)
            .unwrap_err()
            .contains("--shards"));
        let s = detect(&env(&[("JOB_COMPLETION_INDEX", "2")]), Some(4)).unwrap();
        assert_eq!((s.k, s.n), (2, 4));
        // FXSHADE_SHARD.
        let s = detect(&env(&[("FXSHADE_SHARD", "1/3")]), None).unwrap();
        assert_eq!((s.k, s.n), (1, 3));
    }

    /// A resubmitted subset keeps its shard numbers: the resubmit line's
    /// array and variables, read back, name the same shards.
    #[test]
    fn a_resubmitted_subset_keeps_its_shard_numbers() {
        for (min, count) in [(0i64, 8usize), (1, 8)] {
            let orig = Scheduler::new("slurm", min, 1);
            let line = orig.resubmit(&[3, 7], count);
            let array = line
                .split("--array=")
                .nth(1)
                .unwrap()
                .split(' ')
                .next()
                .unwrap();
            let mut vars: Vec<(String, String)> = line
                .split("--export=ALL,")
                .nth(1)
                .unwrap()
                .split(' ')
                .next()
                .unwrap()
                .split(',')
                .map(|kv| {
                    let (k, v) = kv.split_once('=').unwrap();
                    (k.to_string(), v.to_string())
                })
                .collect();
            let ids: Vec<&str> = array.split(',').collect();
            let mut got = Vec::new();
            for id in &ids {
                // What Slurm sets for `--array=3,7`: an uneven array.
                let mut e = vars.clone();
                e.extend([
                    ("SLURM_ARRAY_TASK_ID".into(), id.to_string()),
                    ("SLURM_ARRAY_TASK_MIN".into(), ids[0].to_string()),
                    ("SLURM_ARRAY_TASK_MAX".into(), ids[1].to_string()),
                    ("SLURM_ARRAY_TASK_COUNT".into(), "2".into()),
                ]);
                let s = detect(&e.into_iter().collect(), None).unwrap();
                got.push((s.k, s.n));
            }
            assert_eq!(got, vec![(3, count), (7, count)], "{line}");
            vars.clear();
        }
        // --shards and FXSHADE_SHARDS must agree.
        let e = detect(
            &env(&[("FXSHADE_SHARDS", "4"), ("JOB_COMPLETION_INDEX", "1")]),
            Some(5),
        )
        .unwrap_err();
        assert!(e.contains("disagree"), "{e}");
        // An index beyond N is refused.
        let e = detect(&env(&[("JOB_COMPLETION_INDEX", "4")]), Some(4)).unwrap_err();
        assert!(e.contains("not 0 ≤ K < N"), "{e}");
    }

    #[test]
    fn none_disagreeing_or_broken_arrays_are_refused() {
        assert!(detect(&env(&[]), None)
            .unwrap_err()
            .contains("no job array"));
        let e = detect(
            &env(&[
                ("FXSHADE_SHARD", "0/4"),
                ("SLURM_ARRAY_TASK_ID", "2"),
                ("SLURM_ARRAY_TASK_MIN", "0"),
                ("SLURM_ARRAY_TASK_COUNT", "4"),
            ]),
            None,
        )
        .unwrap_err();
        assert!(e.contains("disagree"), "{e}");
        // The same shard from two sources is fine.
        detect(
            &env(&[
                ("FXSHADE_SHARD", "2/4"),
                ("SLURM_ARRAY_TASK_ID", "2"),
                ("SLURM_ARRAY_TASK_MIN", "0"),
                ("SLURM_ARRAY_TASK_COUNT", "4"),
            ]),
            None,
        )
        .unwrap();
        // A Slurm array with holes (--array=0,2,5).
        let e = detect(
            &env(&[
                ("SLURM_ARRAY_TASK_ID", "2"),
                ("SLURM_ARRAY_TASK_MIN", "0"),
                ("SLURM_ARRAY_TASK_MAX", "5"),
                ("SLURM_ARRAY_TASK_COUNT", "3"),
            ]),
            None,
        )
        .unwrap_err();
        assert!(e.contains("evenly spaced"), "{e}");
        assert!(detect(&env(&[("SGE_TASK_ID", "undefined")]), None)
            .unwrap_err()
            .contains("no job array"));
        assert!(detect(&env(&[("SLURM_ARRAY_TASK_ID", "1")]), None)
            .unwrap_err()
            .contains("SLURM_ARRAY_TASK_MIN"));
        // LSB_JOBINDEX=0: not an array job.
        assert!(detect(&env(&[("LSB_JOBINDEX", "0")]), None)
            .unwrap_err()
            .contains("no job array"));
    }
}
