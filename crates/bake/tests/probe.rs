//! Light at calculation points (`luxbake::probe::direct_at`, `indirect_at`): the direct pass at the
//! points themselves equals the bake's direct map at its texels (same position and normal,
//! point lamps), and follows the inverse-square and cosine law at points between texels; the
//! final gather at the points reads what surrounds them and, at texel centres, the maps' own
//! indirect light.

mod common;

use std::sync::Arc;

use luxbake::bake::{BakeOutput, ObjectMaps, Room};
use luxbake::probe::{CalcPoint, direct_at, indirect_at};
use luxbake::scene::{Lamp, Scene};
use luxbake_backend_cpu::CpuBackend;
use luxbake_ies::Photometry;

use common::{prepare, run, small_room};

/// The valid texels of `out`'s maps whose `x + y` is a multiple of `every`, as calculation
/// points (their centre and normal in `room`'s G-buffer), each with `read(map, x, y)`.
fn map_texels<T>(
    out: &BakeOutput,
    room: &Room,
    every: u32,
    read: impl Fn(&ObjectMaps, u32, u32) -> T,
) -> (Vec<CalcPoint>, Vec<T>) {
    let g = &room.gbuffer;
    let (mut points, mut values) = (Vec::new(), Vec::new());
    for m in &out.maps {
        let r = m.region;
        for y in 0..r.size[1] {
            for x in 0..r.size[0] {
                let i = g.index(r.layer, r.offset[0] + x, r.offset[1] + y);
                if g.position[i + 3] <= 0.5 || (x + y) % every != 0 {
                    continue;
                }
                points.push(CalcPoint {
                    position: [0, 1, 2].map(|c| f64::from(g.position[i + c])),
                    normal: [0, 1, 2].map(|c| f64::from(g.normal[i + c])),
                });
                values.push(read(m, x, y));
            }
        }
    }
    (points, values)
}

#[test]
fn at_a_texel_the_points_direct_light_is_the_maps() {
    let scene = small_room();
    let out = run(&scene);
    assert!(
        out.report.lamp_models.iter().all(|m| !m.area),
        "point lamps"
    );
    let room = prepare(&scene);
    // Every 7th valid texel of the layout, with the bake's unblurred direct light there.
    let (points, want) = map_texels(&out, &room, 7, |m, x, y| {
        let t = m.direct_unblurred().texel(x, y);
        [t[0], t[1], t[2]]
    });
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

/// Every valid texel of `room`'s G-buffer whose index is a multiple of `every`, as a
/// calculation point (its centre and normal).
fn texel_points(room: &Room, every: usize) -> Vec<CalcPoint> {
    let g = &room.gbuffer;
    (0..g.position.len() / 4)
        .filter(|i| g.position[4 * i + 3] > 0.5 && i % every == 0)
        .map(|i| CalcPoint {
            position: [0, 1, 2].map(|c| f64::from(g.position[4 * i + c])),
            normal: [0, 1, 2].map(|c| f64::from(g.normal[4 * i + c])),
        })
        .collect()
}

/// Inside the closed sphere every gather ray meets the front of the sphere: a point gathers
/// exactly the exitance it is given everywhere. On the open floor nothing is above a point:
/// it gathers nothing.
#[test]
fn a_point_gathers_what_surrounds_it() {
    let sphere = Scene::builtin("sphere").expect("sphere");
    let room = prepare(&sphere);
    let points = texel_points(&room, 97);
    assert!(points.len() > 50, "{} points", points.len());
    let got = indirect_at(&room, &points, 256, 0, &|object, _| {
        assert_eq!(object, 0);
        [1.0, 2.0, 3.0]
    });
    // A ray that leaves a texel at grazing incidence may meet the next facet where its
    // interpolated normal faces away (the bakes' gather counts nothing there too): at most one
    // in a hundred.
    let want = [1.0, 2.0, 3.0];
    for e in &got {
        for c in 0..3 {
            assert!(e[c] <= want[c] && e[c] >= 0.99 * want[c], "{e:?}");
        }
    }
    let mean = got.iter().map(|e| f64::from(e[0])).sum::<f64>() / got.len() as f64;
    assert!(mean > 0.999, "mean {mean}");
    let floor = Scene::builtin("floor").expect("floor");
    let room = prepare(&floor);
    let points = texel_points(&room, 31);
    assert!(points.len() > 50, "{} points", points.len());
    let got = indirect_at(&room, &points, 256, 0, &|_, _| [1.0; 3]);
    assert!(got.iter().all(|&e| e == [0.0; 3]), "{got:?}");
}

/// At texel centres the light gathered at the points from the baked exitance maps is the
/// maps' own indirect light: over the room's texels their ratio is 1 within the bake's noise.
#[test]
fn the_indirect_light_gathered_at_points_is_the_maps() {
    let scene = small_room();
    let out = run(&scene);
    let room = prepare(&scene);
    // Every 5th valid texel of every map, with the maps' indirect light there (total − direct,
    // both denoised alike).
    let (points, maps_indirect) = map_texels(&out, &room, 5, |m, x, y| {
        let (t, d) = (m.illuminance().texel(x, y), m.direct().texel(x, y));
        f64::from(t[1] - d[1])
    });
    assert!(points.len() > 500, "{} points", points.len());
    let by_object: Vec<_> = (0..scene.objects.len())
        .map(|k| out.maps.iter().find(|m| m.object == k))
        .collect();
    let got = indirect_at(&room, &points, 1024, 0, &|object, uv| {
        by_object
            .get(object)
            .copied()
            .flatten()
            .map_or([0.0; 3], |m| m.exitance().sample(uv))
    });
    let gathered: f64 = got.iter().map(|e| f64::from(e[1])).sum();
    let maps: f64 = maps_indirect.iter().sum();
    assert!(maps > 0.0);
    let ratio = gathered / maps;
    assert!((ratio - 1.0).abs() < 0.02, "gathered / maps {ratio}");
}
