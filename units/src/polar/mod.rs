//! Method B: light and half vectors into tangent space by the polar angles
//! of the normal, with sin/cos tables — 6 multiplications, 3 additions,
//! 6 table reads, no normalization.
//!
//! A unit vector is `(cos α·sin β, sin α, cos α·cos β)`: `α = asin y`
//! (elevation), `β = atan2(x, z)` (azimuth about y). Rotating about y by
//! `−β_N`, then about x by `α_N`, takes `N` to `(0, 0, 1)`; applied to
//! `L = (α_L, β_L)`:
//!
//! ```text
//! Lyz = Q_lyz(cos α_L · cos(β_L − β_N))
//! L'x = Q_out(cos α_L · sin(β_L − β_N))
//! L'y = Q_out(sin α_L · cos α_N − Lyz · sin α_N)
//! L'z = Q_out(sin α_L · sin α_N + Lyz · cos α_N)
//! ```
//!
//! The implied tangent frame is `T = (cos β_N, 0, −sin β_N)`,
//! `B = N × T`, `N`: `L' = (L·T, L·B, L·N)` ([`reference()`]).
//!
//! ## Angles and tables
//! Angles are binary angle measures: `U0F<k>` codes, fractions of a turn,
//! which wrap around for free (`β_L − β_N` is taken modulo one turn). A
//! table read quantizes the angle to the table's index (`index` stage: its
//! rounding mode picks truncation or rounding to the nearest entry; it must
//! wrap) and reads `sin` or `cos`. Entries are `Q_table(sin(2π·i/2^t))`
//! for the first quarter turn (`i = 0 ..= 2^t/4`); every other entry follows
//! by symmetry (`sin(π − x) = sin x`, `sin(−x) = −sin x`,
//! `cos x = sin(x + π/2)`), so a full table of `2^t` entries and a
//! quarter-wave table of `2^t/4 + 1` entries give bit-identical outputs by
//! construction ([`Tables`]).
//!
//! ## Poles and wrap-around
//! At the poles (`|y| = 1`, `α_N = ±90°`) `β_N` is undefined and the frame
//! singular: fxshade defines `β = 0` there ([`angles_of`]), so
//! `T = (1, 0, 0)` and the transform stays a rotation. `β` wraps at ±180°:
//! the difference `β_L − β_N` is computed modulo a turn, so normals either
//! side of the seam transform continuously (both tested).

use fxshade_numbers::convert::{narrow, to_f64};
use glam::DVec3;

use crate::config::{Config, ConfigError, FieldDecl, FieldKind, UnitDecl};
use crate::datapath::{Compiled, Count, Datapath, Table, Trace};
use crate::format::{ConvertError, Format};
use crate::quantize::{Overflow, Quant};
use crate::units::{width_errors, OpReport, PaperClaim, Phase};

pub mod frames;
pub mod rtl;

/// The `[polar]` configuration section.
pub static DECL: UnitDecl = UnitDecl {
    name: "polar",
    doc: "method B: L and H into tangent space by the polar angles of N, with sin/cos tables",
    fields: &[
        FieldDecl {
            name: "angle_bits",
            kind: FieldKind::Integer { min: 4, max: 24 },
            doc: "angles are unsigned fractions of a turn of this many bits",
        },
        FieldDecl {
            name: "table_bits",
            kind: FieldKind::Integer { min: 4, max: 16 },
            doc: "table index bits: 2^table_bits entries per turn",
        },
        FieldDecl {
            name: "organisation",
            kind: FieldKind::Choice(&["full", "quarter"]),
            doc: "sin/cos table: full (2^t entries) or quarter-wave (2^t/4 + 1 entries, by symmetry); bit-identical outputs",
        },
        FieldDecl { name: "index", kind: FieldKind::Stage, doc: "angle to table index (format ignored: U0F<table_bits>; round picks the entry; must wrap)" },
        FieldDecl { name: "table", kind: FieldKind::Stage, doc: "table entries sin, cos" },
        FieldDecl { name: "lyz", kind: FieldKind::Stage, doc: "Lyz = cos α_L · cos(β_L − β_N)" },
        FieldDecl { name: "out", kind: FieldKind::Stage, doc: "output port: L' components" },
    ],
    groups: &[("light", &["lyz", "out"]), ("tables", &["table"])],
};

