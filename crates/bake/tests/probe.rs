//! Direct light at calculation points (`luxbake::probe::direct_at`): the direct pass at the
//! points themselves equals the bake's direct map at its texels (same position and normal,
//! point lamps), and follows the inverse-square and cosine law at points between texels.

mod common;

use std::sync::Arc;

use luxbake::probe::{CalcPoint, direct_at};
use luxbake::scene::{Lamp, Scene};
use luxbake_backend_cpu::CpuBackend;
use luxbake_ies::Photometry;

use common::{prepare, run, small_room};

#[test]
fn at_a_texel_the_points_direct_light_is_the_maps() {
    let scene = small_room();
    let out = run(&scene);
    assert!(
        out.report.lamp_models.iter().all(|m| !m.area),
        "point lamps"
    );
    let room = prepare(&scene);
    let g = &room.gbuffer;
    // Every 7th valid texel of the layout, with the bake's unblurred direct light there.
    let mut points = Vec::new();
    let mut want = Vec::new();
    for m in &out.maps {
        let r = m.region;
        for y in 0..r.size[1] {
            for x in 0..r.size[0] {
                let i = g.index(r.layer, r.offset[0] + x, r.offset[1] + y);
                if g.position[i + 3] <= 0.5 || (x + y) % 7 != 0 {
                    continue;
                }
                points.push(CalcPoint {
                    position: [0, 1, 2].map(|c| f64::from(g.position[i + c])),
                    normal: [0, 1, 2].map(|c| f64::from(g.normal[i + c])),
                });
                let t = m.direct_unblurred().texel(x, y);
                want.push([t[0], t[1], t[2]]);
            }
        }
    }
    assert!(points.len() > 500, "{} points", points.len());
    let got = direct_at(
        &mut CpuBackend::new(),
        &room,
        &scene.lamps,
        &scene.settings,
        scene.settings.opening_samples,
        &points,
    )
    .expect("direct at points");
    assert_eq!(got.len(), points.len());
    assert!(want.iter().any(|w| w[0] > 0.0));
    let bits = |v: &[[f32; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&got), bits(&want));
}

/// The floor lit by a 250 cd bulb, and points between its texels 1 mm over it.
fn floor_and_points(offset: [f64; 3]) -> (Scene, Vec<CalcPoint>, [f64; 3]) {
    let mut scene = Scene::builtin("floor").expect("floor");
    scene.settings.texels_per_metre = 4.0;
    let lamp = [0.13, 2.3, -0.21];
    scene.lamps = vec![Lamp::new("bulb", Arc::new(Photometry::isotropic(I)), lamp)];
    let points = (0..40)
        .map(|k| {
            let a = f64::from(k) * 0.77;
            let r = 0.011 + 0.093 * f64::from(k);
            CalcPoint {
                position: [
                    lamp[0] + r * a.cos() + offset[0],
                    0.001 + offset[1],
                    lamp[2] + r * a.sin() + offset[2],
                ],
                normal: [0.0, 1.0, 0.0],
            }
        })
        .collect();
    (scene.translated(offset), points, lamp)
}

const I: f64 = 250.0;

fn direct(scene: &Scene, points: &[CalcPoint]) -> Vec<[f32; 3]> {
    direct_at(
        &mut CpuBackend::new(),
        &prepare(scene),
        &scene.lamps,
        &scene.settings,
        scene.settings.opening_samples,
        points,
    )
    .expect("direct at points")
}

#[test]
fn a_room_10_km_out_gives_its_points_the_light_of_the_room_at_the_origin() {
    let (home, at_home, _) = floor_and_points([0.0; 3]);
    let (far, out_there, _) = floor_and_points([10_000.0, 0.0, -10_000.0]);
    let (a, b) = (direct(&home, &at_home), direct(&far, &out_there));
    for (x, y) in a.iter().zip(&b) {
        assert!((x[1] - y[1]).abs() <= 1e-5 * x[1], "{x:?} {y:?}");
    }
}

#[test]
fn between_texels_the_direct_light_follows_the_inverse_square_and_cosine_law() {
    let (scene, points, lamp) = floor_and_points([0.0; 3]);
    let got = direct(&scene, &points);
    for (p, e) in points.iter().zip(&got) {
        let d = [0, 1, 2].map(|c| lamp[c] - p.position[c]);
        let d2 = d.iter().map(|v| v * v).sum::<f64>();
        let want = I * d[1] / (d2 * d2.sqrt());
        let rel = (f64::from(e[1]) - want).abs() / want;
        assert!(rel < 1e-5, "{p:?}: {} lx, closed form {want} lx", e[1]);
        assert_eq!(e[0], e[2]);
    }
}
