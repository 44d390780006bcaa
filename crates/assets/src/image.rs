//! PNG and JPEG decoding into linear albedo textures, and PNG encoding of albedo textures.

use luxbake::scene::AlbedoTexture;

use crate::Limits;

/// The sRGB electro-optical transfer function: an 8-bit sRGB value to linear [0, 1].
pub(crate) fn srgb_to_linear(b: u8) -> f32 {
    let c = f32::from(b) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear [0, 1] to an 8-bit sRGB value.
pub(crate) fn linear_to_srgb(x: f32) -> u8 {
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let c = if x <= 0.003_130_8 {
        x * 12.92
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (c * 255.0 + 0.5) as u8
}

/// Decodes PNG or JPEG bytes (sniffed by signature) into a linear texture, checking the size
/// against `limits` before decoding and box-filtering it down to at most
/// `limits.albedo_texture_side` per side.
pub(crate) fn decode(bytes: &[u8], limits: &Limits) -> Result<AlbedoTexture, String> {
    let (w, h, channels, data) = if bytes.starts_with(b"\x89PNG") {
        decode_png(bytes, limits)?
    } else if bytes.starts_with(&[0xFF, 0xD8]) {
        decode_jpeg(bytes, limits)?
    } else {
        return Err("not a PNG or JPEG image".into());
    };
    let n = (w as usize) * (h as usize);
    if channels == 0 || data.len() < n * channels {
        return Err("decoded image is shorter than its header says".into());
    }
    let lut: Vec<f32> = (0..=255u8).map(srgb_to_linear).collect();
    let texels: Vec<[f32; 3]> = data
        .chunks_exact(channels)
        .take(n)
        .map(|px| match channels {
            1 | 2 => [lut[px[0] as usize]; 3],
            _ => [
                lut[px[0] as usize],
                lut[px[1] as usize],
                lut[px[2] as usize],
            ],
        })
        .collect();
    Ok(shrink(
        AlbedoTexture {
            width: w,
            height: h,
            texels,
        },
        limits.albedo_texture_side.max(1),
    ))
}

fn check_size(w: u32, h: u32, limits: &Limits) -> Result<(), String> {
    if w == 0 || h == 0 {
        return Err(format!("{w}×{h} image has no texels"));
    }
    if w.max(h) > limits.max_texture_side || u64::from(w) * u64::from(h) > limits.max_texture_texels
    {
        return Err(format!(
            "{w}×{h} texels exceeds the limits (side {}, texels {})",
            limits.max_texture_side, limits.max_texture_texels
        ));
    }
    Ok(())
}

fn decode_png(bytes: &[u8], limits: &Limits) -> Result<(u32, u32, usize, Vec<u8>), String> {
    let cap = usize::try_from(limits.max_texture_texels.saturating_mul(8)).unwrap_or(usize::MAX);
    let mut dec =
        png::Decoder::new_with_limits(std::io::Cursor::new(bytes), png::Limits { bytes: cap });
    dec.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = dec.read_info().map_err(|e| format!("PNG: {e}"))?;
    let (w, h) = (reader.info().width, reader.info().height);
    check_size(w, h, limits)?;
    let size = reader
        .output_buffer_size()
        .ok_or("PNG: image too large for memory")?;
    let mut buf = vec![0u8; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| format!("PNG: {e}"))?;
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => return Err("PNG: palette was not expanded".into()),
    };
    // Rows may be padded to `line_size`.
    let row = w as usize * channels;
    let mut data = Vec::with_capacity(row * h as usize);
    for y in 0..h as usize {
        let start = y * info.line_size;
        let line = buf
            .get(start..start + row)
            .ok_or("PNG: truncated image data")?;
        data.extend_from_slice(line);
    }
    Ok((w, h, channels, data))
}

fn decode_jpeg(bytes: &[u8], limits: &Limits) -> Result<(u32, u32, usize, Vec<u8>), String> {
    use zune_jpeg::zune_core::colorspace::ColorSpace;
    use zune_jpeg::zune_core::options::DecoderOptions;
    let side = limits.max_texture_side as usize;
    let options = DecoderOptions::default()
        .jpeg_set_out_colorspace(ColorSpace::RGB)
        .set_max_width(side)
        .set_max_height(side);
    let mut dec = zune_jpeg::JpegDecoder::new_with_options(bytes, options);
    dec.decode_headers().map_err(|e| format!("JPEG: {e:?}"))?;
    let (w, h) = dec.dimensions().ok_or("JPEG: no dimensions")?;
    let (w, h) = (
        u32::try_from(w).map_err(|_| "JPEG: too wide")?,
        u32::try_from(h).map_err(|_| "JPEG: too tall")?,
    );
    check_size(w, h, limits)?;
    let data = dec.decode().map_err(|e| format!("JPEG: {e:?}"))?;
    let channels = dec
        .get_output_colorspace()
        .map_or(3, |c| c.num_components());
    Ok((w, h, channels, data))
}

/// Halves the texture (2×2 box filter) until both sides are at most `max_side`.
fn shrink(mut t: AlbedoTexture, max_side: u32) -> AlbedoTexture {
    while t.width.max(t.height) > max_side && t.width > 1 && t.height > 1 {
        let (w, h) = (t.width / 2, t.height / 2);
        let src = |x: u32, y: u32| t.texels[(y * t.width + x) as usize];
        let mut texels = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                let s = [
                    src(2 * x, 2 * y),
                    src(2 * x + 1, 2 * y),
                    src(2 * x, 2 * y + 1),
                    src(2 * x + 1, 2 * y + 1),
                ];
                texels.push(std::array::from_fn(|k| {
                    (s[0][k] + s[1][k] + s[2][k] + s[3][k]) / 4.0
                }));
            }
        }
        t = AlbedoTexture {
            width: w,
            height: h,
            texels,
        };
    }
    t
}

