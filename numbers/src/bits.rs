//! Verilog expressions for exact-width fixed-point values: extension,
//! alignment, rounding and range limiting, each written out bit for bit so
//! no tool's expression-sizing rules matter.

use crate::quantize::{Overflow, Rounding};

/// A value on a wire: its Verilog expression (a name or a constant),
/// width, signedness and binary point.
#[derive(Clone, Debug)]
pub struct Val {
    /// A name or a sized literal.
    pub expr: String,
    /// Width in bits.
    pub width: u32,
    /// Two's complement.
    pub signed: bool,
    /// Fraction bits.
    pub frac: i32,
}

impl Val {
    /// Bit `i` (a literal bit for a constant expression would be wrong, so
    /// callers only take bits of names).
    pub fn bit(&self, i: u32) -> String {
        if self.width == 1 {
            self.expr.clone()
        } else {
            format!("{}[{i}]", self.expr)
        }
    }
    /// Bits `hi:lo`.
    pub fn slice(&self, hi: u32, lo: u32) -> String {
        if hi == lo {
            self.bit(hi)
        } else {
            format!("{}[{hi}:{lo}]", self.expr)
        }
    }
    /// The sign bit, or `1'b0` for an unsigned value.
    pub fn sign_bit(&self) -> String {
        if self.signed {
            self.bit(self.width - 1)
        } else {
            "1'b0".into()
        }
    }
}

/// `e` as a signed expression when `signed` (`$signed(e)`), else `e`: what a
/// signed wire or register is assigned, so no assignment changes signedness
/// implicitly.
pub fn sv(signed: bool, e: &str) -> String {
    if signed {
        format!("$signed({e})")
    } else {
        e.to_string()
    }
}

/// `{n{b}}` without the replication when `n` is 1.
fn rep(n: u32, b: &str) -> String {
    if n == 1 {
        b.to_string()
    } else {
        format!("{{{n}{{{b}}}}}")
    }
}

/// `v` shifted left by `shift` bits (appending zeros) and sign- or
/// zero-extended to `width` bits: a concatenation exactly `width` wide.
///
/// # Panics
///
/// When `width` is below `v.width + shift`: an alignment never drops bits.
pub fn align(v: &Val, shift: u32, width: u32) -> String {
    let body = v.width + shift;
    assert!(width >= body, "alignment never drops bits");
    let mut parts = Vec::new();
    if width > body {
        parts.push(rep(width - body, &v.sign_bit()));
    }
    parts.push(v.expr.clone());
    if shift > 0 {
        parts.push(format!("{shift}'b0"));
    }
    if parts.len() == 1 {
        parts.remove(0)
    } else {
        format!("{{{}}}", parts.join(", "))
    }
}

/// A sized hex literal of `width` bits holding the two's complement (or
/// unsigned) code `code`.
pub fn literal(width: u32, code: i128) -> String {
    let mask = if width >= 128 {
        u128::MAX
    } else {
        (1u128 << width) - 1
    };
    format!("{width}'h{:x}", code.cast_unsigned() & mask)
}

/// The combinational logic of one quantization, as statements, given the
/// exact input `x` (a wire name), writing `y` (`ow` bits) and `ovf`.
pub struct QuantLogic {
    /// Declarations and assigns.
    pub lines: Vec<String>,
    /// Bits of `x` the logic does not read (for the `unused` sink).
    pub unused: Vec<String>,
    /// Whether a rounding incrementer was built, and its width.
    pub round_adder: Option<u32>,
    /// Bits the range check reads (0 where the rounded value cannot leave
    /// the format): an OR/AND reduction of about this many inputs.
    pub check_bits: u32,
    /// Output bits behind a saturation multiplexer (0 when wrapping or
    /// when the value cannot leave the format).
    pub saturate_bits: u32,
}

/// Quantize `x` to `(ow, os, fo)` with `round` and `overflow`: the result
/// on wire `y` (`ow` bits), the overflow bit on wire `ovf`; helper wires are
/// named `{p}_*`.
///
/// Width of the rounded value `r` of [`quantize`] for an operand of `xw`
/// bits with `s` bits dropped (`s > 0`: the kept bits, at least one, plus
/// one for a nearest mode's increment) or added (`s ≤ 0`).
pub fn rounded_width(xw: u32, s: i32, round: Rounding) -> u32 {
    let n = s.unsigned_abs();
    if s <= 0 {
        xw + n
    } else {
        xw.max(n + 1) - n + u32::from(round != Rounding::Trunc)
    }
}

