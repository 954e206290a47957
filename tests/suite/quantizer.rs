//! The emitted quantizer (`rtl::bits::quantize`) against a closed form, for
//! every input code: rounding by f64 (`floor`, `floor(q + ½)`,
//! `round_ties_even`, exact for these small codes), the range test and
//! wrap or clamp by integer arithmetic. Every rounding and overflow mode,
//! signed and unsigned inputs and outputs, bits dropped (fewer, as many as
//! and more than the input has) and bits added, outputs narrower and wider
//! than the rounded value; simulated on Icarus (every case) and Verilator
//! (a quarter of them: its builds are slow).

use crate::common::text;
use fxshade_model::quantize::{Overflow, Rounding};
use fxshade_model::rtl::bits::{quantize, Val};
use std::fmt::Write as _;
use std::process::Command;

/// Fraction bits of every input.
const FX: i32 = 4;

struct Case {
    xw: u32,
    xs: bool,
    s: i32,
    ow: u32,
    os: bool,
    round: Rounding,
    overflow: Overflow,
}

fn cases() -> Vec<Case> {
    let mut v = Vec::new();
    for xw in [6u32, 8] {
        for xs in [true, false] {
            for s in [1i32, 2, 3, 4, 7, 9, 0, -2] {
                for ow in [2u32, 3, 5, 11] {
                    for os in [true, false] {
                        for round in Rounding::ALL {
                            for overflow in [Overflow::Wrap, Overflow::Saturate] {
                                v.push(Case {
                                    xw,
                                    xs,
                                    s,
                                    ow,
                                    os,
                                    round,
                                    overflow,
                                });
                            }
                        }
                    }
                }
            }
        }
    }
    v
}

/// The closed form: `(y & mask(ow), ovf)` for the input code `code`.
fn expected(c: &Case, code: u64) -> (u64, bool) {
    let x: i64 = if c.xs && code >> (c.xw - 1) & 1 == 1 {
        code as i64 - (1i64 << c.xw)
    } else {
        code as i64
    };
    let r: i64 = if c.s <= 0 {
        x << (-c.s)
    } else {
        let q = x as f64 / f64::powi(2.0, c.s);
        (match c.round {
            Rounding::Trunc => q.floor(),
            Rounding::HalfUp => (q + 0.5).floor(),
            Rounding::HalfEven => q.round_ties_even(),
        }) as i64
    };
    let (lo, hi) = if c.os {
        (-(1i64 << (c.ow - 1)), (1i64 << (c.ow - 1)) - 1)
    } else {
        (0, (1i64 << c.ow) - 1)
    };
    let mask = (1u64 << c.ow) - 1;
    let ovf = r < lo || r > hi;
    let y = match c.overflow {
        Overflow::Wrap => r as u64 & mask,
        Overflow::Saturate => r.clamp(lo, hi) as u64 & mask,
    };
    (y, ovf)
}

/// A testbench holding every case's logic, printing `y ovf` of each case
/// for every 8-bit input code, one line per code.
fn testbench(cases: &[Case]) -> String {
    let mut v =
        String::from("`default_nettype none\nmodule quant_tb;\n  reg [7:0] x;\n  integer i;\n");
    for (k, c) in cases.iter().enumerate() {
        let sg = if c.xs { "signed " } else { "" };
        writeln!(v, "  wire {sg}[{}:0] x{k} = x[{}:0];", c.xw - 1, c.xw - 1).unwrap();
        let q = quantize(
            &Val {
                expr: format!("x{k}"),
                width: c.xw,
                signed: c.xs,
                frac: FX,
            },
            &format!("q{k}"),
            &format!("y{k}"),
            &format!("o{k}"),
            c.ow,
            c.os,
            FX - c.s,
            c.round,
            c.overflow,
        );
        for l in q.lines {
            writeln!(v, "  {l}").unwrap();
        }
    }
    v.push_str("  initial begin\n    for (i = 0; i < 256; i = i + 1) begin\n      x = i[7:0];\n      #1;\n");
    for k in 0..cases.len() {
        writeln!(v, "      $write(\"%h %b \", y{k}, o{k});").unwrap();
    }
    v.push_str("      $display(\"\");\n    end\n    $finish;\n  end\nendmodule\n");
    v
}

fn check(sim: &str) {
    // Verilator compiles slowly: every mode, sign and shift, 8-bit inputs,
    // one narrow and one wide output. Icarus takes them all.
    let cases: Vec<Case> = cases()
        .into_iter()
        .filter(|c| sim == "icarus" || (c.xw == 8 && (c.ow == 3 || c.ow == 11)))
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let tb = dir.path().join("quant_tb.v");
    std::fs::write(&tb, testbench(&cases)).unwrap();
    let out = match sim {
        "icarus" => {
            let vvp = dir.path().join("tb.vvp");
            let o = Command::new("iverilog")
                .args(["-g2005", "-o"])
                .arg(&vvp)
                .arg(&tb)
                .output()
                .expect("iverilog runs (install: apt-get install iverilog)");
            assert!(o.status.success(), "{}", text(&o));
            Command::new("vvp").arg("-n").arg(&vvp).output().unwrap()
        }
        _ => {
            let obj = dir.path().join("obj");
            let o = Command::new("verilator")
                .args([
                    "--binary",
                    "-j",
                    "2",
                    "-O0",
                    "-Wno-fatal",
                    "--top-module",
                    "quant_tb",
                ])
                .arg("--Mdir")
                .arg(&obj)
                .args(["-o", "sim"])
                .arg(&tb)
                .output()
                .expect("verilator runs (install: apt-get install verilator)");
            assert!(o.status.success(), "{}", text(&o));
            Command::new(obj.join("sim")).output().unwrap()
        }
    };
    assert!(out.status.success(), "{}", text(&out));
    let lines: Vec<&str> = std::str::from_utf8(&out.stdout)
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('-') && !l.contains("finish"))
        .collect();
    assert_eq!(lines.len(), 256, "one line per input code");
    let mut checked = 0;
    for (code, line) in lines.iter().enumerate() {
        let f: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(f.len(), 2 * cases.len());
        for (k, c) in cases.iter().enumerate() {
            let code = code as u64 & ((1 << c.xw) - 1);
            let y = u64::from_str_radix(f[2 * k], 16).unwrap();
            let ovf = f[2 * k + 1] == "1";
            let (ey, eovf) = expected(c, code);
            assert_eq!(
                (y, ovf),
                (ey, eovf),
                "{sim}: x = {code:#x} ({}{} frac {FX}), drop {} bits into {}{} bits, {:?} {:?}",
                if c.xs { "I" } else { "U" },
                c.xw,
                c.s,
                if c.os { "I" } else { "U" },
                c.ow,
                c.round,
                c.overflow
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 256 * cases.len());
}

#[test]
fn emitted_quantizer_matches_the_closed_form_on_icarus() {
    check("icarus");
}

#[test]
fn emitted_quantizer_matches_the_closed_form_on_verilator() {
    check("verilator");
}