/// The `[polar]` section, typed (one field per declared field).
#[derive(Clone, Copy, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolarConfig {
    /// Bits of an angle, a fraction of a turn.
    pub angle_bits: u32,
    /// Address bits of a full-turn table.
    pub table_bits: u32,
    /// Full-turn or quarter-wave tables.
    pub organisation: Organisation,
    /// Angle to table index (its format is set by `table_bits`).
    pub index: Quant,
    /// The table entries.
    pub table: Quant,
    /// `Lyz = cos α_L · cos(β_L − β_N)`.
    pub lyz: Quant,
    /// Output port: the components of L'.
    pub out: Quant,
}

impl crate::config::Section for PolarConfig {
    const DECL: &'static UnitDecl = &DECL;
}

/// The polar transform as a registered unit.
pub struct PolarUnit;

crate::unit!(PolarUnit, decl: DECL, section: PolarConfig, check: check, ops: ops,
    rtl: &[&RTL]);

/// The registry entry.
pub static UNIT: PolarUnit = PolarUnit;

/// The unit's generated RTL: variants, design and input vectors.
pub static RTL: crate::rtl::units::RtlUnit = crate::rtl::units::RtlUnit {
    name: "polar",
    doc: "method B: L into the tangent frame of N by polar angles and sin/cos tables",
    variants: &[
        ("quarter", "polar.organisation=\"quarter\""),
        ("full", "polar.organisation=\"full\""),
    ],
    build: crate::polar::rtl::design,
    inputs: crate::polar::rtl::inputs,
};

/// Table organisation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Organisation {
    /// `2^t` entries.
    Full,
    /// `2^t/4 + 1` entries and symmetry.
    Quarter,
}

impl Organisation {
    /// The configuration name (`full`, `quarter`).
    pub const fn name(self) -> &'static str {
        match self {
            Organisation::Full => "full",
            Organisation::Quarter => "quarter",
        }
    }
}

/// The sin and cos tables of a configuration, built from the quarter-wave
/// entries.
#[derive(Clone, Debug)]
pub struct Tables {
    /// `sin(2π·i/2^t)`.
    pub sin: Table,
    /// `cos(2π·i/2^t)`.
    pub cos: Table,
    /// The quarter-wave entries `Q(sin(2π·i/2^t))`, `i = 0 ..= 2^t/4`.
    pub quarter: Vec<i128>,
    /// Organisation (what the RTL stores).
    pub organisation: Organisation,
}

impl Tables {
    /// Build for `t` index bits with entries quantized by `q`.
    ///
    /// # Errors
    ///
    /// A [`ConvertError`] for a NaN or infinite entry, which the sine of a finite angle never is.
    ///
    /// # Panics
    ///
    /// If `t < 2` (a quarter turn holds no entry) or `t ≥ 64` (`2^t` entries do not fit a `usize`).
    pub fn build(t: u32, q: Quant, organisation: Organisation) -> Result<Tables, ConvertError> {
        let n = 1usize << t;
        let quarter: Vec<i128> = (0..=n / 4)
            .map(|i| {
                q.apply_f64((std::f64::consts::TAU * to_f64(i) / to_f64(n)).sin())
                    .map(|r| r.code)
            })
            .collect::<Result<_, _>>()?;
        // sin at index i by symmetry from the quarter-wave entries.
        let sin_at = |i: usize| -> i128 {
            let (quad, r) = (i / (n / 4), i % (n / 4));
            let v = if quad % 2 == 0 {
                quarter[r]
            } else {
                quarter[n / 4 - r]
            };
            if quad >= 2 {
                // The negated entry, brought back into the entry format
                // with its overflow mode (−(−1.0) does not fit I1F15).
                q.apply(-v, q.format().frac()).code
            } else {
                v
            }
        };
        let index = Format::new(false, t, narrow::<i32, _>(t)).expect("valid index format");
        let storage = |phase: u32| match organisation {
            Organisation::Full => None,
            Organisation::Quarter => Some(crate::datapath::QuarterWave {
                entries: quarter.clone(),
                phase,
            }),
        };
        let mk = |name: &'static str, exact: fn(f64) -> f64, codes: Vec<i128>| Table {
            name,
            index,
            out: q,
            exact,
            codes,
            storage: storage(u32::from(name == "cos")),
        };
        Ok(Tables {
            sin: mk(
                "sin",
                |x| (std::f64::consts::TAU * x).sin(),
                (0..n).map(sin_at).collect(),
            ),
            cos: mk(
                "cos",
                |x| (std::f64::consts::TAU * x).cos(),
                (0..n).map(|i| sin_at((i + n / 4) % n)).collect(),
            ),
            quarter,
            organisation,
        })
    }
    /// Entries the RTL stores per table.
    pub fn stored_entries(&self) -> usize {
        match self.organisation {
            Organisation::Full => self.sin.depth(),
            Organisation::Quarter => self.quarter.len(),
        }
    }
    /// Bits the RTL stores per table.
    pub fn stored_bits(&self) -> u64 {
        self.stored_entries() as u64 * u64::from(self.sin.out.format().width())
    }
}

