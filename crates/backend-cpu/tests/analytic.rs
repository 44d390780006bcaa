//! Closed-form checks of the CPU reference backend (issue #4, tests 1–4): blur off wherever a
//! closed form is compared. Each test prints the errors it measured (`--nocapture`).

use std::sync::Arc;

use luxbake::bake::{BakeOutput, bake};
use luxbake::gbuffer::{GBuffer, rasterize};
use luxbake::layout::Layout;
use luxbake::probe::locate;
use luxbake::scene::{Albedo, Blur, Lamp, Mesh, Object, Scene, Settings, Transform};
use luxbake::sources::{closed_forms, meshes};
use luxbake_backend_cpu::CpuBackend;
use luxbake_ies::Photometry;
use luxbake_testkit::{RelativeError, shared_data};

/// `scene` baked on the CPU backend at its own settings.
fn run_cpu(scene: &Scene) -> BakeOutput {
    luxbake_backend_cpu::bake(scene).expect("bake")
}

fn settings(texels_per_metre: f32, bounces: u32, rays: u32) -> Settings {
    Settings {
        rays,
        bounces,
        blur: Blur::None,
        texels_per_metre,
        ..Settings::paper()
    }
}

/// `scene` baked on the CPU backend (every texel of every stage finite and non-negative) and
/// the G-buffer of its layout.
fn bake_checked(scene: &Scene) -> (BakeOutput, GBuffer) {
    let out = run_cpu(scene);
    assert_eq!(out.first_invalid_texel(), None);
    let g = rasterize(scene, &out.layout);
    (out, g)
}

const I0: f64 = 1000.0;

fn floor_scene(density: f32, lamp: Lamp) -> Scene {
    let mut s = Scene::builtin_with_settings("floor", settings(density, 0, 1)).expect("floor");
    s.lamps = vec![lamp];
    s
}

fn isotropic(cd: f64, position: [f32; 3]) -> Lamp {
    Lamp::new(
        "iso",
        Arc::new(Photometry::isotropic(cd)),
        position.map(f64::from),
    )
}

// Test 1a: E(r) = I·h / (h² + r²)^{3/2} on the floor, at every texel and at 20 points.
#[test]
fn floor_inverse_square_cosine() {
    let h = 2.0f64;
    let scene = floor_scene(8.0, isotropic(I0, [0.0, h as f32, 0.0]));
    let (out, g) = bake_checked(&scene);
    let maps = &out.maps[0];
    let closed = |p: [f64; 3]| {
        let r2 = p[0] * p[0] + p[2] * p[2];
        let dy = h - p[1];
        I0 * dy / (dy * dy + r2).powf(1.5)
    };
    let all: RelativeError = maps
        .texels(&g, maps.illuminance())
        .map(|(p, t)| (f64::from(t[0]), closed(p)))
        .collect();
    // 20 calculation points along a spiral, read back bilinearly like `xtask measure`.
    let mut points = RelativeError::default();
    for k in 0..20 {
        let r = 0.45 * k as f64;
        let a = 0.7 * k as f64;
        let p = [r * a.cos(), 0.0, r * a.sin()];
        let sp = locate(&scene, p, 1e-3).expect("point on the floor");
        let e = maps.illuminance().sample(sp.uv)[0];
        points.add(f64::from(e), closed(p));
    }
    println!("floor isotropic, texels: {all}; 20 points (bilinear): {points}");
    assert!(all.n > 10_000);
    assert!(all.max < 0.005, "{all:?}");
    assert!(points.max < 0.005, "{points:?}");
}

fn asym_lamp(test: &str, position: [f32; 3], rotation_deg: f32) -> Option<Lamp> {
    let path = shared_data(test, "photometry/synthetic_asym_typeC.ies")?;
    let bytes = std::fs::read(path).expect("read");
    let mut l = Lamp::new(
        "asym",
        Arc::new(Photometry::parse(&bytes).expect("parse")),
        position.map(f64::from),
    );
    l.rotation_deg = rotation_deg;
    Some(l)
}

/// Expected E for a lamp: intensity from the exact photometric query (f64), cosine, 1/d².
fn expected(lamp: &Lamp, frame: &[[f64; 3]; 3], p: [f64; 3]) -> f64 {
    let lp = lamp.position.map(f64::from);
    let d = [p[0] - lp[0], p[1] - lp[1], p[2] - lp[2]];
    let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    let dir = frame.map(|row| row[0] * d[0] + row[1] * d[1] + row[2] * d[2]);
    let i = lamp.photometry.intensity(dir);
    i * (-d[1]) / d2.powf(1.5)
}

