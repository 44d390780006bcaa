//! `cargo xtask bench trade`: the speed/accuracy trade on `chairs_05`.
//!
//! One knob at a time is varied around a base configuration of the paper's method (rays per
//! texel, texel density, bounces, blur), and the `method` curve puts `--method paper` with its
//! defaults beside every preset of the converged method (draft, default, final) at the grid's
//! density, on the same chart; the `default denoised` and `default raw` curves vary the
//! default's first-bounce rays with its denoiser and without it. Every bake is compared with the **independent Radiance reference**
//! `bench/references/chairs_05.csv` (see [`super::refcheck`]): mean |relative error|, bias and
//! p95 |relative error| at its calculation points, read with `cargo xtask measure`'s look-up.
//! That error decides the Pareto front and the suggested defaults.
//!
//! For continuity every bake is also compared with luxbake's own converged bake (many rays,
//! 4 bounces, blur off; the `RMSE`, `mean rel` and `p95 lx` columns), at a fixed set of
//! surface points: area-uniform random points on the receivers'
//! triangles (seeded), each read from a bake's final illuminance map with the masked bilinear
//! look-up at the point's light-map UV (so bakes of different texel densities compare at the same
//! place on the surface). The value compared is the photometric illuminance
//! `Y = 0.2126 R + 0.7152 G + 0.0722 B` in lux. Errors: RMSE, mean relative error (|Δ| over
//! `max(reference, 1 % of the mean reference)`, so dark corners do not dominate) and the 95th
//! percentile of |Δ|. That measures self-consistency only: the 4-bounce bake itself is biased
//! low against Radiance (reported in the header). Time: the passes' wall time plus the lamp
//! paths' set-up (`Run::wall`; no layout, rasterisation or BVH build).
//!
//! Bakes with the base's bounce count are also compared with a reference of that bounce count
//! (`same-bounce` columns): that isolates noise, resolution and blur from the bias of stopping
//! early.
//!
//! The Pareto front over (time, mean |relative error| against Radiance) is marked; the suggested
//! defaults are the cheapest front point whose error is within [`KNEE`] × the lowest measured.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use luxbake::bake::BakeOutput;
use luxbake::scene::{Blur, Method, Quality, Scene, Settings};
use luxbake_backends::{AnyBackend, BackendKind};
use luxbake_testkit::SplitMix64;
use plotters::prelude::*;

use super::refcheck::{self, Comparison};
use super::{
    Summary, load_average, luminance_f64, machine, open, report_heading, result_path, timed_bake,
    utc_now, write_load_averages, write_results,
};

/// The chosen configuration is the cheapest Pareto point whose mean |relative error| against
/// the Radiance reference is at most `KNEE` times the lowest of the grid.
pub const KNEE: f64 = 1.25;

/// Arguments of `cargo xtask bench trade`.
#[derive(clap::Args)]
pub struct Args {
    /// Backend that bakes the grid and the reference.
    #[arg(long, default_value = "cpu")]
    backend: BackendKind,
}

/// Grid and reference of one run.
struct Preset {
    reference: Settings,
    base: Settings,
    rays: &'static [u32],
    densities: &'static [f32],
    bounces: &'static [u32],
    blurs: &'static [Option<f32>],
    /// Rays per texel of the "3 bounces" curve (bounces and rays together).
    rays_3_bounces: &'static [u32],
    /// First-bounce rays of the converged default's denoised and raw curves.
    converged_rays: &'static [u32],
    points: usize,
}

fn preset(quick: bool) -> Preset {
    let base = |rays, texels_per_metre| Settings {
        rays,
        bounces: 1,
        blur: Blur::Sigma(Settings::PAPER_BLUR_SIGMA),
        texels_per_metre,
        ..Settings::paper()
    };
    if quick {
        Preset {
            reference: Settings {
                bounces: 4,
                blur: Blur::None,
                ..base(64, 8.0)
            },
            base: base(8, 8.0),
            rays: &[2, 8, 32],
            densities: &[4.0, 8.0],
            bounces: &[0, 1, 2, 3],
            blurs: &[None, Some(1.0), Some(2.0)],
            rays_3_bounces: &[2, 8],
            converged_rays: &[4, 16],
            points: 4_000,
        }
    } else {
        Preset {
            reference: Settings {
                bounces: 4,
                blur: Blur::None,
                ..base(256, 24.0)
            },
            base: base(32, 16.0),
            rays: &[4, 16, 32, 64, 256],
            densities: &[8.0, 12.0, 16.0, 24.0],
            bounces: &[0, 1, 2, 3],
            blurs: &[None, Some(1.0), Some(2.0), Some(4.0)],
            rays_3_bounces: &[4, 16, 64],
            converged_rays: &[4, 16, 64, 256],
            points: 20_000,
        }
    }
}

