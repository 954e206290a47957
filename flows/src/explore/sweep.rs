//! Sweep axes and points: `--vary KEY=SPEC` (or a sweep file's `vary`
//! list) parsed against the base configuration.
//!
//! `SPEC` is a comma list (`linear,quadratic`, `0.3,0.4,0.5`,
//! `U1F13,U1F17`) or an inclusive range `A..B[:STEP]`: formats
//! (`U1F13..U1F21` steps the width and the fraction bits together, keeping
//! the integer bits), integers (`8..12`, `10..16:2`) or numbers (`0.3..0.6:0.1`,
//! where the step is required). `width.<group>=W` sets every member of a
//! width group (`fxshade_model::config::WIDTH_GROUPS`) to `W` bits.

use anyhow::{bail, Context};
use fxshade_model::convert::{from_f64, narrow, to_f64};
use fxshade_model::format::Format;
use fxshade_model::Config;

/// Most points one sweep may have.
pub const MAX_POINTS: usize = 100_000;

/// One value of an axis: its label and the overrides it applies.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct AxisValue {
    /// As printed (`U1F15`, `12`, `quadratic`).
    pub label: String,
    /// `--set` overrides (several for a width group).
    pub overrides: Vec<String>,
}

/// One swept key.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Axis {
    /// The key as given (`normalize.d.format`, `width.normals`).
    pub key: String,
    /// Its values, in sweep order.
    pub values: Vec<AxisValue>,
}

/// One point of a sweep.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Point {
    /// Position in the full sweep (0-based; the first axis varies slowest).
    pub index: usize,
    /// `(key, label)` per axis.
    pub labels: Vec<(String, String)>,
    /// The overrides of every axis, in axis order.
    pub overrides: Vec<String>,
}

/// The raw value texts of `SPEC`.
fn values(key: &str, spec: &str) -> anyhow::Result<Vec<String>> {
    let spec = spec.trim();
    if let Some((a, rest)) = spec.split_once("..") {
        let (b, step) = match rest.split_once(':') {
            Some((b, s)) => (b.trim(), Some(s.trim())),
            None => (rest.trim(), None),
        };
        let a = a.trim();
        if let (Ok(fa), Ok(fb)) = (a.parse::<Format>(), b.parse::<Format>()) {
            if fa.signed() != fb.signed() || fa.int_bits() != fb.int_bits() {
                bail!("{a}..{b}: a format range keeps the sign and the integer bits (write U1F13..U1F21)");
            }
            let step: u32 = match step {
                Some(s) => s.parse().ok().filter(|&s| s > 0).with_context(|| {
                    format!("step `{s}`: a format range steps by a positive number of bits")
                })?,
                None => 1,
            };
            if fa.width() > fb.width() {
                bail!("{a}..{b}: the range is empty (the first format is wider)");
            }
            return (fa.width()..=fb.width())
                .step_by(step as usize)
                .map(|w| {
                    Format::new(fa.signed(), w, narrow::<i32, _>(w) - fa.int_bits())
                        .map(|f| f.to_string())
                        .map_err(|e| anyhow::anyhow!("{w} bits: {e}"))
                })
                .collect();
        }
        let whole_step = step.is_none_or(|s| s.parse::<i64>().is_ok());
        if let (true, Ok(ia), Ok(ib)) = (whole_step, a.parse::<i64>(), b.parse::<i64>()) {
            let step: i64 = match step {
                Some(s) => s.parse().ok().filter(|&s| s > 0).with_context(|| {
                    format!("step `{s}`: an integer range steps by a positive integer")
                })?,
                None => 1,
            };
            if ia > ib {
                bail!("{a}..{b}: the range is empty");
            }
            if (ib - ia) / step >= narrow::<i64, _>(MAX_POINTS) {
                bail!("{a}..{b}: more than {MAX_POINTS} values");
            }
            return Ok((ia..=ib)
                .step_by(narrow::<usize, _>(step))
                .map(|v| v.to_string())
                .collect());
        }
        if let (Ok(xa), Ok(xb)) = (a.parse::<f64>(), b.parse::<f64>()) {
            let Some(step) = step else {
                bail!("{a}..{b}: a range of numbers needs a step, e.g. {a}..{b}:0.1");
            };
            let s: f64 = step
                .parse()
                .ok()
                .filter(|s: &f64| s.is_finite() && *s > 0.0)
                .with_context(|| format!("step `{step}`: give a positive number"))?;
            if !(xa.is_finite() && xb.is_finite()) || xa > xb {
                bail!("{a}..{b}: the range is empty");
            }
            let n = ((xb - xa) / s + 1e-9).floor();
            if n >= to_f64(MAX_POINTS) {
                bail!("{a}..{b}:{step}: more than {MAX_POINTS} values");
            }
            // Print each value as the shortest decimal near a + i·s (no
            // 0.30000000000000004 from the accumulation).
            return Ok((0..=from_f64::<usize>(n))
                .map(|i| {
                    let x = xa + to_f64(i) * s;
                    format!("{}", (x * 1e9).round() / 1e9)
                })
                .collect());
        }
        bail!("`{spec}`: a range runs between two formats, two integers or two numbers");
    }
    let v: Vec<String> = spec
        .split(',')
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .collect();
    if v.is_empty() {
        bail!("{key}: no values");
    }
    Ok(v)
}

