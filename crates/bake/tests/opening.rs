//! Lamps with a luminous opening on the CPU backend: which model `auto` picks and why, the
//! area model's noise at the default preset under a real linear pendant, and its cost where
//! nothing is near. (The closed forms on every backend: `tests/tests/opening.rs`.)

mod common;

use std::sync::Arc;

use luxbake::bake::BakeOutput;
use luxbake::gbuffer::rasterize;
use luxbake::scene::{Albedo, Lamp, LampModel, Object, Quality, Scene, Settings, Transform};
use luxbake::sources::builtin::DEFAULT_LAMP_IES;
use luxbake::sources::meshes;
use luxbake_ies::Photometry;
use luxbake_testkit::shared_data;

use common::{assert_finite, run};

/// A 1.8 × 0.75 × 0.9 m table on a 4 × 3.5 m floor, direct light only, at `density`.
fn dining(lamps: Vec<Lamp>, density: f32, samples: u32) -> Scene {
    let settings = Settings {
        bounces: 0,
        texels_per_metre: density,
        opening_samples: samples,
        ..Settings::preset(Quality::Default)
    };
    let pad = 2.0 / density;
    Scene {
        objects: vec![
            Object {
                name: "floor".into(),
                mesh: meshes::plane([4.0, 3.5], pad),
                transform: Transform::IDENTITY,
                albedo: Albedo::grey(0.3),
                receiver: true,
                texel_scale: 1.0,
            },
            Object {
                name: "table".into(),
                mesh: meshes::cuboid([1.8, 0.75, 0.9], false, pad),
                transform: Transform::IDENTITY,
                albedo: Albedo::grey(0.6),
                receiver: true,
                texel_scale: 1.0,
            },
        ],
        lamps,
        settings,
    }
}

fn photometry(test: &str, relative: &str) -> Option<Arc<Photometry>> {
    let path = shared_data(test, relative)?;
    let bytes = std::fs::read(&path).expect("read");
    Some(Arc::new(Photometry::parse(&bytes).expect("parse")))
}

/// The table top's texels (at its height, 0.75 m; the sides' texels lie below): illuminance
/// (green).
fn table_top(scene: &Scene, out: &BakeOutput) -> Vec<f64> {
    let g = rasterize(scene, &out.layout);
    let maps = out.maps.iter().find(|m| m.name == "table").expect("table");
    maps.texels(&g, maps.illuminance())
        .filter(|(p, _)| p[1] > 0.749)
        .map(|(_, t)| f64::from(t[1]))
        .collect()
}

#[test]
fn auto_keeps_a_far_downlight_a_point_and_gives_a_near_linear_pendant_its_opening() {
    let test = "auto_lamp_model";
    let Some(linear) = photometry(test, "photometry/real-world/rw_5.IES") else {
        return;
    };
    let downlight = Arc::new(Photometry::parse(DEFAULT_LAMP_IES.as_bytes()).expect("downlight"));
    let lamps = vec![
        Lamp::new("downlight", downlight.clone(), [1.5, 2.5, 1.2]),
        Lamp::new("pendant", linear.clone(), [0.0, 1.3, 0.0]),
        {
            let mut l = Lamp::new("forced", linear.clone(), [0.0, 1.3, 0.0]);
            l.model = LampModel::Point;
            l
        },
        {
            let mut l = Lamp::new(
                "iso",
                Arc::new(Photometry::isotropic(100.0)),
                [1.0, 1.0, 1.0],
            );
            l.model = LampModel::Area;
            l
        },
    ];
    let out = run(&dining(lamps, 8.0, 8));
    let models = &out.report.lamp_models;
    for m in models {
        println!("{m}");
    }
    assert_eq!(models.len(), 4);
    // The 150 mm downlight: its opening matters within 0.75 m; the floor is 2.5 m away.
    assert!(!models[0].area, "{}", models[0]);
    assert!(
        models[0].reason.starts_with("auto: no receiver"),
        "{}",
        models[0]
    );
    // The 0.61 m linear pendant 0.55 m over the table: within its 1 % distance (2.5 m).
    assert!(models[1].area, "{}", models[1]);
    let d1 = linear
        .emitter()
        .expect("rw_5 opening")
        .point_model_distance(0.01);
    let near = models[1].near_m.expect("near distance");
    let want = LampModel::SWITCH_FACTOR * d1;
    assert!((near - want).abs() < 1e-4 * near, "{near} vs {want}");
    assert!(
        models[1].reason.starts_with("auto: a receiver 0.55"),
        "{}",
        models[1]
    );
    // Asked for: the point; and a file without an opening stays a point.
    assert!(!models[2].area && models[2].reason.contains("point"));
    assert!(!models[3].area && models[3].reason.contains("no luminous opening"));
}

