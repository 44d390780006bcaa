//! # luxbake-output
//!
//! Writes the files of a finished bake ([`luxbake::BakeOutput`]) and reads its EXRs back; its
//! own crate so that the core carries no image codec (it was `luxbake::output`; the paths
//! under it are the same, `luxbake_output::…`).
//!
//! Files of a bake: per object linear EXRs in lux, a tone-mapped PNG, a false-colour
//! illuminance PNG with a lux scale bar, the 8-stage strip of the paper's Figure 5, and a JSON
//! manifest.
//!
//! # Files, per receiving object `<name>` (characters other than `A–Z a–z 0–9 _ -` become `_`)
//! | file | content |
//! |---|---|
//! | `<name>_illuminance.exr` | final illuminance E, lux, before albedo (RGB; A = texel mask) |
//! | `<name>_exitance.exr` | final exitance M = ρ·E, lm/m² (RGB; A = mask) |
//! | `<name>_direct.exr` | direct illuminance, lux (method paper: blurred as E is; converged: unblurred, as in E); indirect = E − direct |
//! | `<name>.png` | exitance, tone-mapped ([`picture`] docs) |
//! | `<name>_false_color.png` | illuminance in false colour with a lux scale bar |
//! | `<name>_stages.png` | the eight stages of Figure 5 side by side |
//!
//! EXRs are single-part, scan-line, ZIP-compressed ([`encode_exr`]), 32-bit float RGBA, the
//! object's region only (its light-map UV square), row 0 at the top (light-map v = 0).
//!
//! # Dilation
//! The light maps — the three EXRs and `<name>.png` — are dilated into their chart padding
//! ([`MapImage::dilated`], [`dilation_passes`] rounds): every empty texel within the padding
//! holds the RGB of the nearest valid texel, so an engine can sample them bilinearly and with
//! mipmaps without pulling in black. The EXRs' alpha stays the texel mask (1 valid, 0
//! padding), so the baked texels remain recoverable; `cargo xtask measure` and
//! [`MapImage::sample`] use it. The PNG has no alpha. The diagnostic pictures
//! (`_false_color.png`, grey where no texel is valid, and `_stages.png`) are not dilated.
//!
//! # Manifest (`manifest.json`)
//! `format` ("luxbake-bake"), `version` (1), `scene` (`source`), `units`, `backend`,
//! `settings` (method, quality, tail_tolerance, rays, bounces, tail, blur, texels_per_metre, bvh,
//! seed, sampler, stride, higher_rays, higher_stride, refine_rays, refine_error, narrow_rays, denoise_correction, direct_at_hits, lamp_paths,
//! opening_samples, opening_probe_stride), `layout`
//! (`layer_size`, `layers`), `lamps` (name, position, aim, rotation_deg, tilt_deg (the tilt
//! the file's tilt factors are taken at, [`luxbake::scene::Lamp::tilt_deg`]), multiplier,
//! color, max_candela (file, at that tilt), lumens (integrated at that tilt × multiplier),
//! used, `model` (the `lamp_model` asked for), `model_used` ("point" or "area"),
//! `model_reason` (why, in words), `opening_near_m` (with the area model: the distance within
//! which texels see the opening; null: everywhere)), `objects` (name, index, receiver, and for receivers `files`, `layer`, `offset`,
//! `size`, `resolution`, plus `transform` {`linear` (columns), `translation`} for all),
//! `stats` (texels, region_texels, triangles, shadow_rays, gather_rays, bvh, bounces_run,
//! `explicit_bounces` (= bounces_run), `tail_fraction` (the estimated share of the total
//! illuminance that the converged method added for the bounces it did not run explicitly),
//! `bounce_ratio` (the ratio λ it extrapolated with, or null), `series` (the converged
//! method's energies: `direct`, per explicit bounce `increments` and the light they
//! `reflected`, Σ (r + g + b) over the valid texels, and `tail_factor`, the factor of the
//! last increment that the tail adds, when it adds one; or null)),
//! `timings` (`setup` and `passes`: label, bounce, seconds; `total_seconds`), `skipped` (text).

#![warn(missing_docs)]

pub mod logluv;
pub mod picture;

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde_json::{Value, json};

use luxbake::bake::{BakeOutput, ObjectMaps};
use luxbake::map::MapImage;
use luxbake::scene::{Blur, Scene, Settings};
use picture::{Picture, albedo_picture, exposure, false_color, false_color_range, strip, tone_map};