// Test 1b: a type C IES lamp; test 1c: the same lamp turned 90° turns the pattern.
#[test]
fn floor_type_c_lamp_and_turned_lamp() {
    let h = 2.0f32;
    let test = "floor_type_c_lamp_and_turned_lamp";
    let Some(lamp) = asym_lamp(test, [0.0, h, 0.0], 0.0) else {
        return;
    };
    let Some(turned) = asym_lamp(test, [0.0, h, 0.0], 90.0) else {
        return;
    };
    let peak = lamp.photometry.max_intensity().0;
    let frame = lamp.frame_f64();
    for (name, l, expect_frame) in [
        ("type C", lamp.clone(), None),
        ("turned 90°", turned, Some(frame)),
    ] {
        let scene = floor_scene(8.0, l.clone());
        let (out, g) = bake_checked(&scene);
        let maps = &out.maps[0];
        let mut err = RelativeError::default();
        let mut moved = 0usize;
        for (p, t) in maps.texels(&g, maps.illuminance()) {
            let want = match expect_frame {
                // Unturned: the lamp's own frame.
                None => expected(&l, &l.frame_f64(), p),
                // Turned 90° (C0 from +X to −Z, counter-clockwise seen from above): the value
                // at p is the unturned lamp's at p rotated back by −90° about +Y.
                Some(f) => {
                    let back = [-p[2], p[1], p[0]];
                    let e = expected(&lamp, &f, back);
                    if (e - expected(&lamp, &f, p)).abs() > 0.05 * e.abs() {
                        moved += 1;
                    }
                    e
                }
            };
            // Compare where the intensity is well inside the measured data (at least 5 % of
            // the peak): at the edge of the data the table ramps over one cell.
            let i_here =
                want * (p[0] * p[0] + p[2] * p[2] + f64::from(h * h)).powf(1.5) / f64::from(h);
            if i_here > 0.05 * peak {
                err.add(f64::from(t[0]), want);
            }
        }
        println!("floor {name}, texels compared: {err}");
        assert!(err.n > 1000, "{name}: {err:?}");
        assert!(err.max < 0.005, "{name}: {err:?}");
        if expect_frame.is_some() {
            assert!(
                moved > 100,
                "the turned pattern must differ from the unturned one"
            );
        }
    }
}

/// 1000 cd in every direction, with tilt factors 1, 0.8 and 0.5 at 0°, 45° and 90°.
const TILTED_ISOTROPIC_IES: &str = "IESNA:LM-63-2002\n[TEST] tilt\nTILT=INCLUDE\n1\n3\n\
    0 45 90\n1 0.8 0.5\n1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 180\n0\n1000 1000\n";

// Test 1d: the tilt factor is taken at the lamp's tilt (the angle between its aim and straight
// down): an isotropic lamp aimed 30° and 45° off the vertical gives exactly the factor times
// the light of the same lamp aimed down, and the closed form E = f(tilt)·I·h / d³.
#[test]
fn the_tilt_factor_at_the_aim_scales_the_direct_light() {
    let h = 2.0f64;
    let photometry = Arc::new(Photometry::parse(TILTED_ISOTROPIC_IES.as_bytes()).expect("parse"));
    let bake_at = |tilt_deg: f64| {
        let mut lamp = Lamp::new(
            "tilted",
            Arc::clone(&photometry),
            [0.0, f64::from(h as f32), 0.0],
        );
        let t = tilt_deg.to_radians();
        lamp.aim = [t.sin() as f32, -t.cos() as f32, 0.0];
        assert!(
            (lamp.tilt_deg() - tilt_deg).abs() < 1e-4,
            "{}",
            lamp.tilt_deg()
        );
        let scene = floor_scene(8.0, lamp);
        let (out, g) = bake_checked(&scene);
        let maps = &out.maps[0];
        let t: Vec<([f64; 3], [f32; 4])> = maps.texels(&g, maps.illuminance()).collect();
        t
    };
    let down = bake_at(0.0);
    // 30°: two thirds of the way from 1 (0°) to 0.8 (45°).
    for (tilt, factor) in [(30.0, 1.0 - 0.2 * 30.0 / 45.0), (45.0, 0.8)] {
        let tilted = bake_at(tilt);
        assert_eq!(tilted.len(), down.len());
        let (mut ratio, mut closed) = (RelativeError::default(), RelativeError::default());
        for ((p, e), (_, e0)) in tilted.iter().zip(&down) {
            ratio.add(f64::from(e[0]), factor * f64::from(e0[0]));
            let r2 = p[0] * p[0] + p[2] * p[2];
            let dy = h - p[1];
            closed.add(f64::from(e[0]), factor * I0 * dy / (dy * dy + r2).powf(1.5));
        }
        println!(
            "tilt {tilt}°: factor {factor:.4}, {} texels; against factor × aimed down max {:.2e}, \
             against the closed form max {:.2e}",
            ratio.n, ratio.max, closed.max
        );
        assert!(ratio.n > 10_000);
        assert!(ratio.max < 1e-5, "{ratio:?}");
        assert!(closed.max < 0.005, "{closed:?}");
    }
}