#[test]
fn the_area_models_noise_at_the_default_preset_under_a_linear_pendant_is_under_one_percent() {
    let test = "opening_noise_at_default";
    let Some(linear) = photometry(test, "photometry/real-world/rw_5.IES") else {
        return;
    };
    let lamp = |samples| {
        let mut l = Lamp::new("pendant", linear.clone(), [0.0, 1.3, 0.0]);
        l.model = LampModel::Area;
        dining(vec![l], 32.0, samples)
    };
    let default = Settings::preset(Quality::Default).opening_samples;
    let scene = lamp(default);
    let reference = lamp(512);
    let (a, b) = (
        table_top(&scene, &run(&scene)),
        table_top(&reference, &run(&reference)),
    );
    assert_eq!(a.len(), b.len());
    assert!(a.len() > 1000, "{} texels", a.len());
    let mut rel: Vec<f64> = a.iter().zip(&b).map(|(x, y)| (x - y).abs() / y).collect();
    rel.sort_by(f64::total_cmp);
    assert!(b.iter().all(|&y| y > 0.0), "the whole top is lit");
    let mean = rel.iter().sum::<f64>() / rel.len() as f64;
    let p99 = rel[rel.len() * 99 / 100];
    let max = rel[rel.len() - 1];
    println!(
        "{} table-top texels, {default} vs 512 samples: mean |rel| {:.3} %, p99 {:.3} %, max {:.3} %",
        rel.len(),
        100.0 * mean,
        100.0 * p99,
        100.0 * max
    );
    assert!(max < 0.01, "max {max}");
}

/// The largest luminance of `p`'s opening over a fine grid of directions, cd/m².
fn max_luminance(p: &Photometry) -> f64 {
    let emitter = p.emitter().expect("an opening");
    let mut max = 0.0f64;
    for i in 0..=360 {
        for j in 0..72 {
            let (g, c) = (
                f64::from(i) * 0.5_f64.to_radians(),
                f64::from(j) * 5f64.to_radians(),
            );
            let d = [g.sin() * c.cos(), g.sin() * c.sin(), -g.cos()];
            let area = emitter.projected_area(d);
            if area > 0.0 {
                max = max.max(p.intensity(d) / area);
            }
        }
    }
    max
}

#[test]
fn openings_touching_a_ceiling_or_a_wall_stay_finite_and_bounded() {
    let test = "opening_extremes";
    let (Some(box_pendant), Some(sconce), Some(disk)) = (
        photometry(test, "photometry/real-world/rw_1.IES"),
        photometry(test, "photometry/real-world/rw_8.IES"),
        photometry(test, "photometry/real-world/rw_2.IES"),
    ) else {
        return;
    };
    let settings = Settings {
        bounces: 0,
        texels_per_metre: 24.0,
        ..Settings::preset(Quality::Default)
    };
    let size = [4.0f32, 2.6, 3.0];
    let half_height = box_pendant.emitter().expect("rw_1 opening").half[2];
    let sconce_depth = sconce.emitter().expect("rw_8 opening").half[0];
    let mut lamps = vec![
        // The box's top 0.5 mm under the ceiling.
        Lamp::new(
            "box",
            box_pendant.clone(),
            [0.0, 2.6 - half_height - 5e-4, 0.0],
        ),
        // The sconce's back 1 mm off the +X wall.
        Lamp::new(
            "sconce",
            sconce.clone(),
            [2.0 - sconce_depth - 1e-3, 1.6, 0.5],
        ),
        // A flat disk that lights up and down (its closed form where the texels see it whole)
        // 0.5 mm under the ceiling.
        Lamp::new("disk", disk.clone(), [-1.2, 2.6 - 5e-4, -0.8]),
    ];
    for l in &mut lamps {
        l.model = LampModel::Area;
    }
    let scene = Scene {
        objects: vec![Object {
            name: "room".into(),
            mesh: meshes::room(size, meshes::RoomAlbedo::uniform([0.5; 3]), 2.0 / 24.0),
            transform: Transform::IDENTITY,
            albedo: Albedo::grey(1.0),
            receiver: true,
            texel_scale: 1.0,
        }],
        lamps,
        settings,
    };
    let out = run(&scene);
    assert_finite(&out);
    let bound = std::f64::consts::PI
        * (max_luminance(&box_pendant) + max_luminance(&sconce) + max_luminance(&disk));
    let mut peak = 0.0f64;
    for m in &out.maps {
        for t in m.illuminance().texels.chunks_exact(4) {
            peak = peak.max(f64::from(t[1]));
        }
    }
    println!("peak {peak:.0} lux, bound π·ΣL_max {bound:.0} lux");
    assert!(peak > 0.0 && peak <= bound, "peak {peak} over {bound}");
    // Handed over first, the preview (the lamps as points, 0.5 mm and 1 mm from the surfaces
    // behind their openings) stays finite too.
    let room = common::prepare(&scene);
    let mut previews = 0;
    luxbake::bake_room_direct_first(
        &mut luxbake_backend_cpu::CpuBackend::new(),
        &room,
        &scene.lamps,
        &scene.settings,
        &mut |_| {},
        &mut |stage, maps| {
            if stage == luxbake::DirectStage::Preview {
                previews += 1;
                for m in maps {
                    let t = &m.illuminance().texels;
                    assert!(t.iter().all(|v| v.is_finite() && *v >= 0.0), "{}", m.name);
                    assert!(t.iter().any(|v| *v > 0.0), "{}", m.name);
                }
            }
        },
    )
    .expect("bake");
    assert_eq!(previews, 1);
}