/// The polar transform of a configuration.
#[derive(Clone, Debug)]
pub struct Polar {
    /// Angle format `U0F<angle_bits>`.
    pub angle: Quant,
    /// Angle → table index.
    pub index: Quant,
    /// `Lyz`.
    pub lyz: Quant,
    /// Output.
    pub out: Quant,
    /// The tables.
    pub tables: Tables,
}

/// Why a polar configuration is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PolarError {
    /// A table entry could not be converted.
    #[error(transparent)]
    Convert(#[from] ConvertError),
    /// Inconsistent bit counts or modes of field `key`.
    #[error("{why}")]
    Config {
        /// The field of `[polar]` at fault.
        key: &'static str,
        /// Why.
        why: String,
    },
}

impl Polar {
    /// From the `[polar]` section.
    ///
    /// # Errors
    ///
    /// [`PolarError::Config`] naming `table_bits` when it exceeds `angle_bits`, or `index` when its
    /// overflow mode is not `wrap`. ([`PolarError::Convert`] cannot arise: the entries are sines of
    /// finite angles.)
    ///
    /// # Panics
    ///
    /// If `u` lacks one of the `[polar]` fields read here or holds it as another kind, or its
    /// `angle_bits` or `table_bits` makes no valid format or table ([`Tables::build`]): never for
    /// the `[polar]` section of a [`Config`], where they lie in `4..=24` and `4..=16`.
    pub fn from_section(u: &PolarConfig) -> Result<Polar, PolarError> {
        let (k, t) = (u.angle_bits, u.table_bits);
        if t > k {
            return Err(PolarError::Config {
                key: "table_bits",
                why: format!("polar.table_bits = {t} exceeds polar.angle_bits = {k}"),
            });
        }
        let idx = u.index;
        if idx.overflow() != Overflow::Wrap {
            return Err(PolarError::Config {
                key: "index",
                why: "polar.index.overflow must be \"wrap\": angles wrap around a turn".into(),
            });
        }
        let angle = Quant::new(
            "angle",
            Format::new(false, k, narrow::<i32, _>(k)).expect("1..=24 bits"),
            idx.round(),
            Overflow::Wrap,
        );
        let index =
            idx.with_format(Format::new(false, t, narrow::<i32, _>(t)).expect("1..=16 bits"));
        Ok(Polar {
            angle,
            index,
            lyz: u.lyz,
            out: u.out,
            tables: Tables::build(t, u.table, u.organisation)?,
        })
    }

    /// From the `[polar]` section of `cfg`.
    ///
    /// # Errors
    ///
    /// As [`Polar::from_section`].
    pub fn from_config(cfg: &Config) -> Result<Polar, PolarError> {
        Self::from_section(&cfg.section())
    }

    /// The transform of `L = (α_L, β_L)` into the tangent frame of
    /// `N = (α_N, β_N)`; angles in the angle format.
    #[inline]
    pub fn transform<C: Datapath>(
        &self,
        cx: &mut C,
        a_l: C::V,
        b_l: C::V,
        a_n: C::V,
        b_n: C::V,
    ) -> [C::V; 3] {
        cx.enter(DECL.name);
        let t = self.terms(cx, a_l, b_l, a_n, b_n);
        let [y, z] = self.tilt(cx, t.s_al, t.lyz, t.c_an, t.s_an);
        cx.leave();
        [t.x, y, z]
    }

