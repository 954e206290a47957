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
