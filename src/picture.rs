//! PNG pictures: grey-level images and error heat-maps with a legend.

use anyhow::Context;

/// Encode a grey-level image (8 bits a pixel) as PNG.
pub fn gray_png(width: usize, height: usize, px: &[u8]) -> anyhow::Result<Vec<u8>> {
    encode(width, height, png::ColorType::Grayscale, px)
}

fn encode(width: usize, height: usize, ct: png::ColorType, px: &[u8]) -> anyhow::Result<Vec<u8>> {
    let mut out = Vec::new();
    {
        let mut e = png::Encoder::new(&mut out, width as u32, height as u32);
        e.set_color(ct);
        e.set_depth(png::BitDepth::Eight);
        let mut w = e.write_header().context("cannot encode a PNG header")?;
        w.write_image_data(px)
            .context("cannot encode a PNG image")?;
    }
    Ok(out)
}

/// The heat-map's classes: label and colour, by error in levels.
pub const CLASSES: [(&str, [u8; 3]); 6] = [
    ("0", [25, 45, 120]),
    ("1", [40, 170, 80]),
    ("2", [235, 205, 40]),
    ("3", [245, 130, 30]),
    ("4-7", [215, 35, 30]),
    ("8+", [255, 0, 255]),
];
/// Colour of pixels no triangle covers.
pub const BACKGROUND: [u8; 3] = [0, 0, 0];

/// The class of an error of `e` levels.
pub fn class_of(e: u32) -> usize {
    match e {
        0..=3 => e as usize,
        4..=7 => 4,
        _ => 5,
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

const S: usize = 2;
const PAD: usize = 4;

fn legend_width() -> usize {
    let mut w = PAD;
    for (label, _) in CLASSES {
        w += 5 * S + 2 * S + label.len() * 4 * S + 3 * S;
    }
    w + "LEVELS".len() * 4 * S + PAD
}

/// An error heat-map as PNG: `err[pixel]` in levels (`None`: not covered),
/// coloured by [`CLASSES`], with a legend strip below the image.
pub fn heatmap_png(width: usize, height: usize, err: &[Option<u32>]) -> anyhow::Result<Vec<u8>> {
    let legend_h = 5 * S + 2 * PAD;
    let w = width.max(legend_width());
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
                Some(e) => CLASSES[class_of(e)].1,
            };
            c.set(x0 + x, y, col);
        }
    }
    let white = [235, 235, 235];
    let (mut x, y) = (PAD, height + PAD);
    for (label, col) in CLASSES {
        c.rect(x, y, 5 * S, 5 * S, col);
        x = c.text(x + 5 * S + 2 * S, y, S, label, white) + 2 * S;
    }
    c.text(x, y, S, "LEVELS", white);
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
        let texels = i.width as u64 * i.height as u64;
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
        buf.iter().map(|&b| b as u16).collect()
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
        let mut e = png::Encoder::new(&mut out, t.width as u32, t.height as u32);
        e.set_color(png::ColorType::Rgb);
        let data: Vec<u8> = if bits == 8 {
            e.set_depth(png::BitDepth::Eight);
            samples.iter().map(|&s| s as u8).collect()
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
        assert!(w >= legend_width() && info.height as usize > 1);
        let x0 = (w - 6) / 2;
        let px = |x: usize| [buf[3 * x], buf[3 * x + 1], buf[3 * x + 2]];
        assert_eq!(px(x0), BACKGROUND);
        assert_eq!(px(x0 + 1), CLASSES[0].1);
        assert_eq!(px(x0 + 2), CLASSES[1].1);
        assert_eq!(px(x0 + 3), CLASSES[2].1);
        assert_eq!(px(x0 + 4), CLASSES[4].1);
        assert_eq!(px(x0 + 5), CLASSES[5].1);
    }
}
