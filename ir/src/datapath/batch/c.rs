//! A compiled program as straight-line C: the baseline `fxshade bench
//! engine` measures the engine against (the same arithmetic, one fused loop
//! over lanes, left to a C compiler's `-O3 -march=native`).
//!
//! The C computes what [`Program::run`] computes, code for code: every
//! operation is the instruction's (shifts align binary points, products
//! and sums wrap in 64 bits like the engine's `i64`, which the counting run
//! guarantees never happens), and every quantization is [`Step::apply`]
//! written out for its constant shift, range and modes. `bench engine`
//! compares the C program's outputs and overflow counts with the engine's
//! on every lane before it reports a time.

use super::{Instr, Program};
use crate::quantize::{Overflow, Rounding, Step};
use std::fmt::Write as _;

/// Why a program has no C form.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CError {
    /// Division and square root are reference operations (no RTL, no C).
    #[error("the program divides or takes a square root, which have no C form here")]
    Reference,
    /// A [specialized](super::Program::specialize) program whose folded
    /// quantizations overflowed: the C form does not carry those counts.
    #[error("the program was specialized with folded overflows, which the C form does not count")]
    Specialized,
}

/// `v` as a C `int64_t` literal (`INT64_MIN` spelled as an expression).
fn lit(v: i64) -> String {
    if v == i64::MIN {
        "(-INT64_C(9223372036854775807) - 1)".into()
    } else {
        format!("INT64_C({v})")
    }
}

/// The C of `raw` shifted left by `s` (wrapping, as the engine's `<<`).
fn shl(r: &str, s: u32) -> String {
    if s == 0 {
        r.to_string()
    } else {
        format!("SHL({r}, {s})")
    }
}

/// C statements computing `d` = [`Step::apply`]`(x, round, overflow)` and
/// `d_bad` (1 when it overflowed, else 0), branch-free: the final choice
/// is a mask, so that a C compiler's if-conversion keeps the loop
/// vectorizable.
fn quant(out: &mut String, d: &str, x: &str, st: &Step, round: Rounding, overflow: Overflow) {
    let s = st.shift;
    // The rounded code and whether the shift left lost bits ("huge").
    let (rounded, huge) = if s > 0 {
        let s = s.unsigned_abs();
        if s >= 64 {
            let r = match round {
                Rounding::Trunc => format!("({x} < 0 ? INT64_C(-1) : INT64_C(0))"),
                _ => "INT64_C(0)".into(),
            };
            (r, "0".to_string())
        } else {
            let r = match round {
                Rounding::Trunc => format!("({x} >> {s})"),
                Rounding::HalfUp => format!("((({x} >> {}) + 1) >> 1)", s - 1),
                Rounding::HalfEven => format!(
                    "((int64_t)((uint64_t){x} + (uint64_t)((INT64_C(1) << {}) - 1 + \
                     (({x} >> {s}) & 1))) >> {s})",
                    s - 1
                ),
            };
            (r, "0".to_string())
        }
    } else if s == 0 {
        (x.to_string(), "0".to_string())
    } else {
        let l = s.unsigned_abs();
        if l < 63 {
            let fits = format!("((SHL({x}, {l}) >> {l}) == {x})");
            (format!("SHL({x}, {l})"), format!("(!{fits} && {x} != 0)"))
        } else {
            let r = if l >= 64 {
                "INT64_C(0)".to_string()
            } else {
                format!("SHL({x}, {l})")
            };
            (r, format!("({x} != 0)"))
        }
    };
    let (min, max) = (narrow_i64(st.min), narrow_i64(st.max));
    let _ = writeln!(out, "    const int64_t {d}_r = {rounded};");
    let _ = writeln!(
        out,
        "    const uint64_t {d}_bad = (uint64_t)({huge} | \
         ((uint64_t)({d}_r - {}) > (uint64_t)({} - {})));",
        lit(min),
        lit(max),
        lit(min)
    );
    let _ = writeln!(out, "    const int64_t {d}_m = -(int64_t){d}_bad;");
    let fix = match overflow {
        Overflow::Wrap => {
            let sh = 64 - st.width;
            if st.signed {
                format!("(SHL({d}_r, {sh}) >> {sh})")
            } else {
                format!("(int64_t)((uint64_t)SHL({d}_r, {sh}) >> {sh})")
            }
        }
        Overflow::Saturate => format!("({x} < 0 ? {} : {})", lit(min), lit(max)),
    };
    let _ = writeln!(
        out,
        "    const int64_t {d} = ({d}_r & ~{d}_m) | ({fix} & {d}_m);"
    );
}

