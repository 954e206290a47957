//! One datapath description, four runs.
//!
//! A unit's arithmetic is written once as a function generic over
//! [`Datapath`]. The same code then runs
//!
//! * in [`Reference`] (f64): real arithmetic, quantization is the identity,
//!   tables return the exact function — the reference;
//! * in [`Fixed`]: bit-accurate fixed point — every operation exact on
//!   `i128` codes, every [`Datapath::quantize`] rounding and
//!   saturating/wrapping as [`Quant::apply`] specifies, overflows counted
//!   per stage;
//! * compiled for batches ([`Trace`] → [`Program`]): the same bit-accurate
//!   arithmetic as [`Fixed`], with binary points resolved once into shift
//!   amounts and each instruction a loop over a block of lanes — the fast
//!   path for vector generation and error analysis;
//! * in [`Count`]: symbolic — values are formats, each operation is recorded
//!   by kind with its operand widths, and any exact intermediate wider than
//!   the model can hold ([`MAX_EXACT_WIDTH`]) is reported.
//!
//! Operation semantics (identical in every context, up to quantization):
//!
//! | op | value | exact result format (in [`Count`]) |
//! |---|---|---|
//! | `mul(a, b)` | `a·b` | width `wa + wb`, frac `fa + fb` |
//! | `add(a, b)`, `sub(a, b)` | `a ± b` | frac `max(fa, fb)`, integer bits `max(ia, ib) + 1` |
//! | `shl(a, n)` | `a·2^n` | frac `fa − n` (wiring, no hardware) |
//! | `max(a, b)` | `max(a, b)` | aligned, no growth (one comparator) |
//! | `add_signed(a, b, s, flip)` | `a + σ·b`, `σ = −1` if `s < 0` (inverted by `flip`), else `+1` | as `sub` (one adder/subtracter steered by the sign bit of `s`) |
//! | `quantize(a, q)` | `a` rounded/clipped to `q` | `q.format()` |
//! | `table(t, i)` | `t.exact(i)` quantized at build time | `t.out.format()` |
//! | `select(s, [v0, v1, …])` | `v_s` (`v0` when `s` is past the end) | aligned, no growth (one multiplexer) |
//! | `div(a, b, q)` | `a / b` correctly rounded to `q` | `q.format()` |
//! | `sqrt(a, q)` | `√a` correctly rounded to `q` | `q.format()` |

mod batch;
mod count;
mod fixed;
mod reference;

pub use batch::smt_literal;
pub use batch::{
    BoxEval, Boxes, CError, Chunk, CompileError, Compiled, Isa, Kernel, MulSplit, Mutation,
    MutationKind, Op, PartialProduct, Port, Program, SmtFunction, Trace, BLOCK, TV,
};
pub use count::{
    Count, MulFormats, MulShape, OpCounts, QuantPoint, Sym, TableShape, WidthError, MAX_EXACT_WIDTH,
};
pub use fixed::{div_exact, sqrt_exact, Fixed, Fx};
pub use reference::Reference;

use crate::format::{ConvertError, Format};
use crate::quantize::Quant;

/// The index a non-negative real selects (its integer part, saturating at
/// `usize::MAX` as Rust's float-to-integer conversion does); `None` for a
/// negative value or NaN.
#[allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "non-negative by the test; the conversion saturates"
)]
pub(crate) fn float_index(x: f64) -> Option<usize> {
    (x >= 0.0).then_some(x as usize)
}

/// The operations a unit's datapath is written in. See the module page for
/// the semantics table.
pub trait Datapath {
    /// A value flowing through the datapath.
    type V: Copy + std::fmt::Debug;

    /// A real number entering the datapath in step `q`'s format (an input
    /// port or a coefficient register). [`Fixed`] quantizes it with `q`'s
    /// modes; [`Reference`] keeps it exact; [`Count`] records nothing.
    ///
    /// # Errors
    ///
    /// A [`ConvertError`] when `x` is NaN or infinite, or (in the contexts that
    /// check it) outside `q`'s format.
    fn constant(&mut self, x: f64, q: &Quant) -> Result<Self::V, ConvertError>;
    /// Exact product.
    fn mul(&mut self, a: Self::V, b: Self::V) -> Self::V;
    /// Exact sum.
    fn add(&mut self, a: Self::V, b: Self::V) -> Self::V;
    /// Exact difference.
    fn sub(&mut self, a: Self::V, b: Self::V) -> Self::V;
    /// Exact scaling by `2^n` (a re-labelling of the binary point).
    fn shl(&mut self, a: Self::V, n: i32) -> Self::V;
    /// The larger of two values (one comparator and a multiplexer).
    fn max(&mut self, a: Self::V, b: Self::V) -> Self::V;
    /// `a + σ·b`, exact, where `σ = −1` when `s < 0` and `σ = +1` when
    /// `s ≥ 0`; `flip` inverts `σ`. One adder/subtracter whose mode is the
    /// sign bit of `s` (a CORDIC micro-rotation). Result format as
    /// [`Datapath::sub`]: signed, `max` of the fraction bits, one more
    /// integer bit than the wider operand.
    fn add_signed(&mut self, a: Self::V, b: Self::V, s: Self::V, flip: bool) -> Self::V;
    /// Round and clip to `q` (the only place bits are dropped).
    fn quantize(&mut self, a: Self::V, q: &Quant) -> Self::V;
    /// Read table `t` at `index`, a value in `t.index`'s format.
    fn table(&mut self, t: &Table, index: Self::V) -> Self::V;
    /// Quotient `a / b`, correctly rounded to `q` (division by zero
    /// saturates and counts as an overflow).
    fn div(&mut self, a: Self::V, b: Self::V, q: &Quant) -> Self::V;
    /// Square root, correctly rounded to `q` (a negative input gives 0 and
    /// counts as an overflow; a root of `2^63` or more saturates to the largest code
    /// in either overflow mode and counts as an overflow).
    fn sqrt(&mut self, a: Self::V, q: &Quant) -> Self::V;
    /// `options[sel]`: a multiplexer choosing one of several values (e.g.
    /// one coefficient set per triangle) by an unsigned integer code `sel`
    /// (format `U<n>F0`). A code past the last option selects option 0. The
    /// options are aligned to the finest of their binary points; the result
    /// format holds every option exactly (no growth).
    fn select(&mut self, sel: Self::V, options: &[Self::V]) -> Self::V;

