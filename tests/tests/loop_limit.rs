//! Mesa's software drivers (llvmpipe for glow, lavapipe for wgpu) end a shader invocation's
//! loops after 65 535 iterations in all (`luxbake::backend::MESA_LOOP_ITERATIONS`): a texel
//! that asks for more rays than fit would lose the rest and read low (the box room's first
//! bounce at 2 048 rays in one pass: −3.2 % on glow, −3.4 % on wgpu). The backends report the
//! limit (`Limits::loop_iterations`); there the gathers split a texel's rays over passes
//! (`GraphConfig::gather_chunk`) and the direct pass an opening's samples
//! (`GraphConfig::direct_chunk`), and what is not split yet (lamp paths, refinement rays) is
//! reported in the skipped list beyond `LOOP_LIMITED_SAMPLES`. Here the box room's first
//! bounce at 2 048 rays on each GPU backend agrees with the CPU's, with no warning; 256 lamp
//! paths are warned about on a limited driver only; a 2 m linear luminaire's direct light at
//! 1 024 opening samples (up to 2 048 per texel near it), in a bake and at calculation points,
//! agrees with the CPU's.

use luxbake::backend::{LOOP_LIMITED_SAMPLES, MESA_LOOP_ITERATIONS};
use luxbake::bake::{BakeOutput, Skipped, bake};
use luxbake::probe::{CalcPoint, direct_at};
use luxbake::scene::{Blur, Scene, Settings};
use luxbake::sources::closed_forms::cie_171_5_8;
use luxbake::{GpuBackend, Room};
use luxbake_backends::{AnyBackend, BackendKind};
use luxbake_tests::Tally;

const RAYS: u32 = 2048;

/// `bench/scenes/<file>` baked with `settings`.
fn bench_scene(file: &str, settings: Settings) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../bench/scenes")
        .join(file);
    let mut scene = Scene::from_toml_file(&path).expect(file);
    scene.settings = settings;
    scene
}

/// The box room of `bench sampling` (4 × 2.5 × 3 m, albedo 0.5, 10 cd at 2.25 m) at 6
/// texels/m, the paper's one bounce of `RAYS` rays, unblurred.
fn scene() -> Scene {
    bench_scene(
        "sampling_room.toml",
        Settings {
            rays: RAYS,
            bounces: 1,
            blur: Blur::None,
            texels_per_metre: 6.0,
            ..Settings::paper()
        },
    )
}

/// Mean indirect illuminance (green, total − direct) over the valid texels.
fn mean_indirect(out: &BakeOutput) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for m in &out.maps {
        let (e, d) = (m.illuminance(), m.direct());
        for (a, b) in e.texels.chunks_exact(4).zip(d.texels.chunks_exact(4)) {
            if a[3] > 0.5 {
                sum += f64::from(a[1] - b[1]);
                n += 1;
            }
        }
    }
    assert!(n > 500, "{n} texels");
    sum / n as f64
}

fn run(backend: &mut AnyBackend, scene: &Scene) -> BakeOutput {
    bake(backend, scene, &scene.settings, &mut |_| {}).expect("bake")
}

#[test]
fn gathers_beyond_a_drivers_loop_limit_are_split_and_agree_with_the_cpu() {
    const { assert!(RAYS > LOOP_LIMITED_SAMPLES) };
    let scene = scene();
    let mut tally =
        Tally::new("gathers_beyond_a_drivers_loop_limit_are_split_and_agree_with_the_cpu");
    let mut cpu = tally.open(BackendKind::Cpu).expect("the CPU backend");
    assert_eq!(cpu.limits().loop_iterations, None);
    let reference = run(&mut cpu, &scene);
    assert!(
        !reference
            .report
            .skipped
            .iter()
            .any(|s| matches!(s, Skipped::LoopLimit { .. }))
    );
    let want = mean_indirect(&reference);
    for kind in [BackendKind::Glow, BackendKind::Wgpu] {
        let Some(mut backend) = tally.open(kind) else {
            continue;
        };
        let limit = backend.limits().loop_iterations;
        let out = run(&mut backend, &scene);
        let warned = out
            .report
            .skipped
            .iter()
            .any(|s| matches!(s, Skipped::LoopLimit { .. }));
        let got = mean_indirect(&out);
        println!(
            "{kind}: loop limit {limit:?}, mean indirect {got:.5} lx against the CPU's \
             {want:.5} ({:+.4} %)",
            100.0 * (got / want - 1.0)
        );
        assert!(
            !warned,
            "{kind}: the gathers are split, nothing to warn about"
        );
        assert!((got / want - 1.0).abs() < 1e-4, "{kind}: {got} vs {want}");
        if let Some(limit) = limit {
            assert_eq!(limit, MESA_LOOP_ITERATIONS);
        }
        // Lamp paths are not split yet: 256 of them per texel are reported there.
        let settings = Settings {
            lamp_paths: 256,
            rays: 4,
            bounces: 1,
            texels_per_metre: 2.0,
            ..Settings::default()
        };
        let (cube, _) = cie_171_5_8(0.5, settings);
        let out = run(&mut backend, &cube);
        let warned = out
            .report
            .skipped
            .iter()
            .find(|s| matches!(s, Skipped::LoopLimit { .. }));
        assert_eq!(warned.is_some(), limit.is_some(), "{kind}: {warned:?}");
        tally.compared(1);
    }
    tally.finish();
}

