//! `cargo xtask bench sampling`: how fast the gather's error falls with the ray count, per
//! direction sampler ([`Sampler`]: the paper's independent hash, the scrambled Sobol sequence).
//!
//! The scene is `bench/scenes/sampling_room.toml` (issue 12): a 4 × 2.5 × 3 m box room of
//! albedo 0.5, a 10 cd isotropic lamp at 2.25 m, one bounce, no blur, 16 texels per metre. The
//! value compared is the floor's indirect illuminance (stage 5 of Figure 5, lux), texel by
//! texel; floor texels are the valid texels whose G-buffer normal points up. The reference is
//! the mean of Sobol bakes with [`REFERENCE_RAYS`] rays and seeds of their own, so its error is
//! independent of the measured bakes' (whose seed is [`SEED`]). The error of a bake is the
//! relative RMSE `sqrt(Σ(E − E_ref)²) / sqrt(ΣE_ref²)` over the floor texels (as the
//! cross-backend harness measures it). Per sampler: the log-log slope of the error against the
//! ray count, and per ray count the ratio hash error / Sobol error. Times are the gather
//! pass's wall seconds, and each sampler's cost per draw on one CPU thread ([`draw_ns`]): the
//! room has 12 triangles, so its rays are cheap and the draws' share of the gather is far
//! larger than in a furnished scene.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use luxbake::bake::BakeOutput;
use luxbake::rng::Draw;
use luxbake::scene::{Sampler, Scene, Settings};
use luxbake_backends::BackendKind;

use super::{
    SamplingRoomStudy, load_average, log_log_slope, luminance_f64, timed_bake, write_results,
};

/// Rays per texel of each reference bake (full run).
pub const REFERENCE_RAYS: u32 = 16_384;
/// Seed of the measured bakes (the reference bakes use `SEED + 1 ..`).
pub const SEED: u32 = 1;
/// The issue's targets: slope at most this for the Sobol sampler…
pub const TARGET_SLOPE: f64 = -0.75;
/// …and the hash error at least this many times the Sobol error at (rays, ratio).
pub const TARGET_RATIOS: [(u32, f64); 2] = [(256, 2.5), (1024, 5.0)];

/// Arguments of `cargo xtask bench sampling`.
#[derive(clap::Args)]
pub struct Args {
    /// Backend that bakes every configuration and the reference.
    #[arg(long, default_value = "cpu")]
    backend: BackendKind,
    /// Reference bakes averaged.
    #[arg(long, default_value_t = 2)]
    reference_bakes: u32,
    /// Rays per texel of each reference bake (default 16384, 1024 with `--quick`).
    #[arg(long)]
    reference_rays: Option<u32>,
}

/// The floor texels: per receiver map, the texel coordinates whose G-buffer normal points up
/// (the floor kind of [`super::grain::surface_texels`]).
fn floor_texels(scene: &Scene, out: &BakeOutput) -> Vec<(usize, u32, u32)> {
    super::grain::surface_texels(scene, out)
        .into_iter()
        .filter(|t| t.3 == 0)
        .map(|(m, x, y, _)| (m, x, y))
        .collect()
}

/// The indirect illuminance (lux, photometric Y) of `out` at `texels`.
fn indirect(out: &BakeOutput, texels: &[(usize, u32, u32)]) -> Result<Vec<f64>, String> {
    texels
        .iter()
        .map(|&(m, x, y)| {
            let map = out
                .maps
                .get(m)
                .and_then(|o| o.stages[4].as_ref())
                .ok_or("a bake without the indirect stage")?;
            let t = map.texel(x, y);
            Ok(luminance_f64(&t))
        })
        .collect()
}

/// Relative RMSE of `v` against `reference`: `sqrt(Σ(v − r)²) / sqrt(Σr²)`.
fn rel_rmse(v: &[f64], reference: &[f64]) -> f64 {
    let (d2, r2) = v
        .iter()
        .zip(reference)
        .fold((0.0, 0.0), |(d2, r2), (a, r)| {
            (d2 + (a - r) * (a - r), r2 + r * r)
        });
    if r2 > 0.0 {
        (d2 / r2).sqrt()
    } else {
        d2.sqrt()
    }
}

/// Nanoseconds per draw of `sampler` on one CPU thread: 2^22 draws, 1024 rays in each of 4096
/// texels.
fn draw_ns(sampler: Sampler) -> f64 {
    let t = Instant::now();
    let mut sum = 0.0f32;
    for texel in 0..4096 {
        for s in 0..1024 {
            let [u0, u1] = sampler.uniform2(std::hint::black_box(texel), s, 1, SEED);
            sum += u0 + u1;
        }
    }
    std::hint::black_box(sum);
    t.elapsed().as_secs_f64() * 1e9 / f64::from(4096 * 1024)
}

