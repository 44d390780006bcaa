//! The first bounce's direct light evaluated at its hits (`Settings::direct_at_hits`) against
//! a closed form: a spot throws a disk of light with a soft edge onto the floor of a room that
//! gets no other direct light, and the ceiling's first bounce is the floor's reflected light
//! integrated over that disk. Read from a coarse floor map the disk's edge is interpolated
//! between texel centres and the ceiling gathers that error; read at the hits it is not.

mod common;

use std::sync::Arc;

use luxbake::scene::{Albedo, Blur, Lamp, Method, Object, Quality, Scene, Settings, Transform};
use luxbake::sources::meshes;
use luxbake_ies::Photometry;

use common::run;

/// The room, metres: the floor at y = 0, the ceiling at y = `HEIGHT`.
const SIZE: [f32; 3] = [3.0, HEIGHT, 3.0];
const HEIGHT: f32 = 1.2;
/// The lamp's height, and its candela inside `FULL_DEG`; linear to 0 at `CUT_DEG`.
const LAMP_Y: f64 = 1.0;
const CANDELA: f64 = 1000.0;
const FULL_DEG: f64 = 20.0;
const CUT_DEG: f64 = 30.0;
const RHO: f64 = 0.5;

/// A rotationally symmetric spot (type C, absolute candela, no opening): `CANDELA` up to
/// `FULL_DEG` from the nadir, linear to 0 at `CUT_DEG`, dark above.
fn spot() -> Arc<Photometry> {
    let ies = format!(
        "IESNA:LM-63-2002\n[TEST] cut-off spot\nTILT=NONE\n\
         1 -1 1 5 1 1 2 0 0 0\n1 1 0\n0 {FULL_DEG} {CUT_DEG} 90 180\n0\n\
         {CANDELA} {CANDELA} 0 0 0\n"
    );
    Arc::new(Photometry::parse(ies.as_bytes()).expect("spot parses"))
}

/// The file's intensity at `gamma_deg` from the nadir (linear between its angles).
fn intensity(gamma_deg: f64) -> f64 {
    if gamma_deg <= FULL_DEG {
        CANDELA
    } else if gamma_deg < CUT_DEG {
        CANDELA * (CUT_DEG - gamma_deg) / (CUT_DEG - FULL_DEG)
    } else {
        0.0
    }
}

/// The first bounce at the ceiling point `(x, HEIGHT, z)`: `ρ/π ∫ E(y) cos θₓ cos θ_y / r² dA`
/// over the floor's lit disk, `E(y) = I(γ) cos γ / d²` (midpoint rule in polar coordinates
/// around the lamp's foot, fine enough that it converges to 1e-5).
fn first_bounce(x: f64, z: f64) -> f64 {
    let h = LAMP_Y;
    let radius = h * CUT_DEG.to_radians().tan();
    let (nr, nphi) = (1200, 720);
    let ceiling = f64::from(HEIGHT);
    let mut sum = 0.0;
    for i in 0..nr {
        let r = radius * (i as f64 + 0.5) / nr as f64;
        let dr = radius / nr as f64;
        let d2 = h * h + r * r;
        let gamma = (r / h).atan().to_degrees();
        let e = intensity(gamma) * (h / d2.sqrt()) / d2;
        if e == 0.0 {
            continue;
        }
        for j in 0..nphi {
            let phi = std::f64::consts::TAU * (j as f64 + 0.5) / nphi as f64;
            let (px, pz) = (r * phi.cos(), r * phi.sin());
            let r2 = (px - x).powi(2) + (pz - z).powi(2) + ceiling * ceiling;
            let cos2 = ceiling * ceiling / r2;
            sum += e * cos2 / r2 * r * dr * (std::f64::consts::TAU / nphi as f64);
        }
    }
    RHO / std::f64::consts::PI * sum
}

/// The room at 5 texels/m (the lit disk's radius, 0.58 m, is three texels) with the spot,
/// one bounce gathered with 16 384 rays per texel and nothing else: no lamp paths, no filter.
fn scene(direct_at_hits: bool) -> Scene {
    let settings = Settings {
        method: Method::Converged,
        bounces: 1,
        tail: false,
        rays: 16_384,
        lamp_paths: 0,
        blur: Blur::None,
        denoise_correction: false,
        texels_per_metre: 5.0,
        direct_at_hits,
        ..Settings::preset(Quality::Default)
    };
    Scene {
        objects: vec![Object {
            name: "room".into(),
            mesh: meshes::room(SIZE, meshes::RoomAlbedo::uniform([RHO as f32; 3]), 0.4),
            transform: Transform::IDENTITY,
            albedo: Albedo::grey(1.0),
            receiver: true,
            texel_scale: 1.0,
        }],
        lamps: vec![Lamp::new("spot", spot(), [0.0, LAMP_Y, 0.0])],
        settings,
    }
}

/// The ceiling's texels within 0.5 m of its centre: (mean relative error of the first bounce
/// against the closed form, its largest, texels).
fn ceiling_error(direct_at_hits: bool) -> (f64, f64, usize) {
    let scene = scene(direct_at_hits);
    let out = run(&scene);
    let g = luxbake::gbuffer::rasterize(&scene, &out.layout);
    let maps = out.maps.iter().find(|m| m.name == "room").expect("room");
    let indirect = maps.indirect().expect("one bounce");
    let errors: Vec<f64> = maps
        .texels(&g, indirect)
        .filter(|(p, _)| p[1] > f64::from(HEIGHT) - 1e-3 && p[0].hypot(p[2]) < 0.5)
        .map(|(p, t)| {
            let exact = first_bounce(p[0], p[2]);
            (f64::from(t[1]) - exact) / exact
        })
        .collect();
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    let max = errors.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    (mean, max, errors.len())
}

#[test]
fn the_first_bounce_read_at_the_hits_matches_the_closed_form_where_the_maps_do_not() {
    let (mean, max, texels) = ceiling_error(true);
    let (map_mean, map_max, _) = ceiling_error(false);
    println!(
        "{texels} ceiling texels: at the hits mean {:+.3} %, max |rel| {:.3} %; from the floor's map mean {:+.3} %, max |rel| {:.3} %",
        100.0 * mean,
        100.0 * max,
        100.0 * map_mean,
        100.0 * map_max
    );
    assert!(texels >= 12, "{texels} texels");
    assert!(
        mean.abs() < 0.001 && max < 0.003,
        "at the hits: {mean} / {max}"
    );
    // What the test detects: the floor map's interpolated edge, many times the error above.
    assert!(map_mean.abs() > 0.02, "from the map: {map_mean}");
}