// Test 1e: the floor modelled at 1/1000 scale bakes at 16 000 texels per metre: the same
// layout as at full scale at 16, and E × 10⁶ (the same candela at a thousandth of the
// distance) in every texel.
#[test]
fn a_scene_at_a_thousandth_of_the_scale_bakes_the_same_texels() {
    let full = floor_scene(16.0, isotropic(I0, [0.0, 2.0, 0.0]));
    let small = full.scaled(1e-3);
    assert!(small.settings.texels_per_metre > 10_000.0);
    let (a, b) = (run_cpu(&full), run_cpu(&small));
    assert_eq!(b.first_invalid_texel(), None);
    assert_eq!(a.layout, b.layout);
    let mut err = RelativeError::default();
    let (ea, eb) = (a.maps[0].illuminance(), b.maps[0].illuminance());
    for (x, y) in ea.texels.chunks_exact(4).zip(eb.texels.chunks_exact(4)) {
        assert_eq!(x[3], y[3], "the same texels are valid");
        if x[3] > 0.5 {
            err.add(f64::from(y[0]), 1e6 * f64::from(x[0]));
        }
    }
    println!(
        "1/1000 scale: {} texels laid out, {} compared, max relative deviation from E × 10⁶ {:.2e}",
        b.layout.texel_count(),
        err.n,
        err.max
    );
    assert!(err.n > 10_000);
    assert!(err.max < 1e-4, "{err:?}");
}

// Test 1f: an absurd density stops the bake with an error naming the texel count and the
// limit, before anything of that size is allocated.
#[test]
fn an_absurd_density_is_an_error_not_an_allocation() {
    let scene = floor_scene(1e9, isotropic(I0, [0.0, 2.0, 0.0]));
    let e = bake(&mut CpuBackend::new(), &scene, &scene.settings, &mut |_| {})
        .expect_err("too many texels");
    let m = e.to_string();
    assert!(
        m.contains(&format!("limit of {} texels", Layout::MAX_TEXELS))
            && m.contains("texels_per_metre"),
        "{m}"
    );
}

// Test 2: closed sphere, E = (I/R²)·Σ_{i=0..k} ρ^i within 1 % for k = 0..3.
#[test]
fn closed_sphere_interreflection_series() {
    let (r, rho) = (1.0f64, 0.5f64);
    for k in 0..=3u32 {
        let settings = settings(12.0 / r as f32, k, 16);
        let (scene, _) = closed_forms::closed_sphere(r as f32, rho as f32, I0, settings);
        let (out, g) = bake_checked(&scene);
        assert_eq!(out.report.bounces_run, k);
        let maps = &out.maps[0];
        let want = I0 / (r * r) * (0..=k).map(|i| rho.powi(i as i32)).sum::<f64>();
        let err: RelativeError = maps
            .texels(&g, maps.illuminance())
            .map(|(_, t)| (f64::from(t[0]), want))
            .collect();
        println!("sphere k={k}, E want {want:.3} lux, texels: {err}");
        assert!(err.n > 1000);
        assert!(err.max < 0.01, "k={k}: {err:?}");
    }
}

