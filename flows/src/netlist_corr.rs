//! Register correspondence between an RTL module and its gate-level
//! netlist, for [`crate::netlist_equiv`]: the candidate equalities of the
//! inductive invariant and the queries that prove it.
//!
//! Yosys keeps the RTL's names on the nets it does not optimize away: a
//! register `normalize_d_15_s3_q` of the RTL is, in the ECP5 netlist, 18
//! `TRELLIS_FF` cells driving a net of the same name, and many combinational
//! nets keep theirs too. So the miter holds a wire `gold.X` and a wire
//! `gate.X` for most names `X`; each pair of equal width is a *candidate*
//! `gold.X = gate.X`. The register packing ([`crate::dsp_pack`]) removes
//! the fabric flip-flops it moves into a `MULT18X18D` (the block's `a_q`,
//! `b_q`, `sa_q`, `sb_q` registers in its cell model, which load the nets
//! on the `A`/`B` pins and the `SIGNEDA`/`SIGNEDB` pins) and keeps the
//! names of those it turns into the block's output register (the block
//! drives them): a packed operand register bit is a candidate equal to the
//! RTL register that loads the same net (`Y <= X;` in the RTL, `X` the
//! pin's net), or to the pin's constant.
//!
//! The invariant `I` is the conjunction of the candidates that survive:
//! [`step_query`] asks for a state `s1` in which every live candidate
//! holds, and a transition to `s2` in which one fails or the outputs
//! differ; a model names the candidates that fail in `s2`, which are
//! dropped, and the query is asked again (the greatest fixed point of
//! signal correspondence, van Eijk 2000). `unsat` says `I` is inductive and
//! the outputs agree in every state of `I`, for every input. Dropping a
//! candidate only weakens the claim; a wrong candidate (a hint that does
//! not hold) cannot make a proof, only fail one.

use std::collections::HashMap;
use std::fmt::Write as _;

/// One candidate equality, both sides as terms over a state named `{s}`
/// (the placeholder [`STATE`]), each a bit vector of the same width.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Candidate {
    /// What it says, for messages: `X` or `inst.a_q[3] = Y[3]`.
    pub name: String,
    /// The RTL side.
    pub gold: String,
    /// The netlist side.
    pub gate: String,
}

/// The state placeholder in candidate terms.
pub const STATE: &str = "{s}";

/// A named wire of the miter as a bit vector term over [`STATE`] (Yosys
/// writes a 1-bit wire as a `Bool`).
fn wire(name: &str, width: u32) -> String {
    let f = format!("(|fxs_miter_n {name}| {STATE})");
    if width == 1 {
        format!("(ite {f} #b1 #b0)")
    } else {
        f
    }
}

/// Bit `i` of a wire term of width `width`.
fn bit(term: &str, width: u32, i: u32) -> String {
    if width == 1 {
        term.to_string()
    } else {
        format!("((_ extract {i} {i}) {term})")
    }
}

/// The names and widths Yosys's comments `; yosys-smt2-<kind> NAME W`
/// give (`kind`: `wire`, `input`, …).
fn named<'a>(smt2: &'a str, kind: &str) -> Vec<(&'a str, u32)> {
    let tag = format!("; yosys-smt2-{kind} ");
    smt2.lines()
        .filter_map(|l| {
            let mut it = l.strip_prefix(tag.as_str())?.split_whitespace();
            Some((it.next()?, it.next()?.parse().ok()?))
        })
        .collect()
}

/// The miter's named wires (without the `gold.`/`gate.` prefix) and their
/// widths, per side, from Yosys's `; yosys-smt2-wire` comments.
fn wires(smt2: &str) -> (HashMap<String, u32>, HashMap<String, u32>) {
    let mut gold = HashMap::new();
    let mut gate = HashMap::new();
    for (n, w) in named(smt2, "wire") {
        if let Some(x) = n.strip_prefix("gold.") {
            gold.insert(x.to_string(), w);
        } else if let Some(x) = n.strip_prefix("gate.") {
            gate.insert(x.to_string(), w);
        }
    }
    (gold, gate)
}

/// A net reference as the netlist writes it on a pin: `x`, `x[3]` or a
/// constant `1'h0` / `1'b1`.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Pin {
    Net(String, Option<u32>),
    Const(bool),
}

fn pin(text: &str) -> Option<Pin> {
    let t = text.trim();
    if let Some((_, v)) = t.split_once('\'') {
        let v = v.get(1..)?;
        return match v {
            "0" => Some(Pin::Const(false)),
            "1" => Some(Pin::Const(true)),
            _ => None,
        };
    }
    let t = t.trim_start_matches('\\');
    match t.split_once('[') {
        Some((n, i)) => Some(Pin::Net(
            n.trim().to_string(),
            Some(i.trim_end_matches(']').trim().parse().ok()?),
        )),
        None => Some(Pin::Net(t.to_string(), None)),
    }
}

