//! 8-bit pictures of light maps: tone mapping, false colour with a lux scale bar, the Figure 5
//! strip, and a tiny bitmap font for the labels.
//!
//! # Tone mapping (the `<object>.png` pictures and the strip)
//! A map value `c` (lux or lm/m², RGB) is shown as the luminance-like quantity `c / π`
//! (cd/m² for exitance), scaled by one exposure shared by every object of a bake, so pictures of
//! different objects compare: `exposure = 0.18 / exp(mean(ln(10⁻⁴ + Y)))` over all valid texels
//! of the final exitance maps, `Y` the Rec. 709 luminance of `c / π`. Each channel then goes
//! through Reinhard's `x / (1 + x)` and the sRGB transfer function. Empty texels are black.
//!
//! # False colour (the `<object>_false_color.png` pictures)
//! The illuminance `E` (Rec. 709 luminance of the RGB illuminance; every channel of it for a
//! white lamp) on a logarithmic scale from `lo` to `hi` lux, whole decades chosen by
//! [`false_color_range`]; below `lo` the first colour, above `hi` the last. Empty texels are
//! mid-grey. Below the map: the colour bar with a tick and a label at each decade, and the unit.

use luxbake::map::MapImage;

/// An 8-bit RGB picture, row 0 first.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Picture {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// `3 × width × height` bytes.
    pub rgb: Vec<u8>,
}

impl Picture {
    /// A picture filled with one colour.
    pub fn filled(width: u32, height: u32, color: [u8; 3]) -> Picture {
        let n = width as usize * height as usize;
        Picture {
            width,
            height,
            rgb: color.repeat(n),
        }
    }

    /// Sets pixel `(x, y)`; ignored outside the picture.
    pub fn set(&mut self, x: u32, y: u32, color: [u8; 3]) {
        if x < self.width && y < self.height {
            let i = 3 * (y as usize * self.width as usize + x as usize);
            if let Some(p) = self.rgb.get_mut(i..i + 3) {
                p.copy_from_slice(&color);
            }
        }
    }

    /// Pixel `(x, y)`, black outside.
    pub fn get(&self, x: u32, y: u32) -> [u8; 3] {
        if x < self.width && y < self.height {
            let i = 3 * (y as usize * self.width as usize + x as usize);
            if let Some(p) = self.rgb.get(i..i + 3) {
                return [p[0], p[1], p[2]];
            }
        }
        [0; 3]
    }

    /// Copies `other` with its top-left corner at `(x, y)`.
    pub fn blit(&mut self, other: &Picture, x: u32, y: u32) {
        for j in 0..other.height {
            for i in 0..other.width {
                self.set(x + i, y + j, other.get(i, j));
            }
        }
    }
}

/// Rec. 709 luminance of linear RGB (the passes' [`luxbake::exact::luminance`]).
pub use luxbake::exact::luminance;

/// The sRGB transfer function of a linear value in [0, 1], as a byte: exactly
/// `round(255·(1.055·x^(1/2.4) − 0.055))` (`12.92·x` up to 0.0031308) with `f32::powf`, as
/// [`srgb_byte_by_powf`] computes it, but from a table: the byte of the 1/4096-wide bin `x`
/// falls in, raised while `x` reaches the next byte's threshold (the least `x` that
/// `srgb_byte_by_powf` maps to it; at most two steps). Every texel of every preview takes
/// three, and `powf` was 2 % of a whole default bake. Non-finite input gives 0.
pub fn srgb_byte(x: f32) -> u8 {
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let t = srgb_table();
    let mut b = t.start[((x * SRGB_BINS as f32) as usize).min(SRGB_BINS - 1)];
    while b < 255 && x >= t.threshold[usize::from(b) + 1] {
        b += 1;
    }
    b
}

/// [`srgb_byte`] computed with `powf`: its definition.
pub fn srgb_byte_by_powf(x: f32) -> u8 {
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

/// Bins of [`srgb_byte`]'s first guess.
const SRGB_BINS: usize = 4096;

/// [`srgb_byte`]'s table: per bin the byte of its lower end, per byte `b ≥ 1` the least `x`
/// in [0, 1] that [`srgb_byte_by_powf`] maps to `b` or more (`threshold[0]` unused).
struct SrgbTable {
    start: Vec<u8>,
    threshold: [f32; 256],
}

fn srgb_table() -> &'static SrgbTable {
    static TABLE: std::sync::OnceLock<SrgbTable> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let start = (0..SRGB_BINS)
            .map(|i| srgb_byte_by_powf(i as f32 / SRGB_BINS as f32))
            .collect();
        let mut threshold = [0.0f32; 256];
        for (b, t) in threshold.iter_mut().enumerate().skip(1) {
            // Bisection over the bit patterns of [0, 1], which order as the values do.
            let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
            while hi - lo > 1 {
                let mid = lo + (hi - lo) / 2;
                if usize::from(srgb_byte_by_powf(f32::from_bits(mid))) >= b {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            *t = f32::from_bits(hi);
        }
        SrgbTable { start, threshold }
    })
}

