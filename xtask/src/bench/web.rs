//! `cargo xtask bench web [--quick] [--lamps A,B]`: the light-map encodings for the web GLB
//! (issue 28, item 4), measured on catalogue bakes.
//!
//! Rooms: `chairs_05` and `bench/scenes/web_showroom.toml` (the catalogue test's showroom with
//! the shared SheenChair), each lit by every lamp file of `--lamps` (from
//! `../shared/photometry`: three manufacturers' IES files and a EULUMDAT file) at the
//! converged method's `default` preset, baked on the CPU as a catalogue row is. Per room ×
//! lamp, every receiver's illuminance map — dilated as the row's EXRs are — is encoded by each
//! candidate and decoded again:
//! - `rgbe-hdr`: Radiance HDR with its run-length encoding (Mozilla Hubs' `MOZ_texture_rgbe`
//!   images), decoded as three.js's `HDRLoader` does (`m · 2^(e − 128) / 255`), as floats and
//!   (`rgbe-hdr-half`) as the half floats of its default `HalfFloatType` (three's
//!   `toHalfFloat` truncates the mantissa);
//! - `rgbe-png`: the same RGBE bytes as an RGBA PNG;
//! - `rgbm-png`: RGBM, `rgb · a · M` with the range `M` the row's largest value (nothing
//!   clips), RGBA PNG;
//! - `logluv-png`: 32-bit LogLuv (`luxbake_output::logluv`, what the web GLB ships: 16-bit
//!   log2 luminance in 1/256 stops, CIE u′ v′ × 410 in 8 bits each), RGBA PNG;
//! - `half-ktx2`: RGBA half floats (round to nearest) in a KTX2 file without supercompression
//!   (`VK_FORMAT_R16G16B16A16_SFLOAT`, what three.js's `KTX2Loader` reads without its
//!   transcoder); and, for scale, `half-png16`: the same half floats deflated (a 16-bit RGBA
//!   PNG of their bits), about what a supercompressed KTX2 could reach.
//!
//! Sizes are summed over the row's receivers and set against the row's illuminance EXRs
//! (`luxbake_output::encode_exr`, the same maps). The error is |decoded − float| / float over
//! the receivers' valid texels of at least 1 lx (and at most the maximum, which every value
//! is), mean and max: of a texel's lux (the Rec. 709 luminance of its RGB, what `luxbake
//! measure` reports), and of each colour channel of at least 1 lx. PNGs use the `png` crate's `High`
//! compression. `--quick` (CI) bakes `chairs_05` with the first lamp at 16 texels/m and writes
//! to `target/bench-quick/`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use luxbake::map::MapImage;
use luxbake::scene::{Scene, SettingsPatch};
use luxbake::sources::scenefile::{from_file_patched, read_photometry};
use luxbake_backends::BackendKind;
use luxbake_output::logluv;
use serde_json::json;

use super::{luminance_f64, machine, open, timed_bake, utc_now, write_results};

/// Arguments of `cargo xtask bench web`.
#[derive(clap::Args)]
pub struct Args {
    /// Lamp files under `../shared/photometry`, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "real-world/rw_1.IES,real-world/rw_5.IES,real-world/rw_7.IES,acrux_452lm.ldt"
    )]
    lamps: Vec<String>,
}

/// The candidates, in table order.
const CANDIDATES: [&str; 7] = [
    "rgbe-hdr",
    "rgbe-hdr-half",
    "rgbe-png",
    "rgbm-png",
    "logluv-png",
    "half-ktx2",
    "half-png16",
];

/// One candidate on one room × lamp.
#[derive(Default, Clone)]
struct Measure {
    bytes: u64,
    /// Relative errors of the texels' lux (Rec. 709 luminance).
    lux: Errors,
    /// Relative errors per colour channel.
    channel: Errors,
}

/// Sum, count and largest of relative errors.
#[derive(Default, Clone, Copy)]
struct Errors {
    sum: f64,
    n: u64,
    max: f64,
}

impl Errors {
    /// Adds `|d − r| / r` when `r` is at least 1 lx.
    fn add(&mut self, r: f64, d: f64) {
        if r >= 1.0 {
            let e = (d - r).abs() / r;
            self.sum += e;
            self.n += 1;
            self.max = self.max.max(e);
        }
    }

    fn mean(&self) -> f64 {
        self.sum / (self.n.max(1) as f64)
    }

