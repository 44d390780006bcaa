//! `cargo xtask bench swap [--quick]`: the shop's lamp swap (issue 26), natively, per backend.
//!
//! Per scene (`chairs_05` with `rw_7.IES` at [0, 2.5, 0], and the furnished room of
//! `bench/scenes/furnished_room.toml`: three SheenChairs and a GlamVelvetSofa, `rw_7.IES` at
//! [0, 2.5, 0]) and backend, in one run:
//!
//! 1. **first bake**: a fresh backend, [`Room::prepare`] and [`bake_room`] with `rw_7.IES` —
//!    everything a page's first bake does (the GPU backends compile their programs here);
//! 2. **whole re-bake**: [`luxbake::bake()`] of the same scene on the warm backend (nothing of the
//!    room reused);
//! 3. **swap**: [`bake_room_direct_first`] on the same room with `rw_5.IES` at [0, 2, 0]:
//!    the time to the first direct light handed over (with an opening baked, the preview of
//!    every lamp as a point, [`DirectStage::Preview`]), to the bake's own direct light and to
//!    the converged maps;
//! 4. **dim**: the swapped lamp's layer ([`bake_layers`]) recombined at multiplier 0.5
//!    ([`LampLayers::combine`](luxbake::layers::LampLayers::combine)): no ray;
//! 5. **fresh bake with the swapped lamp**: a fresh backend, [`Room::prepare`] and
//!    [`bake_room`] with `rw_5.IES` — what the swap spares a page that would bake the room
//!    anew for the new lamp (issue 26's "first bake of the same room and lamp").
//!
//! Reported as ratios against the first bake of the same run (the median over `--runs`), the
//! swap and its direct lights also against the fresh bake with its own lamp,
//! with the swap's host share (the CPU work before and around the passes: lamp reach, the
//! lamp paths' pool, upload, read-back), how well the report's phases add up to its wall
//! time, and the longest time its progress fraction ([`Progress::Work`]) stood still, as a
//! share of its wall time, and what the backend keeps from bake to bake after the swap, in
//! MB: the CPU backend's gather hits and denoiser's chart tests, the GPU backends' kept hits
//! (`luxbake::kept`).

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use luxbake::GpuBackend;
use luxbake::bake::{
    BakeOutput, DirectStage, Progress, Room, bake, bake_room, bake_room_direct_first,
};
use luxbake::layers::{LampState, bake_layers};
use luxbake::scene::{Lamp, LampModel, Quality, Scene, Settings};
use luxbake::sources::scenefile::read_photometry;
use luxbake_backend_cpu::GATHER_HITS_BUDGET;
use luxbake_backends::{AnyBackend, BackendKind};
use serde_json::{Value, json};

use super::{
    Summary, cpu_seconds, load_average, machine, open, report_heading, utc_now, write_results,
};

/// Arguments of `cargo xtask bench swap`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenes: `chairs_05` and `furnished_room`, comma separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "chairs_05,furnished_room"
    )]
    scenes: Vec<String>,
    /// Backends, comma separated (an unavailable one is reported, not fatal).
    #[arg(long, value_delimiter = ',', default_value = "cpu,glow,wgpu")]
    backends: Vec<BackendKind>,
    /// Preset: draft, default or final (`--quick`: draft).
    #[arg(long)]
    quality: Option<Quality>,
    /// Texel density (default: the preset's; `--quick`: 16).
    #[arg(long)]
    texels_per_metre: Option<f32>,
    /// How both lamps emit (default `auto`: `rw_5.IES` at [0, 2, 0] gets its opening, the
    /// chair backs being within its 1 % distance; `point`: what a shop that asks
    /// `lampModel: 'point'` gets).
    #[arg(long)]
    lamp_model: Option<LampModel>,
}

/// The first lamp and its position, and the lamp swapped in.
const FIRST: (&str, [f64; 3]) = ("rw_7.IES", [0.0, 2.5, 0.0]);
const SWAPPED: (&str, [f64; 3]) = ("rw_5.IES", [0.0, 2.0, 0.0]);

