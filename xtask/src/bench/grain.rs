//! `cargo xtask bench grain`: how grainy flat, evenly lit surfaces come out of each preset
//! (issue 12: "a flat, evenly lit wall at `default`: relative standard deviation of its texels
//! against a 4096-ray reference ≤ 1 %").
//!
//! The scene is the box room of `bench sampling` (`bench/scenes/sampling_room.toml`: 4 × 2.5 ×
//! 3 m, albedo 0.5, a 10 cd isotropic lamp 2.25 m above the floor's centre) baked with every
//! bounce. The reference is the converged method with [`REFERENCE_RAYS`] first-bounce rays,
//! [`REFERENCE_HIGHER_RAYS`] for later bounces, every texel gathered (stride 1), no refinement,
//! no denoising, no lamp paths (the gather alone, so the lamp paths are measured against an
//! estimator that does not share them), a 0.2 % tail tolerance and a seed of its own. For
//! every preset (and the paper's method, `default-gather`: the default before lamp paths, 6 rays
//! and the gather alone, and two other splits of the default's first bounce between gather rays
//! and lamp paths: `gather-16`, 16 rays alone, and `rays-4+12`, the default before 2026-12-06 —
//! 4 rays, 12 lamp paths, no bias correction; issue 29's rooms gain from more rays, this
//! room's walls need the connections), per surface kind — floor (normal up), ceiling (down), walls — over the
//! valid texels: the **grain**, the relative standard deviation of `E / E_ref` (total
//! illuminance, photometric Y), and the bias, its mean minus 1. The reference's own noise
//! (4096 Sobol rays: well under 0.3 % per texel) adds to the grain, so the figure is an upper
//! bound of the preset's.

use std::fmt::Write as _;
use std::path::Path;

use luxbake::bake::BakeOutput;
use luxbake::gbuffer::rasterize;
use luxbake::scene::{Blur, Quality, Scene, Settings};
use luxbake_backends::BackendKind;

use super::{SamplingRoomStudy, load_average, luminance_f64, timed_bake, write_results};

/// First-bounce rays per texel of the reference (the figure).
pub const REFERENCE_RAYS: u32 = 4096;
/// Rays per texel of the reference's later bounces.
pub const REFERENCE_HIGHER_RAYS: u32 = 512;
/// Seed of the measured bakes (the reference uses `SEED + 1`).
pub const SEED: u32 = 1;
/// The target: the walls' grain at `default`, at most this.
pub const TARGET_GRAIN: f64 = 0.01;

/// Arguments of `cargo xtask bench grain`.
#[derive(clap::Args)]
pub struct Args {
    /// Backend of every bake.
    #[arg(long, default_value = "cpu")]
    backend: BackendKind,
    /// Texel density, texels per metre (default 32; 8 with `--quick`).
    #[arg(long)]
    texels_per_metre: Option<f32>,
    /// First-bounce rays of the reference (default 4096; 256 with `--quick`).
    #[arg(long)]
    reference_rays: Option<u32>,
}

/// The kinds of surface reported, in order.
const KINDS: [&str; 3] = ["floor", "ceiling", "walls"];

/// Per receiver map, the valid texels and their surface kind (index into [`KINDS`]) by the
/// G-buffer normal.
pub(super) fn surface_texels(scene: &Scene, out: &BakeOutput) -> Vec<(usize, u32, u32, usize)> {
    let g = rasterize(scene, &out.layout);
    let mut texels = Vec::new();
    for (m, maps) in out.maps.iter().enumerate() {
        let r = maps.region;
        for y in 0..r.size[1] {
            for x in 0..r.size[0] {
                let i = g.index(r.layer, r.offset[0] + x, r.offset[1] + y);
                if g.position[i + 3] <= 0.5 {
                    continue;
                }
                let ny = g.normal[i + 1];
                let kind = if ny > 0.9 {
                    0
                } else if ny < -0.9 {
                    1
                } else {
                    2
                };
                texels.push((m, x, y, kind));
            }
        }
    }
    texels
}

/// Total illuminance (lux, photometric Y) of `out` at `texels`.
fn total(out: &BakeOutput, texels: &[(usize, u32, u32, usize)]) -> Result<Vec<f64>, String> {
    texels
        .iter()
        .map(|&(m, x, y, _)| {
            let t = out
                .maps
                .get(m)
                .ok_or("a bake with fewer maps than the reference")?
                .illuminance()
                .texel(x, y);
            Ok(luminance_f64(&t))
        })
        .collect()
}