/// Parse one `KEY=SPEC` against the base configuration; `origin` names
/// where it came from in errors (`--vary`, `sweep.toml:4`).
///
/// # Errors
///
/// `spec` is not `KEY=VALUES` with a known key and values it accepts (a list, a range
/// `a..b[/step]` of at most the allowed points).
pub fn parse_axis(spec: &str, base: &Config, origin: &str) -> anyhow::Result<Axis> {
    let Some((key, vals)) = spec.split_once('=') else {
        bail!("{origin} `{spec}`: expected KEY=SPEC, e.g. width.normals=10..16 or normalize.method=linear,quadratic");
    };
    let key = key.trim().to_string();
    let texts = values(&key, vals).with_context(|| format!("{origin} {key}"))?;
    let mut out = Vec::new();
    if let Some(group) = key.strip_prefix("width.") {
        for t in texts {
            let w: u32 = t.parse().ok().filter(|&w| w > 0).with_context(|| {
                format!("{origin} {key}={t}: a width is a positive number of bits")
            })?;
            let overrides = base
                .group_overrides(group, w)
                .map_err(|e| anyhow::anyhow!("{origin}: {e}"))?;
            out.push(AxisValue {
                label: t,
                overrides,
            });
        }
    } else {
        for t in texts {
            let o = format!("{key}={t}");
            // Name a bad key or value now, not once per point.
            base.clone()
                .apply_override(&o)
                .map_err(|e| anyhow::anyhow!("{origin} {e}"))?;
            out.push(AxisValue {
                label: t,
                overrides: vec![o],
            });
        }
    }
    Ok(Axis { key, values: out })
}

/// Every point of the sweep over `axes` (one point with no overrides when
/// there are none), the first axis varying slowest.
///
/// # Errors
///
/// The product of the axes has more points than a sweep allows.
pub fn points(axes: &[Axis]) -> anyhow::Result<Vec<Point>> {
    let total = axes
        .iter()
        .try_fold(1usize, |n, a| n.checked_mul(a.values.len()))
        .filter(|&n| n <= MAX_POINTS)
        .with_context(|| format!("the sweep has more than {MAX_POINTS} points"))?;
    Ok((0..total)
        .map(|index| {
            let mut rest = index;
            let mut picks = vec![0; axes.len()];
            for (k, a) in axes.iter().enumerate().rev() {
                picks[k] = rest % a.values.len();
                rest /= a.values.len();
            }
            let mut labels = Vec::new();
            let mut overrides = Vec::new();
            for (a, &p) in axes.iter().zip(&picks) {
                labels.push((a.key.clone(), a.values[p].label.clone()));
                overrides.extend(a.values[p].overrides.iter().cloned());
            }
            Point {
                index,
                labels,
                overrides,
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn format_ranges_keep_the_integer_bits() {
        assert_eq!(
            values("k", "U1F13..U1F17:2").unwrap(),
            ["U1F13", "U1F15", "U1F17"]
        );
        assert!(values("k", "U1F13..I1F17").is_err());
        assert!(values("k", "U1F13..U2F17").is_err());
    }

    #[test]
    fn numeric_ranges_and_lists() {
        assert_eq!(values("k", "8..10").unwrap(), ["8", "9", "10"]);
        assert_eq!(
            values("k", "0.3..0.6:0.1").unwrap(),
            ["0.3", "0.4", "0.5", "0.6"]
        );
        assert!(values("k", "0.3..0.6").is_err());
        assert_eq!(
            values("k", "linear, quadratic").unwrap(),
            ["linear", "quadratic"]
        );
        assert!(values("k", "3..1").is_err());
    }

    #[test]
    fn width_groups_move_every_member() {
        let base = Config::embedded();
        let a = parse_axis("width.normals=12", &base, "--vary").unwrap();
        let o = &a.values[0].overrides;
        // Every I2F14 normal becomes I2F10.
        assert!(
            o.contains(&"normalize.normal.format=I2F10".to_string()),
            "{o:?}"
        );
        assert!(
            o.contains(&"interp.vertex.format=I2F10".to_string()),
            "{o:?}"
        );
        assert!(
            o.contains(&"lighting.normal.format=I2F10".to_string()),
            "{o:?}"
        );
        assert!(parse_axis("width.nothing=12", &base, "--vary").is_err());
        assert!(parse_axis("normalize.nothing=1,2", &base, "--vary").is_err());
    }

    #[test]
    fn points_are_the_product_first_axis_slowest() {
        let base = Config::embedded();
        let axes = [
            parse_axis("normalize.method=linear,quadratic", &base, "--vary").unwrap(),
            parse_axis("polar.table_bits=8..10", &base, "--vary").unwrap(),
        ];
        let p = points(&axes).unwrap();
        assert_eq!(p.len(), 6);
        assert_eq!(p[1].labels[0].1, "linear");
        assert_eq!(p[1].labels[1].1, "9");
        assert_eq!(p[3].labels[0].1, "quadratic");
    }
}
