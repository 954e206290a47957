//! The counting (symbolic) context.

use std::collections::BTreeMap;

use super::{Datapath, Table};
use crate::format::ConvertError;
use crate::quantize::{Overflow, Quant, Rounding};

/// The widest exact intermediate the [`super::Fixed`] context holds: 126 bits
/// leave headroom in an `i128` for a rounding increment and an alignment.
pub const MAX_EXACT_WIDTH: u32 = 126;

/// A symbolic value: the exact format of an intermediate, and the stage
/// (configuration key) it last came from, for error messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sym {
    /// Two's complement or unsigned.
    pub signed: bool,
    /// Exact width in bits.
    pub width: u32,
    /// Fraction bits.
    pub frac: i32,
    /// The stage of the quantization (or input) this value derives from;
    /// for a combined value, the first operand's.
    pub origin: &'static str,
}

impl Sym {
    fn from_quant(q: &Quant) -> Sym {
        Sym {
            signed: q.format().signed(),
            width: q.format().width(),
            frac: q.format().frac(),
            origin: q.stage(),
        }
    }
    fn int_bits(&self) -> i32 {
        self.width.cast_signed() - self.frac
    }
}

/// Multiplications of one operand shape.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct MulShape {
    /// Width of the wider operand.
    pub a_width: u32,
    /// Width of the narrower operand.
    pub b_width: u32,
    /// How many.
    pub count: u64,
}

/// Multiplications of one pair of operand formats, and the multiplier the
/// hardware builds for them: both operands as they are when their
/// signedness agrees; a signed × unsigned product zero-extends the unsigned
/// operand by one bit into a signed multiplier (what Verilog and a DSP
/// block's signed ports do), e.g. `I2F14 × U1F17 → 16 × 19 signed`.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct MulFormats {
    /// First operand's exact format, e.g. `I2F14`.
    pub a: String,
    /// Second operand's exact format.
    pub b: String,
    /// The multiplier as built: `16 × 19 signed`.
    pub hardware: String,
    /// How many.
    pub count: u64,
}

/// Reads of one table.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct TableShape {
    /// Table name.
    pub name: &'static str,
    /// Entries.
    pub depth: u64,
    /// Bits per entry.
    pub width: u32,
    /// Reads.
    pub reads: u64,
}

/// Operation counts, by kind, as measured by running a datapath in [`Count`].
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct OpCounts {
    /// Multiplications (any widths).
    pub mul: u64,
    /// Additions and subtractions of the datapath.
    pub add: u64,
    /// Shifts (scalings by powers of two; wiring in hardware).
    pub shift: u64,
    /// Comparisons (`max`).
    pub compare: u64,
    /// Table reads.
    pub table_read: u64,
    /// Multiplexers choosing among values by a code (`select`).
    pub select: u64,
    /// Divisions.
    pub div: u64,
    /// Square roots.
    pub sqrt: u64,
    /// Quantizations that drop bits with a nearest mode: each costs a
    /// rounding incrementer (an adder the datapath counts do not include).
    pub round: u64,
    /// Quantizations with saturation: each costs a range comparison.
    pub saturate: u64,
    /// Multiplications by operand widths.
    pub mul_shapes: Vec<MulShape>,
    /// Multiplications by operand formats, with the multiplier the
    /// hardware builds.
    pub mul_formats: Vec<MulFormats>,
    /// Reads by table.
    pub tables: Vec<TableShape>,
}

impl OpCounts {
    /// Add another count to this one.
    pub fn merge(&mut self, o: &OpCounts) {
        self.mul += o.mul;
        self.add += o.add;
        self.shift += o.shift;
        self.compare += o.compare;
        self.table_read += o.table_read;
        self.select += o.select;
        self.div += o.div;
        self.sqrt += o.sqrt;
        self.round += o.round;
        self.saturate += o.saturate;
        for m in &o.mul_shapes {
            match self
                .mul_shapes
                .iter_mut()
                .find(|x| (x.a_width, x.b_width) == (m.a_width, m.b_width))
            {
                Some(x) => x.count += m.count,
                None => self.mul_shapes.push(m.clone()),
            }
        }
        for m in &o.mul_formats {
            match self
                .mul_formats
                .iter_mut()
                .find(|x| (&x.a, &x.b) == (&m.a, &m.b))
            {
                Some(x) => x.count += m.count,
                None => self.mul_formats.push(m.clone()),
            }
        }
        for t in &o.tables {
            match self.tables.iter_mut().find(|x| x.name == t.name) {
                Some(x) => x.reads += t.reads,
                None => self.tables.push(t.clone()),
            }
        }
    }
}