    fn merge(self, o: Errors) -> Errors {
        Errors {
            sum: self.sum + o.sum,
            n: self.n + o.n,
            max: self.max.max(o.max),
        }
    }

    fn json(&self) -> serde_json::Value {
        json!({"mean": self.mean(), "max": self.max, "n": self.n})
    }
}

impl Measure {
    fn add(&mut self, reference: &MapImage, decoded: &MapImage) {
        for (r, d) in reference
            .texels
            .chunks_exact(4)
            .zip(decoded.texels.chunks_exact(4))
        {
            if r[3] <= 0.5 {
                continue;
            }
            self.lux.add(luminance_f64(r), luminance_f64(d));
            for c in 0..3 {
                self.channel.add(f64::from(r[c]), f64::from(d[c]));
            }
        }
    }
}

/// A room × lamp: the illuminance EXRs' bytes, the largest value, each candidate's measure.
struct Row {
    room: String,
    lamp: String,
    exr_bytes: u64,
    max_lux: f32,
    measures: Vec<Measure>,
}

/// `bench/scenes/web_showroom.toml`.
fn showroom_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../bench/scenes/web_showroom.toml")
}

/// `relative` under `../shared/photometry`.
fn photometry_path(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/photometry")
        .join(relative)
}

/// Runs the study and writes `web-<date>-<machine>.{md,json}`.
pub fn run(args: &Args, quick: bool, out: &Path) -> Result<(), String> {
    let (mut backend, _) = open(BackendKind::Cpu)?;
    let patch = SettingsPatch {
        texels_per_metre: quick.then_some(16.0),
        ..SettingsPatch::default()
    };
    let rooms: Vec<(&str, Scene)> = {
        let settings = patch.settings().map_err(|e| e.reason.clone())?;
        let chairs =
            Scene::builtin_with_settings("chairs_05", settings).map_err(|e| e.to_string())?;
        if quick {
            vec![("chairs_05", chairs)]
        } else {
            let loader = luxbake_assets::SceneLoader::default();
            let showroom = from_file_patched(&showroom_path(), Some(&loader), &patch)
                .map_err(|e| format!("{}: {e}", showroom_path().display()))?;
            vec![("chairs_05", chairs), ("web_showroom", showroom)]
        }
    };
    let lamps = if quick {
        &args.lamps[..1.min(args.lamps.len())]
    } else {
        &args.lamps[..]
    };
    let mut rows = Vec::new();
    for (room, base) in &rooms {
        for lamp in lamps {
            let path = photometry_path(lamp);
            let photometry =
                read_photometry(&path).map_err(|e| format!("{}: {e}", path.display()))?;
            let mut scene = base.clone();
            for l in &mut scene.lamps {
                l.photometry = photometry.clone();
            }
            eprintln!("web: {room} × {lamp}");
            let run = timed_bake(&mut backend, &scene, &scene.settings)?;
            rows.push(measure_row(room, lamp, &run.out)?);
        }
    }
    let (md, json) = report(&rows, quick);
    print!("{md}");
    write_results(out, "web", &md, &json)
}

/// Every candidate on the receivers of one bake.
fn measure_row(room: &str, lamp: &str, out: &luxbake::BakeOutput) -> Result<Row, String> {
    let passes = luxbake_output::dilation_passes(&out.settings);
    let maps: Vec<MapImage> = out
        .maps
        .iter()
        .map(|m| m.illuminance().dilated(passes))
        .collect();
    let range = maps
        .iter()
        .flat_map(|m| m.valid_rgb())
        .flatten()
        .fold(0.0f32, f32::max);
    let mut measures = vec![Measure::default(); CANDIDATES.len()];
    let mut exr_bytes = 0;
    for map in &maps {
        exr_bytes += luxbake_output::encode_exr(map)
            .map_err(|e| e.to_string())?
            .len() as u64;
        let rgbe = bytes_of(map, |c| rgbe([c[0], c[1], c[2]]));
        let hdr_bytes = radiance_hdr_bytes(map, &rgbe);
        let decoded = decode_bytes(map, &rgbe, rgb_of_rgbe);
        let halves = mapped(&decoded, |v| f16_to_f32(f32_to_f16_truncated(v)));
        let rgbm = bytes_of(map, |c| rgbm(c, range));
        let logluv_png = logluv::encode_logluv_png(map).map_err(|e| e.to_string())?;
        let logluv_back = logluv::decode_logluv_png(&logluv_png).map_err(|e| e.to_string())?;
        let half = mapped(map, |v| f16_to_f32(f32_to_f16(v)));
        let ktx2 = ktx2_rgba16f(map);
        let png16 = half_png16(map)?;
        let results: [(u64, MapImage); 7] = [
            (hdr_bytes, decoded.clone()),
            (hdr_bytes, halves),
            (png_rgba(map, &rgbe)?, decoded),
            (
                png_rgba(map, &rgbm)?,
                decode_bytes(map, &rgbm, |t| rgbm_rgb(t, range)),
            ),
            (logluv_png.len() as u64, with_alpha(logluv_back, map)),
            (ktx2.len() as u64, half.clone()),
            (png16, half),
        ];
        for (m, (bytes, back)) in measures.iter_mut().zip(results) {
            m.bytes += bytes;
            m.add(map, &back);
        }
    }
    Ok(Row {
        room: room.into(),
        lamp: lamp.into(),
        exr_bytes,
        max_lux: range,
        measures,
    })
}