/// The converged default at the grid's density for each of `p.converged_rays`, with `blur`.
fn converged_rays(p: &Preset, blur: Blur) -> Vec<Settings> {
    p.converged_rays
        .iter()
        .map(|&rays| Settings {
            rays,
            blur,
            texels_per_metre: p.base.texels_per_metre,
            ..Settings::preset(Quality::Default)
        })
        .collect()
}

/// A surface point: triangle index and barycentric weights.
#[derive(Clone, Copy)]
struct Point {
    triangle: usize,
    bary: [f32; 3],
}

/// `count` area-uniform points on the receivers' triangles of `scene` (seeded, deterministic).
fn surface_points(scene: &Scene, count: usize) -> Vec<Point> {
    let (tris, attrs) = scene.world_triangles();
    let mut cumulative = Vec::with_capacity(tris.len());
    let mut total = 0.0f64;
    for (t, a) in tris.iter().zip(&attrs) {
        let receiver = scene
            .objects
            .get(a.object as usize)
            .is_some_and(|o| o.receiver);
        if receiver {
            let e1 = [0, 1, 2].map(|i| f64::from(t[1][i] - t[0][i]));
            let e2 = [0, 1, 2].map(|i| f64::from(t[2][i] - t[0][i]));
            let c = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            total += 0.5 * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        }
        cumulative.push(total);
    }
    if total <= 0.0 {
        return Vec::new();
    }
    let mut rng = SplitMix64::new(0x5EED);
    (0..count)
        .map(|_| {
            let target = rng.f64() * total;
            let triangle = cumulative
                .partition_point(|c| *c <= target)
                .min(cumulative.len() - 1);
            let (mut u, mut v) = (rng.f64(), rng.f64());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            Point {
                triangle,
                bary: [(1.0 - u - v) as f32, u as f32, v as f32],
            }
        })
        .collect()
}

/// Illuminance Y (lux) of `out` at `points` on `scene` (the scene the bake was made from).
fn values(scene: &Scene, out: &BakeOutput, points: &[Point]) -> Result<Vec<f64>, String> {
    let (_, attrs) = scene.world_triangles();
    let mut by_object = vec![None; scene.objects.len()];
    for m in &out.maps {
        if let Some(slot) = by_object.get_mut(m.object) {
            *slot = Some(m);
        }
    }
    points
        .iter()
        .map(|p| {
            let a = attrs
                .get(p.triangle)
                .ok_or("scenes of different triangle counts")?;
            let uv = [0, 1].map(|k| (0..3).map(|i| p.bary[i] * a.uvs[i][k]).sum::<f32>());
            let rgb = by_object
                .get(a.object as usize)
                .copied()
                .flatten()
                .map_or([0.0; 3], |m| m.illuminance().sample(uv));
            Ok(luminance_f64(&rgb))
        })
        .collect()
}

/// RMSE, mean relative error and 95th-percentile |Δ| of `v` against `reference`.
fn errors(v: &[f64], reference: &[f64]) -> (f64, f64, f64) {
    let n = v.len().min(reference.len());
    if n == 0 {
        return (0.0, 0.0, 0.0);
    }
    let mean_ref = reference.iter().take(n).sum::<f64>() / n as f64;
    let floor = (0.01 * mean_ref).max(f64::MIN_POSITIVE);
    let mut abs: Vec<f64> = v
        .iter()
        .zip(reference)
        .map(|(a, b)| (a - b).abs())
        .collect();
    let rmse = (abs.iter().map(|d| d * d).sum::<f64>() / n as f64).sqrt();
    let rel = abs
        .iter()
        .zip(reference)
        .map(|(d, r)| d / r.max(floor))
        .sum::<f64>()
        / n as f64;
    abs.sort_by(f64::total_cmp);
    let p95 = abs[((n - 1) as f64 * 0.95).round() as usize];
    (rmse, rel, p95)
}

