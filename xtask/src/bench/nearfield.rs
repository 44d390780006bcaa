//! `cargo xtask bench nearfield [--quick] [--rooms A,B] [--backends cpu,glow,wgpu]
//! [--texels-per-metre D]`: the direct
//! light of lamps with a size against Radiance's luminous-opening model (issue 27).
//!
//! The rooms are `bench/scenes/nearfield_*.toml` (linear, 2 m linear, round and box-shaped
//! openings closer to surfaces than five times their size); the references
//! `bench/references/nearfield_<room>.csv` are Radiance's direct illuminance with each file's
//! opening as emitting geometry (`make_references.py nearfield`, validated there against
//! closed forms), at points off hard shadow edges and penumbrae. Each room is baked in memory
//! with its lamps' default model (`auto`) and direct light only (`bounces = 0`) on each backend,
//! then once with every lamp a point (CPU) for the before/after, and every point is compared
//! by relative error: mean |rel|, bias, p95 and max per surface kind, read from the maps and
//! computed at the points themselves, with the worst points listed. The pass time of the area
//! model is reported as a ratio of the point model's on the same backend in the same run.
//! `--quick` (CI) bakes at 16 texels/m on the CPU only and checks nothing; the figures are in
//! the full run's files.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use luxbake::GpuBackend;
use luxbake::bake::Room;
use luxbake::probe::{CalcPoint, direct_at};
use luxbake::scene::{LampModel, Scene, SettingsPatch};
use luxbake::sources::scenefile::from_file_patched;
use luxbake_backends::{AnyBackend, BackendKind};
use luxbake_output::picture::luminance;

use super::refcheck::{self, RefPoint, Stats};
use super::{machine, open, result_path, timed_bake, utc_now, write};

/// Arguments of `cargo xtask bench nearfield`.
#[derive(clap::Args)]
pub struct Args {
    /// Rooms (`bench/scenes/nearfield_<room>.toml`), comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "dining,office,round,box")]
    rooms: Vec<String>,
    /// Backends, comma-separated (an unavailable one is reported, not fatal).
    #[arg(long, value_delimiter = ',', default_value = "cpu,glow,wgpu")]
    backends: Vec<BackendKind>,
    /// Light-map resolution of the bakes (default: 64, 16 with `--quick`).
    #[arg(long)]
    texels_per_metre: Option<f32>,
}

/// `bench/scenes/` of this checkout.
fn scenes_dir() -> PathBuf {
    refcheck::references_dir()
        .parent()
        .map_or_else(|| PathBuf::from("bench/scenes"), |b| b.join("scenes"))
}

/// Opening samples of the second evaluation at the reference points: enough that the
/// lattice's noise (about 1 % at the default's 48 near a bright opening) is far below the
/// model's error, which is what that evaluation shows.
const POINT_SAMPLES: u32 = 1024;

/// Points listed per room and backend where the maps are farthest from the reference.
const WORST_POINTS: usize = 3;

/// A reference point where the map is far from the reference: its CSV line, surface kind,
/// position, the reference, the map's value and the direct light computed at the point with
/// each count of opening samples of [`Row::at_points`], lux.
struct Worst {
    line: usize,
    surface: String,
    position: [f64; 3],
    reference: f64,
    map: f64,
    at: Vec<f64>,
}

/// Per surface kind (and "all"): the statistics and the largest |relative error|.
type BySurface = Vec<(String, Stats, f64)>;

/// One room baked on one backend with one model.
struct Row {
    room: String,
    backend: &'static str,
    model: &'static str,
    /// Per surface kind (and "all"): the statistics and the largest |relative error|, read
    /// from the light maps.
    stats: BySurface,
    /// The same, the direct light computed at the reference points themselves
    /// ([`luxbake::probe::direct_at`]), per count of opening samples ([`POINT_SAMPLES`]).
    at_points: Vec<(u32, BySurface)>,
    /// The points whose map value is farthest from the reference ([`WORST_POINTS`]).
    worst: Vec<Worst>,
    pass_s: f64,
    shadow_rays: u64,
}

/// Statistics of `values` against `refs` per surface kind, "all" first.
fn by_surface(refs: &[RefPoint], values: &[f64]) -> BySurface {
    let mut kinds: Vec<String> = refs.iter().map(|r| r.surface.clone()).collect();
    kinds.sort();
    kinds.dedup();
    let mut out = Vec::new();
    for kind in std::iter::once("all".to_string()).chain(kinds) {
        let (v, r): (Vec<f64>, Vec<f64>) = refs
            .iter()
            .zip(values)
            .filter(|(p, _)| kind == "all" || p.surface == kind)
            .map(|(p, v)| (*v, p.lux))
            .unzip();
        let max = v
            .iter()
            .zip(&r)
            .filter(|(_, r)| **r > 0.0)
            .map(|(v, r)| ((v - r) / r).abs())
            .fold(0.0f64, f64::max);
        out.push((kind, Stats::of(&v, &r), max));
    }
    out
}

