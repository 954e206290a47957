//! One unit's bit-exact model as a callable object: what the C ABI
//! (`capi/`), the SystemVerilog DPI-C package ([`super::dpi`]) and other
//! testbenches evaluate.
//!
//! A [`UnitModel`] is opened from a unit name and a configuration (the
//! embedded default, TOML text or a file, then `--set`-style overrides) with
//! the same validation and messages as the command line. Its ports are the
//! emitted module's, in the same order as the vector files' fields; its
//! [`UnitModel::eval`] maps rows of input codes to rows of output codes and
//! one overflow-flag word per row, computed by the compiled trace that
//! `fxshade vectors` uses, so the results are the vector files' expected
//! values bit for bit.
//!
//! Codes are `i64`: a port's code is its two's-complement value (signed
//! formats) or its unsigned value; a port must therefore be at most 63
//! bits if unsigned (64 if signed), which [`UnitModel::open`] checks. An
//! input code outside its port's format is an error, never wrapped.
//!
//! The flag word is the RTL's `ovf_o`: with `F` flag stages
//! ([`UnitModel::flags`], stage `k` the `k`-th), stage `k` is bit `F−1−k`
//! (the first stage is the most significant bit), as in the vector files'
//! `ovf` field. Pipeline tops with set-up ports (frame, triangle) take
//! every field with every row, the set-up fields included, as the vector
//! stream does: each row is evaluated with the set-up values it carries.

use fxshade_numbers::convert::narrow;
use std::path::Path;

use super::units::{self, RtlUnit};
use super::{Design, Emitted, SetupPort};
use crate::config::{Config, ConfigErrors};
use crate::datapath::Compiled;
use crate::format::Format;
use crate::vectors::{Field, RtlError};

/// The version of the layout description ([`UnitModel::layout`]) and of
/// the calls around it; the C ABI's `fxs_abi_version()`.
pub const ABI_VERSION: u32 = 1;

/// Where a unit's configuration comes from.
#[derive(Clone, Copy, Debug)]
pub enum ConfigSource<'a> {
    /// The embedded default.
    Default,
    /// TOML text, named in error messages by `name`.
    Text {
        /// The text.
        text: &'a str,
        /// Its name in messages (a file name, `<dpi package>`, …).
        name: &'a str,
    },
    /// A TOML file.
    File(&'a Path),
}

/// Why a unit could not be opened or evaluated.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// No unit with RTL has that name.
    #[error("unknown unit `{name}`; the units with RTL are: {units}")]
    UnknownUnit {
        /// The name asked for.
        name: String,
        /// Every unit's name.
        units: String,
    },
    /// The configuration was refused (the command line's messages).
    #[error("{0}")]
    Config(#[from] ConfigErrors),
    /// The design could not be built or emitted.
    #[error("{0}")]
    Rtl(#[from] RtlError),
    /// A port whose codes do not fit an `i64`.
    #[error("port {port} is {format}: its codes do not fit a 64-bit signed integer")]
    Wide {
        /// Port (field) name.
        port: String,
        /// Its format.
        format: Format,
    },
    /// Buffers of the wrong size.
    #[error("{what}: expected {expected} values, got {got}")]
    Shape {
        /// Which buffer.
        what: &'static str,
        /// Values needed.
        expected: usize,
        /// Values given.
        got: usize,
    },
    /// An input code its port's format cannot hold.
    #[error(
        "row {row}: code {code} of input {port} lies outside {format} \
         (codes {min}..={max})"
    )]
    Code {
        /// Row index.
        row: usize,
        /// Port (field) name.
        port: String,
        /// The code.
        code: i64,
        /// The port's format.
        format: Format,
        /// Smallest code.
        min: i128,
        /// Largest code.
        max: i128,
    },
    /// A layout other than the one a caller was generated for.
    #[error(
        "the configuration gives the layout `{actual}`, but the caller was generated for \
         `{expected}`: regenerate it for this configuration"
    )]
    Layout {
        /// What the caller expects.
        expected: String,
        /// What the configuration gives.
        actual: String,
    },
}

/// A unit's bit-exact model for one configuration.
pub struct UnitModel {
    /// The unit.
    pub unit: &'static RtlUnit,
    /// Its traced design.
    pub design: Design,
    /// Its emitted module (ports, flags, latency).
    pub emitted: Emitted,
    prog: Compiled,
    outputs: Vec<Field>,
    /// The trace's input slot of each input field.
    slots: Vec<usize>,
}

