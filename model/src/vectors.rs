//! Test vectors: a manifest and `$readmemh` files, shared by every unit.
//!
//! A vector set is written (atomically: the directory appears whole or not
//! at all) as
//!
//! * `manifest.json` — generator and version, unit, variant, configuration
//!   source, count, seed, and the fields of each line in order, with their
//!   formats, widths and bit positions;
//! * the records in each format of [`crate::writers`]: `inputs.bin`,
//!   `expected.bin` — the binary records the testbench reads; `inputs.hex`,
//!   `expected.hex` — one line per vector: the 32-bit vector index, then the
//!   fields most significant first, as one hex number (what `$readmemh`
//!   reads into a `[32+W-1:0]` memory word);
//! * `<unit>.v`, `<unit>_tb.v` — the unit's generated Verilog and its
//!   self-checking testbench for the configuration;
//! * `config.toml` — the effective configuration.
//!
//! The index field lets a testbench prove that the file holds exactly the
//! manifest's count (a short `$readmemh` file otherwise passes silently on
//! uninitialised entries).

use fxshade_numbers::convert::narrow;
use std::path::Path;

use crate::files::{StagedDir, WriteError};
pub use fxshade_backend::record::{fingerprint, Field, GENERATOR};
pub use fxshade_units::rtl::units::{hunt_ties, structured_code, RtlError};

pub use crate::writers::binary::{push_record, record_bytes};
pub use crate::writers::hex::hex_line;
use crate::writers::VectorWriter;

/// The version of the manifest's layout (`manifest.json` of a vector set,
/// the C ABI's `fxs_manifest`, the Python `Unit.manifest_json`), whose JSON
/// Schema is `schema/manifest.schema.json`: a field's meaning never changes
/// within a version.
pub const MANIFEST_VERSION: u32 = 1;

/// The generated RTL a vector set checks: the unit's module and its
/// self-checking testbench.
#[derive(Clone, Debug, PartialEq)]
pub struct RtlSources {
    /// Module name (`<module>.v`, testbench `<module>_tb.v`).
    pub module: String,
    /// The module's Verilog.
    pub verilog: String,
    /// The testbench's Verilog.
    pub testbench: String,
    /// The Verilator harness: the same testbench driven from C++.
    pub harness: crate::rtl::testbench::Harness,
    /// Cycles from input to output.
    pub latency: u32,
    /// The module's set-up ports (empty: every field travels with the
    /// item).
    pub setup: Vec<crate::rtl::SetupPort>,
    /// The unit's parameters ([`crate::rtl::Design::parameters`]).
    pub parameters: serde_json::Value,
}

impl RtlSources {
    /// `(file name, text)` of the design file and the testbench.
    pub fn files(&self) -> [(String, &str); 2] {
        [
            (format!("{}.v", self.module), self.verilog.as_str()),
            (format!("{}_tb.v", self.module), self.testbench.as_str()),
        ]
    }
}

/// A set of test vectors for one unit.
#[derive(Clone, Debug)]
pub struct VectorSet {
    /// Unit name.
    pub unit: &'static str,
    /// Variant (e.g. the normalizer's method).
    pub variant: String,
    /// Where the configuration came from.
    pub config_source: String,
    /// The effective configuration, as TOML.
    pub config_toml: String,
    /// Seed of the random vectors.
    pub seed: u64,
    /// Input fields, most significant first.
    pub inputs: Vec<Field>,
    /// Output fields, most significant first.
    pub outputs: Vec<Field>,
    /// One row of input codes per vector.
    pub input_rows: Vec<Vec<i128>>,
    /// One row of expected output codes per vector.
    pub output_rows: Vec<Vec<i128>>,
    /// The generated RTL the vectors are for.
    pub rtl: RtlSources,
    /// How many of the vectors are corner cases (they come first).
    pub corner_cases: usize,
    /// The stage id of each bit of the `ovf` output field, most significant
    /// bit first.
    pub flags: Vec<String>,
}

