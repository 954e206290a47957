//! Verilog generated from a traced datapath: the RTL view of a unit.
//!
//! A unit's datapath is recorded once in [`Trace`] (named input ports, the
//! operations at their exact formats, quantizations with their modes and
//! qualified stage ids, constants, selects and table reads, named output
//! ports). [`emit`] walks that graph and writes one self-contained Verilog
//! module:
//!
//! * every value is a wire of exactly its model format (no spare bits);
//!   additions align their operands by concatenation to the exact result
//!   width; a signed × unsigned product zero-extends the unsigned operand by
//!   one bit (the only extra bit, which a signed multiplier needs);
//! * every quantization is written out bit for bit ([`bits::quantize`]):
//!   a slice, one rounding incrementer for a nearest mode, a range check on
//!   the bits above the target, and wrap or saturate;
//! * tables are ROM functions in the source (full, or a quarter wave with
//!   symmetry logic), read through a register;
//! * pipelining (`compact`): a register after every quantization and every
//!   table read; values that skip stages are carried by balancing
//!   registers; each quantization's overflow bit is registered once after
//!   its stage and ORed there into one running register per stage id,
//!   which travels to `ovf_o`;
//! * handshake: valid/ready with one global stall `en`, a register (the
//!   stages stop while the two-entry output buffer is full; `ready_o =
//!   en`), or with `rtl.handshake = "fifo"` a pipeline that never stalls
//!   and an output FIFO; a valid bit per stage reset by `rst_ni`.
//!
//! The module's header names the generator, the configuration (its source
//! and hash), the latency and every port with its format.

#![warn(missing_docs, clippy::missing_errors_doc, clippy::missing_panics_doc)]
// No bare numeric `as` (see fxshade-numbers).
#![warn(
    clippy::cast_lossless,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::cast_precision_loss
)]
// Tests build expected values with plain conversions.
#![cfg_attr(
    test,
    allow(
        clippy::cast_lossless,
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        clippy::cast_possible_wrap,
        clippy::cast_precision_loss
    )
)]

pub mod axis;
pub use fxshade_numbers::bits;
pub mod calibrate;
pub mod core;
pub mod datasheet;
pub mod estimate;
pub mod naming;
pub mod record;
pub mod targets;
pub mod testbench;
pub mod timing;
pub mod wrap;

mod emit;
use emit::formal::{formal_block, formal_block_fifo};
use emit::handshake::{fifo_handshake, fifo_outputs, stall_handshake, stall_outputs};
use emit::schedule::sink_plan;
use emit::tables::banked_port;

// The layers below, under the paths the emitter is written with.
use fxshade_ir::{datapath, escape};
use fxshade_numbers::{format, quantize};

use std::collections::HashMap;
use std::fmt::Write as _;

use crate::datapath::{Mutation, MutationKind, Op, Port, Table, Trace, TV};
use crate::format::Format;
use crate::quantize::{Overflow, Rounding};
use crate::record::{Field, GENERATOR};
use bits::Val;

/// A unit's datapath, ready to emit: the trace with named ports, and what
/// the header says about it.
#[derive(Clone, Debug)]
pub struct Design {
    /// Module name (the unit's name).
    pub module: String,
    /// Unit (registry name).
    pub unit: &'static str,
    /// Variant (method, scheme, path …).
    pub variant: String,
    /// The traced datapath, with named inputs and outputs.
    pub trace: Trace,
    /// Where the configuration came from, and its overrides.
    pub config_source: String,
    /// The effective configuration as TOML (what a vector set records).
    pub config_toml: String,
    /// The configuration this design depends on, as text: the sections
    /// its unit read while building it. Its [`fingerprint`](record::fingerprint)
    /// is the hash in the generated header and the core's name
    /// ([`Design::config_hash`]).
    pub config_key: String,
    /// Lines describing the configuration (coefficients, tables …).
    pub notes: Vec<String>,
    /// Where the pipeline registers go (`[rtl]`).
    pub pipelining: timing::Pipelining,
    /// Set-up ports: groups of inputs loaded through a handshake of their
    /// own and held in registers, rather than carried with every item
    /// (empty: every input travels with the item).
    pub setup: Vec<SetupGroup>,
    /// How the stages hand items on (`[rtl]`).
    pub handshake: timing::Handshake,
    /// The unit's parameters in machine-readable form (the normalizer's
    /// coefficient codes and values, highest power first): the vector
    /// manifest's `parameters` (`null` when there are none).
    pub parameters: serde_json::Value,
}

impl Design {
    /// The configuration hash of the generated header and the core's name:
    /// FNV-1a of [`Design::config_key`].
    pub fn config_hash(&self) -> u64 {
        crate::record::fingerprint(&[self.config_key.as_bytes()])
    }

    /// The sections [`Design::config_key`] holds, in its order.
    pub fn config_sections(&self) -> Vec<&str> {
        self.config_key
            .lines()
            .filter_map(|l| l.strip_prefix('[').and_then(|l| l.strip_suffix(']')))
            .collect()
    }
}

/// A group of inputs loaded through a set-up port of its own (per frame,
/// per triangle): `<name>_valid_i` / `<name>_ready_o` and the group's
/// input ports, held in registers `<field>_q` that every pipeline stage
/// reads directly.
///
/// A held port (not [`SetupGroup::banked`]) accepts a record only when
/// the stages that read the group's registers are empty: `<name>_ready_o`
/// is a register (`<name>_ready_q`), raised the cycle after a record is
/// offered if stages `1..U` (`U` the last stage reading them, see
/// [`SetupPort::drain`]) will then be empty, and no item is taken in the
/// cycle the record loads (`setup_lock` lowers `ready_o`), so an item
/// always computes with the set-up values that were loaded when it
/// entered. With `U = 0` the port is always ready.
#[derive(Clone, Debug, PartialEq)]
pub struct SetupGroup {
    /// Port name (`frame`, `tri`).
    pub name: &'static str,
    /// One line for the header: what the group holds and when it changes.
    pub doc: &'static str,
    /// Its input ports (trace input names).
    pub fields: Vec<String>,
    /// Double-buffered: two banks `<field>_b0_q`, `<field>_b1_q`; a record
    /// loads the bank no item in the reading stages uses, and every item
    /// carries a tag naming the bank it reads (`<name>_tag_q`), so the next
    /// record loads while the last one's items are still in flight. For
    /// per-triangle values, where waiting for the pipe costs every
    /// triangle; a per-frame group waits (one drain a frame).
    pub banked: bool,
}

/// A set-up port as emitted.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SetupPort {
    /// Port name (`frame`, `tri`).
    pub name: &'static str,
    /// What it holds.
    pub doc: &'static str,
    /// Its fields (input ports), in vector-field order.
    pub fields: Vec<String>,
    /// The last stage reading its registers: the port accepts a record
    /// only when stages `1..=drain` are empty (0: always), and no item is
    /// taken in that cycle; with two banks, only when no item in stages
    /// `1..=drain` reads the bank it loads.
    pub drain: u32,
    /// Banks of registers: 2 when double-buffered (the port then waits
    /// only for the items of the bank it loads), else 1.
    pub banks: u32,
    /// Flip-flops holding its values (both banks, the tags and the
    /// port's state).
    pub flops: u64,
}

/// Why a design cannot be emitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EmitError {
    /// The datapath divides or takes a square root.
    #[error("unit {unit} ({variant}) needs a {op}, which has no RTL; choose a variant without division or square root")]
    NoRtl {
        /// Unit.
        unit: &'static str,
        /// Variant.
        variant: String,
        /// `division` or `square root`.
        op: &'static str,
    },
    /// The datapath has no named outputs.
    #[error("unit {0}: the datapath has no named outputs")]
    NoOutputs(&'static str),
    /// A value is wider than the emitter's 126 bits.
    #[error("unit {unit}: a value is {width} bits wide; the emitter handles at most 126")]
    TooWide {
        /// Unit.
        unit: &'static str,
        /// The width.
        width: u32,
    },
    /// Target pipelining for a family without a delay model.
    #[error("unit {unit}: target pipelining for {target}, which has no delay model")]
    NoDelayModel {
        /// Unit.
        unit: &'static str,
        /// The family's name.
        target: &'static str,
    },
}

/// One multiplier as the hardware builds it.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, serde::Serialize)]
pub struct MulHw {
    /// Width of the first operand as built.
    pub a_width: u32,
    /// Width of the second operand as built.
    pub b_width: u32,
    /// A signed multiplier (either operand signed: an unsigned operand is
    /// then zero-extended by one bit).
    pub signed: bool,
    /// The first operand is unsigned, zero-extended by one bit into the
    /// signed product (`a_width` includes that bit): a block that takes
    /// each operand signed or unsigned drops it ([`timing::Dsp::mixed`]).
    #[serde(default)]
    pub a_zext: bool,
    /// The same for the second operand.
    #[serde(default)]
    pub b_zext: bool,
    /// Width of the product as declared (0: `a_width + b_width`); synthesis
    /// leaves a product under a target's minimum result width in logic.
    #[serde(default)]
    pub y_width: u32,
}

