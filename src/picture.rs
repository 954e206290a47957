//! PNG pictures: grey-level images and error heat-maps with a legend.

use anyhow::Context;
use fxshade_model::convert::narrow;

/// Encode a grey-level image (8 bits a pixel) as PNG.
pub fn gray_png(width: usize, height: usize, px: &[u8]) -> anyhow::Result<Vec<u8>> {
    encode(width, height, png::ColorType::Grayscale, px)
}

/// Encode an RGB image (3 bytes a pixel) as PNG.
pub fn rgb_png(width: usize, height: usize, px: &[u8]) -> anyhow::Result<Vec<u8>> {
    encode(width, height, png::ColorType::Rgb, px)
}

fn encode(width: usize, height: usize, ct: png::ColorType, px: &[u8]) -> anyhow::Result<Vec<u8>> {
    let mut out = Vec::new();
    {
        let mut e = png::Encoder::new(&mut out, narrow::<u32, _>(width), narrow::<u32, _>(height));
        e.set_color(ct);
        e.set_depth(png::BitDepth::Eight);
        let mut w = e.write_header().context("cannot encode a PNG header")?;
        w.write_image_data(px)
            .context("cannot encode a PNG image")?;
    }
    Ok(out)
}

/// Colours of the heat-map's classes, in order: exact, 1, 2, 3 levels,
/// then the classes above 3 from red to white.
pub const PALETTE: [[u8; 3]; 10] = [
    [25, 45, 120],
    [40, 170, 80],
    [235, 205, 40],
    [245, 130, 30],
    [215, 35, 30],
    [255, 0, 255],
    [160, 60, 255],
    [120, 200, 255],
    [200, 200, 200],
    [255, 255, 255],
];
/// Colour of pixels no triangle covers.
pub const BACKGROUND: [u8; 3] = [0, 0, 0];

/// The heat-map's classes for a largest error of `max` levels, as
/// inclusive `(lo, hi)` ranges: `0`, `1`, `2`, `3`, then doubling ranges
/// `4–7`, `8–15`, … of which the last ends at `max` itself, so the legend
/// shows the actual largest error (an 83-level error reads `64-83`, not
/// `8+`). Only classes up to `max` are listed (at least `0`).
pub fn classes(max: u32) -> Vec<(u32, u32)> {
    let mut c: Vec<(u32, u32)> = (0..=max.min(3)).map(|e| (e, e)).collect();
    let mut lo = 4u32;
    while lo <= max && c.len() < PALETTE.len() {
        let hi = if c.len() + 1 == PALETTE.len() {
            max
        } else {
            lo.saturating_mul(2).saturating_sub(1).min(max)
        };
        c.push((lo, hi));
        lo = match hi.checked_add(1) {
            Some(l) => l,
            None => break,
        };
    }
    c
}

/// The class of an error of `e` levels among `classes`.
pub fn class_of(classes: &[(u32, u32)], e: u32) -> usize {
    classes
        .iter()
        .position(|&(lo, hi)| (lo..=hi).contains(&e))
        .unwrap_or(classes.len() - 1)
}

fn label((lo, hi): (u32, u32)) -> String {
    if lo == hi {
        lo.to_string()
    } else {
        format!("{lo}-{hi}")
    }
}

// A 3×5 pixel font for the legend: each glyph is five rows of three bits.
fn glyph(c: char) -> [u8; 5] {
    match c {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 1, 1],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        '+' => [0, 2, 7, 2, 0],
        '-' => [0, 0, 7, 0, 0],
        'L' => [4, 4, 4, 4, 7],
        'E' => [7, 4, 6, 4, 7],
        'V' => [5, 5, 5, 5, 2],
        'S' => [7, 4, 7, 1, 7],
        _ => [0; 5],
    }
}

struct Canvas {
    w: usize,
    h: usize,
    px: Vec<u8>,
}

impl Canvas {
    fn set(&mut self, x: usize, y: usize, c: [u8; 3]) {
        if x < self.w && y < self.h {
            let k = 3 * (y * self.w + x);
            self.px[k..k + 3].copy_from_slice(&c);
        }
    }
    fn rect(&mut self, x: usize, y: usize, w: usize, h: usize, c: [u8; 3]) {
        for yy in y..y + h {
            for xx in x..x + w {
                self.set(xx, yy, c);
            }
        }
    }
    /// Text at scale `s`; returns the x after it.
    fn text(&mut self, x: usize, y: usize, s: usize, t: &str, c: [u8; 3]) -> usize {
        let mut cx = x;
        for ch in t.chars() {
            let g = glyph(ch);
            for (row, bits) in g.iter().enumerate() {
                for col in 0..3 {
                    if bits >> (2 - col) & 1 == 1 {
                        self.rect(cx + col * s, y + row * s, s, s, c);
                    }
                }
            }
            cx += 4 * s;
        }
        cx
    }
}