    /// Record what follows as part of unit `unit` (stage ids become
    /// `unit.stage` in a [`Trace`]; other contexts ignore it).
    #[inline]
    fn enter(&mut self, _unit: &'static str) {}
    /// Leave the unit scope opened last.
    #[inline]
    fn leave(&mut self) {}

    /// `a·b + c`, exact: one multiply-add.
    #[inline]
    fn mul_add(&mut self, a: Self::V, b: Self::V, c: Self::V) -> Self::V {
        let p = self.mul(a, b);
        self.add(p, c)
    }
    /// Three-term dot product `a·b`, exact: 3 multiplications, 2 additions.
    #[inline]
    fn dot3(&mut self, a: [Self::V; 3], b: [Self::V; 3]) -> Self::V {
        let x = self.mul(a[0], b[0]);
        let y = self.mul(a[1], b[1]);
        let z = self.mul(a[2], b[2]);
        let xy = self.add(x, y);
        self.add(xy, z)
    }
    /// Quantize each component of a vector with the same step.
    #[inline]
    fn quantize3(&mut self, a: [Self::V; 3], q: &Quant) -> [Self::V; 3] {
        [
            self.quantize(a[0], q),
            self.quantize(a[1], q),
            self.quantize(a[2], q),
        ]
    }
}

/// A read-only table (ROM): `depth = 2^index.width` entries, entry `i` holding
/// `exact(value of index code i)` quantized with `out`.
#[derive(Clone, Debug)]
pub struct Table {
    /// Name, for reports.
    pub name: &'static str,
    /// Format of the index (unsigned, integer codes address the entries).
    pub index: Format,
    /// Output step: the entries' format and how they were rounded.
    pub out: Quant,
    /// The function tabulated, for the reference run.
    pub exact: fn(f64) -> f64,
    /// The entries, as codes of `out.format`.
    pub codes: Vec<i128>,
    /// How the hardware stores the table: every entry, or a quarter wave
    /// with symmetry logic ([`QuarterWave`]). Both read the same codes.
    pub storage: Option<QuarterWave>,
}

/// A sine or cosine table of `2^t` entries stored as the quarter wave
/// `q[i] = Q(sin(2π·i/2^t))`, `i = 0 ..= 2^t/4`, and read by symmetry:
/// with `j = i + phase·2^t/4 (mod 2^t)`, quadrant `h = j >> (t−2)` and
/// `r = j mod 2^t/4`, the entry is `v = q[r]` for even `h`, `q[2^t/4 − r]` for
/// odd `h`, negated (and brought back into the entry format with its
/// overflow mode) for `h ≥ 2`. `phase` is 0 for sine, 1 for cosine.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct QuarterWave {
    /// The `2^t/4 + 1` stored entries.
    pub entries: Vec<i128>,
    /// 0: sine; 1: cosine (a quarter turn ahead).
    pub phase: u32,
}

/// Why a table could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TableError {
    /// The index must be unsigned and at most 24 bits wide.
    #[error("table {name}: index format {index} must be unsigned and at most 24 bits wide")]
    Index {
        /// Table name.
        name: &'static str,
        /// The index format given.
        index: Format,
    },
    /// An entry's exact value was not finite.
    #[error("table {name}: entry {entry}: {source}")]
    Entry {
        /// Table name.
        name: &'static str,
        /// Index of the entry.
        entry: usize,
        /// The conversion error.
        source: ConvertError,
    },
}

impl Table {
    /// Tabulate `exact` over every code of `index`, quantizing with `out`.
    ///
    /// # Errors
    ///
    /// [`TableError::Index`] for an index that is signed or wider than 24 bits,
    /// [`TableError::Entry`] for an entry whose exact value cannot be quantized.
    pub fn build(
        name: &'static str,
        index: Format,
        out: Quant,
        exact: fn(f64) -> f64,
    ) -> Result<Table, TableError> {
        if index.signed() || index.width() > 24 {
            return Err(TableError::Index { name, index });
        }
        let depth = 1usize << index.width();
        let codes = (0..depth)
            .map(|i| {
                out.apply_f64(exact(index.to_f64(i as i128)))
                    .map(|r| r.code)
                    .map_err(|source| TableError::Entry {
                        name,
                        entry: i,
                        source,
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Table {
            name,
            index,
            out,
            exact,
            codes,
            storage: None,
        })
    }
    /// Number of entries.
    pub fn depth(&self) -> usize {
        self.codes.len()
    }
    /// Size in bits: depth × entry width.
    pub fn bits(&self) -> u64 {
        self.depth() as u64 * u64::from(self.out.format().width())
    }
}
