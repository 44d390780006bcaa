//! Mesa's software drivers (llvmpipe for glow, lavapipe for wgpu) end a shader invocation's
//! loops after 65 535 iterations in all (`luxbake::backend::MESA_LOOP_ITERATIONS`): a texel
//! that asks for more rays than fit loses the rest and reads low. The backends report the
//! limit (`Limits::loop_iterations`) and a bake beyond `LOOP_LIMITED_SAMPLES` says so in its
//! skipped list. Here the box room's first bounce at 2 048 rays, on each GPU backend and the
//! CPU: on a limited driver the warning is there and the light is measurably low (the reason
//! for it); on a driver without the limit there is no warning and the backends agree.

use luxbake::GpuBackend;
use luxbake::backend::{LOOP_LIMITED_SAMPLES, MESA_LOOP_ITERATIONS};
use luxbake::bake::{BakeOutput, Skipped, bake};
use luxbake::scene::{Blur, Scene, Settings};
use luxbake_backends::{AnyBackend, BackendKind};
use luxbake_tests::Tally;

const RAYS: u32 = 2048;

/// The box room of `bench sampling` (4 × 2.5 × 3 m, albedo 0.5, 10 cd at 2.25 m) at 6
/// texels/m, the paper's one bounce of `RAYS` rays, unblurred.
fn scene() -> Scene {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../bench/scenes/sampling_room.toml"
    );
    let mut scene = Scene::from_toml_file(std::path::Path::new(path)).expect("sampling room");
    scene.settings = Settings {
        rays: RAYS,
        bounces: 1,
        blur: Blur::None,
        texels_per_metre: 6.0,
        ..Settings::paper()
    };
    scene
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
fn a_loop_limited_driver_is_reported_and_a_bake_beyond_it_says_so() {
    const { assert!(RAYS > LOOP_LIMITED_SAMPLES) };
    let scene = scene();
    let mut tally = Tally::new("a_loop_limited_driver_is_reported_and_a_bake_beyond_it_says_so");
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
        let warned = out.report.skipped.iter().find_map(|s| match s {
            Skipped::LoopLimit { samples, limit } => Some((*samples, *limit)),
            _ => None,
        });
        let got = mean_indirect(&out);
        println!(
            "{kind}: loop limit {limit:?}, warning {warned:?}, mean indirect {got:.5} lx against \
             the CPU's {want:.5} ({:+.2} %)",
            100.0 * (got / want - 1.0)
        );
        match limit {
            Some(limit) => {
                assert_eq!(limit, MESA_LOOP_ITERATIONS);
                assert_eq!(warned, Some((RAYS, limit)), "{kind}");
                // What the warning is for: the driver left rays out.
                assert!(got < want * 0.995, "{kind}: {got} vs {want}");
            }
            None => {
                assert_eq!(warned, None, "{kind}");
                assert!((got / want - 1.0).abs() < 1e-3, "{kind}: {got} vs {want}");
            }
        }
        tally.compared(1);
    }
    tally.finish();
}
