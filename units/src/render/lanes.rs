//! The renderer's f64 work on fragments of one triangle, lane by lane.
//!
//! Per fragment a render computes in f64 the smooth path's reference (the
//! interpolated normal, normalized, shaded: [`super::shade_f64`]) and the
//! exactly interpolated normal in the mesh's frame (the polar-cap test and
//! the mapped references read it). [`Lanes::run`] computes both for up to
//! [`LANES`] fragments of one triangle at once: the same IEEE operations
//! in the same order as [`interp::field`], glam's `normalize` and
//! [`super::shade_f64`] (whose `powi` is the square-and-multiply of
//! `__powidf2`), written over arrays so that they compile to vector
//! instructions ([`Isa::run`]: the widest the CPU has). The results are
//! the scalar ones bit for bit; a unit test holds them equal on every
//! instruction set the machine has.
//!
//! The same call quantizes `c1, c2` to the barycentric format
//! ([`Quant::codes_f64_i64`], inlined here so that it runs in the same
//! vector instructions): the codes of [`Quant::apply_f64`].
//!
//! [`interp::field`]: crate::interp::field

use glam::DVec3;

use crate::datapath::{Isa, Kernel};
use crate::interp::{Scheme, Triangle, PAIRS};
use crate::lighting::{Lighting, LEVELS};
use crate::quantize::Quant;

/// Fragments per call of [`Lanes::run`].
pub(super) const LANES: usize = 64;

/// Three coordinates, each over the lanes.
type Vec3Lanes = [[f64; LANES]; 3];

/// Inputs and results of [`Lanes::run`].
pub(super) struct Lanes {
    /// Lanes in use.
    pub len: usize,
    /// The fragments' barycentrics `c1, c2, c3`.
    pub c: Vec3Lanes,
    /// The smooth path's f64 reference level.
    pub smooth_ref: [f64; LANES],
    /// The normal interpolated in the mesh's frame, normalized.
    pub n_obj: Vec3Lanes,
    /// `c1, c2` quantized ([`Lanes::run`] with a format).
    pub codes: [[i64; LANES]; 2],
    /// Scratch: the camera-frame normal, the power's base and product,
    /// reciprocal lengths.
    n: Vec3Lanes,
    w: [[f64; LANES]; 6],
    base: [f64; LANES],
    pow: [f64; LANES],
    r: [f64; LANES],
}

/// The lighting constants [`super::shade_f64`] reads.
#[derive(Clone, Copy)]
pub(super) struct Shade {
    km: f64,
    ks: f64,
    shininess: u32,
    l: DVec3,
    h: DVec3,
}

impl Shade {
    /// `light`'s constants with the light and half vectors `l`, `h`.
    pub fn new(light: &Lighting, l: DVec3, h: DVec3) -> Shade {
        Shade {
            km: light.i0_km,
            ks: light.i0_ks,
            shininess: light.shininess,
            l,
            h,
        }
    }
}

impl Lanes {
    /// No lanes in use.
    pub fn new() -> Box<Lanes> {
        Box::new(Lanes {
            len: 0,
            c: [[0.0; LANES]; 3],
            smooth_ref: [0.0; LANES],
            n_obj: [[0.0; LANES]; 3],
            codes: [[0; LANES]; 2],
            n: [[0.0; LANES]; 3],
            w: [[0.0; LANES]; 6],
            base: [0.0; LANES],
            pow: [0.0; LANES],
            r: [0.0; LANES],
        })
    }

    /// For lanes `0..len` (their barycentrics in [`Lanes::c`]): the
    /// smooth reference of the camera-frame triangle `smooth` and the
    /// normalized normal of the mesh-frame triangle `object`; with `bary`
    /// (a format of at most 62 bits), `c1, c2` quantized to it into
    /// [`Lanes::codes`] (0 for NaN or ±∞).
    pub fn run(
        &mut self,
        scheme: Scheme,
        smooth: &Triangle,
        object: &Triangle,
        shade: Shade,
        bary: Option<&Quant>,
    ) {
        Isa::current().run(Run {
            lanes: self,
            scheme,
            smooth,
            object,
            shade,
            bary,
        });
    }
}

struct Run<'a> {
    lanes: &'a mut Lanes,
    scheme: Scheme,
    smooth: &'a Triangle,
    object: &'a Triangle,
    shade: Shade,
    bary: Option<&'a Quant>,
}

