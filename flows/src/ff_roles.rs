//! Flip-flops by role, from a synthesized netlist (Yosys JSON): what each
//! fabric flip-flop holds, by the name the emitted RTL gives its register
//! (`dut.<name>` in the harness). The roles follow the emitter's naming
//! (`backend/src/lib.rs`), most specific first:
//!
//! | role | registers |
//! |---|---|
//! | harness | the synthesis harness's own (no `dut.` name, or the module's input port `<name>_i` it drives) |
//! | handshake | `valid_q`, `en_q`, `ready_q`, `out_valid_q`, the FIFO's pointers and count, a set-up port's `_ready_q`, `_cur_q`, `_tag_q` |
//! | output buffer | `out_q`, `skid_q`, the FIFO's entries `fifo_q` |
//! | set-up | a set-up port's registers and banks (`<field>_q`, `_b0_q`, `_b1_q`) |
//! | set-up reads | a bank read or a per-triangle selection registered in a stage (`_bank_s<k>_q`, `_c_s<k>_q`, `_sel_s<k>_q`) |
//! | overflow flags | `*_ovf*`, the running flags `ovf<k>_s<k>_q` |
//! | DSP operands | a product's own operand registers (`_a_q`, `_b_q`, `_a<i>_<j>_q`, `_b<i>_<j>_q`) left in the fabric |
//! | partial products | a split product's partial products and its adder tree's registers (`_pp<i>_<j>_q`, `_l<k>_<n>_q`) |
//! | rounded values | a value rounded and registered before its range check (`_r_q`) |
//! | carried | a value carried to a later stage (`<name>_s<k>_q`) |
//! | stage results | a quantization's or table read's result in the stage after it |

use serde_json::Value;
use std::collections::BTreeMap;

/// The role of the register named `name` (the RTL's name, no hierarchy),
/// given the set-up ports' field names.
pub fn role(name: &str, setup_fields: &[String]) -> &'static str {
    let base = name.split('[').next().unwrap_or(name);
    // The module's input ports: the harness's input registers drive them.
    if base.ends_with("_i") {
        return "harness";
    }
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    // Every flip-flop of the module is named `…_q` (lowRISC); the stage
    // suffix comes before it (`x_s3_q`, `ovf0_s4_q`, `n1_x_bank_s3_q`).
    let core = base.strip_suffix("_q").unwrap_or(base);
    let ends_stage = |suffix: &str| core.rsplit_once(suffix).is_some_and(|(_, k)| digits(k));
    let handshake = [
        "valid_q",
        "en_q",
        "ready_q",
        "out_valid_q",
        "wr_q",
        "rd_q",
        "cnt_q",
    ];
    if handshake.contains(&base)
        || base.ends_with("_ready_q")
        || base.ends_with("_cur_q")
        || base.ends_with("_tag_q")
    {
        return "handshake";
    }
    if ["out_q", "skid_q", "fifo_q"].contains(&base) {
        return "output buffer";
    }
    let field = base
        .strip_suffix("_b0_q")
        .or_else(|| base.strip_suffix("_b1_q"))
        .or_else(|| base.strip_suffix("_q"));
    if field.is_some_and(|f| setup_fields.iter().any(|s| s == f)) {
        return "set-up";
    }
    if ends_stage("_bank_s") || ends_stage("_c_s") || ends_stage("_sel_s") {
        return "set-up reads";
    }
    if base.contains("_ovf") || (base.starts_with("ovf") && ends_stage("_s")) {
        return "overflow flags";
    }
    let own = |tag: char| {
        base.strip_suffix("_q")
            .and_then(|b| b.rsplit_once(&format!("_{tag}")))
            .is_some_and(|(_, rest)| {
                rest.is_empty()
                    || rest
                        .split_once('_')
                        .is_some_and(|(i, j)| digits(i) && digits(j))
            })
    };
    if own('a') || own('b') {
        return "DSP operands";
    }
    let tree = base.strip_suffix("_q").is_some_and(|b| {
        b.rsplit_once("_pp").is_some_and(|(_, r)| {
            r.split_once('_')
                .is_some_and(|(i, j)| digits(i) && digits(j))
        }) || b.rsplit_once("_l").is_some_and(|(_, r)| {
            r.split_once('_')
                .is_some_and(|(i, j)| digits(i) && digits(j))
        })
    });
    if tree {
        return "partial products";
    }
    if base.ends_with("_r_q") {
        return "rounded values";
    }
    if ends_stage("_s") {
        return "carried";
    }
    "stage results"
}

