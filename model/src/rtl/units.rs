//! The units with RTL: one registry that the vector flow, `fxshade rtl`,
//! `rtl-check`, `ops --rtl`, the report and the tests iterate.
//!
//! Each entry names the unit, its variants (and the override selecting
//! each), how to build its traced [`Design`] from a configuration, and how
//! to draw its input vectors (corner cases first). Expected outputs and
//! overflow flags always come from the compiled trace, and the vector
//! layout from the emitted module's ports.

use fxshade_numbers::convert::{narrow, to_f64};
pub use fxshade_units::rtl::units::*;

use super::search::Search;
use super::{emit, Design, Emitted};
use crate::config::Config;
use crate::format::Format;
use crate::vectors::{RtlSources, VectorSet, VectorSource as _};

/// Emit a unit for a configuration.
///
/// # Errors
///
/// The errors of [`RtlUnit::design`] for `cfg`; [`RtlError::Emit`] when the design cannot
/// be emitted ([`emit`]).
pub fn emit_unit(u: &RtlUnit, cfg: &Config) -> Result<(Design, Emitted), RtlError> {
    let d = u.design(cfg)?;
    let e = emit(&d)?;
    Ok((d, e))
}

/// The unit's test vectors: `count` inputs (corner cases first) and the
/// expected outputs and per-vector overflow flags of the compiled trace;
/// `search`: how thoroughly the corner part's mutant killers are searched
/// ([`corner_rows`]).
///
/// # Errors
///
/// [`RtlError::TooMany`] when `count` exceeds [`MAX_STREAM`] or its rows would not fit in
/// the memory `/proc/meminfo` says is available; the errors of [`emit_unit`], of
/// [`VectorStream::new`] (among them [`RtlError::Count`]) and of [`VectorStream::collect`].
pub fn vectors(
    u: &'static RtlUnit,
    cfg: &Config,
    count: usize,
    seed: u64,
    search: Search,
) -> Result<VectorSet, RtlError> {
    check_total(count)?;
    // Held in memory: refuse before any work when they cannot fit.
    let (d, _) = emit_unit(u, cfg)?;
    let fields = d.trace.input_ports().len() + d.trace.output_ports().len() + 1;
    let row = std::mem::size_of::<Vec<i128>>() * 2 + std::mem::size_of::<i128>() * fields;
    let need = (count as u128) * row as u128;
    if let Some(avail) = crate::files::memory_available() {
        if need > u128::from(avail) {
            return Err(RtlError::TooMany {
                count: count as u128,
                why: format!(
                    "held in memory they need {:.1} GB ({row} bytes each) and {:.1} GB is \
                     available",
                    to_f64(need) / 1e9,
                    to_f64(avail) / 1e9
                ),
            });
        }
    }
    VectorStream::new(u, cfg, count, seed, None, search)?.collect()
}

/// The most vectors a stream holds: their records' index field is 32 bits
/// wide, so index 2^32 would wrap to 0.
pub const MAX_STREAM: u64 = 1 << 32;

/// Refuse a stream of more than [`MAX_STREAM`] vectors.
///
/// # Errors
///
/// [`RtlError::TooMany`] when `total` exceeds [`MAX_STREAM`].
pub fn check_total(total: usize) -> Result<(), RtlError> {
    if total as u128 > u128::from(MAX_STREAM) {
        return Err(RtlError::TooMany {
            count: total as u128,
            why: format!(
                "a stream holds at most {MAX_STREAM} (2^32) vectors, the range of the records' \
                 32-bit index"
            ),
        });
    }
    Ok(())
}

/// Random inputs searched for mutant killers ([`corner_rows`]).
pub const MUTANT_POOL: usize = 16384;

/// Random rows are drawn in chunks of this many, chunk `c` from its own
/// seed ([`chunk_seed`]): any slice of a stream is generated without the
/// rows before it.
pub const RANDOM_CHUNK: usize = 4096;