/// `{index[31:0], fields…}` packed LSB first into 64-bit words (on the
/// stack up to 2048 bits).
pub(crate) fn pack(index: u32, fields: &[Field], row: &[i128]) -> (Words, usize) {
    let total = crate::writers::record_bits(fields);
    let n = total.div_ceil(64) + 1;
    let mut w = if n <= 32 {
        Words::Stack([0; 32])
    } else {
        Words::Heap(vec![0; n])
    };
    let mut pos = 0usize;
    let mut put = |bits: u64, width: usize, pos: &mut usize| {
        if width == 0 {
            return;
        }
        let (k, o) = (*pos / 64, *pos % 64);
        w[k] |= bits << o;
        if o + width > 64 && o > 0 {
            w[k + 1] |= bits >> (64 - o);
        }
        *pos += width;
    };
    for (f, &code) in fields.iter().zip(row).rev() {
        put(f.format.to_bits(code), f.format.width() as usize, &mut pos);
    }
    put(u64::from(index), 32, &mut pos);
    (w, total)
}

/// Packed words.
#[allow(clippy::large_enum_variant)] // the stack variant is the point
pub(crate) enum Words {
    Stack([u64; 32]),
    Heap(Vec<u64>),
}

impl std::ops::Deref for Words {
    type Target = [u64];
    fn deref(&self) -> &[u64] {
        match self {
            Words::Stack(a) => a,
            Words::Heap(v) => v,
        }
    }
}

impl std::ops::DerefMut for Words {
    fn deref_mut(&mut self) -> &mut [u64] {
        match self {
            Words::Stack(a) => a,
            Words::Heap(v) => v,
        }
    }
}

/// Input rows and expected output rows of a run of vectors.
pub type Rows = (Vec<Vec<i128>>, Vec<Vec<i128>>);

/// Vectors as the RTL flow reads them: a slice `[first, first + count)` of
/// a unit's stream, drawn in chunks (so a source need not hold them all).
pub trait VectorSource: Sync {
    /// Unit.
    fn unit(&self) -> &'static str;
    /// Input fields, most significant first.
    fn input_fields(&self) -> &[Field];
    /// Output fields (the `ovf` flags first when there are any).
    fn output_fields(&self) -> &[Field];
    /// Index of the first vector in the whole stream.
    fn first(&self) -> usize;
    /// Vectors in this slice.
    fn len(&self) -> usize;
    /// Whether the slice is empty.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Input and expected rows of vectors `[start, start + len)` of the
    /// slice (relative to [`VectorSource::first`]).
    ///
    /// # Errors
    ///
    /// An [`RtlError`] when the rows cannot be generated: for a
    /// [`VectorStream`](crate::rtl::units::VectorStream), the errors of
    /// [`stream_rows`](crate::rtl::units::stream_rows); a [`VectorSet`] never fails.
    ///
    /// # Panics
    ///
    /// Both implementations here panic when `[start, start + len)` is not inside the slice.
    fn chunk(&self, start: usize, len: usize) -> Result<Rows, RtlError>;
    /// The binary records ([`push_record`]) of vectors `[start, start +
    /// len)`, appended to `inputs` and `expected`.
    ///
    /// # Errors
    ///
    /// As [`VectorSource::chunk`].
    ///
    /// # Panics
    ///
    /// As [`VectorSource::chunk`].
    fn records(
        &self,
        start: usize,
        len: usize,
        inputs: &mut Vec<u8>,
        expected: &mut Vec<u8>,
    ) -> Result<(), RtlError> {
        let (rows, exp) = self.chunk(start, len)?;
        for (k, (r, e)) in rows.iter().zip(&exp).enumerate() {
            let idx = narrow::<u32, _>(self.first() + start + k);
            push_record(inputs, idx, self.input_fields(), r);
            push_record(expected, idx, self.output_fields(), e);
        }
        Ok(())
    }
}

impl VectorSource for VectorSet {
    fn unit(&self) -> &'static str {
        self.unit
    }
    fn input_fields(&self) -> &[Field] {
        &self.inputs
    }
    fn output_fields(&self) -> &[Field] {
        &self.outputs
    }
    fn first(&self) -> usize {
        0
    }
    fn len(&self) -> usize {
        self.count()
    }
    fn chunk(&self, start: usize, len: usize) -> Result<Rows, RtlError> {
        Ok((
            self.input_rows[start..start + len].to_vec(),
            self.output_rows[start..start + len].to_vec(),
        ))
    }
}

