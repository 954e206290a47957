//! Plots as PNG and SVG (plotters): error against width, Pareto fronts,
//! histograms. Text is drawn with the DejaVu Sans font built into the
//! binary, so a machine without fonts draws the same pictures.

use anyhow::Context;
use fxshade_model::convert::{from_f64, to_f64};
use plotters::prelude::*;

static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");

fn register() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType file, checked by the tests.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// Image size of every plot.
pub const SIZE: (u32, u32) = (720, 440);

/// One curve: its name and `(x, y)` points.
pub type Series = (String, Vec<(f64, f64)>);

/// A plot's axes and title.
pub struct Frame<'a> {
    /// Title.
    pub title: &'a str,
    /// x-axis label.
    pub x: &'a str,
    /// y-axis label.
    pub y: &'a str,
    /// A logarithmic y axis (points ≤ 0 are left out).
    pub log_y: bool,
}

fn colour(k: usize) -> RGBColor {
    const C: [RGBColor; 8] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(127, 127, 127),
    ];
    C[k % C.len()]
}

fn range(v: impl Iterator<Item = f64> + Clone, log: bool) -> (f64, f64) {
    let (lo, hi) = v
        .filter(|x| x.is_finite() && (!log || *x > 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    if !lo.is_finite() {
        return if log { (0.1, 1.0) } else { (0.0, 1.0) };
    }
    if log {
        (lo / 1.5, hi * 1.5)
    } else if lo == hi {
        (lo - 1.0, hi + 1.0)
    } else {
        let pad = 0.05 * (hi - lo);
        (lo - pad, hi + pad)
    }
}

/// A tick label on an integer axis: the integer at an integer, nothing
/// between (no `9.0`, no `9.5`).
fn integer_tick(v: &f64) -> String {
    if (v - v.round()).abs() < 1e-9 {
        format!("{}", from_f64::<i64>(v.round()))
    } else {
        String::new()
    }
}

/// Draw lines (with markers) and, optionally, highlighted points: `marks`
/// are `(label, x, y)` drawn as large red circles.
fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    f: &Frame,
    series: &[Series],
    scatter: &[(f64, f64)],
    marks: &[(String, f64, f64)],
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let xs = series
        .iter()
        .flat_map(|s| s.1.iter().map(|p| p.0))
        .chain(scatter.iter().map(|p| p.0))
        .chain(marks.iter().map(|m| m.1))
        .collect::<Vec<_>>();
    let ys = series
        .iter()
        .flat_map(|s| s.1.iter().map(|p| p.1))
        .chain(scatter.iter().map(|p| p.1))
        .chain(marks.iter().map(|m| m.2))
        .collect::<Vec<_>>();
    let integer_x = !xs.is_empty()
        && xs
            .iter()
            .all(|x| x.is_finite() && x.fract() == 0.0 && x.abs() < 1e15);
    let (x0, x1) = range(xs.iter().copied(), false);
    let (y0, y1) = range(ys.iter().copied(), f.log_y);
    let keep = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite() && (!f.log_y || p.1 > 0.0);
    let mut b = ChartBuilder::on(&root);
    b.caption(f.title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70);
    macro_rules! body {
        ($chart:expr) => {{
            let mut chart = $chart;
            let mut mesh = chart.configure_mesh();
            mesh.x_desc(f.x).y_desc(f.y).label_style(("sans-serif", 13));
            // Integer axes (widths, bits) are ticked at integers only.
            if integer_x {
                mesh.x_label_formatter(&integer_tick);
            }
            mesh.draw().map_err(|e| anyhow::anyhow!("{e:?}"))?;
            if !scatter.is_empty() {
                chart
                    .draw_series(
                        scatter.iter().filter(|p| keep(p)).map(|&(x, y)| {
                            Circle::new((x, y), 3, RGBColor(150, 150, 150).filled())
                        }),
                    )
                    .map_err(|e| anyhow::anyhow!("{e:?}"))?
                    .label("every point")
                    .legend(|(x, y)| Circle::new((x, y), 3, RGBColor(150, 150, 150).filled()));
            }
            for (k, (name, pts)) in series.iter().enumerate() {
                let c = colour(k);
                let pts: Vec<(f64, f64)> = pts.iter().copied().filter(|p| keep(p)).collect();
                chart
                    .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
                    .map_err(|e| anyhow::anyhow!("{e:?}"))?
                    .label(name.as_str())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2))
                    });
                chart
                    .draw_series(pts.iter().map(|&(x, y)| Circle::new((x, y), 3, c.filled())))
                    .map_err(|e| anyhow::anyhow!("{e:?}"))?;
            }
            for (label, x, y) in marks.iter().filter(|m| keep(&(m.1, m.2))) {
                chart
                    .draw_series(std::iter::once(Circle::new(
                        (*x, *y),
                        7,
                        RED.stroke_width(3),
                    )))
                    .map_err(|e| anyhow::anyhow!("{e:?}"))?
                    .label(label.as_str())
                    .legend(|(x, y)| Circle::new((x, y), 5, RED.stroke_width(2)));
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 12))
                .position(SeriesLabelPosition::UpperRight)
                .draw()
                .map_err(|e| anyhow::anyhow!("{e:?}"))?;
        }};
    }
    if f.log_y {
        body!(b
            .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
            .map_err(|e| anyhow::anyhow!("{e:?}"))?);
    } else {
        body!(b
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| anyhow::anyhow!("{e:?}"))?);
    }
    root.present().map_err(|e| anyhow::anyhow!("{e:?}"))?;
    Ok(())
}

