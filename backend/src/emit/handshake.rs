//! The handshake: one global stall `en` with a two-entry output buffer,
//! or a pipeline that never stalls ending in an output FIFO (registers,
//! LUT RAM or block RAM, as the family keeps it); the output record and
//! the registered outputs.

use crate::*;

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
pub(crate) fn stall_handshake(l: u32, lock: bool, replicas: &[u32]) -> String {
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
pub(crate) fn stall_outputs(outs: &[Port], vals: &[String], flags: &[String]) -> String {
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
pub(crate) fn out_record(
    outs: &[Port],
    vals: &[String],
    flags: &[String],
) -> (u32, Vec<String>, String) {
    let mut parts: Vec<String> = vals.to_vec();
    parts.extend(flags.iter().map(|f| format!("({f})")));
    let mut widths: Vec<(String, u32, bool)> = outs
        .iter()
        .map(|p| (format!("{}_o", p.name), p.format.width(), p.format.signed()))
        .collect();
    if !flags.is_empty() {
        widths.push(("ovf_o".into(), count(flags.len()), false));
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
pub(crate) fn fifo_handshake(l: u32, depth: u32, lock: bool, block: bool) -> String {
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
pub(crate) fn fifo_outputs(
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

#[cfg(test)]
mod tests {
    use crate::emit::{chain, test_design};
    use crate::timing::Handshake;

    /// The signal `name` is, through `wire x = y;` aliases and
    /// `$signed(…)`/bit selects, a register of the module's text (a `reg`
    /// declaration lists one or more names: `reg  out_valid_q, en_q;`).
    fn is_register(v: &str, name: &str) -> bool {
        let mut n = name.to_string();
        for _ in 0..8 {
            for l in v.lines().map(str::trim) {
                if let Some(rest) = l.strip_prefix("reg ") {
                    let names = rest.rsplit(']').next().unwrap_or(rest);
                    if names
                        .trim_end_matches(';')
                        .split(',')
                        .any(|x| x.trim() == n)
                    {
                        return true;
                    }
                }
            }
            let alias = v.lines().map(str::trim).find_map(|l| {
                let rest = l.strip_prefix("wire ")?;
                let (lhs, rhs) = rest.split_once(" = ")?;
                (lhs.rsplit([' ', ']']).next() == Some(n.as_str())).then(|| base(rhs))
            });
            match alias {
                Some(a) => n = a,
                None => return false,
            }
        }
        false
    }

    /// `$signed(out_q[51:36]);` → `out_q`.
    fn base(rhs: &str) -> String {
        let r = rhs.trim_end_matches(';').trim();
        let r = r.strip_prefix("$signed(").unwrap_or(r);
        r.split(['[', ')', ' ']).next().unwrap_or(r).to_string()
    }

    /// With either handshake and any depth, every output port is driven by
    /// a register (no path from an input port to an output port), the
    /// valid bits are one per stage, and the latency is one more than the
    /// stages (stall, or a FIFO in flip-flops or LUT RAM).
    #[test]
    fn every_output_port_is_a_register_for_either_handshake() {
        for hs in [Handshake::Stall, Handshake::Fifo] {
            for depth in 1..=4usize {
                let mut d = test_design(chain("h", depth));
                d.handshake = hs;
                let e = crate::emit(&d).expect("emits");
                let v = &e.verilog;
                let assigns: Vec<(&str, &str)> = v
                    .lines()
                    .filter_map(|l| l.trim().strip_prefix("assign "))
                    .filter_map(|l| l.split_once(" = "))
                    .filter(|(lhs, _)| lhs.ends_with("_o"))
                    .collect();
                for port in ["valid_o", "ready_o", "z_o"] {
                    let (_, rhs) = assigns
                        .iter()
                        .find(|(lhs, _)| *lhs == port)
                        .unwrap_or_else(|| panic!("{hs:?} {depth}: no assign of {port}\n{v}"));
                    assert!(
                        is_register(v, &base(rhs)),
                        "{hs:?} depth {depth}: {port} = {rhs} is not a register\n{v}"
                    );
                }
                let valid = format!("reg  [{}:0] valid_q;", depth - 1);
                assert!(v.contains(&valid), "{hs:?} {depth}: no {valid}");
                assert_eq!(e.latency as usize, depth + 1, "{hs:?} {depth}");
            }
        }
    }
}