/// One quantization point of a datapath, as the counting run saw it.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct QuantPoint {
    /// The stage (configuration key within its unit).
    pub stage: &'static str,
    /// The stage id qualified by the unit it belongs to (`normalize.g`,
    /// `polar.out`): the name the RTL's overflow flags and wires carry.
    pub id: String,
    /// The exact input: signedness, width and fraction bits.
    pub input: String,
    /// Exact input width in bits.
    pub input_width: u32,
    /// Exact input fraction bits.
    pub input_frac: i32,
    /// Target format.
    pub output: crate::format::Format,
    /// Rounding mode.
    pub round: Rounding,
    /// Overflow mode.
    pub overflow: Overflow,
    /// Bits dropped below the target LSB (negative: shifted left).
    pub dropped_bits: i32,
    /// Whether an output reads it (`None`: not known, the report came from
    /// a counting run alone). A dead quantization (the last CORDIC step's
    /// coordinates, whose only reader is the next step) is in the datapath
    /// as written but not in the RTL, and raises no overflow flag.
    pub live: Option<bool>,
}

/// An exact intermediate too wide for the fixed-point model.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("the exact result of `{op}` on values from stages `{a}` and `{b}` is {width} bits wide; the model holds at most {max} exact bits")]
pub struct WidthError {
    /// The operation.
    pub op: &'static str,
    /// Stage of the first operand.
    pub a: &'static str,
    /// Stage of the second operand.
    pub b: &'static str,
    /// The exact width needed.
    pub width: u32,
    /// [`MAX_EXACT_WIDTH`].
    pub max: u32,
}

/// Records every operation by kind and infers exact formats.
#[derive(Clone, Debug, Default)]
pub struct Count {
    counts: OpCounts,
    mul_shapes: BTreeMap<(u32, u32), u64>,
    mul_formats: Vec<MulFormats>,
    tables: BTreeMap<&'static str, (u64, u32, u64)>,
    max_width: u32,
    errors: Vec<WidthError>,
    points: Vec<QuantPoint>,
    scope: Vec<&'static str>,
}

impl Count {
    /// A context with nothing counted.
    pub fn new() -> Self {
        Self::default()
    }
    /// The counts so far.
    pub fn counts(&self) -> OpCounts {
        let mut c = self.counts.clone();
        c.mul_shapes = self
            .mul_shapes
            .iter()
            .rev()
            .map(|(&(a_width, b_width), &count)| MulShape {
                a_width,
                b_width,
                count,
            })
            .collect();
        c.mul_formats = self.mul_formats.clone();
        c.tables = self
            .tables
            .iter()
            .map(|(&name, &(depth, width, reads))| TableShape {
                name,
                depth,
                width,
                reads,
            })
            .collect();
        c
    }
    /// The widest value seen (exact intermediates, quantized values,
    /// inputs), in bits of a signed container: an unsigned `W`-bit value
    /// counts as `W + 1`.
    pub fn max_width(&self) -> u32 {
        self.max_width
    }
    /// Whether every value fits the `i64` fast path of [`super::Fixed`]:
    /// 62 bits, which leaves room for a rounding increment and the sign.
    pub fn fits_i64(&self) -> bool {
        self.max_width <= 62
    }
    fn seen(&mut self, s: Sym) -> Sym {
        self.max_width = self.max_width.max(s.width + u32::from(!s.signed));
        s
    }
    /// Intermediates too wide for the fixed-point model, in order.
    pub fn width_errors(&self) -> &[WidthError] {
        &self.errors
    }
    /// Every quantization step executed, in order (a step inside a loop
    /// appears once per execution).
    pub fn quant_points(&self) -> &[QuantPoint] {
        &self.points
    }
    /// Forget everything counted.
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    fn result(&mut self, op: &'static str, a: &Sym, b: &Sym, r: Sym) -> Sym {
        self.seen(r);
        if r.width > MAX_EXACT_WIDTH
            && !self
                .errors
                .iter()
                .any(|e| e.op == op && e.a == a.origin && e.b == b.origin)
        {
            self.errors.push(WidthError {
                op,
                a: a.origin,
                b: b.origin,
                width: r.width,
                max: MAX_EXACT_WIDTH,
            });
        }
        r
    }

    /// Exact format of `a ± b` (`grow` = 1) or `max(a, b)` (`grow` = 0).
    fn aligned(a: &Sym, b: &Sym, force_signed: bool, grow: i32) -> Sym {
        let signed = a.signed || b.signed || force_signed;
        let frac = a.frac.max(b.frac);
        // An unsigned operand needs one more integer bit in a signed result.
        let ia = a.int_bits() + i32::from(signed && !a.signed);
        let ib = b.int_bits() + i32::from(signed && !b.signed);
        let int = ia.max(ib) + grow;
        Sym {
            signed,
            width: (int + frac).max(1).unsigned_abs(),
            frac,
            origin: a.origin,
        }
    }
}

impl Datapath for Count {
    type V = Sym;