/// Encodes a linear texture as an 8-bit sRGB PNG.
pub(crate) fn encode_albedo_png(t: &AlbedoTexture) -> Result<Vec<u8>, String> {
    let (w, h) = (t.width.max(1), t.height.max(1));
    let mut rgb = Vec::with_capacity((w * h * 3) as usize);
    for i in 0..(w * h) as usize {
        let c = t.texels.get(i).copied().unwrap_or([1.0; 3]);
        rgb.extend(c.map(linear_to_srgb));
    }
    encode_rgb_png(w, h, &rgb)
}

/// Encodes 8-bit RGB rows (row 0 first) as a PNG.
pub(crate) fn encode_rgb_png(w: u32, h: u32, rgb: &[u8]) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut wr = enc.write_header().map_err(|e| e.to_string())?;
        wr.write_image_data(rgb).map_err(|e| e.to_string())?;
        wr.finish().map_err(|e| e.to_string())?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trips() {
        for b in 0..=255u8 {
            assert_eq!(linear_to_srgb(srgb_to_linear(b)), b);
        }
        assert_eq!(srgb_to_linear(255), 1.0);
        assert!((srgb_to_linear(188) - 0.5).abs() < 0.01);
    }

    #[test]
    fn png_round_trip_and_shrink() {
        let t = AlbedoTexture {
            width: 4,
            height: 2,
            texels: (0..8).map(|i| [i as f32 / 8.0, 0.5, 1.0]).collect(),
        };
        let bytes = encode_albedo_png(&t).expect("encode");
        let back = decode(&bytes, &Limits::default()).expect("decode");
        assert_eq!((back.width, back.height), (4, 2));
        for (a, b) in back.texels.iter().zip(&t.texels) {
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() < 0.01, "{a:?} {b:?}");
            }
        }
        let small = decode(
            &bytes,
            &Limits {
                albedo_texture_side: 2,
                ..Limits::default()
            },
        )
        .expect("decode");
        assert_eq!((small.width, small.height), (2, 1));
        let tiny = Limits {
            max_texture_side: 3,
            ..Limits::default()
        };
        assert!(decode(&bytes, &tiny).unwrap_err().contains("limits"));
        assert!(decode(&bytes[..bytes.len() / 2], &Limits::default()).is_err());
        assert!(decode(b"GIF89a", &Limits::default()).is_err());
    }
}
