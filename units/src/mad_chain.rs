//! A chain of multiply-adds with a quantization after each: the benchmark of
//! the fixed-point machinery (`fxshade bench mad-chain`), written once and
//! run in every context.
//!
//! `x ← Q(a_i·x + b_i)` for `i = 0 .. n`.

use crate::datapath::Datapath;
use crate::quantize::Quant;

/// Run the chain on `x` with coefficients `coefs` (already loaded into the
/// context), quantizing each step with `q`.
#[inline]
pub fn mad_chain<C: Datapath>(cx: &mut C, coefs: &[(C::V, C::V)], mut x: C::V, q: &Quant) -> C::V {
    for &(a, b) in coefs {
        let y = cx.mul_add(a, x, b);
        x = cx.quantize(y, q);
    }
    x
}
