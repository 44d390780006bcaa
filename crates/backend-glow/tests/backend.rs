//! The glow backend through the `GpuBackend` interface: tiling and progress, zero-filled
//! textures, upload/read-back round trips, limits and misuse errors.

mod common;

use common::backend_or_skip;
use luxbake::backend::GpuBackend;
use luxbake::bake::{Progress, Room, bake, bake_room};
use luxbake::graph::{PassKind, TexDesc, TexFormat};
use luxbake::program::{Params, Program as Pass, RowKind, TilePlan, coarse};
use luxbake::scene::{Blur, Quality, Scene, Settings};
use luxbake::validity;
use luxbake_backend_glow::{GlowError, webgl2};

fn desc(size: [u32; 2], layers: u32) -> TexDesc {
    TexDesc {
        label: "test",
        size,
        layers,
        format: TexFormat::Rgba32F,
    }
}

#[test]
fn tiles_report_progress_and_do_not_change_the_result() {
    let test = "tiles_report_progress_and_do_not_change_the_result";
    let (Some(whole), Some(tiled)) = (backend_or_skip(test), backend_or_skip(test)) else {
        return;
    };
    let settings = Settings {
        rays: 8,
        bounces: 1,
        blur: Blur::Sigma(1.5),
        texels_per_metre: 8.0,
        ..Settings::default()
    };
    let scene = Scene::builtin_with_settings("chairs_01", settings.clone()).expect("chairs_01");
    let mut runs = Vec::new();
    for (backend, work) in [(whole, u64::MAX), (tiled, 2_000)] {
        let mut backend = backend.with_tile_work(work);
        let mut events: Vec<(usize, f32)> = Vec::new();
        let out = bake(&mut backend, &scene, &settings, &mut |p| {
            if let Progress::PassProgress { index, fraction } = p {
                events.push((*index, *fraction));
            }
        })
        .expect("glow bake");
        runs.push((out, events));
    }
    let (whole_out, whole_events) = &runs[0];
    let (tiled_out, tiled_events) = &runs[1];
    // Every computed pass ends at 1.0 with fractions increasing; tiny tiles give many reports.
    for events in [whole_events, tiled_events] {
        for w in events.windows(2) {
            if w[0].0 == w[1].0 {
                assert!(w[1].1 > w[0].1, "{w:?}");
            }
        }
    }
    let gather = whole_out
        .graph
        .passes
        .iter()
        .position(|p| p.label == "gather")
        .expect("a gather pass");
    let count = |events: &[(usize, f32)]| events.iter().filter(|e| e.0 == gather).count();
    assert!(
        count(tiled_events) > 10 * count(whole_events).max(1),
        "{tiled_events:?}"
    );
    assert_eq!(
        tiled_events
            .iter()
            .rev()
            .find(|e| e.0 == gather)
            .map(|e| e.1),
        Some(1.0)
    );
    // The RNG is stateless: tiling changes nothing, bit for bit.
    for (a, b) in whole_out.maps.iter().zip(&tiled_out.maps) {
        assert_eq!(a.stages, b.stages, "{}", a.name);
    }
}

