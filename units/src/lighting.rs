//! The lighting stage: diffuse `I0·km·max(0, N·L)` plus Blinn–Phong
//! specular `I0·ks·max(0, N·H)^n`, as an 8-bit level (`255·I`, clipped to
//! `0 ..= 255` by the `level` format).
//!
//! Diffuse only ([`Lighting::diffuse`], used by the unit error analyses):
//!
//! ```text
//! dot   = Q_dot(Nx·Lx + Ny·Ly + Nz·Lz)
//! level = Q_level(max(dot, 0) · Q_gain(255·I0·km))
//! ```
//!
//! Diffuse and specular ([`Lighting::shade`], the pipeline's last unit):
//!
//! ```text
//! dl    = max(Q_dot(N·L), 0)          dh = max(Q_dot(N·H), 0)
//! s     = Q_spec(dh)^n                by squaring and multiplying, LSB of n first,
//!                                     every product quantized with Q_spec
//! level = Q_level(dl · Q_gain(255·I0·km) + s · Q_gain(255·I0·ks))
//! ```
//!
//! The power takes `⌊log2 n⌋` squarings and `popcount(n) − 1` multiplications
//! (the first set bit copies the base): for `n = 16`, 4 squarings. The RTL
//! (`rtl/lighting.v`) has one pipeline stage per bit of `n`.

use crate::config::{Config, FieldDecl, FieldKind, UnitDecl};
use crate::datapath::{Count, Datapath};
use crate::format::ConvertError;
use crate::quantize::Quant;
use crate::units::{width_errors, OpReport, Phase};

/// Largest 8-bit level.
pub const LEVELS: f64 = 255.0;

/// The `[lighting]` configuration section.
pub static DECL: UnitDecl = UnitDecl {
    name: "lighting",
    doc: "diffuse term I0·km·max(0, N·L) as an 8-bit level",
    fields: &[
        FieldDecl {
            name: "normal",
            kind: FieldKind::Stage,
            doc: "input port: components of the unit normal N",
        },
        FieldDecl {
            name: "light",
            kind: FieldKind::Stage,
            doc: "input port: components of the unit light vector L",
        },
        FieldDecl {
            name: "dot",
            kind: FieldKind::Stage,
            doc: "N·L after quantization",
        },
        FieldDecl {
            name: "gain",
            kind: FieldKind::Stage,
            doc: "register holding the constant 255·I0·km",
        },
        FieldDecl {
            name: "level",
            kind: FieldKind::Stage,
            doc: "output: the 8-bit intensity level",
        },
        FieldDecl {
            name: "spec",
            kind: FieldKind::Stage,
            doc: "specular power chain: max(0, N·H) and every product of (N·H)^n",
        },
        FieldDecl {
            name: "i0_km",
            kind: FieldKind::Number { min: 0.0, max: 1.0 },
            doc: "I0·km: light intensity times the material's diffuse coefficient",
        },
        FieldDecl {
            name: "i0_ks",
            kind: FieldKind::Number { min: 0.0, max: 1.0 },
            doc: "I0·ks: light intensity times the material's specular coefficient",
        },
        FieldDecl {
            name: "shininess",
            kind: FieldKind::Integer { min: 1, max: 255 },
            doc: "Blinn–Phong exponent n of max(0, N·H)^n",
        },
    ],
    groups: &[
        ("normals", &["normal"]),
        ("light", &["light"]),
        ("shading", &["dot", "spec"]),
        ("level", &["level"]),
    ],
};

/// The lighting stage as a registered unit.
pub struct LightingUnit;

crate::unit!(LightingUnit, decl: DECL, section: Lighting, check: check, ops: ops,
    rtl: &[&RTL]);

/// The registry entry.
pub static UNIT: LightingUnit = LightingUnit;