/// Whether a rounded value of `rw` bits (signed or not) can lie outside a
/// format of `ow` bits (signed or not): where not, [`quantize`]'s range
/// check is the constant 0 and the overflow mode changes nothing.
pub fn can_leave(rw: u32, rsigned: bool, ow: u32, osigned: bool) -> bool {
    match (rsigned, osigned) {
        (true, true) | (false, false) => rw > ow,
        (true, false) => true,
        (false, true) => rw >= ow,
    }
}

/// Rounding (bits dropped, `s = fx − fo > 0`): `t = x >>> s` (a slice), then
/// `u = t + x[s−1]` in `width(t) + 1` bits (the incrementer's carry chain
/// starts at `x`); half_up takes `r = u`, half_even clears `u`'s LSB on a
/// tie, `r = {u[tw:1], u[0] & ~tie}` with `tie = x[s−1] & ~|x[s−2:0]`;
/// trunc takes `r = t`. Bits added
/// (`s ≤ 0`): `r = {x, −s zeros}`. Range: `ovf` when `r` lies outside the
/// target format; wrap keeps the low `ow` bits of `r` (sign-extended when
/// narrower), saturate gives the nearest bound on the side of `r`'s sign.
#[allow(clippy::too_many_arguments)]
pub fn quantize(
    x: &Val,
    p: &str,
    y: &str,
    ovf: &str,
    ow: u32,
    os: bool,
    fo: i32,
    round: Rounding,
    overflow: Overflow,
) -> QuantLogic {
    let mut lines = Vec::new();
    let mut unused = Vec::new();
    let mut round_adder = None;
    let s = x.frac - fo;
    let sgn = if x.signed { "signed " } else { "" };
    // r: the rounded value, in rw bits of x's signedness.
    let (r, rw) = if s <= 0 {
        let rw = x.width + s.unsigned_abs();
        if s == 0 {
            (x.expr.clone(), rw)
        } else {
            let name = format!("{p}_r");
            lines.push(format!(
                "wire {sgn}[{}:0] {name} = {};",
                rw - 1,
                sv(x.signed, &align(x, s.unsigned_abs(), rw))
            ));
            (name, rw)
        }
    } else {
        let s = s.unsigned_abs();
        // Extend so at least one bit stays above the dropped ones.
        let xe = if x.width < s + 1 {
            let name = format!("{p}_x");
            let w = s + 1;
            lines.push(format!(
                "wire {sgn}[{}:0] {name} = {};",
                w - 1,
                sv(x.signed, &align(x, 0, w))
            ));
            Val {
                expr: name,
                width: w,
                signed: x.signed,
                frac: x.frac,
            }
        } else {
            x.clone()
        };
        let tw = xe.width - s;
        let t = xe.slice(xe.width - 1, s);
        match round {
            Rounding::Trunc => {
                unused.push(xe.slice(s - 1, 0));
                let name = format!("{p}_t");
                lines.push(format!(
                    "wire {sgn}[{}:0] {name} = {};",
                    tw - 1,
                    sv(xe.signed, &t)
                ));
                (name, tw)
            }
            Rounding::HalfUp | Rounding::HalfEven => {
                // Both nearest modes add the half bit x[s−1] straight from
                // x, so the incrementer's carry chain starts at x's
                // register. Half-even then clears the sum's LSB on an exact
                // tie (x[s−1] set, x[s−2:0] zero): t + 1 with its LSB
                // cleared is t when t is even and t + 1 when t is odd. The
                // tie detect runs beside the chain and meets it at bit 0.
                let half = xe.bit(s - 1);
                let name = format!("{p}_r");
                // One incrementer: t (extended by one bit) plus the half bit.
                let ext = format!("{{{}, {t}}}", xe.sign_bit());
                let sum = format!("{ext} + {{{}, {half}}}", rep(tw, "1'b0"));
                if round == Rounding::HalfUp {
                    if s >= 2 {
                        unused.push(xe.slice(s - 2, 0));
                    }
                    lines.push(format!(
                        "wire {sgn}[{tw}:0] {name} = {};",
                        sv(xe.signed, &sum)
                    ));
                } else {
                    let tie = format!("{p}_tie");
                    let e = if s >= 2 {
                        format!("{half} & ~(|{})", xe.slice(s - 2, 0))
                    } else {
                        half
                    };
                    lines.push(format!("wire {tie} = {e};"));
                    let up = format!("{p}_up");
                    lines.push(format!("wire [{tw}:0] {up} = {sum};"));
                    lines.push(format!(
                        "wire {sgn}[{tw}:0] {name} = {};",
                        sv(xe.signed, &format!("{{{up}[{tw}:1], {up}[0] & ~{tie}}}"))
                    ));
                }
                round_adder = Some(tw + 1);
                (name, tw + 1)
            }
        }
    };
    let rv = Val {
        expr: r,
        width: rw,
        signed: x.signed,
        frac: fo,
    };
    debug_assert_eq!(rw, rounded_width(x.width, s, round));
    // Range check.
    let ovf_e = if !can_leave(rw, rv.signed, ow, os) {
        "1'b0".to_string()
    } else {
        match (rv.signed, os) {
            (true, true) => {
                if rw > ow {
                    let top = rv.slice(rw - 1, ow - 1);
                    format!("~((&{top}) | ~(|{top}))")
                } else {
                    "1'b0".into()
                }
            }
            (false, false) => {
                if rw > ow {
                    format!("|{}", rv.slice(rw - 1, ow))
                } else {
                    "1'b0".into()
                }
            }
            (true, false) => {
                if rw - 1 > ow {
                    format!("{} | (|{})", rv.bit(rw - 1), rv.slice(rw - 2, ow))
                } else {
                    rv.bit(rw - 1)
                }
            }
            (false, true) => {
                if rw >= ow {
                    format!("|{}", rv.slice(rw - 1, ow - 1))
                } else {
                    "1'b0".into()
                }
            }
        }
    };
    lines.push(format!("wire {ovf} = {ovf_e};"));
    // The in-range value: the low bits, extended when narrower.
    let fit = if rw >= ow {
        rv.slice(ow - 1, 0)
    } else {
        align(&rv, 0, ow)
    };
    let osg = if os { "signed " } else { "" };
    match overflow {
        Overflow::Wrap => lines.push(format!("wire {osg}[{}:0] {y} = {};", ow - 1, sv(os, &fit))),
        Overflow::Saturate => {
            let (max, min) = if os {
                (
                    literal(ow, (1i128 << (ow - 1)) - 1),
                    literal(ow, -(1i128 << (ow - 1))),
                )
            } else {
                (
                    literal(
                        ow,
                        if ow >= 127 {
                            i128::MAX
                        } else {
                            (1i128 << ow) - 1
                        },
                    ),
                    literal(ow, 0),
                )
            };
            let bound = if rv.signed {
                format!("({} ? {min} : {max})", rv.bit(rw - 1))
            } else {
                max
            };
            lines.push(format!(
                "wire {osg}[{}:0] {y} = {};",
                ow - 1,
                sv(os, &format!("{ovf} ? {bound} : {fit}"))
            ));
        }
    }
    let leaves = can_leave(rw, rv.signed, ow, os);
    QuantLogic {
        lines,
        unused,
        round_adder,
        check_bits: if leaves { rw.saturating_sub(ow) + 1 } else { 0 },
        saturate_bits: if leaves && overflow == Overflow::Saturate {
            ow
        } else {
            0
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alignment_pads_and_extends() {
        let v = Val {
            expr: "a".into(),
            width: 4,
            signed: true,
            frac: 2,
        };
        assert_eq!(align(&v, 2, 8), "{{2{a[3]}}, a, 2'b0}");
        assert_eq!(align(&v, 0, 4), "a");
        let u = Val { signed: false, ..v };
        assert_eq!(align(&u, 0, 5), "{1'b0, a}");
    }

    #[test]
    fn literals_are_masked_to_their_width() {
        assert_eq!(literal(4, -1), "4'hf");
        assert_eq!(literal(16, 0x7fff), "16'h7fff");
        assert_eq!(literal(3, 8), "3'h0");
    }
}
