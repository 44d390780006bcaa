//! The core's closed-form checks on every GPU backend (blur off where a closed form is
//! compared): the floor under an isotropic lamp within 0.5 %, the closed sphere's
//! inter-reflection series `E = (I/R²)·Σ_{i≤k} ρ^i` within 1 % (paper method), and at the
//! converged method's default preset CIE 171:2006 test case 5.8 within 2 % and the closed
//! sphere's whole series within 1 %, for ρ up to 0.95. Each test prints the errors it measured,
//! and compares something on at least one backend, or is reported as skipped with the
//! backends it skipped (outside CI; a failure under CI), never as passed
//! ([`luxbake_tests::Tally`]).
//! (The CPU backend's own checks live in the core crate.)

use std::sync::Arc;

use luxbake::bake::BakeOutput;
use luxbake::gbuffer::rasterize;
use luxbake::scene::{Blur, Lamp, Scene, Settings};
use luxbake::sources::closed_forms;
use luxbake_backends::BackendKind;
use luxbake_ies::Photometry;
use luxbake_testkit::RelativeError;
use luxbake_tests::Tally;

const I0: f64 = 1000.0;
const GPU: [BackendKind; 2] = [BackendKind::Glow, BackendKind::Wgpu];

fn settings(texels_per_metre: f32, bounces: u32, rays: u32) -> Settings {
    Settings {
        rays,
        bounces,
        blur: Blur::None,
        texels_per_metre,
        ..Settings::paper()
    }
}

#[test]
fn floor_inverse_square_cosine_on_every_gpu_backend() {
    let h = 2.0f64;
    let mut scene = Scene::builtin_with_settings("floor", settings(8.0, 0, 1)).expect("floor");
    scene.lamps = vec![Lamp::new(
        "iso",
        Arc::new(Photometry::isotropic(I0)),
        [0.0, f64::from(h as f32), 0.0],
    )];
    let mut tally = Tally::new("floor_inverse_square_cosine");
    for backend in GPU {
        let Some(out) = tally.bake(backend, &scene) else {
            continue;
        };
        let g = rasterize(&scene, &out.layout);
        let maps = &out.maps[0];
        let err: RelativeError = maps
            .texels(&g, maps.illuminance())
            .flat_map(|(p, t)| {
                let r2 = p[0] * p[0] + p[2] * p[2];
                let dy = h - p[1];
                let want = I0 * dy / (dy * dy + r2).powf(1.5);
                t.into_iter().take(3).map(move |v| (f64::from(v), want))
            })
            .collect();
        println!("{} floor isotropic, texel channels: {err}", backend.name());
        assert!(err.n > 10_000, "{}", backend.name());
        assert!(err.max < 0.005, "{}: {err:?}", backend.name());
        tally.compared(1);
    }
    tally.finish();
}

#[test]
fn closed_sphere_interreflection_series_on_every_gpu_backend() {
    let (r, rho) = (1.0f64, 0.5f64);
    let mut tally = Tally::new("closed_sphere_interreflection_series");
    for backend in GPU {
        for k in 0..=3u32 {
            let settings = settings(12.0 / r as f32, k, 16);
            let (scene, _) = closed_forms::closed_sphere(r as f32, rho as f32, I0, settings);
            let Some(out) = tally.bake(backend, &scene) else {
                break;
            };
            assert_eq!(out.report.bounces_run, k);
            let g = rasterize(&scene, &out.layout);
            let maps = &out.maps[0];
            let want = I0 / (r * r) * (0..=k).map(|i| rho.powi(i as i32)).sum::<f64>();
            let err: RelativeError = maps
                .texels(&g, maps.illuminance())
                .map(|(_, t)| (f64::from(t[0]), want))
                .collect();
            println!(
                "{} sphere k={k}, E want {want:.3} lux, texels: {err}",
                backend.name()
            );
            assert!(err.n > 1000, "{}", backend.name());
            assert!(err.max < 0.01, "{} k={k}: {err:?}", backend.name());
            tally.compared(1);
        }
    }
    tally.finish();
}

/// Mean over the valid texels of every map of `f(total, direct)` (green channel).
fn map_mean(out: &BakeOutput, f: impl Fn(f64, f64) -> f64) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for m in &out.maps {
        let (e, d) = (m.illuminance(), m.direct());
        for (te, td) in e.texels.chunks_exact(4).zip(d.texels.chunks_exact(4)) {
            if te[3] > 0.5 {
                sum += f(f64::from(te[1]), f64::from(td[1]));
                n += 1;
            }
        }
    }
    assert!(n > 1000, "{n} texels");
    sum / n as f64
}

#[test]
fn cie_171_5_8_and_the_closed_sphere_converge_on_every_gpu_backend() {
    let mut tally = Tally::new("cie_171_5_8_and_the_closed_sphere_converge");
    for backend in GPU {
        for rho in [0.5f32, 0.8, 0.95] {
            let settings = Settings {
                texels_per_metre: 6.0,
                ..Settings::default()
            };
            let (cube, want) = closed_forms::cie_171_5_8(rho, settings);
            let Some(out) = tally.bake(backend, &cube) else {
                break;
            };
            let indirect = map_mean(&out, |e, d| e - d);
            println!(
                "{} CIE 5.8 ρ = {rho:.2}: mean indirect {indirect:.1} lx, exact {want:.1} lx, \
                 error {:+.2} % ({} explicit bounces)",
                backend.name(),
                100.0 * (indirect / want - 1.0),
                out.report.bounces_run
            );
            assert!((indirect / want - 1.0).abs() < 0.02, "{}", backend.name());
            let settings = Settings {
                texels_per_metre: 12.0,
                ..Settings::default()
            };
            let (sphere, want) = closed_forms::closed_sphere(1.0, rho, I0, settings);
            let Some(out) = tally.bake(backend, &sphere) else {
                break;
            };
            let worst = map_mean(&out, |e, _| (e / want - 1.0).abs());
            println!(
                "{} sphere ρ = {rho:.2}: mean |error| {:.3} %",
                backend.name(),
                100.0 * worst
            );
            assert!(worst < 0.01, "{}", backend.name());
            tally.compared(2);
        }
    }
    tally.finish();
}
