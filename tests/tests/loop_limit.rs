//! Mesa's software drivers (llvmpipe for glow, lavapipe for wgpu) end a shader invocation's
//! loops after 65 535 iterations in all (`luxbake::backend::MESA_LOOP_ITERATIONS`): a texel
//! that asks for more rays than fit would lose the rest and read low (the box room's first
//! bounce at 2 048 rays in one pass: −3.2 % on glow, −3.4 % on wgpu). The backends report the
//! limit (`Limits::loop_iterations`); there the gathers split a texel's rays over passes
//! (`GraphConfig::gather_chunk`), and what is not split yet (lamp paths, opening samples,
//! refinement rays) is reported in the skipped list beyond `LOOP_LIMITED_SAMPLES`. Here the box
//! room's first bounce at 2 048 rays on each GPU backend agrees with the CPU's, with no
//! warning; 256 lamp paths are warned about on a limited driver only.

use luxbake::GpuBackend;
use luxbake::backend::{LOOP_LIMITED_SAMPLES, MESA_LOOP_ITERATIONS};
use luxbake::bake::{BakeOutput, Skipped, bake};
use luxbake::scene::{Blur, Scene, Settings};
use luxbake::sources::closed_forms::cie_171_5_8;
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