/// Errors writing or reading bake files.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    /// A file or folder could not be written or read.
    #[error("`{path}`: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// EXR encoding or decoding failed.
    #[error("EXR `{path}`: {message}")]
    Exr {
        /// The path (empty for in-memory encoding).
        path: PathBuf,
        /// The codec's message.
        message: String,
    },
    /// PNG encoding (or decoding, [`logluv::decode_logluv_png`]) failed.
    #[error("PNG `{path}`: {message}")]
    Png {
        /// The path.
        path: PathBuf,
        /// The codec's message.
        message: String,
    },
    /// The manifest could not be read.
    #[error("manifest `{path}`: {message}")]
    Manifest {
        /// The path.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Scan lines per chunk of a ZIP-compressed EXR (OpenEXR's `ZIP_COMPRESSION`).
const EXR_ZIP_LINES: u32 = 16;

/// Encodes a map as a 32-bit float RGBA EXR (ZIP, scan lines; a 0-sized map as one black,
/// empty texel). Deterministic: the same map gives the same bytes.
///
/// The header is the one the `exr` crate writes for such an image (channels A, B, G, R as
/// 32-bit floats, `compression` ZIP, increasing lines, display and data window the map,
/// `chunkCount`, `type` "scanlineimage"); each chunk of 16 lines is the lines' channels
/// (A, B, G, R, each a row of little-endian floats) with OpenEXR's ZIP predictor (bytes split
/// into even and odd halves, then successive differences + 128), deflated by zlib at level 1
/// — 3.7× faster than the `exr` crate's level 4 on the bake's maps at 4 % larger files — or
/// stored raw when that is not smaller. Chunks are compressed in parallel.
pub fn encode_exr(map: &MapImage) -> Result<Vec<u8>, OutputError> {
    let too_large = || OutputError::Exr {
        path: PathBuf::new(),
        message: format!(
            "{} × {} texels is too large for an EXR",
            map.width, map.height
        ),
    };
    let (w, h) = (map.width.max(1), map.height.max(1));
    // Every window coordinate and chunk size must fit an i32.
    let line_bytes = 16 * w as usize;
    if i32::try_from(h).is_err() || i32::try_from(line_bytes * EXR_ZIP_LINES as usize).is_err() {
        return Err(too_large());
    }
    let chunks = h.div_ceil(EXR_ZIP_LINES);
    let mut out = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    let attribute = |out: &mut Vec<u8>, name: &str, kind: &str, value: &[u8]| {
        for text in [name, kind] {
            out.extend_from_slice(text.as_bytes());
            out.push(0);
        }
        out.extend_from_slice(&(value.len() as i32).to_le_bytes());
        out.extend_from_slice(value);
    };
    let window: Vec<u8> = [0, 0, (w - 1) as i32, (h - 1) as i32]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let mut channels = Vec::new();
    for name in ["A", "B", "G", "R"] {
        channels.extend_from_slice(name.as_bytes());
        channels.push(0);
        // FLOAT, perceptually linear (alpha only, as the exr crate marks it), 3 reserved
        // bytes, sampling 1 × 1.
        channels.extend_from_slice(&2i32.to_le_bytes());
        channels.extend_from_slice(&[u8::from(name == "A"), 0, 0, 0]);
        channels.extend_from_slice(&1i32.to_le_bytes());
        channels.extend_from_slice(&1i32.to_le_bytes());
    }
    channels.push(0);
    attribute(
        &mut out,
        "chunkCount",
        "int",
        &(chunks as i32).to_le_bytes(),
    );
    attribute(&mut out, "channels", "chlist", &channels);
    attribute(&mut out, "compression", "compression", &[3]);
    attribute(&mut out, "lineOrder", "lineOrder", &[0]);
    attribute(&mut out, "displayWindow", "box2i", &window);
    attribute(&mut out, "pixelAspectRatio", "float", &1.0f32.to_le_bytes());
    attribute(&mut out, "screenWindowCenter", "v2f", &[0; 8]);
    attribute(
        &mut out,
        "screenWindowWidth",
        "float",
        &1.0f32.to_le_bytes(),
    );
    attribute(&mut out, "dataWindow", "box2i", &window);
    attribute(&mut out, "type", "string", b"scanlineimage");
    out.push(0);
    let packed: Vec<Vec<u8>> = (0..chunks)
        .into_par_iter()
        .map(|c| zip_chunk(map, c * EXR_ZIP_LINES..((c + 1) * EXR_ZIP_LINES).min(h)))
        .collect();
    let table = out.len();
    out.resize(table + 8 * packed.len(), 0);
    for (c, data) in packed.iter().enumerate() {
        let offset = out.len() as u64;
        out[table + 8 * c..table + 8 * c + 8].copy_from_slice(&offset.to_le_bytes());
        out.extend_from_slice(&((c as u32 * EXR_ZIP_LINES) as i32).to_le_bytes());
        out.extend_from_slice(&(data.len() as i32).to_le_bytes());
        out.extend_from_slice(data);
    }
    Ok(out)
}

/// Lines `lines` of `map` as an EXR chunk stores them uncompressed: per line the channels A,
/// B, G, R, each a row of little-endian floats. Calls `put(k, bytes)` for the `k`-th float.
fn chunk_floats(map: &MapImage, lines: std::ops::Range<u32>, mut put: impl FnMut(usize, [u8; 4])) {
    let w = map.width.max(1) as usize;
    let mut k = 0;
    for y in lines {
        let start = 4 * y as usize * w;
        let row = map.texels.get(start..start + 4 * w);
        for channel in [3, 2, 1, 0] {
            for x in 0..w {
                // Texels outside the map read 0, as `MapImage::texel` gives them.
                let v = row.map_or(0.0, |r| r[4 * x + channel]);
                put(k, v.to_le_bytes());
                k += 1;
            }
        }
    }
}

/// One chunk's bytes under OpenEXR's ZIP compression (see [`encode_exr`]): the chunk's bytes
/// split into the even and odd ones (written there directly: a float's bytes 0 and 2 go to
/// the first half, 1 and 3 to the second), successive differences + 128, deflated; the raw
/// bytes when that is not smaller.
fn zip_chunk(map: &MapImage, lines: std::ops::Range<u32>) -> Vec<u8> {
    let floats = lines.len() * 4 * map.width.max(1) as usize;
    let mut split = vec![0u8; 4 * floats];
    let (even, odd) = split.split_at_mut(2 * floats);
    chunk_floats(map, lines.clone(), |k, b| {
        even[2 * k] = b[0];
        even[2 * k + 1] = b[2];
        odd[2 * k] = b[1];
        odd[2 * k + 1] = b[3];
    });
    // Each byte less the one before it, from the end back: every step reads a byte not yet
    // changed.
    for i in (1..split.len()).rev() {
        split[i] = split[i].wrapping_sub(split[i - 1]).wrapping_add(128);
    }
    let packed = miniz_oxide::deflate::compress_to_vec_zlib(&split, 1);
    if packed.len() < split.len() {
        return packed;
    }
    let mut raw = vec![0u8; split.len()];
    chunk_floats(map, lines, |k, b| raw[4 * k..4 * k + 4].copy_from_slice(&b));
    raw
}

/// Reads an RGBA (or RGB, alpha = 1) float EXR written by [`encode_exr`] or any other tool.
pub fn read_exr(path: &Path) -> Result<MapImage, OutputError> {
    use exr::prelude::*;
    let err = |e: exr::error::Error| OutputError::Exr {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let image = read_first_rgba_layer_from_file(
        path,
        |resolution, _| MapImage::zeros(resolution.width() as u32, resolution.height() as u32),
        |m: &mut MapImage, position, (r, g, b, a): (f32, f32, f32, f32)| {
            let i = 4 * (position.y() * m.width as usize + position.x());
            if let Some(t) = m.texels.get_mut(i..i + 4) {
                t.copy_from_slice(&[r, g, b, a]);
            }
        },
    )
    .map_err(err)?;
    Ok(image.layer_data.channel_data.pixels)
}

/// Encodes an 8-bit RGB PNG, lossless, with the `png` crate's fast deflate
/// ([`png::Compression::Fast`]: fdeflate, adaptive row filters): several times faster than its
/// default level at slightly larger files.
pub fn encode_png(p: &Picture) -> Result<Vec<u8>, OutputError> {
    let mut bytes = Vec::new();
    let err = |e: png::EncodingError| OutputError::Png {
        path: PathBuf::new(),
        message: e.to_string(),
    };
    {
        let mut enc = png::Encoder::new(&mut bytes, p.width.max(1), p.height.max(1));
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Fast);
        let mut w = enc.write_header().map_err(err)?;
        if p.width == 0 || p.height == 0 {
            w.write_image_data(&[0, 0, 0]).map_err(err)?;
        } else {
            w.write_image_data(&p.rgb).map_err(err)?;
        }
        w.finish().map_err(err)?;
    }
    Ok(bytes)
}

/// A file-name-safe version of an object name.
pub fn file_stem(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() { "object".into() } else { s }
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    std::fs::write(path, bytes).map_err(io(path))
}

/// The file names of one object's outputs.
fn object_files(stem: &str) -> [(&'static str, String); 6] {
    [
        ("illuminance", format!("{stem}_illuminance.exr")),
        ("exitance", format!("{stem}_exitance.exr")),
        ("direct", format!("{stem}_direct.exr")),
        ("png", format!("{stem}.png")),
        ("false_color", format!("{stem}_false_color.png")),
        ("stages", format!("{stem}_stages.png")),
    ]
}

/// A bake's settings as the manifest's `settings` object (every field of [`Settings`], the
/// blur a sigma in texels or `"none"`).
pub fn settings_json(s: &Settings) -> Value {
    json!({
        "method": s.method.name(),
        "quality": s.quality.name(),
        "tail_tolerance": s.tail_tolerance,
        "rays": s.rays,
        "bounces": s.bounces,
        "tail": s.tail,
        "blur": blur_json(s.blur),
        "texels_per_metre": s.texels_per_metre,
        "bvh": s.bvh.name(),
        "seed": s.seed,
        "sampler": s.sampler.name(),
        "stride": s.stride,
        "higher_rays": s.higher_rays,
        "lamp_paths": s.lamp_paths,
        "opening_samples": s.opening_samples,
        "opening_probe_stride": s.opening_probe_stride,
        "higher_stride": s.higher_stride,
        "refine_rays": s.refine_rays,
        "refine_error": s.refine_error,
        "narrow_rays": s.narrow_rays,
        "denoise_correction": s.denoise_correction,
        "direct_at_hits": s.direct_at_hits,
    })
}

fn blur_json(b: Blur) -> Value {
    match b {
        Blur::None => json!("none"),
        Blur::Sigma(s) => json!(s),
    }
}

/// Writes every file of a bake into `dir` (created if missing) and returns the manifest,
/// which is also written as `manifest.json`. `source` names where the scene came from
/// (`builtin:<name>` or the scene file's path), for `cargo xtask measure`.
pub fn write_bake(
    dir: &Path,
    scene: &Scene,
    output: &BakeOutput,
    source: &str,
) -> Result<Value, OutputError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let exp = exposure(output.maps.iter().map(ObjectMaps::exitance));
    let (lo, hi) = false_color_range(output.maps.iter().map(ObjectMaps::illuminance));
    let mut stems = std::collections::HashSet::new();
    let mut objects = Vec::new();
    // (object's maps, its file names), written in parallel below.
    let mut jobs = Vec::new();
    for (i, o) in scene.objects.iter().enumerate() {
        let t = o.transform;
        let mut entry = json!({
            "name": o.name,
            "index": i,
            "receiver": o.receiver,
            "transform": {"linear": t.linear, "translation": t.translation},
        });
        if let Some(maps) = output.maps.iter().find(|m| m.object == i) {
            let mut stem = file_stem(&o.name);
            if !stems.insert(stem.clone()) {
                stem = format!("{stem}_{i}");
                stems.insert(stem.clone());
            }
            let files = object_files(&stem);
            let r = maps.region;
            entry["files"] = Value::Object(
                files
                    .iter()
                    .map(|(k, f)| ((*k).to_string(), json!(f)))
                    .collect(),
            );
            entry["layer"] = json!(r.layer);
            entry["offset"] = json!(r.offset);
            entry["size"] = json!(r.size);
            entry["resolution"] = json!(r.size);
            jobs.push((maps, files));
        }
        objects.push(entry);
    }
    let passes = dilation_passes(&output.settings);
    // Every object's files at once; the first error in object order is reported.
    jobs.par_iter()
        .map(|(maps, files)| write_object(dir, maps, files, exp, (lo, hi), passes))
        .collect::<Vec<_>>()
        .into_iter()
        .collect::<Result<(), _>>()?;
    let s = &output.settings;
    let rep = &output.report;
    let lamps: Vec<Value> = scene
        .lamps
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let tilt = l.tilt_deg();
            let (max_cd, _) = l.photometry.max_intensity_tilted(tilt);
            let choice = rep.lamp_models.iter().find(|c| c.lamp == i);
            json!({
                "name": l.name,
                "position": l.position,
                "aim": l.aim,
                "rotation_deg": l.rotation_deg,
                "tilt_deg": tilt,
                "multiplier": l.multiplier,
                "color": l.color,
                "max_candela": max_cd,
                "lumens": l.photometry.luminous_flux_tilted(tilt) * f64::from(l.multiplier),
                "used": output.lamps_used.contains(&i),
                "model": l.model.name(),
                "model_used": choice.map(|c| c.used()),
                "model_reason": choice.map(|c| c.reason.clone()),
                "opening_near_m": choice.and_then(|c| c.near_m),
            })
        })
        .collect();
    let manifest = json!({
        "format": "luxbake-bake",
        "version": 1,
        "scene": {"source": source},
        "units": {"length": "m", "illuminance": "lux", "exitance": "lm/m^2"},
        "backend": rep.backend,
        "settings": settings_json(s),
        "layout": {"layer_size": output.layout.layer_size, "layers": output.layout.layers},
        "lamps": lamps,
        "objects": objects,
        "stats": {
            "texels": rep.texels,
            "region_texels": rep.region_texels,
            "triangles": rep.triangles,
            "shadow_rays": rep.shadow_rays,
            "gather_rays": rep.gather_rays,
            "bvh": rep.bvh.name(),
            "bounces_run": rep.bounces_run,
            "explicit_bounces": rep.bounces_run,
            "tail_fraction": rep.tail_fraction,
            "bounce_ratio": rep.bounce_ratio,
            "series": rep.series.as_ref().map(|s| json!({
                "direct": s.direct,
                "increments": s.increments,
                "reflected": s.reflected,
                "tail_factor": s.tail_factor(),
            })),
        },
        "timings": {
            "setup": rep.setup.iter().map(|(k, t)| json!({"label": k, "seconds": t})).collect::<Vec<_>>(),
            "passes": rep.passes.iter().map(|p| json!({"label": p.label, "bounce": p.bounce, "seconds": p.seconds})).collect::<Vec<_>>(),
            "total_seconds": rep.total_seconds,
        },
        "skipped": rep.skipped.iter().map(ToString::to_string).collect::<Vec<_>>(),
        "false_color_lux": [lo, hi],
        "exposure": exp,
    });
    let path = dir.join("manifest.json");
    let text = serde_json::to_string_pretty(&manifest).map_err(|e| OutputError::Manifest {
        path: path.clone(),
        message: e.to_string(),
    })?;
    write(&path, text.as_bytes())?;
    Ok(manifest)
}