fn fields_json(fields: &[Field]) -> serde_json::Value {
    let total: u32 = fields.iter().map(|f| f.format.width()).sum();
    let mut msb = total;
    let v: Vec<serde_json::Value> = fields
        .iter()
        .map(|f| {
            let lsb = msb - f.format.width();
            let j = serde_json::json!({
                "name": f.name, "format": f.format.to_string(), "width": f.format.width(),
                "signed": f.format.signed(), "frac": f.format.frac(), "msb": msb - 1, "lsb": lsb,
            });
            msb = lsb;
            j
        })
        .collect();
    serde_json::json!({ "width": total, "fields": v })
}

impl VectorSet {
    /// Number of vectors.
    pub fn count(&self) -> usize {
        self.input_rows.len()
    }

    /// The manifest: described by `schema/manifest.schema.json`, version
    /// [`MANIFEST_VERSION`].
    pub fn manifest(&self) -> serde_json::Value {
        serde_json::json!({
            "manifest_version": MANIFEST_VERSION,
            "generator": GENERATOR,
            "unit": self.unit,
            "variant": self.variant,
            "config_source": self.config_source,
            "count": self.count(),
            "corner_cases": self.corner_cases,
            "seed": self.seed,
            "first": 0,
            "total": self.count(),
            "line_format": "{index[31:0], fields most significant first} as one hex number per line",
            "record_format": "{zero pad, index[31:0], fields most significant first}, big endian, ceil((32 + width) / 8) bytes per vector",
            "inputs": fields_json(&self.inputs),
            "expected": fields_json(&self.outputs),
            "ovf_bits_msb_first": self.flags,
            "parameters": self.rtl.parameters,
            "latency": self.rtl.latency,
            "setup_ports": self.rtl.setup,
            "setup_stream": if self.rtl.setup.is_empty() {
                "none: every field travels with each vector"
            } else {
                "each vector carries every field; before a vector whose fields of a set-up port differ from the ones that port last accepted (or when it accepted none), the port is sent them (ports in the listed order), then the vector's item goes; records stay in file order"
            },
            "files": self.files_json(),
        })
    }

    /// The manifest's `files`: each format's two files under its keys
    /// ([`crate::writers::WRITERS`]), the RTL, testbench, harness and
    /// configuration.
    fn files_json(&self) -> serde_json::Value {
        let m = &self.rtl.module;
        let mut files = serde_json::json!({
            "rtl": format!("{m}.v"),
            "testbench": format!("{m}_tb.v"),
            "verilator_shell": format!("{m}_shell.v"),
            "verilator_main": format!("{m}_main.cpp"),
            "config": "config.toml",
        });
        for w in crate::writers::WRITERS {
            for (k, f) in w.manifest_keys().into_iter().zip(w.files()) {
                files[k] = serde_json::json!(f);
            }
        }
        files
    }

    /// Write the set into `dir` (replaced as a whole, atomically; a
    /// non-empty directory fxshade did not write is refused unless `force`).
    ///
    /// # Errors
    ///
    /// [`SetError::Write`]: as [`StagedDir::new`] (`force`: [`StagedDir::new_forced`]), then
    /// when a file cannot be written ([`write_set`]) or the directory cannot be committed
    /// ([`StagedDir::commit`]).
    pub fn write(&self, dir: &Path, force: bool) -> Result<(), SetError> {
        let d = if force {
            StagedDir::new_forced(dir)?
        } else {
            StagedDir::new(dir)?
        };
        self.write_into(&d)?;
        d.commit()?;
        Ok(())
    }

    /// Write the set's files into a staged directory.
    ///
    /// # Errors
    ///
    /// As [`write_set`], [`SetError::Write`] only: the set's rows are in memory.
    pub fn write_into(&self, d: &StagedDir) -> Result<(), SetError> {
        self.write_into_dir(d, "")
    }

    /// Write the set's files into subdirectory `sub` of a staged directory
    /// ([`write_set`]).
    ///
    /// # Errors
    ///
    /// As [`write_set`], [`SetError::Write`] only: the set's rows are in memory.
    pub fn write_into_dir(&self, d: &StagedDir, sub: &str) -> Result<(), SetError> {
        write_set(
            d,
            sub,
            self,
            &self.manifest(),
            &self.config_toml,
            &self.rtl,
            crate::writers::WRITERS,
            &mut |_| {},
        )
    }
}

