//! Gather hits kept across bakes on the GPU (`GlowBackend::keep_gather_hits`): a room baked
//! again under another lamp reads its gather rays' hits from the textures the first bake's
//! trace passes wrote, and every map is the one a fresh backend bakes (which traces in the
//! gather), bit for bit.

mod common;

use std::sync::Arc;

use luxbake::GpuBackend;
use luxbake::bake::{BakeOutput, Room, bake_room};
use luxbake::scene::{Lamp, Quality, Scene, Settings};
use luxbake_backend_glow::{GlowBackend, HIT_BYTES};
use luxbake_ies::Photometry;

fn scene(texels_per_metre: f32) -> Scene {
    let settings = Settings {
        texels_per_metre,
        ..Settings::preset(Quality::Default)
    };
    Scene::builtin_with_settings("chairs_01", settings).expect("scene")
}

/// A lamp unlike the scene's downlight: isotropic, off centre, lower.
fn other_lamp() -> Vec<Lamp> {
    vec![Lamp::new(
        "bulb",
        Arc::new(Photometry::isotropic(300.0)),
        [0.8, 1.6, -0.4],
    )]
}

/// Every stage of every object, bit for bit; the floats compared.
fn assert_same(a: &BakeOutput, b: &BakeOutput, what: &str) -> usize {
    assert_eq!(a.maps.len(), b.maps.len(), "{what}");
    let mut floats = 0;
    for (ma, mb) in a.maps.iter().zip(&b.maps) {
        for (sa, sb) in ma.stages.iter().zip(&mb.stages) {
            assert_eq!(sa.is_some(), sb.is_some(), "{what}: {}", ma.name);
            if let (Some(sa), Some(sb)) = (sa, sb) {
                let bits = |m: &luxbake::map::MapImage| -> Vec<u32> {
                    m.texels.iter().map(|v| v.to_bits()).collect()
                };
                assert!(bits(sa) == bits(sb), "{what}: {} differs", ma.name);
                floats += sa.texels.len();
            }
        }
    }
    assert!(floats > 0, "{what}: nothing compared");
    floats
}

fn bake(backend: &mut GlowBackend, scene: &Scene, lamps: &[Lamp]) -> BakeOutput {
    let room = Room::prepare(scene, &scene.settings, backend.limits(), &mut |_| {}).expect("room");
    bake_room(backend, &room, lamps, &scene.settings, &mut |_| {}).expect("bake")
}

#[test]
fn a_swap_reads_the_first_bakes_gather_hits_and_bakes_the_same_maps() {
    let Some(mut backend) = common::backend_or_skip("glow gather hits") else {
        return;
    };
    let scene = scene(16.0);
    let settings = &scene.settings;
    backend.keep_gather_hits(1 << 30).expect("keep");
    let room = Room::prepare(&scene, settings, backend.limits(), &mut |_| {}).expect("room");
    let first = bake_room(&mut backend, &room, &scene.lamps, settings, &mut |_| {}).expect("bake");
    let recorded = backend.gather_hit_stats().expect("kept");
    // Every gather dispatch of the first bake traced its rays, kept them and read them.
    assert!(recorded.traced > 0);
    assert_eq!(recorded.replayed, recorded.traced);
    assert_eq!(recorded.dispatches as u64, recorded.traced);
    assert_eq!(recorded.bytes % HIT_BYTES, 0);

    let other = other_lamp();
    let swapped = bake_room(&mut backend, &room, &other, settings, &mut |_| {}).expect("swap");
    let after = backend.gather_hit_stats().expect("kept");
    let (replayed, traced) = (
        after.replayed - recorded.replayed,
        after.traced - recorded.traced,
    );
    println!(
        "first bake: {} gather dispatches traced and kept ({} bytes); swap: {replayed} read \
         kept hits, {traced} traced; bounces {} then {}",
        recorded.traced, recorded.bytes, first.report.bounces_run, swapped.report.bounces_run
    );
    assert!(replayed > 0);
    if swapped.report.bounces_run <= first.report.bounces_run {
        assert_eq!(traced, 0, "every bounce the first bake ran is read back");
    }

    let Some(mut plain) = common::backend_or_skip("glow gather hits") else {
        return;
    };
    let n = assert_same(
        &first,
        &bake(&mut plain, &scene, &scene.lamps),
        "first bake",
    );
    let m = assert_same(&swapped, &bake(&mut plain, &scene, &other), "swap");
    println!("{n} and {m} floats equal to a tracing backend's");

    // The room dropped, its hits can be freed at once.
    backend.free_dropped_hits().expect("free");
    assert_eq!(backend.gather_hit_stats().expect("kept").bytes, after.bytes);
    drop(room);
    backend.free_dropped_hits().expect("free");
    let freed = backend.gather_hit_stats().expect("kept");
    assert_eq!((freed.bytes, freed.dispatches), (0, 0));
}