/// Rounds of [`MapImage::dilated`] for the written maps of a bake with `settings`: the chart
/// padding ([`chart_padding_texels`](luxbake::layout::chart_padding_texels)), so every texel of
/// the padding between and around charts is filled.
pub fn dilation_passes(settings: &Settings) -> u32 {
    luxbake::layout::chart_padding_texels(settings.blur).ceil() as u32
}

/// Writes one object's six files (`files`, in [`object_files`] order), each encoded on its
/// own rayon task; the first error in file order is reported.
fn write_object(
    dir: &Path,
    maps: &ObjectMaps,
    files: &[(&'static str, String); 6],
    exp: f32,
    (lo, hi): (f32, f32),
    passes: u32,
) -> Result<(), OutputError> {
    let with_path = |p: PathBuf| {
        move |e: OutputError| match e {
            OutputError::Exr { message, .. } => OutputError::Exr { path: p, message },
            OutputError::Png { message, .. } => OutputError::Png { path: p, message },
            other => other,
        }
    };
    let exrs: Vec<MapImage> = [maps.illuminance(), maps.exitance(), maps.direct()]
        .par_iter()
        .map(|m| m.dilated(passes))
        .collect();
    let picture = |k: usize| match k {
        // The PNG has no mask: the dilated exitance, every texel shown (unfilled ones are 0).
        3 => {
            let mut exitance = exrs[1].clone();
            exitance.texels.chunks_exact_mut(4).for_each(|t| t[3] = 1.0);
            tone_map(&exitance, exp)
        }
        4 => false_color(maps.illuminance(), lo, hi),
        _ => {
            let stages: [Option<Picture>; 8] = std::array::from_fn(|i| {
                maps.stages[i].as_ref().map(|m| {
                    if i == 0 {
                        albedo_picture(m)
                    } else {
                        tone_map(m, exp)
                    }
                })
            });
            strip(&stages, maps.region.size[0], maps.region.size[1])
        }
    };
    files
        .par_iter()
        .enumerate()
        .map(|(k, (_, name))| {
            let path = dir.join(name);
            let bytes = match exrs.get(k) {
                Some(map) => encode_exr(map),
                None => encode_png(&picture(k)),
            }
            .map_err(with_path(path.clone()))?;
            write(&path, &bytes)
        })
        .collect::<Vec<_>>()
        .into_iter()
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Written EXRs read back exactly (with the `exr` crate's reader) — one chunk, three
    /// chunks (a partial last one), a chunk stored raw (noise deflate cannot shrink) and a
    /// 0-sized map (one empty texel) — and the bytes are deterministic.
    #[test]
    fn exr_round_trip_is_exact_and_deterministic() {
        let dir = std::env::temp_dir().join(format!("luxbake-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        let mut state = 7u32;
        let mut noise = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            f32::from_bits(state >> 2)
        };
        for (k, (w, h, random)) in [(5, 3, false), (7, 37, false), (9, 4, true), (0, 0, false)]
            .into_iter()
            .enumerate()
        {
            let mut m = MapImage::zeros(w, h);
            for (i, v) in m.texels.iter_mut().enumerate() {
                *v = if random {
                    noise()
                } else {
                    i as f32 * 0.37 + 1e-3
                };
            }
            let a = encode_exr(&m).expect("encode");
            assert_eq!(a, encode_exr(&m).expect("encode"));
            if random {
                // One chunk, stored raw: its size field says 4 lines × 9 texels × 16 bytes.
                let raw = 4 * 9 * 16;
                let size = &a[a.len() - raw - 4..a.len() - raw];
                assert_eq!(size, (raw as i32).to_le_bytes());
            }
            let path = dir.join(format!("m{k}.exr"));
            std::fs::write(&path, &a).expect("write");
            let back = read_exr(&path).expect("read");
            if w == 0 {
                assert_eq!(back, MapImage::zeros(1, 1));
            } else {
                assert_eq!(back, m, "{w} × {h}");
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The written PNG decodes to exactly the picture's pixels (the fast deflate is lossless),
    /// on a picture with smooth and noisy rows so that every row filter is exercised.
    #[test]
    fn png_round_trip_is_exact() {
        let (w, h) = (67u32, 41u32);
        let mut p = Picture::filled(w, h, [0; 3]);
        let mut state = 12345u32;
        for y in 0..h {
            for x in 0..w {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let noise = (state >> 24) as u8;
                let c = if y % 3 == 0 {
                    [noise, noise / 2, 255 - noise]
                } else {
                    [(x * 3) as u8, (y * 5) as u8, (x + y) as u8]
                };
                p.set(x, y, c);
            }
        }
        let bytes = encode_png(&p).expect("png");
        let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
            .read_info()
            .expect("header");
        let mut rgb = vec![0; reader.output_buffer_size().expect("size")];
        let info = reader.next_frame(&mut rgb).expect("frame");
        assert_eq!((info.width, info.height), (w, h));
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(&rgb[..info.buffer_size()], &p.rgb[..]);
    }

    #[test]
    fn png_encodes_and_names_are_safe() {
        let p = Picture::filled(3, 2, [1, 2, 3]);
        let bytes = encode_png(&p).expect("png");
        assert_eq!(&bytes[1..4], b"PNG");
        assert!(encode_png(&Picture::filled(0, 0, [0; 3])).is_ok());
        assert_eq!(file_stem("chair 01/seat"), "chair_01_seat");
        assert_eq!(file_stem(""), "object");
        assert_eq!(file_stem("Wand-Nord_2"), "Wand-Nord_2");
    }
}
