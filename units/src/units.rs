//! The registry of units: each unit's configuration declaration, its
//! configuration check, its operation-count runs and its RTL modules. Config
//! parsing, `ops`, `stages`, the RTL flow, `fxshade rtl`, the report and the
//! tests (through `fxshade rtl list`) all iterate this one list.

use crate::config::{field_error, Config, ConfigError, UnitConfig, UnitDecl};
use crate::datapath::{Count, OpCounts};

/// Per-pixel work or once-per-triangle set-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    /// Once per triangle.
    Setup,
    /// Once per pixel.
    Pixel,
}

/// What a paper claims a variant costs, for comparison with measured counts
/// (`None` where the paper gives no figure).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct PaperClaim {
    /// Multiplications.
    pub mul: Option<u64>,
    /// Additions and subtractions.
    pub add: Option<u64>,
    /// Divisions.
    pub div: Option<u64>,
    /// Square roots.
    pub sqrt: Option<u64>,
    /// Table reads.
    pub table_read: Option<u64>,
    /// Where the claim is made.
    pub source: &'static str,
}

/// Measured operation counts of one variant of one unit.
#[derive(Clone, Debug, serde::Serialize)]
pub struct OpReport {
    /// Unit name (its configuration section).
    pub unit: &'static str,
    /// Variant.
    pub variant: &'static str,
    /// `setup` or `pixel`.
    pub stage: Phase,
    /// The counts, from running the datapath in [`Count`].
    #[serde(flatten)]
    pub counts: OpCounts,
    /// The paper's claim, where it makes one.
    pub paper: Option<PaperClaim>,
    /// Every quantization point, in datapath order.
    pub quant_points: Vec<crate::datapath::QuantPoint>,
}

impl OpReport {
    /// Mark which quantization points an output of `trace` reads: `trace`
    /// is the same datapath run in the tracing context, whose `k`-th
    /// quantization is the counting run's `k`-th point (nothing is marked
    /// when their numbers differ).
    pub fn with_liveness(mut self, trace: &crate::datapath::Trace) -> Self {
        let roots: Vec<_> = trace.output_ports().iter().map(|p| p.value).collect();
        let live = trace.live_nodes(&roots);
        let quants: Vec<bool> = trace
            .ops()
            .iter()
            .enumerate()
            .filter(|(_, o)| matches!(o, crate::datapath::Op::Quant(..)))
            .map(|(i, _)| live[i])
            .collect();
        if quants.len() == self.quant_points.len() {
            for (p, l) in self.quant_points.iter_mut().zip(quants) {
                p.live = Some(l);
            }
        }
        self
    }

    /// A report from a counting run.
    pub fn from_count(
        unit: &'static str,
        variant: &'static str,
        stage: Phase,
        cx: &Count,
        paper: Option<PaperClaim>,
    ) -> Self {
        OpReport {
            unit,
            variant,
            stage,
            counts: cx.counts(),
            paper,
            quant_points: cx.quant_points().to_vec(),
        }
    }
}

/// A registered unit.
pub struct UnitEntry {
    /// Its configuration section.
    pub decl: &'static UnitDecl,
    /// Validate a configuration beyond syntax (e.g. exact widths).
    pub check: fn(&Config) -> Result<(), Vec<ConfigError>>,
    /// Run every variant in the counting context.
    pub ops: fn(&Config) -> Vec<OpReport>,
    /// Its modules with generated RTL (the pipeline section holds two: the
    /// angle interpolation and the top).
    pub rtl: &'static [&'static crate::rtl::units::RtlUnit],
}

/// Every unit, in pipeline order.
pub static UNITS: &[&UnitEntry] = &[
    &crate::interp::UNIT,
    &crate::normalizer::UNIT,
    &crate::angles::UNIT,
    &crate::polar::UNIT,
    &crate::lighting::UNIT,
    &crate::pipeline::UNIT,
    &crate::rtl::section::UNIT,
];

/// Map the first width error of a counting run (the root cause: later ones
/// follow from it) to a configuration error naming the stage it came from.
///
/// # Errors
///
/// One [`ConfigError::BadValue`] ([`field_error`]) for the first width error `cx` recorded, naming
/// its first operand's stage when that is a field of `unit`, else the second's.
pub fn width_errors(cx: &Count, unit: &UnitConfig) -> Result<(), Vec<ConfigError>> {
    let errs: Vec<ConfigError> = cx
        .width_errors()
        .iter()
        .take(1)
        .map(|e| {
            // Name the operand that is a configuration key (a literal is not).
            let key = if unit.decl.fields.iter().any(|f| f.name == e.a) {
                e.a
            } else {
                e.b
            };
            field_error(unit, key, e.to_string())
        })
        .collect();
    if errs.is_empty() {
        Ok(())
    } else {
        Err(errs)
    }
}
