//! Fitting the area model to synthesis: least squares of the *relative*
//! error, with sign constraints, by cyclic coordinate descent.

use super::TERMS;

/// Coefficients `c` (one per term, then a constant) minimising
/// `Σ_i ((Σ_k x_ik·c_k + c_const − y_i) / max(y_i, 1))²` subject to
/// `c_k ≥ 0` wherever `nonneg[k]` (the constant is the last, index
/// [`TERMS`]).
///
/// Exact coordinate minimisation of a convex quadratic with box
/// constraints converges to the constrained optimum; the sweeps stop when
/// no coefficient moves by more than 1e-12 of its scale, or after 200 000
/// sweeps (deterministic: no clock is read). A term that is zero in every
/// row gets 0. Rows with a non-finite value are rejected by the caller.
pub fn fit(rows: &[[f64; TERMS]], y: &[f64], nonneg: [bool; TERMS + 1]) -> [f64; TERMS + 1] {
    const K: usize = TERMS + 1;
    let mut g = [[0.0f64; K]; K];
    let mut h = [0.0f64; K];
    for (x, &yi) in rows.iter().zip(y) {
        let w = 1.0 / yi.max(1.0);
        let mut a = [0.0f64; K];
        for (k, v) in x.iter().enumerate() {
            a[k] = v * w;
        }
        a[TERMS] = w;
        let b = yi * w;
        for i in 0..K {
            h[i] += a[i] * b;
            for j in 0..K {
                g[i][j] += a[i] * a[j];
            }
        }
    }
    let mut c = [0.0f64; K];
    for _ in 0..200_000 {
        let mut moved = 0.0f64;
        for k in 0..K {
            if g[k][k] <= 0.0 {
                continue;
            }
            let gc: f64 = (0..K).map(|j| g[k][j] * c[j]).sum();
            let mut v = c[k] + (h[k] - gc) / g[k][k];
            if nonneg[k] && v < 0.0 {
                v = 0.0;
            }
            moved = moved.max((v - c[k]).abs() / (1.0 + v.abs()));
            c[k] = v;
        }
        if moved < 1e-12 {
            break;
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Data made from known coefficients (independent of the fit: a closed
    /// form) is fitted back to them, and a constraint holds where the
    /// unconstrained optimum would be negative.
    #[test]
    fn recovers_known_coefficients() {
        let truth = [
            0.5, 1.25, 0.75, 0.0, 2.0, 0.0, 0.0625, 0.0, 0.0, 0.0, 1.5, 12.0,
        ];
        let rows: Vec<[f64; TERMS]> = (0..40u32)
            .map(|i| {
                let f = f64::from(i);
                [
                    10.0 + f * 3.0,
                    (f * 7.0) % 13.0,
                    20.0 + (f * 5.0) % 17.0,
                    0.0,
                    (f * 11.0) % 19.0,
                    0.0,
                    64.0 * ((f * 3.0) % 5.0),
                    0.0,
                    0.0,
                    0.0,
                    (f * 13.0) % 23.0,
                ]
            })
            .collect();
        let y: Vec<f64> = rows
            .iter()
            .map(|x| x.iter().zip(&truth).map(|(a, b)| a * b).sum::<f64>() + truth[TERMS])
            .collect();
        let c = fit(&rows, &y, [true; TERMS + 1]);
        for (got, want) in c.iter().zip(&truth) {
            assert!((got - want).abs() < 1e-6, "{c:?} against {truth:?}");
        }
        // y = 10 − x: the best slope is negative, so with the constraint it
        // is 0 and the constant takes the mean (relative weights).
        let rows: Vec<[f64; TERMS]> = (1..5)
            .map(|i| {
                let mut r = [0.0; TERMS];
                r[0] = f64::from(i);
                r
            })
            .collect();
        let y: Vec<f64> = (1..5).map(|i| 10.0 - f64::from(i)).collect();
        let free = fit(&rows, &y, [false; TERMS + 1]);
        assert!((free[0] + 1.0).abs() < 1e-9 && (free[TERMS] - 10.0).abs() < 1e-9);
        let c = fit(&rows, &y, [true; TERMS + 1]);
        assert_eq!(c[0], 0.0);
        assert!(c[TERMS] > 6.0 && c[TERMS] < 9.0, "{c:?}");
    }
}