#[test]
fn an_opening_far_from_the_origin_bakes_as_at_the_origin() {
    let test = "opening_far_from_origin";
    let (Some(linear), Some(disk)) = (
        photometry(test, "photometry/real-world/rw_5.IES"),
        photometry(test, "photometry/real-world/rw_6.IES"),
    ) else {
        return;
    };
    let at = |offset: [f64; 3]| {
        // A linear pendant over the table and a disk beside it.
        let lamps = [(&linear, [0.0, 1.3, 0.0]), (&disk, [1.4, 1.1, 0.6])].map(|(p, at)| {
            let mut l = Lamp::new(
                "pendant",
                p.clone(),
                [offset[0] + at[0], at[1] + offset[1], offset[2] + at[2]],
            );
            l.model = LampModel::Area;
            l
        });
        let mut scene = dining(lamps.to_vec(), 12.0, 48);
        for o in &mut scene.objects {
            o.transform.translation = offset;
        }
        run(&scene)
    };
    let (near, far) = (at([0.0; 3]), at([1.0e4, 0.0, -1.0e4]));
    for (a, b) in near.maps.iter().zip(&far.maps) {
        let (x, y) = (a.illuminance(), b.illuminance());
        let worst = x
            .texels
            .iter()
            .zip(&y.texels)
            .map(|(p, q)| (p - q).abs() / p.abs().max(1e-3))
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-5, "{}: {worst}", a.name);
    }
}

/// Every texel of object `name` (direct light only, so its illuminance): (position, green).
fn texels_of(scene: &Scene, out: &BakeOutput, name: &str) -> Vec<([f64; 3], f64)> {
    let g = rasterize(scene, &out.layout);
    let maps = out.maps.iter().find(|m| m.name == name).expect(name);
    maps.texels(&g, maps.illuminance())
        .map(|(p, t)| (p, f64::from(t[1])))
        .collect()
}

/// The floor texels around a table under a pendant `lamp` (its opening, at 1.3 m) with a grate
/// of thin bars beside the table, baked with `samples` opening samples and probes every
/// `stride` points.
fn grate_floor(lamp: &Arc<Photometry>, samples: u32, stride: u32) -> Vec<([f64; 3], f64)> {
    let mut l = Lamp::new("pendant", lamp.clone(), [0.0, 1.3, 0.0]);
    l.model = LampModel::Area;
    let mut scene = dining(vec![l], 32.0, samples);
    scene.settings.opening_probe_stride = stride;
    // A grate of 5 mm bars 10 cm apart, 0.4 m over the lit floor beside the table (the table
    // shades the floor within about 1.06 m of the lamp in z, 2.1 m in x): from the floor under
    // it each bar hides about 1.6 cm of the opening, between probes or not.
    for i in 0..5 {
        let step = 0.1 * i as f64;
        for (size, at) in [
            ([0.5, 0.005, 0.005], [0.0, 0.4, 1.2 + step]),
            ([0.005, 0.005, 0.5], [-0.2 + step, 0.4, 1.4]),
        ] {
            scene.objects.push(Object {
                name: format!("bar {i} {}", at[0]),
                mesh: meshes::cuboid(size, false, 0.0),
                transform: Transform::from_trs(at, [0.0; 3], [1.0; 3]),
                albedo: Albedo::grey(0.5),
                receiver: false,
                texel_scale: 1.0,
            });
        }
    }
    let out = run(&scene);
    assert_finite(&out);
    texels_of(&scene, &out, "floor")
}

