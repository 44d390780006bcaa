//! The converged method against closed forms on the CPU reference: CIE 171:2006 test case 5.8
//! (a closed cube of uniform reflectance with an isotropic source at its centre) and the closed
//! diffuse sphere, at the default preset, for reflectances up to 0.95, and the reported lux next
//! to a hard shadow's edge. The GPU backends run the cube and sphere checks in the workspace's
//! `tests/` crate.

mod common;

use common::run;

use luxbake::bake::{BakeOutput, Skipped};
use luxbake::probe::locate;
use luxbake::scene::{Albedo, Object, Scene, Settings, SettingsPatch, Transform};
use luxbake::sources::closed_forms::{cie_171_5_8, closed_sphere};
use luxbake::sources::{builtin, meshes};

/// The default preset at `texels_per_metre`.
fn default_preset(texels_per_metre: f32) -> Settings {
    Settings {
        texels_per_metre,
        ..Settings::default()
    }
}

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
        let (scene, want) = cie_171_5_8(rho, default_preset(6.0));
        let out = run(&scene);
        let (indirect, texels) = mean(&out, |e, d| e - d);
        let err = indirect / want - 1.0;
        println!(
            "ρ = {rho:.2}: {texels} texels, {} explicit bounces, tail {:.1} %, mean indirect \
             {indirect:.1} lx, exact {want:.1} lx, error {:+.2} %",
            out.report.bounces_run,
            100.0 * out.report.tail_fraction,
            100.0 * err
        );
        // The series the bake decided on: each bounce's reflected light is ρ times its
        // increment (uniform albedo), and every bounce lands what the one before reflected
        // (a closed cube: retention 1), so the predicted next increment is the next one.
        let series = out
            .report
            .series
            .as_ref()
            .expect("the converged method's series");
        let k = series.increments.len();
        assert!(k >= 5 && series.reflected.len() == k, "{series:?}");
        for (e, r) in series.increments.iter().zip(&series.reflected) {
            assert!(
                (r / e - f64::from(rho)).abs() < 1e-4,
                "ρ = {rho}: {r} / {e}"
            );
        }
        for j in 1..k {
            let retention = series.increments[j] / series.reflected[j - 1];
            assert!(
                (retention - 1.0).abs() < 0.02,
                "ρ = {rho}: χ_{j} {retention}"
            );
        }
        // Issue 29 asks 1 % at ρ = 0.95 (measured +0.57 %; −1.61 % at ρ = 0.5, where the
        // denoiser's averaging of the cube faces' curvature at 6 texels/m costs −1.2 %).
        let bound = if rho >= 0.95 { 0.01 } else { 0.02 };
        assert!(err.abs() < bound, "ρ = {rho}: {indirect} vs {want}");
    }
}

/// `bounces` means what it says: a patch that sets it without `tail` bakes exactly that many
/// explicit bounces and adds no tail, even where the tail tolerance would stop earlier; with
/// `tail = true` it is the cap and the tail is extrapolated (`SettingsPatch`, `Settings::tail`).
#[test]
fn bounces_without_the_tail_are_exact() {
    let run = |bounces: u32, tail: Option<bool>, tail_tolerance: f32| {
        let settings = SettingsPatch {
            bounces: Some(bounces),
            tail,
            tail_tolerance: Some(tail_tolerance),
            texels_per_metre: Some(4.0),
            rays: Some(4),
            ..SettingsPatch::default()
        }
        .settings()
        .expect("settings");
        let out = run(&cie_171_5_8(0.5, settings).0);
        let (mean_e, _) = mean(&out, |e, _| e);
        (out.report, mean_e)
    };
    let (one, _) = run(1, None, 0.01);
    assert_eq!((one.bounces_run, one.tail_fraction), (1, 0.0));
    let (two, exact) = run(2, None, 0.01);
    assert_eq!((two.bounces_run, two.tail_fraction), (2, 0.0));
    assert!(two.bounce_ratio.is_some(), "the ratio is measured");
    let (capped, with_tail) = run(2, Some(true), 0.01);
    assert_eq!(capped.bounces_run, 2);
    assert!(capped.tail_fraction > 0.05, "{}", capped.tail_fraction);
    assert!(with_tail > exact * 1.05, "{with_tail} vs {exact}");
    // A loose tolerance stops early only with the tail.
    let (early, _) = run(6, Some(true), 0.5);
    assert!(early.bounces_run < 6, "{}", early.bounces_run);
    let (all, _) = run(6, None, 0.5);
    assert_eq!((all.bounces_run, all.tail_fraction), (6, 0.0));
    let skipped_bounces = |k: &Skipped| matches!(k, Skipped::Bounces { .. });
    assert!(
        !all.skipped.iter().any(skipped_bounces),
        "{:?}",
        all.skipped
    );
    assert!(
        early.skipped.iter().any(skipped_bounces),
        "{:?}",
        early.skipped
    );
}

