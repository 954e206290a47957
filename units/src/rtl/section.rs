//! The `[rtl]` configuration section (how the generated RTL is pipelined)
//! and its reading into the RTL backend's options ([`Pipelining`],
//! [`Handshake`]): the backend (`fxshade-backend`) knows no configuration.

use super::timing::{Handshake, Pipelining, Target};

/// The `[rtl]` section, typed (one field per declared field).
#[derive(Clone, Copy, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RtlConfig {
    /// Compact, or registers placed by `target`'s delay model.
    pub pipeline: PipelineMode,
    /// The technology whose delay model places the registers.
    pub target: Target,
    /// The requested clock period in ns.
    pub clock_ns: f64,
    /// One global stall, or an output FIFO.
    pub handshake: HandshakeMode,
    /// How the pipeline tops take their per-frame and per-triangle values.
    pub setup: Setup,
}

impl crate::config::Section for RtlConfig {
    const DECL: &'static crate::config::UnitDecl = &DECL;
}

/// `rtl.pipeline`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PipelineMode {
    /// A register after every quantization and table read.
    Compact,
    /// Registers where the target's delay model needs them.
    Target,
}

/// `rtl.handshake`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HandshakeMode {
    /// One global stall.
    Stall,
    /// An output FIFO; the pipeline never stalls.
    Fifo,
}

/// `rtl.setup`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Setup {
    /// Set-up ports into double-buffered registers.
    Port,
    /// Set-up ports into one register a field.
    Hold,
    /// Carried with every pixel.
    Pixel,
}

/// The pipelining policy of a configuration's `[rtl]` section.
pub fn pipelining(cfg: &crate::Config) -> Pipelining {
    let r: RtlConfig = cfg.section();
    match r.pipeline {
        PipelineMode::Target => Pipelining::Target {
            target: r.target,
            clock_ns: r.clock_ns,
        },
        PipelineMode::Compact => Pipelining::Compact,
    }
}

/// The handshake of a configuration's `[rtl]` section.
pub fn handshake(cfg: &crate::Config) -> Handshake {
    match cfg.section::<RtlConfig>().handshake {
        HandshakeMode::Fifo => Handshake::Fifo,
        HandshakeMode::Stall => Handshake::Stall,
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

/// The `[rtl]` section as a registry entry (no datapath of its own).
pub struct RtlSection;

crate::unit!(RtlSection, decl: DECL, section: RtlConfig, check: check, ops: ops, rtl: &[]);

/// The registry entry of the `[rtl]` section.
pub static UNIT: RtlSection = RtlSection;