impl std::fmt::Display for MulHw {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} × {} {}",
            self.a_width,
            self.b_width,
            if self.signed { "signed" } else { "unsigned" }
        )
    }
}

/// One ROM of the emitted module.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RomHw {
    /// Its array's name.
    pub name: String,
    /// Entries.
    pub entries: u64,
    /// Bits per entry.
    pub width: u32,
    /// Read ports: the table reads that index it.
    pub reads: u64,
    /// Marked for block RAM (`rom_style = "block"`, at least
    /// [`BLOCK_ROM_ENTRIES`] entries); else built from logic.
    pub block: bool,
}

/// The arithmetic the emitted module builds, from the trace (what
/// `fxshade ops --rtl` compares with the synthesized netlist).
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Hardware {
    /// Every multiplier, sorted.
    pub muls: Vec<MulHw>,
    /// Every adder and subtractor of the datapath (with the FIFO
    /// handshake, also the FIFO's pointer arithmetic), by result width,
    /// sorted.
    pub adders: Vec<u32>,
    /// Every adder/subtracter steered by a sign bit (`add_signed`), by
    /// result width, sorted: one unit each, written as an add and a
    /// subtract under a `? :` that synthesis merges (Yosys's `opt_share`).
    pub add_subs: Vec<u32>,
    /// Every rounding incrementer, by result width, sorted.
    pub incrementers: Vec<u32>,
    /// Comparators (`max`; with the FIFO handshake, its admission check).
    pub compares: u64,
    /// Multiplexers (`select`).
    pub selects: u64,
    /// Their size: Σ width × (options − 1), one 2:1 multiplexer bit each
    /// (with the choice of every `max`).
    #[serde(default)]
    pub select_bits: u64,
    /// Σ width over the datapath's comparators (`max`).
    #[serde(default)]
    pub compare_bits: u64,
    /// Σ bits read by quantizers' range checks ([`bits::QuantLogic`]).
    #[serde(default)]
    pub check_bits: u64,
    /// Σ output bits behind quantizers' saturation multiplexers.
    #[serde(default)]
    pub saturate_bits: u64,
    /// Table reads.
    pub table_reads: u64,
    /// Bits stored in ROMs (each distinct ROM once).
    pub rom_bits: u64,
    /// Every distinct ROM with its reads.
    #[serde(default)]
    pub roms: Vec<RomHw>,
    /// Flip-flops of the datapath (data, flags and valid bits).
    pub flops: u64,
    /// Of those, the FIFO handshake's entries (depth × output bits), a
    /// memory that synthesis may build as LUT RAM (0 with the stall
    /// handshake).
    #[serde(default)]
    pub fifo_bits: u64,
}

/// An emitted unit: its Verilog, its testbench and its vector layout.
#[derive(Clone, Debug)]
pub struct Emitted {
    /// Module name.
    pub module: String,
    /// The module's source (`<module>.v`).
    pub verilog: String,
    /// A self-checking testbench (`<module>_tb.v`) for `fxshade vectors`.
    pub testbench: String,
    /// The same checks driven from C++ for Verilator (`<module>_shell.v`,
    /// `<module>_main.cpp`).
    pub harness: testbench::Harness,
    /// Cycles from an input transfer to its output (no stalls).
    pub latency: u32,
    /// Where the pipeline registers went.
    pub pipelining: timing::Pipelining,
    /// Target pipelining: the delay model's slowest stage, register
    /// overhead included, ns.
    pub predicted_ns: Option<f64>,
    /// Target pipelining: operations slower than the period by themselves.
    pub too_slow: Vec<String>,
    /// The overflow-flag stages, flag 0 first; in `ovf_o` stage `k` is bit
    /// `F−1−k` (the first stage is the most significant bit).
    pub flags: Vec<String>,
    /// Input fields of a vector line, most significant first (the input
    /// ports in order).
    pub inputs: Vec<Field>,
    /// Output fields of a vector line: `ovf` (when any stage can overflow),
    /// then the output ports in order.
    pub outputs: Vec<Field>,
    /// What the module builds.
    pub hardware: Hardware,
    /// Set-up ports (empty: every input travels with the item).
    pub setup: Vec<SetupPort>,
    /// Where each live operation's value first appears: (trace node,
    /// stage `k`, the signal carrying it). With no stalls, the signal holds
    /// the value of the item that entered `k` cycles earlier. `fxshade
    /// equiv` cuts its proof there; a wrong entry can only fail a proof.
    pub cuts: Vec<(usize, u32, String)>,
    /// The products built as sums of partial products (a multiplier wider
    /// than the period or one DSP block allows): `fxshade equiv` writes the
    /// model's product as the same sum ([`Trace::smt_function_split`], exact
    /// by the split lemma) so the solver matches the partial products.
    ///
    /// [`Trace::smt_function_split`]: crate::datapath::Trace::smt_function_split
    pub splits: Vec<crate::datapath::MulSplit>,
    /// The signal name of every trace node (before the naming pass adds
    /// `_q`/`_d` and a register its `_s<k>` stage): [`node_names`]. A
    /// signal of the module is a node's name, or that name followed by
    /// `_` and a suffix — how a critical path is mapped back to nodes.
    pub node_names: Vec<String>,
}

/// The signal name of every node of `t`, stage-local rather than by trace
/// node number, so that a design's names survive a change elsewhere in the
/// trace:
///
/// * an input port `<port>_i` (`<port>_q` when `setup(port)`: a set-up
///   register);
/// * a quantization `<stage id>_<k>`, the `k`-th quantization of that
///   stage id (`normalize_d_0`; the components of a vector are 0, 1, 2);
/// * a table read `<table>_<k>`;
/// * any other operation `<owner>_<op><k>` and a constant `<owner>_k<k>`,
///   where the owner is the stage id of the nearest quantization that
///   reads the value (through other operations): the arithmetic of `d`
///   is `normalize_d_mul0`, `normalize_d_add1`, … (`w_<op><k>` for a value
///   no quantization reads).
///
/// Every name is distinct (a clash, between a table and a stage id of the
/// same name, gets the node number appended).
pub fn node_names(t: &crate::datapath::Trace, setup: &dyn Fn(&str) -> bool) -> Vec<String> {
    let ops = t.ops();
    let inputs = t.input_ports();
    let n = ops.len();
    // The stage id of the nearest quantization each value feeds: a reverse
    // pass, later (smaller) consumers overwriting earlier ones.
    let mut owner: Vec<Option<String>> = vec![None; n];
    for i in (0..n).rev() {
        let o = match &ops[i] {
            Op::Quant(..) => Some(sanitize(t.stage_id(i).unwrap_or("q"))),
            _ => owner[i].clone(),
        };
        if o.is_some() {
            for a in t.operands(i) {
                owner[a] = o.clone();
            }
        }
    }
    let mut count: HashMap<String, usize> = HashMap::new();
    let mut next = |prefix: String| {
        let k = count.entry(prefix.clone()).or_insert(0);
        *k += 1;
        (prefix, *k - 1)
    };
    let mut used = std::collections::HashSet::new();
    let mut names = Vec::with_capacity(n);
    for (i, op) in ops.iter().enumerate() {
        let own = || owner[i].clone().unwrap_or_else(|| "w".into());
        let kind = match op {
            Op::Mul(..) => "mul",
            Op::Add(..) => "add",
            Op::Sub(..) => "sub",
            Op::Max(..) => "max",
            Op::AddSigned(..) => "addsub",
            Op::Div(..) => "div",
            Op::Sqrt(..) => "sqrt",
            Op::Select(..) => "sel",
            Op::Const(_) => "k",
            Op::Input(_) | Op::Quant(..) | Op::Table(..) => "",
        };
        let name = match op {
            Op::Input(slot) if setup(&inputs[*slot].name) => format!("{}_q", inputs[*slot].name),
            Op::Input(slot) => format!("{}_i", inputs[*slot].name),
            Op::Quant(..) => {
                let (p, k) = next(sanitize(t.stage_id(i).unwrap_or("q")));
                format!("{p}_{k}")
            }
            Op::Table(_, slot) => {
                let (p, k) = next(t.tables()[*slot].name.to_string());
                format!("{p}_{k}")
            }
            _ => {
                let (p, k) = next(format!("{}_{kind}", own()));
                format!("{p}{k}")
            }
        };
        let name = if used.contains(&name) {
            format!("{name}_n{i}")
        } else {
            name
        };
        used.insert(name.clone());
        names.push(name);
    }
    names
}