/// `map` with `f` applied to every RGB value (alpha kept).
fn mapped(map: &MapImage, f: impl Fn(f32) -> f32) -> MapImage {
    let mut m = map.clone();
    for t in m.texels.chunks_exact_mut(4) {
        for v in &mut t[..3] {
            *v = f(*v);
        }
    }
    m
}

/// Four bytes a texel from `f`.
fn bytes_of(map: &MapImage, f: impl Fn([f32; 4]) -> [u8; 4]) -> Vec<u8> {
    map.texels
        .chunks_exact(4)
        .flat_map(|t| f([t[0], t[1], t[2], t[3]]))
        .collect()
}

/// `map`'s shape with each texel's RGB decoded from its four bytes.
fn decode_bytes(map: &MapImage, bytes: &[u8], f: impl Fn([u8; 4]) -> [f32; 3]) -> MapImage {
    let mut m = map.clone();
    for (t, b) in m.texels.chunks_exact_mut(4).zip(bytes.chunks_exact(4)) {
        let rgb = f([b[0], b[1], b[2], b[3]]);
        t[..3].copy_from_slice(&rgb);
    }
    m
}

/// RGBM with range `m`: `a` the smallest step of 1/255 with `rgb ≤ 1`.
fn rgbm(c: [f32; 4], m: f32) -> [u8; 4] {
    let top = c[0].max(c[1]).max(c[2]).max(0.0);
    let a = ((top / m * 255.0).ceil()).clamp(1.0, 255.0);
    let scale = 255.0 * 255.0 / (a * m);
    let q = |v: f32| (v.max(0.0) * scale).round().min(255.0) as u8;
    [q(c[0]), q(c[1]), q(c[2]), a as u8]
}

fn rgbm_rgb(t: [u8; 4], m: f32) -> [f32; 3] {
    let s = f32::from(t[3]) / 255.0 * m / 255.0;
    [t[0], t[1], t[2]].map(|v| f32::from(v) * s)
}

/// `decoded` with the texel mask of `map` (the decoded PNG has alpha 1).
fn with_alpha(mut decoded: MapImage, map: &MapImage) -> MapImage {
    for (d, m) in decoded
        .texels
        .chunks_exact_mut(4)
        .zip(map.texels.chunks_exact(4))
    {
        d[3] = m[3];
    }
    decoded
}

/// RGBE bytes as three.js's `HDRLoader` decodes them: the largest channel's mantissa in
/// (127.5, 255], every mantissa rounded to nearest.
fn rgbe(rgb: [f32; 3]) -> [u8; 4] {
    let c = rgb.map(|v| if v.is_finite() && v > 0.0 { v } else { 0.0 });
    let top = c[0].max(c[1]).max(c[2]);
    if top <= 0.0 {
        return [0; 4];
    }
    let k = (f64::from(top).log2().ceil() as i32).clamp(-127, 127);
    let scale = 255.0 / 2f64.powi(k);
    let m = c.map(|v| (f64::from(v) * scale).round().min(255.0) as u8);
    if m == [0; 3] {
        return [0; 4];
    }
    [m[0], m[1], m[2], (k + 128) as u8]
}

/// `m · 2^(e − 128) / 255` (three.js's `HDRLoader`).
fn rgb_of_rgbe(t: [u8; 4]) -> [f32; 3] {
    if t[3] == 0 {
        return [0.0; 3];
    }
    let scale = 2f64.powi(i32::from(t[3]) - 128) / 255.0;
    [t[0], t[1], t[2]].map(|m| (f64::from(m) * scale) as f32)
}