    /// The first part of [`Polar::transform`] (inside its unit scope): the
    /// three table indices, the six reads, `lyz = Q_lyz(cos α_L · cos Δβ)`
    /// and `x = Q_out(cos α_L · sin Δβ)`, `Δβ = β_L − β_N`. Everything here
    /// depends on `(α_L, Δβ)` alone or on `α_N` alone.
    #[inline]
    fn terms<C: Datapath>(
        &self,
        cx: &mut C,
        a_l: C::V,
        b_l: C::V,
        a_n: C::V,
        b_n: C::V,
    ) -> Terms<C::V> {
        let t = &self.tables;
        let i_al = cx.quantize(a_l, &self.index);
        let d = cx.sub(b_l, b_n);
        let i_d = cx.quantize(d, &self.index);
        let i_an = cx.quantize(a_n, &self.index);
        let (c_al, s_al) = (cx.table(&t.cos, i_al), cx.table(&t.sin, i_al));
        let (c_d, s_d) = (cx.table(&t.cos, i_d), cx.table(&t.sin, i_d));
        let (c_an, s_an) = (cx.table(&t.cos, i_an), cx.table(&t.sin, i_an));
        let lyz = cx.mul(c_al, c_d);
        let lyz = cx.quantize(lyz, &self.lyz);
        let x = cx.mul(c_al, s_d);
        let x = cx.quantize(x, &self.out);
        Terms {
            s_al,
            lyz,
            x,
            c_an,
            s_an,
        }
    }

    /// The second part of [`Polar::transform`]: the tilt by `α_N`,
    /// `y = Q_out(sin α_L · cos α_N − lyz · sin α_N)` and
    /// `z = Q_out(sin α_L · sin α_N + lyz · cos α_N)`, each exact before its
    /// one quantization.
    #[inline]
    fn tilt<C: Datapath>(
        &self,
        cx: &mut C,
        s_al: C::V,
        lyz: C::V,
        c_an: C::V,
        s_an: C::V,
    ) -> [C::V; 2] {
        let p = cx.mul(s_al, c_an);
        let q = cx.mul(lyz, s_an);
        let y = cx.sub(p, q);
        let y = cx.quantize(y, &self.out);
        let p = cx.mul(lyz, c_an);
        let z = cx.mul_add(s_al, s_an, p);
        let z = cx.quantize(z, &self.out);
        [y, z]
    }

    /// [`Polar::transform`]'s first part traced on its own (the same
    /// operations): inputs `a_l, b_l, a_n, b_n` (angle format), outputs
    /// `s_al, c_an, s_an` (table entry format), `lyz` (`lyz` format) and
    /// `x` (`out` format). With [`Polar::tilt_trace`], what an analysis
    /// runs when it holds `(α_L, Δβ)` or `α_N` fixed over many inputs:
    /// composing the two gives [`Polar::trace`]'s codes and overflows
    /// exactly, as every value passed between them is a quantized code.
    pub fn terms_trace(&self) -> Trace {
        let mut tr = Trace::new();
        let a = ["a_l", "b_l", "a_n", "b_n"].map(|n| tr.input_named(n, &self.angle));
        tr.enter(DECL.name);
        let t = self.terms(&mut tr, a[0], a[1], a[2], a[3]);
        tr.leave();
        tr.output("s_al", t.s_al);
        tr.output("lyz", t.lyz);
        tr.output("x", t.x);
        tr.output("c_an", t.c_an);
        tr.output("s_an", t.s_an);
        tr
    }

    /// [`Polar::transform`]'s second part traced on its own: inputs `s_al`,
    /// `c_an`, `s_an` (table entry format) and `lyz` (`lyz` format), in
    /// the order `s_al, lyz, c_an, s_an`; outputs `out_y, out_z`.
    pub fn tilt_trace(&self) -> Trace {
        let mut tr = Trace::new();
        let s_al = tr.input_named("s_al", &self.tables.sin.out);
        let lyz = tr.input_named("lyz", &self.lyz);
        let c_an = tr.input_named("c_an", &self.tables.cos.out);
        let s_an = tr.input_named("s_an", &self.tables.sin.out);
        tr.enter(DECL.name);
        let [y, z] = self.tilt(&mut tr, s_al, lyz, c_an, s_an);
        tr.leave();
        tr.output("out_y", y);
        tr.output("out_z", z);
        tr
    }