/// `../shared/photometry/real-world/<name>` as a lamp at `position`, emitting as `model`
/// says (`None`: the default, `auto`).
fn lamp((name, position): (&str, [f64; 3]), model: Option<LampModel>) -> Result<Lamp, String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/photometry/real-world")
        .join(name);
    let photometry = read_photometry(&path).map_err(|e| e.to_string())?;
    let mut lamp = Lamp::new(name, photometry, position);
    if let Some(model) = model {
        lamp.model = model;
    }
    Ok(lamp)
}

/// The scene `name` with the first lamp, at `settings`.
fn scene(name: &str, settings: &Settings, model: Option<LampModel>) -> Result<Scene, String> {
    let mut scene = match name {
        "furnished_room" => {
            let path =
                Path::new(env!("CARGO_MANIFEST_DIR")).join("../bench/scenes/furnished_room.toml");
            let loader = luxbake_assets::SceneLoader::default();
            let patch = luxbake::scene::SettingsPatch {
                quality: Some(settings.quality),
                texels_per_metre: Some(settings.texels_per_metre),
                ..Default::default()
            };
            luxbake::sources::scenefile::from_file_patched(&path, Some(&loader), &patch)
                .map_err(|e| format!("{}: {e}", path.display()))?
        }
        _ => Scene::builtin_with_settings(name, settings.clone()).map_err(|e| e.to_string())?,
    };
    scene.lamps = vec![lamp(FIRST, model)?];
    Ok(scene)
}

/// One measured run of the four steps on one backend.
#[derive(Debug, Clone, Default)]
struct Measured {
    first: f64,
    whole: f64,
    /// When the first direct light was handed over: the preview when a lamp bakes its
    /// opening ([`DirectStage::Preview`]), else the bake's direct light.
    direct: f64,
    /// When the bake's own direct light was handed over ([`DirectStage::Direct`]).
    exact: f64,
    swap: f64,
    swap_cpu: f64,
    swap_host: f64,
    swap_phases: f64,
    /// The longest time the swap's progress fraction did not grow, over its wall time.
    swap_still: f64,
    dim: f64,
    /// A fresh backend's first bake with the swapped lamp, seconds.
    fresh: f64,
    /// What the backend keeps from bake to bake after the swap, MB (the CPU backend's gather
    /// hits and chart tests; NaN elsewhere).
    kept: f64,
}

/// Host seconds of a bake run on a prepared room: its set-up steps (lamp reach and paths,
/// upload, read-back).
fn host_seconds(out: &BakeOutput) -> f64 {
    out.report.setup.iter().map(|(_, s)| s).sum()
}

/// A page's first bake of `scene`'s room with `lamps`: a fresh backend (keeping its gather
/// hits for a swap, as `--lamp` repeated does), the room prepared, the lamps baked;
/// the backend, the room, the renderer's name and the seconds it all took.
fn first_bake(
    kind: BackendKind,
    scene: &Scene,
    lamps: &[Lamp],
) -> Result<(AnyBackend, Room, String, f64), String> {
    let t = Instant::now();
    let (mut backend, renderer) = open(kind)?;
    backend.keep_gather_hits(GATHER_HITS_BUDGET)?;
    let settings = &scene.settings;
    let room =
        Room::prepare(scene, settings, backend.limits(), &mut |_| {}).map_err(|e| e.to_string())?;
    bake_room(&mut backend, &room, lamps, settings, &mut |_| {}).map_err(|e| e.to_string())?;
    Ok((backend, room, renderer, t.elapsed().as_secs_f64()))
}

