//! Scenes with closed-form answers, for tests and for the accuracy benchmarks: what an
//! independent reference says without running any renderer.
//!
//! - [`cie_171_5_8`]: CIE 171:2006 test case 5.8, a closed 4 m cube of uniform reflectance ρ
//!   with a 10 000 lm isotropic source at its centre. Every bounce keeps ρ of the flux, so the
//!   area-mean indirect illuminance is exactly `Φ·ρ / (A·(1 − ρ))`, `A = 96 m²`: 104.2, 416.7
//!   and 1979.2 lx for ρ = 0.5, 0.8 and 0.95.
//! - [`closed_sphere`]: a closed diffuse sphere of radius R and reflectance ρ with an isotropic
//!   lamp of intensity I at its centre; the direct light `I/R²` is uniform and so is every
//!   bounce: `E = (I/R²) / (1 − ρ)` everywhere (and `(I/R²)·Σ_{i≤k} ρ^i` after k bounces).

use std::f64::consts::PI;
use std::sync::Arc;

use luxbake_ies::Photometry;

use crate::sources::meshes::{self, RoomAlbedo};
use crate::{Albedo, Lamp, Object, Scene, Settings, Transform};

/// Flux of the source of test case 5.8, lumens.
pub const CIE_5_8_FLUX: f64 = 10_000.0;
/// Edge of the cube of test case 5.8, metres.
pub const CIE_5_8_EDGE: f32 = 4.0;

/// Chart padding of these scenes' procedural meshes at `settings`' density, metres: the
/// least padding, [`MIN_CHART_PADDING_TEXELS`](crate::MIN_CHART_PADDING_TEXELS)
/// whatever the blur. Their charts (the cube's six faces, the sphere's six cube-sphere faces)
/// face different ways or meet in the world along their seams, so the method paper's blur,
/// which masks by normal, never carries light from one to another through the padding; the
/// area means these scenes are tested by stay on the layouts they were measured with.
fn padding(settings: &Settings) -> f32 {
    crate::MIN_CHART_PADDING_TEXELS / settings.texels_per_metre
}

/// CIE 171:2006 test case 5.8 at reflectance `rho` and `settings`, and its exact area-mean
/// indirect illuminance in lux (see the module docs). The cube stands on y = 0, the source
/// at its centre.
pub fn cie_171_5_8(rho: f32, settings: Settings) -> (Scene, f64) {
    let edge = CIE_5_8_EDGE;
    let scene = Scene {
        objects: vec![Object {
            name: "cube".into(),
            mesh: meshes::room([edge; 3], RoomAlbedo::uniform([rho; 3]), padding(&settings)),
            transform: Transform::IDENTITY,
            albedo: Albedo::grey(1.0),
            receiver: true,
            texel_scale: 1.0,
        }],
        lamps: vec![Lamp::new(
            "source",
            Arc::new(Photometry::isotropic(CIE_5_8_FLUX / (4.0 * PI))),
            [0.0, f64::from(edge) / 2.0, 0.0],
        )],
        settings,
    };
    let area = 6.0 * f64::from(edge * edge);
    let rho = f64::from(rho);
    (scene, CIE_5_8_FLUX * rho / (area * (1.0 - rho)))
}

/// A closed sphere of `radius` and reflectance `rho` with an isotropic lamp of `candela` at its
/// centre, at `settings`, and its exact converged illuminance `(I/R²)/(1 − ρ)` in lux.
pub fn closed_sphere(radius: f32, rho: f32, candela: f64, settings: Settings) -> (Scene, f64) {
    let scene = Scene {
        objects: vec![Object {
            name: "sphere".into(),
            mesh: meshes::sphere(radius, 64, true, padding(&settings)),
            transform: Transform::IDENTITY,
            albedo: Albedo::grey(rho),
            receiver: true,
            texel_scale: 1.0,
        }],
        lamps: vec![Lamp::new(
            "source",
            Arc::new(Photometry::isotropic(candela)),
            [0.0; 3],
        )],
        settings,
    };
    let direct = candela / f64::from(radius * radius);
    (scene, direct / (1.0 - f64::from(rho)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_values_of_test_case_5_8() {
        for (rho, want) in [(0.5, 104.17), (0.8, 416.67), (0.95, 1979.17)] {
            let (scene, exact) = cie_171_5_8(rho, Settings::default());
            assert!((exact - want).abs() < 0.01, "{rho}: {exact}");
            assert_eq!(scene.lamps.len(), 1);
            assert!(scene.validate().is_ok());
        }
        let (_, e) = closed_sphere(2.0, 0.5, 400.0, Settings::default());
        assert_eq!(e, 200.0);
    }
}
