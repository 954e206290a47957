//! The lighting stage: the diffuse term `I = I0·km·max(0, N·L)` as an 8-bit
//! level (`255·I`, clipped to `0 ..= 255` by the `level` format).
//!
//! Datapath (3 multiplications and 2 additions for `N·L`, one comparison
//! for the clamp at zero, one multiplication by the constant `255·I0·km`):
//!
//! ```text
//! dot   = Q_dot(Nx·Lx + Ny·Ly + Nz·Lz)
//! level = Q_level(max(dot, 0) · Q_gain(255·I0·km))
//! ```

use crate::config::{Config, FieldDecl, FieldKind, UnitConfig, UnitDecl};
use crate::datapath::{Count, Datapath};
use crate::format::ConvertError;
use crate::quantize::Quant;
use crate::units::{width_errors, OpReport, Phase, UnitEntry};

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
            name: "i0_km",
            kind: FieldKind::Number { min: 0.0, max: 1.0 },
            doc: "I0·km: light intensity times the material's diffuse coefficient",
        },
    ],
};

/// The registry entry.
pub static UNIT: UnitEntry = UnitEntry {
    decl: &DECL,
    check,
    ops,
};

/// The lighting stage's formats and constants, resolved from a configuration.
#[derive(Clone, Copy, Debug)]
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
    /// `I0·km`.
    pub i0_km: f64,
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
    /// Zero, for the clamp.
    pub zero: V,
}

impl Lighting {
    /// From the `[lighting]` section.
    pub fn from_config(u: &UnitConfig) -> Self {
        Lighting {
            normal: u.stage("normal"),
            light: u.stage("light"),
            dot: u.stage("dot"),
            gain: u.stage("gain"),
            level: u.stage("level"),
            i0_km: u.number("i0_km"),
        }
    }

    /// Load the constants into a context (once per batch).
    pub fn consts<C: Datapath>(&self, cx: &mut C) -> Result<Consts<C::V>, ConvertError> {
        Ok(Consts {
            gain: cx.constant(LEVELS * self.i0_km, &self.gain)?,
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
        let d = cx.dot3(n, l);
        let d = cx.quantize(d, &self.dot);
        let d = cx.max(d, k.zero);
        let lvl = cx.mul(d, k.gain);
        cx.quantize(lvl, &self.level)
    }

    /// Compiled for batches: inputs the normal's three components, then the
    /// light vector's; output the level.
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

    /// Run once in the counting context.
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
    width_errors(&Lighting::from_config(u).count(), u)
}

fn ops(cfg: &Config) -> Vec<OpReport> {
    let l = Lighting::from_config(cfg.unit(DECL.name));
    vec![OpReport::from_count(
        DECL.name,
        "diffuse",
        Phase::Pixel,
        &l.count(),
        None,
    )]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::datapath::{Fixed, Reference};

    #[test]
    fn fixed_diffuse_tracks_the_reference_within_one_level() {
        let l = Lighting::from_config(Config::embedded().unit("lighting"));
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
            let want_closed = 255.0 * (n[0] * lv[0] + n[1] * lv[1] + n[2] * lv[2]).max(0.0);
            assert!((want - want_closed).abs() < 1e-9);
            assert!(
                (got.to_f64() - want).abs() <= 1.0,
                "{i}: {} vs {want}",
                got.to_f64()
            );
        }
    }
}