impl Kernel for Run<'_> {
    type Output = ();

    #[inline(always)]
    fn call(self) {
        let Run {
            lanes,
            scheme,
            smooth,
            object,
            shade,
            bary,
        } = self;
        // Whole vectors of lanes: those past `len` compute on stale
        // barycentrics and are never read.
        let len = lanes.len.next_multiple_of(8).min(LANES);
        let l = &mut *lanes;
        weights(scheme, &l.c, len, &mut l.w);
        field(smooth, scheme, &l.w, len, &mut l.n);
        normalize(&mut l.n, &mut l.r, len);
        shade_lanes(&l.n, shade, len, &mut l.base, &mut l.pow, &mut l.smooth_ref);
        field(object, scheme, &l.w, len, &mut l.n_obj);
        normalize(&mut l.n_obj, &mut l.r, len);
        if let Some(q) = bary {
            for (c, codes) in l.c.iter().zip(&mut l.codes) {
                q.codes_f64_i64(&c[..len], 0, &mut codes[..len]);
            }
        }
    }
}

/// The interpolation weights of each lane: `c_i` (linear), or
/// `c_i(2c_i − 1)` and `4c_i·c_j` for the pairs `(1,2), (2,3), (3,1)`
/// (quadratic), each computed as [`crate::interp::field`] does.
#[inline(always)]
fn weights(scheme: Scheme, c: &Vec3Lanes, len: usize, w: &mut [[f64; LANES]; 6]) {
    let len = len.min(LANES);
    match scheme {
        Scheme::Linear => {
            for (w, c) in w.iter_mut().zip(c) {
                w[..len].copy_from_slice(&c[..len]);
            }
        }
        Scheme::Quadratic => {
            for i in 0..3 {
                for j in 0..len {
                    let ci = c[i][j];
                    w[i][j] = ci * (2.0 * ci - 1.0);
                }
            }
            for (m, &(a, b)) in PAIRS.iter().enumerate() {
                for j in 0..len {
                    w[3 + m][j] = 4.0 * c[a][j] * c[b][j];
                }
            }
        }
    }
}

/// [`crate::interp::field`] per lane from the [`weights`]: `Σ N_i·c_i`
/// (linear, summed left to right), or `Σ N_i·c_i(2c_i − 1) + Σ N_ij·4c_i c_j`
/// (quadratic, accumulated from zero in the same order).
#[inline(always)]
fn field(t: &Triangle, scheme: Scheme, w: &[[f64; LANES]; 6], len: usize, out: &mut Vec3Lanes) {
    let len = len.min(LANES);
    for (k, o) in out.iter_mut().enumerate() {
        let [a0, a1, a2] = t.n.map(|n| n[k]);
        match scheme {
            Scheme::Linear => {
                for j in 0..len {
                    o[j] = a0 * w[0][j] + a1 * w[1][j] + a2 * w[2][j];
                }
            }
            Scheme::Quadratic => {
                let [b0, b1, b2] = t.mid.map(|n| n[k]);
                for j in 0..len {
                    let mut v = 0.0;
                    v += a0 * w[0][j];
                    v += a1 * w[1][j];
                    v += a2 * w[2][j];
                    v += b0 * w[3][j];
                    v += b1 * w[4][j];
                    v += b2 * w[5][j];
                    o[j] = v;
                }
            }
        }
    }
}

/// glam's `normalize` per lane: `v · (1 / √(v·v))`, `v·v` summed x, y, z.
#[inline(always)]
fn normalize(v: &mut Vec3Lanes, r: &mut [f64; LANES], len: usize) {
    for (j, r) in r[..len].iter_mut().enumerate() {
        let d = v[0][j] * v[0][j] + v[1][j] * v[1][j] + v[2][j] * v[2][j];
        *r = 1.0 / d.sqrt();
    }
    for v in v.iter_mut() {
        for (x, r) in v[..len].iter_mut().zip(r.iter()) {
            *x *= r;
        }
    }
}