/// Each `MULT18X18D` instance of `netlist` (Verilog as `write_verilog`
/// writes it): its name, whether its operands are registered in the block
/// (`REG_INPUTA_CLK`, `REG_INPUTB_CLK`), and its pin connections.
fn mult_blocks(netlist: &str) -> Vec<(String, bool, bool, HashMap<String, String>)> {
    let mut out = Vec::new();
    let mut rest = netlist;
    while let Some(k) = rest.find("MULT18X18D #(") {
        let after = &rest[k + "MULT18X18D #(".len()..];
        // Parameters up to `) name (`, connections up to `);`.
        let Some(pend) = after.find(") ") else { break };
        let params = &after[..pend];
        let tail = &after[pend + 2..];
        let Some(open) = tail.find(" (") else { break };
        let name = tail[..open].trim().trim_start_matches('\\').to_string();
        let body_start = &tail[open + 2..];
        let Some(end) = body_start.find(");") else {
            break;
        };
        let body = &body_start[..end];
        // One connection a line: `.PORT(value),`.
        let mut conns = HashMap::new();
        for l in body.lines() {
            let t = l.trim().trim_end_matches(',');
            let Some(t) = t.strip_prefix('.') else {
                continue;
            };
            if let Some((p, v)) = t.split_once('(') {
                let v = v.strip_suffix(')').unwrap_or(v);
                conns.insert(p.trim().to_string(), v.trim().to_string());
            }
        }
        let reg = |k: &str| {
            params
                .split(&format!(".{k}(\""))
                .nth(1)
                .is_some_and(|v| !v.starts_with("NONE"))
        };
        out.push((name, reg("REG_INPUTA_CLK"), reg("REG_INPUTB_CLK"), conns));
        rest = &body_start[end..];
    }
    out
}

/// `Y <= X;` in the RTL: for each net `X`, the registers `Y` that load it.
fn loads(rtl: &str) -> HashMap<String, Vec<String>> {
    let mut m: HashMap<String, Vec<String>> = HashMap::new();
    for l in rtl.lines() {
        let l = l.trim();
        let Some((y, x)) = l.split_once(" <= ") else {
            continue;
        };
        let x = x.trim_end_matches(';').trim();
        let ok =
            |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if ok(y) && ok(x) {
            m.entry(x.to_string()).or_default().push(y.to_string());
        }
    }
    m
}

/// The candidates for the miter model `smt2` of the RTL `rtl` and the
/// netlist `netlist` (its top module's text).
pub fn candidates(smt2: &str, rtl: &str, netlist: &str) -> Vec<Candidate> {
    let (gold, gate) = wires(smt2);
    let mut out = Vec::new();
    let mut names: Vec<&String> = gold.keys().collect();
    names.sort();
    for x in names {
        let w = gold[x];
        if x == "clk_i" || gate.get(x) != Some(&w) {
            continue;
        }
        // Bit by bit: a net Yosys kept whole but for a few bits (a
        // constant one, an undriven one) keeps the rest.
        let (g, h) = (wire(&format!("gold.{x}"), w), wire(&format!("gate.{x}"), w));
        for i in 0..w {
            out.push(Candidate {
                name: if w == 1 {
                    x.clone()
                } else {
                    format!("{x}[{i}]")
                },
                gold: bit(&g, w, i),
                gate: bit(&h, w, i),
            });
        }
    }
    // Operand registers moved into a block.
    let by_net = loads(rtl);
    for (inst, reg_a, reg_b, conns) in mult_blocks(netlist) {
        for (on, port, reg, sign) in [
            (reg_a, "A", "a_q", "SIGNEDA"),
            (reg_b, "B", "b_q", "SIGNEDB"),
        ] {
            if !on {
                continue;
            }
            let r = format!("gate.{inst}.{reg}");
            let rw = 18;
            let rt = wire(&r, rw);
            for i in 0..18u32 {
                let Some(p) = conns.get(&format!("{port}{i}")).and_then(|t| pin(t)) else {
                    continue;
                };
                let g = bit(&rt, rw, i);
                match p {
                    Pin::Const(v) => out.push(Candidate {
                        name: format!("{inst}.{reg}[{i}] = {}", u8::from(v)),
                        gold: format!("#b{}", u8::from(v)),
                        gate: g,
                    }),
                    Pin::Net(x, j) => {
                        // The emitter gives a product its own operand
                        // registers (`t<n>_a_q`, `t<n>_b_q`), kept apart
                        // from equal copies: those first.
                        let all: Vec<&String> = by_net.get(&x).into_iter().flatten().collect();
                        let own: Vec<&String> = all
                            .iter()
                            .copied()
                            .filter(|y| y.ends_with("_a_q") || y.ends_with("_b_q"))
                            .collect();
                        for y in if own.is_empty() { all } else { own } {
                            let Some(&yw) = gold.get(y) else { continue };
                            let j = j.unwrap_or(0);
                            if j >= yw {
                                continue;
                            }
                            out.push(Candidate {
                                name: format!("{inst}.{reg}[{i}] = {y}[{j}]"),
                                gold: bit(&wire(&format!("gold.{y}"), yw), yw, j),
                                gate: g.clone(),
                            });
                        }
                    }
                }
            }
            let s = format!("gate.{inst}.s{reg}");
            if let Some(Pin::Const(v)) = conns.get(sign).and_then(|t| pin(t)) {
                out.push(Candidate {
                    name: format!("{inst}.s{reg} = {}", u8::from(v)),
                    gold: format!("#b{}", u8::from(v)),
                    gate: wire(&s, 1),
                });
            }
        }
    }
    out
}