/// The seed of random chunk `c` of a stream seeded `seed`.
pub fn chunk_seed(seed: u64, c: u64) -> u64 {
    crate::vectors::fingerprint(&[&seed.to_le_bytes(), &c.to_le_bytes(), b"chunk"])
}

/// The corner part of a unit's stream: its own corner cases, then the
/// inputs that tell apart every mutant of the design
/// ([`super::mutants::killers`], searched among [`MUTANT_POOL`] random
/// inputs of another seed, then [`super::mutants::directed_killers`], then
/// [`super::search::killers`], as thoroughly as `search` says) which the
/// corner cases do not. It does not depend on the count.
///
/// # Errors
///
/// The errors of [`unit_inputs`]; [`RtlError::Cache`] when the cache directory cannot be
/// used or a cached entry cannot be read or is not private (failing to write the entry is
/// not an error); the errors of [`super::mutants::killers`],
/// [`super::mutants::directed_killers`] and [`super::search::killers`].
pub fn corner_rows(
    u: &RtlUnit,
    d: &Design,
    cfg: &Config,
    seed: u64,
    search: Search,
) -> Result<Vec<Vec<i128>>, RtlError> {
    let formats: Vec<_> = d.trace.input_ports().iter().map(|p| p.format).collect();
    let mut rows = unit_inputs(u, cfg, Part::Corners, seed, &formats)?;
    // Half the pool from the unit's own distribution, half codes over every
    // input's whole range with random trailing zeros (rounding ties and
    // overflows live there).
    let mut pool = unit_inputs(
        u,
        cfg,
        Part::Random(MUTANT_POOL / 2),
        seed ^ 0x6d75_7461_6e74,
        &formats,
    )?;
    let mut rng = crate::sampling::Rng::new(seed ^ 0x7469_6573);
    for _ in 0..MUTANT_POOL / 2 {
        pool.push(
            formats
                .iter()
                .map(|&f| crate::vectors::structured_code(f, &mut rng))
                .collect(),
        );
    }
    let key = corner_key(d, &rows, &pool, seed, search);
    if let Some(found) = read_corner_cache(key, &formats)? {
        rows.extend(found);
        return Ok(rows);
    }
    let (killers, missed) = super::mutants::killers(d, &rows, &pool)?;
    let (more, missed) = super::mutants::directed_killers(d, &missed, seed)?;
    let (found, _missed) = super::search::killers(d, &missed, &pool, seed, search)?;
    let mut searched = killers;
    searched.extend(more);
    searched.extend(found);
    write_corner_cache(key, &searched)?;
    rows.extend(searched);
    Ok(rows)
}

/// The cache key of a unit's searched rows: a fingerprint of everything
/// they depend on — the traced design (operations, tables, ports), the
/// corner cases and the random pool, the seed, and the source of the
/// searches and the compiled arithmetic they run, so that a change to any
/// of them misses the cache.
fn corner_key(
    d: &Design,
    corners: &[Vec<i128>],
    pool: &[Vec<i128>],
    seed: u64,
    search: Search,
) -> u64 {
    // Tables by their contents (their `Debug` holds a function address).
    let tables: Vec<_> = d
        .trace
        .tables()
        .iter()
        .map(|t| (t.name, t.index, t.out, &t.codes, &t.storage))
        .collect();
    let design = format!(
        "{:?}{:?}{:?}{:?}",
        d.trace.ops(),
        tables,
        d.trace.input_ports(),
        d.trace.output_ports()
    );
    let rows = format!("{corners:?}{pool:?}");
    crate::vectors::fingerprint(&[
        env!("CARGO_PKG_VERSION").as_bytes(),
        include_str!("mutants.rs").as_bytes(),
        include_str!("search.rs").as_bytes(),
        include_str!("witness.rs").as_bytes(),
        include_str!("direction.rs").as_bytes(),
        include_str!("probe.rs").as_bytes(),
        include_str!("units.rs").as_bytes(),
        fxshade_ir::sources::BATCH.as_bytes(),
        fxshade_ir::sources::INTERVAL.as_bytes(),
        fxshade_ir::sources::CUT.as_bytes(),
        fxshade_numbers::QUANTIZE_SOURCE.as_bytes(),
        design.as_bytes(),
        rows.as_bytes(),
        &seed.to_le_bytes(),
        search.name().as_bytes(),
    ])
}