/// The flip-flops of module `top` of `netlist` by role ([`role`]), in the
/// order of the table above. In a flattened harness the unit's registers
/// are those with a `dut.` name and the others the harness's; where the
/// unit is a module of its own (the harness instantiates a module the
/// netlist defines), every flip-flop of the harness module is the
/// harness's and the unit module's are named by its own nets. A cell is a
/// flip-flop when its type starts with one of `ff_types` (the family's
/// flip-flop classes).
pub fn roles(
    netlist: &Value,
    top: &str,
    setup_fields: &[String],
    ff_types: &[&str],
) -> Vec<(String, u64)> {
    let mut count: BTreeMap<&'static str, u64> = BTreeMap::new();
    let m = &netlist["modules"][top];
    tally(
        m,
        Some("dut."),
        "harness",
        setup_fields,
        ff_types,
        &mut count,
    );
    for c in m["cells"].as_object().into_iter().flatten().map(|(_, c)| c) {
        let t = c["type"].as_str().unwrap_or("");
        if crate::dsp_pack::has_body(netlist, t) {
            tally(
                &netlist["modules"][t],
                None,
                "unnamed",
                setup_fields,
                ff_types,
                &mut count,
            );
        }
    }
    const ORDER: [&str; 12] = [
        "carried",
        "stage results",
        "partial products",
        "rounded values",
        "overflow flags",
        "DSP operands",
        "set-up",
        "set-up reads",
        "handshake",
        "output buffer",
        "harness",
        "unnamed",
    ];
    ORDER
        .iter()
        .filter_map(|r| count.get(r).map(|n| (r.to_string(), *n)))
        .collect()
}

/// Count the flip-flops of module `m` by role into `count`: a flip-flop
/// is named by the first net name on its output (with `prefix`: only
/// names under it, the prefix removed); unnamed ones take role
/// `unnamed_role` (the harness's in a flattened harness, where the unit's
/// names all carry the prefix).
fn tally(
    m: &Value,
    prefix: Option<&str>,
    unnamed_role: &'static str,
    setup_fields: &[String],
    ff_types: &[&str],
    count: &mut BTreeMap<&'static str, u64>,
) {
    let mut names: BTreeMap<u64, String> = BTreeMap::new();
    for (name, n) in m["netnames"].as_object().into_iter().flatten() {
        let rtl = match prefix {
            Some(p) => match name.strip_prefix(p) {
                Some(r) => r,
                None => continue,
            },
            None => name.as_str(),
        };
        if rtl.contains('$') {
            continue;
        }
        for (k, b) in n["bits"].as_array().into_iter().flatten().enumerate() {
            if let Some(b) = b.as_u64() {
                names.entry(b).or_insert_with(|| format!("{rtl}[{k}]"));
            }
        }
    }
    for c in m["cells"].as_object().into_iter().flatten().map(|(_, c)| c) {
        let t = c["type"].as_str().unwrap_or("");
        let ff = ff_types.iter().any(|p| t.starts_with(p));
        if !ff {
            continue;
        }
        let q = c["connections"]["Q"][0].as_u64();
        let r = match q.and_then(|q| names.get(&q)) {
            Some(n) => role(n, setup_fields),
            None => unnamed_role,
        };
        *count.entry(r).or_default() += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::role;

    #[test]
    fn names_map_to_roles() {
        let setup = vec!["n1_x".to_string(), "l_x".to_string()];
        for (name, r) in [
            ("valid_q[3]", "handshake"),
            ("tri_tag_q[0]", "handshake"),
            ("out_q[7]", "output buffer"),
            ("n1_x_b0_q[2]", "set-up"),
            ("l_x_q[0]", "set-up"),
            ("n1_x_bank_s6_q[1]", "set-up reads"),
            ("normalize_d_137_ovf_s31_q", "overflow flags"),
            ("ovf3_s12_q", "overflow flags"),
            ("t91_a_q[4]", "DSP operands"),
            ("t100_b0_1_q[2]", "DSP operands"),
            ("t100_pp0_1_q[5]", "partial products"),
            ("t100_l0_0_q[5]", "partial products"),
            ("lighting_dot_158_r_q[3]", "rounded values"),
            ("c1_i_s2_q[0]", "carried"),
            ("normalize_g_143_q[4]", "stage results"),
            ("c1_i[3]", "harness"),
        ] {
            assert_eq!(role(name, &setup), r, "{name}");
        }
    }
}