/// The plot as `(PNG bytes, SVG text)`.
pub fn plot(
    f: &Frame,
    series: &[Series],
    scatter: &[(f64, f64)],
    marks: &[(String, f64, f64)],
) -> anyhow::Result<(Vec<u8>, String)> {
    register();
    let (w, h) = SIZE;
    let mut rgb = vec![255u8; (3 * w * h) as usize];
    draw(
        BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area(),
        f,
        series,
        scatter,
        marks,
    )
    .with_context(|| format!("drawing the plot `{}`", f.title))?;
    let mut svg = String::new();
    draw(
        SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area(),
        f,
        series,
        scatter,
        marks,
    )
    .with_context(|| format!("drawing the plot `{}` as SVG", f.title))?;
    Ok((crate::picture::rgb_png(w as usize, h as usize, &rgb)?, svg))
}

/// A two-axis sweep's metric as a heat map: one cell per pair of axis
/// values (`x` across, `y` up), coloured from light (smallest) to dark
/// (largest) on a linear scale, each cell printed with its value
/// (`-` where the point has none).
pub struct Grid<'a> {
    /// Title.
    pub title: &'a str,
    /// The first axis (across) and its values.
    pub x: (&'a str, &'a [String]),
    /// The second axis (up) and its values.
    pub y: (&'a str, &'a [String]),
    /// `cells[i][j]`: the value at `x[i]`, `y[j]`.
    pub cells: &'a [Vec<Option<f64>>],
}

/// The colour of `t` in 0..=1: light yellow to dark blue.
fn scale(t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (a, b) = ((255.0, 247.0, 188.0), (8.0, 48.0, 107.0));
    let m = |u: f64, v: f64| from_f64::<u8>((u + (v - u) * t).round());
    RGBColor(m(a.0, b.0), m(a.1, b.1), m(a.2, b.2))
}

fn draw_grid<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    g: &Grid,
    fmt: &dyn Fn(f64) -> String,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let e = |e| anyhow::anyhow!("{e:?}");
    root.fill(&WHITE).map_err(e)?;
    let (nx, ny) = (g.x.1.len(), g.y.1.len());
    let vals = g.cells.iter().flatten().flatten().copied();
    let (lo, hi) = vals
        .clone()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    let mut chart = ChartBuilder::on(&root)
        .caption(g.title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(90)
        .build_cartesian_2d(0f64..to_f64(nx.max(1)), 0f64..to_f64(ny.max(1)))
        .map_err(e)?;
    let xl = |v: &f64| {
        let i = (v - 0.5).round();
        if (v - 0.5 - i).abs() < 1e-6 && i >= 0.0 {
            g.x.1.get(from_f64::<usize>(i)).cloned().unwrap_or_default()
        } else {
            String::new()
        }
    };
    let yl = |v: &f64| {
        let j = (v - 0.5).round();
        if (v - 0.5 - j).abs() < 1e-6 && j >= 0.0 {
            g.y.1.get(from_f64::<usize>(j)).cloned().unwrap_or_default()
        } else {
            String::new()
        }
    };
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(g.x.0)
        .y_desc(g.y.0)
        .x_labels(2 * nx + 1)
        .y_labels(2 * ny + 1)
        .x_label_formatter(&xl)
        .y_label_formatter(&yl)
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(e)?;
    for (i, col) in g.cells.iter().enumerate() {
        for (j, v) in col.iter().enumerate() {
            let t = match v {
                Some(v) if hi > lo => (v - lo) / (hi - lo),
                _ => 0.0,
            };
            let fill = if v.is_some() { scale(t) } else { WHITE };
            let (x, y) = (to_f64(i), to_f64(j));
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(x, y), (x + 1.0, y + 1.0)],
                    fill.filled(),
                )))
                .map_err(e)?;
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(x, y), (x + 1.0, y + 1.0)],
                    RGBColor(200, 200, 200).stroke_width(1),
                )))
                .map_err(e)?;
            let text = v.map_or("-".to_string(), fmt);
            let ink = if t > 0.55 { WHITE } else { BLACK };
            let style = ("sans-serif", 14).into_font().color(&ink).pos(
                plotters::style::text_anchor::Pos::new(
                    plotters::style::text_anchor::HPos::Center,
                    plotters::style::text_anchor::VPos::Center,
                ),
            );
            chart
                .draw_series(std::iter::once(Text::new(text, (x + 0.5, y + 0.5), style)))
                .map_err(e)?;
        }
    }
    root.present().map_err(e)?;
    Ok(())
}

