//! The interpolator's RTL side: its traced design (the Verilog is emitted
//! from it, `crate::rtl`) and its input vectors.

use super::{setup, Interp, DECL, PAIRS, THETA_LADDER};
use crate::config::Config;
use crate::datapath::{Fixed, Fx};
use crate::quantize::Rounding;
use crate::rtl::units::Part;
use crate::rtl::units::{hunt_ties, structured_code, RtlError};
use crate::sampling::{self, Rng};
use fxshade_numbers::convert::narrow;

/// The unit's traced datapath for a configuration.
///
/// # Errors
///
/// Never: every `[interp]` section traces (the `Result` is that of `RtlUnit::build`).
pub fn design(cfg: &Config) -> Result<crate::rtl::Design, RtlError> {
    let i = Interp::from_config(cfg);
    Ok(crate::rtl::units::design(
        DECL.name,
        i.scheme.name(),
        i.trace(),
        cfg,
        vec![format!("Scheme: {}", i.scheme.name())],
    ))
}

/// One input: `[c1, c2, N1x, N1y, N1z, …, N31z]` as codes.
type Row = Vec<i128>;

fn triangle_row(i: &Interp, theta: f64, c: [f64; 3], rng: &mut Rng) -> Row {
    let t =
        setup(sampling::triangle_meeting(theta, rng)).expect("random unit normals meeting Θ ≥ 0");
    let code = |q: &crate::quantize::Quant, x: f64| q.apply_f64(x).map(|r| r.code).unwrap_or(0);
    let mut row = vec![code(&i.bary, c[0]), code(&i.bary, c[1])];
    for v in t.n.iter().chain(t.mid.iter()) {
        row.extend([v.x, v.y, v.z].map(|x| code(&i.vertex, x)));
    }
    row
}

fn eval_row(i: &Interp, fx: &mut Fixed<i128>, one: Fx, row: &[i128]) -> [Fx; 3] {
    let (fb, fv) = (i.bary.format(), i.vertex.format());
    let v: [[Fx; 3]; 6] =
        std::array::from_fn(|k| std::array::from_fn(|c| Fx::from_code(row[2 + 3 * k + c], fv)));
    i.eval(
        fx,
        one,
        Fx::from_code(row[0], fb),
        Fx::from_code(row[1], fb),
        &v,
    )
}

/// Input vectors: corner cases (vertices, edge midpoints, centroids,
/// extrapolation beyond the triangle, extreme codes, rounding ties at every
/// nearest-mode stage), then random triangles meeting a random Θ of the
/// ladder with random barycentrics, alternating with random codes.
///
/// # Errors
///
/// Never: its one fallible step is [`Interp::count`], whose constants are finite.
pub fn inputs(
    cfg: &Config,
    part: crate::rtl::units::Part,
    seed: u64,
) -> Result<Vec<Vec<i128>>, RtlError> {
    let i = Interp::from_config(cfg);
    let (fb, fv) = (i.bary.format(), i.vertex.format());
    let mut rng = Rng::new(seed);
    let mut rows: Vec<Row> = Vec::new();
    let (bmax, vmax, vmin) = (fb.max_code(), fv.max_code(), fv.min_code());
    if let Part::Random(count) = part {
        let (bspan, vspan) = (
            narrow::<u64, _>(bmax + 1),
            narrow::<u64, _>(vmax - vmin + 1),
        );
        while rows.len() < count {
            if rows.len().is_multiple_of(2) {
                let theta = THETA_LADDER[narrow::<usize, _>(rng.below(THETA_LADDER.len() as u64))];
                let c = rng.barycentric();
                rows.push(triangle_row(&i, theta, c, &mut rng));
            } else {
                let mut r = vec![i128::from(rng.below(bspan)), i128::from(rng.below(bspan))];
                r.extend((0..18).map(|_| vmin + i128::from(rng.below(vspan))));
                rows.push(r);
            }
        }
        return Ok(rows);
    }
    let mut bary_corners = vec![
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0 / 3.0; 3],
    ];
    for &(a, b) in &PAIRS {
        let mut c = [0.0; 3];
        c[a] = 0.5;
        c[b] = 0.5;
        bary_corners.push(c);
    }
    for &theta in &THETA_LADDER {
        for &c in &bary_corners {
            rows.push(triangle_row(&i, theta, c, &mut rng));
        }
    }
    // Extrapolation (c1 + c2 > 1, c3 < 0) and extreme codes.
    rows.push([vec![bmax, bmax], vec![vmax; 18]].concat());
    rows.push([vec![bmax, bmax], vec![vmin; 18]].concat());
    rows.push([vec![0, 0], vec![vmin; 18]].concat());
    rows.push(
        [
            vec![bmax, 0],
            (0..18)
                .map(|k| if k % 2 == 0 { vmax } else { vmin })
                .collect(),
        ]
        .concat(),
    );
    let one = Interp::one(&mut Fixed::<i128>::new());
    let stages: Vec<&'static str> = i
        .count()?
        .1
        .quant_points()
        .iter()
        .filter(|p| p.round != Rounding::Trunc && p.dropped_bits > 0)
        .map(|p| p.stage)
        .collect();
    let mut stages_dedup = stages.clone();
    stages_dedup.dedup();
    let mut trng = Rng::new(seed ^ 0x7469_6573);
    rows.extend(hunt_ties(
        &stages_dedup,
        8,
        200_000,
        || {
            let mut r = vec![
                structured_code(fb, &mut trng),
                structured_code(fb, &mut trng),
            ];
            r.extend((0..18).map(|_| structured_code(fv, &mut trng)));
            r
        },
        |fx, row| {
            eval_row(&i, fx, one, row);
        },
    ));
    Ok(rows)
}
