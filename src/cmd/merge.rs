//! `fxshade merge <rtl-check JSON>…`: add up the shards of one regression.

use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::Args;

use super::rtl_check::RunSummary;
use crate::output::{emit, OutputArgs, Table};

/// `fxshade merge`
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The `--json` outputs of `fxshade rtl-check --shard K/N`, one per
    /// shard (all N of them).
    #[arg(required = true, value_name = "FILE")]
    files: Vec<PathBuf>,
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
}

/// Check that `shards` (file, its `(K, N)`) are every shard of one split,
/// each once: errors name the files. Returns N.
pub fn check_shards(shards: &[(PathBuf, Option<(usize, usize)>)]) -> anyhow::Result<usize> {
    let Some((f0, first)) = shards.first() else {
        bail!("no shard given");
    };
    let Some((_, n)) = *first else {
        bail!("{}: a run without --shard", f0.display());
    };
    let mut seen = vec![None::<&PathBuf>; n];
    for (f, shard) in shards {
        let Some((k, nk)) = *shard else {
            bail!("{}: a run without --shard", f.display());
        };
        if nk != n {
            bail!(
                "{}: shard {k}/{nk}, but {} is one of {n}",
                f.display(),
                f0.display()
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
    let missing: Vec<String> = (0..n)
        .filter(|&k| seen[k].is_none())
        .map(|k| format!("{k}/{n}"))
        .collect();
    if !missing.is_empty() {
        bail!("shards missing: {}", missing.join(", "));
    }
    Ok(n)
}

/// Run it: exit status 0 only when every shard is there, they belong to
/// one run, and every vector passed.
pub fn run(a: &MergeArgs) -> anyhow::Result<()> {
    let mut runs = Vec::new();
    for f in &a.files {
        let text = fxshade_model::files::read_text_limited(f)
            .map_err(|e| crate::output::UsageError(format!("{}: cannot read: {e}", f.display())))?;
        let r: RunSummary = serde_json::from_str(&text).with_context(|| {
            format!(
                "{}: not the --json output of `fxshade rtl-check --shard K/N`",
                f.display()
            )
        })?;
        runs.push((f.clone(), r));
    }
    let (f0, r0) = &runs[0];
    if r0.shard.is_none() {
        bail!(
            "{}: a run without --shard; merge takes the shards of one run",
            f0.display()
        );
    }
    for (f, r) in &runs {
        for (what, a, b) in [
            ("unit", &r.unit, &r0.unit),
            ("variant", &r.variant, &r0.variant),
            ("configuration", &r.config_hash, &r0.config_hash),
            ("simulator", &r.sim, &r0.sim),
        ] {
            if a != b {
                bail!(
                    "{}: {what} {a}, but {} has {b}: not shards of one run",
                    f.display(),
                    f0.display()
                );
            }
        }
        if r.seed != r0.seed || r.total != r0.total {
            bail!(
                "{}: seed {} and {} vectors, but {} has seed {} and {}: not shards of one run",
                f.display(),
                r.seed,
                r.total,
                f0.display(),
                r0.seed,
                r0.total
            );
        }
    }
    let n = check_shards(
        &runs
            .iter()
            .map(|(f, r)| (f.clone(), r.shard))
            .collect::<Vec<_>>(),
    )?;
    let checked: usize = runs.iter().map(|(_, r)| r.count).sum();
    anyhow::ensure!(
        checked == r0.total,
        "the shards cover {checked} vectors of {}",
        r0.total
    );
    let m = Merged {
        unit: r0.unit.clone(),
        variant: r0.variant.clone(),
        config_hash: r0.config_hash.clone(),
        seed: r0.seed,
        shards: n,
        total: r0.total,
        passed: runs.iter().map(|(_, r)| r.passed).sum(),
        failed: runs.iter().map(|(_, r)| r.failed).sum(),
    };
    let mut t =
        Table::new(["unit", "variant", "shards", "vectors", "passed", "failed"]).titled(format!(
            "merged rtl-check, configuration {}, seed {}",
            m.config_hash, m.seed
        ));
    t.row([
        m.unit.clone(),
        m.variant.clone(),
        n.to_string(),
        m.total.to_string(),
        m.passed.to_string(),
        m.failed.to_string(),
    ]);
    emit(a.out, &[t], &serde_json::to_value(&m)?)?;
    anyhow::ensure!(
        m.failed == 0 && m.passed == m.total as u64,
        "{} of {} vectors failed",
        m.total as u64 - m.passed.min(m.total as u64),
        m.total
    );
    Ok(())
}