#[test]
fn closed_sphere_converges_to_the_whole_series() {
    for rho in [0.5f32, 0.8, 0.95] {
        let (scene, want) = closed_sphere(1.0, rho, 1000.0, default_preset(12.0));
        let out = run(&scene);
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

/// A floor lit by a 1000 cd isotropic lamp 2 m above it and a black 1 m square 0.75 m above
/// the floor, centred under the lamp: its hard shadow's edges lie at |x| = 0.8 m and
/// |z| = 0.8 m. Nothing reflects onto the floor (a plane cannot see itself, the square is no
/// receiver and reflects nothing), so the total illuminance is the direct light's closed
/// form `I·h/d³` outside the shadow and 0 inside.
fn shadow_edge_scene(settings: Settings) -> Scene {
    let padding = builtin::padding_m(&settings, 1.0);
    let object = |name: &str, size: f32, y: f32, albedo: f32, receiver: bool| Object {
        name: name.into(),
        mesh: meshes::plane([size; 2], padding),
        transform: Transform::from_trs([0.0, f64::from(y), 0.0], [0.0; 3], [1.0; 3]),
        albedo: Albedo::grey(albedo),
        receiver,
        texel_scale: 1.0,
    };
    Scene {
        objects: vec![
            object("floor", 4.0, 0.0, 0.5, true),
            object("square", 1.0, 0.75, 0.0, false),
        ],
        lamps: vec![builtin::isotropic_lamp(1000.0, [0.0, 2.0, 0.0])],
        settings,
    }
}

#[test]
fn a_point_5_cm_from_a_hard_shadow_edge_reads_its_closed_form() {
    let closed_form = |x: f64, z: f64| 1000.0 * 2.0 / (x * x + z * z + 4.0).powf(1.5);
    // Points 5 cm outside (|x| = 0.85) and inside (|x| = 0.75) the shadow's edge, along it.
    let points: Vec<(f64, f64, bool)> = [-0.4, -0.2, 0.0, 0.2, 0.4]
        .into_iter()
        .flat_map(|z| {
            [
                (0.85, z, true),
                (-0.85, z, true),
                (0.75, z, false),
                (-0.75, z, false),
            ]
        })
        .collect();
    let worst = |settings: Settings| {
        let scene = shadow_edge_scene(settings);
        let out = run(&scene);
        let floor = &out.maps[0];
        assert_eq!(floor.name, "floor");
        let mut worst: f64 = 0.0;
        for &(x, z, lit) in &points {
            let sp = locate(&scene, [x, 0.0, z], 1e-3).expect("a point on the floor");
            let got = f64::from(floor.illuminance().sample(sp.uv)[1]);
            let want = closed_form(x, z);
            // Inside the shadow the error is relative to the light just outside it.
            let err = if lit { got / want - 1.0 } else { got / want };
            worst = worst.max(err.abs());
        }
        worst
    };
    let converged = worst(Settings::default());
    // The paper's method blurs the reported direct light (σ 2 texels): the same points read
    // far off, so this test tells the two apart.
    let paper = worst(Settings::paper());
    println!(
        "5 cm from a hard shadow edge, 64 texels/m: worst error {:.2} % (default preset), \
         {:.1} % (--method paper)",
        100.0 * converged,
        100.0 * paper
    );
    assert!(converged < 0.02, "{converged}");
    assert!(paper > 0.02, "{paper}");
}