/// `text` as comment lines of at most 78 columns, each starting with
/// `lead`.
pub fn comment(lead: &str, text: &str) -> String {
    let mut out = String::new();
    let mut line = String::new();
    for w in text.split_whitespace() {
        if !line.is_empty() && lead.len() + line.len() + 1 + w.len() > 78 {
            out += &format!("{lead}{line}\n");
            line.clear();
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line += w;
    }
    if !line.is_empty() {
        out += &format!("{lead}{line}\n");
    }
    out
}

/// `e` as a plain bit vector: a bare name becomes a one-part
/// concatenation (unsigned), so the partial-product sums mix no signedness.
fn as_bits(e: String) -> String {
    if e.starts_with('{') {
        e
    } else {
        format!("{{{e}}}")
    }
}

/// Nanoseconds to two decimals.
fn fmt_ns(t: f64) -> String {
    format!("{t:.2}")
}

fn sanitize(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

/// A count of ports, flags or options as `u32` (saturating: no design
/// comes near 2^32 of any).
fn count(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// The left shift aligning a value of `from` fraction bits to `to`, the
/// fraction of the sum or selection it enters (`to ≥ from`: the result's
/// fraction is its widest operand's).
fn shift_up(to: i32, from: i32) -> u32 {
    u32::try_from(to - from).expect("a result's fraction is its widest operand's")
}

fn decl(signed: bool, width: u32) -> String {
    format!("{}[{}:0]", if signed { "signed " } else { "" }, width - 1)
}

/// Format of a port, for the header: `I2F14 (16 bits, signed)`.
fn port_doc(f: Format) -> String {
    format!(
        "{f} ({} bit{}, {})",
        f.width(),
        if f.width() == 1 { "" } else { "s" },
        if f.signed() {
            "two's complement"
        } else {
            "unsigned"
        }
    )
}

/// ROMs of at least this many entries carry `(* rom_style = "block" *)`:
/// synthesis maps them to block RAM (iCE40 SB_RAM40_4K, 7-series RAMB18E1,
/// ECP5 DP16KD); smaller ones stay in logic.
pub const BLOCK_ROM_ENTRIES: usize = 128;

struct Emitter<'a> {
    t: &'a Trace,
    stage: Vec<Option<u32>>,
    name: Vec<String>,
    /// `(node, stage)` → the wire or register holding the node's value then.
    at: HashMap<(usize, u32), String>,
    /// Overflow bit of a quantization node: `(node, stage)` → name.
    ovf_at: HashMap<(usize, u32), String>,
    /// Quantization nodes whose value cannot leave their format (no range
    /// check, no mutant): their overflow bit is a constant 0, registered
    /// nowhere and ORed into no flag.
    never_ovf: Vec<bool>,
    body: Vec<String>,
    /// Register assignments with the stage each register belongs to (it
    /// holds the value of the item in that stage).
    regs: Vec<(u32, String)>,
    unused: Vec<String>,
    hw: Hardware,
    roms: Vec<(Vec<i128>, String, Format, u32)>,
    rom_text: Vec<String>,
    /// Mutants of each quantization node: `(number, mutation)`, numbers
    /// from 1 (the `mutant_i` value selecting it).
    mutants: HashMap<usize, Vec<(usize, Mutation)>>,
    /// Nanoseconds after its stage's registers at which each node's value
    /// is ready (0: a register or a port).
    arrival: Vec<f64>,
    /// Products built as one DSP block (target pipelining on a DSP
    /// target): the register after one sits in the block, so logic reading
    /// it in the next stage starts [`timing::Dsp::route_out`] late.
    dsp_out: Vec<bool>,
    /// Target pipelining: the delay model and the time per stage.
    timing: Option<(timing::DelayModel, f64)>,
    /// The longest predicted stage delay (combinational part), ns.
    worst: f64,
    /// Operations slower than a whole stage by themselves.
    too_slow: Vec<String>,
    splits: Vec<crate::datapath::MulSplit>,
    /// Set-up groups each node depends on (bit `g`: group `g`), for the
    /// set-up inputs and the combinational logic computed from them alone
    /// (no stage: read directly at every stage).
    groups: Vec<u32>,
    /// The last stage reading each set-up group's registers.
    drain: Vec<u32>,
    /// Whether each set-up group is double-buffered ([`SetupGroup::banked`]).
    banked: Vec<bool>,
    /// A banked set-up input read at a stage: `(node, stage)` → the wire
    /// choosing the bank of the item in that stage.
    bank_at: HashMap<(usize, u32), String>,
    /// Selections of constants by a banked set-up input (the normalizer's
    /// coefficient set by `sel`): built where they are read, from the
    /// selector carried with the item ([`Self::lazy_select`]).
    lazy: Vec<bool>,
    /// A banked set-up input carried with the item: `(node, stage)` → name.
    carried: HashMap<(usize, u32), String>,
    /// A lazy selection materialized at a stage: `(node, stage)` → name.
    lazy_at: HashMap<(usize, u32), String>,
    /// The set-up groups' port names.
    group_names: Vec<&'static str>,
    /// Products read operand registers of their own
    /// ([`Emitter::mul_operand`]): pipelined for ECP5, whose DSP blocks
    /// `synth --netlist` fills with them.
    own_operands: bool,
    /// Those registers, `(stage, "q <= d;")`: written in a block of their
    /// own marked `keep`, so that Yosys does not merge equal copies back
    /// into one register that several blocks would share.
    own_regs: Vec<(u32, String)>,
    /// Bank multiplexers written as wires for own operand registers.
    bank_wires: std::collections::HashSet<String>,
    /// The earliest stage at which each staged node's value is read (by
    /// another operation, or an output): what [`sink_plan`] reads after a
    /// first pass.
    first_read: Vec<Option<u32>>,
    /// Table reads placed later than their operand allows
    /// ([`sink_plan`]): node → the stage of its address logic.
    sink: Vec<Option<u32>>,
}

impl<'a> Emitter<'a> {
    /// Write a quantizer's logic and count its hardware; whether its
    /// overflow bit can be set (false: the value cannot leave its format,
    /// no range check).
    pub(crate) fn quant_logic(&mut self, ql: bits::QuantLogic) -> bool {
        self.hw.check_bits += u64::from(ql.check_bits);
        self.hw.saturate_bits += u64::from(ql.saturate_bits);
        self.body.extend(ql.lines);
        self.unused.extend(ql.unused);
        if let Some(w) = ql.round_adder {
            self.hw.incrementers.push(w);
        }
        ql.check_bits > 0
    }

    /// An operand read at `stage`, with its binary point as the TV says.
    fn operand(&mut self, tv: &TV, stage: u32) -> Val {
        let expr = self.value_at(tv.node(), stage);
        let sym = tv.sym();
        Val {
            expr,
            width: sym.width,
            signed: sym.signed,
            frac: tv.frac(),
        }
    }

    fn node(&mut self, i: usize) -> Result<(), EmitError> {
        // Combinational logic of set-up values alone is itself a set-up
        // value: no stage, read directly wherever it is needed.
        let op = self.t.ops()[i].clone();
        let operands: Vec<usize> = match &op {
            Op::Mul(a, b) | Op::Add(a, b) | Op::Sub(a, b) | Op::Max(a, b) => {
                vec![a.node(), b.node()]
            }
            Op::AddSigned(a, b, c, _) => vec![a.node(), b.node(), c.node()],
            Op::Select(s, o) => std::iter::once(s.node())
                .chain(o.iter().map(|v| v.node()))
                .collect(),
            _ => Vec::new(),
        };
        let mask = operands.iter().fold(0, |m, &n| m | self.groups[n]);
        let held = mask != 0 && operands.iter().all(|&n| self.stage[n].is_none());
        let banked = (0..self.banked.len()).any(|k| mask >> k & 1 == 1 && self.banked[k]);
        if held && banked {
            // A banked group's values differ from item to item (two
            // triangles may be in flight): a selection of constants by one
            // of its inputs is built where it is read; any other logic of
            // them is an ordinary stage-0 operation on the banks' reads.
            if let Op::Select(s, o) = &op {
                let consts = o
                    .iter()
                    .all(|v| matches!(self.t.ops()[v.node()], Op::Const(_)));
                if consts && self.banked_group(s.node()).is_some() {
                    self.lazy[i] = true;
                    return Ok(());
                }
            }
            return self.node_op(i, op, false);
        }
        self.node_op(i, op, held)?;
        if held {
            if let Some(s) = self.stage[i].take() {
                self.at.remove(&(i, s));
            }
            self.groups[i] = mask;
        }
        Ok(())
    }

    fn node_op(&mut self, i: usize, op: Op, held: bool) -> Result<(), EmitError> {
        let sym = self.t.sym(i);
        let d = decl(sym.signed, sym.width);
        let name = self.name[i].clone();
        match op {
            Op::Input(_) if self.groups[i] != 0 => {
                // A set-up register: no stage.
            }
            Op::Input(_) => {
                self.stage[i] = Some(0);
                self.at.insert((i, 0), name);
            }
            Op::Const(c) => {
                self.body.push(format!(
                    "localparam {d} {name} = {};",
                    bits::sv(sym.signed, &bits::literal(sym.width, c))
                ));
            }
            Op::Mul(a, b) => {
                let (sa, sb) = (a.sym(), b.sym());
                // Operand widths as built: a mixed product extends its
                // unsigned operand by one bit, which a block that takes
                // unsigned operands drops again.
                let ext = !self.model().and_then(|m| m.dsp).is_some_and(|d| d.mixed);
                let (wa, wb) = (
                    sa.width + u32::from(ext && sb.signed && !sa.signed),
                    sb.width + u32::from(ext && sa.signed && !sb.signed),
                );
                let dm = self.model().map_or(0.0, |m| m.mul(wa, wb));
                let (mut s, mut t0) = self.place(&[a.node(), b.node()], dm);
                // On a DSP target the model's multiplier delay is the
                // block's with its operand registers packed, which needs
                // operands straight from flip-flops: an operand computed
                // by logic in this stage (or leaving another block) is
                // registered first, and the product starts the next stage.
                if let Some((m, _)) = self.timing {
                    if m.dsp.is_some() && t0 > 0.0 && !held {
                        s += 1;
                        t0 = 0.0;
                    }
                }
                // A DSP's operand registers sit in the block: an operand
                // that arrives late in the stage before is registered in
                // the fabric first (one more stage).
                if let (Some((m, budget)), true) = (self.timing, t0 == 0.0) {
                    if let Some(dsp) = m.dsp {
                        let late = [a.node(), b.node()].iter().any(|&n| {
                            self.stage[n].is_some_and(|sn| sn + 1 == s)
                                && self.arrival[n] + dsp.route_in > budget
                        });
                        if late {
                            s += 1;
                        }
                    }
                }
                // On a DSP target every product reads operand registers of
                // its own (`<product>_a_q`, `_b_q`; a split product one pair
                // per partial product), loaded from the value the stage
                // before holds: the block takes them in as its operand
                // registers, and no register is shared between blocks or
                // with other logic (`synth --netlist` never copies one).
                let own = s >= 1 && !held && self.own_operands;
                let (oa, ob) = (self.mul_operand(&a, s, own), self.mul_operand(&b, s, own));
                if let Some((m, budget)) = self.timing {
                    if !held && t0 + dm > budget && self.split_mul(i, &oa, &ob, s, m, budget) {
                        return Ok(());
                    }
                }
                let va = self.own_operand(oa, s, &format!("{name}_a_q"));
                let vb = self.own_operand(ob, s, &format!("{name}_b_q"));
                // The unsigned operand of a signed × unsigned product, zero-
                // extended on a wire of its own: the multiplier's operand is
                // then that wire, one bit wider, and no tool widens it to the
                // product's width.
                let zext = |e: &mut Self, v: &Val, tag: &str| -> String {
                    let n = format!("{name}_{tag}");
                    e.body.push(format!(
                        "wire signed [{}:0] {n} = $signed({{1'b0, {}}});",
                        v.width, v.expr
                    ));
                    n
                };
                let (ea, eb, hw) = match (va.signed, vb.signed) {
                    (true, false) => (
                        va.expr.clone(),
                        zext(self, &vb, "b"),
                        MulHw {
                            a_width: va.width,
                            b_width: vb.width + 1,
                            signed: true,
                            a_zext: false,
                            b_zext: true,
                            y_width: sym.width,
                        },
                    ),
                    (false, true) => (
                        zext(self, &va, "a"),
                        vb.expr.clone(),
                        MulHw {
                            a_width: va.width + 1,
                            b_width: vb.width,
                            signed: true,
                            a_zext: true,
                            b_zext: false,
                            y_width: sym.width,
                        },
                    ),
                    (sa, _) => (
                        va.expr.clone(),
                        vb.expr.clone(),
                        MulHw {
                            a_width: va.width,
                            b_width: vb.width,
                            signed: sa,
                            a_zext: false,
                            b_zext: false,
                            y_width: sym.width,
                        },
                    ),
                };
                self.hw.muls.push(hw);
                // No `$signed(...)` around the product: its argument would be
                // self-determined and the product truncated. Both operands
                // are of the product's signedness already.
                self.body.push(format!("wire {d} {name} = {ea} * {eb};"));
                self.dsp_out[i] = self.model().is_some_and(|m| m.dsp.is_some());
                self.stage[i] = Some(s);
                self.at.insert((i, s), name.clone());
                self.ready(i, t0 + dm, &name);
                // Logic of this stage reading the product waits for it to
                // leave the block unregistered: the routing out comes on
                // top (in the next stage, from the block's output
                // register, `arrival_at` charges the same).
                if let Some(dsp) = self.model().and_then(|m| m.dsp) {
                    self.arrival[i] += dsp.route_out;
                }
            }
            Op::Add(a, b) | Op::Sub(a, b) | Op::Max(a, b) => {
                let dl = self.model().map_or(0.0, |m| {
                    if matches!(op, Op::Max(..)) {
                        m.max(sym.width)
                    } else {
                        m.add(sym.width)
                    }
                });
                let (s, t0) = self.place(&[a.node(), b.node()], dl);
                let (va, vb) = (self.operand(&a, s), self.operand(&b, s));
                let w = sym.width;
                let xa = bits::align(&va, shift_up(sym.frac, va.frac), w);
                let xb = bits::align(&vb, shift_up(sym.frac, vb.frac), w);
                let e = match op {
                    Op::Add(..) => {
                        self.hw.adders.push(w);
                        format!("{xa} + {xb}")
                    }
                    Op::Sub(..) => {
                        self.hw.adders.push(w);
                        format!("{xa} - {xb}")
                    }
                    _ => {
                        self.hw.compares += 1;
                        // A comparator (a carry chain) and a choice.
                        self.hw.compare_bits += u64::from(w);
                        self.hw.select_bits += u64::from(w);
                        let (ca, cb) = (format!("{name}_a"), format!("{name}_b"));
                        self.body
                            .push(format!("wire {d} {ca} = {};", bits::sv(sym.signed, &xa)));
                        self.body
                            .push(format!("wire {d} {cb} = {};", bits::sv(sym.signed, &xb)));
                        format!("({ca} > {cb}) ? {ca} : {cb}")
                    }
                };
                let e = if matches!(op, Op::Max(..)) {
                    e
                } else {
                    bits::sv(sym.signed, &e)
                };
                self.body.push(format!("wire {d} {name} = {e};"));
                self.stage[i] = Some(s);
                self.at.insert((i, s), name.clone());
                self.ready(i, t0 + dl, &name);
            }
            Op::AddSigned(a, b, sg, flip)
                if matches!(
                    (&self.t.ops()[a.node()], &self.t.ops()[b.node()]),
                    (Op::Const(_), Op::Const(_))
                ) =>
            {
                // Both operands constant: a choice of two constants, no
                // adder (CORDIC's starting angle ±¼ turn).
                let (Op::Const(ca), Op::Const(cb)) =
                    (&self.t.ops()[a.node()], &self.t.ops()[b.node()])
                else {
                    unreachable!("matched above")
                };
                let dl = self.model().map_or(0.0, |m| m.select(2));
                let (s, t0) = self.place(&[sg.node()], dl);
                let vs = self.operand(&sg, s);
                let (xa, xb) = (ca << (sym.frac - a.frac()), cb << (sym.frac - b.frac()));
                let lit = |c: i128| bits::sv(sym.signed, &bits::literal(sym.width, c));
                let neg = format!("{name}_sub");
                let bit = vs.sign_bit();
                let mode = if flip { format!("~{bit}") } else { bit };
                self.body.push(format!("wire {neg} = {mode};"));
                if vs.width > 1 {
                    let rest = vs.slice(vs.width - 2, 0);
                    if !self.unused.contains(&rest) {
                        self.unused.push(rest);
                    }
                }
                self.hw.selects += 1;
                self.hw.select_bits += u64::from(sym.width);
                self.body.push(format!(
                    "wire {d} {name} = {neg} ? {} : {};",
                    lit(xa - xb),
                    lit(xa + xb)
                ));
                // Folded here: the constants' own parameters may go unread.
                for c in [a.node(), b.node()] {
                    let k = self.name[c].clone();
                    if !self.unused.contains(&k) {
                        self.unused.push(k);
                    }
                }
                self.stage[i] = Some(s);
                self.at.insert((i, s), name.clone());
                self.ready(i, t0 + dl, &name);
            }
            Op::AddSigned(a, b, sg, flip) => {
                let dl = self.model().map_or(0.0, |m| m.add_signed(sym.width));
                let (s, t0) = self.place(&[a.node(), b.node(), sg.node()], dl);
                let (va, vb, vs) = (
                    self.operand(&a, s),
                    self.operand(&b, s),
                    self.operand(&sg, s),
                );
                let w = sym.width;
                let xa = bits::align(&va, shift_up(sym.frac, va.frac), w);
                let xb = bits::align(&vb, shift_up(sym.frac, vb.frac), w);
                // One adder/subtracter: its mode is the sign bit of `sg`
                // (Yosys's opt_share merges the pair into one $alu).
                self.hw.add_subs.push(w);
                let neg = format!("{name}_sub");
                let bit = vs.sign_bit();
                // Only the sign of `sg` is read here; where nothing else
                // reads the rest (CORDIC's last `v`), the sink takes it.
                if vs.width > 1 {
                    let rest = vs.slice(vs.width - 2, 0);
                    if !self.unused.contains(&rest) {
                        self.unused.push(rest);
                    }
                }
                let mode = if flip { format!("~{bit}") } else { bit };
                self.body.push(format!("wire {neg} = {mode};"));
                let (sub, add) = (
                    bits::sv(true, &format!("{xa} - {xb}")),
                    bits::sv(true, &format!("{xa} + {xb}")),
                );
                self.body
                    .push(format!("wire {d} {name} = {neg} ? {sub} : {add};"));
                self.stage[i] = Some(s);
                self.at.insert((i, s), name.clone());
                self.ready(i, t0 + dl, &name);
            }
            Op::Select(sel, opts) => {
                let mut all: Vec<usize> = vec![sel.node()];
                all.extend(opts.iter().map(|o| o.node()));
                let dl = self.model().map_or(0.0, |m| m.select(count(opts.len())));
                let (s, t0) = self.place(&all, dl);
                let vs = self.operand(&sel, s);
                self.case_select(i, &name, &vs.expr, vs.width, &opts, s);
                self.stage[i] = Some(s);
                self.at.insert((i, s), name.clone());
                self.ready(i, t0 + dl, &name);
            }
            Op::Quant(a, q) if self.timing.is_some() && !self.mutants.contains_key(&i) => {
                self.quant_timed(i, &a, &q);
            }
            Op::Quant(a, q) => {
                let s = self.place(&[a.node()], 0.0).0;
                let va = self.operand(&a, s);
                let f = q.format();
                let (yc, oc) = (format!("{name}_c"), format!("{name}_ovf_c"));
                let muts = self.mutants.get(&i).cloned().unwrap_or_default();
                let (y0, o0) = if muts.is_empty() {
                    (yc.clone(), oc.clone())
                } else {
                    (format!("{name}_c0"), format!("{name}_ovf_c0"))
                };
                let ql = bits::quantize(
                    &va,
                    &name,
                    &y0,
                    &o0,
                    f.width(),
                    f.signed(),
                    f.frac(),
                    q.round(),
                    q.overflow(),
                );
                if !muts.is_empty() {
                    // Mutation schema: each mutant's quantizer beside the
                    // original, chosen by `mutant_i`.
                    let (mut ysel, mut osel) = (y0.clone(), o0.clone());
                    for (k, m) in &muts {
                        let (mut va_m, mut r, mut o) = (va.clone(), q.round(), q.overflow());
                        match m.kind {
                            MutationKind::Round(x) => r = x,
                            MutationKind::Overflow(x) => o = x,
                            MutationKind::Shift => va_m.frac += 1,
                        }
                        let (ym, om) = (format!("{name}_m{k}"), format!("{name}_ovf_m{k}"));
                        let ml = bits::quantize(
                            &va_m,
                            &format!("{name}_m{k}"),
                            &ym,
                            &om,
                            f.width(),
                            f.signed(),
                            f.frac(),
                            r,
                            o,
                        );
                        self.body.push(format!("// mutant {k}: {m}"));
                        self.body.extend(ml.lines);
                        self.unused.extend(ml.unused);
                        ysel = format!("(mutant_i == 16'd{k}) ? {ym} : {ysel}");
                        osel = format!("(mutant_i == 16'd{k}) ? {om} : {osel}");
                    }
                    self.body.push(format!(
                        "wire {} {yc} = {ysel};",
                        decl(f.signed(), f.width())
                    ));
                    self.body.push(format!("wire {oc} = {osel};"));
                }
                // A mutant may overflow where the original cannot.
                let settable = self.quant_logic(ql) || !muts.is_empty();
                self.reg(s + 1, &name, f.signed(), f.width(), &yc);
                self.stage[i] = Some(s + 1);
                self.at.insert((i, s + 1), name);
                self.overflow_bit(i, oc, s, settable, q.overflow());
            }
            Op::Table(a, slot) => {
                let tb = self.t.tables()[slot].clone();
                let t = tb.index.width();
                let f = tb.out.format();
                // Address logic before the registered read (the quarter
                // wave's phase and mirror), and after it (the quarter-turn
                // choice and the sign).
                let (before, after) = self.model().map_or((0.0, 0.0), |m| match tb.storage {
                    None => (0.0, m.bram),
                    Some(_) => (
                        m.carry(2) + m.lut + m.carry(t - 1),
                        m.bram + m.lut + m.carry(f.width() + 1) + m.lut,
                    ),
                });
                let (mut s, _) = self.place(&[a.node()], before);
                if let Some(k) = self.sink[i] {
                    s = s.max(k);
                }
                let va = self.operand(&a, s);
                self.stage[i] = Some(s + 1);
                // The logic after a quarter-wave read gets a stage of its
                // own when the RAM's clock-to-output and it do not fit one.
                let late = match (self.timing, &tb.storage) {
                    (Some((m, budget)), Some(_)) => after > budget && after - m.bram > 0.0,
                    _ => false,
                };
                self.table_read(i, &va, &tb, s, late);
                let n = self.name[i].clone();
                let t_out = match self.model() {
                    Some(m) if late => after - m.bram,
                    _ => after,
                };
                self.ready(i, t_out, &n);
            }
            Op::Div(..) | Op::Sqrt(..) => unreachable!("checked before"),
        }
        Ok(())
    }
}

/// Emit `d` as one Verilog module with the `compact` pipeline.
///
/// # Errors
///
/// [`EmitError::NoRtl`] for a division or square root in the outputs' cone,
/// [`EmitError::NoOutputs`] for a datapath without outputs,
/// [`EmitError::TooWide`] for a value wider than 126 bits,
/// [`EmitError::NoDelayModel`] for target pipelining on a family without a
/// delay model.
pub fn emit(d: &Design) -> Result<Emitted, EmitError> {
    emit_with(d, &[])
}

/// Emit `d` with every mutation of `muts` built in beside the original
/// logic (a mutation schema): an extra input `mutant_i[15:0]` selects
/// mutant `k` (`muts[k − 1]`), 0 the unmutated design. One simulator build
/// then runs every mutant; the testbench takes `+MUTANT=k`.
///
/// # Errors
///
/// As [`emit`].
///
/// # Panics
///
/// With 2^16 mutations or more (mutant numbers are 16 bits).
pub fn emit_mutants(d: &Design, muts: &[Mutation]) -> Result<Emitted, EmitError> {
    assert!(muts.len() < 1 << 16, "mutant numbers fit mutant_i");
    emit_with(d, muts)
}

fn emit_with(d: &Design, muts: &[Mutation]) -> Result<Emitted, EmitError> {
    let t = &d.trace;
    let outs: Vec<Port> = t.output_ports().to_vec();
    if outs.is_empty() {
        return Err(EmitError::NoOutputs(d.unit));
    }
    // The family of target pipelining, with its delay model.
    let family = match d.pipelining {
        timing::Pipelining::Target { target, clock_ns } => match target.delay() {
            Some(m) => Some((target, m, clock_ns)),
            None => {
                return Err(EmitError::NoDelayModel {
                    unit: d.unit,
                    target: target.name(),
                })
            }
        },
        timing::Pipelining::Compact => None,
    };
    let roots: Vec<TV> = outs.iter().map(|p| p.value).collect();
    let live = t.live_nodes(&roots);
    for (i, op) in t.ops().iter().enumerate() {
        if !live[i] {
            continue;
        }
        let op_name = match op {
            Op::Div(..) => Some("division"),
            Op::Sqrt(..) => Some("square root"),
            _ => None,
        };
        if let Some(op) = op_name {
            return Err(EmitError::NoRtl {
                unit: d.unit,
                variant: d.variant.clone(),
                op,
            });
        }
        if t.sym(i).width > 126 {
            return Err(EmitError::TooWide {
                unit: d.unit,
                width: t.sym(i).width,
            });
        }
    }
    let inputs = t.input_ports();
    for g in &d.setup {
        for f in &g.fields {
            assert!(
                inputs.iter().any(|p| p.name == *f),
                "set-up field {f} is an input port"
            );
        }
    }
    let setup_of = |port: &str| {
        d.setup
            .iter()
            .position(|g| g.fields.iter().any(|f| f == port))
    };
    let names = node_names(t, &|port| setup_of(port).is_some());
    let build = |sink: Vec<Option<u32>>| -> Result<Emitter, EmitError> {
        let mut e = Emitter {
            t,
            stage: vec![None; t.ops().len()],
            name: names.clone(),
            at: HashMap::new(),
            ovf_at: HashMap::new(),
            never_ovf: vec![false; t.ops().len()],
            body: Vec::new(),
            regs: Vec::new(),
            unused: Vec::new(),
            hw: Hardware::default(),
            roms: Vec::new(),
            rom_text: Vec::new(),
            mutants: HashMap::new(),
            arrival: vec![0.0; t.ops().len()],
            dsp_out: vec![false; t.ops().len()],
            timing: match family {
                Some((_, m, clock_ns)) if muts.is_empty() => Some((m, m.budget(clock_ns))),
                _ => None,
            },
            own_operands: muts.is_empty()
                && family.is_some_and(|(t, ..)| t.split_products_own_operands()),
            own_regs: Vec::new(),
            bank_wires: std::collections::HashSet::new(),
            worst: 0.0,
            too_slow: Vec::new(),
            splits: Vec::new(),
            groups: t
                .ops()
                .iter()
                .map(|op| match op {
                    Op::Input(slot) => setup_of(&inputs[*slot].name).map_or(0, |g| 1 << g),
                    _ => 0,
                })
                .collect(),
            drain: vec![0; d.setup.len()],
            banked: d.setup.iter().map(|g| g.banked).collect(),
            bank_at: HashMap::new(),
            lazy: vec![false; t.ops().len()],
            carried: HashMap::new(),
            lazy_at: HashMap::new(),
            group_names: d.setup.iter().map(|g| g.name).collect(),
            first_read: vec![None; t.ops().len()],
            sink,
        };
        for (k, m) in muts.iter().enumerate() {
            e.mutants
                .entry(m.node)
                .or_default()
                .push((k + 1, m.clone()));
        }
        for (i, op) in t.ops().iter().enumerate() {
            if live[i] || matches!(op, Op::Input(_)) {
                e.node(i)?;
            }
        }
        Ok(e)
    };
    // Two passes: the first finds where each value is first read; table
    // reads whose values would only wait in registers are then placed
    // just before their first reader, carrying the narrower address
    // instead ([`sink_plan`]). Every other placement is unchanged.
    let first = build(vec![None; t.ops().len()])?;
    let plan = sink_plan(&first);
    let mut e = if plan.iter().any(Option::is_some) {
        build(plan)?
    } else {
        first
    };
    for p in &inputs {
        if !live[p.value.node()] {
            e.unused.push(format!("{}_i", p.name));
        }
    }
    // Latency: the deepest output, at least one register.
    // An output still combinational in its stage (target pipelining) is
    // registered once more, so every output port leaves a register.
    let latency = roots
        .iter()
        .filter_map(|r| {
            let n = r.node();
            e.stage[n].map(|s| {
                let wire = e.timing.is_some()
                    && e.at.get(&(n, s)).is_some_and(|w| {
                        !e.regs
                            .iter()
                            .any(|(_, a)| a.starts_with(&format!("{w} <= ")))
                    })
                    && !matches!(t.ops()[n], Op::Input(_));
                s + u32::from(wire)
            })
        })
        .max()
        .unwrap_or(0)
        .max(1);
    // Flags: every live quantization's stage id, in order.
    let mut flags: Vec<String> = Vec::new();
    let mut flag_nodes: Vec<Vec<usize>> = Vec::new();
    for (i, op) in t.ops().iter().enumerate() {
        if live[i] && matches!(op, Op::Quant(..)) {
            let id = t.stage_id(i).unwrap_or("").to_string();
            match flags.iter().position(|f| *f == id) {
                Some(k) => flag_nodes[k].push(i),
                None => {
                    flags.push(id);
                    flag_nodes.push(vec![i]);
                }
            }
        }
    }
    let mut out_vals = Vec::new();
    for p in &outs {
        out_vals.push(e.value_at(p.value.node(), latency));
    }
    let mut flag_bits = Vec::new();
    for (k, nodes) in flag_nodes.iter().enumerate() {
        // Only quantizers that can overflow feed the flag; a stage id
        // whose every quantizer cannot is a constant 0.
        let settable: Vec<usize> = nodes.iter().copied().filter(|&n| !e.never_ovf[n]).collect();
        flag_bits.push(if settable.is_empty() {
            "1'b0".to_string()
        } else {
            e.flag_chain(k, &settable, latency)
        });
    }
    let nf = flags.len();
    e.hw.flops += u64::from(latency); // valid bits
                                      // The FIFO handshake: an output FIFO with room for every item in
                                      // flight (a power of two above the pipeline's depth) and a head
                                      // register; the stall handshake: an output buffer of two registers
                                      // (the head and the skid). Either way the ports are registers, one
                                      // cycle more.
    let fifo = d.handshake == timing::Handshake::Fifo && muts.is_empty();
    // A FIFO for a target whose memories are block RAM reads it
    // synchronously (one cycle more).
    let memory = family.map(|(t, ..)| t.fifo_memory());
    let block = fifo && memory == Some(targets::FifoMemory::Block);
    let depth = (latency + 2).next_power_of_two();
    let aw = depth.trailing_zeros();
    let out_w: u32 = outs.iter().map(|p| p.format.width()).sum::<u32>() + count(nf);
    if fifo {
        // Pointers, the count, the registered admission and output-valid
        // bits, the FIFO's entries and its head; the pointers' two
        // incrementers, the count's add and subtract, its three compares
        // with the admission bounds and the one with 2 for valid_o (the
        // pointers' equality is not an ordered compare).
        e.hw.flops += 3 * (u64::from(aw) + 1) + 2 + (u64::from(depth) + 1) * u64::from(out_w);
        e.hw.adders.extend([aw + 1; 4]);
        e.hw.compares += 4;
        // Its entries, a memory synthesis may build as LUT RAM.
        e.hw.fifo_bits += u64::from(depth) * u64::from(out_w);
    } else {
        // The head and the skid register with their valid bits (the
        // enable's copies are counted where they are written).
        e.hw.flops += 2 * u64::from(out_w) + 2;
        // The head loads the skid register or the last stage.
        e.hw.select_bits += u64::from(out_w);
    }
    let pipe_latency = latency;
    let latency = latency + 1 + u32::from(block);
    // Set-up ports: the registers of their live fields.
    let mut setup = Vec::new();
    // Held ports whose ready, while high, keeps items out.
    let mut locks: Vec<String> = Vec::new();
    let mut setup_text = String::new();
    for (g, grp) in d.setup.iter().enumerate() {
        let drain = e.drain[g].min(pipe_latency);
        let mut regs = Vec::new();
        let mut fields = Vec::new();
        let mut flops = 0;
        for p in inputs.iter().filter(|p| grp.fields.contains(&p.name)) {
            fields.push(p.name.clone());
            if live[p.value.node()] {
                let f = p.format;
                regs.push((format!("{}_q", p.name), format!("{}_i", p.name), f));
                flops += u64::from(f.width());
            }
        }
        if grp.banked {
            let (text, extra) = banked_port(grp.name, grp.doc, drain, &regs, fifo);
            setup_text += &text;
            flops = 2 * flops + extra;
            e.hw.flops += flops;
            setup.push(SetupPort {
                name: grp.name,
                doc: grp.doc,
                fields,
                drain,
                banks: 2,
                flops,
            });
            continue;
        }
        e.hw.flops += flops;
        let n = grp.name;
        if drain == 0 {
            // Only stage 0 reads the registers: an item taken in the same
            // cycle reads the old values, the next one the new.
            setup_text += &comment(
                "  // ",
                &format!("Set-up port `{n}`: {}. Only stage 0 reads these registers: it accepts a record in any cycle.", grp.doc),
            );
            let _ = writeln!(setup_text, "  assign {n}_ready_o = 1'b1;");
        } else {
            // Ready is a register: raised the cycle after a record is
            // offered when stages 1..drain will be empty; in that cycle the
            // record loads and no item is taken (`setup_lock`), so every
            // item computes with the values held when it was taken.
            e.hw.flops += 1;
            let (step, shift_in) = if fifo {
                ("1'b1", "in_xfer")
            } else {
                ("en", "in_take")
            };
            let busy = if drain == 1 {
                shift_in.to_string()
            } else {
                format!("{{valid_q[{}:0], {shift_in}}}", drain - 2)
            };
            setup_text += &comment(
                "  // ",
                &format!(
                    "Set-up port `{n}`: {}. {n}_ready_o is a register, raised the cycle after a record is offered if stages 1..{drain}, which read these registers, will be empty; in that cycle the record loads and no item is taken.",
                    grp.doc
                ),
            );
            let _ = writeln!(setup_text, "  reg  {n}_ready_q;");
            let _ = writeln!(
                setup_text,
                "  wire [{}:0] {n}_busy_d = {step} ? {busy} : valid_q[{}:0];",
                drain - 1,
                drain - 1
            );
            let _ = writeln!(
                setup_text,
                "  wire {n}_ready_d = {n}_valid_i & ~{n}_ready_q & ~|{n}_busy_d;\n  always @(posedge clk_i or negedge rst_ni) begin\n    if (!rst_ni) {n}_ready_q <= 1'b0;\n    else {n}_ready_q <= {n}_ready_d;\n  end"
            );
            let _ = writeln!(setup_text, "  assign {n}_ready_o = {n}_ready_q;");
            locks.push(format!("{n}_ready_q"));
        }
        for (q, _, f) in &regs {
            let _ = writeln!(setup_text, "  reg  {} {q};", decl(f.signed(), f.width()));
        }
        if !regs.is_empty() {
            setup_text += "  always @(posedge clk_i) begin\n";
            let _ = writeln!(
                setup_text,
                "    if ({n}_valid_i & {n}_ready_o) begin",
                n = grp.name
            );
            for (q, i, _) in &regs {
                let _ = writeln!(setup_text, "      {q} <= {i};");
            }
            setup_text += "    end\n  end\n";
        }
        setup_text += "\n";
        setup.push(SetupPort {
            name: grp.name,
            doc: grp.doc,
            fields,
            drain,
            banks: 1,
            flops,
        });
    }
    e.hw.muls.sort();
    e.hw.adders.sort();
    e.hw.add_subs.sort();
    e.hw.incrementers.sort();

    // Header.
    let hash = d.config_hash();
    let mut v = String::new();
    let _ = writeln!(
        v,
        "// {}.v: unit `{}` ({}), generated from its traced datapath.",
        d.module, d.unit, d.variant
    );
    let _ = writeln!(v, "//");
    let _ = writeln!(
        v,
        "// GENERATED by {GENERATOR}. Do not edit: regenerate with"
    );
    let _ = writeln!(
        v,
        "//   fxshade rtl {} [--config FILE] [--set KEY=VALUE]... --out DIR",
        d.unit
    );
    let _ = writeln!(
        v,
        "// Configuration: {} (hash {hash:016x})",
        d.config_source
    );
    let sections = d.config_sections();
    if !sections.is_empty() {
        let _ = writeln!(
            v,
            "// The hash covers the sections the module depends on: [{}].",
            sections.join("], [")
        );
    }
    for n in &d.notes {
        // Printable ASCII only (lowRISC): the notes' symbols spelled out.
        let _ = writeln!(v, "// {}", crate::escape::ascii(n));
    }
    let _ = writeln!(v, "//");
    let predicted_ns = e.timing.map(|(m, _)| e.worst + m.reg);
    let _ = writeln!(v, "// Pipelining: {}.", d.pipelining.describe());
    if let Some(p) = predicted_ns {
        let _ = writeln!(
            v,
            "// Delay model: slowest stage {} ns predicted ({:.1} MHz){}.",
            fmt_ns(p),
            1000.0 / p,
            if e.too_slow.is_empty() {
                String::new()
            } else {
                format!("; slower than the period: {}", e.too_slow.join(", "))
            }
        );
    }
    let _ = writeln!(
        v,
        "// Latency {latency} cycles; one vector per clock. Handshake: valid/ready on"
    );
    if fifo {
        let _ = writeln!(
            v,
            "// both sides; the pipeline never stalls and ends in an output FIFO of\n\
             // {depth} entries and a head register; ready_o is a register (the FIFO's\n\
             // room on its next count): no path from ready_i or valid_i."
        );
    } else {
        let _ = writeln!(
            v,
            "// both sides with one global stall, a register: the stages stop while the\n\
             // output buffer (a head and a skid register) is full. ready_o, valid_o\n\
             // and the outputs are registers: no path from ready_i or valid_i."
        );
    }
    for p in &setup {
        let text = if p.banks == 2 {
            format!(
                "Set-up port `{n}` ({n}_valid_i/{n}_ready_o): {}. Two banks of registers: a record loads the bank no item in stages 1..{} reads and makes it current, so the next record loads while the last one's items are in flight; an item computes with the values current when it was accepted (an item accepted in the same cycle as a record keeps the old ones). {n}_ready_o is a register.",
                p.doc,
                p.drain,
                n = p.name
            )
        } else if p.drain == 0 {
            format!(
                "Set-up port `{n}` ({n}_valid_i/{n}_ready_o): {}. Held in registers that only stage 0 reads; a record is accepted in any cycle (an item taken in the same cycle keeps the old values).",
                p.doc,
                n = p.name
            )
        } else {
            format!(
                "Set-up port `{n}` ({n}_valid_i/{n}_ready_o): {}. Held in registers; {n}_ready_o is a register, raised the cycle after a record is offered if stages 1..{} will then be empty, and no item is taken in the cycle the record loads, so an item computes with the set-up values held when it was accepted.",
                p.doc,
                p.drain,
                n = p.name
            )
        };
        v += &comment("// ", &text);
    }
    let _ = writeln!(
        v,
        "// Arithmetic: model/ARITHMETIC.md; every wire has its exact model format."
    );
    let _ = writeln!(v, "//");
    let _ = writeln!(v, "// Ports:");
    let _ = writeln!(
        v,
        "//   clk_i, rst_ni (asynchronous, active low), valid_i/ready_o, valid_o/ready_i"
    );
    for g in &setup {
        let _ = writeln!(
            v,
            "//   {n}_valid_i/{n}_ready_o: set-up port `{n}`, loads the fields marked [{n}]",
            n = g.name
        );
    }
    for p in &inputs {
        let group = setup
            .iter()
            .find(|g| g.fields.contains(&p.name))
            .map_or(String::new(), |g| format!(" [{}]", g.name));
        let _ = writeln!(
            v,
            "//   {:<12} in   {}{group}",
            format!("{}_i", p.name),
            port_doc(p.format)
        );
    }
    for p in &outs {
        let _ = writeln!(
            v,
            "//   {:<12} out  {}",
            format!("{}_o", p.name),
            port_doc(p.format)
        );
    }
    if !muts.is_empty() {
        let _ = writeln!(
            v,
            "//   {:<12} in   [15:0] mutant selector (0: the design; k: mutant k, listed at its quantizer)",
            "mutant_i"
        );
    }
    if nf > 0 {
        let _ = writeln!(
            v,
            "//   {:<12} out  overflow flags of this vector, one per stage id:",
            "ovf_o"
        );
        for (k, f) in flags.iter().enumerate() {
            let _ = writeln!(v, "//                  bit {:<2} {f}", nf - 1 - k);
        }
    }
    v += "\n`default_nettype none\n\n";
    let _ = writeln!(v, "module {} (", d.module);
    let mut ports = vec![
        "input  wire clk_i".to_string(),
        "input  wire rst_ni".to_string(),
        "input  wire valid_i".to_string(),
        "output wire ready_o".to_string(),
    ];
    for g in &setup {
        ports.push(format!("input  wire {}_valid_i", g.name));
        ports.push(format!("output wire {}_ready_o", g.name));
    }
    for p in &inputs {
        ports.push(format!(
            "input  wire {} {}_i",
            decl(p.format.signed(), p.format.width()),
            p.name
        ));
    }
    ports.push("output wire valid_o".into());
    ports.push("input  wire ready_i".into());
    for p in &outs {
        ports.push(format!(
            "output wire {} {}_o",
            decl(p.format.signed(), p.format.width()),
            p.name
        ));
    }
    if nf > 0 {
        ports.push(format!("output wire [{}:0] ovf_o", nf - 1));
    }
    if !muts.is_empty() {
        ports.push("input  wire [15:0] mutant_i".into());
    }
    let _ = writeln!(v, "  {}", ports.join(",\n  "));
    v += ");\n\n";
    for r in &e.rom_text {
        for l in r.lines() {
            let _ = writeln!(v, "  {l}");
        }
        v += "\n";
    }
    let lock = &locks;
    assert!(
        e.regs.iter().all(|(st, _)| (1..=pipe_latency).contains(st)),
        "every register belongs to a stage of the pipeline"
    );
    let stages: Vec<u32> = (1..=pipe_latency)
        .filter(|k| e.regs.iter().any(|(st, _)| st == k))
        .collect();
    // Stages whose loads take a copy of the stall enable: every stage after
    // the first with registers or a product's own operand registers.
    let replicas: Vec<u32> = if fifo {
        Vec::new()
    } else {
        (2..=pipe_latency)
            .filter(|k| e.regs.iter().chain(&e.own_regs).any(|(st, _)| st == k))
            .collect()
    };
    e.hw.flops += replicas.len() as u64;
    if fifo {
        v += &fifo_handshake(pipe_latency, depth, !lock.is_empty(), block);
    } else {
        v += &stall_handshake(pipe_latency, !lock.is_empty(), &replicas);
    }

    v += &setup_text;
    if !lock.is_empty() {
        let _ = writeln!(
            v,
            "  // No item is taken in the cycle a held set-up port loads.\n  assign setup_lock_d = {};\n",
            lock.iter()
                .map(|q| format!("{}_d", q.trim_end_matches("_q")))
                .collect::<Vec<_>>()
                .join(" | ")
        );
    }
    v += "  // Datapath.\n";
    for l in &e.body {
        for ll in l.lines() {
            let _ = writeln!(v, "  {ll}");
        }
    }
    // Each stage's load, a wire of its own, so the enable of every
    // pipeline register keeps a name in the netlist (`synth --netlist`
    // moves into a DSP block only registers loaded by one of these).
    v += "\n  // Stage loads: the item entering stage k is valid and the stages move.\n";
    for &k in &stages {
        let load = match (k, fifo) {
            (1, false) => "in_take".to_string(),
            (1, true) => "in_xfer".to_string(),
            (_, false) => format!("en_s{k}_q & valid_q[{}]", k - 2),
            (_, true) => format!("valid_q[{}]", k - 2),
        };
        let _ = writeln!(v, "  wire load_s{k} = {load};");
    }
    v += "\n  // Pipeline registers (data: no reset, held while stalled). A stage's\n";
    v += "  // registers load only with a valid item, so bubbles do not toggle them.\n";
    v += "  always @(posedge clk_i) begin\n";
    let write_regs = |v: &mut String, regs: &[(u32, String)]| {
        for &k in &stages {
            let regs: Vec<&String> = regs
                .iter()
                .filter(|(st, _)| *st == k)
                .map(|(_, r)| r)
                .collect();
            if regs.is_empty() {
                continue;
            }
            let _ = writeln!(v, "    if (load_s{k}) begin");
            for r in regs {
                let _ = writeln!(v, "      {r}");
            }
            *v += "    end\n";
        }
        *v += "  end\n\n";
    };
    write_regs(&mut v, &e.regs);
    if !e.own_regs.is_empty() {
        // They load whenever the stages move (an item or a bubble): a
        // product's operand registers then hold the stage before's values
        // of the item in the product's stage, and their enable is not a
        // stage's load, so Yosys cannot merge one with the balancing
        // register of the same value (which several loads would share).
        v += "  // Each product's own operand registers (a DSP block takes them in):\n";
        v += "  // loaded whenever the stages move, kept apart from equal copies.\n";
        v += "  (* keep *)\n  always @(posedge clk_i) begin\n";
        let mut own = e.own_regs.clone();
        own.sort_by_key(|(st, _)| *st);
        let mut k0 = 0;
        for (k, r) in &own {
            if fifo {
                let _ = writeln!(v, "    {r}");
                continue;
            }
            if *k != k0 {
                if k0 != 0 {
                    v += "    end\n";
                }
                // Stage 1's copies move with the first stage: `en`.
                let en = if *k == 1 {
                    "en".to_string()
                } else {
                    format!("en_s{k}_q")
                };
                let _ = writeln!(v, "    if ({en}) begin");
                k0 = *k;
            }
            let _ = writeln!(v, "      {r}");
        }
        if !fifo && k0 != 0 {
            v += "    end\n";
        }
        v += "  end\n\n";
    }
    if fifo {
        let distributed = memory == Some(targets::FifoMemory::Distributed);
        v += &fifo_outputs(depth, &outs, &out_vals, &flag_bits, distributed, block);
    } else {
        v += &stall_outputs(&outs, &out_vals, &flag_bits);
    }
    // Set-up registers: unchanged while an item is in the stages reading
    // them or entering; with banks, each bank while an item tagged with it
    // is there (and the registered ready is the test it stands for).
    let mut formal_setup: Vec<String> = Vec::new();
    for p in &setup {
        let regs: Vec<&String> = p
            .fields
            .iter()
            .filter(|f| inputs.iter().any(|q| &q.name == *f && live[q.value.node()]))
            .collect();
        let n = p.name;
        let w = p.drain;
        if p.banks == 2 {
            if w > 0 {
                formal_setup.push(format!(
                    "assert ({n}_ready_q == ~|(valid_q[{}:0] & ({n}_tag_q ^ {{{w}{{{n}_cur_q}}}})));",
                    w - 1
                ));
            }
            for b in 0..2 {
                if regs.is_empty() {
                    continue;
                }
                let mine = if b == 0 { "~" } else { "" };
                let busy = if w == 0 {
                    String::new()
                } else {
                    format!("(|(valid_q[{}:0] & {mine}{n}_tag_q)) | ", w - 1)
                };
                let list: Vec<String> = regs.iter().map(|f| format!("{f}_b{b}_q")).collect();
                formal_setup.push(format!(
                    "if ($past({busy}(f_in & {mine}{n}_cur_q))) assert ($stable({{{}}}));",
                    list.join(", ")
                ));
            }
        } else if w > 0 && !regs.is_empty() {
            // The registered ready stands for "stages 1..U are empty".
            formal_setup.push(format!(
                "assert (!{n}_ready_q || valid_q[{}:0] == {w}'d0);",
                w - 1
            ));
            let list: Vec<String> = regs.iter().map(|f| format!("{f}_q")).collect();
            formal_setup.push(format!(
                "if ($past((|valid_q[{}:0]) | f_in)) assert ($stable({{{}}}));",
                w - 1,
                list.join(", ")
            ));
        }
    }
    v += &if fifo {
        formal_block_fifo(pipe_latency, depth, &outs, nf, &formal_setup, lock, block)
    } else {
        formal_block(pipe_latency, &outs, nf, &formal_setup, lock, &replicas)
    };
    if !e.unused.is_empty() {
        let _ = writeln!(
            v,
            "\n  // Bits the arithmetic drops (truncation) or does not read.\n  wire unused_bits = ^{{{}}};",
            e.unused.join(", ")
        );
    }
    v += "endmodule\n\n`default_nettype wire\n";

    let in_fields: Vec<Field> = inputs
        .iter()
        .map(|p| Field::new(&p.name, p.format))
        .collect();
    let mut out_fields = Vec::new();
    if nf > 0 {
        out_fields.push(Field::new(
            "ovf",
            Format::new(false, count(nf), 0).expect("at most 64 flags"),
        ));
    }
    out_fields.extend(outs.iter().map(|p| Field::new(&p.name, p.format)));
    let testbench = testbench::generate(
        &d.module,
        &in_fields,
        &out_fields,
        nf,
        !muts.is_empty(),
        &setup,
    );
    let harness = testbench::harness(
        &d.module,
        &in_fields,
        &out_fields,
        nf,
        !muts.is_empty(),
        &setup,
    );
    // lowRISC names: flip-flops `_q`, their next values `_d`.
    let names = naming::plan(&v);
    let v = naming::rename(&v, &names);
    // Cut points: the first name of each live operation that is a signal
    // of its own.
    let mut cuts = Vec::new();
    for (i, op) in t.ops().iter().enumerate() {
        if !live[i] || matches!(op, Op::Input(_) | Op::Const(_)) {
            continue;
        }
        if let Some(s0) = e.stage[i] {
            if let Some(n) = e.at.get(&(i, s0)) {
                if n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                    cuts.push((i, s0, names.get(n).unwrap_or(n).clone()));
                }
            }
        }
    }
    Ok(Emitted {
        node_names: node_names(t, &|port| setup_of(port).is_some()),
        module: d.module.clone(),
        verilog: wrap::wrap_verilog(&v, wrap::WIDTH),
        testbench: wrap::wrap_verilog(&testbench, wrap::WIDTH),
        harness,
        latency,
        pipelining: if muts.is_empty() {
            d.pipelining
        } else {
            timing::Pipelining::Compact
        },
        predicted_ns,
        too_slow: e
            .too_slow
            .iter()
            .map(|s| naming::rename(s, &names))
            .collect(),
        splits: e.splits,
        flags,
        inputs: in_fields,
        outputs: out_fields,
        hardware: e.hw,
        setup,
        cuts,
    })
}

#[cfg(test)]
mod node_name_tests {
    use crate::datapath::{Datapath, Trace};
    use crate::emit::sat;

    /// `y = Q_s(a·b + c)`, `z = Q_s(y·y)`: with `extra`, one more product
    /// of another stage is traced first.
    fn trace(extra: bool) -> Trace {
        let mut t = Trace::new();
        let a = t.input_named("a", &sat("u.in", 8));
        let b = t.input_named("b", &sat("u.in", 8));
        let c = t.input_named("c", &sat("u.in", 8));
        if extra {
            let p = t.mul(a, a);
            let q = t.quantize(p, &sat("u.other", 16));
            t.output("o", q);
        }
        let p = t.mul(a, b);
        let s = t.add(p, c);
        let y = t.quantize(s, &sat("u.s", 16));
        let yy = t.mul(y, y);
        let z = t.quantize(yy, &sat("u.s", 16));
        t.output("z", z);
        t
    }

    /// Names are stage-local: a quantization is `<stage id>_<k>`, the
    /// arithmetic it reads `<stage id>_<op><k>`, ports `<port>_i`; all
    /// distinct; and tracing another stage's work first renames nothing of
    /// this stage (names no longer hold trace node numbers).
    #[test]
    fn names_are_stage_local_and_survive_a_change_elsewhere() {
        let names = |extra| super::node_names(&trace(extra), &|_| false);
        let plain = names(false);
        assert_eq!(
            plain,
            ["a_i", "b_i", "c_i", "u_s_mul0", "u_s_add0", "u_s_0", "u_s_mul1", "u_s_1"]
        );
        let more = names(true);
        assert!(more.contains(&"u_other_0".to_string()), "{more:?}");
        let mine: Vec<&String> = more.iter().filter(|n| n.starts_with("u_s_")).collect();
        assert_eq!(mine, plain[3..].iter().collect::<Vec<_>>());
        let mut seen = std::collections::HashSet::new();
        assert!(more.iter().all(|n| seen.insert(n)), "{more:?}");
    }
}