/// A candidate's equality in state `s`.
fn holds(c: &Candidate, s: &str) -> String {
    format!(
        "(= {} {})",
        c.gold.replace(STATE, s),
        c.gate.replace(STATE, s)
    )
}

/// The miter model `smt2`, a state `s1`, its successor `s2`, and every
/// candidate in `live` holding in `s1`: what both queries below assume.
fn assumed(smt2: &str, live: &[&Candidate]) -> String {
    let mut q = String::from("(set-logic QF_BV)\n");
    q += smt2;
    q += "\n(declare-const s1 |fxs_miter_s|)\n(declare-const s2 |fxs_miter_s|)\n\
          (assert (|fxs_miter_t| s1 s2))\n";
    for c in live {
        let _ = writeln!(q, "(assert {})", holds(c, "s1"));
    }
    q
}

/// The inductive step over the miter model `smt2` with the candidates
/// `live`: a state `s1` where all hold, its successor `s2` where one fails
/// or the outputs differ (`differs(state)`: the outputs' difference in a
/// state). Each candidate's equality in `s2` is the nullary function
/// `fxs_k<n>` (`n` its index in `live`), read back by `get-value`.
pub fn step_query(smt2: &str, live: &[&Candidate], differs: &dyn Fn(&str) -> String) -> String {
    let mut q = assumed(smt2, live);
    let mut ks = Vec::new();
    for (n, c) in live.iter().enumerate() {
        let _ = writeln!(q, "(define-fun fxs_k{n} () Bool {})", holds(c, "s2"));
        ks.push(format!("fxs_k{n}"));
    }
    let fail: Vec<String> = ks.iter().map(|k| format!("(not {k})")).collect();
    let _ = writeln!(
        q,
        "(assert (or {} {} {}))\n(check-sat)\n(get-value ({}))",
        fail.join(" "),
        differs("s1"),
        differs("s2"),
        if ks.is_empty() {
            "true".to_string()
        } else {
            ks.join(" ")
        }
    );
    q
}

/// A run of the miter from reset with fixed pseudo-random inputs (seed
/// `seed`; `valid_i` high), `cycles` long: a simulation by the solver.
/// Each candidate's equality in the last three cycles is read back
/// (`fxs_k<n>_<cycle>`): one that fails in a run from reset is no
/// invariant, and dropping it here saves a step query each.
pub fn sim_query(smt2: &str, cands: &[Candidate], cycles: u32, seed: u64) -> String {
    let mut x = seed | 1;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    let mut q = String::from("(set-logic QF_BV)\n");
    q += smt2;
    q.push('\n');
    for k in 0..=cycles {
        let _ = writeln!(q, "(declare-const s{k} |fxs_miter_s|)");
    }
    for k in 0..cycles {
        let _ = writeln!(q, "(assert (|fxs_miter_t| s{k} s{}))", k + 1);
    }
    for (n, w) in named(smt2, "input") {
        if n == "in_clk_i" || w == 0 || w > 64 {
            continue;
        }
        for k in 0..=cycles {
            let at = format!("(|fxs_miter_n {n}| s{k})");
            let v = match n {
                "in_rst_ni" => u64::from(k > 0),
                "in_valid_i" => 1,
                _ => next() & (u64::MAX >> (64 - w)),
            };
            if w == 1 {
                let _ = writeln!(q, "(assert (= {at} {}))", v == 1);
            } else {
                let _ = writeln!(q, "(assert (= {at} (_ bv{v} {w})))");
            }
        }
    }
    q += "(check-sat)\n(get-value (";
    for k in cycles.saturating_sub(2)..=cycles {
        for c in cands {
            q += &holds(c, &format!("s{k}"));
            q.push(' ');
        }
    }
    q += "))\n";
    q
}

/// Is there a state where every candidate in `live` holds (the invariant
/// is not empty)? The query: `sat` expected.
pub fn sanity_query(smt2: &str, live: &[&Candidate]) -> String {
    let mut q = assumed(smt2, live);
    q += "(check-sat)\n";
    q
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pins_parse() {
        assert_eq!(pin("n_z_i[15]"), Some(Pin::Net("n_z_i".into(), Some(15))));
        assert_eq!(pin("en_s3_q"), Some(Pin::Net("en_s3_q".into(), None)));
        assert_eq!(pin("1'h0"), Some(Pin::Const(false)));
        assert_eq!(pin("1'b1"), Some(Pin::Const(true)));
    }

    #[test]
    fn registers_loading_a_net_are_found_in_the_rtl() {
        let m = loads("      t16_b_q <= normalize_d_15_d;\n  x <= a + b;\n");
        assert_eq!(m["normalize_d_15_d"], vec!["t16_b_q".to_string()]);
        assert_eq!(m.len(), 1);
    }
}
