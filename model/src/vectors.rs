//! Test vectors: a manifest and `$readmemh` files, shared by every unit.
//!
//! A vector set is written (atomically: the directory appears whole or not
//! at all) as
//!
//! * `manifest.json` — generator and version, unit, variant, configuration
//!   source, count, seed, and the fields of each line in order, with their
//!   formats, widths and bit positions;
//! * `inputs.hex`, `expected.hex` — one line per vector: the 32-bit vector
//!   index, then the fields most significant first, as one hex number
//!   (what `$readmemh` reads into a `[32+W-1:0]` memory word);
//! * `<unit>_params.vh` — the Verilog parameter header for the configuration;
//! * `config.toml` — the effective configuration.
//!
//! The index field lets a testbench prove that the file holds exactly the
//! manifest's count (a short `$readmemh` file otherwise passes silently on
//! uninitialised entries).

use std::fmt::Write as _;
use std::path::Path;

use crate::files::{StagedDir, WriteError};
use crate::format::Format;

/// Generator name and version, recorded in manifests and headers.
pub const GENERATOR: &str = concat!("fxshade ", env!("CARGO_PKG_VERSION"));

/// One field of a vector line.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Field {
    /// Name (`nx`, `ovf`, …).
    pub name: String,
    /// Format of the codes (flags are `U<n>F0`).
    pub format: Format,
}

impl Field {
    /// A field.
    pub fn new(name: &str, format: Format) -> Self {
        Field {
            name: name.to_string(),
            format,
        }
    }
}

/// A generated parameter header: file name and text, and any other files
/// the RTL reads for the configuration (ROM contents).
#[derive(Clone, Debug, PartialEq)]
pub struct ParamsHeader {
    /// File name, e.g. `normalize_params.vh`.
    pub name: String,
    /// Contents.
    pub text: String,
    /// Further generated files (name, contents), e.g. `$readmemh` ROM images.
    pub extra: Vec<(String, String)>,
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
    /// The Verilog parameter header.
    pub params: ParamsHeader,
    /// How many of the vectors are corner cases (they come first).
    pub corner_cases: usize,
}

/// `{index[31:0], fields…}` as one hex number, most significant first.
pub fn hex_line(index: u32, fields: &[Field], row: &[i128]) -> String {
    // Pack into bits, LSB first, then print nibbles MSB first.
    let total: usize = 32
        + fields
            .iter()
            .map(|f| f.format.width() as usize)
            .sum::<usize>();
    let mut bits = vec![false; total.div_ceil(4) * 4];
    let mut pos = 0;
    for (f, &code) in fields.iter().zip(row).rev() {
        let b = f.format.to_bits(code);
        for k in 0..f.format.width() as usize {
            bits[pos + k] = (b >> k) & 1 == 1;
        }
        pos += f.format.width() as usize;
    }
    for k in 0..32 {
        bits[pos + k] = (index >> k) & 1 == 1;
    }
    let mut s = String::with_capacity(bits.len() / 4);
    for nib in (0..bits.len() / 4).rev() {
        let v = (0..4).fold(0u8, |acc, k| acc | ((bits[nib * 4 + k] as u8) << k));
        s.push(char::from_digit(v as u32, 16).expect("nibble"));
    }
    s
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

    /// The manifest.
    pub fn manifest(&self) -> serde_json::Value {
        serde_json::json!({
            "generator": GENERATOR,
            "unit": self.unit,
            "variant": self.variant,
            "config_source": self.config_source,
            "count": self.count(),
            "corner_cases": self.corner_cases,
            "seed": self.seed,
            "line_format": "{index[31:0], fields most significant first} as one hex number per line",
            "inputs": fields_json(&self.inputs),
            "expected": fields_json(&self.outputs),
            "files": {
                "inputs": "inputs.hex", "expected": "expected.hex",
                "params": self.params.name, "config": "config.toml",
            },
        })
    }

    /// The `inputs.hex` text.
    pub fn inputs_hex(&self) -> String {
        let mut s = String::new();
        for (i, r) in self.input_rows.iter().enumerate() {
            let _ = writeln!(s, "{}", hex_line(i as u32, &self.inputs, r));
        }
        s
    }

    /// The `expected.hex` text.
    pub fn expected_hex(&self) -> String {
        let mut s = String::new();
        for (i, r) in self.output_rows.iter().enumerate() {
            let _ = writeln!(s, "{}", hex_line(i as u32, &self.outputs, r));
        }
        s
    }

    /// Write the set into `dir` (replaced as a whole, atomically).
    pub fn write(&self, dir: &Path) -> Result<(), WriteError> {
        let d = StagedDir::new(dir)?;
        self.write_into(&d)?;
        d.commit()?;
        Ok(())
    }

    /// Write the set's files into a staged directory.
    pub fn write_into(&self, d: &StagedDir) -> Result<(), WriteError> {
        self.write_into_dir(d, "")
    }

    /// Write the set's files into subdirectory `sub` of a staged directory.
    pub fn write_into_dir(&self, d: &StagedDir, sub: &str) -> Result<(), WriteError> {
        let p = |f: &str| {
            if sub.is_empty() {
                f.to_string()
            } else {
                format!("{sub}/{f}")
            }
        };
        let manifest = serde_json::to_string_pretty(&self.manifest()).expect("serializable") + "\n";
        d.write(&p("manifest.json"), manifest.as_bytes())?;
        d.write(&p("inputs.hex"), self.inputs_hex().as_bytes())?;
        d.write(&p("expected.hex"), self.expected_hex().as_bytes())?;
        d.write(&p(&self.params.name), self.params.text.as_bytes())?;
        for (name, text) in &self.params.extra {
            d.write(&p(name), text.as_bytes())?;
        }
        d.write(&p("config.toml"), self.config_toml.as_bytes())?;
        Ok(())
    }
}