/// The file of a cache key: `<cache>/corners/<key>.txt`, one row per line
/// ([`crate::cache`]: a private directory of the user's own, or an error);
/// `None` when no cache is installed (the rows are searched every time).
fn corner_cache_file(key: u64) -> Result<Option<std::path::PathBuf>, RtlError> {
    match crate::cache::subdir("corners") {
        Ok(d) => Ok(Some(d.join(format!("{key:016x}.txt")))),
        Err(crate::cache::CacheError::NotInstalled) => Ok(None),
        Err(e) => Err(e.into()),
    }
}

/// The rows cached under `key`, if a whole, readable entry is there whose
/// rows are codes of `formats` (a cache entry someone else could have
/// written is an error, not a miss).
fn read_corner_cache(
    key: u64,
    formats: &[crate::format::Format],
) -> Result<Option<Vec<Vec<i128>>>, RtlError> {
    let Some(file) = corner_cache_file(key)? else {
        return Ok(None);
    };
    let Some(bytes) = crate::cache::read(&file)? else {
        return Ok(None);
    };
    let text = String::from_utf8_lossy(&bytes);
    let mut lines = text.lines();
    if lines.next() != Some("fxshade searched rows 1") {
        return Ok(None);
    }
    let mut rows = Vec::new();
    for l in lines {
        if l == "end" {
            return Ok(Some(rows));
        }
        let Some(row) = l
            .split(' ')
            .map(|c| c.parse::<i128>().ok())
            .collect::<Option<Vec<_>>>()
        else {
            return Ok(None);
        };
        let fits = row.len() == formats.len()
            && row
                .iter()
                .zip(formats)
                .all(|(&c, f)| (f.min_code()..=f.max_code()).contains(&c));
        if !fits {
            return Ok(None);
        }
        rows.push(row);
    }
    Ok(None)
}

/// Cache `rows` under `key` (whole or not at all). A full file system is
/// only a slower next run, so it is not an error; an unsafe cache is.
fn write_corner_cache(key: u64, rows: &[Vec<i128>]) -> Result<(), RtlError> {
    let mut text = String::from("fxshade searched rows 1\n");
    for r in rows {
        let codes: Vec<String> = r.iter().map(|c| c.to_string()).collect();
        text.push_str(&codes.join(" "));
        text.push('\n');
    }
    text.push_str("end\n");
    let Some(file) = corner_cache_file(key)? else {
        return Ok(());
    };
    match crate::cache::write(&file, text.as_bytes()) {
        Ok(())
        | Err(crate::cache::CacheError::Full { .. } | crate::cache::CacheError::Io { .. }) => {
            Ok(())
        }
        Err(e) => Err(e.into()),
    }
}

/// A unit's input rows (`u.inputs`), every code made one its port can
/// hold: a corner case a port cannot hold (a barycentric 1.0 on a `U0F16`
/// port) becomes the nearest code it can, so the vector files, the RTL and
/// the model all see the same value. A row of the wrong length is an error.
///
/// # Errors
///
/// The errors of the unit's generator (`u.inputs`); [`RtlError::Stage`] (stage `inputs`)
/// when a row does not hold one code per entry of `formats`.
pub fn unit_inputs(
    u: &RtlUnit,
    cfg: &Config,
    part: Part,
    seed: u64,
    formats: &[Format],
) -> Result<Vec<Vec<i128>>, RtlError> {
    let mut rows = (u.inputs)(cfg, part, seed)?;
    for (i, r) in rows.iter_mut().enumerate() {
        if r.len() != formats.len() {
            return Err(RtlError::Stage {
                unit: u.name,
                stage: "inputs",
                why: format!(
                    "row {i} has {} codes for {} input ports",
                    r.len(),
                    formats.len()
                ),
            });
        }
        for (c, f) in r.iter_mut().zip(formats) {
            *c = (*c).clamp(f.min_code(), f.max_code());
        }
    }
    Ok(rows)
}

