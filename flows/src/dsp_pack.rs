//! Register packing into ECP5 `MULT18X18D` blocks, on Yosys's JSON netlist.
//!
//! Yosys's `synth_ecp5` maps every product to a combinational
//! `MULT18X18D` and leaves the registers around it in the fabric (it has
//! no ECP5 counterpart of `ice40_dsp` or `xilinx_dsp`). A product then
//! pays the routing from a fabric flip-flop into the block and back out
//! on top of the multiplier itself: about 3.2 + 3.9 + 3.2 ns on an
//! LFE5U-85F, 92 MHz at best. This pass moves those registers into the
//! block, as a vendor flow does:
//!
//! * **Which registers.** Only a plain flip-flop (`TRELLIS_FF`: clocked on
//!   the rising edge, no set or reset in use, power-up 0) whose enable is
//!   always on, a pipeline stage's own load (a net the emitted RTL names
//!   `load_s<k>`: the item entering stage `k` is valid and the stages
//!   move) or the stages' move itself (`en`, or its copy for stage `k`,
//!   `en_s<k>_q`, which load a product's own operand registers), so a
//!   register whose enable Yosys built from other
//!   logic (a set-up port's load, a folded multiplexer) stays in the
//!   fabric.
//! * **Inputs.** When every non-constant bit of `A` and of `B` comes from
//!   such a flip-flop, all on one clock, with one enable per operand, and
//!   every one of those flip-flops feeds only this block's operand pins,
//!   the block registers its operands itself
//!   (`REG_INPUTA_CLK`/`REG_INPUTB_CLK = "CLK0"`) from the flip-flops' `D`
//!   nets and the flip-flops are removed. A register with any other load
//!   is never copied into a block: the netlist keeps exactly the
//!   registers the RTL has. Both operands or neither: nextpnr times a
//!   block with one registered operand as if neither were.
//! * **Output.** When every used bit of `P` feeds exactly one such
//!   flip-flop's `D`, on the same clock, with one enable, those flip-flops
//!   become the block's output register (`REG_OUTPUT_CLK = "CLK0"`) and are
//!   removed; the block drives their `Q` nets.
//!
//! Each distinct enable takes one of the block's `CE0`–`CE3` (an enable
//! that is always on ties its pin to 1), the output register's `CE0`:
//! nextpnr writes `REG_INPUTA_CE`, `REG_INPUTB_CE` and `REG_PIPELINE_CE`
//! into the bitstream but no `REG_OUTPUT_CE`, so the block's output
//! register runs on its default enable, `CE0`, whatever the netlist says
//! (and fxshade's simulation model refuses any other). `RST0` is tied to 0. The function
//! is unchanged cycle for cycle from the first load of every register on:
//! only power-up contents may differ, which the pipeline's valid bits
//! ignore. Checked by the unit tests below on small netlists, and by
//! gate-level co-simulation of packed units against the model
//! (`fxshade synth --netlist`, [`crate::netlist`]; `tests/suite/synth.rs`).

use anyhow::{bail, Context, Result};
use serde_json::{json, Map, Value};
use std::collections::{BTreeMap, HashMap};

/// What the pass did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct PackStats {
    /// Blocks that took their operand registers.
    pub inputs: usize,
    /// Blocks that took their output register.
    pub outputs: usize,
    /// Fabric flip-flops removed (moved into blocks, or left without a
    /// load by the move).
    pub ffs_removed: usize,
    /// Blocks whose operand registers stay in the fabric because one of
    /// them has a load besides the block (it is not copied).
    #[serde(default)]
    pub kept_shared: usize,
    /// Blocks with a register left in the fabric because its enable is
    /// neither always on nor a stage's load.
    #[serde(default)]
    pub kept_enable: usize,
}

/// A bit of a connection: a net number or a constant (`"0"`, `"1"`, `"x"`).
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
enum Bit {
    Net(u64),
    Const(String),
}