/// The shared exposure of a set of exitance maps (see the module docs).
pub fn exposure<'a>(maps: impl IntoIterator<Item = &'a MapImage>) -> f32 {
    let mut sum = 0.0f64;
    let mut n = 0u64;
    for m in maps {
        for c in m.valid_rgb() {
            let y = luminance(c) / std::f32::consts::PI;
            if y.is_finite() && y >= 0.0 {
                sum += f64::from(1e-4 + y).ln();
                n += 1;
            }
        }
    }
    if n == 0 {
        return 1.0;
    }
    let key = (sum / n as f64).exp() as f32;
    let e = 0.18 / key;
    if e.is_finite() && e > 0.0 { e } else { 1.0 }
}

/// Tone-maps a map (lux or lm/m²) with `exposure` (see the module docs).
pub fn tone_map(map: &MapImage, exposure: f32) -> Picture {
    let mut p = Picture::filled(map.width, map.height, [0; 3]);
    // Texel by texel in storage order (a map's texels are its rows, as the picture's pixels).
    let n = map.width as usize * map.height as usize;
    let texels = map.texels.chunks_exact(4).take(n);
    for (t, px) in texels.zip(p.rgb.chunks_exact_mut(3)) {
        if t[3] > 0.5 {
            for (o, &v) in px.iter_mut().zip(&t[..3]) {
                let v = v / std::f32::consts::PI * exposure;
                *o = srgb_byte(if v > 0.0 { v / (1.0 + v) } else { 0.0 });
            }
        }
    }
    p
}

/// Shows an albedo map (reflectance in [0, 1]) in sRGB.
pub fn albedo_picture(map: &MapImage) -> Picture {
    let mut p = Picture::filled(map.width, map.height, [0; 3]);
    for y in 0..map.height {
        for x in 0..map.width {
            let t = map.texel(x, y);
            if map.is_valid(x, y) || t[3] > 0.0 {
                p.set(x, y, [srgb_byte(t[0]), srgb_byte(t[1]), srgb_byte(t[2])]);
            }
        }
    }
    p
}

const RAMP: [[f32; 3]; 6] = [
    [0.05, 0.03, 0.35],
    [0.10, 0.30, 0.90],
    [0.00, 0.75, 0.75],
    [0.30, 0.85, 0.20],
    [1.00, 0.85, 0.10],
    [0.95, 0.15, 0.10],
];

/// The false-colour ramp at `t` in [0, 1] (clamped).
pub fn ramp(t: f32) -> [u8; 3] {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let f = t * (RAMP.len() - 1) as f32;
    let i = (f.floor() as usize).min(RAMP.len() - 2);
    let w = f - i as f32;
    [0, 1, 2].map(|c| {
        let v = RAMP[i][c] * (1.0 - w) + RAMP[i + 1][c] * w;
        (v * 255.0 + 0.5) as u8
    })
}

/// Decade range `(lo, hi)` in lux for illuminance maps: `hi` = the decade at or above the
/// largest valid value, `lo` = the decade at or below the 1st percentile of the positive values,
/// at most six decades below `hi`. All-dark maps give `(0.1, 1)`.
pub fn false_color_range<'a>(maps: impl IntoIterator<Item = &'a MapImage>) -> (f32, f32) {
    let mut values: Vec<f32> = maps
        .into_iter()
        .flat_map(|m| m.valid_rgb().map(luminance))
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    if values.is_empty() {
        return (0.1, 1.0);
    }
    // The largest and the 1st percentile (the value a full sort puts at `len / 100`) without
    // sorting every texel.
    let max = values.iter().copied().fold(f32::MIN, f32::max);
    let at = values.len() / 100;
    let p1 = *values.select_nth_unstable_by(at, f32::total_cmp).1;
    let hi_exp = max.log10().ceil().clamp(-30.0, 30.0);
    let lo_exp = p1.log10().floor().clamp(hi_exp - 6.0, hi_exp - 1.0);
    (10f32.powf(lo_exp), 10f32.powf(hi_exp))
}

fn log_position(v: f32, lo: f32, hi: f32) -> f32 {
    if v.is_nan() || v <= 0.0 {
        return 0.0;
    }
    (v.log10() - lo.log10()) / (hi.log10() - lo.log10())
}