    /// Compiled for batches: inputs α_L, β_L, α_N, β_N codes; outputs L'.
    ///
    /// # Errors
    ///
    /// [`CompileError::Width`](crate::datapath::CompileError::Width) when an exact intermediate is
    /// wider than [`MAX_EXACT_WIDTH`](crate::datapath::MAX_EXACT_WIDTH).
    pub fn compile(&self) -> Result<Compiled, crate::datapath::CompileError> {
        self.trace().compile_outputs()
    }

    /// The unit traced with named ports: inputs `a_l, b_l, a_n, b_n`
    /// (angle format), outputs `out_x, out_y, out_z`.
    pub fn trace(&self) -> Trace {
        let mut tr = Trace::new();
        let a = ["a_l", "b_l", "a_n", "b_n"].map(|n| tr.input_named(n, &self.angle));
        let out = self.transform(&mut tr, a[0], a[1], a[2], a[3]);
        tr.output3("out", out);
        tr
    }

    /// One counting run.
    ///
    /// # Errors
    ///
    /// A [`ConvertError`] only for a NaN or infinite constant; its one constant is 0, so it never
    /// returns one.
    pub fn count(&self) -> Result<Count, ConvertError> {
        let mut cx = Count::new();
        let a = cx.constant(0.0, &self.angle)?;
        self.transform(&mut cx, a, a, a, a);
        Ok(cx)
    }
}

/// What [`Polar::transform`]'s first part hands its second: `sin α_L`,
/// `lyz`, `x` and the reads of `α_N`.
struct Terms<V> {
    s_al: V,
    lyz: V,
    x: V,
    c_an: V,
    s_an: V,
}

/// `(α, β)` of a unit vector, in turns: `α = asin y ∈ [−¼, ¼]`,
/// `β = atan2(x, z) ∈ (−½, ½]`; at the poles (`|y| ≥ 1 − 10⁻¹²`) `β = 0`.
pub fn angles_of(v: DVec3) -> (f64, f64) {
    let v = v.normalize();
    let a = v.y.clamp(-1.0, 1.0).asin() / std::f64::consts::TAU;
    let b = if v.y.abs() >= 1.0 - 1e-12 {
        0.0
    } else {
        v.x.atan2(v.z) / std::f64::consts::TAU
    };
    (a, b)
}

/// The unit vector of `(α, β)` in turns.
pub fn vector_of(a: f64, b: f64) -> DVec3 {
    let (a, b) = (a * std::f64::consts::TAU, b * std::f64::consts::TAU);
    DVec3::new(a.cos() * b.sin(), a.sin(), a.cos() * b.cos())
}

/// The implied tangent frame of the normal with azimuth `b_n` (turns):
/// `T = (cos β, 0, −sin β)`, `B = N × T`, `N`.
pub fn frame(n: DVec3, b_n: f64) -> (DVec3, DVec3, DVec3) {
    let b = b_n * std::f64::consts::TAU;
    let t = DVec3::new(b.cos(), 0.0, -b.sin());
    (t, n.cross(t), n)
}

/// The exact tangent-space vector: `(L·T, L·B, L·N)` in the implied frame
/// of `N = (α_N, β_N)` (angles in turns).
pub fn reference(a_l: f64, b_l: f64, a_n: f64, b_n: f64) -> DVec3 {
    let l = vector_of(a_l, b_l);
    let n = vector_of(a_n, b_n);
    let (t, b, n) = frame(n, b_n);
    DVec3::new(l.dot(t), l.dot(b), l.dot(n))
}