impl Bit {
    fn of(v: &Value) -> Result<Bit> {
        match v {
            Value::Number(n) => Ok(Bit::Net(n.as_u64().context("a net number")?)),
            Value::String(s) => Ok(Bit::Const(s.clone())),
            _ => bail!("netlist: a connection bit is neither a net nor a constant"),
        }
    }
    fn value(&self) -> Value {
        match self {
            Bit::Net(n) => json!(n),
            Bit::Const(s) => json!(s),
        }
    }
}

/// A block pin and the flip-flop it connects to.
type PinFf = (String, String);

/// A flip-flop's enable: a net, or always on.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
enum Enable {
    Always,
    Net(Bit),
}

fn param<'a>(c: &'a Value, k: &str) -> Option<&'a str> {
    // Yosys pads a string parameter that looks like a bit pattern ("1 ").
    c["parameters"][k].as_str().map(str::trim_end)
}

fn conn(c: &Value, port: &str) -> Result<Vec<Bit>> {
    match c["connections"].get(port) {
        None => Ok(Vec::new()),
        Some(Value::Array(a)) => a.iter().map(Bit::of).collect(),
        Some(_) => bail!("netlist: port {port} is not a bit list"),
    }
}

fn one(c: &Value, port: &str) -> Result<Option<Bit>> {
    Ok(conn(c, port)?.into_iter().next())
}

/// The nets the emitted RTL names as a stage's load (`load_s<k>`, any
/// hierarchy prefix) or the stages' move (`en`, `en_s<k>_q`): the only
/// enables a packed register may have besides always on.
fn stage_loads(module: &Value) -> Result<std::collections::HashSet<Bit>> {
    let mut set = std::collections::HashSet::new();
    for (name, n) in module["netnames"].as_object().into_iter().flatten() {
        let leaf = name.rsplit('.').next().unwrap_or(name);
        let digits = |k: &str| !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit());
        let is_load = leaf == "en"
            || leaf.strip_prefix("load_s").is_some_and(digits)
            || leaf
                .strip_prefix("en_s")
                .and_then(|k| k.strip_suffix("_q"))
                .is_some_and(digits);
        if is_load {
            for b in n["bits"].as_array().into_iter().flatten() {
                set.insert(Bit::of(b)?);
            }
        }
    }
    Ok(set)
}

/// `(clock, enable)` of a plain flip-flop, or None.
fn plain_ff(c: &Value) -> Result<Option<(Bit, Enable)>> {
    if c["type"] != "TRELLIS_FF"
        || param(c, "CLKMUX").unwrap_or("CLK") != "CLK"
        || param(c, "REGSET").unwrap_or("RESET") != "RESET"
    {
        return Ok(None);
    }
    let lsr = one(c, "LSR")?;
    if param(c, "LSRMUX").unwrap_or("LSR") != "LSR"
        || !(lsr.is_none() || lsr == Some(Bit::Const("0".into())))
    {
        return Ok(None);
    }
    let Some(clk @ Bit::Net(_)) = one(c, "CLK")? else {
        return Ok(None);
    };
    let en = match param(c, "CEMUX").unwrap_or("1") {
        "1" => Enable::Always,
        "CE" => match one(c, "CE")? {
            Some(Bit::Const(z)) if z == "1" => Enable::Always,
            Some(b) => Enable::Net(b),
            None => return Ok(None),
        },
        _ => return Ok(None),
    };
    Ok(Some((clk, en)))
}