/// [`Grid`] as `(PNG bytes, SVG text)`, values printed by `fmt`.
pub fn grid(g: &Grid, fmt: &dyn Fn(f64) -> String) -> anyhow::Result<(Vec<u8>, String)> {
    register();
    let (w, h) = SIZE;
    let mut rgb = vec![255u8; (3 * w * h) as usize];
    draw_grid(
        BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area(),
        g,
        fmt,
    )
    .with_context(|| format!("drawing the grid `{}`", g.title))?;
    let mut svg = String::new();
    draw_grid(
        SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area(),
        g,
        fmt,
    )
    .with_context(|| format!("drawing the grid `{}` as SVG", g.title))?;
    Ok((crate::picture::rgb_png(w as usize, h as usize, &rgb)?, svg))
}

/// A histogram as bars: `counts[k]` of the bin `labels[k]`, drawn as a
/// line over bin indices (plots it through [`plot`]).
pub fn histogram(
    title: &str,
    x: &str,
    series: &[(String, Vec<u64>)],
) -> anyhow::Result<(Vec<u8>, String)> {
    let s: Vec<Series> = series
        .iter()
        .map(|(n, c)| {
            let total: u64 = c.iter().sum::<u64>().max(1);
            (
                n.clone(),
                c.iter()
                    .enumerate()
                    .map(|(k, &v)| (to_f64(k), to_f64(v) / to_f64(total)))
                    .collect(),
            )
        })
        .collect();
    plot(
        &Frame {
            title,
            x,
            y: "share of pixels",
            log_y: true,
        },
        &s,
        &[],
        &[],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_built_in_font_loads_and_plots_draw_text() {
        // ab_glyph accepts the embedded bytes as a font.
        assert!(plotters::style::register_font("check", FontStyle::Normal, FONT).is_ok());
        let (png, svg) = plot(
            &Frame {
                title: "t",
                x: "width",
                y: "error",
                log_y: true,
            },
            &[("a".into(), vec![(10.0, 1e-3), (12.0, 1e-4), (14.0, 2e-5)])],
            &[(11.0, 1e-3)],
            &[("chosen".into(), 12.0, 1e-4)],
        )
        .unwrap();
        assert_eq!(&png[1..4], b"PNG");
        assert!(svg.starts_with("<svg") && svg.contains("<text") && svg.contains("width"));
        // The PNG holds more than the white background and the lines: text
        // pixels are grey levels a plain line plot would not have.
        let dec = png::Decoder::new(&png[..]);
        let mut r = dec.read_info().unwrap();
        let mut buf = vec![0; r.output_buffer_size()];
        r.next_frame(&mut buf).unwrap();
        let dark = buf.chunks(3).filter(|p| p.iter().all(|&c| c < 100)).count();
        assert!(dark > 500, "{dark} dark pixels: no text or axes drawn");
    }

    /// Widths 8..12 on the x axis: ticks read `9`, never `9.0` or `9.5`;
    /// a fractional axis keeps its decimals.
    #[test]
    fn integer_axes_are_ticked_at_integers() {
        let frame = Frame {
            title: "t",
            x: "width (bits)",
            y: "error",
            log_y: false,
        };
        let texts = |pts: Vec<(f64, f64)>| {
            let (_, svg) = plot(&frame, &[("a".into(), pts)], &[], &[]).unwrap();
            svg.split("<text")
                .skip(1)
                .filter_map(|t| t.split_once('>').map(|x| x.1))
                .filter_map(|t| t.split_once("</text>").map(|x| x.0.trim().to_string()))
                .collect::<Vec<_>>()
        };
        let t = texts(
            (8..=12)
                .map(|w| (f64::from(w), 1.0 / f64::from(w)))
                .collect(),
        );
        assert!(t.iter().any(|x| x == "9"), "{t:?}");
        assert!(
            !t.iter()
                .any(|x| x.contains(".0") && x.parse::<f64>().is_ok_and(|v| v >= 8.0)),
            "{t:?}"
        );
        assert!(!t.iter().any(|x| x == "9.5"), "{t:?}");
        let t = texts(vec![(0.25, 1.0), (0.5, 2.0), (0.75, 1.5)]);
        assert!(t.iter().any(|x| x.contains('.')), "{t:?}");
    }
}