/// The conventional baseline on the datapath: `L' = normalize(M·L)` with
/// `M = [T; B; N]` given per pixel (9 multiplications and 6 additions for
/// the matrix, then an exact normalization: 6 multiplications, 2 additions,
/// a square root and a division).
///
/// # Panics
///
/// If `cx.constant` rejects the literal 1: never in the contexts of `fxshade-ir`, which reject only
/// NaN and ±∞.
pub fn tbn<C: Datapath>(
    cx: &mut C,
    q: &Quant,
    t: [C::V; 3],
    b: [C::V; 3],
    n: [C::V; 3],
    l: [C::V; 3],
) -> [C::V; 3] {
    let m = [cx.dot3(t, l), cx.dot3(b, l), cx.dot3(n, l)];
    let m = cx.quantize3(m, q);
    let d = cx.dot3(m, m);
    let s = cx.sqrt(d, q);
    let literal = Quant::new(
        "literal",
        Format::signed_int(8),
        crate::quantize::Rounding::Trunc,
        Overflow::Saturate,
    );
    let one = cx.constant(1.0, &literal).expect("1 is finite");
    let g = cx.div(one, s, q);
    let p = [cx.mul(m[0], g), cx.mul(m[1], g), cx.mul(m[2], g)];
    cx.quantize3(p, q)
}

fn check(cfg: &Config) -> Result<(), Vec<ConfigError>> {
    let u = cfg.unit(DECL.name);
    let p = Polar::from_config(cfg).map_err(|e| {
        let key = match &e {
            PolarError::Config { key, .. } => key,
            PolarError::Convert(_) => "table",
        };
        vec![crate::config::field_error(u, key, e.to_string())]
    })?;
    let cx = p
        .count()
        .map_err(|e| vec![crate::config::field_error(u, "table", e.to_string())])?;
    width_errors(&cx, u)
}

