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
    fn reg(&mut self, stage: u32, name: &str, signed: bool, width: u32, src: &str) {
        self.body
            .push(format!("reg  {} {name};", decl(signed, width)));
        self.regs.push((stage, format!("{name} <= {src};")));
        self.hw.flops += width as u64;
    }

    /// [`Self::reg`] for a product's own operand register
    /// ([`Self::own_regs`]).
    fn own_reg(&mut self, stage: u32, name: &str, signed: bool, width: u32, src: &str) {
        self.body
            .push(format!("reg  {} {name};", decl(signed, width)));
        self.own_regs.push((stage, format!("{name} <= {src};")));
        self.hw.flops += width as u64;
    }

    /// The node's value at `stage` (balancing registers created on demand).
    fn value_at(&mut self, node: usize, stage: u32) -> String {
        if self.stage[node].is_some_and(|s0| stage >= s0) && !self.lazy[node] {
            let r = &mut self.first_read[node];
            *r = Some(r.map_or(stage, |x| x.min(stage)));
        }
        self.carry_to(node, stage)
    }

    /// [`Self::value_at`] without recording the read: the balancing
    /// registers' own chain.
    fn carry_to(&mut self, node: usize, stage: u32) -> String {
        if self.lazy[node] {
            return self.lazy_select(node, stage);
        }
        let Some(s0) = self.stage[node] else {
            if let Some(g) = self.banked_group(node) {
                return self.bank_read(node, g, stage);
            }
            let g = self.groups[node];
            for (k, d) in self.drain.iter_mut().enumerate() {
                if g >> k & 1 == 1 {
                    *d = (*d).max(stage);
                }
            }
            return self.name[node].clone();
        };
        assert!(stage >= s0, "values flow forward");
        if let Some(n) = self.at.get(&(node, stage)) {
            return n.clone();
        }
        let prev = self.carry_to(node, stage - 1);
        let sym = self.t.sym(node);
        let name = format!("{}_s{stage}", self.name[node]);
        self.reg(stage, &name, sym.signed, sym.width, &prev);
        self.at.insert((node, stage), name.clone());
        name
    }

    /// The banked set-up group of a set-up input, if its group is banked.
    fn banked_group(&self, node: usize) -> Option<usize> {
        if !matches!(self.t.ops()[node], Op::Input(_)) {
            return None;
        }
        let g = self.groups[node];
        (0..self.banked.len()).find(|&k| g >> k & 1 == 1 && self.banked[k])
    }

    /// A banked set-up input as the item in `stage` sees it: bank 1 when
    /// the item's tag (`<group>_cur_q` at stage 0, `<group>_tag_q[s−1]`
    /// after) is 1, else bank 0. Reading it at `stage` makes the group's
    /// port wait for that stage (its drain).
    ///
    /// Pipelined for a target, a read at stage `s ≥ 1` is a register of
    /// stage `s` loaded from the banks as the item in stage `s − 1` sees
    /// them: the value then leaves a flip-flop, as a DSP block's operand
    /// register needs (a multiplexer in front of the multiplier keeps its
    /// operand registers in the fabric and the product combinational), and
    /// the port waits for stage `s − 1` only.
    fn bank_read(&mut self, node: usize, g: usize, stage: u32) -> String {
        if let Some(n) = self.bank_at.get(&(node, stage)) {
            return n.clone();
        }
        let registered = stage > 0 && self.timing.is_some();
        let read = if registered { stage - 1 } else { stage };
        self.drain[g] = self.drain[g].max(read);
        let field = self.name[node].trim_end_matches("_q").to_string();
        let group = self.group_names[g];
        let tag = if read == 0 {
            format!("{group}_cur_q")
        } else {
            format!("{group}_tag_q[{}]", read - 1)
        };
        let sym = self.t.sym(node);
        let mux = format!("{tag} ? {field}_b1_q : {field}_b0_q");
        let name = format!("{field}_bank_s{stage}");
        if registered {
            self.reg(stage, &name, sym.signed, sym.width, &mux);
        } else {
            self.body.push(format!(
                "wire {} {name} = {mux};",
                decl(sym.signed, sym.width)
            ));
        }
        self.bank_at.insert((node, stage), name.clone());
        name
    }

    /// A banked set-up input taken from its bank at stage 0 and carried
    /// with the item to `stage` (one register a stage).
    fn carried(&mut self, node: usize, stage: u32) -> String {
        if stage == 0 {
            let g = self.banked_group(node).expect("a banked set-up input");
            return self.bank_read(node, g, 0);
        }
        if let Some(n) = self.carried.get(&(node, stage)) {
            return n.clone();
        }
        let prev = self.carried(node, stage - 1);
        let field = self.name[node].trim_end_matches("_q").to_string();
        let sym = self.t.sym(node);
        let name = format!("{field}_c_s{stage}");
        self.reg(stage, &name, sym.signed, sym.width, &prev);
        self.carried.insert((node, stage), name.clone());
        name
    }

    /// A selection of constants by a banked set-up input, read at `stage`:
    /// the selector is carried with the item (a few bits instead of the
    /// selected value's width, and no bank for later stages to wait for),
    /// and, pipelined for a target, the multiplexer sits in the stage
    /// before and its result is a register of `stage` (compact, or at stage
    /// 0, it is combinational in `stage`). So the normalizer's coefficient
    /// set costs one multiplexer (and register) per reading stage, and for
    /// a target no path runs from a set-up register through the
    /// multiplexer into a multiplier.
    fn lazy_select(&mut self, node: usize, stage: u32) -> String {
        if let Some(n) = self.lazy_at.get(&(node, stage)) {
            return n.clone();
        }
        let Op::Select(sel, opts) = self.t.ops()[node].clone() else {
            unreachable!("a lazy node is a selection")
        };
        let sym = self.t.sym(node);
        // Pipelined for a target, the multiplexer gets a stage of its own
        // (it is off the multiplier's path); compact, it sits in the
        // reading stage.
        let registered = stage > 0 && self.timing.is_some();
        let at = if registered { stage - 1 } else { stage };
        let vs = self.carried(sel.node(), at);
        let base = self.name[node].clone();
        let mux = format!("{base}_m{at}");
        self.case_select(node, &mux, &vs, sel.sym().width, &opts, at);
        let name = if !registered {
            mux
        } else {
            let r = format!("{base}_s{stage}");
            self.reg(stage, &r, sym.signed, sym.width, &mux);
            r
        };
        self.lazy_at.insert((node, stage), name.clone());
        name
    }

    /// The multiplexer of selection `node` as a `case` on `sel` (`width`
    /// bits) into `reg name`, its options read at `stage` and aligned to
    /// the node's format; option 0 past the last.
    fn case_select(
        &mut self,
        node: usize,
        name: &str,
        sel: &str,
        width: u32,
        opts: &[TV],
        stage: u32,
    ) {
        let sym = self.t.sym(node);
        let vals: Vec<String> = opts
            .iter()
            .map(|o| {
                let v = self.operand(o, stage);
                bits::sv(
                    sym.signed,
                    &bits::align(&v, (sym.frac - v.frac) as u32, sym.width),
                )
            })
            .collect();
        self.hw.selects += 1;
        self.hw.select_bits += u64::from(sym.width) * (vals.len() as u64).saturating_sub(1);
        self.body
            .push(format!("reg  {} {name};", decl(sym.signed, sym.width)));
        let mut t = "always @* begin\n".to_string();
        let _ = writeln!(t, "  case ({sel})");
        for (k, v) in vals.iter().enumerate().skip(1) {
            let _ = writeln!(t, "    {width}'d{k}: {name} = {v};");
        }
        let _ = writeln!(t, "    default: {name} = {};", vals[0]);
        t += "  endcase\nend";
        self.body.push(t);
    }

    fn ovf_at(&mut self, node: usize, stage: u32) -> String {
        let s0 = self.stage[node].expect("a quantization has a stage");
        if let Some(n) = self.ovf_at.get(&(node, stage)) {
            return n.clone();
        }
        assert!(stage > s0);
        let prev = self.ovf_at(node, stage - 1);
        let name = format!("{}_ovf_s{stage}", self.name[node]);
        self.reg(stage, &name, false, 1, &prev);
        self.ovf_at.insert((node, stage), name.clone());
        name
    }

    /// Flag `k` of `ovf_o` at `latency`: the OR of its quantizers' overflow
    /// bits, folded into one register per stage as they arrive. Each
    /// quantizer's bit is registered once after the stage that computes it
    /// (the OR never lengthens that stage's path) and ORed there into the
    /// flag's running register; before, every bit was carried on its own
    /// to the output and ORed only there (one flip-flop per quantizer and
    /// later stage). A bit that first exists at `latency` is ORed there
    /// unregistered, as before.
    fn flag_chain(&mut self, k: usize, nodes: &[usize], latency: u32) -> String {
        let mut parts: std::collections::BTreeMap<u32, Vec<String>> = Default::default();
        for &n in nodes {
            let first = self
                .ovf_at
                .keys()
                .filter(|(m, _)| *m == n)
                .map(|&(_, s)| s)
                .min()
                .unwrap_or_else(|| self.stage[n].expect("a quantization has a stage"));
            let at = (first + 1).min(latency);
            let bit = self.ovf_at(n, at);
            parts.entry(at).or_default().push(bit);
        }
        let from = *parts.keys().next().expect("a flag has a quantizer");
        let mut acc: Option<String> = None;
        for s in from..=latency {
            if let Some(a) = acc.take() {
                let name = format!("ovf{k}_s{s}");
                self.reg(s, &name, false, 1, &a);
                acc = Some(name);
            }
            let Some(p) = parts.get(&s) else { continue };
            let mut terms: Vec<String> = acc.take().into_iter().collect();
            terms.extend(p.iter().cloned());
            acc = Some(if terms.len() == 1 {
                terms.remove(0)
            } else {
                // Four terms a line: lines stay under 100 columns.
                let w = format!("ovf{k}_or_s{s}");
                let lines: Vec<String> = terms.chunks(4).map(|c| c.join(" | ")).collect();
                self.body.push(format!(
                    "wire {w} =
    {};",
                    lines.join("\n    | ")
                ));
                w
            });
        }
        acc.expect("the last stage is reached")
    }

    /// Where an operation of delay `d` on `operands` goes: the stage of its
    /// latest operand and the time its inputs are ready there; with target
    /// pipelining, the next stage (operands registered, ready at 0) when
    /// `d` would not fit after them.
    fn place(&mut self, operands: &[usize], d: f64) -> (u32, f64) {
        let staged = operands.iter().any(|&n| self.stage[n].is_some());
        let s = operands
            .iter()
            .filter_map(|&n| self.stage[n])
            .max()
            .unwrap_or(0);
        let a = operands
            .iter()
            .map(|&n| self.arrival_at(n, s))
            .fold(0.0, f64::max);
        match self.timing {
            // Set-up values alone (no stage): no register to add before
            // them, so the operation stays at stage 0.
            Some((_, budget)) if staged && a > 0.0 && a + d > budget => {
                let a1 = operands
                    .iter()
                    .map(|&n| self.arrival_at(n, s + 1))
                    .fold(0.0, f64::max);
                (s + 1, a1)
            }
            _ => (s, a),
        }
    }

    /// When node `n`'s value is ready at `stage` (at or after its own):
    /// its arrival in its own stage; a set-up value's at any stage (its
    /// logic after its registers); 0 from a register, except the one right
    /// after a DSP product, which sits in the block ([`Self::dsp_out`]).
    fn arrival_at(&self, n: usize, stage: u32) -> f64 {
        match self.stage[n] {
            None => self.arrival[n],
            Some(s0) if s0 == stage => self.arrival[n],
            Some(s0) if s0 + 1 == stage && self.dsp_out[n] => self
                .model()
                .and_then(|m| m.dsp)
                .map_or(0.0, |d| d.route_out),
            Some(_) => 0.0,
        }
    }

    /// Record that node `i` is ready `t` ns into its stage.
    fn ready(&mut self, i: usize, t: f64, what: &str) {
        self.arrival[i] = t;
        self.worst = self.worst.max(t);
        if let Some((_, budget)) = self.timing {
            if t > budget + 1e-9 {
                self.too_slow
                    .push(format!("{what} ({} ns > {budget:.2} ns)", fmt_ns(t)));
            }
        }
    }

    /// The delay model, when pipelining for a target.
    fn model(&self) -> Option<timing::DelayModel> {
        self.timing.map(|(m, _)| m)
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

    fn rom(&mut self, entries: &[i128], base: &str, f: Format, addr_bits: u32) -> String {
        if let Some((_, n, _, _)) = self
            .roms
            .iter()
            .find(|(e, _, ff, _)| e == entries && *ff == f)
        {
            return n.clone();
        }
        let name = format!("{base}_rom");
        let mut t = String::new();
        // An array initialized once: simulators index it, synthesis reads
        // it as a ROM (its contents are the model's codes, in the source).
        let _ = writeln!(
            t,
            "// {name}: {} entries of {f}, the model's codes.",
            entries.len()
        );
        // Deep ROMs go to block RAM (their reads are registered straight
        // from the array); Yosys's cost model would otherwise build a ROM
        // read by six ports from logic.
        let _ = writeln!(
            t,
            "{}reg  {} {name} [0:{}];",
            if entries.len() >= BLOCK_ROM_ENTRIES {
                "(* rom_style = \"block\" *) "
            } else {
                ""
            },
            decl(f.signed(), f.width()),
            entries.len() - 1
        );
        t += "initial begin\n";
        for (i, &c) in entries.iter().enumerate() {
            let _ = writeln!(
                t,
                "  {name}[{i}] = {};",
                bits::sv(f.signed(), &bits::literal(f.width(), c))
            );
        }
        t += "end\n";
        let _ = addr_bits;
        self.rom_text.push(t);
        self.hw.rom_bits += entries.len() as u64 * f.width() as u64;
        self.hw.roms.push(RomHw {
            name: name.clone(),
            entries: entries.len() as u64,
            width: f.width(),
            reads: 0,
            block: entries.len() >= BLOCK_ROM_ENTRIES,
        });
        self.roms
            .push((entries.to_vec(), name.clone(), f, addr_bits));
        name
    }

    /// One more read port of the ROM `name`.
    fn count_read(&mut self, name: &str) {
        if let Some(r) = self.hw.roms.iter_mut().find(|r| r.name == name) {
            r.reads += 1;
        }
    }

    /// A table read at stage `s`, registered into `s + 1`. With `late`,
    /// the raw entry and its quadrant bits are registered once more, into
    /// `s + 2`, before the quarter-turn choice and the sign (a period too
    /// short for the block RAM's clock-to-output and that logic).
    fn table_read(&mut self, i: usize, idx: &Val, tb: &Table, s: u32, late: bool) {
        let f = tb.out.format();
        let t = tb.index.width();
        let base = &self.name[i].clone();
        let ix = idx.slice(t - 1, 0);
        let value = match &tb.storage {
            None => {
                let rom = self.rom(&tb.codes, tb.name, f, t);
                self.count_read(&rom);
                format!("{rom}[{ix}]")
            }
            Some(q) => {
                // j = i + phase·quarter turn; quadrant h = j[t−1:t−2].
                let j = format!("{base}_j");
                let jexpr = if q.phase == 0 {
                    ix.clone()
                } else {
                    self.hw.adders.push(2);
                    format!(
                        "{{{} + 2'd{}, {}}}",
                        idx.slice(t - 1, t - 2),
                        q.phase,
                        idx.slice(t - 3, 0)
                    )
                };
                self.body.push(format!("wire [{}:0] {j} = {jexpr};", t - 1));
                let a = format!("{base}_a");
                // Odd quadrants read the mirror image: 2^(t−2) − r.
                self.body.push(format!(
                    "wire [{}:0] {a} = {j}[{}] ? ({} - {{1'b0, {j}[{}:0]}}) : {{1'b0, {j}[{}:0]}};",
                    t - 2,
                    t - 2,
                    bits::literal(t - 1, 1i128 << (t - 2)),
                    t - 3,
                    t - 3
                ));
                self.hw.adders.push(t - 1);
                // The ROM holds the first 2^(t−2) entries, a power of two a
                // block RAM holds exactly; the quarter-turn entry (address
                // 2^(t−2), the only one with that bit set) is a constant.
                // The read is registered straight from the ROM, so synthesis
                // can map it to a block RAM's registered read port; the
                // quarter-turn choice and the sign are applied after that
                // register, in the next stage, by the reading operation.
                let depth = 1usize << (t - 2);
                let rom = self.rom(&q.entries[..depth], "quarter", f, t - 2);
                self.count_read(&rom);
                let raw = format!("{base}_raw");
                self.reg(
                    s + 1,
                    &raw,
                    f.signed(),
                    f.width(),
                    &format!("{rom}[{a}[{}:0]]", t - 3),
                );
                let top = format!("{base}_top");
                self.reg(s + 1, &top, false, 1, &format!("{a}[{}]", t - 2));
                let neg = format!("{base}_neg_q");
                self.reg(s + 1, &neg, false, 1, &format!("{j}[{}]", t - 1));
                let (raw, top, neg, so) = if late {
                    let (r2, t2, n2) = (
                        format!("{raw}_s{}", s + 2),
                        format!("{top}_s{}", s + 2),
                        format!("{neg}_s{}", s + 2),
                    );
                    self.reg(s + 2, &r2, f.signed(), f.width(), &raw);
                    self.reg(s + 2, &t2, false, 1, &top);
                    self.reg(s + 2, &n2, false, 1, &neg);
                    (r2, t2, n2, s + 2)
                } else {
                    (raw, top, neg, s + 1)
                };
                let v = format!("{base}_v");
                self.body.push(format!(
                    "wire {} {v} = {top} ? {} : {raw};",
                    decl(f.signed(), f.width()),
                    bits::sv(f.signed(), &bits::literal(f.width(), q.entries[depth]))
                ));
                // Negated in one more bit, then back into the entry format.
                let n = format!("{base}_n");
                let vv = Val {
                    expr: v.clone(),
                    width: f.width(),
                    signed: f.signed(),
                    frac: f.frac(),
                };
                self.body.push(format!(
                    "wire signed [{}:0] {n} = {};",
                    f.width(),
                    bits::sv(
                        true,
                        &format!(
                            "{} - {}",
                            bits::literal(f.width() + 1, 0),
                            bits::align(&vv, 0, f.width() + 1)
                        )
                    )
                ));
                self.hw.adders.push(f.width() + 1);
                let nv = Val {
                    expr: n,
                    width: f.width() + 1,
                    signed: true,
                    frac: f.frac(),
                };
                let ny = format!("{base}_nv");
                let qz = bits::quantize(
                    &nv,
                    &format!("{base}_neg"),
                    &ny,
                    &format!("unused_{base}_novf"),
                    f.width(),
                    f.signed(),
                    f.frac(),
                    Rounding::Trunc,
                    tb.out.overflow(),
                );
                self.hw.check_bits += u64::from(qz.check_bits);
                self.hw.saturate_bits += u64::from(qz.saturate_bits);
                // The negation's choice below.
                self.hw.select_bits += u64::from(f.width());
                self.body.extend(qz.lines);
                let out = base.clone();
                self.body.push(format!(
                    "wire {} {out} = {};",
                    decl(f.signed(), f.width()),
                    bits::sv(f.signed(), &format!("{neg} ? {ny} : {v}"))
                ));
                self.stage[i] = Some(so);
                self.at.insert((i, so), out);
                self.hw.table_reads += 1;
                return;
            }
        };
        // Registered read.
        let out = base.clone();
        self.reg(s + 1, &out, f.signed(), f.width(), &value);
        self.at.insert((i, s + 1), out);
        self.hw.table_reads += 1;
    }

    /// A quantization under target pipelining: its output is a wire (the
    /// next operation registers it if it must); the rounding incrementer
    /// and the range check with saturation share a stage when they fit,
    /// else the rounded value is registered between them.
    fn quant_timed(&mut self, i: usize, a: &TV, q: &crate::quantize::Quant) {
        let (m, budget) = self.timing.expect("target pipelining");
        let name = self.name[i].clone();
        let f = q.format();
        let sa = a.sym();
        let drop = a.frac() - f.frac();
        let rw = bits::rounded_width(sa.width, drop, q.round());
        let nearest = q.round() != Rounding::Trunc;
        let dr = m.round(drop.max(0) as u32, rw, nearest);
        let checked = if bits::can_leave(rw, sa.signed, f.width(), f.signed()) {
            rw.saturating_sub(f.width()) + 1
        } else {
            0
        };
        let ds = m.saturate(checked, q.overflow() == Overflow::Saturate);
        let (s0, a0) = self.place(&[a.node()], 0.0);
        let both = dr > 0.0 && ds > 0.0;
        let (s, t, split) = if a0 + dr + ds <= budget {
            (s0, a0, false)
        } else if both && a0 + dr <= budget {
            (s0, a0, true)
        } else if a0 == 0.0 || self.stage[a.node()].is_none() {
            // Nothing to register before the operand (a register, or a
            // set-up value read wherever it is needed).
            (s0, a0, both && dr + ds > budget)
        } else {
            (s0 + 1, 0.0, both && dr + ds > budget)
        };
        let va = self.operand(a, s);
        let (yc, oc) = (format!("{name}_c"), format!("{name}_ovf_c"));
        let (src, stage, t_end) = if split {
            // Round into a format wide enough never to overflow, register,
            // then check the range and saturate: the same function.
            let rname = format!("{name}_rw");
            let r = bits::quantize(
                &va,
                &format!("{name}_rnd"),
                &rname,
                &format!("{name}_rnd_ovf"),
                rw,
                sa.signed,
                f.frac(),
                q.round(),
                Overflow::Wrap,
            );
            self.hw.check_bits += u64::from(r.check_bits);
            self.hw.saturate_bits += u64::from(r.saturate_bits);
            self.body.extend(r.lines);
            self.unused.extend(r.unused);
            self.unused.push(format!("{name}_rnd_ovf"));
            if let Some(w) = r.round_adder {
                self.hw.incrementers.push(w);
            }
            let rq = format!("{name}_r_q");
            self.reg(s + 1, &rq, sa.signed, rw, &rname);
            self.worst = self.worst.max(t + dr);
            (
                Val {
                    expr: rq,
                    width: rw,
                    signed: sa.signed,
                    frac: f.frac(),
                },
                s + 1,
                ds,
            )
        } else {
            (va, s, t + dr + ds)
        };
        let round = if split { Rounding::Trunc } else { q.round() };
        let ql = bits::quantize(
            &src,
            &name,
            &yc,
            &oc,
            f.width(),
            f.signed(),
            f.frac(),
            round,
            q.overflow(),
        );
        self.hw.check_bits += u64::from(ql.check_bits);
        self.hw.saturate_bits += u64::from(ql.saturate_bits);
        self.body.extend(ql.lines);
        self.unused.extend(ql.unused);
        if let Some(w) = ql.round_adder {
            self.hw.incrementers.push(w);
        }
        self.stage[i] = Some(stage);
        self.at.insert((i, stage), yc);
        self.ovf_at.insert((i, stage), oc);
        self.ready(i, t_end, &name);
    }

    /// A multiplier too slow for a stage, split into partial products:
    /// `a × b = Σ a_i × b_j · 2^(lo_i + lo_j)` over chunks of each operand
    /// (the top chunk of a signed operand signed, the others unsigned and
    /// zero-extended by one bit when their partner is signed), each partial
    /// product registered, then summed by a tree of adders in the product's
    /// width (exact: the product fits it), with registers between tree
    /// levels where the period needs them. On a target without DSP blocks
    /// the narrower operand is cut into chunks short enough for a LUT
    /// multiplier to fit the period; on a DSP target both operands are cut
    /// to the block's size, so every partial product is one block. Returns
    /// false when no split helps.
    fn split_mul(
        &mut self,
        i: usize,
        oa: &Opnd,
        ob: &Opnd,
        s: u32,
        m: timing::DelayModel,
        budget: f64,
    ) -> bool {
        let a_first = oa.val().width >= ob.val().width;
        let (ox, oy) = if a_first { (oa, ob) } else { (ob, oa) };
        let (x, y) = (ox.val(), oy.val());
        if x.expr.contains('\'') || y.expr.contains('\'') {
            return false;
        }
        let (cx, cy) = match m.dsp {
            None => {
                let mut c = y.width;
                while c > 1 && m.lut_mul(x.width + 1, c + 1) > budget {
                    c -= 1;
                }
                (x.width, c)
            }
            Some(d) => {
                // Chunks that fit the block with the extension bit; an
                // operand that fits whole stays whole.
                // (a signed operand as wide as the block fits it whole).
                let fit = |v: &Val, max: u32| {
                    if v.width < max || (v.signed && v.width == max) {
                        v.width
                    } else {
                        max - 1
                    }
                };
                (fit(x, d.a), fit(y, d.b))
            }
        };
        if cx >= x.width && cy >= y.width {
            return false;
        }
        let name = self.name[i].clone();
        let sym = self.t.sym(i);
        let w = sym.width;
        // Operands read at stage s: chunk wires of the shared value; own
        // operands: each partial product registers its two chunks.
        let xs = match ox {
            Opnd::At(v) => self.chunks(&name, v, cx, "a"),
            Opnd::Own(p) => chunk_slices(p, cx),
        };
        let ys = match oy {
            Opnd::At(v) => self.chunks(&name, v, cy, "b"),
            Opnd::Own(p) => chunk_slices(p, cy),
        };
        let mut parts: Vec<String> = Vec::new();
        let chunk = |&(_, width, signed, lo): &(String, u32, bool, u32)| crate::datapath::Chunk {
            lo,
            width,
            signed,
        };
        let recorded = xs
            .iter()
            .flat_map(|x| ys.iter().map(move |y| (chunk(x), chunk(y))))
            .map(|(x, y)| {
                let (a, b) = if a_first { (x, y) } else { (y, x) };
                crate::datapath::PartialProduct { a, b }
            })
            .collect();
        self.splits.push(crate::datapath::MulSplit {
            node: i,
            parts: recorded,
        });
        let mut slowest: f64 = 0.0;
        for (jx, (xe, xw, xsg, xlo)) in xs.iter().enumerate() {
            for (jy, (ye, yw, ysg, ylo)) in ys.iter().enumerate() {
                let own = |e: &mut Self, o: &Opnd, src: &str, w: u32, sg: bool, tag: &str| {
                    if matches!(o, Opnd::Own(_)) {
                        let q = format!("{name}_{tag}{jx}_{jy}_q");
                        e.own_reg(s, &q, sg, w, &bits::sv(sg, src));
                        q
                    } else {
                        src.to_string()
                    }
                };
                let xe = &own(self, ox, xe, *xw, *xsg, "a");
                let ye = &own(self, oy, ye, *yw, *ysg, "b");
                // Both factors of one signedness: a signed one extends an
                // unsigned partner by its bit.
                let ps = *xsg || *ysg;
                let (xe, xw) = self.extended(&name, xe, *xw, ps && !*xsg, &format!("az{jx}_{jy}"));
                let (ye, yw) = self.extended(&name, ye, *yw, ps && !*ysg, &format!("bz{jx}_{jy}"));
                let pw = xw + yw;
                let pp = format!("{name}_pp{jx}_{jy}");
                self.body
                    .push(format!("wire {} {pp} = {xe} * {ye};", decl(ps, pw)));
                self.hw.muls.push(MulHw {
                    a_width: xw,
                    b_width: yw,
                    signed: ps,
                    a_zext: ps && !*xsg,
                    b_zext: ps && !*ysg,
                    y_width: pw,
                });
                slowest = slowest.max(m.mul(xw, yw));
                let q = format!("{pp}_q");
                self.reg(s + 1, &q, ps, pw, &pp);
                let lo = xlo + ylo;
                // Aligned to the product's width: the partial's weight
                // 2^lo, extended by its own signedness, bits beyond w
                // dropped (the sum is exact modulo 2^w).
                let v = Val {
                    expr: q,
                    width: pw,
                    signed: ps,
                    frac: 0,
                };
                if pw + lo <= w {
                    parts.push(as_bits(bits::align(&v, lo, w)));
                } else {
                    let keep = w - lo;
                    let kept = Val {
                        expr: v.slice(keep - 1, 0),
                        width: keep,
                        signed: false,
                        frac: 0,
                    };
                    parts.push(as_bits(bits::align(&kept, lo, w)));
                    self.unused.push(v.slice(pw - 1, keep));
                }
            }
        }
        self.worst = self.worst.max(slowest);
        if slowest > budget + 1e-9 {
            self.too_slow.push(format!(
                "{name}: its smallest partial products ({} ns > {budget:.2} ns)",
                fmt_ns(slowest)
            ));
        }
        // The adder tree, level by level, from the partial products'
        // registers: in the DSP blocks, so the first level starts late.
        let (mut stage, mut t) = (s + 1, m.dsp.map_or(0.0, |d| d.route_out));
        let mut level = 0;
        while parts.len() > 1 {
            if t > 0.0 && t + m.add(w) > budget {
                let mut regd = Vec::new();
                for (n, p) in parts.iter().enumerate() {
                    let q = format!("{name}_l{level}_{n}_q");
                    self.reg(stage + 1, &q, sym.signed, w, &bits::sv(sym.signed, p));
                    regd.push(format!("{{{q}}}"));
                }
                parts = regd;
                stage += 1;
                t = 0.0;
            }
            let mut next = Vec::new();
            for (n, pair) in parts.chunks(2).enumerate() {
                if pair.len() == 1 {
                    next.push(pair[0].clone());
                    continue;
                }
                let sum = format!("{name}_l{level}_{n}");
                self.body.push(format!(
                    "wire {} {sum} = {};",
                    decl(sym.signed, w),
                    bits::sv(sym.signed, &format!("{} + {}", pair[0], pair[1]))
                ));
                self.hw.adders.push(w);
                next.push(format!("{{{sum}}}"));
            }
            parts = next;
            t += m.add(w);
            level += 1;
        }
        self.body.push(format!(
            "wire {} {name} = {};",
            decl(sym.signed, w),
            bits::sv(sym.signed, &parts[0])
        ));
        self.stage[i] = Some(stage);
        self.at.insert((i, stage), name.clone());
        self.ready(i, t, &name);
        true
    }

    /// A product's operand `tv` at stage `s`: with `own`, when its value
    /// comes from a register at `s` (a staged value from an earlier stage,
    /// or a held set-up value), the value the stage before holds, for the
    /// product to register on its own ([`Opnd::Own`]); else the value at
    /// `s` itself (a constant, a banked or per-triangle selected value,
    /// which are registers of their own already, or stage 0).
    fn mul_operand(&mut self, tv: &TV, s: u32, own: bool) -> Opnd {
        let n = tv.node();
        if let (true, Some(g)) = (own && s >= 1 && !self.lazy[n], self.banked_group(n)) {
            // A banked set-up input: the bank multiplexer as the item in
            // stage s - 1 sees it, a wire the product registers itself.
            let read = s - 1;
            self.drain[g] = self.drain[g].max(read);
            let field = self.name[n].trim_end_matches("_q").to_string();
            let name = format!("{field}_bank_m{read}");
            let sym = self.t.sym(n);
            if !self.bank_wires.contains(&name) {
                let group = self.group_names[g];
                let tag = if read == 0 {
                    format!("{group}_cur_q")
                } else {
                    format!("{group}_tag_q[{}]", read - 1)
                };
                self.body.push(format!(
                    "wire {} {name} = {tag} ? {field}_b1_q : {field}_b0_q;",
                    decl(sym.signed, sym.width)
                ));
                self.bank_wires.insert(name.clone());
            }
            return Opnd::Own(Val {
                expr: name,
                width: sym.width,
                signed: sym.signed,
                frac: tv.frac(),
            });
        }
        let staged_before = self.stage[n].is_some_and(|s0| s0 < s);
        let setup = self.stage[n].is_none()
            && self.banked_group(n).is_none()
            && !matches!(self.t.ops()[n], Op::Const(_));
        if own && !self.lazy[n] && (staged_before || setup) {
            Opnd::Own(self.operand(tv, s - 1))
        } else {
            Opnd::At(self.operand(tv, s))
        }
    }

    /// The operand itself at stage `s`: [`Opnd::Own`] registered whole
    /// into `name` (a register of stage `s`).
    fn own_operand(&mut self, o: Opnd, s: u32, name: &str) -> Val {
        match o {
            Opnd::At(v) => v,
            Opnd::Own(p) => {
                self.own_reg(s, name, p.signed, p.width, &p.expr);
                Val {
                    expr: name.to_string(),
                    ..p
                }
            }
        }
    }

    /// The chunks of operand `v`, `c` bits each from the bottom: (name,
    /// width, signed, weight). The top chunk of a signed operand is signed;
    /// the others are unsigned. One chunk is the operand itself.
    fn chunks(&mut self, name: &str, v: &Val, c: u32, tag: &str) -> Vec<(String, u32, bool, u32)> {
        let k = v.width.div_ceil(c);
        if k == 1 {
            return vec![(v.expr.clone(), v.width, v.signed, 0)];
        }
        let mut out = Vec::new();
        for j in 0..k {
            let lo = j * c;
            let hi = (lo + c).min(v.width) - 1;
            let cw = hi - lo + 1;
            let csigned = v.signed && j == k - 1;
            let n = format!("{name}_{tag}{j}");
            self.body.push(format!(
                "wire {} {n} = {};",
                decl(csigned, cw),
                bits::sv(csigned, &v.slice(hi, lo))
            ));
            out.push((n, cw, csigned, lo));
        }
        out
    }

    /// `e` (`w` bits, unsigned) zero-extended into a signed wire of `w + 1`
    /// bits when `zext`, else `e` itself.
    fn extended(&mut self, name: &str, e: &str, w: u32, zext: bool, tag: &str) -> (String, u32) {
        if !zext {
            return (e.to_string(), w);
        }
        let n = format!("{name}_{tag}");
        self.body
            .push(format!("wire signed [{w}:0] {n} = $signed({{1'b0, {e}}});"));
        (n, w + 1)
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
                    sa.width + (ext && sb.signed && !sa.signed) as u32,
                    sb.width + (ext && sa.signed && !sb.signed) as u32,
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
                let xa = bits::align(&va, (sym.frac - va.frac) as u32, w);
                let xb = bits::align(&vb, (sym.frac - vb.frac) as u32, w);
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
                let xa = bits::align(&va, (sym.frac - va.frac) as u32, w);
                let xb = bits::align(&vb, (sym.frac - vb.frac) as u32, w);
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
                let dl = self.model().map_or(0.0, |m| m.select(opts.len() as u32));
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
                self.hw.check_bits += u64::from(ql.check_bits);
                self.hw.saturate_bits += u64::from(ql.saturate_bits);
                self.body.extend(ql.lines);
                self.unused.extend(ql.unused);
                if let Some(w) = ql.round_adder {
                    self.hw.incrementers.push(w);
                }
                let _ = Overflow::Wrap;
                self.reg(s + 1, &name, f.signed(), f.width(), &yc);
                let ov = format!("{name}_ovf");
                self.reg(s + 1, &ov, false, 1, &oc);
                self.stage[i] = Some(s + 1);
                self.at.insert((i, s + 1), name);
                self.ovf_at.insert((i, s + 1), ov);
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

/// Where the second pass places table reads, from a first pass `e`: a
/// table read whose value is first read at stage `r` later than the stage
/// after its own is placed so that its value appears just before `r`, and
/// its address (no wider than its value) waits in the balancing registers
/// instead. Its readers keep their stages: with no delay model the value
/// is read at `r` from the read's register (address stage `r − 1`); with
/// one, at least one more register lies between (address stage `r − 3`,
/// room for the quarter wave's late stage), so the value arrives at `r`
/// from a register as before. `None`: placed as soon as the address
/// allows.
fn sink_plan(e: &Emitter) -> Vec<Option<u32>> {
    let t = e.t;
    let margin = if e.timing.is_some() { 3 } else { 1 };
    t.ops()
        .iter()
        .enumerate()
        .map(|(i, op)| {
            let Op::Table(a, slot) = op else {
                return None;
            };
            let narrower = t.tables()[*slot].index.width() <= t.sym(i).width;
            let staged = e.stage[a.node()].is_some() && !e.lazy[i];
            let (out, r) = (e.stage[i]?, e.first_read[i]?);
            let k = r.checked_sub(margin)?;
            (narrower && staged && k >= out).then_some(k)
        })
        .collect()
}

/// A product's operand as [`Emitter::mul_operand`] finds it.
enum Opnd {
    /// The value at the product's stage, as every reader there sees it.
    At(Val),
    /// The value the stage before holds: the product registers it (or
    /// each of its partial products its chunks) into registers of its own.
    Own(Val),
}

impl Opnd {
    fn val(&self) -> &Val {
        match self {
            Opnd::At(v) | Opnd::Own(v) => v,
        }
    }
}

/// [`Emitter::chunks`] of `v` as slices of its expression (no wires): for
/// registers that load them.
fn chunk_slices(v: &Val, c: u32) -> Vec<(String, u32, bool, u32)> {
    let k = v.width.div_ceil(c);
    if k == 1 {
        return vec![(v.expr.clone(), v.width, v.signed, 0)];
    }
    (0..k)
        .map(|j| {
            let lo = j * c;
            let hi = (lo + c).min(v.width) - 1;
            (v.slice(hi, lo), hi - lo + 1, v.signed && j == k - 1, lo)
        })
        .collect()
}

/// The module's formal properties, inside `ifdef FORMAL` (Yosys's
/// `read_verilog -formal` defines it; simulators and synthesis never see
/// them). `fxshade formal` proves them for every unit and top with
/// yosys-smtbmc and z3, by a bounded check from reset and k-induction:
///
/// * `ready_o = en` (`& ~setup_lock` with a held set-up port), and the
///   skid register holds an item only behind the head;
/// * the valid bits move one stage in a cycle with `en` (the first taking
///   `valid_i`) and hold otherwise: an item enters only by an input
///   transfer, never skips, splits or swaps a stage; an item leaving the
///   last stage lands in the head or the skid register, the skid
///   register's item moves to the head when it is free, and `en` is high
///   the cycle after one with `ready_i`;
/// * while `valid_o && !ready_i`, the next cycle keeps `valid_o` and every
///   output port unchanged;
/// * the pipeline drains: after `j` cycles in a row with `en` high and no
///   input transfer, its first `j` stages are empty;
/// * set-up registers (`setup`: the last stage reading them, their names)
///   hold in every cycle that starts with an item in stages `1..=drain`
///   or an item entering: an item computes with the set-up values of the
///   cycle it entered.
///
/// Together: every accepted item leaves once, in order, and none is made
/// up. (A first version also stated that the transfers in flight equal the
/// number of valid bits; z3 needs minutes to prove that popcount identity
/// on the deep tops, and the per-stage statements above imply it.)
fn formal_block(
    latency: u32,
    outs: &[Port],
    nf: usize,
    setup: &[String],
    lock: &[String],
    replicas: &[u32],
) -> String {
    let l = latency;
    let mut v = formal_prelude(l, "en & ~f_in");
    v += "  always @(*) begin\n";
    if !lock.is_empty() {
        let _ = writeln!(v, "    assert (ready_o == (en & ~({})));", lock.join(" | "));
    } else {
        v += "    assert (ready_o == en);\n";
    }
    v += "    assert (!skid_valid || out_valid_q);\n";
    for k in replicas {
        let _ = writeln!(v, "    assert (en_s{k}_q == en_q);");
    }
    v += "  end\n";
    let shifted = if l == 1 {
        "$past(f_in)".to_string()
    } else {
        format!("{{$past(valid_q[{}:0]), $past(f_in)}}", l - 2)
    };
    let shift = format!(
        "      if ($past(en)) assert (valid_q == {shifted});\n      else assert ($stable(valid_q));\n\
         \x20     if ($past(ready_i)) assert (en);\n\
         \x20     if ($past(out_arrive & ~out_load)) assert (skid_valid);\n\
         \x20     if ($past(out_load & (out_arrive | skid_valid))) assert (out_valid_q);\n\
         \x20     if ($past(skid_valid & ~out_load)) assert (skid_valid && $stable(skid_q));\n\
         \x20     if ($past(out_load & skid_valid)) assert (out_q == $past(skid_q));\n\
         \x20     if ($past(out_load & ~skid_valid & out_arrive)) assert (out_q == $past(last_d));\n\
         \x20     if ($past(~out_load & out_arrive)) assert (skid_q == $past(last_d));\n"
    );
    v += &formal_clocked(l, &shift, outs, nf, setup);
    v
}

/// The opening of a formal block: `f_past_valid` (reset first), `f_in`
/// (an input transfer) and `f_idle`, the cycles in a row (up to `l`) with
/// `idle` true.
fn formal_prelude(l: u32, idle: &str) -> String {
    let cw = 32 - (l + 1).leading_zeros();
    let mut v = String::new();
    v += "\n`ifdef FORMAL\n";
    v += "  // Handshake properties, proved by `fxshade formal` (yosys-smtbmc, z3): no\n";
    v += "  // item is made up, lost, duplicated or reordered; outputs hold under stall.\n";
    v += "  reg f_past_valid = 1'b0;\n";
    v += "  always @(posedge clk_i) f_past_valid <= 1'b1;\n";
    v += "  always @(*) if (!f_past_valid) assume (!rst_ni);\n";
    v += "  wire f_in = valid_i & ready_o;\n";
    let _ = writeln!(v, "  reg  [{}:0] f_idle;", cw - 1);
    v += "  always @(posedge clk_i or negedge rst_ni) begin\n";
    let _ = writeln!(v, "    if (!rst_ni) f_idle <= {cw}'d0;");
    let _ = writeln!(
        v,
        "    else f_idle <= ({idle}) ? ((f_idle == {cw}'d{l}) ? f_idle : f_idle + {cw}'d1) : {cw}'d0;"
    );
    v += "  end\n";
    v
}

/// The clocked properties both handshakes share, around `shift` (how the
/// valid bits move): the drain, output hold under stall, set-up registers
/// held while an item reads them, and the cover; closes the block.
fn formal_clocked(l: u32, shift: &str, outs: &[Port], nf: usize, setup: &[String]) -> String {
    let mut v = String::new();
    v += "  always @(posedge clk_i) begin\n";
    v += "    if (f_past_valid && rst_ni) begin\n";
    let _ = writeln!(
        v,
        "      assert ((valid_q & ~({{{l}{{1'b1}}}} << f_idle)) == {l}'d0);"
    );
    // Invariants of the set-up ports (no `$past`: they hold in every
    // cycle after reset, so induction may assume them one cycle back).
    for line in setup.iter().filter(|l| l.starts_with("assert")) {
        let _ = writeln!(v, "      {line}");
    }
    v += "    end\n";
    v += "    if (f_past_valid && rst_ni && $past(rst_ni)) begin\n";
    v += shift;
    v += "      if ($past(valid_o & ~ready_i)) begin\n";
    v += "        assert (valid_o);\n";
    for p in outs {
        let _ = writeln!(v, "        assert ($stable({}_o));", p.name);
    }
    if nf > 0 {
        v += "        assert ($stable(ovf_o));\n";
    }
    v += "      end\n";
    // Set-up registers: unchanged while an item is in the stages reading
    // them or entering.
    for line in setup.iter().filter(|l| !l.starts_with("assert")) {
        let _ = writeln!(v, "      {line}");
    }
    v += "    end\n";
    v += "    if (f_past_valid && rst_ni) cover (valid_o & ready_i);\n";
    v += "  end\n";
    v += "`endif\n";
    v
}

/// The stall handshake's control: one valid bit per stage and one global
/// enable `en`, which is a register (`en_q`, low while the skid register holds an item): the
/// stages move unless the output buffer's second entry, the skid
/// register, holds an item. The output ports are the buffer's head
/// register `out_q` ([`stall_outputs`]); an item leaving the last stage
/// goes to the head when it is free or taken this cycle, else to the skid
/// register, and the stages stop until the skid register empties, which
/// it does in the cycle after one with `ready_i`. `valid_o` is
/// `out_valid_q`; `ready_o` is `en` (with a held set-up port, a register
/// `ready_q` loaded with the next `en & ~setup_lock`). So no input port
/// reaches an output port, and `ready_i` reaches only the buffer's
/// controls, not the stages' enables. Latency `l + 1`.
///
/// `replicas`: the stages (k ≥ 2) whose registers load with a copy of the
/// enable of their own, `en_s<k>_q` (loaded like `en_q`, in a block marked
/// `keep` so synthesis does not merge them back): each copy drives one
/// stage's loads instead of one register driving every stage's.
fn stall_handshake(l: u32, lock: bool, replicas: &[u32]) -> String {
    let mut v = String::new();
    v += "  // Handshake: one valid bit per stage and one global stall, en, which is a\n";
    v += "  // register: the stages move unless the output buffer's skid register holds\n";
    v += "  // an item. The output ports are the buffer's head, out_q; an item leaving\n";
    v += "  // the last stage goes to the head when it is free or taken this cycle, else\n";
    v += "  // to the skid register. ready_o and valid_o are registers: no input port\n";
    v += "  // reaches an output port, and ready_i reaches only the buffer.\n";
    let _ = writeln!(v, "  reg  [{}:0] valid_q;", l - 1);
    v += "  reg  out_valid_q, en_q;\n";
    v += "  wire en = en_q;\n";
    v += "  wire skid_valid = ~en_q;\n";
    let _ = writeln!(v, "  wire out_arrive = en & valid_q[{}];", l - 1);
    v += "  wire out_load = ~out_valid_q | ready_i;\n";
    v += "  wire en_d = out_load | (en_q & ~out_arrive);\n";
    if lock {
        v += "  wire setup_lock_d;\n";
        v += "  reg  ready_q;\n";
        v += "  assign ready_o = ready_q;\n";
    } else {
        v += "  assign ready_o = en;\n";
    }
    v += "  wire in_take = valid_i & ready_o;\n";
    v += "  assign valid_o = out_valid_q;\n";
    v += "  always @(posedge clk_i or negedge rst_ni) begin\n";
    v += "    if (!rst_ni) begin\n";
    let _ = writeln!(v, "      valid_q <= {l}'b0;");
    v += "      out_valid_q <= 1'b0;\n      en_q <= 1'b1;\n";
    if lock {
        v += "      ready_q <= 1'b1;\n";
    }
    v += "    end else begin\n";
    if l == 1 {
        v += "      if (en) valid_q <= in_take;\n";
    } else {
        let _ = writeln!(
            v,
            "      if (en) valid_q <= {{valid_q[{}:0], in_take}};",
            l - 2
        );
    }
    v += "      out_valid_q <= ~out_load | skid_valid | out_arrive;\n";
    v += "      en_q <= en_d;\n";
    if lock {
        v += "      ready_q <= en_d & ~setup_lock_d;\n";
    }
    v += "    end\n  end\n";
    if !replicas.is_empty() {
        v += "  // The enable, one copy a stage: each drives one stage's loads.\n";
        for k in replicas {
            let _ = writeln!(v, "  reg  en_s{k}_q;");
        }
        v += "  (* keep *)\n  always @(posedge clk_i or negedge rst_ni) begin\n";
        v += "    if (!rst_ni) begin\n";
        for k in replicas {
            let _ = writeln!(v, "      en_s{k}_q <= 1'b1;");
        }
        v += "    end else begin\n";
        for k in replicas {
            let _ = writeln!(v, "      en_s{k}_q <= en_d;");
        }
        v += "    end\n  end\n";
    }
    v += "\n";
    v
}

/// The stall handshake's output buffer: the head `out_q`, which drives
/// the output ports, and the skid register `skid_q`, both loaded only
/// with an item (`last_d`: the last stage's results and flags).
fn stall_outputs(outs: &[Port], vals: &[String], flags: &[String]) -> String {
    let (w, parts, ports) = out_record(outs, vals, flags);
    let mut v = String::new();
    v += "  // Output buffer: the head drives the ports; the skid register takes the\n";
    v += "  // item that leaves the last stage while the head is stalled.\n";
    let _ = writeln!(v, "  wire [{}:0] last_d = {{{}}};", w - 1, parts.join(", "));
    let _ = writeln!(v, "  reg  [{}:0] out_q, skid_q;", w - 1);
    v += "  always @(posedge clk_i) begin\n";
    v += "    if (out_load & (skid_valid | out_arrive)) out_q <= skid_valid ? skid_q : last_d;\n";
    v += "    if (~out_load & out_arrive) skid_q <= last_d;\n";
    v += "  end\n";
    v += &ports;
    v
}

/// The output record of `outs` and the flags: its width, its parts
/// (values, then the flags' ORs) for a concatenation, and the port
/// assignments from `out_q`.
fn out_record(outs: &[Port], vals: &[String], flags: &[String]) -> (u32, Vec<String>, String) {
    let mut parts: Vec<String> = vals.to_vec();
    parts.extend(flags.iter().map(|f| format!("({f})")));
    let mut widths: Vec<(String, u32, bool)> = outs
        .iter()
        .map(|p| (format!("{}_o", p.name), p.format.width(), p.format.signed()))
        .collect();
    if !flags.is_empty() {
        widths.push(("ovf_o".into(), flags.len() as u32, false));
    }
    let w: u32 = widths.iter().map(|x| x.1).sum();
    let mut v = String::new();
    let mut msb = w;
    for (name, width, signed) in widths {
        let lsb = msb - width;
        let slice = format!("out_q[{}:{lsb}]", msb - 1);
        let e = if signed {
            format!("$signed({slice})")
        } else {
            slice
        };
        let _ = writeln!(v, "  assign {name} = {e};");
        msb = lsb;
    }
    (w, parts, v)
}

/// The FIFO handshake's control: the valid bits shift every cycle into an
/// output FIFO: a memory of `depth ≥ l + 2` entries, whose pointers
/// `wr_q`, `rd_q` are registers, and the head register `out_q`
/// ([`fifo_outputs`]), which drives the output ports. `ready_o` admits an
/// item only while the FIFO holds at most `depth − l − 1`, so it has room
/// for the item when it arrives `l` cycles later whatever else arrives
/// meanwhile. A count `cnt_q` of the items in the memory and the head;
/// `valid_o` is a register (`out_valid_q`) loaded with `next count ≠ 0`,
/// which is `f_wr | (cnt_q ≥ 2) | (valid_o & ~ready_i)`, so no reduction
/// of the count lies between `ready_i` and the pointers; `ready_o` is a
/// register (`ready_q`) loaded with the room test on the next count,
/// picked from tests of the current count against `K − 1`, `K + 1` and
/// `K` by whether an item enters the FIFO and whether one leaves, so only
/// a multiplexer follows `ready_i` (and, with a held set-up port, ANDed
/// with the next `~setup_lock`).
///
/// With `block` (a target whose memories are block RAM with a registered
/// read: iCE40) every item goes through the memory and the head loads
/// only from it, so the read is synchronous and maps to a RAM block; an
/// item then reaches the head one cycle later (latency `l + 2`), and
/// `valid_o` follows the head's loads. Otherwise (LUT RAM or flip-flops)
/// an item arriving at an empty memory goes straight to the head (latency
/// `l + 1`).
fn fifo_handshake(l: u32, depth: u32, lock: bool, block: bool) -> String {
    let aw = depth.trailing_zeros();
    let mut v = String::new();
    let k = depth - l - 1;
    let w = aw + 1;
    v += "  // Handshake: the pipeline never stalls (a stage's registers load whenever\n";
    v += "  // its item is valid) and ends in an output FIFO; ready_o admits an item\n";
    v += "  // while the FIFO has room for it and for every item ahead of it. ready_o\n";
    v += "  // is a register: the room test on the next count, chosen from three tests\n";
    v += "  // of the current count by what enters and leaves this cycle. valid_o is a\n";
    v += "  // register too: the next count is not zero. The output ports are the\n";
    v += "  // FIFO's head register, out_q.\n";
    let _ = writeln!(v, "  reg  [{}:0] valid_q;", l - 1);
    let _ = writeln!(v, "  reg  [{aw}:0] wr_q, rd_q, cnt_q;");
    v += "  reg  ready_q, out_valid_q;\n";
    let _ = writeln!(v, "  wire f_wr = valid_q[{}];", l - 1);
    v += "  wire in_xfer = valid_i & ready_o;\n";
    v += "  wire out_xfer = valid_o & ready_i;\n";
    v += "  wire out_load = ~out_valid_q | ready_i;\n";
    v += "  wire mem_empty = wr_q == rd_q;\n";
    if block {
        v += "  wire mem_wr = f_wr;\n";
    } else {
        v += "  wire mem_wr = f_wr & ~(out_load & mem_empty);\n";
    }
    v += "  wire mem_rd = out_load & ~mem_empty;\n";
    if lock {
        v += "  wire setup_lock_d;\n";
    }
    v += "  assign ready_o = ready_q;\n";
    v += "  assign valid_o = out_valid_q;\n";
    v += "  always @(posedge clk_i or negedge rst_ni) begin\n";
    v += "    if (!rst_ni) begin\n";
    let _ = writeln!(v, "      valid_q <= {l}'b0;");
    let _ = writeln!(
        v,
        "      wr_q <= {w}'d0;\n      rd_q <= {w}'d0;\n      cnt_q <= {w}'d0;\n      ready_q <= 1'b1;\n      out_valid_q <= 1'b0;"
    );
    v += "    end else begin\n";
    if l == 1 {
        v += "      valid_q <= in_xfer;\n";
    } else {
        let _ = writeln!(v, "      valid_q <= {{valid_q[{}:0], in_xfer}};", l - 2);
    }
    let _ = writeln!(v, "      wr_q <= wr_q + {{{aw}'d0, mem_wr}};");
    let _ = writeln!(v, "      rd_q <= rd_q + {{{aw}'d0, mem_rd}};");
    let _ = writeln!(
        v,
        "      cnt_q <= cnt_q + {{{aw}'d0, f_wr}} - {{{aw}'d0, out_xfer}};"
    );
    let unlock = if lock { " & ~setup_lock_d" } else { "" };
    let _ = writeln!(
        v,
        "      ready_q <= ((f_wr & ~out_xfer) ? (cnt_q <= {w}'d{}) :\n                  (~f_wr & out_xfer) ? (cnt_q <= {w}'d{}) : (cnt_q <= {w}'d{k})){unlock};",
        k - 1,
        k + 1
    );
    if block {
        v += "      out_valid_q <= mem_rd | (out_valid_q & ~ready_i);\n";
    } else {
        let _ = writeln!(
            v,
            "      out_valid_q <= f_wr | (cnt_q >= {w}'d2) | (out_valid_q & ~ready_i);"
        );
    }
    v += "    end\n  end\n\n";
    v
}

/// The FIFO handshake's output FIFO: the memory, written from the last
/// stage's registers, and the head register `out_q`, which drives the
/// output ports: it loads the memory's oldest entry when it is free or
/// taken, or the arriving item straight when the memory is empty. With
/// `distributed` (a target with LUT RAM: ECP5, xc7) the memory carries
/// `ram_style = "distributed"`, so its asynchronous read feeds the head;
/// with `block` ([`fifo_handshake`]) the head loads only from the memory.
fn fifo_outputs(
    depth: u32,
    outs: &[Port],
    vals: &[String],
    flags: &[String],
    distributed: bool,
    block: bool,
) -> String {
    let aw = depth.trailing_zeros();
    let (w, parts, ports) = out_record(outs, vals, flags);
    let mut v = String::new();
    v += "  // Output FIFO: the memory, written by the last stage when the head is\n";
    v += "  // busy, and the head register, which drives the ports.\n";
    if distributed {
        v += "  (* ram_style = \"distributed\" *)\n";
    }
    let _ = writeln!(v, "  reg  [{}:0] fifo_q [0:{}];", w - 1, depth - 1);
    let _ = writeln!(v, "  reg  [{}:0] out_q;", w - 1);
    let _ = writeln!(
        v,
        "  wire [{}:0] fifo_in = {{{}}};",
        w - 1,
        parts.join(", ")
    );
    v += "  always @(posedge clk_i) begin\n";
    let _ = writeln!(v, "    if (mem_wr) fifo_q[wr_q[{}:0]] <= fifo_in;", aw - 1);
    let _ = writeln!(v, "    if (mem_rd) out_q <= fifo_q[rd_q[{}:0]];", aw - 1);
    if !block {
        v += "    else if (out_load & f_wr) out_q <= fifo_in;\n";
    }
    v += "  end\n";
    v += &ports;
    v
}

/// The FIFO handshake's formal properties (`ifdef FORMAL`, proved by
/// `fxshade formal` as [`formal_block`]'s):
///
/// * the valid bits shift one stage every cycle, the first taking the
///   input transfer;
/// * the FIFO never overflows: it holds at most `depth` items, and an item
///   at stage `k` finds it holding fewer than `depth − (l − k)` (each
///   stage ahead of it adds at most one item before it arrives);
/// * while `valid_o && !ready_i`, the next cycle keeps `valid_o` and every
///   output port unchanged;
/// * after `j` cycles without an input transfer the first `j` stages are
///   empty; set-up registers hold while an item is in the stages reading
///   them.
fn formal_block_fifo(
    l: u32,
    depth: u32,
    outs: &[Port],
    nf: usize,
    setup: &[String],
    lock: &[String],
    block: bool,
) -> String {
    let aw = depth.trailing_zeros();
    let cw = aw + 2;
    let mut v = formal_prelude(l, "~f_in");
    // The FIFO never overflows: an item at stage k finds room when it
    // arrives, whatever the l − k stages ahead of it bring first. The
    // count is the memory's (the pointers') and the head's.
    let _ = writeln!(
        v,
        "  wire [{}:0] f_count = {{1'b0, wr_q - rd_q}} + {{{}'d0, out_valid_q}};",
        cw - 1,
        cw - 1
    );
    v += "  always @(*) begin\n";
    let _ = writeln!(v, "    assert (f_count <= {cw}'d{depth});");
    // The count and the registered admission test follow the pointers;
    // the head holds an item whenever the memory does.
    let _ = writeln!(v, "    assert ({{1'b0, cnt_q}} == f_count);");
    if !block {
        v += "    assert (mem_empty || out_valid_q);\n";
    }
    let unlock = if lock.is_empty() {
        String::new()
    } else {
        format!(" & ~({})", lock.join(" | "))
    };
    let _ = writeln!(
        v,
        "    assert (ready_q == ((f_count <= {cw}'d{}){unlock}));",
        depth - l - 1
    );
    for k in 1..=l {
        let _ = writeln!(
            v,
            "    assert (!valid_q[{}] || f_count + {cw}'d{} < {cw}'d{depth});",
            k - 1,
            l - k,
        );
    }
    v += "  end\n";
    let shifted = if l == 1 {
        "$past(f_in)".to_string()
    } else {
        format!("{{$past(valid_q[{}:0]), $past(f_in)}}", l - 2)
    };
    let shift = format!("      assert (valid_q == {shifted});\n");
    v += &formal_clocked(l, &shift, outs, nf, setup);
    v
}

/// A double-buffered set-up port `n` whose banks are read up to stage
/// `w` ([`SetupGroup::banked`]): the banks, the current bank `<n>_cur_q`
/// (the one an item accepted now reads), one tag bit per stage 1..`w`
/// (the bank of the item there) and the registered ready. A record loads
/// the other bank and makes it current; it is accepted while no item in
/// stages 1..`w` reads that bank, so an item accepted in the same cycle
/// keeps the old bank, and the ready is the same test on the next cycle's
/// state, held in a register (no path from an input port to it). Returns
/// the text and the flip-flops besides the banks.
fn banked_port(
    n: &str,
    doc: &str,
    w: u32,
    regs: &[(String, String, Format)],
    fifo: bool,
) -> (String, u64) {
    let mut t = comment(
        "  // ",
        &format!(
            "Set-up port `{n}`: {doc}. Two banks: a record loads the bank the items in stages 1..{w} do not read and makes it the current one; each item carries the bank it read (a tag per stage), so the next record loads while the last one's items are in flight. Ready is a register."
        ),
    );
    let _ = writeln!(t, "  reg  {n}_cur_q;");
    let _ = writeln!(t, "  reg  {n}_ready_q;");
    let _ = writeln!(t, "  wire {n}_load = {n}_valid_i & {n}_ready_q;");
    let _ = writeln!(t, "  wire {n}_cur_d = {n}_cur_q ^ {n}_load;");
    let _ = writeln!(t, "  assign {n}_ready_o = {n}_ready_q;");
    let mut extra = 2;
    if w == 0 {
        // Only stage 0 reads the banks: the other one is always free.
        t += "  always @(posedge clk_i or negedge rst_ni) begin
";
        let _ = writeln!(
            t,
            "    if (!rst_ni) begin
      {n}_cur_q <= 1'b0;
      {n}_ready_q <= 1'b1;
    end else begin
      {n}_cur_q <= {n}_cur_d;
      {n}_ready_q <= 1'b1;
    end"
        );
        t += "  end
";
    } else {
        extra += w as u64;
        let (step, shift_in) = if fifo {
            ("1'b1", "in_xfer")
        } else {
            ("en", "in_take")
        };
        let shift = |reg: &str, bit: &str| {
            if w == 1 {
                bit.to_string()
            } else {
                format!("{{{reg}[{}:0], {bit}}}", w - 2)
            }
        };
        let _ = writeln!(t, "  reg  [{}:0] {n}_tag_q;", w - 1);
        let _ = writeln!(
            t,
            "  wire [{}:0] {n}_tag_d = {step} ? {} : {n}_tag_q;",
            w - 1,
            shift(&format!("{n}_tag_q"), &format!("{n}_cur_q"))
        );
        let _ = writeln!(
            t,
            "  wire [{}:0] {n}_busy_d = {step} ? {} : valid_q[{}:0];",
            w - 1,
            shift("valid_q", shift_in),
            w - 1
        );
        t += "  always @(posedge clk_i or negedge rst_ni) begin
";
        let _ = writeln!(
            t,
            "    if (!rst_ni) begin
      {n}_cur_q <= 1'b0;
      {n}_tag_q <= {w}'b0;
      {n}_ready_q <= 1'b1;
    end else begin
      {n}_cur_q <= {n}_cur_d;
      {n}_tag_q <= {n}_tag_d;"
        );
        let _ = writeln!(
            t,
            "      {n}_ready_q <= ~|({n}_busy_d & ({n}_tag_d ^ {{{w}{{{n}_cur_d}}}}));
    end"
        );
        t += "  end
";
    }
    for (q, _, f) in regs {
        let base = q.trim_end_matches("_q");
        for b in 0..2 {
            let _ = writeln!(t, "  reg  {} {base}_b{b}_q;", decl(f.signed(), f.width()));
        }
    }
    if !regs.is_empty() {
        t += "  always @(posedge clk_i) begin
";
        let _ = writeln!(t, "    if ({n}_load & {n}_cur_q) begin");
        for (q, i, _) in regs {
            let _ = writeln!(t, "      {}_b0_q <= {i};", q.trim_end_matches("_q"));
        }
        let _ = writeln!(
            t,
            "    end
    if ({n}_load & ~{n}_cur_q) begin"
        );
        for (q, i, _) in regs {
            let _ = writeln!(t, "      {}_b1_q <= {i};", q.trim_end_matches("_q"));
        }
        t += "    end
  end
";
    }
    t += "
";
    (t, extra)
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
    let mut names = vec![String::new(); t.ops().len()];
    for (i, op) in t.ops().iter().enumerate() {
        names[i] = match op {
            Op::Input(slot) if setup_of(&inputs[*slot].name).is_some() => {
                format!("{}_q", inputs[*slot].name)
            }
            Op::Input(slot) => format!("{}_i", inputs[*slot].name),
            Op::Const(_) => format!("K{i}"),
            Op::Quant(..) => format!("{}_{i}", sanitize(t.stage_id(i).unwrap_or("q"))),
            Op::Table(_, slot) => format!("{}_{i}", t.tables()[*slot].name),
            _ => format!("t{i}"),
        };
    }
    let build = |sink: Vec<Option<u32>>| -> Result<Emitter, EmitError> {
        let mut e = Emitter {
            t,
            stage: vec![None; t.ops().len()],
            name: names.clone(),
            at: HashMap::new(),
            ovf_at: HashMap::new(),
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
                s + wire as u32
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
        flag_bits.push(e.flag_chain(k, nodes, latency));
    }
    let nf = flags.len();
    e.hw.flops += latency as u64; // valid bits
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
    let out_w: u32 = outs.iter().map(|p| p.format.width()).sum::<u32>() + nf as u32;
    if fifo {
        // Pointers, the count, the registered admission and output-valid
        // bits, the FIFO's entries and its head; the pointers' two
        // incrementers, the count's add and subtract, its three compares
        // with the admission bounds and the one with 2 for valid_o (the
        // pointers' equality is not an ordered compare).
        e.hw.flops += 3 * (aw as u64 + 1) + 2 + (depth as u64 + 1) * out_w as u64;
        e.hw.adders.extend([aw + 1; 4]);
        e.hw.compares += 4;
        // Its entries, a memory synthesis may build as LUT RAM.
        e.hw.fifo_bits += depth as u64 * out_w as u64;
    } else {
        // The head and the skid register with their valid bits (the
        // enable's copies are counted where they are written).
        e.hw.flops += 2 * out_w as u64 + 2;
        // The head loads the skid register or the last stage.
        e.hw.select_bits += u64::from(out_w);
    }
    let pipe_latency = latency;
    let latency = latency + 1 + block as u32;
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
                flops += f.width() as u64;
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
            Format::new(false, nf as u32, 0).expect("at most 64 flags"),
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
