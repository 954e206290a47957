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

/// A unit: one entry of the registry ([`UNITS`]) from which the
/// configuration, the CLI's choices, `ops`, `explore`, the RTL flow, the
/// report and the tests are derived. Adding a unit is its folder (its
/// datapath, its [`crate::config::Section`] and this trait), one line in
/// [`UNITS`], its section of `default.toml`, its tests and its golden files.
pub trait Unit: Sync {
    /// Its configuration section's declaration (keys, kinds, ranges, docs).
    fn decl(&self) -> &'static UnitDecl;

    /// Its name: the configuration section's.
    fn name(&self) -> &'static str {
        self.decl().name
    }

    /// Reads its typed section from `cfg` ([`Config::section`]) and
    /// reports whether the type matches the declaration.
    ///
    /// # Errors
    ///
    /// The [`crate::config::SectionError`] of [`UnitConfig::try_typed`].
    fn section_is_typed(&self, cfg: &Config) -> Result<(), crate::config::SectionError>;

    /// Validate a configuration beyond syntax (e.g. exact widths).
    ///
    /// # Errors
    ///
    /// Every [`ConfigError`] found, each naming the field it is about.
    fn check(&self, cfg: &Config) -> Result<(), Vec<ConfigError>>;

    /// Run every variant in the counting context.
    fn ops(&self, cfg: &Config) -> Vec<OpReport>;

    /// Its modules with generated RTL (variants, design, input vectors,
    /// corner cases; the pipeline section holds two: the angle
    /// interpolation and the top).
    fn rtl(&self) -> &'static [&'static crate::rtl::units::RtlUnit];
}

/// `impl Unit` for a unit type from its declaration, typed section, check,
/// counting run and RTL list — the five things every unit states.
#[macro_export]
macro_rules! unit {
    ($ty:ident, decl: $decl:expr, section: $sec:ty, check: $check:expr, ops: $ops:expr,
     rtl: $rtl:expr $(,)?) => {
        impl $crate::units::Unit for $ty {
            fn decl(&self) -> &'static $crate::config::UnitDecl {
                &$decl
            }
            fn section_is_typed(
                &self,
                cfg: &$crate::config::Config,
            ) -> Result<(), $crate::config::SectionError> {
                cfg.unit(<$sec as $crate::config::Section>::DECL.name)
                    .try_typed::<$sec>()
                    .map(|_| ())
            }
            fn check(
                &self,
                cfg: &$crate::config::Config,
            ) -> Result<(), Vec<$crate::config::ConfigError>> {
                $check(cfg)
            }
            fn ops(&self, cfg: &$crate::config::Config) -> Vec<$crate::units::OpReport> {
                $ops(cfg)
            }
            fn rtl(&self) -> &'static [&'static $crate::rtl::units::RtlUnit] {
                const MODULES: &[&$crate::rtl::units::RtlUnit] = $rtl;
                MODULES
            }
        }
    };
}

/// Every unit, in pipeline order.
pub static UNITS: &[&dyn Unit] = &[
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{FieldKind, Section};

    /// Every unit's typed section reads the embedded configuration, and
    /// every name of every declared choice (a choice the struct's type
    /// cannot name, or a field on one side only, fails here, not in use).
    #[test]
    fn every_typed_section_matches_its_declaration_for_every_choice() {
        let base = Config::embedded();
        for u in UNITS {
            u.section_is_typed(&base)
                .unwrap_or_else(|e| panic!("{}: {e}", u.name()));
            for f in u.decl().fields {
                let names: &[&str] = match f.kind {
                    FieldKind::Choice(n) => n,
                    FieldKind::ChoiceOf(n) => n(),
                    _ => continue,
                };
                for n in names {
                    let set = format!("{}.{}=\"{n}\"", u.name(), f.name);
                    let c = Config::resolve(None, std::slice::from_ref(&set))
                        .unwrap_or_else(|e| panic!("{set}: {e}"));
                    u.section_is_typed(&c)
                        .unwrap_or_else(|e| panic!("{set}: {e}"));
                }
            }
        }
    }

    /// The typed value is the declared value: the normalizer's Θ and
    /// method, the polar table format and an integer, set by flags, read
    /// back through the section types.
    #[test]
    fn typed_sections_carry_the_configured_values() {
        let c = Config::resolve(
            None,
            &[
                "normalize.theta=0.75".into(),
                "normalize.method=\"linear\"".into(),
                "polar.table.format=\"I1F13\"".into(),
                "polar.angle_bits=12".into(),
                "rtl.handshake=\"fifo\"".into(),
            ],
        )
        .unwrap();
        let n: crate::normalizer::NormalizeConfig = c.section();
        assert_eq!(n.theta, 0.75);
        assert_eq!(n.method, crate::normalizer::Method::Linear);
        let p: crate::polar::PolarConfig = c.section();
        assert_eq!(p.table.format().to_string(), "I1F13");
        assert_eq!(p.table.stage(), "table");
        assert_eq!(p.angle_bits, 12);
        let r: crate::rtl::section::RtlConfig = c.section();
        assert_eq!(r.handshake, crate::rtl::section::HandshakeMode::Fifo);
        // The defaults are the embedded file's.
        assert_eq!(crate::normalizer::NormalizeConfig::defaults().theta, 0.5);
    }
}