fn ops(cfg: &Config) -> Vec<OpReport> {
    let Ok(p) = Polar::from_config(cfg) else {
        return Vec::new();
    };
    let mut v = Vec::new();
    if let Ok(cx) = p.count() {
        v.push(OpReport::from_count(
            DECL.name,
            "polar",
            Phase::Pixel,
            &cx,
            Some(PaperClaim {
                mul: Some(6),
                add: Some(3),
                div: Some(0),
                sqrt: Some(0),
                table_read: Some(6),
                source: "polar paper: 6 mul, 3 add, 6 table reads",
            }),
        ));
    }
    let mut cx = Count::new();
    if let Ok(z) = cx.constant(0.0, &p.out) {
        tbn(&mut cx, &p.out, [z; 3], [z; 3], [z; 3], [z; 3]);
        v.push(OpReport::from_count(
            DECL.name,
            "tbn_baseline",
            Phase::Pixel,
            &cx,
            Some(PaperClaim {
                mul: Some(9),
                add: Some(6),
                div: None,
                sqrt: None,
                table_read: Some(0),
                source: "polar paper: 9 mul, 6 add plus a normalization",
            }),
        ));
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::datapath::{Fixed, Reference};

    fn polar() -> Polar {
        Polar::from_config(&Config::embedded()).unwrap()
    }

    /// `terms_trace` then `tilt_trace` give the whole transform's codes and
    /// per-stage overflow counts, on the default formats and on narrow ones
    /// (outputs of ±½, `lyz` of two fraction bits) that overflow and round
    /// often.
    #[test]
    fn the_two_parts_compose_into_the_transform() {
        let base = Config::embedded().section::<PolarConfig>();
        let narrow_out = PolarConfig {
            out: base.out.with_format(Format::new(true, 8, 8).unwrap()),
            lyz: base.lyz.with_format(Format::new(true, 4, 2).unwrap()),
            ..base
        };
        for (u, must_overflow) in [(base, false), (narrow_out, true)] {
            let p = Polar::from_section(&u).unwrap();
            let turn = 1u64 << p.angle.format().width();
            let mut rng = crate::sampling::Rng::new(11);
            let ins: Vec<Vec<i128>> = (0..4)
                .map(|_| (0..5000).map(|_| i128::from(rng.below(turn))).collect())
                .collect();
            let refs: Vec<&[i128]> = ins.iter().map(|v| v.as_slice()).collect();
            let (want, want_ov) = p.compile().unwrap().run_i128(&refs);
            let (t, t_ov) = p.terms_trace().compile_outputs().unwrap().run_i128(&refs);
            let (yz, yz_ov) = p
                .tilt_trace()
                .compile_outputs()
                .unwrap()
                .run_i128(&[&t[0], &t[1], &t[3], &t[4]]);
            assert_eq!([&t[2], &yz[0], &yz[1]], [&want[0], &want[1], &want[2]]);
            let per_stage = |ov: &[(&'static str, u64)], s: &str| -> u64 {
                ov.iter().filter(|(n, _)| *n == s).map(|(_, c)| c).sum()
            };
            for s in ["index", "lyz", "out"] {
                assert_eq!(
                    per_stage(&want_ov, s),
                    per_stage(&t_ov, s) + per_stage(&yz_ov, s),
                    "stage {s}"
                );
            }
            assert_eq!(per_stage(&want_ov, "out") > 0, must_overflow);
        }
    }

    #[test]
    fn counts_match_the_paper() {
        let r = ops(&Config::embedded());
        let c = &r.iter().find(|x| x.variant == "polar").unwrap().counts;
        assert_eq!((c.mul, c.add, c.table_read), (6, 3, 6));
        let b = &r
            .iter()
            .find(|x| x.variant == "tbn_baseline")
            .unwrap()
            .counts;
        assert_eq!((b.mul, b.add, b.sqrt, b.div), (15, 8, 1, 1));
    }

    #[test]
    fn the_datapath_in_f64_is_the_exact_frame() {
        let p = polar();
        let mut rng = crate::sampling::Rng::new(3);
        for _ in 0..1000 {
            let (al, bl) = angles_of(rng.direction());
            let (an, bn) = angles_of(rng.direction());
            let got = p.transform(&mut Reference, al, bl, an, bn);
            let want = reference(al, bl, an, bn);
            assert!((DVec3::from_array(got) - want).length() < 1e-12);
            // A rotation: unit length, N maps to +z.
            assert!((want.length() - 1.0).abs() < 1e-12);
            let nn = reference(an, bn, an, bn);
            assert!((nn - DVec3::Z).length() < 1e-12);
        }
    }

    #[test]
    fn full_and_quarter_tables_are_bit_identical() {
        for t in [4, 6, 10] {
            let q = Config::embedded().section::<PolarConfig>().table;
            let f = Tables::build(t, q, Organisation::Full).unwrap();
            let h = Tables::build(t, q, Organisation::Quarter).unwrap();
            assert_eq!(f.sin.codes, h.sin.codes);
            assert_eq!(f.cos.codes, h.cos.codes);
            assert_eq!(h.stored_entries(), (1 << t) / 4 + 1);
            // Entries are the quantized exact values, by symmetry.
            for (i, &c) in f.sin.codes.iter().enumerate() {
                let exact = (std::f64::consts::TAU * i as f64 / (1 << t) as f64).sin();
                assert!((q.format().to_f64(c) - exact).abs() <= q.format().ulp() / 2.0 + 1e-15);
            }
        }
    }

    #[test]
    fn poles_and_wrap_around() {
        // Poles: β defined as 0, the frame T = (1, 0, 0), still a rotation.
        for y in [1.0, -1.0] {
            let (a, b) = angles_of(DVec3::new(0.0, y, 0.0));
            assert_eq!(b, 0.0);
            assert!((a.abs() - 0.25).abs() < 1e-15);
            let (t, bb, n) = frame(DVec3::new(0.0, y, 0.0), b);
            assert!(
                (t - DVec3::X).length() < 1e-15
                    && (bb.length() - 1.0).abs() < 1e-15
                    && n.dot(t).abs() < 1e-15
            );
            let l = reference(0.1, 0.2, a, b);
            assert!((l.length() - 1.0).abs() < 1e-12);
        }
        // Wrap: β_N just below a full turn and β_L just above zero transform
        // exactly like the same difference away from the seam.
        let p = polar();
        let f = p.angle.format();
        let turn = 1i128 << f.width();
        let mut fx = Fixed::<i128>::new();
        let mut run = |bl: i128, bn: i128| {
            let v = [300, bl, 120, bn].map(|c| crate::datapath::Fx::from_code(c, f));
            p.transform(&mut fx, v[0], v[1], v[2], v[3])
                .map(|x| x.code())
        };
        assert_eq!(run(5, turn - 3), run(108, 100));
        let t = |c: i128| c as f64 / turn as f64;
        let seam = reference(t(300), t(5), t(120), t(turn - 3) - 1.0);
        let plain = reference(t(300), t(108), t(120), t(100));
        assert!((seam - plain).length() < 1e-12);
    }
}