/// Why a vector set could not be written.
#[derive(Debug, thiserror::Error)]
pub enum SetError {
    /// A file could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
    /// The vectors could not be generated.
    #[error(transparent)]
    Vectors(#[from] RtlError),
}

/// Vectors per chunk [`write_set`] generates and writes at a time.
pub const WRITE_CHUNK: usize = 8192;

/// Write a vector set into subdirectory `sub` (empty: the top) of a staged
/// directory: `manifest.json`, `config.toml`, the RTL and its testbench,
/// and the records in each format of `writers` (an inputs file and an
/// expected file each, [`VectorWriter::files`]; the testbench reads the
/// binary records, so give [`writers::BINARY`](crate::writers::BINARY)).
/// The records are drawn from `src` [`WRITE_CHUNK`] at a time and written
/// as they come, so memory does not grow with the count; `progress` gets
/// the vectors written so far.
///
/// # Errors
///
/// [`SetError::Write`] when a file cannot be written,
/// [`SetError::Vectors`] when the vectors cannot be generated.
///
/// # Panics
///
/// Never: a `serde_json::Value` always serializes, and every writer has two files.
#[allow(clippy::too_many_arguments)]
pub fn write_set(
    d: &StagedDir,
    sub: &str,
    src: &dyn VectorSource,
    manifest: &serde_json::Value,
    config_toml: &str,
    rtl: &RtlSources,
    writers: &[&dyn VectorWriter],
    progress: &mut dyn FnMut(usize),
) -> Result<(), SetError> {
    use std::io::Write;
    let p = |f: &str| {
        if sub.is_empty() {
            f.to_string()
        } else {
            format!("{sub}/{f}")
        }
    };
    let m = serde_json::to_string_pretty(manifest).expect("serializable") + "\n";
    d.write(&p("manifest.json"), m.as_bytes())?;
    d.write(&p("config.toml"), config_toml.as_bytes())?;
    for (name, text) in rtl.files() {
        d.write(&p(&name), text.as_bytes())?;
    }
    for (name, text) in rtl.harness.files() {
        d.write(&p(&name), text.as_bytes())?;
    }
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |reason| WriteError::Io { path, reason }
    };
    let open = |name: &str| -> Result<(std::path::PathBuf, std::io::BufWriter<std::fs::File>), WriteError> {
        let path = d.path(&p(name))?;
        let f = std::fs::File::create(&path).map_err(io(&path))?;
        Ok((path, std::io::BufWriter::with_capacity(1 << 20, f)))
    };
    // Two files per format: its inputs, then its expected outputs.
    let mut files = Vec::new();
    for w in writers {
        for name in w.files() {
            files.push(open(name)?);
        }
    }
    let (ins, outs) = (src.input_fields(), src.output_fields());
    let mut done = 0;
    while done < src.len() {
        let len = WRITE_CHUNK.min(src.len() - done);
        let (rows, exp) = src.chunk(done, len)?;
        let mut bufs: Vec<Vec<u8>> = vec![Vec::new(); files.len()];
        for (k, (r, e)) in rows.iter().zip(&exp).enumerate() {
            let idx = narrow::<u32, _>(src.first() + done + k);
            for (w, b) in writers.iter().zip(bufs.chunks_mut(2)) {
                w.push(&mut b[0], idx, ins, r);
                w.push(&mut b[1], idx, outs, e);
            }
        }
        for ((path, w), b) in files.iter_mut().zip(&bufs) {
            w.write_all(b).map_err(io(path))?;
        }
        done += len;
        progress(done);
    }
    for (path, w) in files.iter_mut() {
        w.flush().map_err(io(path))?;
    }
    Ok(())
}

impl From<crate::cache::CacheError> for RtlError {
    fn from(e: crate::cache::CacheError) -> Self {
        RtlError::Cache(e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_lines_pack_msb_first() {
        let f = vec![
            Field::new("a", "I4F0".parse().unwrap()),
            Field::new("b", "U3F0".parse().unwrap()),
        ];
        // index 1, a = -1 (0xf), b = 5 (0b101): bits 1 | 1111 | 101 -> 0x1_7d (39 bits -> 10 hex digits)
        assert_eq!(
            hex_line(1, &f, &[-1, 5]),
            format!("{:010x}", (1u64 << 7) | (0xf << 3) | 5)
        );
    }
}