fn room_scene(albedo_factor: Option<f32>, multiplier: f32) -> Scene {
    let mut s = Scene::builtin_with_settings(
        "chairs_01",
        Settings {
            rays: 8,
            bounces: 1,
            blur: Blur::Sigma(1.5),
            texels_per_metre: 6.0,
            ..Settings::paper()
        },
    )
    .expect("chairs_01");
    if let Some(a) = albedo_factor {
        for o in &mut s.objects {
            o.albedo.factor = [a; 3];
        }
    }
    for l in &mut s.lamps {
        l.multiplier = multiplier;
    }
    s
}

// Test 3a: albedo 0 → no indirect light at all.
#[test]
fn zero_albedo_gives_no_indirect() {
    let scene = room_scene(Some(0.0), 1.0);
    let out = run_cpu(&scene);
    assert_eq!(out.first_invalid_texel(), None);
    let mut lit = 0;
    for m in &out.maps {
        let ind = m.indirect().expect("one bounce");
        assert!(
            ind.texels.chunks_exact(4).all(|t| t[..3] == [0.0; 3]),
            "{}",
            m.name
        );
        // Final illuminance = blurred direct exactly.
        assert_eq!(m.illuminance(), m.direct());
        lit += m.direct().valid_rgb().filter(|c| c[0] > 0.0).count();
    }
    assert!(lit > 1000, "the lamp lights the room");
}

// Test 3b: doubling the lamp multiplier doubles every texel of every stage.
#[test]
fn doubling_the_multiplier_doubles_every_texel() {
    let a = run_cpu(&room_scene(None, 1.0));
    let b = run_cpu(&room_scene(None, 2.0));
    let mut worst = 0.0f64;
    let mut compared = 0usize;
    for (ma, mb) in a.maps.iter().zip(&b.maps) {
        for s in 1..8 {
            let (Some(sa), Some(sb)) = (&ma.stages[s], &mb.stages[s]) else {
                continue;
            };
            for (x, y) in sa.texels.chunks_exact(4).zip(sb.texels.chunks_exact(4)) {
                for c in 0..3 {
                    let want = 2.0 * f64::from(x[c]);
                    let got = f64::from(y[c]);
                    if want > 0.0 {
                        worst = worst.max((got - want).abs() / want);
                        compared += 1;
                    } else {
                        assert_eq!(got, 0.0);
                    }
                }
            }
        }
    }
    println!("multiplier ×2: {compared} values, max relative deviation {worst:.2e}");
    assert!(compared > 10_000);
    assert!(worst < 1e-6, "{worst}");
}

/// A room with an isotropic lamp 1 mm in front of the +X wall, half-way up.
fn lamp_at_wall_scene() -> Scene {
    let size = [4.0f32, 2.5, 3.0];
    let density = 10.0;
    let mesh = meshes::room(size, meshes::RoomAlbedo::uniform([0.5; 3]), 4.0 / density);
    Scene {
        objects: vec![Object {
            name: "room".into(),
            mesh,
            transform: Transform::IDENTITY,
            albedo: Albedo::grey(1.0),
            receiver: true,
            texel_scale: 1.0,
        }],
        lamps: vec![isotropic(I0, [size[0] / 2.0 - 1e-3, 1.25, 0.3])],
        settings: settings(density, 1, 16),
    }
}

// Test 4a: a lamp 1 mm from a wall: the wall it almost touches follows the closed form.
#[test]
fn lamp_one_millimetre_from_a_wall() {
    let scene = lamp_at_wall_scene();
    let (out, g) = bake_checked(&scene);
    let maps = &out.maps[0];
    let l = scene.lamps[0].position.map(f64::from);
    let mut err = RelativeError::default();
    let mut brightest = 0.0f64;
    for (p, t) in maps.texels(&g, maps.direct_unblurred()) {
        // Texels of the +X wall (x = 2): cosine = 1 mm / d.
        if (p[0] - 2.0).abs() < 1e-4 {
            let d = [p[0] - l[0], p[1] - l[1], p[2] - l[2]];
            let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let want = I0 * (p[0] - l[0]) / d2.powf(1.5);
            err.add(f64::from(t[0]), want);
            brightest = brightest.max(f64::from(t[0]));
        }
    }
    println!("lamp 1 mm from wall, wall texels: {err}; brightest {brightest:.3e} lux");
    assert!(err.n > 500);
    assert!(err.max < 0.005, "{err:?}");
}