/// The unit's generated RTL: variants, design and input vectors.
pub static RTL: crate::rtl::units::RtlUnit = crate::rtl::units::RtlUnit {
    name: "lighting",
    doc: "diffuse (i0_ks = 0) or diffuse + Blinn-Phong specular shading to a level",
    variants: &[
        ("diffuse", "lighting.i0_ks=0"),
        ("diffuse+specular", "lighting.i0_ks=0.25"),
    ],
    build: crate::lighting::rtl::design,
    inputs: crate::lighting::rtl::inputs,
};

/// The lighting stage's formats and constants: the `[lighting]` section,
/// typed (one field per declared field).
#[derive(Clone, Copy, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Lighting {
    /// Input port of N's components.
    pub normal: Quant,
    /// Input port of L's components.
    pub light: Quant,
    /// `N·L`.
    pub dot: Quant,
    /// The constant `255·I0·km`.
    pub gain: Quant,
    /// The output level.
    pub level: Quant,
    /// The specular power chain.
    pub spec: Quant,
    /// `I0·km`.
    pub i0_km: f64,
    /// `I0·ks`.
    pub i0_ks: f64,
    /// The Blinn–Phong exponent `n ≥ 1`.
    pub shininess: u32,
}

impl crate::config::Section for Lighting {
    const DECL: &'static crate::config::UnitDecl = &DECL;
}