/// Label of a decade value in lux: `0.01`, `0.1`, `1`, `10`, `100`, `1k`, `10k`, `100k`, `1M`,
/// else `1e<n>`.
pub fn decade_label(exp: i32) -> String {
    match exp {
        -2 => "0.01".into(),
        -1 => "0.1".into(),
        0 => "1".into(),
        1 => "10".into(),
        2 => "100".into(),
        3 => "1k".into(),
        4 => "10k".into(),
        5 => "100k".into(),
        6 => "1M".into(),
        e => format!("1e{e}"),
    }
}

/// Renders the false-colour picture of an illuminance map with its scale bar.
pub fn false_color(map: &MapImage, lo: f32, hi: f32) -> Picture {
    const SCALE: u32 = 2;
    const MARGIN: u32 = 8;
    let width = map.width.max(280);
    let bar_h = 14;
    let label_h = 5 * SCALE;
    let height = map.height + MARGIN + bar_h + 4 + label_h + MARGIN;
    let mut p = Picture::filled(width, height, [32, 32, 32]);
    for y in 0..map.height {
        for x in 0..map.width {
            let t = map.texel(x, y);
            let c = if t[3] > 0.5 {
                ramp(log_position(luminance([t[0], t[1], t[2]]), lo, hi))
            } else {
                [128, 128, 128]
            };
            p.set(x, y, c);
        }
    }
    // The bar spans [x0, x1); the unit "lux" goes right of it.
    let unit_w = text_width("lux", SCALE);
    let x0 = MARGIN + 6;
    let x1 = width.saturating_sub(MARGIN + unit_w + 6).max(x0 + 1);
    let y0 = map.height + MARGIN;
    for x in x0..x1 {
        let c = ramp((x - x0) as f32 / (x1 - x0 - 1).max(1) as f32);
        for y in y0..y0 + bar_h {
            p.set(x, y, c);
        }
    }
    draw_text(&mut p, "lux", x1 + 6, y0 + (bar_h - label_h) / 2, SCALE);
    let (lo_e, hi_e) = (lo.log10().round() as i32, hi.log10().round() as i32);
    let decades = (hi_e - lo_e).max(1);
    // Label every decade, or every other one where labels would collide.
    let step = if (x1 - x0) / decades as u32 >= 36 {
        1
    } else {
        2
    };
    for (k, e) in (lo_e..=hi_e).enumerate() {
        let x = x0 + ((x1 - x0 - 1) as f32 * (e - lo_e) as f32 / decades as f32).round() as u32;
        for y in y0 + bar_h..y0 + bar_h + 3 {
            p.set(x, y, [230, 230, 230]);
        }
        if k % step == 0 {
            let label = decade_label(e);
            let w = text_width(&label, SCALE);
            let lx = x.saturating_sub(w / 2).min(width.saturating_sub(w));
            draw_text(&mut p, &label, lx, y0 + bar_h + 4, SCALE);
        }
    }
    p
}

/// Lays out the eight stages of the paper's Figure 5 side by side, each labelled with its
/// number; a missing stage is a dark tile.
pub fn strip(stages: &[Option<Picture>; 8], width: u32, height: u32) -> Picture {
    const GAP: u32 = 4;
    let total_w = 8 * width + 7 * GAP;
    let mut p = Picture::filled(total_w, height, [16, 16, 16]);
    for (i, s) in stages.iter().enumerate() {
        let x = i as u32 * (width + GAP);
        match s {
            Some(tile) => p.blit(tile, x, 0),
            None => {
                for yy in 0..height {
                    for xx in 0..width {
                        p.set(x + xx, yy, [48, 48, 48]);
                    }
                }
            }
        }
        let label = format!("{}", i + 1);
        let scale = if width >= 40 && height >= 24 { 2 } else { 1 };
        for yy in 0..5 * scale + 2 {
            for xx in 0..3 * scale + 2 {
                p.set(x + xx, yy, [0, 0, 0]);
            }
        }
        draw_text(&mut p, &label, x + 1, 1, scale);
    }
    p
}

/// 3×5 glyphs, one row per byte, bit 2 = left column.
fn glyph(c: char) -> [u8; 5] {
    match c {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 2, 2],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        '.' => [0, 0, 0, 0, 2],
        '-' => [0, 0, 7, 0, 0],
        'e' => [0, 7, 7, 4, 7],
        'k' => [4, 5, 6, 5, 5],
        'M' => [5, 7, 7, 5, 5],
        'l' => [6, 2, 2, 2, 7],
        'u' => [0, 5, 5, 5, 7],
        'x' => [0, 5, 2, 2, 5],
        _ => [0; 5],
    }
}

/// Width of `text` in pixels at `scale`.
pub fn text_width(text: &str, scale: u32) -> u32 {
    let n = text.chars().count() as u32;
    if n == 0 { 0 } else { (4 * n - 1) * scale }
}