    fn enter(&mut self, unit: &'static str) {
        self.scope.push(unit);
    }
    fn leave(&mut self) {
        self.scope.pop();
    }

    fn constant(&mut self, x: f64, q: &Quant) -> Result<Sym, ConvertError> {
        if x.is_nan() {
            return Err(ConvertError::NaN);
        }
        if x.is_infinite() {
            return Err(ConvertError::Infinite(x));
        }
        Ok(self.seen(Sym::from_quant(q)))
    }
    fn mul(&mut self, a: Sym, b: Sym) -> Sym {
        self.counts.mul += 1;
        let shape = (a.width.max(b.width), a.width.min(b.width));
        *self.mul_shapes.entry(shape).or_default() += 1;
        let fmt = |s: &Sym| {
            format!(
                "{}{}F{}",
                if s.signed { 'I' } else { 'U' },
                s.int_bits(),
                s.frac
            )
        };
        let (fa, fb) = (fmt(&a), fmt(&b));
        match self
            .mul_formats
            .iter_mut()
            .find(|m| (m.a.as_str(), m.b.as_str()) == (fa.as_str(), fb.as_str()))
        {
            Some(m) => m.count += 1,
            None => {
                let (wa, wb) = match (a.signed, b.signed) {
                    (true, false) => (a.width, b.width + 1),
                    (false, true) => (a.width + 1, b.width),
                    _ => (a.width, b.width),
                };
                self.mul_formats.push(MulFormats {
                    a: fa,
                    b: fb,
                    hardware: format!(
                        "{wa} × {wb} {}",
                        if a.signed || b.signed {
                            "signed"
                        } else {
                            "unsigned"
                        }
                    ),
                    count: 1,
                })
            }
        }
        let r = Sym {
            signed: a.signed || b.signed,
            width: a.width + b.width,
            frac: a.frac + b.frac,
            origin: a.origin,
        };
        self.result("mul", &a, &b, r)
    }
    fn add(&mut self, a: Sym, b: Sym) -> Sym {
        self.counts.add += 1;
        let r = Self::aligned(&a, &b, false, 1);
        self.result("add", &a, &b, r)
    }
    fn sub(&mut self, a: Sym, b: Sym) -> Sym {
        self.counts.add += 1;
        let r = Self::aligned(&a, &b, true, 1);
        self.result("sub", &a, &b, r)
    }
    fn shl(&mut self, a: Sym, n: i32) -> Sym {
        self.counts.shift += 1;
        Sym {
            frac: a.frac - n,
            ..a
        }
    }
    fn add_signed(&mut self, a: Sym, b: Sym, _s: Sym, _flip: bool) -> Sym {
        self.counts.add += 1;
        let r = Self::aligned(&a, &b, true, 1);
        self.result("add_signed", &a, &b, r)
    }
    fn max(&mut self, a: Sym, b: Sym) -> Sym {
        self.counts.compare += 1;
        let r = Self::aligned(&a, &b, false, 0);
        self.result("max", &a, &b, r)
    }
    fn quantize(&mut self, a: Sym, q: &Quant) -> Sym {
        self.points.push(QuantPoint {
            stage: q.stage(),
            id: match self.scope.last() {
                Some(u) => format!("{u}.{}", q.stage()),
                None => q.stage().to_string(),
            },
            input: format!(
                "{}{}F{}",
                if a.signed { 'I' } else { 'U' },
                a.int_bits(),
                a.frac
            ),
            input_width: a.width,
            input_frac: a.frac,
            output: q.format(),
            round: q.round(),
            overflow: q.overflow(),
            dropped_bits: a.frac - q.format().frac(),
            live: None,
        });
        if a.frac > q.format().frac() && q.round() != Rounding::Trunc {
            self.counts.round += 1;
        }
        if q.overflow() == Overflow::Saturate {
            self.counts.saturate += 1;
        }
        self.seen(Sym::from_quant(q))
    }
    fn table(&mut self, t: &Table, _index: Sym) -> Sym {
        self.counts.table_read += 1;
        let e = self
            .tables
            .entry(t.name)
            .or_insert((t.depth() as u64, t.out.format().width(), 0));
        e.2 += 1;
        self.seen(Sym::from_quant(&t.out))
    }
    fn div(&mut self, _a: Sym, _b: Sym, q: &Quant) -> Sym {
        self.counts.div += 1;
        self.seen(Sym::from_quant(q))
    }
    fn sqrt(&mut self, _a: Sym, q: &Quant) -> Sym {
        self.counts.sqrt += 1;
        self.seen(Sym::from_quant(q))
    }
    fn select(&mut self, _sel: Sym, options: &[Sym]) -> Sym {
        self.counts.select += 1;
        let first = options[0];
        let r = options[1..]
            .iter()
            .fold(first, |acc, o| Self::aligned(&acc, o, false, 0));
        self.result("select", &first, &first, r)
    }
}