/// Pack registers into every `MULT18X18D` of module `top` (see the module
/// documentation). Deterministic: blocks in name order.
///
/// # Errors
///
/// The netlist has no module `top`, or a cell it must rewire lacks a port or a parameter.
///
/// # Panics
///
/// When the netlist's `modules` (or its top's `cells`) is neither an object nor absent: Yosys's
/// JSON always has them.
pub fn pack_mult18(netlist: &mut Value, top: &str) -> Result<PackStats> {
    let module = netlist["modules"]
        .get_mut(top)
        .with_context(|| format!("netlist has no module {top}"))?;
    let stage_load = stage_loads(module)?;
    let enable_ok = |e: &Enable| match e {
        Enable::Always => true,
        Enable::Net(b) => stage_load.contains(b),
    };
    let mut loads: HashMap<Bit, Vec<(String, String)>> = HashMap::new();
    let mut drivers: HashMap<Bit, (String, String)> = HashMap::new();
    if let Some(ports) = module["ports"].as_object() {
        for (name, p) in ports {
            for b in p["bits"].as_array().into_iter().flatten() {
                let b = Bit::of(b)?;
                if p["direction"] == "input" {
                    drivers.insert(b, ("$port".into(), name.clone()));
                } else {
                    loads
                        .entry(b)
                        .or_default()
                        .push(("$port".into(), name.clone()));
                }
            }
        }
    }
    let cells = module["cells"]
        .as_object_mut()
        .context("netlist module has no cells")?;
    for (name, c) in cells.iter() {
        let dirs = c["port_directions"].as_object();
        for (port, bits) in c["connections"].as_object().into_iter().flatten() {
            let out = dirs
                .and_then(|d| d.get(port))
                .is_some_and(|d| d == "output");
            for b in bits.as_array().into_iter().flatten() {
                let b = Bit::of(b)?;
                if matches!(b, Bit::Const(_)) {
                    continue;
                }
                if out {
                    drivers.insert(b, (name.clone(), port.clone()));
                } else {
                    loads
                        .entry(b)
                        .or_default()
                        .push((name.clone(), port.clone()));
                }
            }
        }
    }
    let mults: Vec<String> = {
        let mut v: Vec<String> = cells
            .iter()
            .filter(|(_, c)| c["type"] == "MULT18X18D")
            .map(|(n, _)| n.clone())
            .collect();
        v.sort();
        v
    };
    let mut st = PackStats::default();
    let mut removed = 0usize;
    for m in mults {
        let mc = &cells[&m];
        let untouched = [
            "REG_INPUTA_CLK",
            "REG_INPUTB_CLK",
            "REG_OUTPUT_CLK",
            "REG_PIPELINE_CLK",
        ]
        .iter()
        .all(|k| param(mc, k).unwrap_or("NONE") == "NONE");
        if !untouched {
            continue;
        }
        let mut clock: Option<Bit> = None;
        let mut same_clock = |c: &Bit| match &clock {
            None => {
                clock = Some(c.clone());
                true
            }
            Some(k) => k == c,
        };
        // Operand registers: per operand, (pin, flip-flop) and the enable.
        let mut operands: Vec<(Vec<PinFf>, Option<Enable>)> = Vec::new();
        let mut inputs_ok = true;
        let mut shared = false;
        let mut foreign_enable = false;
        for op in ["A", "B"] {
            let mut regs = Vec::new();
            let mut en: Option<Enable> = None;
            for k in 0..18 {
                let pin = format!("{op}{k}");
                let Some(b) = one(mc, &pin)? else { continue };
                if matches!(b, Bit::Const(_)) {
                    continue;
                }
                let ok = match drivers.get(&b) {
                    Some((ff, port)) if port == "Q" && ff != "$port" => match plain_ff(&cells[ff])?
                    {
                        Some((_, e)) if !enable_ok(&e) => {
                            foreign_enable = true;
                            false
                        }
                        Some((clk, e))
                            if same_clock(&clk) && en.as_ref().is_none_or(|x| *x == e) =>
                        {
                            // Every load of the flip-flop is an operand pin
                            // of this block: nothing else would keep it.
                            let only_here = loads.get(&b).is_none_or(|l| {
                                l.iter().all(|(c, p)| {
                                    c == &m && (p.starts_with('A') || p.starts_with('B'))
                                })
                            });
                            if !only_here {
                                shared = true;
                            }
                            en = Some(e);
                            regs.push((pin, ff.clone()));
                            only_here
                        }
                        _ => false,
                    },
                    _ => false,
                };
                if !ok {
                    inputs_ok = false;
                }
            }
            operands.push((regs, en));
        }
        // Output register: each used P bit feeds one plain flip-flop.
        let mut outs: Vec<(String, String)> = Vec::new();
        let mut out_en: Option<Enable> = None;
        let mut outputs_ok = true;
        for k in 0..36 {
            let pin = format!("P{k}");
            let Some(b) = one(mc, &pin)? else { continue };
            let l = loads.get(&b).map(Vec::as_slice).unwrap_or(&[]);
            match l {
                [] => {}
                [(ff, port)] if port == "DI" && ff != "$port" => match plain_ff(&cells[ff])? {
                    Some((_, e)) if !enable_ok(&e) => {
                        foreign_enable = true;
                        outputs_ok = false;
                    }
                    Some((clk, e))
                        if same_clock(&clk) && out_en.as_ref().is_none_or(|x| *x == e) =>
                    {
                        out_en = Some(e);
                        outs.push((pin, ff.clone()));
                    }
                    _ => outputs_ok = false,
                },
                _ => outputs_ok = false,
            }
        }
        let outputs_ok = outputs_ok && !outs.is_empty();
        let inputs_ok = inputs_ok && operands.iter().any(|(r, _)| !r.is_empty());
        st.kept_shared += usize::from(shared);
        st.kept_enable += usize::from(foreign_enable);
        if !inputs_ok && !outputs_ok {
            continue;
        }
        let clk = clock.clone().expect("a packed register has a clock");
        // Enables onto CE0..CE3.
        let mut ces: Vec<Enable> = Vec::new();
        let mut ce_pin = |e: &Enable| -> String {
            let k = ces.iter().position(|x| x == e).unwrap_or_else(|| {
                ces.push(e.clone());
                ces.len() - 1
            });
            format!("CE{k}")
        };
        // The output register's enable first, so it is CE0: nextpnr writes
        // no REG_OUTPUT_CE into the bitstream, so the block uses its
        // default, CE0, whatever the netlist says.
        let out_pin = outputs_ok.then(|| ce_pin(out_en.as_ref().expect("an output register")));
        let mut params: BTreeMap<String, String> = BTreeMap::new();
        let mut rewire: Vec<(String, Bit)> = Vec::new();
        if inputs_ok {
            let fallback = operands
                .iter()
                .find_map(|(_, e)| e.clone())
                .expect("an operand register");
            for ((regs, en), op) in operands.iter().zip(["A", "B"]) {
                let pin = ce_pin(en.as_ref().unwrap_or(&fallback));
                params.insert(format!("REG_INPUT{op}_CLK"), "CLK0".into());
                params.insert(format!("REG_INPUT{op}_CE"), pin);
                params.insert(format!("REG_INPUT{op}_RST"), "RST0".into());
                for (p, ff) in regs {
                    let d = one(&cells[ff], "DI")?.context("a flip-flop without D")?;
                    rewire.push((p.clone(), d));
                }
            }
            st.inputs += 1;
        }
        let mut dead_outs = Vec::new();
        if let Some(pin) = out_pin {
            params.insert("REG_OUTPUT_CLK".into(), "CLK0".into());
            params.insert("REG_OUTPUT_CE".into(), pin);
            params.insert("REG_OUTPUT_RST".into(), "RST0".into());
            for (p, ff) in &outs {
                let q = one(&cells[ff], "Q")?.context("a flip-flop without Q")?;
                rewire.push((p.clone(), q));
                dead_outs.push(ff.clone());
            }
            st.outputs += 1;
        }
        // Apply: loads and drivers follow the rewiring.
        for (p, new) in &rewire {
            let old = one(&cells[&m], p)?.expect("connected");
            if let Some(l) = loads.get_mut(&old) {
                l.retain(|(c, q)| !(c == &m && q == p));
            }
            if p.starts_with('P') {
                drivers.insert(new.clone(), (m.clone(), p.clone()));
            } else if matches!(new, Bit::Net(_)) {
                loads
                    .entry(new.clone())
                    .or_default()
                    .push((m.clone(), p.clone()));
            }
        }
        for ff in &dead_outs {
            for b in conn(&cells[ff], "DI")?
                .into_iter()
                .chain(conn(&cells[ff], "CE")?)
                .chain(conn(&cells[ff], "CLK")?)
            {
                if let Some(l) = loads.get_mut(&b) {
                    l.retain(|(c, _)| c != ff);
                }
            }
            cells.remove(ff);
            removed += 1;
        }
        let mc = cells.get_mut(&m).expect("the block");
        for (p, b) in &rewire {
            mc["connections"][p] = json!([b.value()]);
        }
        mc["connections"]["CLK0"] = json!([clk.value()]);
        mc["connections"]["RST0"] = json!(["0"]);
        for (k, e) in ces.iter().enumerate() {
            let v = match e {
                Enable::Always => json!("1"),
                Enable::Net(b) => b.value(),
            };
            mc["connections"][format!("CE{k}")] = json!([v]);
            if let Enable::Net(b @ Bit::Net(_)) = e {
                loads
                    .entry(b.clone())
                    .or_default()
                    .push((m.clone(), format!("CE{k}")));
            }
        }
        if let Some(Bit::Net(_)) = clock {
            loads
                .entry(clk.clone())
                .or_default()
                .push((m.clone(), "CLK0".into()));
        }
        let present: Vec<&str> = ["CLK0", "RST0", "CE0", "CE1", "CE2", "CE3"]
            .into_iter()
            .filter(|k| mc["connections"].get(k).is_some())
            .collect();
        let dirs = mc["port_directions"]
            .as_object_mut()
            .context("a cell without port directions")?;
        for k in present {
            dirs.entry(k.to_string()).or_insert(json!("input"));
        }
        let ps = mc["parameters"]
            .as_object_mut()
            .context("a cell without parameters")?;
        for (k, v) in params {
            ps.insert(k, json!(v));
        }
    }
    // Flip-flops left without a load (their only load was a block's
    // operand, now registered in the block).
    loop {
        let dead: Vec<String> = cells
            .iter()
            .filter(|(_, c)| c["type"] == "TRELLIS_FF")
            .filter_map(|(n, c)| {
                let q = one(c, "Q").ok().flatten()?;
                loads
                    .get(&q)
                    .is_none_or(|l| l.is_empty())
                    .then(|| n.clone())
            })
            .collect();
        if dead.is_empty() {
            break;
        }
        for ff in dead {
            let c = &cells[&ff];
            let ins: Vec<Bit> = ["DI", "CE", "CLK", "LSR"]
                .iter()
                .flat_map(|p| conn(c, p).unwrap_or_default())
                .collect();
            for b in ins {
                if let Some(l) = loads.get_mut(&b) {
                    l.retain(|(x, _)| x != &ff);
                }
            }
            cells.remove(&ff);
            removed += 1;
        }
    }
    st.ffs_removed = removed;
    Ok(st)
}