/// Draws `text` in light grey with its top-left at `(x, y)`.
pub fn draw_text(p: &mut Picture, text: &str, x: u32, y: u32, scale: u32) {
    for (k, c) in text.chars().enumerate() {
        let g = glyph(c);
        let gx = x + 4 * scale * k as u32;
        for (row, bits) in g.iter().enumerate() {
            for col in 0..3u32 {
                if bits & (4 >> col) != 0 {
                    for dy in 0..scale {
                        for dx in 0..scale {
                            p.set(gx + col * scale + dx, y + row as u32 * scale + dy, [235; 3]);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn uniform(value: f32, w: u32, h: u32) -> MapImage {
        let mut m = MapImage::zeros(w, h);
        for t in m.texels.chunks_exact_mut(4) {
            t.copy_from_slice(&[value, value, value, 1.0]);
        }
        m
    }

    #[test]
    fn the_srgb_table_gives_the_bytes_of_powf() {
        // Around every byte's threshold, a few ulps either side, and evenly over [0, 1].
        let t = srgb_table();
        let mut checked = 0;
        for &x in &t.threshold[1..] {
            for d in -8i32..=8 {
                let v = f32::from_bits(x.to_bits().saturating_add_signed(d));
                if v <= 1.0 {
                    assert_eq!(srgb_byte(v), srgb_byte_by_powf(v), "{v:e}");
                    checked += 1;
                }
            }
        }
        for i in 0..=1_000_000u32 {
            let v = i as f32 / 1e6;
            assert_eq!(srgb_byte(v), srgb_byte_by_powf(v), "{v:e}");
        }
        assert!(checked > 255 * 16, "{checked}");
        // Every byte is reached.
        let bytes: std::collections::HashSet<u8> =
            t.threshold.iter().map(|&x| srgb_byte(x)).collect();
        assert_eq!(bytes.len(), 256);
    }

    #[test]
    fn srgb_endpoints_and_guards() {
        for (linear, byte) in [(0.0, 0), (1.0, 255), (2.0, 255), (f32::NAN, 0), (0.5, 188)] {
            assert_eq!(srgb_byte(linear), byte, "{linear}");
        }
    }

    #[test]
    fn exposure_maps_the_log_average_to_middle_grey() {
        let m = uniform(100.0 * std::f32::consts::PI, 4, 4);
        let e = exposure([&m]);
        assert!((e * (100.0 + 1e-4) - 0.18).abs() < 1e-5, "{e}");
        assert_eq!(exposure(std::iter::empty()), 1.0);
        let p = tone_map(&m, e);
        // 0.18 / 1.18 in sRGB.
        assert_eq!(p.get(0, 0), [srgb_byte(0.18 / 1.18); 3]);
    }

    #[test]
    fn false_color_range_in_decades() {
        let mut m = uniform(0.0, 10, 10);
        for (i, t) in m.texels.chunks_exact_mut(4).enumerate() {
            let v = 3.0 + 5.0 * i as f32;
            t[..3].copy_from_slice(&[v, v, v]);
        }
        assert_eq!(false_color_range([&m]), (1.0, 1000.0));
        assert_eq!(false_color_range([&uniform(0.0, 2, 2)]), (0.1, 1.0));
        let (lo, hi) = false_color_range([&uniform(50.0, 2, 2)]);
        assert_eq!((lo, hi), (10.0, 100.0));
    }

    #[test]
    fn false_color_picture_has_the_map_and_a_bar() {
        let m = uniform(10.0, 300, 20);
        let p = false_color(&m, 1.0, 100.0);
        assert_eq!(p.width, 300);
        assert!(p.height > 20 + 14);
        // 10 lux is the middle of 1..100.
        assert_eq!(p.get(5, 5), ramp(0.5));
        // The bar starts with the first colour of the ramp.
        assert_eq!(p.get(14, 20 + 8 + 2), ramp(0.0));
        assert_eq!(ramp(-1.0), ramp(0.0));
        assert_eq!(ramp(7.0), ramp(1.0));
        assert_eq!(decade_label(3), "1k");
        assert_eq!(decade_label(-4), "1e-4");
        assert_eq!(text_width("lux", 2), 22);
    }

    #[test]
    fn strip_places_eight_tiles() {
        let tile = Picture::filled(10, 6, [200, 100, 50]);
        let mut stages: [Option<Picture>; 8] = Default::default();
        stages[0] = Some(tile.clone());
        stages[7] = Some(tile);
        let s = strip(&stages, 10, 6);
        assert_eq!(s.width, 8 * 10 + 7 * 4);
        assert_eq!(s.get(9, 5), [200, 100, 50]);
        assert_eq!(s.get(14 + 5, 5), [48, 48, 48]);
        assert_eq!(s.get(7 * 14 + 9, 5), [200, 100, 50]);
    }
}
