//! The `[rtl]` configuration section (how the generated RTL is pipelined)
//! and its reading into the RTL backend's options ([`Pipelining`],
//! [`Handshake`]): the backend (`fxshade-backend`) knows no configuration.

use super::timing::{Handshake, Pipelining, Target};

/// The pipelining policy of a configuration's `[rtl]` section.
///
/// # Panics
///
/// Never: `rtl.target` is checked against [`Target::pipelined_names`], each of which
/// [`Target::from_name`] accepts.
pub fn pipelining(cfg: &crate::Config) -> Pipelining {
    match cfg.unit("rtl").choice("pipeline") {
        "target" => Pipelining::Target {
            target: Target::from_name(cfg.unit("rtl").choice("target"))
                .expect("the configuration checks the name"),
            clock_ns: cfg.unit("rtl").number("clock_ns"),
        },
        _ => Pipelining::Compact,
    }
}

/// The handshake of a configuration's `[rtl]` section.
pub fn handshake(cfg: &crate::Config) -> Handshake {
    match cfg.unit("rtl").choice("handshake") {
        "fifo" => Handshake::Fifo,
        _ => Handshake::Stall,
    }
}

/// The `[rtl]` configuration section: how the generated RTL is pipelined.
pub static DECL: crate::config::UnitDecl = crate::config::UnitDecl {
    name: "rtl",
    doc: "how the generated RTL is pipelined (every unit and top)",
    fields: &[
        crate::config::FieldDecl {
            name: "pipeline",
            kind: crate::config::FieldKind::Choice(&["compact", "target"]),
            doc: "compact: a register after every quantization and table read; target: registers where the delay model of rtl.target needs them for rtl.clock_ns",
        },
        crate::config::FieldDecl {
            name: "target",
            kind: crate::config::FieldKind::ChoiceOf(Target::pipelined_names),
            doc: "the technology whose delay model places the registers (rtl.pipeline = \"target\")",
        },
        crate::config::FieldDecl {
            name: "clock_ns",
            kind: crate::config::FieldKind::Number {
                min: 0.1,
                max: 1000.0,
            },
            doc: "the requested clock period in ns (rtl.pipeline = \"target\")",
        },
        crate::config::FieldDecl {
            name: "handshake",
            kind: crate::config::FieldKind::Choice(&["stall", "fifo"]),
            doc: "stall: one global stall, a register: every stage holds while the two-entry output buffer (head and skid register) is full; fifo: the pipeline never stalls and ends in an output FIFO with room for every item in flight and a head register, ready_o a registered credit check. Either way ready_o, valid_o and the outputs are registers, latency one more than the stages",
        },
        crate::config::FieldDecl {
            name: "setup",
            kind: crate::config::FieldKind::Choice(&["port", "hold", "pixel"]),
            doc: "the pipeline tops' per-frame and per-triangle values: port: loaded through set-up ports (frame_valid_i, tri_valid_i) into registers the stages read, the triangle's double-buffered (two banks, a tag per stage: the next triangle loads while the last one's pixels are in flight); hold: the same ports with one register a field (a triangle waits until the stages reading them have drained: fewer flip-flops, more cycles per pixel on small triangles); pixel: carried with every pixel through the pipeline registers",
        },
    ],
    groups: &[],
};

fn check(_: &crate::Config) -> Result<(), Vec<crate::config::ConfigError>> {
    Ok(())
}

fn ops(_: &crate::Config) -> Vec<crate::units::OpReport> {
    Vec::new()
}

/// The registry entry of the `[rtl]` section (no datapath of its own).
pub static UNIT: crate::units::UnitEntry = crate::units::UnitEntry {
    decl: &DECL,
    check,
    ops,
    rtl: &[],
};