/// Bakes `room` (direct light only, lamps as `model`, or as the file says) on the opened
/// `backend` (`kind`).
fn bake_room(
    room: &str,
    backend: &mut AnyBackend,
    kind: BackendKind,
    model: Option<LampModel>,
    texels_per_metre: f32,
) -> Result<Row, String> {
    let path = scenes_dir().join(format!("nearfield_{room}.toml"));
    let patch = SettingsPatch {
        bounces: Some(0),
        texels_per_metre: Some(texels_per_metre),
        ..SettingsPatch::default()
    };
    let loader = luxbake_assets::SceneLoader::default();
    let mut scene: Scene = from_file_patched(&path, Some(&loader), &patch)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    if let Some(m) = model {
        for l in &mut scene.lamps {
            l.model = m;
        }
    }
    let ref_path = refcheck::reference_path(&format!("nearfield_{room}"));
    let refs = refcheck::load(&ref_path)?;
    let settings = scene.settings.clone();
    let run = timed_bake(backend, &scene, &settings)?;
    let located = refcheck::locate(&scene, &refs, &refcheck::shown(&ref_path))?;
    let measured = refcheck::sample(&run.out, &located)?;
    let values: Vec<f64> = measured.iter().map(|m| m[0]).collect();
    let room_prepared = Room::prepare(&scene, &settings, backend.limits(), &mut |_| {})
        .map_err(|e| format!("{room}: {e}"))?;
    let points: Vec<CalcPoint> = refs
        .iter()
        .map(|r| CalcPoint {
            position: r.position,
            normal: r.normal,
        })
        .collect();
    let mut at_points = Vec::new();
    let mut at_values = Vec::new();
    let counts = [settings.opening_samples, POINT_SAMPLES];
    for samples in counts {
        let exact = direct_at(
            backend,
            &room_prepared,
            &scene.lamps,
            &settings,
            samples,
            &points,
        )
        .map_err(|e| format!("{room}: direct at the points: {e}"))?;
        let lux: Vec<f64> = exact.iter().map(|&e| f64::from(luminance(e))).collect();
        at_points.push((samples, by_surface(&refs, &lux)));
        at_values.push(lux);
    }
    let rel = |i: usize| ((values[i] - refs[i].lux) / refs[i].lux).abs();
    let mut order: Vec<usize> = (0..refs.len()).filter(|&i| refs[i].lux > 0.0).collect();
    order.sort_by(|&a, &b| rel(b).total_cmp(&rel(a)));
    let worst = order
        .into_iter()
        .take(WORST_POINTS)
        .map(|i| Worst {
            line: refs[i].line,
            surface: refs[i].surface.clone(),
            position: refs[i].position,
            reference: refs[i].lux,
            map: values[i],
            at: at_values.iter().map(|v| v[i]).collect(),
        })
        .collect();
    let used = run.out.report.lamp_models.iter().any(|m| m.area);
    Ok(Row {
        room: room.to_string(),
        backend: kind.name(),
        model: if used { "area" } else { "point" },
        stats: by_surface(&refs, &values),
        at_points,
        worst,
        pass_s: run.wall(),
        shadow_rays: run.out.report.shadow_rays,
    })
}

/// A table row's cells `| lead | kind | points | mean | bias | p95 | max |`, in %.
fn stats_cells(lead: &str, kind: &str, s: &Stats, max: f64) -> String {
    format!(
        "| {lead} | {kind} | {} | {:.2} | {:+.2} | {:.2} | {:.2} |",
        s.n,
        100.0 * s.mean_abs_rel,
        100.0 * s.bias,
        100.0 * s.p95_abs_rel,
        100.0 * max
    )
}

/// Per surface kind: the statistics, the kind and the largest |relative error|.
fn surfaces_json(stats: &[(String, Stats, f64)]) -> Vec<serde_json::Value> {
    stats
        .iter()
        .map(|(k, s, max)| {
            let mut j = s.json();
            j["surface"] = serde_json::json!(k);
            j["max_abs_rel"] = serde_json::json!(max);
            j
        })
        .collect()
}

