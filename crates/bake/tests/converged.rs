//! The converged method against closed forms on the CPU reference: CIE 171:2006 test case 5.8
//! (a closed cube of uniform reflectance with an isotropic source at its centre) and the closed
//! diffuse sphere, at the default preset, for reflectances up to 0.95. The GPU backends run the
//! same checks in the workspace's `tests/` crate.

use luxbake::bake::{BakeOutput, bake};
use luxbake::cpu::CpuBackend;
use luxbake::scene::Settings;
use luxbake::sources::closed_forms::{cie_171_5_8, closed_sphere};

/// Mean over every valid texel of every map of `f(total, direct)` (green channel).
fn mean(out: &BakeOutput, f: impl Fn(f64, f64) -> f64) -> (f64, usize) {
    let (mut sum, mut n) = (0.0, 0usize);
    for m in &out.maps {
        let (e, d) = (m.illuminance(), m.direct());
        for (te, td) in e.texels.chunks_exact(4).zip(d.texels.chunks_exact(4)) {
            if te[3] > 0.5 {
                assert!(te[..3].iter().all(|v| v.is_finite()));
                sum += f(f64::from(te[1]), f64::from(td[1]));
                n += 1;
            }
        }
    }
    (sum / n as f64, n)
}

#[test]
fn cie_171_test_5_8_closed_cube() {
    for rho in [0.5f32, 0.8, 0.95] {
        let settings = Settings {
            texels_per_metre: 6.0,
            ..Settings::default()
        };
        let (scene, want) = cie_171_5_8(rho, settings.clone());
        let out = bake(&mut CpuBackend::new(), &scene, &settings, &mut |_| {}).expect("bake");
        let (indirect, texels) = mean(&out, |e, d| e - d);
        let err = indirect / want - 1.0;
        println!(
            "ρ = {rho:.2}: {texels} texels, {} explicit bounces, tail {:.1} %, mean indirect \
             {indirect:.1} lx, exact {want:.1} lx, error {:+.2} %",
            out.report.bounces_run,
            100.0 * out.report.tail_fraction,
            100.0 * err
        );
        assert!(err.abs() < 0.02, "ρ = {rho}: {indirect} vs {want}");
    }
}

#[test]
fn closed_sphere_converges_to_the_whole_series() {
    for rho in [0.5f32, 0.8, 0.95] {
        let settings = Settings {
            texels_per_metre: 12.0,
            ..Settings::default()
        };
        let (scene, want) = closed_sphere(1.0, rho, 1000.0, settings.clone());
        let out = bake(&mut CpuBackend::new(), &scene, &settings, &mut |_| {}).expect("bake");
        let (e, texels) = mean(&out, |e, _| e);
        let (worst, _) = mean(&out, |e, _| (e / want - 1.0).abs());
        println!(
            "ρ = {rho:.2}: {texels} texels, {} explicit bounces, tail {:.1} %, mean E {e:.1} lx, \
             exact {want:.1} lx, error {:+.2} %, mean |error| {:.2} %",
            out.report.bounces_run,
            100.0 * out.report.tail_fraction,
            100.0 * (e / want - 1.0),
            100.0 * worst
        );
        assert!((e / want - 1.0).abs() < 0.01, "ρ = {rho}: {e} vs {want}");
        assert!(worst < 0.01, "ρ = {rho}: mean |error| {worst}");
    }
}
