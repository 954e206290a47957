//! Issue #32 on a live Slurm: Debian's slurmctld, slurmd and munge started
//! single-node on this machine (`scripts/cluster/slurm/local-cluster.sh`,
//! which `./scripts/test` installs the packages for), the templates
//! submitted as a user would, and the daemons stopped by their pids at the
//! end whatever happens.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common::*;

const BIN: &str = env!("CARGO_BIN_EXE_fxshade");

fn slurm_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/cluster/slurm")
}

/// A single-node Slurm, stopped when dropped.
struct Cluster {
    dir: tempfile::TempDir,
    conf: PathBuf,
    cache: PathBuf,
    work: PathBuf,
}

impl Cluster {
    fn start() -> Cluster {
        // SAFETY: getuid has no preconditions.
        let root = unsafe { libc::getuid() } == 0;
        assert!(
            root,
            "the live Slurm test starts slurmctld and slurmd, which needs root here: run \
             ./scripts/test as root (it installs slurmctld slurmd slurm-client munge)"
        );
        let dir = tempfile::tempdir().unwrap();
        let o = Command::new(slurm_dir().join("local-cluster.sh"))
            .arg("start")
            .arg(dir.path().join("slurm"))
            .output()
            .unwrap();
        let conf = dir.path().join("slurm/slurm.conf");
        let c = Cluster {
            cache: dir.path().join("cache"),
            work: dir.path().join("work"),
            conf,
            dir,
        };
        assert!(o.status.success(), "Slurm did not start: {}", text(&o));
        std::fs::create_dir_all(&c.work).unwrap();
        c
    }

    /// A Slurm command or a template, run from the work directory with the
    /// cluster's configuration, the scratch cache and this fxshade.
    fn cmd(&self, program: impl AsRef<std::ffi::OsStr>) -> Command {
        let mut c = Command::new(program);
        c.current_dir(&self.work)
            .env("SLURM_CONF", &self.conf)
            .env("FXSHADE", BIN)
            .env("FXSHADE_CACHE_DIR", &self.cache);
        c
    }

    fn run(&self, c: &mut Command) -> Output {
        let o = c.output().unwrap();
        assert!(o.status.success(), "{c:?}: {}", text(&o));
        o
    }

    /// Wait until job `id` (and everything before it) has left the queue;
    /// its state and exit code (`COMPLETED`, `0:0`). The bound (an hour,
    /// far beyond any load) only turns a stuck cluster into a failure with
    /// its logs.
    fn wait(&self, id: &str) -> (String, String) {
        for _ in 0..18_000 {
            let o = self.run(self.cmd("squeue").args(["-h", "-o", "%i"]));
            if String::from_utf8_lossy(&o.stdout).trim().is_empty() {
                let o = self.run(self.cmd("scontrol").args(["show", "job", id]));
                let s = String::from_utf8_lossy(&o.stdout).into_owned();
                let field = |k: &str| {
                    s.split_whitespace()
                        .find_map(|w| w.strip_prefix(k))
                        .unwrap_or("?")
                        .to_string()
                };
                return (field("JobState="), field("ExitCode="));
            }
            std::thread::sleep(std::time::Duration::from_millis(200));
        }
        panic!("job {id} did not finish in an hour: {}", self.logs());
    }

    fn logs(&self) -> String {
        let mut s = String::new();
        for f in ["slurmctld.log", "slurmd.log"] {
            let t = std::fs::read_to_string(self.dir.path().join("slurm/log").join(f))
                .unwrap_or_default();
            let tail: Vec<&str> = t.lines().rev().take(20).collect();
            s += &format!(
                "\n{f}:\n{}",
                tail.into_iter().rev().collect::<Vec<_>>().join("\n")
            );
        }
        s
    }

    /// A job's output file (`fxshade-merge-<id>.out`).
    fn output(&self, name: &str) -> String {
        std::fs::read_to_string(self.work.join(name)).unwrap_or_default()
    }

    /// `submit.sh N RESULTS ARGS…`: the merge job's id.
    fn submit(&self, n: usize, results: &Path, args: &[&str], fxshade: &Path) -> String {
        let o = self.run(
            self.cmd(slurm_dir().join("submit.sh"))
                .env("FXSHADE", fxshade)
                .arg(n.to_string())
                .arg(results)
                .args(args),
        );
        String::from_utf8_lossy(&o.stdout).trim().to_string()
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new(slurm_dir().join("local-cluster.sh"))
            .arg("stop")
            .arg(self.dir.path().join("slurm"))
            .output();
    }
}