/// Grain (relative standard deviation of `v / reference`) and bias (its mean − 1) over the
/// texels of `kind`; `None` without texels with a positive reference.
pub fn grain(
    v: &[f64],
    reference: &[f64],
    kinds: &[usize],
    kind: usize,
) -> Option<(f64, f64, usize)> {
    let r: Vec<f64> = v
        .iter()
        .zip(reference)
        .zip(kinds)
        .filter(|&((_, &e), &k)| k == kind && e > 0.0)
        .map(|((a, e), _)| a / e)
        .collect();
    if r.is_empty() {
        return None;
    }
    let n = r.len() as f64;
    let mean = r.iter().sum::<f64>() / n;
    let var = r.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
    Some((var.sqrt(), mean - 1.0, r.len()))
}

/// One measured bake.
struct Measured {
    name: String,
    /// Per [`KINDS`]: grain, bias, texels.
    kinds: Vec<Option<(f64, f64, usize)>>,
    pass_s: f64,
}

/// Runs the study; prints and writes the results.
pub fn run(args: &Args, quick: bool, out: &Path) -> Result<(), String> {
    let density = args
        .texels_per_metre
        .unwrap_or(if quick { 8.0 } else { 32.0 });
    let reference_rays = args
        .reference_rays
        .unwrap_or(if quick { 256 } else { REFERENCE_RAYS });
    let (study, scene, mut backend) = SamplingRoomStudy::begin(args.backend, quick)?;
    let with = |s: Settings| Settings {
        texels_per_metre: density,
        seed: SEED,
        ..s
    };
    let reference_settings = Settings {
        rays: reference_rays,
        higher_rays: REFERENCE_HIGHER_RAYS.min(reference_rays),
        stride: 1,
        higher_stride: 1,
        refine_rays: 0,
        lamp_paths: 0,
        blur: Blur::None,
        tail_tolerance: 0.002,
        seed: SEED + 1,
        ..with(Settings::preset(Quality::Final))
    };
    eprintln!("grain: reference ({reference_rays} rays, {density} texels/m)");
    let reference_run = timed_bake(&mut backend, &scene, &reference_settings)?;
    let texels = surface_texels(&scene, &reference_run.out);
    let kinds: Vec<usize> = texels.iter().map(|t| t.3).collect();
    let reference = total(&reference_run.out, &texels)?;

    let cases = [
        ("paper".to_owned(), with(Settings::paper())),
        ("draft".to_owned(), with(Settings::preset(Quality::Draft))),
        (
            "default".to_owned(),
            with(Settings::preset(Quality::Default)),
        ),
        // The default before lamp paths (issue 12): 6 rays, the gather alone, no bias
        // correction.
        (
            "default-gather".to_owned(),
            with(Settings {
                rays: 6,
                lamp_paths: 0,
                denoise_correction: false,
                ..Settings::preset(Quality::Default)
            }),
        ),
        // More gather rays for fewer lamp paths (issue 29, docs/performance.md "Gather rays
        // against lamp paths").
        (
            "gather-16".to_owned(),
            with(Settings {
                rays: 16,
                lamp_paths: 0,
                ..Settings::preset(Quality::Default)
            }),
        ),
        // The default before 2026-12-06: 4 rays, 12 lamp paths, no bias correction.
        (
            "rays-4+12".to_owned(),
            with(Settings {
                rays: 4,
                lamp_paths: 12,
                denoise_correction: false,
                ..Settings::preset(Quality::Default)
            }),
        ),
        ("final".to_owned(), with(Settings::preset(Quality::Final))),
    ];
    let mut measured = Vec::new();
    for (name, s) in cases {
        let run = timed_bake(&mut backend, &scene, &s)?;
        let v = total(&run.out, &texels)?;
        let m = Measured {
            kinds: (0..KINDS.len())
                .map(|k| grain(&v, &reference, &kinds, k))
                .collect(),
            pass_s: run.wall(),
            name,
        };
        eprintln!(
            "grain: {:<8} {}  passes {:.2} s",
            m.name,
            KINDS
                .iter()
                .zip(&m.kinds)
                .map(|(k, g)| match g {
                    Some((g, b, _)) => format!("{k} {:.2} % ({:+.2} %)", 100.0 * g, 100.0 * b),
                    None => format!("{k} n/a"),
                })
                .collect::<Vec<_>>()
                .join(", "),
            m.pass_s
        );
        measured.push(m);
    }
    let load_after = load_average();

    let lines = [
        format!(
            "- scene: bench/scenes/sampling_room.toml at {density} texels/m, every bounce; value: \
             total illuminance per texel; grain = relative standard deviation of E / E_ref, \
             bias = its mean − 1"
        ),
        format!(
            "- reference: converged, {reference_rays} first-bounce rays, {} later, stride 1, no \
             refinement, no denoising, tail tolerance 0.2 %, seed {} ({} explicit bounces, \
             passes {:.1} s)",
            reference_settings.higher_rays,
            SEED + 1,
            reference_run.out.report.bounces_run,
            reference_run.wall()
        ),
    ];
    let title = "Grain of flat, evenly lit surfaces — sampling_room";
    let mut md = study.report(title, &lines, &load_after);
    let _ = writeln!(
        md,
        "| bake | floor grain | floor bias | ceiling grain | ceiling bias | walls grain | walls bias | passes s |"
    );
    let _ = writeln!(md, "|---|--:|--:|--:|--:|--:|--:|--:|");
    let pct = |v: Option<(f64, f64, usize)>, i: usize| {
        v.map_or("n/a".to_owned(), |g| {
            format!("{:.2} %", 100.0 * if i == 0 { g.0 } else { g.1 })
        })
    };
    for m in &measured {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {:.2} |",
            m.name,
            pct(m.kinds[0], 0),
            pct(m.kinds[0], 1),
            pct(m.kinds[1], 0),
            pct(m.kinds[1], 1),
            pct(m.kinds[2], 0),
            pct(m.kinds[2], 1),
            m.pass_s
        );
    }
    let walls_default = measured
        .iter()
        .find(|m| m.name == "default")
        .and_then(|m| m.kinds[2]);
    let _ = writeln!(
        md,
        "\n- target: walls' grain at `default` ≤ {:.0} %{}: {}",
        100.0 * TARGET_GRAIN,
        if quick {
            " (checked by the full run; --quick has a coarse map and a 256-ray reference)"
        } else {
            ""
        },
        match walls_default {
            Some((g, _, _)) if g <= TARGET_GRAIN => format!("{:.2} %, met", 100.0 * g),
            Some((g, _, _)) => format!("{:.2} %, NOT met", 100.0 * g),
            None => "not measured".to_owned(),
        }
    );
    print!("{md}");

    let json = serde_json::json!({
        "texels_per_metre": density,
        "reference": { "rays": reference_rays, "higher_rays": reference_settings.higher_rays,
                       "seed": SEED + 1, "pass_s": reference_run.wall(),
                       "explicit_bounces": reference_run.out.report.bounces_run },
        "bakes": measured.iter().map(|m| serde_json::json!({
            "bake": m.name, "pass_s": m.pass_s,
            "kinds": KINDS.iter().zip(&m.kinds).map(|(k, g)| serde_json::json!({
                "kind": k, "grain": g.map(|g| g.0), "bias": g.map(|g| g.1),
                "texels": g.map(|g| g.2),
            })).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "target_walls_grain_at_default": TARGET_GRAIN,
    });
    write_results(out, "grain", &md, &study.json(json, &load_after))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grain_and_bias_of_known_ratios() {
        let reference = [2.0, 2.0, 4.0, 1.0, 0.0];
        let v = [2.2, 1.8, 4.0, 5.0, 3.0];
        let kinds = [0, 0, 1, 2, 0];
        // Floor: ratios 1.1 and 0.9 (the zero reference is left out): grain 0.1, bias 0.
        let (g, b, n) = grain(&v, &reference, &kinds, 0).expect("floor");
        assert!((g - 0.1).abs() < 1e-12 && b.abs() < 1e-12 && n == 2);
        let (g, b, n) = grain(&v, &reference, &kinds, 2).expect("walls");
        assert!(g == 0.0 && (b - 4.0).abs() < 1e-12 && n == 1);
        assert_eq!(grain(&v, &reference, &kinds, 3), None);
    }
}