/// [`super::shade_f64`] per lane: `255·(km·max(0, n·l) + ks·max(0, n·h)^e)`,
/// clipped, the power by `__powidf2`'s square-and-multiply (the factor
/// multiplied in for each set bit of `e`, lowest first, then squared).
#[inline(always)]
fn shade_lanes(
    n: &Vec3Lanes,
    s: Shade,
    len: usize,
    base: &mut [f64; LANES],
    pow: &mut [f64; LANES],
    out: &mut [f64; LANES],
) {
    let dot = |v: DVec3, j: usize| n[0][j] * v.x + n[1][j] * v.y + n[2][j] * v.z;
    pow[..len].fill(1.0);
    for (j, b) in base[..len].iter_mut().enumerate() {
        *b = dot(s.h, j).max(0.0);
    }
    let mut e = s.shininess;
    loop {
        if e & 1 != 0 {
            for (p, b) in pow[..len].iter_mut().zip(base.iter()) {
                *p *= b;
            }
        }
        e >>= 1;
        if e == 0 {
            break;
        }
        for b in &mut base[..len] {
            *b *= *b;
        }
    }
    for (j, o) in out[..len].iter_mut().enumerate() {
        let d = dot(s.l, j).max(0.0);
        *o = (LEVELS * (s.km * d + s.ks * pow[j])).clamp(0.0, 255.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// Every lane equals the scalar computation bit for bit (the
    /// interpolation, glam's normalization, `shade_f64` with `powi`), for
    /// both schemes, exponents with few and many bits, partial lane
    /// counts, and barycentrics with negative weights, on every
    /// instruction set this machine has.
    #[test]
    fn lanes_equal_the_scalar_references_bit_for_bit() {
        let mut rng = Rng::new(7);
        let unit = |rng: &mut Rng| {
            DVec3::new(
                rng.uniform(-1.0, 1.0),
                rng.uniform(-1.0, 1.0),
                rng.uniform(-1.0, 1.0),
            )
            .normalize()
        };
        let cfg = crate::config::Config::embedded();
        let mut light = Lighting::from_config(&cfg);
        // Barycentric formats: the default's, and every mode.
        let mut quants = vec![
            crate::pipeline::Pipeline::with_method(&cfg, crate::normalizer::Method::None)
                .unwrap()
                .interp
                .bary,
        ];
        for round in crate::quantize::Rounding::ALL {
            for ov in [
                crate::quantize::Overflow::Wrap,
                crate::quantize::Overflow::Saturate,
            ] {
                let f = crate::format::Format::new(true, 12, 9).unwrap();
                quants.push(Quant::new("c", f, round, ov));
            }
        }
        for isa in Isa::ALL.into_iter().filter(|i| i.available()) {
            for (case, e) in [1u32, 2, 7, 16, 32, 255].into_iter().enumerate() {
                light.shininess = e;
                let tri = |rng: &mut Rng| Triangle {
                    n: std::array::from_fn(|_| unit(rng)),
                    mid: std::array::from_fn(|_| unit(rng)),
                    cos_phi: 0.0,
                    theta: None,
                };
                let (ts, to) = (tri(&mut rng), tri(&mut rng));
                let (l, h) = (unit(&mut rng), unit(&mut rng));
                for scheme in [Scheme::Linear, Scheme::Quadratic] {
                    let mut lanes = Lanes::new();
                    lanes.len = [LANES, 1, 13, 40, 63, 64][case];
                    for j in 0..lanes.len {
                        let (a, b) = (rng.uniform(-0.1, 1.1), rng.uniform(-0.1, 1.1));
                        lanes.c[0][j] = a;
                        lanes.c[1][j] = b;
                        lanes.c[2][j] = 1.0 - a - b;
                    }
                    let shade = Shade::new(&light, l, h);
                    let bary = &quants[case % quants.len()];
                    isa.run(Run {
                        lanes: &mut lanes,
                        scheme,
                        smooth: &ts,
                        object: &to,
                        shade,
                        bary: Some(bary),
                    });
                    for j in 0..lanes.len {
                        let c = [lanes.c[0][j], lanes.c[1][j], lanes.c[2][j]];
                        let n = crate::interp::field(&ts, c, scheme).normalize();
                        let want = super::super::shade_f64(&light, n, l, h);
                        let at = format!("{} e={e} {scheme:?} lane {j}", isa.name());
                        assert_eq!(lanes.smooth_ref[j].to_bits(), want.to_bits(), "{at}");
                        let no = crate::interp::field(&to, c, scheme).normalize();
                        for k in 0..3 {
                            assert_eq!(lanes.n_obj[k][j].to_bits(), no[k].to_bits(), "{at}");
                        }
                        for (k, (codes, &x)) in lanes.codes.iter().zip(&c).enumerate() {
                            let want = bary.apply_f64(x).unwrap().code;
                            assert_eq!(i128::from(codes[j]), want, "{at} c{k}");
                        }
                    }
                }
            }
        }
    }
}