/// Opening samples of the near-field check: up to twice as many per texel near the opening,
/// far beyond what one invocation of a loop-limited driver completes.
const OPENING_SAMPLES: u32 = 1024;

/// `bench/scenes/nearfield_office.toml` (a 2 m linear luminaire 0.5 m over a desk, its
/// opening used everywhere in the room), direct light only, 6 texels/m.
fn office() -> Scene {
    bench_scene(
        "nearfield_office.toml",
        Settings {
            bounces: 0,
            texels_per_metre: 6.0,
            opening_samples: OPENING_SAMPLES,
            ..Settings::default()
        },
    )
}

/// Points on the desk top (0.75 m, the luminaire 0.5 m above) and on the floor beside it,
/// facing up.
fn office_points() -> Vec<CalcPoint> {
    let mut points = Vec::new();
    for (y, z0) in [(0.75, -0.2), (0.0, 1.3)] {
        for i in 0..12 {
            for j in 0..3 {
                points.push(CalcPoint {
                    position: [
                        -1.1 + 0.2 * f64::from(i),
                        y,
                        z0 - 0.25 + 0.25 * f64::from(j),
                    ],
                    normal: [0.0, 1.0, 0.0],
                });
            }
        }
    }
    points
}

/// The direct light's green channel of every valid texel, map after map.
fn direct_texels(out: &BakeOutput) -> Vec<f64> {
    out.maps
        .iter()
        .flat_map(|m| {
            m.direct()
                .texels
                .chunks_exact(4)
                .filter(|t| t[3] > 0.5)
                .map(|t| f64::from(t[1]))
                .collect::<Vec<_>>()
        })
        .collect()
}

#[test]
fn opening_samples_beyond_a_drivers_loop_limit_are_split_and_agree_with_the_cpu() {
    const { assert!(2 * OPENING_SAMPLES > 8 * LOOP_LIMITED_SAMPLES) };
    let scene = office();
    let points = office_points();
    let mut tally =
        Tally::new("opening_samples_beyond_a_drivers_loop_limit_are_split_and_agree_with_the_cpu");
    let mut cpu = tally.open(BackendKind::Cpu).expect("the CPU backend");
    let reference = run(&mut cpu, &scene);
    assert!(reference.report.lamp_models.iter().all(|m| m.area));
    let want = direct_texels(&reference);
    let room = Room::prepare(&scene, &scene.settings, cpu.limits(), &mut |_| {}).expect("room");
    let at = |backend: &mut AnyBackend| -> Vec<f64> {
        direct_at(
            backend,
            &room,
            &scene.lamps,
            &scene.settings,
            OPENING_SAMPLES,
            &points,
        )
        .expect("direct at the points")
        .iter()
        .map(|e| f64::from(e[1]))
        .collect()
    };
    let want_at = at(&mut cpu);
    assert!(want_at.iter().all(|&e| e > 10.0), "{want_at:?}");
    for kind in [BackendKind::Glow, BackendKind::Wgpu] {
        let Some(mut backend) = tally.open(kind) else {
            continue;
        };
        let out = run(&mut backend, &scene);
        assert!(
            !out.report
                .skipped
                .iter()
                .any(|s| matches!(s, Skipped::LoopLimit { .. })),
            "{kind}: the opening samples are split, nothing to warn about"
        );
        let got = direct_texels(&out);
        assert_eq!(got.len(), want.len(), "{kind}");
        let worst_map = got
            .iter()
            .zip(&want)
            .map(|(g, w)| (g - w).abs() / w.max(1e-3))
            .fold(0.0f64, f64::max);
        let got_at = at(&mut backend);
        let worst_at = got_at
            .iter()
            .zip(&want_at)
            .map(|(g, w)| (g - w).abs() / w)
            .fold(0.0f64, f64::max);
        println!(
            "{kind}: loop limit {:?}; {} texels, worst |rel| against the CPU {worst_map:.2e}; \
             {} points, worst {worst_at:.2e}",
            backend.limits().loop_iterations,
            got.len(),
            got_at.len()
        );
        assert!(worst_map < 1e-3, "{kind}: map {worst_map}");
        assert!(worst_at < 1e-4, "{kind}: points {worst_at}");
        tally.compared(2);
    }
    tally.finish();
}
