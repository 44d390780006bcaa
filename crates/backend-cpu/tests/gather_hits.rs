//! Gather hits kept across bakes (`CpuBackend::keep_gather_hits`, `luxbake::cpu::hits`): a
//! room baked again under another lamp replays its gather rays' hits, and every map is the
//! one a fresh backend bakes, bit for bit.

use luxbake::bake::{BakeOutput, Room, bake_room};
use luxbake::scene::{Lamp, Quality, Scene, Settings};
use luxbake_backend_cpu::CpuBackend;
use luxbake_ies::Photometry;
use std::sync::Arc;

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

/// Every stage of every object, bit for bit.
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

fn fresh(scene: &Scene, lamps: &[Lamp]) -> BakeOutput {
    let mut backend = CpuBackend::new();
    let room = Room::prepare(
        scene,
        &scene.settings,
        backend_limits(&backend),
        &mut |_| {},
    )
    .expect("room");
    bake_room(&mut backend, &room, lamps, &scene.settings, &mut |_| {}).expect("bake")
}

fn backend_limits(b: &CpuBackend) -> luxbake::backend::Limits {
    luxbake::GpuBackend::limits(b)
}

/// A backend that keeps gather hits, `scene`'s room prepared for it and baked once (what it
/// recorded: the stats).
fn baked_once(scene: &Scene) -> (CpuBackend, Room, BakeOutput, luxbake::cpu::GatherHitStats) {
    let settings = &scene.settings;
    let mut backend = CpuBackend::new();
    backend.keep_gather_hits(luxbake_backend_cpu::GATHER_HITS_BUDGET);
    let room = Room::prepare(scene, settings, backend_limits(&backend), &mut |_| {}).expect("room");
    let first = bake_room(&mut backend, &room, &scene.lamps, settings, &mut |_| {}).expect("bake");
    let recorded = backend.gather_hit_stats().expect("kept");
    (backend, room, first, recorded)
}

#[test]
fn a_swap_replays_the_first_bakes_gather_hits_and_bakes_the_same_maps() {
    let scene = scene(16.0);
    let settings = &scene.settings;
    let (mut backend, room, first, recorded) = baked_once(&scene);
    assert_eq!(recorded.replayed, 0);
    assert!(recorded.traced > 0);
    assert_eq!(
        recorded.bytes,
        recorded.traced as usize * luxbake::cpu::hits::HIT_BYTES
    );

    let other = other_lamp();
    let swapped = bake_room(&mut backend, &room, &other, settings, &mut |_| {}).expect("swap");
    let after = backend.gather_hit_stats().expect("kept");
    let replayed = after.replayed;
    let traced = after.traced - recorded.traced;
    println!(
        "first bake: {} rays traced and recorded ({} bytes); swap: {replayed} replayed, {traced} \
         traced; bounces {} then {}",
        recorded.traced, recorded.bytes, first.report.bounces_run, swapped.report.bounces_run
    );
    // Every bounce the first bake ran is replayed; only bounces past its last are traced.
    assert!(replayed > 0);
    if swapped.report.bounces_run <= first.report.bounces_run {
        assert_eq!(traced, 0);
    }

    let n = assert_same(&first, &fresh(&scene, &scene.lamps), "first bake");
    let m = assert_same(&swapped, &fresh(&scene, &other), "swap");
    println!("{n} and {m} floats equal to fresh bakes'");
}

#[test]
fn another_room_traces_its_own_rays_and_a_zero_budget_records_nothing() {
    let (a, b) = (scene(16.0), scene(12.0));
    let mut backend = CpuBackend::new();
    backend.keep_gather_hits(luxbake_backend_cpu::GATHER_HITS_BUDGET);
    for s in [&a, &b] {
        let room =
            Room::prepare(s, &s.settings, backend_limits(&backend), &mut |_| {}).expect("room");
        let before = backend.gather_hit_stats().expect("kept");
        let out = bake_room(&mut backend, &room, &s.lamps, &s.settings, &mut |_| {}).expect("bake");
        let after = backend.gather_hit_stats().expect("kept");
        // A room prepared anew has a BVH of its own: nothing to replay.
        assert_eq!(after.replayed, before.replayed);
        assert!(after.traced > before.traced);
        // The room before was dropped: its rows went at this bake's upload.
        assert_eq!(
            after.bytes,
            (after.traced - before.traced) as usize * luxbake::cpu::hits::HIT_BYTES
        );
        assert_same(&out, &fresh(s, &s.lamps), "another room");
    }
    let mut none = CpuBackend::new();
    none.keep_gather_hits(0);
    let room = Room::prepare(&a, &a.settings, backend_limits(&none), &mut |_| {}).expect("room");
    for _ in 0..2 {
        let out = bake_room(&mut none, &room, &a.lamps, &a.settings, &mut |_| {}).expect("bake");
        assert_same(&out, &fresh(&a, &a.lamps), "zero budget");
    }
    let stats = none.gather_hit_stats().expect("kept");
    assert_eq!((stats.replayed, stats.bytes), (0, 0));
    assert!(stats.traced > 0);
}

/// The same BVH under a changed G-buffer (a clone of the room with some texels moved): the
/// rows whose rays start elsewhere are traced again, the others replayed, and the maps are
/// those of a fresh backend.
#[test]
fn rows_whose_texels_moved_are_traced_again() {
    let scene = scene(16.0);
    let settings = &scene.settings;
    let (mut backend, room, _, recorded) = baked_once(&scene);

    // Every 50th valid texel 1 mm higher: its rays start elsewhere.
    let mut moved = room.clone();
    let g = &mut moved.gbuffer;
    let mut count = 0;
    let valid: Vec<usize> = (0..g.position.len() / 4)
        .filter(|&i| g.position[4 * i + 3] > 0.5)
        .collect();
    for &i in valid.iter().step_by(50) {
        g.position[4 * i + 1] += 1e-3;
        count += 1;
    }
    assert!(count > 100);
    let out = bake_room(&mut backend, &moved, &scene.lamps, settings, &mut |_| {}).expect("bake");
    let after = backend.gather_hit_stats().expect("kept");
    let (replayed, traced) = (after.replayed, after.traced - recorded.traced);
    println!("{count} texels moved: {replayed} rays replayed, {traced} traced");
    assert!(replayed > 0 && traced > 0);

    let mut plain = CpuBackend::new();
    let want = bake_room(&mut plain, &moved, &scene.lamps, settings, &mut |_| {}).expect("bake");
    assert_same(&out, &want, "moved texels");
}