/// A step's code bound as `i64`: a program compiled for `i64` has formats
/// of at most 63 bits, so its bounds fit.
fn narrow_i64(v: i128) -> i64 {
    i64::try_from(v).expect("an i64 program's code range fits i64")
}

impl Program<i64> {
    /// The program as a C99 translation unit (with GCC/Clang's
    /// `__restrict__`): `FXS_N_IN`, `FXS_N_OUT`, `FXS_N_STAGES`, and
    ///
    /// ```c
    /// void fxs_kernel(size_t n, const int64_t *const *in,
    ///                 int64_t *const *out, uint64_t *ov);
    /// ```
    ///
    /// which reads `in[i][k]` (input port `i`, lane `k < n`), writes
    /// `out[j][k]` and adds the overflows of stage `s` to `ov[s]` — what
    /// [`Program::run_into`] returns, in [`Program::run`]'s stage order
    /// (`stage_names` gives it). Each lane is straight-line code (selects,
    /// no branches), so a C compiler may vectorize across lanes.
    ///
    /// # Errors
    ///
    /// [`CError::Reference`] for a program with a division or square root;
    /// [`CError::Specialized`] for a specialized program with folded
    /// overflows.
    pub fn c_source(&self) -> Result<String, CError> {
        if !self.base_overflows.is_empty() {
            return Err(CError::Specialized);
        }
        let mut o = String::new();
        let _ = writeln!(
            o,
            "/* Generated by fxshade (fxshade-ir batch::c): the program's arithmetic as\n \
             * straight-line C, one loop over lanes. */\n\
             #include <stddef.h>\n#include <stdint.h>\n\n\
             #define SHL(x, s) ((int64_t)((uint64_t)(x) << (s)))\n\
             #define FXS_N_IN {}\n#define FXS_N_OUT {}\n#define FXS_N_STAGES {}\n",
            self.inputs.len(),
            self.outputs.len(),
            self.stages.len().max(1)
        );
        for (k, t) in self.tables.iter().enumerate() {
            let _ = write!(o, "static const int64_t t{k}[{}] = {{", t.len());
            for (i, v) in t.iter().enumerate() {
                if i % 8 == 0 {
                    o.push_str("\n    ");
                }
                let _ = write!(o, "{}, ", lit(*v));
            }
            o.push_str("\n};\n");
        }
        // The lanes take every array as a restrict parameter (GCC ignores
        // restrict on local pointers when it checks for aliasing).
        o.push_str("\nstatic void fxs_lanes(size_t n");
        for i in 0..self.inputs.len() {
            let _ = write!(o, ",\n    const int64_t *__restrict__ in{i}");
        }
        for j in 0..self.outputs.len() {
            let _ = write!(o, ",\n    int64_t *__restrict__ out{j}");
        }
        o.push_str(",\n    uint64_t *__restrict__ ov)\n{\n");
        for s in 0..self.stages.len() {
            let _ = writeln!(o, "    uint64_t ov{s} = 0;");
        }
        o.push_str("    for (size_t k = 0; k < n; k++) {\n");
        let mut body = String::new();
        // Each stage's overflows of one lane, summed once per lane (one
        // update of each accumulator per iteration: a reduction).
        let mut bad: Vec<Vec<String>> = vec![Vec::new(); self.stages.len()];
        for (i, &(d, _)) in self.inputs.iter().enumerate() {
            let _ = writeln!(body, "    const int64_t r{d} = in{i}[k];");
        }
        for &(d, c) in &self.consts {
            let _ = writeln!(body, "    const int64_t r{d} = {};", lit(c));
        }
        for ins in &self.instrs {
            let r = |n: usize| format!("r{n}");
            match *ins {
                Instr::Mul { d, a, b } => {
                    let _ = writeln!(
                        body,
                        "    const int64_t r{d} = (int64_t)((uint64_t)r{a} * (uint64_t)r{b});"
                    );
                }
                Instr::AddSub {
                    d,
                    a,
                    sa,
                    b,
                    sb,
                    sub,
                } => {
                    let _ = writeln!(
                        body,
                        "    const int64_t r{d} = (int64_t)((uint64_t){} {} (uint64_t){});",
                        shl(&r(a), sa),
                        if sub { '-' } else { '+' },
                        shl(&r(b), sb)
                    );
                }
                Instr::Max { d, a, sa, b, sb } => {
                    let (x, y) = (shl(&r(a), sa), shl(&r(b), sb));
                    let _ = writeln!(body, "    const int64_t r{d} = {x} >= {y} ? {x} : {y};");
                }
                Instr::AddSigned {
                    d,
                    a,
                    sa,
                    b,
                    sb,
                    s,
                    flip,
                } => {
                    let (x, y) = (shl(&r(a), sa), shl(&r(b), sb));
                    let _ = writeln!(
                        body,
                        "    const int64_t r{d} = ((r{s} < 0) != {}) ? \
                         (int64_t)((uint64_t){x} - (uint64_t){y}) : \
                         (int64_t)((uint64_t){x} + (uint64_t){y});",
                        u8::from(flip)
                    );
                }
                Instr::Quant {
                    d,
                    a,
                    ref step,
                    round,
                    overflow,
                    stage,
                    ..
                } => {
                    quant(&mut body, &r(d), &r(a), step, round, overflow);
                    bad[stage].push(format!("r{d}_bad"));
                }
                Instr::Select {
                    d, sel, ref opts, ..
                } => {
                    // An index outside the options reads the first (as the
                    // engine does).
                    let mut e = shl(&r(opts[0].0), opts[0].1);
                    for (i, &(src, sh)) in opts.iter().enumerate().skip(1).rev() {
                        e = format!("(r{sel} == {i} ? {} : {e})", shl(&r(src), sh));
                    }
                    let _ = writeln!(body, "    const int64_t r{d} = {e};");
                }
                Instr::Table { d, a, table, index } => {
                    let mask = self.tables[table].len() - 1;
                    let bits = if index.width() >= 64 {
                        u64::MAX
                    } else {
                        (1u64 << index.width()) - 1
                    };
                    let _ = writeln!(
                        body,
                        "    const int64_t r{d} = t{table}[(uint64_t)r{a} & UINT64_C({}) & UINT64_C({mask})];",
                        bits
                    );
                }
                Instr::Div { .. } | Instr::Sqrt { .. } => return Err(CError::Reference),
            }
        }
        for (s, b) in bad.iter().enumerate().filter(|(_, b)| !b.is_empty()) {
            let _ = writeln!(body, "    ov{s} += {};", b.join(" + "));
        }
        for (j, &(d, _)) in self.outputs.iter().enumerate() {
            let _ = writeln!(body, "    out{j}[k] = r{d};");
        }
        for line in body.lines() {
            let _ = writeln!(o, "    {line}");
        }
        o.push_str("    }\n");
        for s in 0..self.stages.len() {
            let _ = writeln!(o, "    ov[{s}] += ov{s};");
        }
        o.push_str(
            "}\n\nvoid fxs_kernel(size_t n, const int64_t *const *in, int64_t *const *out,\n",
        );
        o.push_str("    uint64_t *ov)\n{\n    fxs_lanes(n");
        for i in 0..self.inputs.len() {
            let _ = write!(o, ", in[{i}]");
        }
        for j in 0..self.outputs.len() {
            let _ = write!(o, ", out[{j}]");
        }
        o.push_str(", ov);\n}\n");
        Ok(o)
    }

    /// The quantization stages in the order of [`Program::run`]'s overflow
    /// counts before it drops the zero ones (and of `c_source`'s `ov`).
    pub fn stage_names(&self) -> &[&'static str] {
        &self.stages
    }
}
