//! The polar transform's RTL side: its traced design (the Verilog, ROMs
//! included, is emitted from it, `crate::rtl`) and its input vectors.

use super::{Organisation, Polar, DECL};
use crate::config::Config;
use crate::datapath::{Fixed, Fx};
use crate::quantize::Rounding;
use crate::rtl::units::Part;
use crate::rtl::units::{hunt_ties, RtlError};
use crate::sampling::Rng;
use fxshade_numbers::convert::narrow;

/// The unit's traced datapath for a configuration.
///
/// # Errors
///
/// [`RtlError::Polar`] when the `[polar]` section is unusable ([`Polar::from_config`]).
pub fn design(cfg: &Config) -> Result<crate::rtl::Design, RtlError> {
    let p = Polar::from_config(cfg)?;
    let org = match p.tables.organisation {
        Organisation::Full => "full",
        Organisation::Quarter => "quarter",
    };
    let notes = vec![format!(
        "{}-bit angles, {}-bit table index, {org} sin/cos tables: {} entries of {} ({} bits) stored",
        p.angle.format().width(),
        p.index.format().width(),
        p.tables.stored_entries(),
        p.tables.sin.out.format(),
        p.tables.stored_bits()
    )];
    Ok(crate::rtl::units::design(
        DECL.name,
        org,
        p.trace(),
        cfg,
        notes,
    ))
}

fn eval(p: &Polar, fx: &mut Fixed<i128>, row: &[i128]) -> [Fx; 3] {
    let f = p.angle.format();
    let a = [0, 1, 2, 3].map(|i| Fx::from_code(row[i], f));
    crate::datapath::Datapath::quantize(fx, a[0], &p.angle); // (a no-op: codes are in range)
    p.transform(fx, a[0], a[1], a[2], a[3])
}

/// Input vectors: corner cases (poles, the β seam, zero and quarter-turn
/// angles, every quadrant boundary, rounding ties), then random angles:
/// elevations in [−¼, ¼] turn, azimuths anywhere, alternating with
/// arbitrary codes.
///
/// # Errors
///
/// [`RtlError::Polar`] when the `[polar]` section is unusable ([`Polar::from_config`]).
pub fn inputs(
    cfg: &Config,
    part: crate::rtl::units::Part,
    seed: u64,
) -> Result<Vec<Vec<i128>>, RtlError> {
    let p = Polar::from_config(cfg)?;
    let f = p.angle.format();
    let turn = 1i128 << f.width();
    let q = turn / 4;
    let m = |c: i128| c.rem_euclid(turn);
    let mut rows: Vec<Vec<i128>> = Vec::new();
    if let Part::Random(count) = part {
        let mut rng = Rng::new(seed);
        while rows.len() < count {
            if rows.len().is_multiple_of(2) {
                let el = |rng: &mut Rng| m(-q + i128::from(rng.below(narrow::<u64, _>(2 * q + 1))));
                let (al, an) = (el(&mut rng), el(&mut rng));
                rows.push(vec![
                    al,
                    i128::from(rng.below(narrow::<u64, _>(turn))),
                    an,
                    i128::from(rng.below(narrow::<u64, _>(turn))),
                ]);
            } else {
                rows.push(
                    (0..4)
                        .map(|_| i128::from(rng.below(narrow::<u64, _>(turn))))
                        .collect(),
                );
            }
        }
        return Ok(rows);
    }
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
        || {
            (0..4)
                .map(|_| i128::from(trng.below(narrow::<u64, _>(turn))))
                .collect()
        },
        |fx, r| {
            eval(&p, fx, r);
        },
    ));
    Ok(rows)
}