/// Mean, 99.9th percentile and largest of `v`.
fn stats(mut v: Vec<f64>) -> (f64, f64, f64) {
    v.sort_by(f64::total_cmp);
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    (mean, v[v.len() * 999 / 1000], v[v.len() - 1])
}

/// `lamp`'s floor under the grate ([`grate_floor`]) at the default preset with every ray, with
/// its probes and with every ray at 512 samples, and each texel's error against the last
/// (relative to its light, floored at 1 % of the peak: the umbra).
fn grate_errors(lamp: &Arc<Photometry>) -> (Vec<[f64; 3]>, Vec<f64>, Vec<f64>) {
    let samples = Settings::preset(Quality::Default).opening_samples;
    let stride = Settings::preset(Quality::Default).opening_probe_stride;
    assert!(stride > 1, "the default probes");
    let every = grate_floor(lamp, samples, 0);
    let probed = grate_floor(lamp, samples, stride);
    let reference = grate_floor(lamp, 512, 0);
    assert_eq!(every.len(), probed.len());
    assert_eq!(every.len(), reference.len());
    let peak = reference.iter().map(|t| t.1).fold(0.0, f64::max);
    let mut texels = Vec::new();
    let (mut err_every, mut err_probed) = (Vec::new(), Vec::new());
    for ((e, p), r) in every.iter().zip(&probed).zip(&reference) {
        assert_eq!(e.0, p.0);
        let scale = r.1.max(0.01 * peak);
        texels.push([e.1, p.1, scale]);
        err_every.push((e.1 - r.1).abs() / scale);
        err_probed.push((p.1 - r.1).abs() / scale);
    }
    (texels, err_every, err_probed)
}

/// The opening's probes (`Settings::opening_probe_stride`) on the floor around a table with
/// the grate ([`grate_floor`]) under `lamp`: a texel whose probes all see the opening takes the
/// shares of its rectangles and round ends by their control variate from the probes alone
/// (`luxbake::opening`, "Control variate") and every other part's points as seen. Against
/// 512 samples the error is the exhaustive estimate's (mean at most `mean_ratio` of it, p99.9
/// and the largest at most 1.5×), and what the probes miss (a bar between them) brightens
/// only a few texels (under `few` of them by over 2 % of their light), by at most `sliver`;
/// none is darker by over 2 % (the two estimates differ by the lattices' noise, some 0.1 %,
/// where both see the whole opening).
fn probes_keep_the_penumbrae(lamp: &Arc<Photometry>, mean_ratio: f64, few: f64, sliver: f64) {
    let (texels, err_every, err_probed) = grate_errors(lamp);
    let brighter = texels
        .iter()
        .filter(|t| (t[1] - t[0]) / t[2] > 0.02)
        .count();
    let darker = texels
        .iter()
        .filter(|t| (t[0] - t[1]) / t[2] > 0.02)
        .count();
    let worst_change = texels
        .iter()
        .map(|t| (t[1] - t[0]) / t[2])
        .fold(0.0, f64::max);
    let ((me, pe, xe), (mp, pp, xp)) = (stats(err_every), stats(err_probed));
    println!(
        "{} floor texels, {brighter} brighter and {darker} darker than with every ray by over \
         2 % (at most {:.2} % brighter); against 512 samples: every ray mean {:.3} %, p99.9 \
         {:.2} %, max {:.2} %; probed mean {:.3} %, p99.9 {:.2} %, max {:.2} %",
        texels.len(),
        100.0 * worst_change,
        100.0 * me,
        100.0 * pe,
        100.0 * xe,
        100.0 * mp,
        100.0 * pp,
        100.0 * xp
    );
    assert!(brighter > 0, "the probes missed no bar");
    assert!(
        (brighter as f64) < few * texels.len() as f64 && darker == 0,
        "{brighter} brighter, {darker} darker of {} texels",
        texels.len()
    );
    assert!(worst_change < sliver, "a texel {worst_change} brighter");
    assert!(mp <= mean_ratio * me, "mean {mp} vs {me}");
    assert!(
        pp <= 1.5 * pe && xp <= 1.5 * xe,
        "p99.9 {pp} vs {pe}, max {xp} vs {xe}"
    );
}