/// One measured bake.
struct Measured {
    sampler: Sampler,
    rays: u32,
    error: f64,
    /// Mean of the floor's indirect illuminance relative to the reference's, minus 1.
    mean_bias: f64,
    gather_s: f64,
}

/// The gather pass's wall seconds of a bake.
fn gather_seconds(out: &BakeOutput) -> f64 {
    out.report
        .passes
        .iter()
        .filter(|p| p.label == "gather")
        .map(|p| p.seconds)
        .sum()
}

/// Runs the study; prints and writes the results.
pub fn run(args: &Args, quick: bool, out: &Path) -> Result<(), String> {
    let rays: &[u32] = if quick {
        &[4, 16, 64]
    } else {
        &[16, 64, 256, 1024]
    };
    let reference_rays = args
        .reference_rays
        .unwrap_or(if quick { 1024 } else { REFERENCE_RAYS });
    let (study, scene, mut backend) = SamplingRoomStudy::begin(args.backend, quick)?;
    let settings = |sampler, rays, seed| Settings {
        sampler,
        rays,
        seed,
        ..scene.settings.clone()
    };

    let mut reference: Vec<f64> = Vec::new();
    let mut texels = Vec::new();
    let mut reference_s = 0.0;
    let bakes = args.reference_bakes.max(1);
    for k in 0..bakes {
        let s = settings(Sampler::Sobol, reference_rays, SEED + 1 + k);
        eprintln!(
            "sampling: reference bake {} of {bakes} ({reference_rays} rays, sobol)",
            k + 1
        );
        let run = timed_bake(&mut backend, &scene, &s)?;
        if texels.is_empty() {
            texels = floor_texels(&scene, &run.out);
            reference = vec![0.0; texels.len()];
        }
        reference_s += gather_seconds(&run.out);
        for (r, v) in reference.iter_mut().zip(indirect(&run.out, &texels)?) {
            *r += v / f64::from(bakes);
        }
    }
    if texels.is_empty() {
        return Err("the scene has no floor texels".into());
    }
    let reference_mean = reference.iter().sum::<f64>() / reference.len() as f64;

    let mut measured = Vec::new();
    for sampler in Sampler::ALL {
        for &n in rays {
            let run = timed_bake(&mut backend, &scene, &settings(sampler, n, SEED))?;
            let v = indirect(&run.out, &texels)?;
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            let m = Measured {
                sampler,
                rays: n,
                error: rel_rmse(&v, &reference),
                mean_bias: mean / reference_mean - 1.0,
                gather_s: gather_seconds(&run.out),
            };
            eprintln!(
                "sampling: {:<5} {:>5} rays  rel RMSE {:.3e}  mean {:+.2e}  gather {:.2} s",
                sampler.name(),
                n,
                m.error,
                m.mean_bias,
                m.gather_s
            );
            measured.push(m);
        }
    }
    let load_after = load_average();
    let draws: Vec<(Sampler, f64)> = Sampler::ALL.iter().map(|&s| (s, draw_ns(s))).collect();

    let errors = |sampler: Sampler| -> Vec<(f64, f64)> {
        measured
            .iter()
            .filter(|m| m.sampler == sampler)
            .map(|m| (f64::from(m.rays), m.error))
            .collect()
    };
    let error_at = |sampler: Sampler, n: u32| {
        measured
            .iter()
            .find(|m| m.sampler == sampler && m.rays == n)
            .map(|m| m.error)
    };
    let slopes: Vec<(Sampler, Option<f64>)> = Sampler::ALL
        .iter()
        .map(|&s| (s, log_log_slope(&errors(s))))
        .collect();
    let ratio = |n: u32| match (error_at(Sampler::Hash, n), error_at(Sampler::Sobol, n)) {
        (Some(h), Some(s)) if s > 0.0 => Some(h / s),
        _ => None,
    };

    let lines = [
        format!(
            "- scene: bench/scenes/sampling_room.toml; {} floor texels; value: the floor's \
             indirect illuminance (1 bounce, no blur), mean {reference_mean:.4} lx in the \
             reference",
            texels.len()
        ),
        format!(
            "- reference: mean of {bakes} Sobol bake(s) of {reference_rays} rays (seeds \
             {}..={}), gather {reference_s:.1} s in all; measured bakes: seed {SEED}",
            SEED + 1,
            SEED + bakes
        ),
    ];
    let title = "Gather sampling: error vs rays — sampling_room";
    let mut md = study.report(title, &lines, &load_after);
    let _ = writeln!(
        md,
        "| rays | hash rel RMSE | Sobol rel RMSE | hash / Sobol | hash gather s | Sobol gather s |"
    );
    let _ = writeln!(md, "|--:|--:|--:|--:|--:|--:|");
    let time_at = |sampler: Sampler, n: u32| {
        measured
            .iter()
            .find(|m| m.sampler == sampler && m.rays == n)
            .map_or(f64::NAN, |m| m.gather_s)
    };
    for &n in rays {
        let _ = writeln!(
            md,
            "| {n} | {:.3e} | {:.3e} | {:.2} | {:.2} | {:.2} |",
            error_at(Sampler::Hash, n).unwrap_or(f64::NAN),
            error_at(Sampler::Sobol, n).unwrap_or(f64::NAN),
            ratio(n).unwrap_or(f64::NAN),
            time_at(Sampler::Hash, n),
            time_at(Sampler::Sobol, n),
        );
    }
    let _ = writeln!(md);
    for (s, ns) in &draws {
        let _ = writeln!(
            md,
            "- {} sampler: {ns:.1} ns per draw (one CPU thread)",
            s.name()
        );
    }
    for (s, slope) in &slopes {
        let _ = writeln!(
            md,
            "- log-log slope of the {} error: {}",
            s.name(),
            slope.map_or("n/a".to_owned(), |v| format!("{v:.3}"))
        );
    }
    let sobol_slope = slopes
        .iter()
        .find(|(s, _)| *s == Sampler::Sobol)
        .and_then(|(_, v)| *v);
    let verdict = |ok: bool| if ok { "met" } else { "NOT met" };
    if quick {
        let _ = writeln!(
            md,
            "- targets: checked by the full run only (16 to 1024 rays; --quick stops at 64)"
        );
    } else {
        let _ = writeln!(
            md,
            "- target slope ≤ {TARGET_SLOPE}: {}",
            verdict(sobol_slope.is_some_and(|v| v <= TARGET_SLOPE))
        );
    }
    for (n, target) in TARGET_RATIOS.into_iter().filter(|_| !quick) {
        let r = ratio(n);
        let _ = writeln!(
            md,
            "- target hash / Sobol ≥ {target} at {n} rays: {}",
            match r {
                Some(r) => format!("{r:.2}, {}", verdict(r >= target)),
                None => "not measured".to_owned(),
            }
        );
    }
    print!("{md}");

    let json = serde_json::json!({
        "floor_texels": texels.len(), "reference_mean_lux": reference_mean,
        "reference": { "sampler": "sobol", "rays": reference_rays, "bakes": bakes,
                       "seeds": (SEED + 1..=SEED + bakes).collect::<Vec<_>>(),
                       "gather_s": reference_s },
        "seed": SEED,
        "points": measured.iter().map(|m| serde_json::json!({
            "sampler": m.sampler.name(), "rays": m.rays, "rel_rmse": m.error,
            "mean_bias": m.mean_bias, "gather_s": m.gather_s,
        })).collect::<Vec<_>>(),
        "draw_ns": draws.iter().map(|(s, v)| (s.name(), *v)).collect::<std::collections::BTreeMap<_, _>>(),
        "slopes": slopes.iter().map(|(s, v)| (s.name(), *v)).collect::<std::collections::BTreeMap<_, _>>(),
        "ratios": rays.iter().map(|&n| serde_json::json!({ "rays": n, "hash_over_sobol": ratio(n) })).collect::<Vec<_>>(),
        "targets": { "sobol_slope_at_most": TARGET_SLOPE,
                     "ratio_at_least": TARGET_RATIOS.iter().map(|(n, r)| serde_json::json!({ "rays": n, "ratio": r })).collect::<Vec<_>>() },
    });
    write_results(out, "sampling", &md, &study.json(json, &load_after))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_rmse_of_a_known_difference() {
        let r = [3.0, 4.0];
        assert_eq!(rel_rmse(&r, &r), 0.0);
        assert!((rel_rmse(&[3.0, 5.0], &r) - 0.2).abs() < 1e-12);
        assert_eq!(rel_rmse(&[1.0], &[0.0]), 1.0);
    }

    #[test]
    fn the_scene_file_is_the_issue_room() {
        let scene = Scene::from_toml_file(&crate::bench::sampling_room_path()).expect("scene file");
        let s = &scene.settings;
        assert_eq!((s.bounces, s.texels_per_metre), (1, 16.0));
        assert_eq!(s.blur, luxbake::scene::Blur::None);
        assert_eq!(scene.lamps.len(), 1);
        assert_eq!(scene.lamps[0].position, [0.0, 2.25, 0.0]);
        assert_eq!(scene.objects.len(), 1);
        let colors = scene.objects[0].mesh.colors.as_ref().expect("room colours");
        assert!(colors.iter().all(|&c| c == [0.5; 3]));
    }
}