/// Glyph scale of the legend: a 3 × 5 font drawn at 3 pixels a dot, so
/// its text is 15 pixels high and stays readable when a page shows the
/// image at half its size.
const S: usize = 3;
const PAD: usize = 6;

/// Width of one legend entry: its swatch, a gap, its label and a gap.
fn entry_width(c: (u32, u32)) -> usize {
    5 * S + 2 * S + label(c).len() * 4 * S + 3 * S
}

/// The legend's rows for a picture `width` wide: entries (and the word
/// LEVELS last) laid out left to right, a new row where the next would
/// not fit (at least one entry a row); each row's classes by index.
fn legend_rows(classes: &[(u32, u32)], width: usize) -> Vec<Vec<usize>> {
    let avail = width.max(160).saturating_sub(2 * PAD);
    let mut rows: Vec<Vec<usize>> = vec![Vec::new()];
    let mut x = 0;
    for (k, &c) in classes.iter().enumerate() {
        let w = entry_width(c);
        if x > 0 && x + w > avail {
            rows.push(Vec::new());
            x = 0;
        }
        rows.last_mut().expect("one row").push(k);
        x += w;
    }
    rows
}

/// The picture's width for an image `width` wide: the image, or the
/// widest legend row and the word LEVELS.
fn legend_width(classes: &[(u32, u32)], width: usize) -> usize {
    legend_rows(classes, width)
        .iter()
        .map(|r| r.iter().map(|&k| entry_width(classes[k])).sum::<usize>())
        .max()
        .unwrap_or(0)
        .max("LEVELS".len() * 4 * S)
        + 2 * PAD
}

/// An error heat-map as PNG: `err[pixel]` in levels (`None`: not covered),
/// coloured by the [`classes`] of its largest error, with a legend below
/// the image that prints each class's bounds, wrapped to the image's width
/// (the word LEVELS on a row of its own).
pub fn heatmap_png(width: usize, height: usize, err: &[Option<u32>]) -> anyhow::Result<Vec<u8>> {
    let classes = classes(err.iter().flatten().copied().max().unwrap_or(0));
    let rows = legend_rows(&classes, width);
    let row_h = 5 * S + PAD;
    let legend_h = (rows.len() + 1) * row_h + PAD;
    let w = width.max(legend_width(&classes, width));
    let h = height + legend_h;
    let mut c = Canvas {
        w,
        h,
        px: vec![40; 3 * w * h],
    };
    let x0 = (w - width) / 2;
    for y in 0..height {
        for x in 0..width {
            let col = match err[y * width + x] {
                None => BACKGROUND,
                Some(e) => PALETTE[class_of(&classes, e)],
            };
            c.set(x0 + x, y, col);
        }
    }
    let white = [235, 235, 235];
    let mut y = height + PAD;
    for row in &rows {
        let mut x = PAD;
        for &k in row {
            c.rect(x, y, 5 * S, 5 * S, PALETTE[k]);
            x = c.text(x + 5 * S + 2 * S, y, S, &label(classes[k]), white) + 2 * S;
        }
        y += row_h;
    }
    c.text(PAD, y, S, "LEVELS", white);
    encode(w, h, png::ColorType::Rgb, &c.px)
}

/// The largest normal map read: 64 Mi texels (8192 × 8192).
pub const MAX_MAP_TEXELS: u64 = 1 << 26;

/// Read a tangent-space normal map from a PNG file: RGB or RGBA, 8 or 16
/// bits per channel (palette and grey images are refused), decoded with the
/// given green convention.
pub fn read_normal_map(
    path: &std::path::Path,
    green: fxshade_model::texture::Green,
) -> anyhow::Result<fxshade_model::texture::NormalTexture> {
    let file = std::fs::File::open(path)
        .with_context(|| format!("--normal-map {}: cannot open", path.display()))?;
    let mut dec = png::Decoder::new(std::io::BufReader::new(file));
    dec.set_transformations(png::Transformations::IDENTITY);
    let mut r = dec.read_info().map_err(|e| {
        anyhow::anyhow!(
            "--normal-map {}: not a PNG file I can read: {e}",
            path.display()
        )
    })?;
    {
        let i = r.info();
        let texels = u64::from(i.width) * u64::from(i.height);
        anyhow::ensure!(
            texels <= MAX_MAP_TEXELS,
            "--normal-map {}: {}×{} texels; at most {MAX_MAP_TEXELS} are read",
            path.display(),
            i.width,
            i.height
        );
    }
    let (ct, depth) = r.output_color_type();
    let channels = match ct {
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        other => anyhow::bail!(
            "--normal-map {}: colour type {other:?}; a normal map is RGB or RGBA",
            path.display()
        ),
    };
    let bits = match depth {
        png::BitDepth::Eight => 8,
        png::BitDepth::Sixteen => 16,
        other => anyhow::bail!(
            "--normal-map {}: {other:?} bits per channel; give 8 or 16",
            path.display()
        ),
    };
    let mut buf = vec![0; r.output_buffer_size()];
    let info = r
        .next_frame(&mut buf)
        .map_err(|e| anyhow::anyhow!("--normal-map {}: corrupt image data: {e}", path.display()))?;
    buf.truncate(info.buffer_size());
    let data: Vec<u16> = if bits == 8 {
        buf.iter().map(|&b| u16::from(b)).collect()
    } else {
        buf.chunks_exact(2)
            .map(|c| u16::from_be_bytes([c[0], c[1]]))
            .collect()
    };
    let max = (1u32 << bits) - 1;
    fxshade_model::texture::NormalTexture::from_channels(
        info.width as usize,
        info.height as usize,
        channels,
        max,
        &data,
        green,
    )
    .map_err(|e| anyhow::anyhow!("--normal-map {}: {e}", path.display()))
}

