//! The interpolator's RTL side: the parameter header of `rtl/interp.v` and
//! test vectors with per-vector overflow flags.

use super::{setup, Interp, Scheme, DECL, PAIRS, THETA_LADDER};
use crate::config::Config;
use crate::datapath::{Datapath, Fixed, Fx};
use crate::format::Format;
use crate::quantize::Rounding;
use crate::sampling::{self, Rng};
use crate::vectors::{
    check_rtl_stages, header_preamble, hunt_ties, stage_params, structured_code, Field,
    ParamsHeader, RtlError, VectorSet,
};

/// The Verilog parameter header `interp_params.vh` for a configuration.
pub fn params_header(cfg: &Config) -> Result<(Interp, ParamsHeader), RtlError> {
    let i = Interp::from_config(cfg.unit(DECL.name));
    let (_, p) = i.count()?;
    check_rtl_stages(
        &p,
        &[
            ("bary", i.bary.format()),
            ("vertex", i.vertex.format()),
            ("weight", i.weight.format()),
            ("out", i.out.format()),
        ],
    )
    .map_err(|(stage, why)| RtlError::Stage {
        unit: "interp",
        stage,
        why,
    })?;
    let mut t = header_preamble(
        "interp_params.vh",
        "interp",
        DECL.name,
        cfg,
        &format!("Scheme: {}", i.scheme.name()),
    );
    t += &format!(
        "localparam integer SCHEME = {};\n",
        if i.scheme == Scheme::Linear { 1 } else { 2 }
    );
    t += &stage_params("B", &i.bary, false);
    t += &stage_params("V", &i.vertex, false);
    t += &stage_params("W", &i.weight, true);
    t += &stage_params("O", &i.out, true);
    Ok((
        i,
        ParamsHeader {
            name: "interp_params.vh".into(),
            text: t,
            extra: Vec::new(),
        },
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

/// Test vectors: corner cases (vertices, edge midpoints, centroids,
/// extrapolation beyond the triangle, extreme codes, rounding ties at every
/// nearest-mode stage), then random triangles meeting a random Θ of the
/// ladder with random barycentrics, alternating with random codes.
pub fn vectors(cfg: &Config, count: usize, seed: u64) -> Result<VectorSet, RtlError> {
    let (i, params) = params_header(cfg)?;
    let (fb, fv) = (i.bary.format(), i.vertex.format());
    let mut rng = Rng::new(seed);
    let mut rows: Vec<Row> = Vec::new();
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
    let (bmax, vmax, vmin) = (fb.max_code(), fv.max_code(), fv.min_code());
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
    let mut fx = Fixed::<i128>::new();
    let one = fx.constant(1.0, &i.bary)?;
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
    let corners = rows.len();
    if count < corners {
        return Err(RtlError::Count { count, corners });
    }
    let (bspan, vspan) = ((bmax + 1) as u64, (vmax - vmin + 1) as u64);
    while rows.len() < count {
        if rows.len() % 2 == 0 {
            let theta = THETA_LADDER[rng.below(THETA_LADDER.len() as u64) as usize];
            let c = rng.barycentric();
            rows.push(triangle_row(&i, theta, c, &mut rng));
        } else {
            let mut r = vec![rng.below(bspan) as i128, rng.below(bspan) as i128];
            r.extend((0..18).map(|_| vmin + rng.below(vspan) as i128));
            rows.push(r);
        }
    }
    let output_rows = rows
        .iter()
        .map(|row| {
            fx.reset();
            let out = eval_row(&i, &mut fx, one, row);
            let flag = |s: &str| fx.overflows().iter().any(|(st, c)| *st == s && *c > 0) as i128;
            vec![
                (flag("weight") << 1) | flag("out"),
                out[0].code(),
                out[1].code(),
                out[2].code(),
            ]
        })
        .collect();
    let mut inputs = vec![Field::new("c1", fb), Field::new("c2", fb)];
    for v in ["n1", "n2", "n3", "n12", "n23", "n31"] {
        for c in ["x", "y", "z"] {
            inputs.push(Field::new(&format!("{v}{c}"), fv));
        }
    }
    let fo = i.out.format();
    Ok(VectorSet {
        unit: DECL.name,
        variant: i.scheme.name().to_string(),
        config_source: cfg.source.clone(),
        config_toml: cfg.to_toml(),
        seed,
        inputs,
        outputs: vec![
            Field::new("ovf", Format::new(false, 2, 0).expect("valid")),
            Field::new("ox", fo),
            Field::new("oy", fo),
            Field::new("oz", fo),
        ],
        input_rows: rows,
        output_rows,
        params,
        corner_cases: corners,
    })
}
