//! Lamp paths (`luxbake::lightpaths`) against the gather alone, CPU reference: combined by
//! multiple importance sampling they estimate the same first bounce (no bias), with less noise
//! where a lamp lights a small patch brightly. Each test prints what it measured
//! (`--nocapture`).

use std::sync::Arc;

use luxbake::bake::{BakeOutput, bake};
use luxbake::scene::{Blur, Lamp, Method, Quality, Scene, Settings};
use luxbake_backend_cpu::CpuBackend;
use luxbake_ies::Photometry;

/// One explicit bounce, no filter, converged method: the first bounce as gathered.
fn first_bounce(rays: u32, lamp_paths: u32) -> Settings {
    Settings {
        rays,
        lamp_paths,
        bounces: 1,
        blur: Blur::None,
        texels_per_metre: 16.0,
        seed: 3,
        ..Settings::preset(Quality::Default)
    }
}

/// Per object: the mean indirect illuminance (total − direct, green) over its valid texels,
/// and the texels.
fn indirect_means(out: &BakeOutput) -> Vec<(String, f64, usize)> {
    out.maps
        .iter()
        .map(|m| {
            let (e, d) = (m.illuminance(), m.direct());
            let (mut sum, mut n) = (0.0f64, 0usize);
            for (te, td) in e.texels.chunks_exact(4).zip(d.texels.chunks_exact(4)) {
                if te[3] > 0.5 {
                    assert!(te.iter().all(|v| v.is_finite()), "{}", m.name);
                    sum += f64::from(te[1]) - f64::from(td[1]);
                    n += 1;
                }
            }
            (m.name.clone(), sum / n.max(1) as f64, n)
        })
        .collect()
}

/// Relative RMS difference of the indirect illuminance of `a` against `b` over every valid
/// texel of every map.
fn texel_rms(a: &BakeOutput, b: &BakeOutput) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (ma, mb) in a.maps.iter().zip(&b.maps) {
        let (ea, da, eb, db) = (ma.illuminance(), ma.direct(), mb.illuminance(), mb.direct());
        for i in 0..ea.texels.len() / 4 {
            if ea.texels[4 * i + 3] > 0.5 && eb.texels[4 * i + 3] > 0.5 {
                let ia = f64::from(ea.texels[4 * i + 1]) - f64::from(da.texels[4 * i + 1]);
                let ib = f64::from(eb.texels[4 * i + 1]) - f64::from(db.texels[4 * i + 1]);
                num += (ia - ib) * (ia - ib);
                den += ib * ib;
            }
        }
    }
    (num / den).sqrt()
}

/// The bake `got` ran its lamp paths (its report skips none).
fn assert_lamp_paths_ran(what: &str, got: &BakeOutput) {
    let skipped = &got.report.skipped;
    assert!(
        !skipped
            .iter()
            .any(|s| s.to_string().starts_with("lamp paths")),
        "{what}: {skipped:?}"
    );
}

/// Every object's mean indirect illuminance in `got` within `tolerance` (relative) of `want`
/// ([`indirect_means`] of a reference), each printed; every object has over 100 texels and
/// a positive reference.
fn assert_means_agree(what: &str, want: &[(String, f64, usize)], got: &BakeOutput, tolerance: f64) {
    let got = indirect_means(got);
    assert_eq!(want.len(), got.len(), "{what}");
    for ((object, w, n), (_, g, _)) in want.iter().zip(&got) {
        let err = g / w - 1.0;
        println!(
            "{what}, {object}: {n} texels, mean indirect {g:.3} lx vs {w:.3} lx ({:+.2} %)",
            100.0 * err
        );
        assert!(*n > 100 && *w > 0.0, "{what}, {object}");
        assert!(err.abs() < tolerance, "{what}, {object}: {g} vs {w}");
    }
}

fn run(scene: &Scene, s: &Settings) -> BakeOutput {
    bake(&mut CpuBackend::new(), scene, s, &mut |_| {}).expect("bake")
}