/// [`probes_keep_the_penumbrae`] under a linear pendant's rectangle (`rw_5.IES`). Measured:
/// mean 0.441 against every ray's 0.438 % (0.444 % with the probes before the control
/// variate), p99.9 and the largest the same; 27 of 14 336 texels brighter by over 2 %, by at
/// most 9 %.
#[test]
fn opening_probes_keep_the_penumbrae_of_every_ray() {
    let Some(linear) = photometry("opening_probes", "photometry/real-world/rw_5.IES") else {
        return;
    };
    probes_keep_the_penumbrae(&linear, 1.02, 0.01, 0.2);
}

/// [`probes_keep_the_penumbrae`] under a downlight's 0.21 m disk (`rw_2.IES`), whose twelve
/// probes leave wider gaps for the bars than the pendant's narrow rectangle. Measured with the
/// disk's control variate: mean 1.224 against every ray's 1.127 % (the same with its points
/// summed instead), p99.9 and the largest the same; 218 of 14 336 texels brighter by over 2 %,
/// by at most 34.7 % (34.5 % with its points summed).
#[test]
fn opening_probes_keep_the_penumbrae_of_every_ray_under_a_disk() {
    let Some(disk) = photometry("opening_probes_disk", "photometry/real-world/rw_2.IES") else {
        return;
    };
    probes_keep_the_penumbrae(&disk, 1.1, 0.02, 0.4);
}

#[test]
fn a_lamp_baking_its_opening_hands_over_a_point_preview_before_its_direct_light() {
    let test = "opening_preview";
    let Some(linear) = photometry(test, "photometry/real-world/rw_5.IES") else {
        return;
    };
    let downlight = Arc::new(Photometry::parse(DEFAULT_LAMP_IES.as_bytes()).expect("downlight"));
    let lamps = vec![
        Lamp::new("pendant", linear, [0.0, 1.3, 0.0]),
        Lamp::new("downlight", downlight, [1.5, 2.5, 1.2]),
    ];
    let mut scene = dining(lamps, 8.0, 16);
    scene.settings.bounces = 1;
    scene.settings.rays = 4;
    let room = common::prepare(&scene);
    let mut stages = Vec::new();
    let bounce_started = std::cell::Cell::new(false);
    let mut shown = Vec::new();
    let out = luxbake::bake_room_direct_first(
        &mut luxbake_backend_cpu::CpuBackend::new(),
        &room,
        &scene.lamps,
        &scene.settings,
        &mut |p| {
            if let luxbake::Progress::PassStart { bounce, .. } = p {
                bounce_started.set(bounce_started.get() || *bounce >= 1);
            }
        },
        &mut |stage, maps| {
            assert!(!bounce_started.get(), "{stage:?} after a bounce started");
            stages.push(stage);
            shown.push(maps.to_vec());
        },
    )
    .expect("bake");
    assert!(
        out.report.lamp_models[0].area,
        "{}",
        out.report.lamp_models[0]
    );
    assert_eq!(
        stages,
        [luxbake::DirectStage::Preview, luxbake::DirectStage::Direct]
    );
    // The preview is both lamps as points: a bake with every lamp's model `point`, bit for
    // bit; then the bake's own direct light.
    let mut points = scene.clone();
    for l in &mut points.lamps {
        l.model = LampModel::Point;
    }
    points.settings.bounces = 0;
    let point = run(&points);
    assert_finite(&point);
    let mut differs = 0;
    for ((preview, direct), (p, o)) in shown[0]
        .iter()
        .zip(&shown[1])
        .zip(point.maps.iter().zip(&out.maps))
    {
        assert_eq!(preview.illuminance(), p.direct(), "{}", p.name);
        assert_eq!(direct.illuminance(), o.direct(), "{}", o.name);
        differs += usize::from(preview.illuminance() != direct.illuminance());
    }
    // The pendant 0.55 m over the table lights it from its opening: the preview differs.
    assert!(differs > 0, "the preview equals the opening's direct light");
    // Handing the light over changes nothing in the result.
    let plain = run(&scene);
    for (a, b) in plain.maps.iter().zip(&out.maps) {
        assert_eq!(a.illuminance(), b.illuminance(), "{}", a.name);
    }
}
