//! LogLuv light maps in 8-bit RGBA PNGs: the web encoding of the catalogue's GLB.
//!
//! A texel is Ward's 32-bit LogLuv (*The LogLuv Encoding for Full Gamut, High Dynamic Range
//! Images*, 1998) of its linear Rec. 709 RGB, in the four bytes of a PNG pixel:
//! - R, G: `Le = round(256 · (log2 Y + 64))`, big-endian 16 bits (`Le = 0`: black), Y the
//!   luminance (CIE Y of the RGB: the lux `luxbake measure` reports). Steps of 1/256 stop from
//!   2^-64 to 2^192: Y decodes within `2^(1/512) − 1` (0.14 %) wherever it is.
//! - B, A: the CIE 1976 chromaticity, `round(410 · u′)` and `round(410 · v′)`.
//!
//! Decoding ([`rgb_of_logluv`], and the `luxbake` npm package's `registerWebGLB`, which does
//! the same in JavaScript): `Y = 2^(Le/256 − 64)`, `u′ = B/410`, `v′ = A/410`,
//! `X = Y · 9u′ / 4v′`, `Z = Y · (12 − 3u′ − 20v′) / 4v′`, then [`XYZ_TO_RGB`], negative
//! components clamped to 0. The lux of a texel comes back within 0.14 % plus what the 8-bit
//! chromaticity moves in a colour far outside grey (measured within 0.22 % on the catalogue's
//! rooms, `cargo xtask bench web`); a single colour channel of a saturated colour can be off by
//! more (the chromaticity step is 1/410). The PNG is lossless: the bytes come back as written.
//!
//! Why LogLuv: of RGBE (Radiance HDR or PNG), RGBM, LogLuv and half floats, it is the one
//! that keeps every texel's lux within 1 % (RGBE: 1.4 % on saturated texels, where the green
//! mantissa shares the red one's exponent) at a small fraction of the EXRs' size (0.04–0.06),
//! and that a browser reads without a codec of its own (a PNG; half floats need a 16-bit PNG,
//! which browsers reduce to 8 bits, or a KTX2 file 0.8 times the EXRs' size). Measured in
//! `docs/catalogue.md`.

use std::path::PathBuf;

use luxbake::map::MapImage;

use crate::OutputError;

/// The bound of the luminance (lux) quantisation: half a step of 1/256 stop.
pub const LUMINANCE_STEP_ERROR: f64 = 0.001_354_9;

/// Linear Rec. 709 RGB to CIE XYZ (D65), row-major.
pub const RGB_TO_XYZ: [[f64; 3]; 3] = [
    [0.4124, 0.3576, 0.1805],
    [0.2126, 0.7152, 0.0722],
    [0.0193, 0.1192, 0.9505],
];

/// The inverse of [`RGB_TO_XYZ`] (to 10 decimals), row-major.
pub const XYZ_TO_RGB: [[f64; 3]; 3] = [
    [3.240_625_477_3, -1.537_207_972_2, -0.498_628_598_7],
    [-0.968_930_714_7, 1.875_756_060_9, 0.041_517_523_8],
    [0.055_710_120_4, -0.204_021_050_6, 1.056_995_942_3],
];

/// The scale of the 8-bit chromaticity.
const UV_SCALE: f64 = 410.0;

fn times(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    m.map(|r| r[0] * v[0] + r[1] * v[1] + r[2] * v[2])
}

/// The LogLuv bytes of one linear RGB value (negative and NaN components count as 0; black,
/// and values below 2^-64, give `[0; 4]`).
pub fn logluv(rgb: [f32; 3]) -> [u8; 4] {
    let c = rgb.map(|v| {
        if v.is_finite() && v > 0.0 {
            f64::from(v)
        } else {
            0.0
        }
    });
    let [x, y, z] = times(&RGB_TO_XYZ, c);
    if y <= 0.0 {
        return [0; 4];
    }
    let le = (256.0 * (y.log2() + 64.0)).round();
    if le < 1.0 {
        return [0; 4];
    }
    let le = le.min(65535.0) as u16;
    let d = x + 15.0 * y + 3.0 * z;
    let q = |w: f64| (UV_SCALE * w).round().clamp(0.0, 255.0) as u8;
    let [hi, lo] = le.to_be_bytes();
    [hi, lo, q(4.0 * x / d), q(9.0 * y / d)]
}

/// The linear RGB of LogLuv bytes (see the module docs).
pub fn rgb_of_logluv(t: [u8; 4]) -> [f32; 3] {
    let le = u16::from_be_bytes([t[0], t[1]]);
    if le == 0 || t[3] == 0 {
        return [0.0; 3];
    }
    let y = (f64::from(le) / 256.0 - 64.0).exp2();
    let (u, v) = (f64::from(t[2]) / UV_SCALE, f64::from(t[3]) / UV_SCALE);
    let x = y * 9.0 * u / (4.0 * v);
    let z = y * (12.0 - 3.0 * u - 20.0 * v) / (4.0 * v);
    times(&XYZ_TO_RGB, [x, y, z]).map(|c| c.max(0.0) as f32)
}