/// Rows `[start, start + len)` of the stream whose first `corners.len()`
/// rows are `corners` and whose rest are random chunks (codes of
/// `formats`, [`unit_inputs`]).
///
/// # Errors
///
/// As [`unit_inputs`], for each random chunk the rows reach.
pub fn stream_rows(
    u: &RtlUnit,
    cfg: &Config,
    corners: &[Vec<i128>],
    seed: u64,
    start: usize,
    len: usize,
    formats: &[Format],
) -> Result<Vec<Vec<i128>>, RtlError> {
    let mut out = Vec::with_capacity(len);
    let end = start + len;
    let mut i = start;
    while i < end.min(corners.len()) {
        out.push(corners[i].clone());
        i += 1;
    }
    while i < end {
        let r = i - corners.len();
        let c = r / RANDOM_CHUNK;
        let mut chunk = unit_inputs(
            u,
            cfg,
            Part::Random(RANDOM_CHUNK),
            chunk_seed(seed, c as u64),
            formats,
        )?;
        let from = r % RANDOM_CHUNK;
        let take = (RANDOM_CHUNK - from).min(end - i);
        out.extend(chunk.drain(from..from + take));
        i += take;
    }
    Ok(out)
}

/// A vector set from input rows: outputs and flags from the compiled trace,
/// fields from the emitted ports.
///
/// # Errors
///
/// The errors of [`compile_outputs`]; [`RtlError::Stage`] (stage `inputs`) when a code of
/// `rows` lies outside the format of its input field.
///
/// # Panics
///
/// When the compiled trace of `d` flags other stages than `e` (`e` was not emitted from
/// `d`), or when a row holds fewer codes than `e` has inputs.
pub fn vector_set(
    d: &Design,
    e: &Emitted,
    rows: Vec<Vec<i128>>,
    corners: usize,
    seed: u64,
) -> Result<VectorSet, RtlError> {
    let prog = compile_outputs(d)?;
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
    let output_rows = expected_rows(&prog, e.flags.len(), n_in, &rows);
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
            harness: e.harness.clone(),
            latency: e.latency,
            setup: e.setup.clone(),
            parameters: d.parameters.clone(),
        },
        corner_cases: corners,
        flags: e.flags.clone(),
    })
}

/// The design's output ports compiled: what computes the expected outputs
/// and flags of its vectors.
///
/// # Errors
///
/// [`RtlError::Compile`] when the trace of the output ports cannot be compiled
/// ([`Compiled::compile`](crate::datapath::Compiled::compile)).
pub fn compile_outputs(d: &Design) -> Result<crate::datapath::Compiled, RtlError> {
    let outs: Vec<_> = d.trace.output_ports().iter().map(|p| p.value).collect();
    Ok(crate::datapath::Compiled::compile(&d.trace, &outs)?)
}

/// Expected output rows (the `ovf` field first when there are `nf` flag
/// stages, stage k at bit nf−1−k) of `rows` through the compiled trace.
fn expected_rows(
    prog: &crate::datapath::Compiled,
    nf: usize,
    n_in: usize,
    rows: &[Vec<i128>],
) -> Vec<Vec<i128>> {
    let (res, flags) = expected_columns(prog, n_in, rows);
    (0..rows.len())
        .map(|i| {
            let mut r = Vec::with_capacity(res.len() + 1);
            expected_row_into(&mut r, nf > 0, &res, &flags, i);
            r
        })
        .collect()
}

/// Append lane `i`'s expected row to `r`: the flag word first when the
/// design has flag stages (the model's flag word is the RTL's `ovf_o`),
/// then every output's code.
fn expected_row_into(
    r: &mut Vec<i128>,
    with_flags: bool,
    res: &[Vec<i128>],
    flags: &[u64],
    i: usize,
) {
    if with_flags {
        r.push(i128::from(flags[i]));
    }
    r.extend(res.iter().map(|o| o[i]));
}