/// The size of a Radiance HDR file of the RGBE `bytes` (four a texel): its header and every
/// scan line run-length encoded per component (Radiance's RLE: runs of 3 to 127 equal bytes
/// as two bytes, literals of up to 128 bytes after a count byte; lines narrower than 8 texels
/// or wider than 32767 flat).
fn radiance_hdr_bytes(map: &MapImage, bytes: &[u8]) -> u64 {
    let (w, h) = (map.width.max(1) as usize, map.height.max(1) as usize);
    let header = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").len();
    if !(8..=0x7fff).contains(&w) || bytes.len() < 4 * w * h {
        return (header + 4 * w * h) as u64;
    }
    let mut total = header;
    for line in bytes.chunks_exact(4 * w) {
        total += 4;
        for c in 0..4 {
            let comp: Vec<u8> = line.iter().skip(c).step_by(4).copied().collect();
            let run_at = |i: usize| {
                comp[i..]
                    .iter()
                    .take(127)
                    .take_while(|&&b| b == comp[i])
                    .count()
            };
            let mut i = 0;
            while i < comp.len() {
                if run_at(i) >= 3 {
                    total += 2;
                    i += run_at(i);
                    continue;
                }
                let start = i;
                while i < comp.len() && i - start < 128 && run_at(i) < 3 {
                    i += 1;
                }
                total += 1 + i - start;
            }
        }
    }
    total as u64
}

/// `f32` to IEEE half, rounding to nearest (ties to even); beyond 65504 to infinity.
fn f32_to_f16(v: f32) -> u16 {
    let bits = v.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let exp = ((bits >> 23) & 0xff) as i32 - 127 + 15;
    let mant = bits & 0x7f_ffff;
    if exp >= 31 {
        return sign | 0x7c00;
    }
    if exp <= 0 {
        if exp < -10 {
            return sign;
        }
        let m = mant | 0x80_0000;
        let shift = (14 - exp) as u32;
        let half = m >> shift;
        let rest = m & ((1 << shift) - 1);
        let mid = 1 << (shift - 1);
        let round = u32::from(rest > mid || (rest == mid && half & 1 == 1));
        return sign | (half + round) as u16;
    }
    let half = ((exp as u32) << 10) | (mant >> 13);
    let rest = mant & 0x1fff;
    let round = u32::from(rest > 0x1000 || (rest == 0x1000 && half & 1 == 1));
    sign | (half + round) as u16
}

/// `f32` to IEEE half as three.js's `DataUtils.toHalfFloat` does: clamped to ±65504, the
/// mantissa truncated.
fn f32_to_f16_truncated(v: f32) -> u16 {
    let v = v.clamp(-65504.0, 65504.0);
    let bits = v.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let exp = ((bits >> 23) & 0xff) as i32 - 127 + 15;
    let mant = bits & 0x7f_ffff;
    if exp <= 0 {
        if exp < -10 {
            return sign;
        }
        return sign | ((mant | 0x80_0000) >> (14 - exp)) as u16;
    }
    sign | (((exp as u32) << 10) | (mant >> 13)) as u16
}

fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = i32::from((h >> 10) & 0x1f);
    let mant = f32::from(h & 0x3ff);
    sign * match exp {
        0 => mant * 2f32.powi(-24),
        31 => f32::INFINITY,
        e => (1.0 + mant / 1024.0) * 2f32.powi(e - 15),
    }
}