/// Encodes the RGB of `map` as an 8-bit RGBA LogLuv PNG (alpha of the map dropped; a 0-sized
/// map as one black texel), with the `png` crate's `High` compression. Deterministic.
pub fn encode_logluv_png(map: &MapImage) -> Result<Vec<u8>, OutputError> {
    let err = |e: png::EncodingError| OutputError::Png {
        path: PathBuf::new(),
        message: e.to_string(),
    };
    let mut pixels: Vec<u8> = map
        .texels
        .chunks_exact(4)
        .flat_map(|t| logluv([t[0], t[1], t[2]]))
        .collect();
    if map.width == 0 || map.height == 0 {
        pixels = vec![0; 4];
    }
    let mut bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut bytes, map.width.max(1), map.height.max(1));
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::High);
        let mut w = enc.write_header().map_err(err)?;
        w.write_image_data(&pixels).map_err(err)?;
        w.finish().map_err(err)?;
    }
    Ok(bytes)
}

/// Decodes an 8-bit RGBA LogLuv PNG into a map whose alpha is 1; another PNG layout or a
/// damaged file is an [`OutputError::Png`], never a panic.
pub fn decode_logluv_png(bytes: &[u8]) -> Result<MapImage, OutputError> {
    let err = |message: String| OutputError::Png {
        path: PathBuf::new(),
        message,
    };
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::IDENTITY);
    let mut reader = decoder.read_info().map_err(|e| err(e.to_string()))?;
    let info = reader.info();
    let (w, h) = (info.width, info.height);
    if info.color_type != png::ColorType::Rgba || info.bit_depth != png::BitDepth::Eight {
        return Err(err(format!(
            "{:?} {:?}: a LogLuv light map is 8-bit RGBA",
            info.color_type, info.bit_depth
        )));
    }
    if u64::from(w) * u64::from(h) > 1 << 26 {
        return Err(err(format!("{w} × {h} texels is too large")));
    }
    let mut buf = vec![
        0;
        reader
            .output_buffer_size()
            .ok_or_else(|| err("size".into()))?
    ];
    let frame = reader
        .next_frame(&mut buf)
        .map_err(|e| err(e.to_string()))?;
    let mut map = MapImage::zeros(w, h);
    for (t, p) in map
        .texels
        .chunks_exact_mut(4)
        .zip(buf[..frame.buffer_size()].chunks_exact(4))
    {
        let rgb = rgb_of_logluv([p[0], p[1], p[2], p[3]]);
        t.copy_from_slice(&[rgb[0], rgb[1], rgb[2], 1.0]);
    }
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lux(c: &[f32]) -> f64 {
        RGB_TO_XYZ[1]
            .iter()
            .zip(c)
            .map(|(w, v)| w * f64::from(*v))
            .sum()
    }

    /// Grey and tinted values from 1e-3 to 1e5 lux come back within the luminance step
    /// (plus the chromaticity's share for the tinted ones); the PNG is deterministic.
    #[test]
    fn round_trip_keeps_lux() {
        let (w, h) = (61u32, 7u32);
        let mut m = MapImage::zeros(w, h);
        for (i, t) in m.texels.chunks_exact_mut(4).enumerate() {
            let v = 10f32.powf(-3.0 + 8.0 * i as f32 / (w * h) as f32);
            let c = if i % 2 == 0 {
                [v, v, v]
            } else {
                [v, 0.8 * v, 0.6 * v]
            };
            t.copy_from_slice(&[c[0], c[1], c[2], 1.0]);
        }
        let bytes = encode_logluv_png(&m).expect("encode");
        assert_eq!(bytes, encode_logluv_png(&m).expect("encode"));
        let back = decode_logluv_png(&bytes).expect("decode");
        assert_eq!((back.width, back.height), (w, h));
        for (i, (a, b)) in m.texels.chunks(4).zip(back.texels.chunks(4)).enumerate() {
            let e = (lux(b) - lux(a)).abs() / lux(a);
            let bound = if i % 2 == 0 { 1.5e-3 } else { 3e-3 };
            assert!(e <= bound, "{a:?} {b:?}: {e}");
            for c in 0..3 {
                assert!((b[c] - a[c]).abs() <= 0.02 * a[c], "{a:?} {b:?}");
            }
        }
    }

    #[test]
    fn edges_and_bad_files() {
        assert_eq!(logluv([0.0; 3]), [0; 4]);
        assert_eq!(logluv([-1.0, f32::NAN, 0.0]), [0; 4]);
        assert_eq!(rgb_of_logluv([0; 4]), [0.0; 3]);
        // 1 lx of grey: Le = 256 · 64, D65 white at u′ 0.1978, v′ 0.4683.
        assert_eq!(logluv([1.0; 3]), [64, 0, 81, 192]);
        assert_eq!(logluv([1e-30; 3]), [0; 4]);
        let one = decode_logluv_png(&encode_logluv_png(&MapImage::zeros(0, 0)).expect("png"));
        assert_eq!(one.expect("1 × 1").texels, vec![0.0, 0.0, 0.0, 1.0]);
        let rgb = crate::encode_png(&crate::picture::Picture::filled(2, 2, [1, 2, 3]));
        let e = decode_logluv_png(&rgb.expect("png"))
            .expect_err("RGB")
            .to_string();
        assert!(e.contains("8-bit RGBA"), "{e}");
        let bytes = encode_logluv_png(&MapImage::zeros(9, 9)).expect("png");
        // Every prefix short of IEND (12 bytes; without it the image is whole) fails.
        for n in 0..bytes.len() - 12 {
            assert!(
                decode_logluv_png(&bytes[..n]).is_err(),
                "prefix of {n} bytes"
            );
        }
    }
}
