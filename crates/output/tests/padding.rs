//! Chart padding and dilation (issue 14, item 2): the written light maps are dilated into
//! their padding, and the padding rule keeps the method paper's blur from carrying light from
//! one chart of an object into another.

mod common;

use common::{run, temp_dir};

use luxbake::bake::BakeOutput;
use luxbake::layout::chart_padding_texels;
use luxbake::map::MapImage;
use luxbake::scene::{Albedo, Mesh, Object, Scene, Settings, Transform};
use luxbake::sources::builtin::{self, isotropic_lamp};
use luxbake::sources::meshes;
use luxbake_output::{dilation_passes, read_exr, write_bake};

/// Checks that `written` is `baked` dilated by `passes`: same alpha, same valid texels, and
/// every empty texel within `passes` texels (Chebyshev) of a valid one holds the RGB of a
/// valid texel at the least such distance. Returns how many padding texels were checked.
fn assert_dilated(baked: &MapImage, written: &MapImage, passes: u32, what: &str) -> usize {
    assert_eq!((written.width, written.height), (baked.width, baked.height));
    let (w, h) = (i64::from(baked.width), i64::from(baked.height));
    let mut checked = 0;
    for y in 0..h {
        for x in 0..w {
            let (b, t) = (
                baked.texel(x as u32, y as u32),
                written.texel(x as u32, y as u32),
            );
            assert_eq!(b[3], t[3], "{what} ({x}, {y}): alpha is the mask");
            if b[3] > 0.5 {
                assert_eq!(b, t, "{what} ({x}, {y}): a baked texel is kept");
                continue;
            }
            // The valid texels at the least Chebyshev distance `r` ≤ passes.
            let near = (1..=i64::from(passes)).find_map(|r| {
                let ring: Vec<[f32; 4]> = (-r..=r)
                    .flat_map(|dy| (-r..=r).map(move |dx| (dx, dy)))
                    .filter(|&(dx, dy)| dx.abs().max(dy.abs()) == r)
                    .map(|(dx, dy)| (x + dx, y + dy))
                    .filter(|&(nx, ny)| nx >= 0 && ny >= 0 && nx < w && ny < h)
                    .map(|(nx, ny)| baked.texel(nx as u32, ny as u32))
                    .filter(|n| n[3] > 0.5)
                    .collect();
                (!ring.is_empty()).then_some(ring)
            });
            match near {
                Some(ring) => {
                    assert!(
                        ring.iter().any(|n| n[..3] == t[..3]),
                        "{what} ({x}, {y}): padding texel {t:?} holds no nearest valid value"
                    );
                    checked += 1;
                }
                None => assert_eq!(t, b, "{what} ({x}, {y}): beyond the padding"),
            }
        }
    }
    checked
}

/// Every written EXR of a bake holds its baked texels, keeps the mask in alpha, and has each
/// padding texel filled with the value of a nearest valid texel.
#[test]
fn written_maps_are_dilated_into_their_padding() {
    let settings = Settings {
        rays: 2,
        bounces: 1,
        texels_per_metre: 12.0,
        ..Settings::paper()
    };
    let scene = Scene::builtin_with_settings("chairs_01", settings).expect("chairs_01");
    let out = run(&scene);
    let dir = temp_dir("pad", "dilated");
    let manifest = write_bake(&dir, &scene, &out, "builtin:chairs_01").expect("write");
    let passes = dilation_passes(&scene.settings);
    assert_eq!(passes, 8, "σ 2: 2 + ⌈3σ⌉ texels of padding");
    let mut checked = 0;
    for entry in manifest["objects"].as_array().expect("objects") {
        let i = entry["index"].as_u64().expect("index") as usize;
        let maps = out.maps.iter().find(|m| m.object == i).expect("maps");
        let files = &entry["files"];
        for (key, baked) in [
            ("illuminance", maps.illuminance()),
            ("exitance", maps.exitance()),
            ("direct", maps.direct()),
        ] {
            let name = files[key].as_str().expect("file");
            let written = read_exr(&dir.join(name)).expect("read back");
            checked += assert_dilated(baked, &written, passes, name);
        }
    }
    eprintln!("{checked} padding texels checked");
    assert!(checked > 1000, "only {checked} padding texels checked");
    std::fs::remove_dir_all(&dir).ok();
}