/// The converged default's strided gathers (every fourth texel per axis, on a compact grid,
/// then the rest of the tile: `coarse::grid_tile`) in tiles of a row or two, many of which
/// hold no grid row, and with kept hits read back in a second bake: the maps of one tile per
/// layer, bit for bit.
#[test]
fn strided_gathers_in_small_tiles_and_from_kept_hits_do_not_change_the_result() {
    let test = "strided_gathers_in_small_tiles_and_from_kept_hits_do_not_change_the_result";
    let (Some(whole), Some(tiled)) = (backend_or_skip(test), backend_or_skip(test)) else {
        return;
    };
    let settings = Settings {
        texels_per_metre: 10.0,
        ..Settings::preset(Quality::Default)
    };
    assert!(settings.higher_stride > 1);
    let scene = Scene::builtin_with_settings("chairs_01", settings.clone()).expect("chairs_01");
    let mut whole = whole.with_tile_work(u64::MAX);
    whole.keep_gather_hits(1 << 30).expect("keep hits");
    let want = bake(&mut whole, &scene, &settings, &mut |_| {}).expect("glow bake");
    let mut tiled = tiled.with_tile_work(2_000);
    tiled.keep_gather_hits(1 << 30).expect("keep hits");
    let room = Room::prepare(&scene, &settings, tiled.limits(), &mut |_| {}).expect("room");
    // One tile per layer, cut around long runs of rows without a valid texel, which keep no
    // hits, and for a strided gather also around those without a narrow texel
    // (`TilePlan::tiles_by_kind`): a gather at stride 1 keeps one part a piece, a strided one
    // its compact grid's where the piece holds grid rows and the rest's (the orphans' alone
    // where it holds no narrow texel).
    let (size, layers) = (want.layout.layer_size, want.layout.layers);
    let kinds = validity::row_kinds(&room.gbuffer.position, size[0]);
    let plan = TilePlan::new(size, layers, 1, u64::MAX);
    let pieces = plan.gather_tiles(&kinds, 4);
    let [mut plain, mut strided, mut want_parts] = [0u64; 3];
    for p in &want.graph.passes {
        if let (PassKind::Run(Pass::Gather), Params::Gather(g)) = (p.kind, &p.params)
            && p.bounce <= want.report.bounces_run
        {
            if g.stride > 1 {
                strided += 1;
            } else {
                plain += 1;
            }
            want_parts += (plan.gather_tiles(&kinds, g.stride).iter())
                .filter(|(_, k)| *k != RowKind::Empty)
                .map(|(t, _)| 1 + u64::from(coarse::grid_tile(*t, g.stride).is_some()))
                .sum::<u64>();
        }
    }
    let kept = whole.gather_hit_stats().expect("kept");
    assert!(strided > 0, "no strided gather");
    assert!(
        pieces.iter().any(|p| p.1 == RowKind::Narrow)
            && pieces.iter().any(|p| p.1 == RowKind::Plain),
        "tiles with and without a narrow texel: {pieces:?}"
    );
    assert!(kept.orphan_parts > 0, "{kept:?}");
    assert_eq!(kept.traced, want_parts, "{plain} + {strided} gathers");
    let mut compared = 0;
    for run in 0..2 {
        let out = bake_room(&mut tiled, &room, &scene.lamps, &settings, &mut |_| {}).expect("bake");
        for (a, b) in want.maps.iter().zip(&out.maps) {
            assert_eq!(a.stages, b.stages, "bake {run}: {}", a.name);
            compared += a.stages.iter().flatten().count();
        }
    }
    assert!(compared > 0);
    let kept = tiled.gather_hit_stats().expect("kept");
    // The second bake read every dispatch's hits.
    assert!(
        kept.traced > 0 && kept.replayed == 2 * kept.traced,
        "{kept:?}"
    );
}

#[test]
fn textures_start_at_zero_and_round_trip_exactly() {
    let Some(mut glow) = backend_or_skip("textures_start_at_zero_and_round_trip_exactly") else {
        return;
    };
    let t = glow.create_texture(&desc([13, 7], 3)).expect("texture");
    for layer in 0..3 {
        let back = glow.read_back(&t, layer).expect("read back");
        assert_eq!(back.len(), 13 * 7 * 4);
        assert!(back.iter().all(|&v| v == 0.0));
    }
    let data: Vec<f32> = (0..13 * 7 * 4)
        .map(|i| f32::from_bits(0x3f80_0000 + i * 7919))
        .collect();
    glow.upload(&t, 2, &data).expect("upload");
    assert_eq!(glow.read_back(&t, 2).expect("read back"), data);
    assert!(
        glow.read_back(&t, 1)
            .expect("read back")
            .iter()
            .all(|&v| v == 0.0)
    );
}

