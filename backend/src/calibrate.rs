//! Probes that calibrate the delay model ([`super::timing`]): one
//! operation of each kind and several widths, alone between two registers
//! (`fxshade synth calibrate --target T` places and routes each in the
//! synthesis harness, whose input registers start the path and whose stage
//! register ends it, and prints the measured period beside the model's).

use super::timing::Target;
use super::Design;
use crate::datapath::{Datapath, Trace};
use crate::format::Format;
use crate::quantize::{Overflow, Quant, Rounding};

/// One calibration probe.
#[derive(Clone, Debug)]
pub struct Probe {
    /// What it measures, e.g. `mul 16x16`.
    pub label: String,
    /// The probe's design (compact pipelining: the operation, then one
    /// register).
    pub design: Design,
    /// The delay model's period for it: register overhead plus the
    /// operation, ns.
    pub predicted_ns: f64,
}

fn q(f: Format, round: Rounding, overflow: Overflow) -> Quant {
    Quant::new("out", f, round, overflow)
}

fn fmt(signed: bool, width: u32) -> Format {
    Format::new(signed, width, 0).expect("probe widths are small")
}

fn design(label: &str, trace: Trace) -> Design {
    Design {
        module: format!("probe_{}", label.replace([' ', 'x', '+'], "_")),
        unit: "probe",
        variant: label.to_string(),
        trace,
        config_source: "<calibration probe>".into(),
        config_toml: String::new(),
        config_key: String::new(),
        notes: vec![format!("Delay-model calibration probe: {label}.")],
        pipelining: super::timing::Pipelining::Compact,
        setup: Vec::new(),
        handshake: super::timing::Handshake::Stall,
        parameters: serde_json::Value::Null,
    }
}

/// The probes for `target`: adders, multipliers (DSP-sized and not), and
/// a rounding incrementer with saturation; none for a family without a
/// delay model (nothing to calibrate).
///
/// # Panics
///
/// Never: every probe's formats are constants that fit.
pub fn probes(target: Target) -> Vec<Probe> {
    let Some(m) = target.delay() else {
        return Vec::new();
    };
    let mut out = Vec::new();
    // Adders: a + b of w − 1 bits each, exact in w bits.
    for w in [9u32, 17, 33, 49] {
        let mut t = Trace::new();
        let a = t.input_named("a", &q(fmt(true, w - 1), Rounding::Trunc, Overflow::Wrap));
        let b = t.input_named("b", &q(fmt(true, w - 1), Rounding::Trunc, Overflow::Wrap));
        let s = t.add(a, b);
        let y = t.quantize(s, &q(fmt(true, w), Rounding::Trunc, Overflow::Wrap));
        t.output("y", y);
        let label = format!("add {w}");
        out.push(Probe {
            design: design(&label, t),
            label,
            predicted_ns: m.reg + m.add(w),
        });
    }
    // Multipliers: signed a × b, the exact product kept.
    for (wa, wb) in [
        (8u32, 8u32),
        (12, 12),
        (16, 4),
        (16, 8),
        (16, 16),
        (18, 18),
        (24, 18),
    ] {
        let mut t = Trace::new();
        let a = t.input_named("a", &q(fmt(true, wa), Rounding::Trunc, Overflow::Wrap));
        let b = t.input_named("b", &q(fmt(true, wb), Rounding::Trunc, Overflow::Wrap));
        let p = t.mul(a, b);
        let y = t.quantize(p, &q(fmt(true, wa + wb), Rounding::Trunc, Overflow::Wrap));
        t.output("y", y);
        let label = format!("mul {wa}x{wb}");
        out.push(Probe {
            design: design(&label, t),
            label,
            predicted_ns: m.reg + m.mul(wa, wb),
        });
    }
    // Round half-even 32 → 16 bits dropping 8, then saturate 8 bits.
    {
        let mut t = Trace::new();
        let a = t.input_named(
            "a",
            &q(
                Format::new(true, 32, 16).expect("fits"),
                Rounding::Trunc,
                Overflow::Wrap,
            ),
        );
        let f = Format::new(true, 16, 8).expect("fits");
        let y = t.quantize(a, &q(f, Rounding::HalfEven, Overflow::Saturate));
        t.output("y", y);
        let label = "round+sat 32 to 16".to_string();
        let rw = super::bits::rounded_width(32, 8, Rounding::HalfEven);
        out.push(Probe {
            design: design(&label, t),
            label,
            predicted_ns: m.reg + m.round(8, rw, true) + m.saturate(rw - 16 + 1, true),
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_probe_emits_one_stage_and_its_predicted_period_is_positive() {
        for t in Target::pipelined() {
            for p in probes(t) {
                let e = super::super::emit(&p.design).expect("a probe emits");
                // One stage and the output buffer's head.
                assert_eq!(e.latency, 2, "{}", p.label);
                assert!(p.predicted_ns > 0.0);
                assert!(e.verilog.contains(&format!("module {}", p.design.module)));
            }
        }
    }
}
