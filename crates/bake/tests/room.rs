//! A prepared room baked under other lamps: `Room::prepare` + `bake_room` gives exactly the
//! maps of a whole `bake` of the same scene and lamps, for the lamps it was prepared with and
//! for others (moved, dimmed, a second lamp), including a scene far from the origin; a room
//! prepared for another texel density is refused.

mod common;

use std::sync::Arc;

use luxbake::bake::{BakeError, BakeOutput, ReadBack, Room, bake_room, bake_room_reading};
use luxbake::graph::PassKind;
use luxbake::prepare::PrepareError;
use luxbake::scene::{Lamp, Scene, Settings};
use luxbake::{GpuBackend, Progress};
use luxbake_backend_cpu::CpuBackend;
use luxbake_ies::Photometry;

use common::{prepare, run, small_room};

/// The bit patterns of every stage of every object's maps.
fn bits(out: &BakeOutput) -> Vec<Vec<u32>> {
    out.maps
        .iter()
        .flat_map(|m| m.stages.iter().flatten())
        .map(|img| img.texels.iter().map(|v| v.to_bits()).collect())
        .collect()
}

/// Other lamps for the same room: the scene's lamp moved and dimmed, plus an isotropic one.
fn other_lamps(scene: &Scene) -> Vec<Lamp> {
    let mut moved = scene.lamps[0].clone();
    moved.position[0] += 0.4;
    moved.position[1] -= 0.3;
    moved.multiplier *= 0.5;
    let bulb = Lamp::new(
        "bulb",
        Arc::new(Photometry::isotropic(300.0)),
        [-0.8, 1.9, 0.6],
    );
    vec![moved, bulb]
}

#[test]
fn a_prepared_room_bakes_other_lamps_as_a_whole_bake_does() {
    let scene = small_room();
    let s = &scene.settings;
    let mut steps = Vec::new();
    let room = Room::prepare(&scene, s, CpuBackend::new().limits(), &mut |p| {
        if let Progress::Setup(step) = p {
            steps.push(step.to_string());
        }
    })
    .expect("room");
    assert_eq!(steps, ["layout", "rasterise", "bvh", "unocclude"]);

    let mut backend = CpuBackend::new();
    let mut steps = Vec::new();
    let same = bake_room(&mut backend, &room, &scene.lamps, s, &mut |p| {
        if let Progress::Setup(step) = p {
            steps.push(step.to_string());
        }
    })
    .expect("same lamps");
    // No room work is repeated.
    for step in ["layout", "rasterise", "bvh", "unocclude"] {
        assert!(
            !steps.iter().any(|s| s == step),
            "{step} ran again: {steps:?}"
        );
    }
    let reference = run(&scene);
    assert!(!bits(&reference).is_empty());
    assert_eq!(
        bits(&same),
        bits(&reference),
        "the prepared room's own lamps"
    );

    let lamps = other_lamps(&scene);
    let swapped = bake_room(&mut backend, &room, &lamps, s, &mut |_| {}).expect("swap");
    let fresh = run(&Scene {
        lamps: lamps.clone(),
        ..scene.clone()
    });
    assert_eq!(bits(&swapped), bits(&fresh), "other lamps");
    assert_ne!(
        bits(&swapped),
        bits(&reference),
        "the lamps changed nothing"
    );
    assert_eq!(swapped.lamps_used, [0, 1]);
}

#[test]
fn a_room_far_from_the_origin_places_its_lamps_like_the_small_room() {
    let scene = small_room().translated([25_000.0, 0.0, -12_000.0]);
    let room = prepare(&scene);
    assert!(
        room.shift.is_some(),
        "the room is baked moved next to the origin"
    );
    let lamps: Vec<Lamp> = other_lamps(&scene)
        .into_iter()
        .map(|mut l| {
            l.position[0] += 25_000.0;
            l.position[2] -= 12_000.0;
            l
        })
        .collect();
    let swapped = bake_room(
        &mut CpuBackend::new(),
        &room,
        &lamps,
        &scene.settings,
        &mut |_| {},
    )
    .expect("swap");
    let fresh = run(&Scene {
        lamps,
        ..scene.clone()
    });
    assert_eq!(bits(&swapped), bits(&fresh));
}

#[test]
fn only_the_g_buffer_upload_is_independent_of_the_lamps() {
    let out = run(&small_room());
    let (room, lamps): (Vec<_>, Vec<_>) = out.graph.passes.iter().partition(|p| !p.lamps);
    assert_eq!(
        room.iter().map(|p| p.kind).collect::<Vec<_>>(),
        [PassKind::GBuffer]
    );
    assert!(
        lamps
            .iter()
            .any(|p| p.kind == PassKind::Run(luxbake::program::Program::Connect))
    );
}

#[test]
fn a_room_prepared_for_another_density_is_refused() {
    let scene = small_room();
    let room = prepare(&scene);
    let denser = Settings {
        texels_per_metre: 16.0,
        ..scene.settings.clone()
    };
    let err = bake_room(
        &mut CpuBackend::new(),
        &room,
        &scene.lamps,
        &denser,
        &mut |_| {},
    )
    .expect_err("another density");
    assert!(
        matches!(err, BakeError::Prepare(PrepareError::Mismatch { .. })),
        "{err}"
    );
    assert!(err.to_string().contains("texels per metre"), "{err}");
}