// Test 4b: the whole scene scaled by 10⁻³ and 10³: illuminance scales as 1/s².
#[test]
fn scaled_scenes_scale_as_inverse_square() {
    let h = 2.0f32;
    let base = floor_scene(4.0, isotropic(I0, [0.0, h, 0.0]));
    let reference = run_cpu(&base);
    let reference_maps = &reference.maps[0];
    for s in [1e-3f32, 1e3] {
        let mut scene = base.clone();
        scene.objects[0].transform = Transform::from_trs([0.0; 3], [0.0; 3], [s; 3]);
        scene.lamps[0].position = [0.0, f64::from(h * s), 0.0];
        scene.settings.texels_per_metre = 4.0 / s;
        let out = run_cpu(&scene);
        assert_eq!(out.first_invalid_texel(), None);
        let m = &out.maps[0];
        assert_eq!(m.region.size, reference_maps.region.size, "same texel grid");
        let mut err = RelativeError::default();
        let scale = f64::from(s) * f64::from(s);
        for (a, b) in reference_maps
            .illuminance()
            .texels
            .chunks_exact(4)
            .zip(m.illuminance().texels.chunks_exact(4))
        {
            if a[3] > 0.5 {
                err.add(f64::from(b[0]) * scale, f64::from(a[0]));
            }
        }
        println!("scale {s:e}, texels' E·s² vs unscaled: {err}");
        assert!(err.n > 1000);
        assert!(err.max < 1e-3, "scale {s}: {err:?}");
    }
}

// Test 4c: grazing incidence: a lamp 1 cm above a 20 m floor; and 10⁶ cd.
#[test]
fn grazing_incidence_and_a_million_candela() {
    for (h, cd) in [(0.01f64, I0), (2.0, 1e6)] {
        let scene = floor_scene(8.0, isotropic(cd, [0.0, h as f32, 0.0]));
        let (out, g) = bake_checked(&scene);
        let maps = &out.maps[0];
        let mut err = RelativeError::default();
        let mut min_cos = 1.0f64;
        for (p, t) in maps.texels(&g, maps.illuminance()) {
            let r2 = p[0] * p[0] + p[2] * p[2];
            let dy = h - p[1];
            let want = cd * dy / (dy * dy + r2).powf(1.5);
            if r2 > 0.25 {
                err.add(f64::from(t[0]), want);
                min_cos = min_cos.min(dy / (dy * dy + r2).sqrt());
            }
        }
        println!("floor h={h} m, {cd:e} cd, texels: {err}; grazing cos down to {min_cos:.1e}");
        assert!(err.max < 0.005, "h={h}: {err:?}");
    }
}

// Test 4d: degenerate and sliver triangles, and texels on silhouette edges: no NaN or Inf
// anywhere, partially covered edge texels still follow the closed form.
#[test]
fn degenerate_slivers_and_silhouette_edges() {
    let h = 2.0f64;
    let mut scene = floor_scene(8.0, isotropic(I0, [0.0, h as f32, 0.0]));
    // An extra receiver: a zero-area triangle, a 1 µm-wide sliver 1 m long standing on the
    // floor, and a normal triangle, with light-map UVs to match.
    let mesh = Mesh {
        positions: vec![
            [1.0, 0.5, 1.0],
            [1.0, 0.5, 1.0],
            [1.0, 0.5, 1.0],
            [2.0, 0.0, 2.0],
            [2.000_001, 0.0, 2.0],
            [2.0, 1.0, 2.0],
            [3.0, 0.0, 3.0],
            [3.5, 0.0, 3.0],
            [3.0, 0.5, 3.0],
        ],
        normals: vec![
            [0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, -1.0],
            [0.0, 0.0, -1.0],
            [0.0, 0.0, -1.0],
            [0.0, 0.0, -1.0],
            [0.0, 0.0, -1.0],
            [0.0, 0.0, -1.0],
        ],
        lightmap_uvs: vec![
            [0.1, 0.1],
            [0.1, 0.1],
            [0.1, 0.1],
            [0.2, 0.9],
            [0.200_001, 0.9],
            [0.2, 0.1],
            [0.4, 0.9],
            [0.9, 0.9],
            [0.4, 0.4],
        ],
        material_uvs: None,
        colors: None,
        indices: vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]],
    };
    scene.objects.push(Object {
        name: "slivers".into(),
        mesh,
        transform: Transform::IDENTITY,
        albedo: Albedo::grey(0.5),
        receiver: true,
        texel_scale: 1.0,
    });
    scene.settings.bounces = 1;
    scene.settings.rays = 8;
    // Silhouette texels of the floor: partially covered (coverage < 1) yet exact.
    let (out, g) = bake_checked(&scene);
    let floor = &out.maps[0];
    let r = floor.region;
    let mut edge = RelativeError::default();
    for y in 0..r.size[1] {
        for x in 0..r.size[0] {
            let i = g.index(r.layer, r.offset[0] + x, r.offset[1] + y);
            let (p, coverage) = (&g.position[i..i + 4], g.albedo[i + 3]);
            if p[3] > 0.5 && coverage < 0.999 {
                let p = [p[0], p[1], p[2]].map(f64::from);
                let r2 = p[0] * p[0] + p[2] * p[2];
                let want = I0 * (h - p[1]) / ((h - p[1]).powi(2) + r2).powf(1.5);
                edge.add(f64::from(floor.direct_unblurred().texel(x, y)[0]), want);
            }
        }
    }
    println!(
        "silhouette texels of the floor: {} (coverage < 1), max err {:.2e}",
        edge.n, edge.max
    );
    assert!(edge.n > 0, "the floor has partially covered edge texels");
    assert!(edge.max < 0.005, "{edge:?}");
}