/// Runs the comparison and writes `nearfield-<date>-<machine>.{md,json}`.
pub fn run(args: &Args, quick: bool, out: &Path) -> Result<(), String> {
    let backends: Vec<BackendKind> = if quick {
        vec![BackendKind::Cpu]
    } else {
        args.backends.clone()
    };
    // One backend per kind, kept for every bake (it compiles its programs once).
    let mut opened: Vec<(BackendKind, AnyBackend)> = Vec::new();
    for &kind in &backends {
        match open(kind) {
            Ok((b, _)) => opened.push((kind, b)),
            Err(e) => eprintln!("nearfield: {} unavailable: {e}", kind.name()),
        }
    }
    let texels_per_metre = args
        .texels_per_metre
        .unwrap_or(if quick { 16.0 } else { 64.0 });
    let mut rows = Vec::new();
    for room in &args.rooms {
        for (kind, backend) in &mut opened {
            eprintln!("nearfield: {room} on {}", kind.name());
            rows.push(bake_room(room, backend, *kind, None, texels_per_metre)?);
            rows.push(bake_room(
                room,
                backend,
                *kind,
                Some(LampModel::Point),
                texels_per_metre,
            )?);
        }
    }
    let (date, time) = utc_now();
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Near field — direct light against Radiance's luminous openings, {date} {time} UTC\n"
    );
    let _ = writeln!(
        md,
        "- machine: {}\n- rooms: `bench/scenes/nearfield_*.toml`, references \
         `bench/references/nearfield_*.csv` (Radiance, openings as emitting geometry, direct \
         light, points off shadow edges and penumbrae)\n- bakes: each room's lamps as the \
         file says (`auto`: the opening where a receiver is near, see the manifest's \
         `model_reason`) and every lamp a point, `bounces = 0`, {} texels/m, default preset \
         ({} opening samples)\n- relative error = (bake − reference) / reference, in %; \
         time = the passes' wall time, area over point on the same backend\n",
        machine(),
        texels_per_metre,
        luxbake::scene::Settings::default().opening_samples,
    );
    let _ = writeln!(
        md,
        "| room | backend | model | surface | points | mean \\|rel\\| | bias | p95 | max | passes s |\n\
         |---|---|---|---|--:|--:|--:|--:|--:|--:|"
    );
    for r in &rows {
        for (kind, s, max) in &r.stats {
            let lead = format!("{} | {} | {}", r.room, r.backend, r.model);
            let _ = writeln!(
                md,
                "{} {:.2} |",
                stats_cells(&lead, kind, s, *max),
                r.pass_s
            );
        }
    }
    let _ = writeln!(
        md,
        "\nThe direct light computed at the reference points themselves \
         (`luxbake::probe::direct_at` on each backend, the same lamps' models), not read \
         from the light maps, with the default's opening samples and with {POINT_SAMPLES}: \
         the maps add \
         their texel interpolation where the light bends within a texel (a luminaire's \
         cut-off); the default's samples add the lattice's noise, which the maps' \
         interpolation averages over four texels.\n\n\
         | room | backend | model | opening samples | surface | points | mean \\|rel\\| | bias | p95 | max |\n\
         |---|---|---|--:|---|--:|--:|--:|--:|--:|"
    );
    for r in &rows {
        for (samples, stats) in &r.at_points {
            for (kind, s, max) in stats {
                let lead = format!("{} | {} | {} | {samples}", r.room, r.backend, r.model);
                let _ = writeln!(md, "{}", stats_cells(&lead, kind, s, *max));
            }
        }
    }
    let _ = writeln!(
        md,
        "\nThe {WORST_POINTS} points per room and backend where the maps (lamps as the file \
         says) are farthest from the reference, with the direct light computed at the point \
         itself (relative errors in %): a map far off where the point is not is the texel \
         interpolation; both off with the default's samples but not with {POINT_SAMPLES}, the \
         samples' noise.\n\n\
         | room | backend | line | surface | position m | reference lx | map | at point, \
         default samples | at point, {POINT_SAMPLES} |\n|---|---|--:|---|---|--:|--:|--:|--:|"
    );
    for r in rows.iter().filter(|r| r.model == "area") {
        for w in &r.worst {
            let pct = |v: f64| format!("{v:.4} ({:+.2})", 100.0 * (v / w.reference - 1.0));
            let at: Vec<String> = w.at.iter().map(|&v| pct(v)).collect();
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {:.3}, {:.3}, {:.3} | {:.4} | {} | {} |",
                r.room,
                r.backend,
                w.line,
                w.surface,
                w.position[0],
                w.position[1],
                w.position[2],
                w.reference,
                pct(w.map),
                at.join(" | ")
            );
        }
    }
    let _ = writeln!(
        md,
        "\n| room | backend | passes area / point | shadow rays area / point |\n|---|---|--:|--:|"
    );
    for pair in rows.chunks(2) {
        if let [a, p] = pair {
            let _ = writeln!(
                md,
                "| {} | {} | {:.2} | {:.1} |",
                a.room,
                a.backend,
                a.pass_s / p.pass_s.max(1e-9),
                a.shadow_rays as f64 / (p.shadow_rays as f64).max(1.0)
            );
        }
    }
    let json = serde_json::json!({
        "date": date, "time_utc": time, "machine": machine(), "quick": quick,
        "rows": rows.iter().map(|r| serde_json::json!({
            "room": r.room, "backend": r.backend, "model": r.model, "pass_s": r.pass_s,
            "shadow_rays": r.shadow_rays,
            "surfaces": surfaces_json(&r.stats),
            "at_points": r.at_points.iter().map(|(samples, stats)| serde_json::json!({
                "opening_samples": samples, "surfaces": surfaces_json(stats),
            })).collect::<Vec<_>>(),
            "worst": r.worst.iter().map(|w| serde_json::json!({
                "line": w.line, "surface": w.surface, "position": w.position,
                "reference_lux": w.reference, "map_lux": w.map,
                "at_point_lux": r.at_points.iter().zip(&w.at)
                    .map(|((samples, _), v)| serde_json::json!({
                        "opening_samples": samples, "lux": v,
                    })).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    });
    print!("{md}");
    write(&result_path(out, "nearfield", "md"), &md)?;
    write(
        &result_path(out, "nearfield", "json"),
        &serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?,
    )
}