/// The opening comment of a generated parameter header: what it is for,
/// who generated it, and the configuration it came from.
pub fn header_preamble(
    file: &str,
    module: &str,
    unit: &str,
    cfg: &crate::config::Config,
    detail: &str,
) -> String {
    let fp = fingerprint(&[cfg.to_toml().as_bytes()]);
    let mut t = format!("// {file}: parameters of rtl/{module}.v for one configuration.\n");
    t += &format!("// Generated by {GENERATOR}; do not edit. Regenerate with\n");
    t += &format!("//   fxshade vectors {unit} [--config FILE] --out DIR\n");
    t += &format!("// Configuration: {} (fingerprint {fp:016x})", cfg.source);
    if !cfg.overrides.is_empty() {
        t += &format!(", overrides: {}", cfg.overrides.join(" "));
    }
    t += "\n";
    t += &format!("// {detail}\n");
    t += "// Formats: <S>_W width, <S>_F fraction bits, <S>_S signed; <S>_R rounding\n";
    t += "// (0 trunc, 1 half_up, 2 half_even); <S>_SAT overflow (0 wrap, 1 saturate).\n";
    t
}

/// One stage's parameters: `<P>_W, <P>_F, <P>_S` and, with `modes`,
/// `<P>_R, <P>_SAT`.
pub fn stage_params(prefix: &str, q: &crate::quantize::Quant, modes: bool) -> String {
    use crate::quantize::{Overflow, Rounding};
    let f = q.format();
    let mut l = format!(
        "localparam integer {prefix}_W = {}, {prefix}_F = {}, {prefix}_S = {}",
        f.width(),
        f.frac(),
        f.signed() as u8
    );
    if modes {
        let r = match q.round() {
            Rounding::Trunc => 0,
            Rounding::HalfUp => 1,
            Rounding::HalfEven => 2,
        };
        l += &format!(
            ", {prefix}_R = {r}, {prefix}_SAT = {}",
            (q.overflow() == Overflow::Saturate) as u8
        );
    }
    l + ";\n"
}

