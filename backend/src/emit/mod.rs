//! The emitter's passes over one traced datapath, each an `impl` block of
//! the crate's `Emitter` (or free functions) in a module of its own:
//! schedule → balance → flags → tables and products as nodes are placed →
//! handshake → formal properties; `emit_with` in the crate root runs them
//! and the naming and line-wrapping passes write the text.

pub(crate) mod balance;
pub(crate) mod flags;
pub(crate) mod formal;
pub(crate) mod handshake;
pub(crate) mod multiply;
pub(crate) mod schedule;
pub(crate) mod tables;

/// A design of `trace` for the passes' tests (compact pipelining, the
/// stall handshake unless changed).
#[cfg(test)]
pub(crate) fn test_design(trace: crate::datapath::Trace) -> crate::Design {
    crate::Design {
        module: "pass_test".into(),
        unit: "pass_test",
        variant: "test".into(),
        trace,
        config_source: "<test>".into(),
        config_toml: String::new(),
        config_key: String::new(),
        notes: Vec::new(),
        pipelining: crate::timing::Pipelining::Compact,
        setup: Vec::new(),
        handshake: crate::timing::Handshake::Stall,
        parameters: serde_json::Value::Null,
    }
}

/// A quantization to `S<width>F0` at `stage`, truncating, saturating.
#[cfg(test)]
pub(crate) fn sat(stage: &'static str, width: u32) -> crate::quantize::Quant {
    crate::quantize::Quant::new(
        stage,
        crate::format::Format::new(true, width, 0).expect("a small format"),
        crate::quantize::Rounding::Trunc,
        crate::quantize::Overflow::Saturate,
    )
}

/// `y_1 = Q(a + b)`, `y_{k+1} = Q(y_k + b)` for `depth` quantizations of
/// stage `<unit>.y` (9 bits, from 8-bit inputs), output `z`: a pipeline of
/// `depth` compact stages for the passes' tests.
#[cfg(test)]
pub(crate) fn chain(unit: &str, depth: usize) -> crate::datapath::Trace {
    use crate::datapath::Datapath;
    let stage = |s: &str| -> &'static str { Box::leak(format!("{unit}.{s}").into_boxed_str()) };
    let mut t = crate::datapath::Trace::new();
    let a = t.input_named("a", &sat(stage("in"), 8));
    let b = t.input_named("b", &sat(stage("in"), 8));
    let s = t.add(a, b);
    let mut y = t.quantize(s, &sat(stage("y"), 9));
    for _ in 1..depth {
        let s = t.add(y, b);
        y = t.quantize(s, &sat(stage("y"), 9));
    }
    t.output("z", y);
    t
}