/// Indices of the points of `(time, error)` that no other point beats in both.
fn pareto(points: &[(f64, f64)]) -> Vec<usize> {
    (0..points.len())
        .filter(|&i| {
            let (t, e) = points[i];
            !points
                .iter()
                .enumerate()
                .any(|(j, &(tj, ej))| j != i && tj <= t && ej <= e && (tj < t || ej < e))
        })
        .collect()
}

fn blur_name(b: Blur) -> String {
    match b {
        Blur::None => "none".to_owned(),
        Blur::Sigma(s) => format!("σ{s}"),
    }
}

/// A configuration's short label.
fn label(s: &Settings) -> String {
    let method = match s.method {
        Method::Paper => "paper".to_owned(),
        Method::Converged => format!("converged {}", s.quality.name()),
    };
    format!(
        "{method}: {} rays, {} t/m, {} b, blur {}",
        s.rays,
        s.texels_per_metre,
        s.bounces,
        blur_name(s.blur)
    )
}

/// One measured configuration.
struct Measured {
    settings: Settings,
    time: Summary,
    texels: u64,
    rmse: f64,
    rel: f64,
    p95: f64,
    /// RMSE, mean relative and p95 error against the reference with the same bounce count.
    same: Option<(f64, f64, f64)>,
    /// Against the independent Radiance reference.
    radiance: Comparison,
}

/// `base` with one knob set to each of `values` in turn.
fn around<T: Copy>(base: &Settings, values: &[T], set: impl Fn(&mut Settings, T)) -> Vec<Settings> {
    values
        .iter()
        .map(|&v| {
            let mut s = base.clone();
            set(&mut s, v);
            s
        })
        .collect()
}