/// What a bake reported, in order.
#[derive(Debug, Clone, PartialEq)]
enum Event {
    Work(f32),
    Start(u32),
    Direct,
    /// The lamp paths' pool traced (a host step).
    LampPaths,
}

#[test]
fn progress_follows_the_work_and_the_direct_light_comes_first() {
    let scene = small_room();
    let room = prepare(&scene);
    let events = std::cell::RefCell::new(Vec::new());
    let mut shown = None;
    let out = luxbake::bake_room_direct_first(
        &mut CpuBackend::new(),
        &room,
        &scene.lamps,
        &scene.settings,
        &mut |p| match p {
            Progress::Work(f) => events.borrow_mut().push(Event::Work(*f)),
            Progress::PassStart { bounce, .. } => events.borrow_mut().push(Event::Start(*bounce)),
            Progress::Setup("lamp paths") => events.borrow_mut().push(Event::LampPaths),
            _ => {}
        },
        &mut |stage, maps| {
            // The small room's lamp is a point: no preview.
            assert_eq!(stage, luxbake::DirectStage::Direct);
            shown = Some(maps.to_vec());
            events.borrow_mut().push(Event::Direct);
        },
    )
    .expect("bake");
    let events = events.into_inner();
    eprintln!("{events:?}");
    // The direct light is handed over before the first bounce, as the bake's own direct maps.
    let direct_at = events
        .iter()
        .position(|e| *e == Event::Direct)
        .expect("direct event");
    let first_bounce = events
        .iter()
        .position(|e| matches!(e, Event::Start(b) if *b >= 1))
        .expect("a bounce ran");
    assert!(direct_at < first_bounce, "{events:?}");
    // The lamp paths' pool is the first bounce's: traced after the direct light is out.
    let paths_at = events
        .iter()
        .position(|e| *e == Event::LampPaths)
        .expect("the bake traces lamp paths");
    assert!(
        direct_at < paths_at && paths_at < first_bounce,
        "{events:?}"
    );
    // Tracing it, a host step, moves the fraction too: once per part of the pool.
    let while_tracing = events[paths_at..first_bounce]
        .iter()
        .filter(|e| matches!(e, Event::Work(_)))
        .count();
    assert!(
        while_tracing as u32 >= luxbake::lightpaths::POOL_REPORTS / 2,
        "{while_tracing} work events while the pool was traced: {events:?}"
    );
    let shown = shown.expect("direct maps");
    assert_eq!(shown.len(), out.maps.len());
    for (a, b) in shown.iter().zip(&out.maps) {
        assert_eq!(a.illuminance(), b.direct());
        assert!(a.indirect().is_none());
    }
    // Handing it over changes nothing.
    let plain = bake_room(
        &mut CpuBackend::new(),
        &room,
        &scene.lamps,
        &scene.settings,
        &mut |_| {},
    )
    .expect("bake");
    assert_eq!(bits(&plain), bits(&out));

    // The work fraction never decreases, ends at 1, and grows in steps: no long stand-still
    // followed by a jump (the graph reserves many more bounces than run).
    let work: Vec<f32> = events
        .iter()
        .filter_map(|e| match e {
            Event::Work(f) => Some(*f),
            _ => None,
        })
        .collect();
    assert!(work.len() > 10, "{work:?}");
    assert!(work.windows(2).all(|w| w[0] <= w[1]), "{work:?}");
    assert_eq!(work.last(), Some(&1.0));
    let jump = work.windows(2).map(|w| w[1] - w[0]).fold(work[0], f32::max);
    assert!(jump < 0.35, "largest step {jump}: {work:?}");
    assert!(out.report.bounces_run < scene.settings.bounces);
}

#[test]
fn reading_back_the_light_only_gives_the_same_illuminance_and_direct_light() {
    let scene = small_room();
    let room = prepare(&scene);
    let mut backend = CpuBackend::new();
    let all = bake_room(
        &mut backend,
        &room,
        &scene.lamps,
        &scene.settings,
        &mut |_| {},
    )
    .expect("all stages");
    let mut early = 0;
    let light = bake_room_reading(
        &mut backend,
        &room,
        &scene.lamps,
        &scene.settings,
        ReadBack::LIGHT,
        &mut |_| {},
        Some(&mut |_: luxbake::DirectStage, _: &[luxbake::bake::ObjectMaps]| early += 1),
    )
    .expect("light only");
    assert_eq!(early, 1, "the direct light is still handed over first");
    assert!(all.report.bounces_run > 0);
    assert_eq!(light.maps.len(), all.maps.len());
    let bits =
        |m: &luxbake::map::MapImage| m.texels.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    for (l, a) in light.maps.iter().zip(&all.maps) {
        for (i, (ls, als)) in l.stages.iter().zip(&a.stages).enumerate() {
            assert!(als.is_some(), "{}: stage {i} was computed", a.name);
            assert_eq!(
                ls.is_some(),
                ReadBack::LIGHT.reads(i),
                "{}: stage {i}",
                l.name
            );
        }
        assert!(
            l.illuminance().texels.iter().any(|&v| v > 0.0),
            "{}",
            l.name
        );
        assert_eq!(bits(l.illuminance()), bits(a.illuminance()), "{}", l.name);
        assert_eq!(bits(l.direct()), bits(a.direct()), "{}", l.name);
    }
}