/// Two 1 m × 1 m up-facing charts of one object, side by side in the light map `padding`
/// texels apart (at 64 texels per metre): chart A under an isotropic lamp, chart B 3 m away
/// under a black non-receiving board (facing down) that hides the lamp. Nothing reaches B — direct light is
/// blocked, the board reflects nothing and A is coplanar — so its exact illuminance is 0.
fn two_charts(padding: f32, settings: Settings) -> Scene {
    let p = f64::from(padding / settings.texels_per_metre);
    let (width, height) = (2.0 + 2.0 * p, 1.0 + p);
    let quad = |x0: f32, u0: f64| {
        let corners = [[x0, 0.5], [x0 + 1.0, 0.5], [x0 + 1.0, -0.5], [x0, -0.5]];
        let uv = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]]
            .map(|[a, b]: [f64; 2]| [((u0 + a) / width) as f32, ((p / 2.0 + b) / height) as f32]);
        (corners.map(|[x, z]| [x, 0.0, z]), uv)
    };
    let (a, a_uv) = quad(-0.5, p / 2.0);
    let (b, b_uv) = quad(3.0, p / 2.0 + 1.0 + p);
    let mesh = Mesh {
        positions: [a, b].concat(),
        normals: vec![[0.0, 1.0, 0.0]; 8],
        lightmap_uvs: [a_uv, b_uv].concat(),
        material_uvs: None,
        colors: None,
        indices: vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]],
    };
    let board = Object {
        name: "board".into(),
        mesh: meshes::plane([3.0, 2.0], 0.1),
        // Facing down, so B sees its front (a texel that sees mostly back faces is made
        // invalid: luxbake::validity).
        transform: Transform::from_trs([3.5, 0.5, 0.0], [180.0, 0.0, 0.0], [1.0; 3]),
        albedo: Albedo::grey(0.0),
        receiver: false,
        texel_scale: 1.0,
    };
    Scene {
        objects: vec![
            Object {
                name: "pair".into(),
                mesh,
                transform: Transform::IDENTITY,
                albedo: Albedo::grey(0.5),
                receiver: true,
                texel_scale: 1.0,
            },
            board,
        ],
        lamps: vec![isotropic_lamp(1000.0, [0.0, 2.0, 0.0])],
        settings,
    }
}

/// The largest illuminance on chart B (the right half of the map) and the number of valid
/// texels there.
fn chart_b(out: &BakeOutput) -> (f32, usize) {
    let m = out.maps[0].illuminance();
    let mut most = 0.0f32;
    let mut n = 0;
    for y in 0..m.height {
        for x in m.width / 2..m.width {
            let t = m.texel(x, y);
            if t[3] > 0.5 {
                most = most.max(t[0]).max(t[1]).max(t[2]);
                n += 1;
            }
        }
    }
    (most, n)
}

/// The method paper's σ 2 blur masks taps by object and normal only: with the old 4-texel
/// padding it carries A's light onto B; with [`chart_padding_texels`] nothing crosses.
#[test]
fn paper_blur_moves_no_light_between_charts_of_one_object() {
    let settings = Settings {
        rays: 4,
        bounces: 1,
        ..Settings::paper()
    };
    let padding = chart_padding_texels(settings.blur);
    assert_eq!(padding, 8.0);
    assert_eq!(
        builtin::padding_m(&settings, 1.0),
        padding / settings.texels_per_metre
    );
    let ok = run(&two_charts(padding, settings.clone()));
    let (lit, texels) = chart_b(&ok);
    assert!(texels > 3000, "{texels} texels on B");
    assert_eq!(lit, 0.0, "light crossed {padding} texels of padding");
    // A is lit (E ≈ 1000 cd · 2 m / d³ ≥ 150 lx); the control shows the test can fail.
    let a = ok.maps[0]
        .illuminance()
        .texel(ok.maps[0].region.size[0] / 4, 32);
    assert!(a[0] > 100.0, "{a:?}");
    let leaky = run(&two_charts(4.0, settings));
    let (leaked, _) = chart_b(&leaky);
    eprintln!(
        "B: {lit} lx at {padding} texels, up to {leaked} lx at 4; A {:.1} lx",
        a[0]
    );
    assert!(leaked > 1.0, "4 texels: {leaked} lx on B");
}