/// Runs the trade study; prints and writes the results.
pub fn run(args: &Args, quick: bool, runs: Option<usize>, out: &Path) -> Result<(), String> {
    let p = preset(quick);
    let runs = runs.unwrap_or(1).max(1);
    let load_before = load_average();
    let (date, time) = utc_now();
    let (mut backend, renderer) = open(args.backend)?;
    let scene_name = "chairs_05";
    let ref_path = refcheck::reference_path(scene_name);
    let refs = refcheck::load(&ref_path)?;
    let ref_label = refcheck::shown(&ref_path);
    let bake_at =
        |backend: &mut AnyBackend, s: &Settings| -> Result<(Scene, Vec<f64>, BakeOutput), String> {
            let scene =
                Scene::builtin_with_settings(scene_name, s.clone()).map_err(|e| e.to_string())?;
            let mut times = Vec::new();
            let mut last = None;
            for _ in 0..runs {
                let r = timed_bake(backend, &scene, s)?;
                times.push(r.wall());
                last = Some(r.out);
            }
            let out = last.ok_or("no run")?;
            Ok((scene, times, out))
        };

    eprintln!("trade: reference {}", label(&p.reference));
    let (ref_scene, ref_times, ref_out) = bake_at(&mut backend, &p.reference)?;
    let points = surface_points(&ref_scene, p.points);
    let reference = values(&ref_scene, &ref_out, &points)?;
    let ref_vs_radiance = refcheck::evaluate(&ref_scene, &ref_out, &refs, &ref_label)?;
    let ref_time = Summary::of(&ref_times);
    drop(ref_out);
    // The same reference with the base's bounce count: separates the other knobs' error (noise,
    // resolution, blur) from the bias of stopping after fewer bounces.
    let same_bounces = Settings {
        bounces: p.base.bounces,
        ..p.reference.clone()
    };
    eprintln!("trade: reference {}", label(&same_bounces));
    let (sb_scene, _, sb_out) = bake_at(&mut backend, &same_bounces)?;
    let reference_sb = values(&sb_scene, &sb_out, &points)?;
    drop(sb_out);

    // The grid: one knob at a time around the base (the base itself measured once).
    let knobs: Vec<(&str, Vec<Settings>)> = vec![
        ("rays", around(&p.base, p.rays, |s, v| s.rays = v)),
        (
            "texel density",
            around(&p.base, p.densities, |s, v| s.texels_per_metre = v),
        ),
        ("bounces", around(&p.base, p.bounces, |s, v| s.bounces = v)),
        (
            "blur",
            around(&p.base, p.blurs, |s, v| {
                s.blur = v.map_or(Blur::None, Blur::Sigma)
            }),
        ),
        // The methods side by side at the grid's density: the paper's pipeline with its
        // measured defaults, and every preset of the converged method.
        (
            "method",
            std::iter::once(Settings::paper())
                .chain([Quality::Draft, Quality::Default, Quality::Final].map(Settings::preset))
                .map(|s| Settings {
                    texels_per_metre: p.base.texels_per_metre,
                    ..s
                })
                .collect(),
        ),
        // The converged default's rays with its denoiser and without (issue 29): the
        // denoised curve must approach the raw one as the rays grow.
        ("default denoised", converged_rays(&p, Blur::Sigma(1.0))),
        ("default raw", converged_rays(&p, Blur::None)),
        (
            "rays at 3 bounces",
            around(&p.base, p.rays_3_bounces, |s, rays| {
                s.rays = rays;
                s.bounces = 3;
            }),
        ),
    ];
    let mut measured: Vec<Measured> = Vec::new();
    let mut curves: Vec<(&str, Vec<usize>)> = Vec::new();
    for (name, list) in &knobs {
        let mut idx = Vec::new();
        for s in list {
            if let Some(i) = measured.iter().position(|m| &m.settings == s) {
                idx.push(i);
                continue;
            }
            let (scene, times, out) = bake_at(&mut backend, s)?;
            let texels = out.report.texels;
            let v = values(&scene, &out, &points)?;
            let (rmse, rel, p95) = errors(&v, &reference);
            let radiance = refcheck::evaluate(&scene, &out, &refs, &ref_label)?;
            let same = if s.bounces == same_bounces.bounces {
                Some(errors(&v, &reference_sb))
            } else {
                None
            };
            let time = Summary::of(&times);
            eprintln!(
                "trade: {:<40} {:>8.0} ms  vs Radiance: |rel| {:.1} %, bias {:+.1} %  \
                 (self-ref RMSE {rmse:.2} lx)",
                label(s),
                time.median * 1e3,
                radiance.all.total.mean_abs_rel * 100.0,
                radiance.all.total.bias * 100.0,
            );
            idx.push(measured.len());
            measured.push(Measured {
                settings: s.clone(),
                time,
                texels,
                rmse,
                rel,
                p95,
                same,
                radiance,
            });
        }
        curves.push((name, idx));
    }
    let load_after = load_average();

    let pts: Vec<(f64, f64)> = measured
        .iter()
        .map(|m| (m.time.median, m.radiance.all.total.mean_abs_rel))
        .collect();
    let front = pareto(&pts);
    let best = pts.iter().map(|p| p.1).fold(f64::MAX, f64::min);
    let choice = front
        .iter()
        .copied()
        .filter(|&i| pts[i].1 <= KNEE * best)
        .min_by(|&a, &b| measured[a].time.median.total_cmp(&measured[b].time.median));

    let mut md = report_heading(
        &format!("Speed/accuracy trade — {scene_name}"),
        (&date, &time),
        args.backend.name(),
        &renderer,
        "",
    );
    let _ = writeln!(
        md,
        "- reference: {} ({:.0} ms); {} surface points; {} run(s) per point{}",
        label(&p.reference),
        ref_time.median * 1e3,
        points.len(),
        runs,
        if quick { "; --quick" } else { "" }
    );
    let _ = writeln!(
        md,
        "- independent reference: `{}` ({} Radiance points); the luxbake reference above \
         against it: mean |rel| {:.1} %, bias {:+.1} %, p95 |rel| {:.1} %",
        ref_label,
        refs.len(),
        ref_vs_radiance.all.total.mean_abs_rel * 100.0,
        ref_vs_radiance.all.total.bias * 100.0,
        ref_vs_radiance.all.total.p95_abs_rel * 100.0,
    );
    let _ = writeln!(
        md,
        "- `Radiance` columns: relative error against the independent reference (the Pareto \
         front and the choice use its mean |rel|); `RMSE`, `mean rel`, `p95 lx`: against the \
         luxbake reference (self-consistency only)"
    );
    write_load_averages(&mut md, &load_before, &load_after);
    let _ = writeln!(
        md,
        "| knob | rays | texels/m | bounces | blur | texels | pass ms | RMSE lx | mean rel % | p95 lx \
         | same-bounce RMSE lx | same-bounce rel % | Radiance mean \\|rel\\| % | Radiance bias % \
         | Radiance p95 \\|rel\\| % | Pareto |"
    );
    let _ = writeln!(
        md,
        "|---|--:|--:|--:|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|:-:|"
    );
    for (name, idx) in &curves {
        for &i in idx {
            let m = &measured[i];
            let s = &m.settings;
            let r = &m.radiance.all.total;
            let _ = writeln!(
                md,
                "| {name} | {} | {} | {} | {} | {} | {:.0} | {:.2} | {:.2} | {:.2} | {} | {} \
                 | {:.1} | {:+.1} | {:.1} | {} |",
                s.rays,
                s.texels_per_metre,
                s.bounces,
                blur_name(s.blur),
                m.texels,
                m.time.median * 1e3,
                m.rmse,
                m.rel * 100.0,
                m.p95,
                m.same.map_or(String::new(), |e| format!("{:.2}", e.0)),
                m.same
                    .map_or(String::new(), |e| format!("{:.2}", e.1 * 100.0)),
                r.mean_abs_rel * 100.0,
                r.bias * 100.0,
                r.p95_abs_rel * 100.0,
                if front.contains(&i) { "●" } else { "" }
            );
        }
    }
    match choice {
        Some(i) => {
            let m = &measured[i];
            let r = &m.radiance.all.total;
            let _ = writeln!(
                md,
                "\nChosen (cheapest Pareto point with mean |rel| against Radiance ≤ {KNEE} × the \
                 lowest, {:.1} %): **{}** — {:.0} ms, against Radiance mean |rel| {:.1} %, bias \
                 {:+.1} %, p95 |rel| {:.1} %.\n",
                best * 100.0,
                label(&m.settings),
                m.time.median * 1e3,
                r.mean_abs_rel * 100.0,
                r.bias * 100.0,
                r.p95_abs_rel * 100.0,
            );
            let _ = writeln!(md, "Its error per surface kind:\n");
            md.push_str(&m.radiance.markdown());
        }
        None => {
            let _ = writeln!(
                md,
                "\nNo Pareto point within {KNEE} × the lowest error against Radiance."
            );
        }
    }
    print!("{md}");

    let svg = result_path(out, "trade", "svg");
    plot(&svg, &measured, &curves, &front).map_err(|e| format!("plot: {e}"))?;
    println!("wrote {}", svg.display());
    let _ = writeln!(
        md,
        "\n![error vs time]({})",
        svg.file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned())
    );
    let (measured_ref, front_ref) = (&measured, &front);
    let json_points: Vec<serde_json::Value> = curves
        .iter()
        .flat_map(|(name, idx)| {
            idx.iter().map(move |&i| {
                let m = &measured_ref[i];
                let s = &m.settings;
                serde_json::json!({
                    "knob": name, "rays": s.rays, "texels_per_metre": s.texels_per_metre,
                    "bounces": s.bounces, "blur": blur_name(s.blur), "texels": m.texels,
                    "pass_wall_s": m.time.json(), "rmse_lux": m.rmse, "mean_rel": m.rel,
                    "p95_lux": m.p95, "pareto": front_ref.contains(&i),
                    "same_bounce_reference": m.same.map(|e| serde_json::json!({
                        "rmse_lux": e.0, "mean_rel": e.1, "p95_lux": e.2 })),
                    "radiance": m.radiance.json(),
                })
            })
        })
        .collect();
    let json = serde_json::json!({
        "scene": scene_name, "date": date, "time_utc": time, "machine": machine(),
        "backend": args.backend.name(), "renderer": renderer, "quick": quick, "runs": runs,
        "reference": label(&p.reference), "reference_pass_wall_s": ref_time.json(),
        "surface_points": points.len(),
        "load_average_before": load_before, "load_average_after": load_after,
        "points": json_points,
        "chosen": choice.map(|i| label(&measured[i].settings)),
        "knee": KNEE, "same_bounce_reference": label(&same_bounces),
        "radiance_reference": ref_label, "radiance_points": refs.len(),
        "reference_vs_radiance": ref_vs_radiance.json(),
    });
    let by_knob: BTreeMap<&str, usize> = curves.iter().map(|(n, i)| (*n, i.len())).collect();
    eprintln!("trade: {} bakes over {:?}", measured.len(), by_knob);
    write_results(out, "trade", &md, &json)
}