impl UnitModel {
    /// Open `unit` for the configuration `config` with `sets` applied in
    /// order (each `KEY=VALUE`, as `--set`).
    ///
    /// # Errors
    ///
    /// [`ModelError::UnknownUnit`] when no unit with RTL is named `unit`; [`ModelError::Config`]
    /// when the configuration file cannot be read, or the configuration or an override is
    /// refused; then as [`UnitModel::of`].
    pub fn open(unit: &str, config: ConfigSource, sets: &[String]) -> Result<Self, ModelError> {
        let u = units::unit(unit).ok_or_else(|| ModelError::UnknownUnit {
            name: crate::escape::line(unit),
            units: units::names(),
        })?;
        let cfg = match config {
            ConfigSource::Default => Config::resolve(None, sets)?,
            ConfigSource::File(p) => Config::resolve(Some(p), sets)?,
            ConfigSource::Text { text, name } => Config::resolve_text(text, name, sets)?,
        };
        Self::of(u, &cfg)
    }

    /// The model of `u` for a resolved configuration.
    ///
    /// # Errors
    ///
    /// [`ModelError::Rtl`] when the design cannot be built, emitted or compiled
    /// ([`units::emit_unit`], [`units::compile_outputs`]); [`ModelError::Wide`] when an unsigned
    /// input or output port is wider than 63 bits.
    ///
    /// # Panics
    ///
    /// Never: the emitted module's input fields are the trace's input ports, each an input node.
    pub fn of(u: &'static RtlUnit, cfg: &Config) -> Result<Self, ModelError> {
        let (design, emitted) = units::emit_unit(u, cfg)?;
        let prog = units::compile_outputs(&design)?;
        let outputs: Vec<Field> = emitted
            .outputs
            .iter()
            .filter(|f| f.name != "ovf" || emitted.flags.is_empty())
            .cloned()
            .collect();
        for f in emitted.inputs.iter().chain(&outputs) {
            if !f.format.signed() && f.format.width() > 63 {
                return Err(ModelError::Wide {
                    port: f.name.clone(),
                    format: f.format,
                });
            }
        }
        let ports = design.trace.input_ports();
        let slots = emitted
            .inputs
            .iter()
            .map(|f| {
                let p = ports
                    .iter()
                    .find(|p| p.name == f.name)
                    .expect("every input field is a traced input port");
                match design.trace.ops()[p.value.node()] {
                    crate::datapath::Op::Input(slot) => slot,
                    _ => unreachable!("an input port is an input node"),
                }
            })
            .collect();
        Ok(UnitModel {
            unit: u,
            design,
            emitted,
            prog,
            outputs,
            slots,
        })
    }

    /// The emitted module's name (`normalize`, `pipeline_smooth`, …).
    pub fn module(&self) -> &str {
        &self.emitted.module
    }

    /// Input ports, in the module's and the vector files' order.
    pub fn inputs(&self) -> &[Field] {
        &self.emitted.inputs
    }

    /// Output ports, in order, without the flag word.
    pub fn outputs(&self) -> &[Field] {
        &self.outputs
    }

    /// The overflow-flag stage ids, flag 0 first (bit `F−1−k` of the flag
    /// word is stage `k`).
    pub fn flags(&self) -> &[String] {
        &self.emitted.flags
    }

    /// Cycles from an input transfer to its output in the emitted module
    /// (no stalls).
    pub fn latency(&self) -> u32 {
        self.emitted.latency
    }

    /// The set-up ports (empty: every input travels with the item).
    pub fn setup(&self) -> &[SetupPort] {
        &self.emitted.setup
    }