// The gather against a form-factor integral: a 2 m floor lit by an isotropic lamp 0.4 m above
// it, and a small downward-facing patch 0.5 m above the floor. The patch's first-bounce
// indirect illuminance is `∫ ρ·E_floor(q) · cos θ_q cos θ_c / (π r²) dA_q`, integrated here by
// the midpoint rule in f64. This checks hit light-map UVs, region look-ups and the cosine
// weighting with a non-uniform reflected map.
#[test]
fn gather_matches_form_factor_quadrature() {
    let (rho, h_lamp, h_patch, half) = (0.5f64, 0.4f64, 0.5f64, 1.0f64);
    let density = 16.0f32;
    let pad = 4.0 / density;
    let plane = |size: f32, y: f32, flip: bool, albedo: f32, name: &str| Object {
        name: name.into(),
        mesh: meshes::plane([size; 2], pad),
        transform: Transform::from_trs(
            [0.0, f64::from(y), 0.0],
            [if flip { 180.0 } else { 0.0 }, 0.0, 0.0],
            [1.0; 3],
        ),
        albedo: Albedo::grey(albedo),
        receiver: true,
        texel_scale: 1.0,
    };
    let scene = Scene {
        objects: vec![
            plane(2.0 * half as f32, 0.0, false, rho as f32, "floor"),
            plane(0.25, h_patch as f32, true, 0.5, "patch"),
        ],
        lamps: vec![isotropic(I0, [0.0, h_lamp as f32, 0.0])],
        settings: settings(density, 1, 1024),
    };
    let (out, g) = bake_checked(&scene);
    let patch = &out.maps[1];
    let indirect = patch.indirect().expect("one bounce");
    let n = 400;
    let step = 2.0 * half / f64::from(n);
    let quadrature = |c: [f64; 3]| {
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let q = [
                    -half + (f64::from(i) + 0.5) * step,
                    0.0,
                    -half + (f64::from(j) + 0.5) * step,
                ];
                let e = I0 * h_lamp / (h_lamp * h_lamp + q[0] * q[0] + q[2] * q[2]).powf(1.5);
                let d = [c[0] - q[0], c[1] - q[1], c[2] - q[2]];
                let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                sum += rho * e * d[1] * d[1] / (std::f64::consts::PI * r2 * r2) * step * step;
            }
        }
        sum
    };
    let (mut got, mut want, mut count) = (0.0, 0.0, 0);
    for (p, t) in patch.texels(&g, indirect) {
        got += f64::from(t[0]);
        want += quadrature(p);
        count += 1;
    }
    let err = (got - want).abs() / want;
    println!(
        "gather vs quadrature: {count} patch texels, mean indirect {:.3} lux (quadrature {:.3}), error {err:.2e}",
        got / f64::from(count),
        want / f64::from(count)
    );
    assert!(count >= 9);
    assert!(err < 0.02, "{err}");
}