fn measure_once(
    kind: BackendKind,
    scene: &Scene,
    model: Option<LampModel>,
) -> Result<(Measured, String), String> {
    let settings = &scene.settings;
    let swapped = vec![lamp(SWAPPED, model)?];
    let (mut backend, room, renderer, first) = first_bake(kind, scene, &scene.lamps)?;

    let t = Instant::now();
    bake(&mut backend, scene, settings, &mut |_| {}).map_err(|e| e.to_string())?;
    let whole = t.elapsed().as_secs_f64();

    let (t, c) = (Instant::now(), cpu_seconds());
    // When the first direct light was handed over (a preview with a lamp's opening), and the
    // bake's own direct light.
    let (mut direct, mut exact) = (None, None);
    // When the progress fraction last grew, and the longest wait for it to grow.
    let (mut grew, mut still) = (0.0f64, 0.0f64);
    let out = bake_room_direct_first(
        &mut backend,
        &room,
        &swapped,
        settings,
        &mut |p| {
            if let Progress::Work(_) = p {
                let now = t.elapsed().as_secs_f64();
                still = still.max(now - grew);
                grew = now;
            }
        },
        &mut |stage, _| {
            let now = Some(t.elapsed().as_secs_f64());
            direct = direct.or(now);
            if stage == DirectStage::Direct {
                exact = now;
            }
        },
    )
    .map_err(|e| e.to_string())?;
    let swap = t.elapsed().as_secs_f64();
    let swap_still = still.max(swap - grew) / swap;
    let swap_cpu = cpu_seconds() - c;
    let phases = host_seconds(&out) + out.report.passes.iter().map(|p| p.seconds).sum::<f64>();
    let kept = backend.kept_bytes() as f64 / 1e6;

    let layers = bake_layers(&mut backend, &room, &swapped, settings, &mut |_| {})
        .map_err(|e| e.to_string())?;
    let t = Instant::now();
    let dimmed = layers
        .combine(&[LampState {
            multiplier: 0.5,
            ..LampState::of(&swapped[0])
        }])
        .map_err(|e| e.to_string())?;
    let dim = t.elapsed().as_secs_f64();
    if dimmed.maps.len() != out.maps.len() {
        return Err("the recombined maps lost an object".into());
    }
    drop((backend, room));
    let (_, _, _, fresh) = first_bake(kind, scene, &swapped)?;
    Ok((
        Measured {
            first,
            whole,
            direct: direct.ok_or("the direct light was never handed over")?,
            exact: exact.ok_or("the bake's direct light was never handed over")?,
            swap,
            swap_cpu,
            swap_host: host_seconds(&out),
            swap_phases: phases / out.report.total_seconds.max(1e-9),
            swap_still,
            dim,
            fresh,
            kept,
        },
        renderer,
    ))
}