/// Encode a normal map as an RGB PNG of `bits` (8 or 16) per channel.
pub fn normal_map_png(
    t: &fxshade_model::texture::NormalTexture,
    bits: u32,
    green: fxshade_model::texture::Green,
) -> anyhow::Result<Vec<u8>> {
    let samples = t.to_channels(bits, green);
    let mut out = Vec::new();
    {
        let mut e = png::Encoder::new(
            &mut out,
            narrow::<u32, _>(t.width),
            narrow::<u32, _>(t.height),
        );
        e.set_color(png::ColorType::Rgb);
        let data: Vec<u8> = if bits == 8 {
            e.set_depth(png::BitDepth::Eight);
            samples.iter().map(|&s| narrow::<u8, _>(s)).collect()
        } else {
            e.set_depth(png::BitDepth::Sixteen);
            samples.iter().flat_map(|s| s.to_be_bytes()).collect()
        };
        let mut w = e.write_header().context("cannot encode a PNG header")?;
        w.write_image_data(&data)
            .context("cannot encode a PNG image")?;
    }
    Ok(out)
}

/// The texel flags of a baked map as an RGB picture: converted texels grey,
/// unused black, seams yellow, ambiguous texels red, poles blue.
pub fn flags_png(
    width: usize,
    height: usize,
    flags: &[fxshade_model::texture::TexelFlag],
) -> anyhow::Result<Vec<u8>> {
    use fxshade_model::texture::TexelFlag as F;
    let px: Vec<u8> = flags
        .iter()
        .flat_map(|f| match f {
            F::Converted => [128, 128, 128],
            F::Unused => [0, 0, 0],
            F::Seam => [235, 205, 40],
            F::Ambiguous => [215, 35, 30],
            F::Pole => [40, 90, 220],
        })
        .collect();
    encode(width, height, png::ColorType::Rgb, &px)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heatmap_colours_each_class_and_leaves_background_black() {
        let err = [None, Some(0), Some(1), Some(2), Some(5), Some(300)];
        let png = heatmap_png(6, 1, &err).unwrap();
        let dec = png::Decoder::new(&png[..]);
        let mut r = dec.read_info().unwrap();
        let mut buf = vec![0; r.output_buffer_size()];
        let info = r.next_frame(&mut buf).unwrap();
        let w = info.width as usize;
        assert!(w >= legend_width(&classes(300), 6) && info.height as usize > 1);
        // At a page's image width the legend wraps instead of widening it.
        assert_eq!(legend_width(&classes(300), 256).max(256), 256);
        assert!(legend_rows(&classes(300), 256).len() > 1);
        let x0 = (w - 6) / 2;
        let px = |x: usize| [buf[3 * x], buf[3 * x + 1], buf[3 * x + 2]];
        assert_eq!(px(x0), BACKGROUND);
        assert_eq!(px(x0 + 1), PALETTE[0]);
        assert_eq!(px(x0 + 2), PALETTE[1]);
        assert_eq!(px(x0 + 3), PALETTE[2]);
        assert_eq!(px(x0 + 4), PALETTE[4]);
        // 300 levels: the last class, 128-300.
        assert_eq!(px(x0 + 5), PALETTE[9]);
    }

    #[test]
    fn heat_map_classes_end_at_the_largest_error() {
        assert_eq!(classes(0), [(0, 0)]);
        assert_eq!(classes(2), [(0, 0), (1, 1), (2, 2)]);
        assert_eq!(
            classes(83),
            [
                (0, 0),
                (1, 1),
                (2, 2),
                (3, 3),
                (4, 7),
                (8, 15),
                (16, 31),
                (32, 63),
                (64, 83)
            ]
        );
        // 13 and 83 levels no longer share a class.
        let c = classes(83);
        assert_ne!(class_of(&c, 13), class_of(&c, 83));
        // At most one class per colour; the last still ends at the maximum.
        let c = classes(u32::MAX);
        assert_eq!(c.len(), PALETTE.len());
        assert_eq!(c.last().unwrap().1, u32::MAX);
    }
}