#[test]
fn another_room_traces_its_own_rays_and_a_small_budget_keeps_nothing() {
    let Some(mut backend) = common::backend_or_skip("glow gather hits") else {
        return;
    };
    let Some(mut plain) = common::backend_or_skip("glow gather hits") else {
        return;
    };
    let (a, b) = (scene(12.0), scene(8.0));
    backend.keep_gather_hits(1 << 30).expect("keep");
    for s in [&a, &b] {
        let before = backend.gather_hit_stats().expect("kept");
        let out = bake(&mut backend, s, &s.lamps);
        let after = backend.gather_hit_stats().expect("kept");
        // A room prepared anew has a BVH of its own: nothing to read back; the room before
        // was dropped, so its hits went at this bake's upload.
        assert_eq!(
            after.replayed - before.replayed,
            after.traced - before.traced
        );
        assert!(after.traced > before.traced);
        assert_eq!(after.dispatches as u64, after.traced - before.traced);
        assert_same(&out, &bake(&mut plain, s, &s.lamps), "another room");
    }
    backend.keep_gather_hits(HIT_BYTES).expect("keep");
    let room = Room::prepare(&a, &a.settings, backend.limits(), &mut |_| {}).expect("room");
    for _ in 0..2 {
        let out = bake_room(&mut backend, &room, &a.lamps, &a.settings, &mut |_| {}).expect("bake");
        assert_same(&out, &bake(&mut plain, &a, &a.lamps), "small budget");
    }
    let stats = backend.gather_hit_stats().expect("kept");
    assert_eq!(
        (stats.traced, stats.replayed, stats.bytes, stats.dispatches),
        (0, 0, 0, 0)
    );
}

/// Six rays a texel in the first bounce and three in the later ones: the trace pass's draws
/// of four rays end with a draw of two (and of three), whose unused colour outputs go nowhere.
#[test]
fn rays_that_fill_no_whole_draw_are_kept_and_read_back_alike() {
    let Some(mut backend) = common::backend_or_skip("glow gather hits") else {
        return;
    };
    let Some(mut plain) = common::backend_or_skip("glow gather hits") else {
        return;
    };
    let mut scene = scene(8.0);
    scene.settings.rays = 6;
    scene.settings.higher_rays = 3;
    backend.keep_gather_hits(1 << 30).expect("keep");
    let room = Room::prepare(&scene, &scene.settings, backend.limits(), &mut |_| {}).expect("room");
    let other = other_lamp();
    for lamps in [&scene.lamps, &other] {
        let out =
            bake_room(&mut backend, &room, lamps, &scene.settings, &mut |_| {}).expect("bake");
        assert_same(&out, &bake(&mut plain, &scene, lamps), "six and three rays");
    }
    let stats = backend.gather_hit_stats().expect("kept");
    assert!(
        stats.traced > 0 && stats.replayed > stats.traced,
        "{stats:?}"
    );
}