/// Runs the study; the error is a message for stderr.
pub fn run(args: &Args, quick: bool, runs: Option<usize>, out: &Path) -> Result<(), String> {
    let runs = runs.unwrap_or(if quick { 1 } else { 3 }).max(1);
    let quality = args.quality.unwrap_or(if quick {
        Quality::Draft
    } else {
        Quality::Default
    });
    let mut settings = Settings::preset(quality);
    if let Some(d) = args.texels_per_metre.or(quick.then_some(16.0)) {
        settings.texels_per_metre = d;
    }
    let scenes: Vec<String> = if quick {
        vec!["chairs_05".into()]
    } else {
        args.scenes.clone()
    };
    let (date, time) = utc_now();
    let mut md = report_heading(
        "Lamp swap",
        (&date, &time),
        "per row",
        "see the table",
        &format!(
            "; preset `{}`, {} texels/m, median of {runs} run(s); load average {}",
            quality.name(),
            settings.texels_per_metre,
            load_average()
        ),
    );
    let _ = writeln!(
        md,
        "\nRatios against the first bake (fresh backend: room prepared, programs compiled, \
         {} at {:?}) in the same run; the swap puts {} at {:?} on the same room; lamp model \
         `{}`; the last three columns are against a fresh backend's first bake of the room \
         with the swapped lamp: the swap, the first direct light it handed over (\"swap: direct\"; \
         with an opening baked, the preview of the lamps as points) and the bake's own direct \
         light.\n",
        FIRST.0,
        FIRST.1,
        SWAPPED.0,
        SWAPPED.1,
        args.lamp_model.unwrap_or_default().name()
    );
    let _ = writeln!(
        md,
        "| scene | backend | first bake [s] | whole re-bake | swap: direct | swap: converged | swap host share | swap CPU / wall | phases / wall | progress still | dim [ms] | kept [MB] | fresh bake, swapped lamp [s] | swap / fresh | direct / fresh | the bake's direct / fresh |"
    );
    let _ = writeln!(
        md,
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    let mut rows = Vec::new();
    for name in &scenes {
        let scene = scene(name, &settings, args.lamp_model)?;
        for &kind in &args.backends {
            let mut all = Vec::new();
            let mut renderer = String::new();
            for _ in 0..runs {
                match measure_once(kind, &scene, args.lamp_model) {
                    Ok((m, r)) => {
                        all.push(m);
                        renderer = r;
                    }
                    Err(e) => {
                        let _ = writeln!(md, "| {name} | {} | unavailable: {e} |", kind.name());
                        rows.push(json!({"scene": name, "backend": kind.name(), "error": e}));
                        break;
                    }
                }
            }
            if all.is_empty() {
                continue;
            }
            let med = |f: fn(&Measured) -> f64| Summary::of(&all.iter().map(f).collect::<Vec<_>>());
            let first = med(|m| m.first).median;
            let ratio = |f: fn(&Measured) -> f64| med(f).median / first;
            let swap = med(|m| m.swap).median;
            let kept = all.iter().map(|m| m.kept).fold(f64::NAN, f64::max);
            let kept_mb = if kept.is_finite() {
                format!("{kept:.1}")
            } else {
                "–".into()
            };
            let _ = writeln!(
                md,
                "| {name} | {} | {first:.2} | {:.2}× | {:.2}× | {:.2}× | {:.0} % | {:.2} | {:.2} | {:.0} % | {:.1} | {} | {:.2} | {:.2}× | {:.2}× | {:.2}× |",
                kind.name(),
                ratio(|m| m.whole),
                ratio(|m| m.direct),
                ratio(|m| m.swap),
                100.0 * med(|m| m.swap_host).median / swap,
                med(|m| m.swap_cpu).median / swap,
                med(|m| m.swap_phases).median,
                100.0 * med(|m| m.swap_still).median,
                1e3 * med(|m| m.dim).median,
                kept_mb,
                med(|m| m.fresh).median,
                swap / med(|m| m.fresh).median,
                med(|m| m.direct).median / med(|m| m.fresh).median,
                med(|m| m.exact).median / med(|m| m.fresh).median,
            );
            rows.push(json!({
                "scene": name, "backend": kind.name(), "renderer": renderer,
                "first_s": med(|m| m.first).json(), "whole_s": med(|m| m.whole).json(),
                "direct_s": med(|m| m.direct).json(), "direct_exact_s": med(|m| m.exact).json(),
                "swap_s": med(|m| m.swap).json(),
                "swap_cpu_s": med(|m| m.swap_cpu).json(), "swap_host_s": med(|m| m.swap_host).json(),
                "swap_phases_over_wall": med(|m| m.swap_phases).json(),
                "swap_longest_still_over_wall": med(|m| m.swap_still).json(),
                "dim_s": med(|m| m.dim).json(),
                "fresh_s": med(|m| m.fresh).json(),
                "kept_mb": if kept.is_finite() { json!(kept) } else { Value::Null },
            }));
        }
    }
    print!("{md}");
    let json = json!({
        "study": "swap", "date": date, "time_utc": time, "machine": machine(),
        "load_average": load_average(), "quality": quality.name(),
        "texels_per_metre": settings.texels_per_metre, "runs": runs,
        "first": {"lamp": FIRST.0, "position": FIRST.1},
        "swapped": {"lamp": SWAPPED.0, "position": SWAPPED.1},
        "lamp_model": args.lamp_model.unwrap_or_default().name(),
        "rows": Value::Array(rows),
    });
    write_results(out, "swap", &md, &json)
}
