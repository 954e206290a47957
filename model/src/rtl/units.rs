//! The units with RTL: one registry that the vector flow, `fxshade rtl`,
//! `rtl-check`, `ops --rtl`, the report and the tests iterate.
//!
//! Each entry names the unit, its variants (and the override selecting
//! each), how to build its traced [`Design`] from a configuration, and how
//! to draw its input vectors (corner cases first). Expected outputs and
//! overflow flags always come from the compiled trace, and the vector
//! layout from the emitted module's ports.

use super::{emit, Design, Emitted};
use crate::config::Config;
use crate::vectors::{RtlError, RtlSources, VectorSet};

/// Input rows (codes in the design's input-port order) and how many of them
/// are corner cases.
pub type Inputs = (Vec<Vec<i128>>, usize);

/// A unit with RTL.
pub struct RtlUnit {
    /// Name: configuration section (or scope), module, vector directory.
    pub name: &'static str,
    /// One line for people.
    pub doc: &'static str,
    /// Variants: name and the `--set` override selecting it.
    pub variants: &'static [(&'static str, &'static str)],
    /// The traced datapath of a configuration.
    pub design: fn(&Config) -> Result<Design, RtlError>,
    /// `count` input vectors for a seed, corner cases first.
    pub inputs: fn(&Config, usize, u64) -> Result<Inputs, RtlError>,
}

/// Every unit with RTL, in pipeline order, the pipeline top last: the
/// `rtl` modules of [`crate::units::UNITS`].
pub fn all() -> impl Iterator<Item = &'static RtlUnit> {
    crate::units::UNITS
        .iter()
        .flat_map(|u| u.rtl.iter().copied())
}

/// Look a unit up by name.
pub fn unit(name: &str) -> Option<&'static RtlUnit> {
    all().find(|u| u.name == name)
}

/// The names of every unit with RTL, for messages.
pub fn names() -> String {
    all().map(|u| u.name).collect::<Vec<_>>().join(", ")
}

/// Emit a unit for a configuration.
pub fn emit_unit(u: &RtlUnit, cfg: &Config) -> Result<(Design, Emitted), RtlError> {
    let d = (u.design)(cfg)?;
    let e = emit(&d)?;
    Ok((d, e))
}

/// The unit's test vectors: `count` inputs (corner cases first) and the
/// expected outputs and per-vector overflow flags of the compiled trace.
pub fn vectors(u: &RtlUnit, cfg: &Config, count: usize, seed: u64) -> Result<VectorSet, RtlError> {
    let (d, e) = emit_unit(u, cfg)?;
    let (rows, corners) = inputs(u, &d, cfg, count, seed)?;
    vector_set(&d, &e, rows, corners, seed)
}

/// Random inputs searched for mutant killers ([`inputs`]).
pub const MUTANT_POOL: usize = 16384;

/// The unit's input rows for `count` vectors: its own corner cases, then
/// the inputs that tell apart every mutant of the design
/// ([`super::mutants::killers`], searched among [`MUTANT_POOL`] random
/// inputs of another seed) which the corner cases do not, then its random
/// inputs. The corner part (returned count) does not depend on `count`.
pub fn inputs(
    u: &RtlUnit,
    d: &Design,
    cfg: &Config,
    count: usize,
    seed: u64,
) -> Result<(Vec<Vec<i128>>, usize), RtlError> {
    let (rows, corners) = (u.inputs)(cfg, count, seed)?;
    // Half the pool from the unit's own distribution, half codes over every
    // input's whole range with random trailing zeros (rounding ties and
    // overflows live there).
    let (pool, pc) = (u.inputs)(cfg, corners + MUTANT_POOL / 2, seed ^ 0x6d75_7461_6e74)?;
    let mut pool = pool[pc..].to_vec();
    let mut rng = crate::sampling::Rng::new(seed ^ 0x7469_6573);
    let formats: Vec<_> = d.trace.input_ports().iter().map(|p| p.format).collect();
    for _ in 0..MUTANT_POOL / 2 {
        pool.push(
            formats
                .iter()
                .map(|&f| crate::vectors::structured_code(f, &mut rng))
                .collect(),
        );
    }
    let (mut killers, missed) = super::mutants::killers(d, &rows[..corners], &pool)?;
    let (more, _missed) = super::mutants::directed_killers(d, &missed, seed)?;
    killers.extend(more);
    let n = corners + killers.len();
    if count < n {
        return Err(RtlError::Count { count, corners: n });
    }
    let mut out = Vec::with_capacity(count);
    out.extend_from_slice(&rows[..corners]);
    out.extend(killers);
    out.extend(rows[corners..].iter().take(count - n).cloned());
    Ok((out, n))
}

/// A vector set from input rows: outputs and flags from the compiled trace,
/// fields from the emitted ports.
pub fn vector_set(
    d: &Design,
    e: &Emitted,
    rows: Vec<Vec<i128>>,
    corners: usize,
    seed: u64,
) -> Result<VectorSet, RtlError> {
    let outs: Vec<_> = d.trace.output_ports().iter().map(|p| p.value).collect();
    let prog = crate::datapath::Compiled::compile(&d.trace, &outs)?;
    assert_eq!(
        prog.flag_stages(),
        e.flags.as_slice(),
        "the compiled trace and the emitted module flag the same stages"
    );
    let n_in = e.inputs.len();
    for (i, r) in rows.iter().enumerate() {
        for (f, &c) in e.inputs.iter().zip(r) {
            if !(f.format.min_code()..=f.format.max_code()).contains(&c) {
                return Err(RtlError::Stage {
                    unit: d.unit,
                    stage: "inputs",
                    why: format!(
                        "vector {i}: code {c} of field {} lies outside {}",
                        f.name, f.format
                    ),
                });
            }
        }
    }
    let cols: Vec<Vec<i128>> = (0..n_in)
        .map(|k| rows.iter().map(|r| r[k]).collect())
        .collect();
    let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
    let (res, flags) = prog.run_flags_i128(&refs);
    let nf = e.flags.len();
    let output_rows = (0..rows.len())
        .map(|i| {
            let mut r = Vec::with_capacity(res.len() + 1);
            if nf > 0 {
                // Stage k is bit nf−1−k of the flag field.
                let f = flags[i];
                let v = (0..nf).fold(0i128, |acc, k| {
                    acc | ((((f >> k) & 1) as i128) << (nf - 1 - k))
                });
                r.push(v);
            }
            r.extend(res.iter().map(|o| o[i]));
            r
        })
        .collect();
    Ok(VectorSet {
        unit: d.unit,
        variant: d.variant.clone(),
        config_source: d.config_source.clone(),
        config_toml: d.config_toml.clone(),
        seed,
        inputs: e.inputs.clone(),
        outputs: e.outputs.clone(),
        input_rows: rows,
        output_rows,
        rtl: RtlSources {
            module: e.module.clone(),
            verilog: e.verilog.clone(),
            testbench: e.testbench.clone(),
            latency: e.latency,
        },
        corner_cases: corners,
        flags: e.flags.clone(),
    })
}

impl Design {
    /// A design of `unit` for `cfg`.
    pub fn new(
        unit: &'static str,
        variant: &str,
        trace: crate::datapath::Trace,
        cfg: &Config,
        notes: Vec<String>,
    ) -> Design {
        let mut source = cfg.source.clone();
        if !cfg.overrides.is_empty() {
            source += &format!(", overrides: {}", cfg.overrides.join(" "));
        }
        Design {
            module: unit.to_string(),
            unit,
            variant: variant.to_string(),
            trace,
            config_source: source,
            config_toml: cfg.to_toml(),
            notes,
        }
    }
}
