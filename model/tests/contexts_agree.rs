//! The compiled batch path, the scalar fixed-point context on i128 codes and
//! on i64 codes must be the same arithmetic: identical codes and identical
//! overflow counts, for a datapath that uses every operation, across random
//! formats and modes.

use fxshade_model::datapath::{Compiled, Count, Datapath, Fixed, Program, Trace};
use fxshade_model::format::Format;
use fxshade_model::quantize::{Overflow, Quant, Raw, Rounding};
use proptest::prelude::*;

#[derive(Clone, Copy, Debug)]
struct Steps {
    x: Quant,
    y: Quant,
    a: Quant,
    b: Quant,
    c: Quant,
}

/// Uses mul, sub, shl, max, add, quantize, div and sqrt.
fn kernel<C: Datapath>(cx: &mut C, s: &Steps, k: C::V, x: C::V, y: C::V) -> [C::V; 3] {
    let p = cx.mul(x, y);
    let p2 = cx.shl(p, 1);
    let d = cx.sub(p2, x);
    let m = cx.max(d, y);
    let a = cx.quantize(m, &s.a);
    let t = cx.mul_add(a, k, y);
    let b = cx.quantize(t, &s.b);
    let q = cx.div(b, y, &s.c);
    let r = cx.sqrt(a, &s.c);
    [b, q, r]
}

fn arb_quant(stage: &'static str, max_w: u32) -> impl Strategy<Value = Quant> {
    (
        any::<bool>(),
        2u32..=max_w,
        -4i32..=24,
        0usize..3,
        0usize..2,
    )
        .prop_map(move |(sg, w, f, r, o)| {
            Quant::new(
                stage,
                Format::new(sg, w, f).unwrap(),
                Rounding::ALL[r],
                Overflow::ALL[o],
            )
        })
}

fn run_scalar<R: Raw>(s: &Steps, k: f64, xs: &[i128], ys: &[i128]) -> (Vec<[i128; 3]>, u64) {
    let mut cx = Fixed::<R>::new();
    let kv = cx.constant(k, &s.b).unwrap();
    let out = xs
        .iter()
        .zip(ys)
        .map(|(&x, &y)| {
            let xv = fxshade_model::Fx::<R>::from_code(x, s.x.format());
            let yv = fxshade_model::Fx::<R>::from_code(y, s.y.format());
            kernel(&mut cx, s, kv, xv, yv).map(|v| v.code())
        })
        .collect();
    (out, cx.total_overflows())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(600))]

    #[test]
    fn compiled_equals_scalar(
        x in arb_quant("x", 20), y in arb_quant("y", 20), a in arb_quant("a", 24),
        b in arb_quant("b", 24), c in arb_quant("c", 24),
        k in -3.0f64..3.0, seed in any::<u64>(), n in 1usize..600,
    ) {
        let s = Steps { x, y, a, b, c };
        // Random codes of the input formats (the whole range, ends included).
        let mut st = seed | 1;
        let mut next = |f: Format| {
            st ^= st << 13; st ^= st >> 7; st ^= st << 17;
            let span = (f.max_code() - f.min_code() + 1) as u128;
            f.min_code() + ((u128::from(st) * 0x9e37_79b9) % span) as i128
        };
        let mut xs: Vec<i128> = (0..n).map(|_| next(x.format())).collect();
        let ys: Vec<i128> = (0..n).map(|_| next(y.format())).collect();
        xs[0] = x.format().min_code();
        if n > 1 { xs[1] = x.format().max_code(); }

        let (want, want_ov) = run_scalar::<i128>(&s, k, &xs, &ys);

        let mut tr = Trace::new();
        let xv = tr.input(&x);
        let yv = tr.input(&y);
        let kv = tr.constant(k, &b).unwrap();
        let outs = kernel(&mut tr, &s, kv, xv, yv);
        let prog = Compiled::compile(&tr, &outs).unwrap();
        let (got, ov) = prog.run_i128(&[&xs, &ys]);
        let got_ov: u64 = ov.iter().map(|(_, n)| n).sum::<u64>() + tr_const_overflows(&prog);
        for i in 0..n {
            prop_assert_eq!([got[0][i], got[1][i], got[2][i]], want[i], "lane {}", i);
        }
        // The scalar run counts the constant's overflow once per batch too.
        prop_assert_eq!(got_ov, want_ov);

        // The i64 scalar context agrees whenever the widths allow it.
        let mut count = Count::new();
        let kc = count.constant(k, &b).unwrap();
        let xc = count.constant(0.0, &x).unwrap();
        let yc = count.constant(0.0, &y).unwrap();
        kernel(&mut count, &s, kc, xc, yc);
        prop_assert_eq!(count.fits_i64(), prog.is_narrow());
        if count.fits_i64() {
            let (narrow, narrow_ov) = run_scalar::<i64>(&s, k, &xs, &ys);
            prop_assert_eq!(&narrow, &want);
            prop_assert_eq!(narrow_ov, want_ov);
            let p64 = Program::<i64>::compile(&tr, &outs).unwrap();
            prop_assert_eq!(p64.counts(), &count.counts());
        }
    }
}

fn tr_const_overflows(p: &Compiled) -> u64 {
    match p {
        Compiled::Narrow(p) => p.const_overflows().len() as u64,
        Compiled::Wide(p) => p.const_overflows().len() as u64,
    }
}

#[test]
fn i64_program_refuses_wide_datapaths() {
    let q = Quant::new(
        "w",
        Format::new(true, 40, 30).unwrap(),
        Rounding::Trunc,
        Overflow::Wrap,
    );
    let mut tr = Trace::new();
    let x = tr.input(&q);
    let p = tr.mul(x, x);
    assert!(Program::<i64>::compile(&tr, &[p]).is_err());
    assert!(Program::<i128>::compile(&tr, &[p]).is_ok());
}