/// The cells of module `top` by type (after packing: the netlist that is
/// placed), the cells of the modules it instantiates counted in their
/// place (as the placer, which flattens the hierarchy, sees them): an
/// instance of a module the netlist defines with a body (not a black box
/// of the cell library) adds that module's cells, not itself.
pub fn cell_counts(netlist: &Value, top: &str) -> Vec<(String, u64)> {
    fn walk(netlist: &Value, module: &str, depth: u32, m: &mut BTreeMap<String, u64>) {
        for c in netlist["modules"][module]["cells"]
            .as_object()
            .into_iter()
            .flat_map(Map::values)
        {
            let Some(t) = c["type"].as_str() else {
                continue;
            };
            if depth < 16 && has_body(netlist, t) {
                walk(netlist, t, depth + 1, m);
            } else {
                *m.entry(t.to_string()).or_default() += 1;
            }
        }
    }
    let mut m: BTreeMap<String, u64> = BTreeMap::new();
    walk(netlist, top, 0, &mut m);
    m.into_iter().collect()
}

/// Whether `netlist` defines module `name` with cells of its own (a
/// design module, not a black box of the cell library).
pub fn has_body(netlist: &Value, name: &str) -> bool {
    let m = &netlist["modules"][name];
    m.is_object()
        && m["attributes"]["blackbox"].is_null()
        && m["cells"].as_object().is_some_and(|c| !c.is_empty())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ff(d: Value, q: u64, ce: Option<u64>) -> Value {
        let mut c = json!({
            "type": "TRELLIS_FF",
            "parameters": {"CLKMUX": "CLK", "GSR": "DISABLED", "LSRMUX": "LSR", "REGSET": "RESET",
                           "CEMUX": if ce.is_some() { "CE" } else { "1 " }},
            "port_directions": {"CLK": "input", "DI": "input", "LSR": "input", "Q": "output", "CE": "input"},
            "connections": {"CLK": [2], "DI": [d], "LSR": ["0"], "Q": [q]}
        });
        if let Some(e) = ce {
            c["connections"]["CE"] = json!([e]);
        }
        c
    }

    /// A two-bit product: operand flip-flops (a1 also feeds a port when
    /// `a1_extra_load`), a product flip-flop on P0 and P1, P2 unused; the
    /// enables 5 and 6 are stage loads (`load_s2`, `load_s3`).
    fn netlist(p1_extra_load: bool, a1_extra_load: bool) -> Value {
        let mut cells = Map::new();
        cells.insert("fa0".into(), ff(json!(10), 20, Some(5)));
        cells.insert("fa1".into(), ff(json!(11), 21, Some(5)));
        cells.insert("fb0".into(), ff(json!(12), 22, None));
        cells.insert("fp0".into(), ff(json!(30), 40, Some(6)));
        cells.insert("fp1".into(), ff(json!(31), 41, Some(6)));
        let mut conns = Map::new();
        conns.insert("A0".into(), json!([20]));
        conns.insert("A1".into(), json!([21]));
        conns.insert("A2".into(), json!(["0"]));
        conns.insert("B0".into(), json!([22]));
        conns.insert("P0".into(), json!([30]));
        conns.insert("P1".into(), json!([31]));
        conns.insert("P2".into(), json!([32]));
        let mut dirs = Map::new();
        for k in ["A0", "A1", "A2", "B0"] {
            dirs.insert(k.into(), json!("input"));
        }
        for k in ["P0", "P1", "P2"] {
            dirs.insert(k.into(), json!("output"));
        }
        cells.insert(
            "m".into(),
            json!({"type": "MULT18X18D", "parameters": {}, "port_directions": dirs, "connections": conns}),
        );
        let mut outs = vec![40, 41];
        if a1_extra_load {
            outs.push(21);
        }
        if p1_extra_load {
            outs.push(31);
        }
        json!({"modules": {"top": {
            "ports": {
                "clk": {"direction": "input", "bits": [2]},
                "i": {"direction": "input", "bits": [10, 11, 12, 5, 6]},
                "o": {"direction": "output", "bits": outs}
            },
            "netnames": {
                "dut.load_s2": {"bits": [5]},
                "dut.load_s3": {"bits": [6]},
                "i": {"bits": [10, 11, 12, 5, 6]}
            },
            "cells": cells
        }}})
    }

    #[test]
    fn packs_operand_and_product_registers() {
        let mut n = netlist(false, false);
        let st = pack_mult18(&mut n, "top").unwrap();
        assert_eq!(
            st,
            PackStats {
                inputs: 1,
                outputs: 1,
                ffs_removed: 5,
                kept_shared: 0,
                kept_enable: 0,
            }
        );
        let cells = &n["modules"]["top"]["cells"];
        let m = &cells["m"];
        // Operands from the flip-flops' D nets; the constant bit stays.
        assert_eq!(m["connections"]["A0"], json!([10]));
        assert_eq!(m["connections"]["A1"], json!([11]));
        assert_eq!(m["connections"]["A2"], json!(["0"]));
        assert_eq!(m["connections"]["B0"], json!([12]));
        // The product drives the removed flip-flops' Q nets.
        assert_eq!(m["connections"]["P0"], json!([40]));
        assert_eq!(m["connections"]["P1"], json!([41]));
        assert_eq!(m["connections"]["CLK0"], json!([2]));
        // The output's enable (on CE0, the only one the bitstream honours
        // for it), A's, B's (always on): three pins.
        assert_eq!(m["parameters"]["REG_OUTPUT_CE"], "CE0");
        assert_eq!(m["connections"]["CE0"], json!([6]));
        assert_eq!(m["parameters"]["REG_INPUTA_CE"], "CE1");
        assert_eq!(m["connections"]["CE1"], json!([5]));
        assert_eq!(m["parameters"]["REG_INPUTB_CE"], "CE2");
        assert_eq!(m["connections"]["CE2"], json!(["1"]));
        assert_eq!(m["port_directions"]["CE2"], "input");
        // Every moved flip-flop is gone.
        let left: Vec<&String> = cells.as_object().unwrap().keys().collect();
        assert_eq!(left, vec!["m"]);
    }

    /// An operand register that also feeds a port is never copied into
    /// the block: both operands stay in the fabric, the product register
    /// still moves.
    #[test]
    fn an_operand_register_with_another_load_is_not_copied() {
        let mut n = netlist(false, true);
        let st = pack_mult18(&mut n, "top").unwrap();
        assert_eq!((st.inputs, st.outputs, st.kept_shared), (0, 1, 1));
        let cells = &n["modules"]["top"]["cells"];
        let m = &cells["m"];
        assert_eq!(m["parameters"].get("REG_INPUTA_CLK"), None);
        assert_eq!(m["connections"]["A1"], json!([21]));
        let left: Vec<&String> = cells.as_object().unwrap().keys().collect();
        assert_eq!(left, vec!["fa0", "fa1", "fb0", "m"]);
    }

    /// A register whose enable is not a stage's load (here the product
    /// register's, once the net loses its `load_s3` name) stays out.
    #[test]
    fn a_register_whose_enable_is_not_a_stage_load_is_not_packed() {
        let mut n = netlist(false, false);
        let names = n["modules"]["top"]["netnames"].as_object_mut().unwrap();
        names.remove("dut.load_s3");
        names.insert("dut.bank_load".into(), json!({"bits": [6]}));
        let st = pack_mult18(&mut n, "top").unwrap();
        assert_eq!((st.inputs, st.outputs, st.kept_enable), (1, 0, 1));
        let cells = &n["modules"]["top"]["cells"];
        assert_eq!(cells["m"]["parameters"].get("REG_OUTPUT_CLK"), None);
        assert!(cells.get("fp0").is_some() && cells.get("fp1").is_some());
    }

    #[test]
    fn a_product_bit_with_two_loads_keeps_the_output_register_out() {
        let mut n = netlist(true, false);
        let st = pack_mult18(&mut n, "top").unwrap();
        assert_eq!(st.outputs, 0);
        assert_eq!(st.inputs, 1);
        let m = &n["modules"]["top"]["cells"]["m"];
        assert_eq!(m["parameters"].get("REG_OUTPUT_CLK"), None);
        assert_eq!(m["connections"]["P1"], json!([31]));
    }

    #[test]
    fn a_flip_flop_with_a_reset_is_not_packed() {
        let mut n = netlist(false, false);
        n["modules"]["top"]["cells"]["fa0"]["connections"]["LSR"] = json!([7]);
        let st = pack_mult18(&mut n, "top").unwrap();
        assert_eq!(st.inputs, 0, "A0 comes from a flip-flop with a reset");
        assert_eq!(st.outputs, 1);
    }

    /// An instance of a design module counts as that module's cells; a
    /// black box of the cell library as one cell of its type.
    #[test]
    fn cell_counts_look_through_the_units_module() {
        let n = json!({"modules": {
            "top": {"cells": {
                "r": {"type": "TRELLIS_FF"},
                "dut": {"type": "unit"}
            }},
            "unit": {"attributes": {"keep_hierarchy": "1"}, "cells": {
                "a": {"type": "TRELLIS_FF"},
                "b": {"type": "TRELLIS_FF"},
                "m": {"type": "MULT18X18D"}
            }},
            "MULT18X18D": {"attributes": {"blackbox": "1"}, "cells": {}}
        }});
        assert_eq!(
            cell_counts(&n, "top"),
            [("MULT18X18D".to_string(), 1), ("TRELLIS_FF".into(), 3)]
        );
        assert_eq!(cell_counts(&n, "unit").len(), 2);
        assert!(has_body(&n, "unit") && !has_body(&n, "MULT18X18D") && !has_body(&n, "x"));
    }
}
