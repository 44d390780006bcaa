//! Test 5: the same seed gives bit-identical EXR files; another seed changes the noise, and so
//! does the other gather sampler. Also checks the file set and manifest keys that
//! `cargo xtask bake` writes.

mod common;

use common::{run, temp_dir};

use std::path::Path;

use luxbake::scene::{Blur, Sampler, Scene, Settings};
use luxbake_output::write_bake;

fn scene(seed: u32) -> Scene {
    scene_with(seed, Sampler::default())
}

fn scene_with(seed: u32, sampler: Sampler) -> Scene {
    Scene::builtin_with_settings(
        "chairs_01",
        Settings {
            rays: 8,
            bounces: 2,
            blur: Blur::Sigma(1.5),
            texels_per_metre: 6.0,
            seed,
            sampler,
            ..Settings::default()
        },
    )
    .expect("chairs_01")
}

fn exr_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .expect("read dir")
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "exr"))
        .map(|p| {
            let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
            (name.unwrap_or_default(), std::fs::read(&p).expect("read"))
        })
        .collect();
    files.sort();
    files
}

#[test]
fn same_seed_gives_identical_exr_bytes() {
    let s = scene(7);
    let (a, b) = (run(&s), run(&s));
    let (da, db) = (temp_dir("det", "a"), temp_dir("det", "b"));
    let manifest = write_bake(&da, &s, &a, "builtin:chairs_01").expect("write a");
    write_bake(&db, &s, &b, "builtin:chairs_01").expect("write b");
    let (fa, fb) = (exr_files(&da), exr_files(&db));
    assert_eq!(fa.len(), 3 * a.maps.len(), "three EXRs per receiver");
    assert!(
        fa == fb,
        "EXR bytes differ between two bakes with the same seed"
    );

    // Every object's files exist; the manifest has the keys the issue lists.
    let objects = manifest["objects"].as_array().expect("objects");
    assert_eq!(objects.len(), s.objects.len());
    for o in objects {
        for key in [
            "layer",
            "offset",
            "size",
            "resolution",
            "transform",
            "files",
        ] {
            assert!(!o[key].is_null(), "object {} lacks {key}", o["name"]);
        }
        for f in o["files"].as_object().expect("files").values() {
            let f = f.as_str().expect("file name");
            assert!(da.join(f).exists(), "{f} missing");
        }
    }
    for key in [
        "settings", "lamps", "timings", "skipped", "stats", "layout", "scene",
    ] {
        assert!(!manifest[key].is_null(), "manifest lacks {key}");
    }
    assert_eq!(manifest["settings"]["rays"], 8);
    assert_eq!(manifest["settings"]["sampler"], "hash");
    assert!(da.join("manifest.json").exists());

    // A different seed changes the gathered noise (and nothing is NaN).
    let c = run(&scene(8));
    let differs = a
        .maps
        .iter()
        .zip(&c.maps)
        .any(|(x, y)| x.illuminance().texels != y.illuminance().texels);
    assert!(differs, "the seed must drive the gather");
    for d in [da, db] {
        std::fs::remove_dir_all(d).ok();
    }
}

#[test]
fn the_sobol_sampler_is_deterministic_and_only_changes_the_gather() {
    let hash = run(&scene(7));
    let s = scene_with(7, Sampler::Sobol);
    let (a, b) = (run(&s), run(&s));
    assert_eq!(a.maps, b.maps, "two Sobol bakes with the same seed differ");
    for (h, x) in hash.maps.iter().zip(&a.maps) {
        // Stages (1)-(4) come before any gather; (5)-(8) depend on the gathered rays.
        assert_eq!(h.stages[..4], x.stages[..4], "{}", h.name);
        let texels = |m: &Option<luxbake::map::MapImage>| m.as_ref().map(|i| i.texels.clone());
        assert_ne!(texels(&h.stages[4]), texels(&x.stages[4]), "{}", h.name);
        let finite = |m: &Option<luxbake::map::MapImage>| {
            m.as_ref()
                .is_some_and(|i| i.texels.iter().all(|v| v.is_finite() && *v >= 0.0))
        };
        assert!(x.stages[4..].iter().all(finite), "{}", h.name);
    }
}