/// `points.csv` without its `seconds` and `cached` columns (how long a
/// point took is not a result).
fn results_of(csv: &Path) -> String {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let keep: Vec<usize> = (0..header.len())
        .filter(|&i| header[i] != "seconds" && header[i] != "cached")
        .collect();
    std::iter::once(header.clone())
        .chain(lines.map(|l| l.split(',').collect()))
        .map(|cells: Vec<&str>| keep.iter().map(|&i| cells[i]).collect::<Vec<_>>().join(","))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn regressions_and_sweeps_run_on_a_live_slurm() {
    let c = Cluster::start();
    let args = ["normalize", "--count", "2000", "--seed", "3"];

    // 1. prebuild, a 4-task array and its merge: the verdict passes.
    let good = c.work.join("good");
    let id = c.submit(4, &good, &args, Path::new(BIN));
    let (state, code) = c.wait(&id);
    let out = c.output(&format!("fxshade-merge-{id}.out"));
    assert_eq!(
        (state.as_str(), code.as_str()),
        ("COMPLETED", "0:0"),
        "{out}{}",
        c.logs()
    );
    assert!(out.contains("2000      2000     2000        0"), "{out}");
    // The prebuild built the simulator once; every shard found it built.
    for k in 0..4 {
        let j: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(good.join(format!("shard-{k}-of-4.json"))).unwrap(),
        )
        .unwrap();
        assert_eq!(j["build_seconds"], 0.0, "shard {k} built again");
        assert_eq!(j["scheduler"]["kind"], "slurm");
        assert_eq!(j["design_fingerprint"].as_str().unwrap().len(), 64);
    }

    // 2. A shard that dies (its node crashed: no result) does not leave the
    // merge pending: it runs, fails, and says how to resubmit; the line it
    // gives, run as printed, completes the regression.
    let flaky = c.work.join("flaky-fxshade");
    let healed = c.work.join("healed");
    std::fs::write(
        &flaky,
        format!(
            "#!/bin/sh\nif [ \"$SLURM_ARRAY_TASK_ID\" = 2 ] && [ ! -e {} ]; then exit 1; fi\n\
             exec {BIN} \"$@\"\n",
            healed.display()
        ),
    )
    .unwrap();
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&flaky, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    let bad = c.work.join("bad");
    let id = c.submit(4, &bad, &args, &flaky);
    let (state, code) = c.wait(&id);
    let out = c.output(&format!("fxshade-merge-{id}.out"));
    assert_eq!((state.as_str(), code.as_str()), ("FAILED", "1:0"), "{out}");
    let want = "missing 2/4: resubmit with sbatch --array=2 --export=ALL,FXSHADE_SHARDS=4 \
                <shard script>";
    assert!(out.contains(want), "{out}");
    std::fs::write(&healed, "").unwrap();
    let line = want.split_once("resubmit with ").unwrap().1;
    let mut words: Vec<String> = shlex::split(line).unwrap();
    words.truncate(words.len() - 2); // `<shard script>`
    let shard = slurm_dir().join("shard.sbatch");
    let o = c.run(
        c.cmd(&words[0])
            .args(&words[1..])
            .arg("--parsable")
            .env("FXSHADE", &flaky)
            .arg(&shard)
            .arg(&bad)
            .args(args),
    );
    let again = String::from_utf8_lossy(&o.stdout).trim().to_string();
    assert_eq!(c.wait(&again).0, "COMPLETED", "{}", c.logs());
    let o = fxshade(&["merge", bad.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));

    // 3. A shard of another configuration, run as a job step, is refused
    // and named.
    let mixed = c.work.join("mixed");
    std::fs::create_dir_all(&mixed).unwrap();
    for k in [0, 2, 3] {
        let f = format!("shard-{k}-of-4.json");
        std::fs::copy(good.join(&f), mixed.join(&f)).unwrap();
    }
    c.run(
        c.cmd("srun")
            .args(["-N1", "-n1", "--quiet", BIN, "rtl-check"])
            .args(args)
            .args([
                "--set",
                "normalize.theta=0.5",
                "--shard",
                "1/4",
                "--jobs",
                "1",
            ])
            .arg("--result")
            .arg(&mixed),
    );
    let o = fxshade(&["merge", mixed.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("shard-1-of-4.json: design")
            && text(&o).contains("not shards of one run"),
        "{}",
        text(&o)
    );

    // 4. A prebuild that fails cancels the array instead of leaving it
    // pending, and the merge still runs and says no shard ran.
    let none = c.work.join("none");
    let id = c.submit(
        4,
        &none,
        &["normalize", "--sim", "nonesuch"],
        Path::new(BIN),
    );
    let (state, _) = c.wait(&id);
    let out = c.output(&format!("fxshade-merge-{id}.out"));
    assert_eq!(state, "FAILED", "{out}");
    assert!(out.contains("no *.json result in it"), "{out}");

    // 5. A sweep whose points run as `srun` job steps gives the local
    // sweep's points.
    let sweep = [
        "explore",
        "--vary",
        "polar.table_bits=7..9",
        "--analyses",
        "polar",
    ];
    let local = c.work.join("local");
    let o = c.run(
        c.cmd(BIN)
            .args(sweep)
            .args(["--no-cache", "--out"])
            .arg(&local),
    );
    drop(o);
    let remote = c.work.join("remote");
    c.run(
        c.cmd(BIN)
            .args(sweep)
            .args([
                "--no-cache",
                "--launcher",
                "srun -N1 -n1 --quiet",
                "--jobs",
                "2",
                "--out",
            ])
            .arg(&remote),
    );
    assert_eq!(
        results_of(&remote.join("points.csv")),
        results_of(&local.join("points.csv"))
    );
}

/// Every job-array variable a scheduler may have set, removed so a test
/// run inside a job array sees only what it sets.
const ARRAY_VARS: [&str; 16] = [
    "SLURM_ARRAY_TASK_ID",
    "SLURM_ARRAY_TASK_MIN",
    "SLURM_ARRAY_TASK_MAX",
    "SLURM_ARRAY_TASK_COUNT",
    "SLURM_ARRAY_TASK_STEP",
    "LSB_JOBINDEX",
    "LSB_JOBINDEX_END",
    "LSB_JOBINDEX_STEP",
    "SGE_TASK_ID",
    "SGE_TASK_FIRST",
    "SGE_TASK_LAST",
    "SGE_TASK_STEPSIZE",
    "JOB_COMPLETION_INDEX",
    "FXSHADE_SHARD",
    "FXSHADE_SHARDS",
    "FXSHADE_SHARD_BASE",
];

fn fx_env(env: &[(&str, &str)], args: &[&str]) -> Output {
    let mut c = Command::new(BIN);
    for v in ARRAY_VARS {
        c.env_remove(v);
    }
    c.envs(env.iter().copied()).args(args).output().unwrap()
}

/// `--shard auto` takes the slice each scheduler's variables name (the
/// same vectors as `--shard K/N`), refuses none and disagreement, and a
/// merge names a stopped shard and resubmits it in its scheduler's terms.
#[test]
fn shard_auto_reads_every_scheduler() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = |d: &Path| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(d.join("manifest.json")).unwrap()).unwrap()
    };
    // (variables, extra flags, the shard they name)
    type Case<'a> = (&'a [(&'a str, &'a str)], &'a [&'a str], (u64, u64));
    let cases: [Case; 6] = [
        (
            &[
                ("SLURM_ARRAY_TASK_ID", "3"),
                ("SLURM_ARRAY_TASK_MIN", "1"),
                ("SLURM_ARRAY_TASK_MAX", "4"),
                ("SLURM_ARRAY_TASK_COUNT", "4"),
            ],
            &[],
            (2, 4),
        ),
        (
            &[("LSB_JOBINDEX", "1"), ("LSB_JOBINDEX_END", "3")],
            &[],
            (0, 3),
        ),
        (
            &[
                ("SGE_TASK_ID", "4"),
                ("SGE_TASK_FIRST", "2"),
                ("SGE_TASK_LAST", "6"),
                ("SGE_TASK_STEPSIZE", "2"),
            ],
            &[],
            (1, 3),
        ),
        (&[("JOB_COMPLETION_INDEX", "4")], &["--shards", "5"], (4, 5)),
        (&[("FXSHADE_SHARD", "1/2")], &[], (1, 2)),
        // A resubmitted subset: the task id is the shard.
        (
            &[
                ("SLURM_ARRAY_TASK_ID", "7"),
                ("SLURM_ARRAY_TASK_MIN", "3"),
                ("SLURM_ARRAY_TASK_MAX", "7"),
                ("SLURM_ARRAY_TASK_COUNT", "2"),
                ("FXSHADE_SHARDS", "8"),
            ],
            &[],
            (7, 8),
        ),
    ];
    for (i, (env, extra, (k, n))) in cases.iter().enumerate() {
        let auto = dir.path().join(format!("auto{i}"));
        let given = dir.path().join(format!("given{i}"));
        let mut a = vec![
            "vectors",
            "normalize",
            "--count",
            "800",
            "--no-hex",
            "--shard",
            "auto",
        ];
        a.extend(*extra);
        a.extend(["--out", auto.to_str().unwrap()]);
        let o = fx_env(env, &a);
        assert!(o.status.success(), "{env:?}: {}", text(&o));
        let kn = format!("{k}/{n}");
        let o = fx_env(
            &[],
            &[
                "vectors",
                "normalize",
                "--count",
                "800",
                "--no-hex",
                "--shard",
                &kn,
                "--out",
                given.to_str().unwrap(),
            ],
        );
        assert!(o.status.success(), "{}", text(&o));
        for f in ["inputs.bin", "expected.bin"] {
            assert!(
                std::fs::read(auto.join(f)).unwrap() == std::fs::read(given.join(f)).unwrap(),
                "{env:?}: {f} differs from --shard {kn}"
            );
        }
        assert_eq!(manifest(&auto)["first"], manifest(&given)["first"]);
    }
    // None set, two that disagree, --shards without auto: usage errors.
    let out = dir.path().join("x");
    let out = out.to_str().unwrap();
    for (env, args, says) in [
        (
            &[][..],
            &["vectors", "normalize", "--shard", "auto", "--out", out][..],
            "no job array is set",
        ),
        (
            &[
                ("FXSHADE_SHARD", "0/2"),
                ("LSB_JOBINDEX", "2"),
                ("LSB_JOBINDEX_END", "2"),
            ][..],
            &["vectors", "normalize", "--shard", "auto", "--out", out][..],
            "disagree",
        ),
        (
            &[("JOB_COMPLETION_INDEX", "0")][..],
            &["rtl-check", "normalize", "--shard", "auto"][..],
            "give --shards N",
        ),
        (
            &[][..],
            &["rtl-check", "normalize", "--shard", "0/2", "--shards", "2"][..],
            "--shards N goes with --shard auto",
        ),
    ] {
        let o = fx_env(env, args);
        assert_eq!(o.status.code(), Some(2), "{env:?} {args:?}: {}", text(&o));
        assert!(text(&o).contains(says), "{env:?} {args:?}: {}", text(&o));
        assert!(!Path::new(out).exists());
    }
    // LSF shards of a run, one of which stopped with an error: the merge
    // reports the error and the bsub line, 1-based.
    let res = dir.path().join("results");
    for k in 1..=3 {
        let idx = k.to_string();
        let mut a = vec!["rtl-check", "normalize", "--count", "300", "--jobs", "1"];
        a.extend(["--shard", "auto", "--result", res.to_str().unwrap()]);
        if k == 2 {
            a.extend(["--rtl-dir", "/nonexistent/rtl"]);
        }
        let o = fx_env(&[("LSB_JOBINDEX", &idx), ("LSB_JOBINDEX_END", "3")], &a);
        assert_eq!(o.status.success(), k != 2, "{}", text(&o));
    }
    let o = fx_env(&[], &["merge", res.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let t = text(&o);
    assert!(
        t.contains("shard 1/3 stopped with an error: cannot read --rtl-dir"),
        "{t}"
    );
    assert!(
        t.contains("resubmit with bsub -J \"<name>[2]\" -env \"all,FXSHADE_SHARDS=3\""),
        "{t}"
    );
}

/// A point whose launch fails fails the sweep (nothing written, nothing
/// cached), a shard numbered beyond its count is refused without a panic,
/// and shard counts that disagree are refused.
#[test]
fn failed_launches_and_impossible_shards_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let sweep = |out: &Path, extra: &[&str]| {
        let mut c = Command::new(BIN);
        for v in ARRAY_VARS {
            c.env_remove(v);
        }
        c.args([
            "explore",
            "--vary",
            "polar.table_bits=7..8",
            "--analyses",
            "polar",
        ])
        .arg("--cache")
        .arg(&cache)
        .args(extra)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
    };
    let out = dir.path().join("failed");
    let o = sweep(
        &out,
        &[
            "--launcher",
            "false",
            "--launch-dir",
            dir.path().to_str().unwrap(),
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("2 points could not be launched"),
        "{}",
        text(&o)
    );
    assert!(!out.exists(), "a failed sweep wrote {}", out.display());
    // Nothing was cached: the local run measures both points.
    let o = sweep(&dir.path().join("local"), &["--shard", "0/2"]);
    assert!(o.status.success(), "{}", text(&o));
    // No job directory is left behind.
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| {
            e.file_name()
                .to_string_lossy()
                .starts_with(".fxshade-launch-")
        })
        .collect();
    assert!(left.is_empty(), "{left:?}");
    // A shard [4, 4] (edited) is refused by name.
    let f = dir.path().join("local/explore.json");
    let mut j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
    j["shard"] = serde_json::json!([4, 4]);
    std::fs::write(&f, j.to_string()).unwrap();
    let o = fx_env(
        &[],
        &[
            "explore",
            "--merge",
            f.to_str().unwrap(),
            "--out",
            dir.path().join("m").to_str().unwrap(),
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(!text(&o).contains("panicked"), "{}", text(&o));
    assert!(text(&o).contains("shard 4/4"), "{}", text(&o));
    // FXSHADE_SHARD's N against --shards.
    let o = fx_env(
        &[("FXSHADE_SHARD", "1/3"), ("FXSHADE_SHARDS", "4")],
        &["rtl-check", "normalize", "--shard", "auto"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("names 3 shards"), "{}", text(&o));
}
