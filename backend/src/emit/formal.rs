//! The `ifdef FORMAL` block: the handshake's properties (no item lost,
//! duplicated or reordered; outputs hold while stalled), which `fxshade
//! formal` proves with yosys-smtbmc after cutting the datapath.

use crate::*;

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
pub(crate) fn formal_block(
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
pub(crate) fn formal_prelude(l: u32, idle: &str) -> String {
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
pub(crate) fn formal_clocked(
    l: u32,
    shift: &str,
    outs: &[Port],
    nf: usize,
    setup: &[String],
) -> String {
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
pub(crate) fn formal_block_fifo(
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

#[cfg(test)]
mod tests {
    use crate::emit::{chain, test_design};
    use crate::timing::Handshake;

    /// The formal pass writes one `ifdef FORMAL` block holding every
    /// `assert`, `assume` and `cover` of the module (simulators and
    /// synthesis never see them); under either handshake the outputs are
    /// asserted to hold while stalled, every output port by name; and the
    /// drain property counts idle cycles up to the number of stages, so it
    /// speaks of every valid bit.
    #[test]
    fn properties_cover_every_output_and_every_stage_inside_ifdef_formal() {
        for hs in [Handshake::Stall, Handshake::Fifo] {
            for depth in 1..=4usize {
                let mut d = test_design(chain("f", depth));
                d.handshake = hs;
                let v = crate::emit(&d).expect("emits").verilog;
                let start = v.find("`ifdef FORMAL").expect("a formal block");
                let end = start + v[start..].find("`endif").expect("its end");
                assert_eq!(v.matches("`ifdef FORMAL").count(), 1, "{hs:?} {depth}");
                for kw in ["assert (", "assume (", "cover ("] {
                    let outside = v[..start].matches(kw).count() + v[end..].matches(kw).count();
                    assert_eq!(outside, 0, "{hs:?} {depth}: {kw} outside the block");
                }
                let block = &v[start..end];
                assert!(
                    block.contains("assert ($stable(z_o));"),
                    "{hs:?} {depth}\n{block}"
                );
                assert!(
                    block.contains("assert (valid_o);"),
                    "{hs:?} {depth}\n{block}"
                );
                let saturates = format!("'d{depth})");
                assert!(
                    block
                        .lines()
                        .any(|l| l.contains("f_idle ==") && l.contains(&saturates)),
                    "{hs:?} {depth}: the drain counter does not reach {depth}\n{block}"
                );
            }
        }
    }
}
