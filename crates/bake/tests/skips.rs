//! "Model only what the scene requires": lamps that reach nothing, negligible bounces,
//! non-receivers and tiny scenes are skipped, reported, and change nothing in the result.

mod common;

use common::run;

use std::sync::Arc;

use luxbake::bake::Skipped;
use luxbake::scene::{Blur, BvhMode, Lamp, Scene, Settings};
use luxbake_ies::Photometry;

fn floor(bounces: u32) -> Scene {
    Scene::builtin_with_settings(
        "floor",
        Settings {
            rays: 4,
            bounces,
            blur: Blur::None,
            texels_per_metre: 4.0,
            ..Settings::default()
        },
    )
    .expect("floor")
}

#[test]
fn lamps_that_reach_nothing_are_left_out() {
    let mut scene = floor(0);
    let reference = run(&scene);
    // Below the floor (behind it), and a dark lamp above it.
    let below = Lamp::new(
        "below",
        Arc::new(Photometry::isotropic(500.0)),
        [0.0, -1.0, 0.0],
    );
    let mut dark = Lamp::new(
        "dark",
        Arc::new(Photometry::isotropic(500.0)),
        [1.0, 1.0, 0.0],
    );
    dark.multiplier = 0.0;
    scene.lamps.push(below);
    scene.lamps.push(dark);
    let out = run(&scene);
    assert_eq!(out.lamps_used, vec![0]);
    for (i, name) in [(1, "below"), (2, "dark")] {
        assert!(
            out.report.skipped.contains(&Skipped::Lamp {
                lamp: i,
                name: name.into()
            }),
            "{:?}",
            out.report.skipped
        );
    }
    // The result is the one-lamp result, bit for bit.
    assert_eq!(out.maps[0].illuminance(), reference.maps[0].illuminance());
}

#[test]
fn tiny_scenes_use_brute_force_and_non_receivers_get_no_map() {
    let mut scene = floor(0);
    let out = run(&scene);
    assert_eq!(out.report.bvh, BvhMode::None);
    assert!(out.report.skipped.iter().any(|s| matches!(
        s,
        Skipped::Bvh {
            requested: BvhMode::Wide,
            triangles: 2
        }
    )));
    scene.objects[0].receiver = false;
    let out = run(&scene);
    assert!(out.maps.is_empty());
    assert!(
        out.report
            .skipped
            .iter()
            .any(|s| matches!(s, Skipped::NonReceiver { object: 0, .. }))
    );
}

#[test]
fn negligible_bounces_stop_early() {
    // The floor alone reflects nothing back onto itself: bounce 1 adds nothing, 2..=4 are
    // skipped.
    let out = run(&floor(4));
    assert_eq!(out.report.bounces_run, 1);
    assert!(
        out.report
            .skipped
            .iter()
            .any(|s| matches!(s, Skipped::Bounces { from: 2, to: 4, .. }))
    );
    let ind = out.maps[0].indirect().expect("indirect");
    assert!(ind.valid_rgb().all(|c| c == [0.0; 3]));
}