/// The compiled trace run on `rows` (their first `n_in` codes): one column
/// of codes per output, and the per-lane overflow-flag words.
fn expected_columns(
    prog: &crate::datapath::Compiled,
    n_in: usize,
    rows: &[Vec<i128>],
) -> (Vec<Vec<i128>>, Vec<u64>) {
    let cols: Vec<Vec<i128>> = (0..n_in)
        .map(|k| rows.iter().map(|r| r[k]).collect())
        .collect();
    let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
    prog.run_flags_i128(&refs)
}

/// A unit's vector stream, or the slice of it one shard covers, generated
/// chunk by chunk on demand: memory does not grow with the count. Vector
/// `i` of the stream is the same whatever the count or the shard (corner
/// part first, then random chunks with seeds of their own), so shard `k` of
/// `n` covers `[k·total/n, (k+1)·total/n)` and the shards together are
/// exactly the unsharded stream.
#[derive(Clone)]
pub struct VectorStream {
    /// The unit.
    pub unit: &'static RtlUnit,
    cfg: Config,
    /// The traced design.
    pub design: Design,
    /// Its emitted module and testbench.
    pub emitted: Emitted,
    prog: crate::datapath::Compiled,
    /// The corner part of the stream.
    pub corners: Vec<Vec<i128>>,
    /// Seed.
    pub seed: u64,
    /// Vectors in the whole stream.
    pub total: usize,
    /// First vector of this slice.
    pub first: usize,
    /// Vectors in this slice.
    pub count: usize,
}

impl VectorStream {
    /// The stream of `total` vectors, or with `shard = Some((k, n))` its
    /// `k`-th of `n` slices (`k < n`); its corner part searched as
    /// thoroughly as `search` says ([`corner_rows`]).
    ///
    /// # Errors
    ///
    /// As [`check_total`], [`emit_unit`] and [`corner_rows`]; [`RtlError::Count`] when `total`
    /// is below the number of corner rows; as [`compile_outputs`].
    ///
    /// # Panics
    ///
    /// When `shard` is `Some((k, 0))` and no error comes first (a division by zero).
    pub fn new(
        u: &'static RtlUnit,
        cfg: &Config,
        total: usize,
        seed: u64,
        shard: Option<(usize, usize)>,
        search: Search,
    ) -> Result<VectorStream, RtlError> {
        check_total(total)?;
        let (design, emitted) = emit_unit(u, cfg)?;
        let corners = corner_rows(u, &design, cfg, seed, search)?;
        if total < corners.len() {
            return Err(RtlError::Count {
                count: total,
                corners: corners.len(),
            });
        }
        let prog = compile_outputs(&design)?;
        let (first, end) = match shard {
            None => (0, total),
            Some((k, n)) => (
                (total as u128 * k as u128 / n as u128) as usize,
                (total as u128 * (k as u128 + 1) / n as u128) as usize,
            ),
        };
        Ok(VectorStream {
            unit: u,
            cfg: cfg.clone(),
            design,
            emitted,
            prog,
            corners,
            seed,
            total,
            first,
            count: end - first,
        })
    }

    /// Slice `k` of `n` of this slice (`[first + k·count/n, first +
    /// (k+1)·count/n)`), sharing its corner part: for splitting a run over
    /// jobs.
    ///
    /// # Panics
    ///
    /// If `k` is not below `n`.
    pub fn slice(&self, k: usize, n: usize) -> VectorStream {
        assert!(k < n, "slice k of n");
        let a = (self.count as u128 * k as u128 / n as u128) as usize;
        let b = (self.count as u128 * (k as u128 + 1) / n as u128) as usize;
        let mut s = self.clone();
        s.first = self.first + a;
        s.count = b - a;
        s
    }

    /// The RTL the vectors are for.
    pub fn rtl(&self) -> RtlSources {
        RtlSources {
            module: self.emitted.module.clone(),
            verilog: self.emitted.verilog.clone(),
            testbench: self.emitted.testbench.clone(),
            harness: self.emitted.harness.clone(),
            latency: self.emitted.latency,
            setup: self.emitted.setup.clone(),
            parameters: self.design.parameters.clone(),
        }
    }