/// Why the lighting stage could not be compiled.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LightingError {
    /// A constant could not be converted.
    #[error(transparent)]
    Convert(#[from] ConvertError),
    /// The datapath is too wide.
    #[error(transparent)]
    Compile(#[from] crate::datapath::CompileError),
}

/// Per-batch constants of the lighting stage in a context.
#[derive(Clone, Copy, Debug)]
pub struct Consts<V> {
    /// `255·I0·km` in the `gain` format.
    pub gain: V,
    /// `255·I0·ks` in the `gain` format.
    pub gain_s: V,
    /// Zero, for the clamp.
    pub zero: V,
}

impl Lighting {
    /// From the `[lighting]` section of `cfg`.
    pub fn from_config(cfg: &Config) -> Self {
        cfg.section()
    }

    /// Load the constants into a context (once per batch).
    ///
    /// # Errors
    ///
    /// The [`ConvertError`] of `cx.constant` when `255·i0_km` or `255·i0_ks` is NaN or infinite;
    /// never for a [`Lighting`] of a configuration, where both lie in `0..=1`.
    pub fn consts<C: Datapath>(&self, cx: &mut C) -> Result<Consts<C::V>, ConvertError> {
        Ok(Consts {
            gain: cx.constant(LEVELS * self.i0_km, &self.gain)?,
            gain_s: cx.constant(LEVELS * self.i0_ks, &self.gain)?,
            zero: cx.constant(0.0, &self.dot)?,
        })
    }

    /// The diffuse level `Q_level(max(Q_dot(N·L), 0) · gain)`.
    #[inline]
    pub fn diffuse<C: Datapath>(
        &self,
        cx: &mut C,
        k: &Consts<C::V>,
        n: [C::V; 3],
        l: [C::V; 3],
    ) -> C::V {
        cx.enter(DECL.name);
        let d = cx.dot3(n, l);
        let d = cx.quantize(d, &self.dot);
        let d = cx.max(d, k.zero);
        let lvl = cx.mul(d, k.gain);
        let out = cx.quantize(lvl, &self.level);
        cx.leave();
        out
    }

    /// `max(Q_dot(a·b), 0)`.
    #[inline]
    fn clamped_dot<C: Datapath>(
        &self,
        cx: &mut C,
        k: &Consts<C::V>,
        a: [C::V; 3],
        b: [C::V; 3],
    ) -> C::V {
        let d = cx.dot3(a, b);
        let d = cx.quantize(d, &self.dot);
        cx.max(d, k.zero)
    }

    /// `x^n` by squaring and multiplying, LSB of `n` first, every product
    /// quantized with `Q_spec`; `x` is quantized with `Q_spec` first. The
    /// first set bit copies the base (no multiplication).
    ///
    /// # Panics
    ///
    /// Never: the exponent `max(shininess, 1)` has a set bit, which sets the result.
    #[inline]
    pub fn power<C: Datapath>(&self, cx: &mut C, x: C::V) -> C::V {
        let mut base = cx.quantize(x, &self.spec);
        let mut acc = None;
        let mut e = self.shininess.max(1);
        loop {
            if e & 1 == 1 {
                acc = Some(match acc {
                    None => base,
                    Some(a) => {
                        let p = cx.mul(a, base);
                        cx.quantize(p, &self.spec)
                    }
                });
            }
            e >>= 1;
            if e == 0 {
                break;
            }
            let sq = cx.mul(base, base);
            base = cx.quantize(sq, &self.spec);
        }
        acc.expect("n >= 1 has a set bit")
    }

    /// Diffuse and specular:
    /// `Q_level(max(Q_dot(N·L), 0)·gain + Q_spec(max(Q_dot(N·H), 0))^n·gain_s)`.
    /// With `i0_ks = 0` the specular term is exactly zero, so this is
    /// [`Lighting::diffuse`] (the same codes, without the power chain).
    #[inline]
    pub fn shade<C: Datapath>(
        &self,
        cx: &mut C,
        k: &Consts<C::V>,
        n: [C::V; 3],
        l: [C::V; 3],
        h: [C::V; 3],
    ) -> C::V {
        if self.i0_ks == 0.0 {
            return self.diffuse(cx, k, n, l);
        }
        cx.enter(DECL.name);
        let dl = self.clamped_dot(cx, k, n, l);
        let dh = self.clamped_dot(cx, k, n, h);
        let s = self.power(cx, dh);
        let d = cx.mul(dl, k.gain);
        let t = cx.mul_add(s, k.gain_s, d);
        let out = cx.quantize(t, &self.level);
        cx.leave();
        out
    }

    /// The unit traced with named ports: inputs `n`, `l`, `h` (`_x, _y, _z`
    /// each; normal and light formats), output `level`. Diffuse only when
    /// `i0_ks = 0` (then `h` is not read).
    ///
    /// # Errors
    ///
    /// [`LightingError::Convert`] when `255·i0_km` or `255·i0_ks` is NaN or infinite
    /// ([`Lighting::consts`]).
    pub fn trace(&self) -> Result<crate::datapath::Trace, LightingError> {
        let mut tr = crate::datapath::Trace::new();
        let n = tr.input3("n", &self.normal);
        let l = tr.input3("l", &self.light);
        let h = tr.input3("h", &self.light);
        let k = self.consts(&mut tr)?;
        let lvl = self.shade(&mut tr, &k, n, l, h);
        tr.output("level", lvl);
        Ok(tr)
    }

    /// Number of pipeline stages of the power chain: the bit length of `n`.
    pub fn power_stages(&self) -> u32 {
        32 - self.shininess.max(1).leading_zeros()
    }

    /// Compiled for batches: inputs the normal's three components, then the
    /// light vector's; output the level.
    ///
    /// # Errors
    ///
    /// [`LightingError::Convert`] as [`Lighting::trace`]; [`LightingError::Compile`] when the
    /// diffuse datapath does not compile (an exact intermediate wider than
    /// [`MAX_EXACT_WIDTH`](crate::datapath::MAX_EXACT_WIDTH)).
    pub fn compile(&self) -> Result<crate::datapath::Compiled, LightingError> {
        let mut tr = crate::datapath::Trace::new();
        let n = [
            tr.input(&self.normal),
            tr.input(&self.normal),
            tr.input(&self.normal),
        ];
        let l = [
            tr.input(&self.light),
            tr.input(&self.light),
            tr.input(&self.light),
        ];
        let k = self.consts(&mut tr)?;
        let lvl = self.diffuse(&mut tr, &k, n, l);
        Ok(crate::datapath::Compiled::compile(&tr, &[lvl])?)
    }

    /// [`Lighting::shade`] compiled for batches: inputs N, L, H (three
    /// components each); output the level.
    ///
    /// # Errors
    ///
    /// [`LightingError::Convert`] as [`Lighting::trace`]; [`LightingError::Compile`] when the
    /// shading datapath does not compile (an exact intermediate wider than
    /// [`MAX_EXACT_WIDTH`](crate::datapath::MAX_EXACT_WIDTH)).
    pub fn compile_shade(&self) -> Result<crate::datapath::Compiled, LightingError> {
        let mut tr = crate::datapath::Trace::new();
        let n = [0; 3].map(|_| tr.input(&self.normal));
        let l = [0; 3].map(|_| tr.input(&self.light));
        let h = [0; 3].map(|_| tr.input(&self.light));
        let k = self.consts(&mut tr)?;
        let lvl = self.shade(&mut tr, &k, n, l, h);
        Ok(crate::datapath::Compiled::compile(&tr, &[lvl])?)
    }

    /// [`Lighting::shade`] once in the counting context.
    ///
    /// # Panics
    ///
    /// If `255·i0_km` or `255·i0_ks` is NaN or infinite ([`Lighting::consts`]): never for a
    /// [`Lighting`] of a configuration.
    pub fn count_shade(&self) -> Count {
        let mut cx = Count::new();
        let k = self.consts(&mut cx).expect("finite constants");
        let n = [cx.constant(0.0, &self.normal).expect("finite"); 3];
        let l = [cx.constant(0.0, &self.light).expect("finite"); 3];
        self.shade(&mut cx, &k, n, l, l);
        cx
    }

    /// Run once in the counting context.
    ///
    /// # Panics
    ///
    /// If `255·i0_km` or `255·i0_ks` is NaN or infinite ([`Lighting::consts`]): never for a
    /// [`Lighting`] of a configuration.
    pub fn count(&self) -> Count {
        let mut cx = Count::new();
        let k = self.consts(&mut cx).expect("finite constants");
        let n = [cx.constant(0.0, &self.normal).expect("finite"); 3];
        let l = [cx.constant(0.0, &self.light).expect("finite"); 3];
        self.diffuse(&mut cx, &k, n, l);
        cx
    }
}

fn check(cfg: &Config) -> Result<(), Vec<crate::config::ConfigError>> {
    let u = cfg.unit(DECL.name);
    let l = Lighting::from_config(cfg);
    width_errors(&l.count(), u)?;
    width_errors(&l.count_shade(), u)
}

fn ops(cfg: &Config) -> Vec<OpReport> {
    let l = Lighting::from_config(cfg);
    vec![
        OpReport::from_count(DECL.name, "diffuse", Phase::Pixel, &l.count(), None),
        OpReport::from_count(
            DECL.name,
            "diffuse+specular",
            Phase::Pixel,
            &l.count_shade(),
            None,
        ),
    ]
}

/// The lighting unit's RTL side: its traced design and input vectors.
pub mod rtl {
    use super::{Lighting, DECL};
    use crate::config::Config;
    use crate::rtl::units::Part;
    use crate::rtl::units::{structured_code, RtlError};
    use crate::sampling::Rng;
    use glam::DVec3;

    /// The unit's traced datapath: diffuse, or diffuse + specular.
    ///
    /// # Errors
    ///
    /// [`RtlError::Lighting`] as [`Lighting::trace`]: never for a configuration, whose `i0_km` and
    /// `i0_ks` lie in `0..=1`.
    pub fn design(cfg: &Config) -> Result<crate::rtl::Design, RtlError> {
        let l = Lighting::from_config(cfg);
        let variant = if l.i0_ks == 0.0 {
            "diffuse"
        } else {
            "diffuse+specular"
        };
        let notes = vec![format!(
            "I0·km = {}, I0·ks = {}, shininess {}",
            l.i0_km, l.i0_ks, l.shininess
        )];
        Ok(crate::rtl::units::design(
            DECL.name,
            variant,
            l.trace()?,
            cfg,
            notes,
        ))
    }

    /// Input vectors: extreme codes and perpendicular or opposite vectors,
    /// then random unit N, L, H (N within 60° of L half the time), then
    /// structured random codes.
    ///
    /// # Errors
    ///
    /// Never (the `Result` is that of `RtlUnit::inputs`).
    pub fn inputs(
        cfg: &Config,
        part: crate::rtl::units::Part,
        seed: u64,
    ) -> Result<Vec<Vec<i128>>, RtlError> {
        let l = Lighting::from_config(cfg);
        let (fnm, fl) = (l.normal.format(), l.light.format());
        let qn = |v: DVec3| {
            v.to_array()
                .map(|x| l.normal.apply_f64(x).map_or(0, |r| r.code))
        };
        let ql = |v: DVec3| {
            v.to_array()
                .map(|x| l.light.apply_f64(x).map_or(0, |r| r.code))
        };
        let row = |n: [i128; 3], a: [i128; 3], b: [i128; 3]| [n, a, b].concat();
        let mut rows = Vec::new();
        let (z, x, y) = (DVec3::Z, DVec3::X, DVec3::Y);
        rows.push(row(qn(z), ql(z), ql(z)));
        rows.push(row(qn(z), ql(x), ql(y)));
        rows.push(row(qn(z), ql(-z), ql(-z)));
        rows.push(row(
            [fnm.max_code(); 3],
            [fl.max_code(); 3],
            [fl.max_code(); 3],
        ));
        rows.push(row(
            [fnm.min_code(); 3],
            [fl.min_code(); 3],
            [fl.min_code(); 3],
        ));
        rows.push(row(
            [fnm.max_code(); 3],
            [fl.min_code(); 3],
            [fl.max_code(); 3],
        ));
        let Part::Random(count) = part else {
            return Ok(rows);
        };
        rows.clear();
        let mut rng = Rng::new(seed);
        while rows.len() < count {
            if rows.len() % 2 == 0 {
                let lv = rng.direction();
                let n = rng.in_cone(lv, 0.5);
                let h = (lv + rng.in_cone(n, 0.3)).normalize_or(DVec3::Z);
                rows.push(row(qn(n), ql(lv), ql(h)));
            } else {
                let mut r: Vec<i128> = (0..3).map(|_| structured_code(fnm, &mut rng)).collect();
                r.extend((0..6).map(|_| structured_code(fl, &mut rng)));
                rows.push(r);
            }
        }
        Ok(rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::datapath::{Fixed, Reference};

    #[test]
    fn fixed_diffuse_tracks_the_reference_within_one_level() {
        let l = Lighting::from_config(&Config::embedded());
        let mut fx = Fixed::<i128>::new();
        let kf = l.consts(&mut fx).unwrap();
        let mut rf = Reference;
        let kr = l.consts(&mut rf).unwrap();
        for i in 0..200 {
            let t = i as f64 * 0.0314;
            let n = [t.sin() * 0.6, 0.8, t.cos() * 0.6];
            let lv = [0.0, (t * 0.7).cos(), (t * 0.7).sin()];
            let nq = n.map(|x| fx.constant(x, &l.normal).unwrap());
            let lq = lv.map(|x| fx.constant(x, &l.light).unwrap());
            let got = l.diffuse(&mut fx, &kf, nq, lq);
            let want = l.diffuse(&mut rf, &kr, n, lv);
            let want_closed =
                255.0 * l.i0_km * (n[0] * lv[0] + n[1] * lv[1] + n[2] * lv[2]).max(0.0);
            assert!((want - want_closed).abs() < 1e-9);
            assert!(
                (got.to_f64() - want).abs() <= 1.0,
                "{i}: {} vs {want}",
                got.to_f64()
            );
        }
    }
}