/// A KTX2 file of `map` as RGBA half floats: header, index, one level, the data format
/// descriptor of `VK_FORMAT_R16G16B16A16_SFLOAT`, no supercompression.
fn ktx2_rgba16f(map: &MapImage) -> Vec<u8> {
    const VK_FORMAT_R16G16B16A16_SFLOAT: u32 = 97;
    let (w, h) = (map.width.max(1), map.height.max(1));
    let data: Vec<u8> = map
        .texels
        .iter()
        .flat_map(|&v| f32_to_f16(v).to_le_bytes())
        .collect();
    // The basic data format descriptor block: 24 bytes, then 16 a sample (R, G, B, A).
    let mut dfd = Vec::new();
    let block_size: u32 = 24 + 16 * 4;
    dfd.extend_from_slice(&(4 + block_size).to_le_bytes());
    dfd.extend_from_slice(&0u32.to_le_bytes()); // vendor 0 (Khronos), type 0 (basic)
    dfd.extend_from_slice(&(2u32 | (block_size << 16)).to_le_bytes()); // version 2, size
    dfd.extend_from_slice(&[1, 1, 1, 0]); // model RGBSDA, primaries BT.709, linear, flags
    dfd.extend_from_slice(&[0, 0, 0, 0]); // texel block dimensions 1 × 1 × 1 × 1
    dfd.extend_from_slice(&[8, 0, 0, 0, 0, 0, 0, 0]); // 8 bytes a block, plane 0
    for (channel, offset) in [(0u8, 0u16), (1, 16), (2, 32), (15, 48)] {
        dfd.extend_from_slice(&offset.to_le_bytes());
        dfd.push(15); // bit length − 1
        dfd.push(channel | 0x80 | 0x40); // float, signed
        dfd.extend_from_slice(&[0; 4]); // sample position
        dfd.extend_from_slice(&0xbf80_0000u32.to_le_bytes()); // lower −1.0
        dfd.extend_from_slice(&0x3f80_0000u32.to_le_bytes()); // upper 1.0
    }
    let head = 80 + 24;
    let data_offset = (head + dfd.len()).next_multiple_of(8);
    let mut out = Vec::with_capacity(data_offset + data.len());
    out.extend_from_slice(&[
        0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
    ]);
    for v in [VK_FORMAT_R16G16B16A16_SFLOAT, 2, w, h, 0, 0, 1, 1, 0] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in [head as u32, dfd.len() as u32, 0, 0] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in [
        0u64,
        0,
        data_offset as u64,
        data.len() as u64,
        data.len() as u64,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&dfd);
    out.resize(data_offset, 0);
    out.extend_from_slice(&data);
    out
}

/// The PNG size of `map`'s RGBA half floats as 16-bit samples.
fn half_png16(map: &MapImage) -> Result<u64, String> {
    let data: Vec<u8> = map
        .texels
        .iter()
        .flat_map(|&v| f32_to_f16(v).to_be_bytes())
        .collect();
    png_bytes(map, &data, png::BitDepth::Sixteen)
}

/// The PNG size of four bytes a texel.
fn png_rgba(map: &MapImage, data: &[u8]) -> Result<u64, String> {
    png_bytes(map, data, png::BitDepth::Eight)
}

fn png_bytes(map: &MapImage, data: &[u8], depth: png::BitDepth) -> Result<u64, String> {
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, map.width.max(1), map.height.max(1));
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(depth);
    enc.set_compression(png::Compression::High);
    let mut w = enc.write_header().map_err(|e| e.to_string())?;
    let zero = vec![0u8; if depth == png::BitDepth::Eight { 4 } else { 8 }];
    let pixels = if data.is_empty() { &zero[..] } else { data };
    w.write_image_data(pixels).map_err(|e| e.to_string())?;
    w.finish().map_err(|e| e.to_string())?;
    Ok(bytes.len() as u64)
}