    /// The whole slice in memory (for small counts).
    ///
    /// # Errors
    ///
    /// As [`stream_rows`] for the whole slice.
    pub fn collect(&self) -> Result<VectorSet, RtlError> {
        let (input_rows, output_rows) = self.chunk(0, self.count)?;
        Ok(self.set_of(input_rows, output_rows))
    }

    /// A vector set of this stream's unit and layout holding `rows`.
    fn set_of(&self, input_rows: Vec<Vec<i128>>, output_rows: Vec<Vec<i128>>) -> VectorSet {
        VectorSet {
            unit: self.design.unit,
            variant: self.design.variant.clone(),
            config_source: self.design.config_source.clone(),
            config_toml: self.design.config_toml.clone(),
            seed: self.seed,
            inputs: self.emitted.inputs.clone(),
            outputs: self.emitted.outputs.clone(),
            input_rows,
            output_rows,
            rtl: self.rtl(),
            corner_cases: self
                .corners
                .len()
                .saturating_sub(self.first)
                .min(self.count),
            flags: self.emitted.flags.clone(),
        }
    }

    /// The manifest of this slice (the fields of [`VectorSet::manifest`],
    /// with `first` and `total` saying which slice of the stream it is).
    pub fn manifest(&self) -> serde_json::Value {
        let mut m = self.set_of(Vec::new(), Vec::new()).manifest();
        m["count"] = self.count.into();
        m["first"] = self.first.into();
        m["total"] = self.total.into();
        m
    }
}

impl crate::vectors::VectorSource for VectorStream {
    fn unit(&self) -> &'static str {
        self.design.unit
    }
    fn input_fields(&self) -> &[crate::vectors::Field] {
        &self.emitted.inputs
    }
    fn output_fields(&self) -> &[crate::vectors::Field] {
        &self.emitted.outputs
    }
    fn first(&self) -> usize {
        self.first
    }
    fn len(&self) -> usize {
        self.count
    }
    fn chunk(&self, start: usize, len: usize) -> Result<crate::vectors::Rows, RtlError> {
        let rows = self.input_chunk(start, len)?;
        let out = expected_rows(
            &self.prog,
            self.emitted.flags.len(),
            self.emitted.inputs.len(),
            &rows,
        );
        Ok((rows, out))
    }
    /// As the default, without an expected row per vector: the records are
    /// packed from the output columns (what co-simulation streams).
    fn records(
        &self,
        start: usize,
        len: usize,
        inputs: &mut Vec<u8>,
        expected: &mut Vec<u8>,
    ) -> Result<(), RtlError> {
        use crate::vectors::push_record;
        let rows = self.input_chunk(start, len)?;
        let (res, flags) = expected_columns(&self.prog, self.emitted.inputs.len(), &rows);
        let with_flags = !self.emitted.flags.is_empty();
        let mut e = Vec::with_capacity(res.len() + 1);
        for (k, r) in rows.iter().enumerate() {
            let idx = narrow::<u32, _>(self.first + start + k);
            push_record(inputs, idx, &self.emitted.inputs, r);
            e.clear();
            expected_row_into(&mut e, with_flags, &res, &flags, k);
            push_record(expected, idx, &self.emitted.outputs, &e);
        }
        Ok(())
    }
}

impl VectorStream {
    /// Input rows `[start, start + len)` of the slice.
    fn input_chunk(&self, start: usize, len: usize) -> Result<Vec<Vec<i128>>, RtlError> {
        assert!(start + len <= self.count, "inside the slice");
        stream_rows(
            self.unit,
            &self.cfg,
            &self.corners,
            self.seed,
            self.first + start,
            len,
            &self
                .design
                .trace
                .input_ports()
                .iter()
                .map(|p| p.format)
                .collect::<Vec<_>>(),
        )
    }
}