/// Check that the RTL quantizer can express every quantization point of a
/// counting run (it must drop fewer bits than its input holds) and that every
/// format is at least 2 bits wide.
pub fn check_rtl_stages(
    cx: &crate::datapath::Count,
    formats: &[(&'static str, Format)],
) -> Result<(), (&'static str, String)> {
    for p in cx.quant_points() {
        if p.dropped_bits >= p.input_width as i32 {
            return Err((
                p.stage,
                format!(
                    "drops {} of {} bits; the RTL quantizer needs fewer",
                    p.dropped_bits, p.input_width
                ),
            ));
        }
    }
    for (name, f) in formats {
        if f.width() < 2 {
            return Err((name, "the RTL needs formats of at least 2 bits".into()));
        }
    }
    Ok(())
}

/// Inputs that make each of `stages` meet an exact rounding tie (a
/// nearest-mode quantization whose dropped bits are exactly one half: what
/// tells `half_up` from `half_even`, and what random vectors almost never
/// contain), up to `per_stage` each, among `tries` candidates from `gen`
/// (give it codes with many trailing zeros). `eval` runs one candidate in
/// the scalar fixed-point context.
pub fn hunt_ties(
    stages: &[&'static str],
    per_stage: usize,
    tries: usize,
    mut gen: impl FnMut() -> Vec<i128>,
    mut eval: impl FnMut(&mut crate::datapath::Fixed<i128>, &[i128]),
) -> Vec<Vec<i128>> {
    let mut fx = crate::datapath::Fixed::<i128>::new();
    let mut found: Vec<(&str, usize)> = stages.iter().map(|s| (*s, 0)).collect();
    let mut out = Vec::new();
    for _ in 0..tries {
        if found.iter().all(|(_, c)| *c >= per_stage) {
            break;
        }
        let cand = gen();
        fx.reset();
        eval(&mut fx, &cand);
        let mut useful = false;
        for (st, c) in found.iter_mut() {
            if *c < per_stage && fx.ties().iter().any(|(s, k)| s == st && *k > 0) {
                *c += 1;
                useful = true;
            }
        }
        if useful {
            out.push(cand);
        }
    }
    out
}

/// A random code of `f` with a random number of trailing zero bits (or
/// zero), for tie hunting.
pub fn structured_code(f: Format, rng: &mut crate::sampling::Rng) -> i128 {
    let span = (f.max_code() - f.min_code() + 1) as u64;
    let c = f.min_code() + rng.below(span) as i128;
    let tz = rng.below(f.width() as u64) as u32;
    if rng.below(3) == 0 {
        0
    } else {
        c & !((1i128 << tz) - 1)
    }
}

/// Why RTL parameters or vectors could not be generated, for any unit.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RtlError {
    /// An input or constant could not be converted.
    #[error(transparent)]
    Convert(#[from] crate::format::ConvertError),
    /// The normalizer could not be designed.
    #[error(transparent)]
    Design(#[from] crate::normalizer::DesignError),
    /// The polar configuration is unusable.
    #[error(transparent)]
    Polar(#[from] crate::polar::PolarError),
    /// A variant the RTL does not implement.
    #[error("{unit}.method = \"{method}\": the RTL implements {supported} only")]
    Method {
        /// Unit.
        unit: &'static str,
        /// The configured variant.
        method: &'static str,
        /// What the RTL implements.
        supported: &'static str,
    },
    /// A stage the RTL cannot express.
    #[error("{unit}.{stage}: {why}")]
    Stage {
        /// Unit.
        unit: &'static str,
        /// Stage name.
        stage: &'static str,
        /// Why.
        why: String,
    },
    /// Too few vectors for the corner cases.
    #[error("--count {count} is below the {corners} corner cases every set holds")]
    Count {
        /// Requested.
        count: usize,
        /// Needed at least.
        corners: usize,
    },
}

/// FNV-1a, 64 bits: a stable fingerprint of a configuration or of sources
/// (for names and build caches, not for security).
pub fn fingerprint(parts: &[&[u8]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for p in parts {
        for &b in *p {
            h ^= b as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        h ^= 0xff;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
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