/// The Markdown report and its JSON.
fn report(rows: &[Row], quick: bool) -> (String, serde_json::Value) {
    let (date, time) = utc_now();
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Web light-map encodings, {date} {time} UTC\n\n- machine: {}; backend cpu\n\
         - bakes: `default` preset at {} texels/m, per room × lamp every receiver's \
         illuminance (dilated as the row's EXRs); size = the candidate's bytes over the \
         illuminance EXRs' bytes (the same maps)\n- error: |decoded − float| / float over the \
         valid texels ≥ 1 lx, in %: of a texel's lux (the Rec. 709 luminance of its RGB, what \
         `luxbake measure` reports) and of each colour channel ≥ 1 lx\n",
        machine(),
        if quick { 16 } else { 64 }
    );
    let _ = writeln!(
        md,
        "| candidate | size / EXR (min–max) | lux error mean % | lux error max % | channel error mean % | channel error max % | size ≤ 1/3 and lux ≤ 1 % |\n|---|--:|--:|--:|--:|--:|---|"
    );
    let mut summary = Vec::new();
    for (k, name) in CANDIDATES.iter().enumerate() {
        let ratios: Vec<f64> = rows
            .iter()
            .map(|r| r.measures[k].bytes as f64 / r.exr_bytes.max(1) as f64)
            .collect();
        let lo = ratios.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = ratios.iter().copied().fold(0.0f64, f64::max);
        let lux = rows
            .iter()
            .fold(Errors::default(), |e, r| e.merge(r.measures[k].lux));
        let channel = rows
            .iter()
            .fold(Errors::default(), |e, r| e.merge(r.measures[k].channel));
        let meets = hi <= 1.0 / 3.0 && lux.max <= 0.01;
        let _ = writeln!(
            md,
            "| {name} | {lo:.3}–{hi:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {} |",
            100.0 * lux.mean(),
            100.0 * lux.max,
            100.0 * channel.mean(),
            100.0 * channel.max,
            if meets { "yes" } else { "no" }
        );
        summary.push(json!({"candidate": name, "ratio_min": lo, "ratio_max": hi,
            "lux_error": lux.json(), "channel_error": channel.json(), "meets": meets}));
    }
    let _ = writeln!(
        md,
        "\n| room | lamp | max lux | EXR bytes | {} |\n|---|---|--:|--:|{}",
        CANDIDATES.join(" | "),
        "--:|".repeat(CANDIDATES.len())
    );
    for r in rows {
        let cells: Vec<String> = r
            .measures
            .iter()
            .map(|m| {
                format!(
                    "{:.3} ({:.2}/{:.2} %)",
                    m.bytes as f64 / r.exr_bytes.max(1) as f64,
                    100.0 * m.lux.max,
                    100.0 * m.channel.max
                )
            })
            .collect();
        let _ = writeln!(
            md,
            "| {} | {} | {:.0} | {} | {} |",
            r.room,
            r.lamp,
            r.max_lux,
            r.exr_bytes,
            cells.join(" | ")
        );
    }
    let _ = writeln!(
        md,
        "\nCells: size / EXR (max lux error / max channel error). `rgbe-hdr-half` is \
         `rgbe-hdr` as three.js holds it with `HDRLoader`'s default `HalfFloatType`."
    );
    let json = json!({
        "date": date, "time_utc": time, "machine": machine(), "quick": quick,
        "summary": summary,
        "rows": rows.iter().map(|r| json!({
            "room": r.room, "lamp": r.lamp, "max_lux": r.max_lux, "exr_bytes": r.exr_bytes,
            "candidates": CANDIDATES.iter().zip(&r.measures).map(|(c, m)| json!({
                "candidate": c, "bytes": m.bytes, "lux_error": m.lux.json(),
                "channel_error": m.channel.json(),
            })).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    });
    (md, json)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_floats_round_and_truncate() {
        for v in [0.0f32, 1.0, 0.5, 1000.25, 65504.0, 6.1e-5, 3.0e-6, 1.0e-9] {
            let back = f16_to_f32(f32_to_f16(v));
            assert!((back - v).abs() <= v * 2f32.powi(-11) + 6e-8, "{v} {back}");
            let t = f16_to_f32(f32_to_f16_truncated(v));
            assert!(t <= v && v - t <= v * 2f32.powi(-10) + 6e-8, "{v} {t}");
        }
        assert_eq!(f32_to_f16(1.0), 0x3c00);
        assert_eq!(f32_to_f16(1e6), 0x7c00);
        assert_eq!(f32_to_f16_truncated(1e6), 0x7bff);
    }

    #[test]
    fn encodings_round_trip() {
        for c in [[100.0f32, 80.0, 60.0, 1.0], [1.5, 1.5, 1.5, 1.0]] {
            let back = rgb_of_rgbe(rgbe([c[0], c[1], c[2]]));
            let rgbm_back = rgbm_rgb(rgbm(c, 200.0), 200.0);
            for k in 0..3 {
                assert!((back[k] - c[k]).abs() / c[k] < 0.02, "{c:?} {back:?}");
                assert!(
                    (rgbm_back[k] - c[k]).abs() / c[k] < 0.05,
                    "{c:?} {rgbm_back:?}"
                );
            }
        }
        assert_eq!(rgbe([1.0, 0.5, 0.0]), [255, 128, 0, 128]);
        // 10 texels of one value: each component one run (2 bytes) after the line header.
        let mut flat = MapImage::zeros(10, 1);
        flat.texels.iter_mut().for_each(|v| *v = 1.0);
        let rgbe_bytes = bytes_of(&flat, |c| rgbe([c[0], c[1], c[2]]));
        let header = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 10\n".len() as u64;
        assert_eq!(radiance_hdr_bytes(&flat, &rgbe_bytes), header + 4 + 4 * 2);
        let ktx = ktx2_rgba16f(&MapImage::zeros(3, 2));
        assert_eq!(ktx.len(), 104 + 96 + 3 * 2 * 8);
    }
}