/// `chairs_01` (the IES downlight, a chair's shadow), and the same room with a second lamp
/// (an isotropic 60 cd lamp in a corner, whose light the chair shadows differently): the
/// first bounce with 4 rays and 32 lamp paths per texel agrees with 512 rays of the gather
/// alone on every object's mean within 1.5 % (with 16 rays and 256 lamp paths within
/// 0.5 %), and its texels are closer to that reference
/// than the gather's with the same 4 rays alone (multiple importance sampling adds a strategy
/// without losing the first). A downlight puts most lamp paths on the floor, where they
/// cannot light the floor itself, so the floor gains least.
#[test]
fn lamp_paths_estimate_the_first_bounce_of_the_gather_alone() {
    let one = Scene::builtin_with_settings("chairs_01", first_bounce(4, 32)).expect("chairs_01");
    let mut two = one.clone();
    two.lamps.push(Lamp::new(
        "corner",
        Arc::new(Photometry::isotropic(60.0)),
        [2.2, 2.2, -1.7],
    ));
    for (name, scene) in [("one lamp", &one), ("two lamps", &two)] {
        let reference = run(scene, &first_bounce(512, 0));
        assert!(
            reference.report.skipped.is_empty(),
            "{:?}",
            reference.report.skipped
        );
        let paths = run(scene, &first_bounce(4, 32));
        let gather = run(scene, &first_bounce(4, 0));
        assert_lamp_paths_ran(name, &paths);
        let want = indirect_means(&reference);
        assert_means_agree(name, &want, &paths, 0.015);
        // Many paths: the same means to within 0.5 % (no bias hidden in the noise).
        let many = run(scene, &first_bounce(16, 256));
        assert_means_agree(
            &format!("{name}, 16 rays + 256 lamp paths"),
            &want,
            &many,
            0.005,
        );
        let (rms_paths, rms_gather) = (
            texel_rms(&paths, &reference),
            texel_rms(&gather, &reference),
        );
        println!(
            "{name}: texels' relative RMS difference to 512 rays: 4 rays + 32 lamp paths \
             {:.1} %, 4 rays alone {:.1} %",
            100.0 * rms_paths,
            100.0 * rms_gather
        );
        assert!(
            rms_paths < rms_gather,
            "{name}: {rms_paths} vs {rms_gather}"
        );
    }
}

/// Refinement keeps the lamp paths: on `chairs_01`, the first bounce with 4 rays and 32 lamp
/// paths per texel, refined with 12 more rays where the estimated relative error exceeds
/// 10 %, agrees with 512 rays of the gather alone on every object's mean within 1.5 %
/// (a second estimate of 12 rays and 96 connections, weighted as the first, averaged with it
/// by ray count: no bias), and its texels are closer to that reference than without the
/// refinement and than the same refinement of the gather alone.
#[test]
fn refinement_keeps_the_lamp_paths() {
    let scene = Scene::builtin_with_settings("chairs_01", first_bounce(4, 32)).expect("chairs_01");
    let refined = |lamp_paths| Settings {
        refine_rays: 12,
        refine_error: 0.1,
        ..first_bounce(4, lamp_paths)
    };
    let reference = run(&scene, &first_bounce(512, 0));
    let both = run(&scene, &refined(32));
    assert_lamp_paths_ran("refined with lamp paths", &both);
    let want = indirect_means(&reference);
    assert_means_agree("refined with lamp paths", &want, &both, 0.015);
    let [rms_both, rms_paths, rms_gather] = [
        both,
        run(&scene, &first_bounce(4, 32)),
        run(&scene, &refined(0)),
    ]
    .map(|out| texel_rms(&out, &reference));
    println!(
        "texels' relative RMS difference to 512 rays: refined with lamp paths {:.1} %, \
         lamp paths unrefined {:.1} %, refined gather alone {:.1} %",
        100.0 * rms_both,
        100.0 * rms_paths,
        100.0 * rms_gather
    );
    assert!(
        rms_both < rms_paths && rms_both < rms_gather,
        "{rms_both} vs {rms_paths}, {rms_gather}"
    );
}

/// Where lamp paths cannot be weighted (a first bounce on a grid, the paper's method), the
/// bake runs the gather alone and says so for the converged method.
#[test]
fn lamp_paths_that_cannot_apply_are_reported_not_dropped_silently() {
    let s = first_bounce(4, 8);
    let scene = Scene::builtin_with_settings("chairs_01", s.clone()).expect("chairs_01");
    for (what, settings, reported) in [
        (
            "stride 2",
            Settings {
                stride: 2,
                ..s.clone()
            },
            true,
        ),
        (
            "paper",
            Settings {
                method: Method::Paper,
                ..s.clone()
            },
            false,
        ),
    ] {
        let out = run(&scene, &settings);
        let skipped: Vec<String> = out.report.skipped.iter().map(|k| k.to_string()).collect();
        let said = skipped.iter().any(|k| k.starts_with("lamp paths"));
        println!("{what}: {skipped:?}");
        assert_eq!(said, reported, "{what}: {skipped:?}");
    }
}