/// Log-log plot of the mean |relative error| against Radiance vs pass time, one curve per knob,
/// the Pareto front circled in red.
fn plot(
    path: &Path,
    measured: &[Measured],
    curves: &[(&str, Vec<usize>)],
    front: &[usize],
) -> Result<(), Box<dyn std::error::Error>> {
    let xs = measured.iter().map(|m| m.time.median.max(1e-4));
    let err = |m: &Measured| (m.radiance.all.total.mean_abs_rel * 100.0).max(1e-4);
    let ys = measured.iter().map(err);
    let (x0, x1) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
    let (y0, y1) = ys.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
    if x0 > x1 || y0 > y1 {
        return Err("nothing to plot".into());
    }
    let root = SVGBackend::new(path, (960, 640)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "chairs_05: error against Radiance vs time (one curve per knob; red rings: Pareto)",
            ("sans-serif", 20),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (x0 / 1.5..x1 * 1.5).log_scale(),
            (y0 / 1.5..y1 * 1.5).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_desc("pass time [s] (wall)")
        .y_desc("mean |relative error| vs Radiance [%]")
        .draw()?;
    let colors = [
        BLUE,
        GREEN,
        MAGENTA,
        CYAN,
        BLACK,
        RGBColor(230, 120, 0),
        RGBColor(120, 60, 160),
        RGBColor(128, 128, 128),
    ];
    for (k, (name, idx)) in curves.iter().enumerate() {
        let color = colors[k % colors.len()];
        let mut pts: Vec<(f64, f64)> = idx
            .iter()
            .map(|&i| (measured[i].time.median.max(1e-4), err(&measured[i])))
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?
            .label(*name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
        chart.draw_series(pts.iter().map(|p| Circle::new(*p, 4, color.filled())))?;
    }
    chart.draw_series(front.iter().map(|&i| {
        Circle::new(
            (measured[i].time.median.max(1e-4), err(&measured[i])),
            9,
            RED.stroke_width(2),
        )
    }))?;
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let pts = [(1.0, 5.0), (2.0, 3.0), (3.0, 4.0), (4.0, 1.0), (2.0, 3.0)];
        // (3, 4) is beaten by (2, 3); the two equal points do not dominate each other.
        assert_eq!(pareto(&pts), vec![0, 1, 3, 4]);
    }

    #[test]
    fn errors_of_a_known_difference() {
        let reference = [10.0, 10.0, 10.0, 10.0];
        let v = [11.0, 9.0, 10.0, 10.0];
        let (rmse, rel, p95) = errors(&v, &reference);
        assert!((rmse - (0.5f64).sqrt()).abs() < 1e-12, "{rmse}");
        assert!((rel - 0.05).abs() < 1e-12, "{rel}");
        assert_eq!(p95, 1.0);
        assert_eq!(errors(&[], &[]), (0.0, 0.0, 0.0));
    }

    #[test]
    fn surface_points_are_deterministic_and_on_receivers() {
        let scene = Scene::builtin_with_settings(
            "chairs_01",
            Settings {
                texels_per_metre: 8.0,
                ..Settings::paper()
            },
        )
        .expect("scene");
        let a = surface_points(&scene, 500);
        let b = surface_points(&scene, 500);
        assert_eq!(a.len(), 500);
        let (_, attrs) = scene.world_triangles();
        for (p, q) in a.iter().zip(&b) {
            assert_eq!(p.triangle, q.triangle);
            assert_eq!(p.bary, q.bary);
            assert!(p.bary.iter().all(|w| (0.0..=1.0).contains(w)));
            assert!(scene.objects[attrs[p.triangle].object as usize].receiver);
        }
    }
}
