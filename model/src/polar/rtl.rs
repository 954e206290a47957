//! The polar transform's RTL side: the parameter header of `rtl/polar.v`,
//! the ROM images, and test vectors with per-vector overflow flags.

use super::{Organisation, Polar, DECL};
use crate::config::Config;
use crate::datapath::{Fixed, Fx};
use crate::format::Format;
use crate::quantize::Rounding;
use crate::sampling::Rng;
use crate::vectors::{
    check_rtl_stages, header_preamble, hunt_ties, stage_params, Field, ParamsHeader, RtlError,
    VectorSet,
};

fn rom(codes: &[i128], f: Format) -> String {
    codes
        .iter()
        .map(|&c| format!("{:0w$x}\n", f.to_bits(c), w = f.hex_digits()))
        .collect()
}

/// The Verilog parameter header `polar_params.vh` and the ROM images.
pub fn params_header(cfg: &Config) -> Result<(Polar, ParamsHeader), RtlError> {
    let p = Polar::from_config(cfg.unit(DECL.name))?;
    let t = p.index.format().width();
    if t < 3 {
        return Err(RtlError::Stage {
            unit: "polar",
            stage: "table_bits",
            why: "the RTL needs at least 3 index bits".into(),
        });
    }
    check_rtl_stages(
        &p.count()?,
        &[
            ("table", p.tables.sin.out.format()),
            ("lyz", p.lyz.format()),
            ("out", p.out.format()),
        ],
    )
    .map_err(|(stage, why)| RtlError::Stage {
        unit: "polar",
        stage,
        why,
    })?;
    let org = match p.tables.organisation {
        Organisation::Full => "full",
        Organisation::Quarter => "quarter-wave",
    };
    let detail = format!(
        "{}-bit angles, {}-bit table index, {org} tables of {} bits each",
        p.angle.format().width(),
        t,
        p.tables.stored_bits()
    );
    let mut s = header_preamble("polar_params.vh", "polar", DECL.name, cfg, &detail);
    s += &format!(
        "localparam integer K = {}, T = {t}, QUARTER = {};\n",
        p.angle.format().width(),
        (p.tables.organisation == Organisation::Quarter) as u8
    );
    let round = match p.index.round() {
        Rounding::Trunc => 0,
        Rounding::HalfUp => 1,
        Rounding::HalfEven => 2,
    };
    s += &format!("localparam integer I_R = {round};\n");
    s += &stage_params("E", &p.tables.sin.out, false);
    s += &stage_params("Y", &p.lyz, true);
    s += &stage_params("O", &p.out, true);
    let fe = p.tables.sin.out.format();
    let extra = match p.tables.organisation {
        Organisation::Quarter => {
            vec![("polar_quarter.hex".to_string(), rom(&p.tables.quarter, fe))]
        }
        Organisation::Full => vec![
            ("polar_sin.hex".to_string(), rom(&p.tables.sin.codes, fe)),
            ("polar_cos.hex".to_string(), rom(&p.tables.cos.codes, fe)),
        ],
    };
    Ok((
        p,
        ParamsHeader {
            name: "polar_params.vh".into(),
            text: s,
            extra,
        },
    ))
}

fn eval(p: &Polar, fx: &mut Fixed<i128>, row: &[i128]) -> [Fx; 3] {
    let f = p.angle.format();
    let a = [0, 1, 2, 3].map(|i| Fx::from_code(row[i], f));
    crate::datapath::Datapath::quantize(fx, a[0], &p.angle); // (a no-op: codes are in range)
    p.transform(fx, a[0], a[1], a[2], a[3])
}

/// Test vectors: corner cases (poles, the β seam, zero and quarter-turn
/// angles, every quadrant boundary, rounding ties), then random angles:
/// elevations in [−¼, ¼] turn, azimuths anywhere, alternating with
/// arbitrary codes.
pub fn vectors(cfg: &Config, count: usize, seed: u64) -> Result<VectorSet, RtlError> {
    let (p, params) = params_header(cfg)?;
    let f = p.angle.format();
    let turn = 1i128 << f.width();
    let q = turn / 4;
    let m = |c: i128| c.rem_euclid(turn);
    let mut rows: Vec<Vec<i128>> = Vec::new();
    // Poles of N and of L, the seam of β, quadrant boundaries.
    for &an in &[q, m(-q), 0, 1, m(-1), q - 1] {
        for &(bl, bn) in &[
            (0, 0),
            (1, turn - 1),
            (turn - 1, 1),
            (q, m(-q)),
            (turn / 2, 0),
            (3, turn - 5),
        ] {
            for &al in &[0, q, m(-q), q / 2] {
                rows.push(vec![al, bl, an, bn]);
            }
        }
    }
    let mut rng = Rng::new(seed);
    let stages: Vec<&'static str> = {
        let mut s: Vec<&'static str> = p
            .count()?
            .quant_points()
            .iter()
            .filter(|x| x.round != Rounding::Trunc && x.dropped_bits > 0)
            .map(|x| x.stage)
            .collect();
        s.dedup();
        s
    };
    let mut trng = Rng::new(seed ^ 0x706f_6c61);
    rows.extend(hunt_ties(
        &stages,
        8,
        100_000,
        || (0..4).map(|_| trng.below(turn as u64) as i128).collect(),
        |fx, r| {
            eval(&p, fx, r);
        },
    ));
    let corners = rows.len();
    if count < corners {
        return Err(RtlError::Count { count, corners });
    }
    while rows.len() < count {
        if rows.len() % 2 == 0 {
            let el = |rng: &mut Rng| m(-q + rng.below((2 * q + 1) as u64) as i128);
            let (al, an) = (el(&mut rng), el(&mut rng));
            rows.push(vec![
                al,
                rng.below(turn as u64) as i128,
                an,
                rng.below(turn as u64) as i128,
            ]);
        } else {
            rows.push((0..4).map(|_| rng.below(turn as u64) as i128).collect());
        }
    }
    let mut fx = Fixed::<i128>::new();
    let output_rows = rows
        .iter()
        .map(|r| {
            fx.reset();
            let out = eval(&p, &mut fx, r);
            let flag = |s: &str| fx.overflows().iter().any(|(st, c)| *st == s && *c > 0) as i128;
            vec![
                (flag("lyz") << 1) | flag("out"),
                out[0].code(),
                out[1].code(),
                out[2].code(),
            ]
        })
        .collect();
    let fo = p.out.format();
    Ok(VectorSet {
        unit: DECL.name,
        variant: match p.tables.organisation {
            Organisation::Full => "full".into(),
            Organisation::Quarter => "quarter".into(),
        },
        config_source: cfg.source.clone(),
        config_toml: cfg.to_toml(),
        seed,
        inputs: ["al", "bl", "an", "bn"]
            .iter()
            .map(|n| Field::new(n, f))
            .collect(),
        outputs: vec![
            Field::new("ovf", Format::new(false, 2, 0).expect("valid")),
            Field::new("lx", fo),
            Field::new("ly", fo),
            Field::new("lz", fo),
        ],
        input_rows: rows,
        output_rows,
        params,
        corner_cases: corners,
    })
}
