//! `fxshade vectors <unit>`: test vectors, with the unit's generated
//! Verilog and testbench, for a configuration.

use fxshade_model::convert::{narrow, to_f64};
use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use fxshade_model::files::StagedDir;
use fxshade_model::rtl::units::VectorStream;
use fxshade_model::vectors::write_set;
use fxshade_model::writers::{self, VectorWriter};

use super::ConfigArgs;

/// `fxshade vectors`
#[derive(Args, Debug)]
pub struct VectorsArgs {
    /// The unit.
    #[arg(value_parser = super::unit_arg(&[]))]
    unit: String,
    #[command(flatten)]
    cfg: ConfigArgs,
    /// Number of vectors in the whole stream (corner cases first, then
    /// random; written as they are generated: memory does not grow with it).
    #[arg(long, default_value_t = 10_000)]
    count: usize,
    /// Seed of the random vectors: the same seed gives identical files.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// `--shard K/N|auto`: write only shard K of N (0-based), a
    /// deterministic, disjoint slice of the same stream (its records carry
    /// their stream indices; the manifest says `first` and `total`).
    #[command(flatten)]
    shard: crate::shard_args::ShardArgs,
    /// Leave out `inputs.hex` and `expected.hex` (the testbench reads the
    /// binary records; the text files are for people and `$readmemh`).
    #[arg(long)]
    no_hex: bool,
    /// Output directory (replaced as a whole when the set is complete; a
    /// non-empty directory fxshade did not write is refused).
    #[arg(long, short = 'o', value_name = "DIR")]
    out: PathBuf,
    /// Replace `--out` even when it holds files fxshade did not write.
    #[arg(long)]
    force: bool,
    /// Also write `<module>.core`, a FuseSoC CAPI2 core of the directory
    /// (`fxshade:<unit>:<variant>_<config hash>:<fxshade version>`; filesets for the module,
    /// the testbench and the vectors; targets `sim` on Icarus and `lint` on
    /// Verilator): `fusesoc --cores-root DIR run --target sim NAME`.
    #[arg(long)]
    core: bool,
}

/// Bytes free for an unprivileged user on the file system holding `dir`.
fn free_bytes(dir: &Path) -> Option<u64> {
    let c = std::ffi::CString::new(dir.as_os_str().as_encoded_bytes()).ok()?;
    // SAFETY: statvfs writes into the struct we pass; the path is a valid C
    // string.
    unsafe {
        let mut s: libc::statvfs = std::mem::zeroed();
        (libc::statvfs(c.as_ptr(), &mut s) == 0).then(|| s.f_bavail as u64 * s.f_frsize as u64)
    }
}

/// Run it.
pub fn run(a: &VectorsArgs) -> anyhow::Result<()> {
    let shard = a.shard.resolve()?.map(|s| (s.k, s.n));
    if a.core && shard.is_some() {
        return Err(crate::output::UsageError(
            "--core describes a whole vector set: leave out --shard".into(),
        )
        .into());
    }
    let u = crate::rtl_flow::unit(&a.unit)?;
    let cfg = a.cfg.resolve()?;
    let start = std::time::Instant::now();
    // Sizes first, before the search for mutant killers: the count, then
    // the disk space the records need.
    fxshade_model::rtl::units::check_total(a.count)
        .map_err(|e| crate::output::UsageError(e.to_string()))?;
    let (_, emitted) = fxshade_model::rtl::units::emit_unit(u, &cfg)?;
    // The formats written: the binary records always (the testbench
    // reads them), the others unless left out.
    let writers: Vec<&dyn VectorWriter> = writers::WRITERS
        .iter()
        .copied()
        .filter(|w| !(a.no_hex && w.name() == "hex"))
        .collect();
    let per: usize = writers
        .iter()
        .map(|w| w.record_bytes(&emitted.inputs) + w.record_bytes(&emitted.outputs))
        .sum();
    let count = match shard {
        Some((k, n)) => narrow::<u64, _>(
            a.count as u128 * (k as u128 + 1) / n as u128 - a.count as u128 * k as u128 / n as u128,
        ),
        None => a.count as u64,
    };
    // At most 2^32 records of at most a few KiB: no overflow in u128.
    let need = u128::from(count) * per as u128 + (1 << 20);
    let parent = a
        .out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if let Some(free) = free_bytes(parent) {
        anyhow::ensure!(
            need <= u128::from(free),
            "{} vectors of {} need {:.2} GB ({per} bytes each{}), and the file system of {} has {:.2} GB free: nothing was written \
             (use --no-hex, fewer vectors, or --shard)",
            count,
            u.name,
            to_f64(need) / 1e9,
            if a.no_hex { "" } else { " with the hex files" },
            parent.display(),
            to_f64(free) / 1e9
        );
    }
    let d = if a.force {
        StagedDir::new_forced(&a.out)
    } else {
        StagedDir::new(&a.out)
    }
    .with_context(|| format!("cannot write the vectors to {}", a.out.display()))?;
    let s = VectorStream::new(u, &cfg, a.count, a.seed, shard, super::search_mode()?)?;
    let mut m = s.manifest();
    // A format not written has no files.
    for w in writers::WRITERS {
        if !writers.iter().any(|x| x.name() == w.name()) {
            for k in w.manifest_keys() {
                m["files"][k] = serde_json::Value::Null;
            }
        }
    }
    let bar = (s.count >= 1_000_000).then(|| crate::progress::bar(s.count as u64, "vectors"));
    write_set(
        &d,
        "",
        &s,
        &m,
        &s.design.config_toml,
        &s.rtl(),
        &writers,
        &mut |done| {
            if let Some(b) = &bar {
                b.set_position(done as u64);
            }
        },
    )
    .with_context(|| format!("cannot write the vectors to {}", a.out.display()))?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    if a.core {
        let core = fxshade_model::rtl::core::capi2(
            u.name,
            &s.design.variant,
            &s.emitted.module,
            s.design.config_hash(),
            Some(s.count),
        );
        d.write(&format!("{}.core", s.emitted.module), core.as_bytes())
            .with_context(|| format!("cannot write the vectors to {}", a.out.display()))?;
    }
    d.commit()
        .with_context(|| format!("cannot write the vectors to {}", a.out.display()))?;
    let secs = start.elapsed().as_secs_f64();
    crate::output::print_out(&format!(
        "{} vectors ({} corner cases){} of {} ({}) written to {} in {:.2} s ({:.0} vectors/s)\n",
        s.count,
        s.corners.len().saturating_sub(s.first).min(s.count),
        match shard {
            Some((k, n)) => format!(
                ", shard {k}/{n} = indices {}..{} of {}",
                s.first,
                s.first + s.count,
                s.total
            ),
            None => String::new(),
        },
        u.name,
        s.design.variant,
        a.out.display(),
        secs,
        to_f64(s.count) / secs.max(1e-9)
    ))
}