#[test]
fn limits_and_misuse_are_errors() {
    let Some(mut glow) = backend_or_skip("limits_and_misuse_are_errors") else {
        return;
    };
    let limits = glow.limits();
    assert_eq!(limits.max_array_layers, webgl2::ARRAY_LAYERS);
    assert_eq!(limits.max_texture_units, webgl2::TEXTURE_UNITS);
    assert!(limits.max_texture_size >= webgl2::TEXTURE_SIZE);
    let too_many = glow.create_texture(&desc([4, 4], webgl2::ARRAY_LAYERS + 1));
    assert!(
        matches!(too_many, Err(GlowError::Limit { .. })),
        "{too_many:?}"
    );
    let too_wide = glow.create_texture(&desc([limits.max_texture_size + 1, 1], 1));
    assert!(
        matches!(too_wide, Err(GlowError::Limit { .. })),
        "{too_wide:?}"
    );
    let t = glow.create_texture(&desc([4, 4], 2)).expect("texture");
    let short = glow.upload(&t, 0, &[0.0; 3]);
    assert!(
        matches!(short, Err(GlowError::InvalidInput(_))),
        "{short:?}"
    );
    let layer = glow.upload(&t, 2, &[0.0; 64]);
    assert!(
        matches!(layer, Err(GlowError::InvalidInput(_))),
        "{layer:?}"
    );
    let read = glow.read_back(&t, 5);
    assert!(matches!(read, Err(GlowError::InvalidInput(_))), "{read:?}");
}

/// One backend bakes a prepared room under several lamps: after each bake it holds no texture
/// and no scene (they were released), its programs stay, and every bake equals one on a fresh
/// backend.
#[test]
fn one_backend_bakes_a_room_again_and_again_without_growing() {
    let test = "one_backend_bakes_a_room_again_and_again_without_growing";
    let Some(mut kept) = backend_or_skip(test) else {
        return;
    };
    let settings = Settings {
        rays: 4,
        texels_per_metre: 8.0,
        ..Settings::preset(luxbake::scene::Quality::Default)
    };
    let scene = Scene::builtin_with_settings("chairs_01", settings.clone()).expect("chairs_01");
    let room = luxbake::Room::prepare(&scene, &settings, kept.limits(), &mut |_| {}).expect("room");
    let mut dimmer = scene.lamps.clone();
    dimmer[0].multiplier = 0.25;
    dimmer[0].position[0] += 0.3;
    // The number of compiled programs after the first bake: later bakes compile none.
    let programs = |held: &str| -> Option<usize> {
        let rest = held.split("programs: ").nth(1)?;
        rest.split(|c: char| !c.is_ascii_digit())
            .next()?
            .parse()
            .ok()
    };
    let mut compiled = None;
    for lamps in [&scene.lamps, &dimmer, &scene.lamps] {
        let out = luxbake::bake_room(&mut kept, &room, lamps, &settings, &mut |_| {})
            .expect("bake on the kept backend");
        let held = format!("{kept:?}");
        assert!(
            held.contains("textures: 0") && held.contains("scenes: 0"),
            "{held}"
        );
        let now = programs(&held).filter(|&n| n > 0);
        assert!(now.is_some(), "no compiled programs in {held}");
        assert_eq!(
            *compiled.get_or_insert(now),
            now,
            "programs compiled again: {held}"
        );
        let Some(mut fresh) = backend_or_skip(test) else {
            return;
        };
        let reference = luxbake::bake_room(&mut fresh, &room, lamps, &settings, &mut |_| {})
            .expect("bake on a fresh backend");
        assert!(!out.maps.is_empty());
        assert_eq!(out.maps.len(), reference.maps.len());
        for (a, b) in out.maps.iter().zip(&reference.maps) {
            assert_eq!(a.stages, b.stages, "{}", a.name);
        }
    }
}
