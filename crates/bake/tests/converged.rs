//! The converged method against closed forms: CIE 171:2006 test case 5.8 (a closed cube of
//! uniform reflectance with an isotropic source at its centre) and the closed diffuse sphere,
//! both at the default preset, for reflectances up to 0.95.

use std::f64::consts::PI;
use std::sync::Arc;

use luxbake::bake::{BakeOutput, bake};
use luxbake::cpu::CpuBackend;
use luxbake::scene::{Albedo, Lamp, Object, Scene, Settings, Transform};
use luxbake::sources::meshes::{self, RoomAlbedo};
use luxbake_ies::Photometry;

/// Mean over every valid texel of every map of `f(total, direct)`.
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

fn isotropic_lamp(candela: f64, position: [f32; 3]) -> Lamp {
    Lamp::new(
        "source",
        Arc::new(Photometry::isotropic(candela)),
        position,
    )
}

/// CIE 171:2006 test case 5.8: a 4 m cube, every surface of reflectance ρ, a 10 000 lm
/// isotropic source at its centre. The area-mean indirect illuminance is exactly
/// Φ·ρ / (A·(1 − ρ)), A = 96 m²: 104.2, 416.7 and 1979.2 lx for ρ = 0.5, 0.8, 0.95.
#[test]
fn cie_171_test_5_8_closed_cube() {
    let flux = 10_000.0;
    for rho in [0.5f32, 0.8, 0.95] {
        let settings = Settings {
            texels_per_metre: 6.0,
            ..Settings::default()
        };
        let scene = Scene {
            objects: vec![Object {
                name: "cube".into(),
                mesh: meshes::room(
                    [4.0, 4.0, 4.0],
                    RoomAlbedo::uniform([rho; 3]),
                    4.0 / settings.texels_per_metre,
                ),
                transform: Transform::IDENTITY,
                albedo: Albedo::grey(1.0),
                receiver: true,
                texel_scale: 1.0,
            }],
            lamps: vec![isotropic_lamp(flux / (4.0 * PI), [0.0, 2.0, 0.0])],
            settings: settings.clone(),
        };
        let out = bake(&mut CpuBackend::new(), &scene, &settings, &mut |_| {}).expect("bake");
        let (indirect, texels) = mean(&out, |e, d| e - d);
        let rho = f64::from(rho);
        let want = flux * rho / (96.0 * (1.0 - rho));
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

/// A closed diffuse sphere of radius R and reflectance ρ with an isotropic lamp of intensity
/// I at its centre: E = (I/R²) / (1 − ρ) everywhere.
#[test]
fn closed_sphere_converges_to_the_whole_series() {
    let (radius, candela) = (1.0f32, 1000.0);
    for rho in [0.5f32, 0.8, 0.95] {
        let settings = Settings {
            texels_per_metre: 12.0,
            ..Settings::default()
        };
        let scene = Scene {
            objects: vec![Object {
                name: "sphere".into(),
                mesh: meshes::sphere(radius, 64, true, 4.0 / settings.texels_per_metre),
                transform: Transform::IDENTITY,
                albedo: Albedo::grey(rho),
                receiver: true,
                texel_scale: 1.0,
            }],
            lamps: vec![isotropic_lamp(candela, [0.0; 3])],
            settings: settings.clone(),
        };
        let out = bake(&mut CpuBackend::new(), &scene, &settings, &mut |_| {}).expect("bake");
        let rho = f64::from(rho);
        let want = candela / f64::from(radius * radius) / (1.0 - rho);
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