    /// The set-up port whose fields include input `name`, if any.
    pub fn setup_group(&self, name: &str) -> Option<&'static str> {
        self.emitted
            .setup
            .iter()
            .find(|g| g.fields.iter().any(|f| f == name))
            .map(|g| g.name)
    }

    /// The port layout in one line, for callers generated for one
    /// configuration to check they were given that configuration:
    /// `abi=1;unit=U;module=M;in=NAME:FMT,…;out=NAME:FMT,…;flags=F`.
    pub fn layout(&self) -> String {
        let list = |fs: &[Field]| {
            fs.iter()
                .map(|f| format!("{}:{}", f.name, f.format))
                .collect::<Vec<_>>()
                .join(",")
        };
        format!(
            "abi={ABI_VERSION};unit={};module={};in={};out={};flags={}",
            self.unit.name,
            self.emitted.module,
            list(self.inputs()),
            list(self.outputs()),
            self.flags().len()
        )
    }

    /// Refuse a caller generated for another layout.
    ///
    /// # Errors
    ///
    /// [`ModelError::Layout`] when `expected` is neither empty nor [`UnitModel::layout`].
    pub fn check_layout(&self, expected: &str) -> Result<(), ModelError> {
        let actual = self.layout();
        if expected.is_empty() || expected == actual {
            Ok(())
        } else {
            Err(ModelError::Layout {
                expected: crate::escape::line(expected),
                actual,
            })
        }
    }

    /// The vector manifest's description of this unit (fields, formats,
    /// flags, latency, set-up ports, parameters), as JSON.
    ///
    /// # Panics
    ///
    /// Never: the design compiled when the model was opened, its module was emitted from it, and
    /// an empty set holds no code to refuse.
    pub fn manifest(&self) -> serde_json::Value {
        let vs = units::vector_set(&self.design, &self.emitted, Vec::new(), 0, 0)
            .expect("an empty vector set is valid");
        let mut m = vs.manifest();
        m["layout"] = self.layout().into();
        m["abi_version"] = ABI_VERSION.into();
        m
    }

    /// The real-arithmetic reference of `n` rows of input values (`n ×
    /// inputs().len()`, row by row) into `outputs` (`n × outputs().len()`):
    /// the traced datapath with every quantization the identity and every
    /// table its exact function ([`crate::datapath::Trace::run_f64`]), so
    /// the bit-exact model's error against it is the error of its formats.
    ///
    /// # Errors
    ///
    /// [`ModelError::Shape`] when `inputs` does not hold `n × inputs().len()` values or
    /// `outputs` does not hold `n × outputs().len()`.
    pub fn reference(
        &self,
        n: usize,
        inputs: &[f64],
        outputs: &mut [f64],
    ) -> Result<(), ModelError> {
        let ni = self.inputs().len();
        let no = self.outputs().len();
        if inputs.len() != n * ni {
            return Err(ModelError::Shape {
                what: "inputs",
                expected: n * ni,
                got: inputs.len(),
            });
        }
        if outputs.len() != n * no {
            return Err(ModelError::Shape {
                what: "outputs",
                expected: n * no,
                got: outputs.len(),
            });
        }
        let outs: Vec<_> = self
            .design
            .trace
            .output_ports()
            .iter()
            .map(|p| p.value)
            .collect();
        let nslots = self.slots.iter().max().map_or(0, |m| m + 1);
        let mut row = vec![0f64; nslots];
        for i in 0..n {
            for (k, &s) in self.slots.iter().enumerate() {
                row[s] = inputs[i * ni + k];
            }
            let r = self.design.trace.run_f64(&row, &outs);
            outputs[i * no..(i + 1) * no].copy_from_slice(&r);
        }
        Ok(())
    }

    /// Evaluate `n` rows: `inputs` holds `n × inputs().len()` codes row by
    /// row; `outputs` receives `n × outputs().len()` codes row by row and
    /// `flags` (when given) `n` flag words. Every input code is checked
    /// against its port's format first; on an error nothing is written.
    ///
    /// # Errors
    ///
    /// [`ModelError::Shape`] when `inputs`, `outputs` or `flags` (when given) does not hold
    /// `n × inputs().len()`, `n × outputs().len()` or `n` values; [`ModelError::Code`] for the
    /// first input code outside its port's format.
    pub fn eval(
        &self,
        n: usize,
        inputs: &[i64],
        outputs: &mut [i64],
        flags: Option<&mut [u64]>,
    ) -> Result<(), ModelError> {
        let ni = self.inputs().len();
        let no = self.outputs().len();
        let shape = |what, expected: usize, got| {
            if expected == got {
                Ok(())
            } else {
                Err(ModelError::Shape {
                    what,
                    expected,
                    got,
                })
            }
        };
        shape("inputs", n * ni, inputs.len())?;
        shape("outputs", n * no, outputs.len())?;
        if let Some(f) = &flags {
            shape("flags", n, f.len())?;
        }
        for (row, r) in inputs.chunks(ni.max(1)).enumerate().take(n) {
            for (f, &c) in self.inputs().iter().zip(r) {
                let (min, max) = (f.format.min_code(), f.format.max_code());
                if !(min..=max).contains(&i128::from(c)) {
                    return Err(ModelError::Code {
                        row,
                        port: f.name.clone(),
                        code: c,
                        format: f.format,
                        min,
                        max,
                    });
                }
            }
        }
        let cols: Vec<Vec<i128>> = (0..ni)
            .map(|k| (0..n).map(|i| i128::from(inputs[i * ni + k])).collect())
            .collect();
        let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
        let (res, words) = self.prog.run_flags_i128(&refs);
        for (k, col) in res.iter().enumerate() {
            for (i, &c) in col.iter().enumerate() {
                outputs[i * no + k] = narrow::<i64, _>(c);
            }
        }
        if let Some(f) = flags {
            if self.flags().is_empty() {
                f.fill(0);
            } else {
                f.copy_from_slice(&words);
            }
        }
        Ok(())
    }
}
