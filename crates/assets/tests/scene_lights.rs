//! Scene files with file meshes through [`SceneLoader`]: a glTF file's `KHR_lights_punctual`
//! lights become lamps with `lights = true` (moved by the object's transform, optionally with
//! `lights_ies` photometry), bad values give errors naming the key, and a scaled object's
//! generated charts keep their padding in texels. Skipped with a message when
//! `../shared/models` is absent.

mod common;

use common::{check_charts, models_dir};

use std::path::Path;

use luxbake::scene::{Scene, Transform};
use luxbake::sources::scenefile::from_str_with;
use luxbake_assets::uv::{self, UnwrapOptions};
use luxbake_assets::{ImportOptions, Limits, SceneLoader, import};

const LAMP_FILE: &str = "LightsPunctualLamp/LightsPunctualLamp.gltf";

fn loader() -> SceneLoader {
    SceneLoader {
        on_warning: Box::new(|_| {}),
        ..SceneLoader::default()
    }
}

fn scene(dir: &Path, lamp: bool, object: &str) -> Result<Scene, String> {
    let lamp = if lamp {
        "[[lamp]]\nposition = [0, 2.5, 0]\nies = \"isotropic:100\"\n"
    } else {
        ""
    };
    let text =
        format!("[settings]\ntexels_per_metre = 8\nblur = 1.0\n{lamp}[[object]]\n{object}\n");
    from_str_with(&text, dir, None, &loader()).map_err(|e| e.to_string())
}

fn near(a: [f32; 3], b: [f32; 3], tol: f32) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
}

#[test]
fn file_lights_become_lamps_moved_by_the_object() {
    let Some(dir) = models_dir("file_lights_become_lamps_moved_by_the_object") else {
        return;
    };
    let model = import(&dir.join(LAMP_FILE), &ImportOptions::default()).expect("import");
    assert_eq!(model.lights.len(), 5, "the test file has five point lights");
    let object = format!(
        "mesh = \"{LAMP_FILE}\"\nname = \"lamp\"\nposition = [1, 0, 2]\n\
         rotation_deg = [0, 90, 0]\nscale = 2\nlights = true"
    );
    let t = Transform::from_trs([1.0, 0.0, 2.0], [0.0, 90.0, 0.0], [2.0; 3]);

    let s = scene(&dir, false, &object).expect("loads");
    assert_eq!(s.lamps.len(), 5, "no [[lamp]]: the file's five lights");
    for (lamp, light) in s.lamps.iter().zip(&model.lights) {
        let want = t.point(light.position);
        assert!(
            near(lamp.position.map(|c| c as f32), want, 1e-4),
            "{:?} vs {want:?}",
            lamp.position
        );
        assert_ne!(
            lamp.position,
            light.position.map(f64::from),
            "moved by the transform"
        );
        let len = lamp.aim.iter().map(|c| c * c).sum::<f32>().sqrt();
        assert!((len - 1.0).abs() < 1e-5, "aim normalised: {:?}", lamp.aim);
        // The file's own photometry: the light's intensity on the axis.
        let (cd, _) = lamp.photometry.max_intensity();
        let want = f64::from(light.intensity_cd);
        assert!((cd - want).abs() <= 1e-3 * want.max(1.0), "{cd} vs {want}");
        assert_eq!(lamp.color, light.color);
        assert!(lamp.name.starts_with("lamp/"), "{}", lamp.name);
    }

    let off = scene(&dir, true, &format!("mesh = \"{LAMP_FILE}\"")).expect("loads");
    assert_eq!(off.lamps.len(), 1, "lights default to off");

    let iso = format!("{object}\nlights_ies = \"isotropic:100\"\nlights_multiplier = 0.5");
    let s = scene(&dir, true, &iso).expect("loads");
    assert_eq!(s.lamps.len(), 6, "one [[lamp]] and five file lights");
    for lamp in &s.lamps[1..] {
        assert_eq!(lamp.photometry.max_intensity().0, 100.0);
        assert_eq!(lamp.photometry.intensity([1.0, 0.0, 0.0]), 100.0);
        assert_eq!(lamp.multiplier, 0.5);
    }
}

#[test]
fn bad_light_keys_give_errors_naming_them() {
    let Some(dir) = models_dir("bad_light_keys_give_errors_naming_them") else {
        return;
    };
    for (extra, key) in [
        ("lights = 3", "lights"),
        (
            "lights = true\nlights_ies = \"no-such-file.ies\"",
            "object[0].lights_ies",
        ),
        (
            "lights = true\nlights_ies = \"isotropic:x\"",
            "object[0].lights_ies",
        ),
        (
            "lights = true\nlights_multiplier = -2",
            "object[0].lights_multiplier",
        ),
        ("lights_ies = \"isotropic:1\"", "object[0].lights_ies"),
    ] {
        let r = scene(&dir, true, &format!("mesh = \"{LAMP_FILE}\"\n{extra}"));
        let e = r.expect_err(extra);
        assert!(e.contains(key), "{extra}: {e}");
    }
    // A file without lights.
    let r = scene(
        &dir,
        true,
        "mesh = \"CornellBox/CornellBox-Original.obj\"\nlights = true",
    );
    let e = r.expect_err("no lights");
    assert!(
        e.contains("object[0].lights") && e.contains("no lights"),
        "{e}"
    );
}

#[test]
fn scaled_objects_keep_their_chart_padding_in_texels() {
    let Some(dir) = models_dir("scaled_objects_keep_their_chart_padding_in_texels") else {
        return;
    };
    let s = scene(
        &dir,
        true,
        "mesh = \"CornellBox/CornellBox-Original.obj\"\nscale = 0.4",
    )
    .expect("loads");
    let pad = uv::padding_texels(s.settings.blur);
    let d = s.settings.texels_per_metre;
    let mut checked = 0;
    for o in &s.objects {
        check_charts("", o, d, pad);
        checked += 1;
    }
    assert!(checked >= 2);
    // The same file unscaled would be unwrapped differently: the scale reached the loader.
    let unscaled = ImportOptions {
        limits: Limits::default(),
        unwrap: UnwrapOptions {
            texels_per_metre: d,
            padding_texels: pad,
            scale: [1.0; 3],
        },
    };
    let plain = import(&dir.join("CornellBox/CornellBox-Original.obj"), &unscaled).expect("import");
    assert!(
        plain
            .parts
            .iter()
            .zip(&s.objects)
            .any(|(p, o)| p.mesh.lightmap_uvs != o.mesh.lightmap_uvs)
    );
}
