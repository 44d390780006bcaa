//! Per-lamp layers: a lamp's maps are linear in its intensity, so a recombination with any
//! multiplier equals a fresh bake with that multiplier (1e-5 relative), a lamp switched off
//! leaves exactly the other's light, and bad states are refused.

mod common;

use std::sync::Arc;

use luxbake::GpuBackend;
use luxbake::bake::{BakeOutput, Room};
use luxbake::layers::{LampLayers, LampState, LayerError, bake_layers};
use luxbake::scene::{Lamp, Scene};
use luxbake_backend_cpu::CpuBackend;
use luxbake_ies::Photometry;

use common::{run, small_room};

/// `scene`'s room prepared and each of its lamps baked alone, on the CPU backend.
fn layered(scene: &Scene) -> LampLayers {
    let room = Room::prepare(
        scene,
        &scene.settings,
        CpuBackend::new().limits(),
        &mut |_| {},
    )
    .expect("room");
    bake_layers(
        &mut CpuBackend::new(),
        &room,
        &scene.lamps,
        &scene.settings,
        &mut |_| {},
    )
    .expect("layers")
}

/// Largest |a − b| / max(|b|, floor) over every light stage's RGB, and how many values were
/// compared; `floor` is 1e-6 of the largest value of `b` (texels that are dark in both).
fn worst(a: &BakeOutput, b: &BakeOutput) -> (f64, usize) {
    assert_eq!(a.maps.len(), b.maps.len());
    let peak = b
        .maps
        .iter()
        .flat_map(|m| m.stages.iter().skip(1).flatten())
        .flat_map(|i| i.texels.iter())
        .fold(0.0f64, |m, v| m.max(f64::from(v.abs())));
    let floor = peak * 1e-6;
    let (mut worst, mut n) = (0.0f64, 0);
    for (ma, mb) in a.maps.iter().zip(&b.maps) {
        for (sa, sb) in ma.stages.iter().zip(&mb.stages).skip(1) {
            let (Some(sa), Some(sb)) = (sa, sb) else {
                assert_eq!(sa.is_some(), sb.is_some(), "a stage is missing");
                continue;
            };
            assert_eq!(sa.texels.len(), sb.texels.len());
            for (ta, tb) in sa.texels.chunks_exact(4).zip(sb.texels.chunks_exact(4)) {
                assert_eq!(ta[3], tb[3], "texel masks differ");
                for c in 0..3 {
                    let (x, y) = (f64::from(ta[c]), f64::from(tb[c]));
                    worst = worst.max((x - y).abs() / y.abs().max(floor));
                    n += 1;
                }
            }
        }
    }
    (worst, n)
}

#[test]
fn a_dimmed_layer_equals_a_fresh_bake_with_that_multiplier() {
    let mut scene = small_room();
    // A tinted lamp: its layer is baked in its colour.
    scene.lamps[0].color = [1.0, 0.8, 0.55];
    let layers = layered(&scene);
    assert_eq!(layers.layers.len(), 1);
    assert_eq!(layers.colors, [[1.0, 0.8, 0.55]]);
    let color = scene.lamps[0].color;
    for multiplier in [1.0, 0.37, 2.5, 1e-3] {
        let mut dimmed = scene.clone();
        dimmed.lamps[0].multiplier = multiplier;
        dimmed.lamps[0].color = color;
        let fresh = run(&dimmed);
        let combined = layers
            .combine(&[LampState {
                multiplier,
                color,
                on: true,
            }])
            .expect("combine");
        let (err, n) = worst(&combined, &fresh);
        assert!(n > 10_000, "only {n} values compared");
        assert!(err <= 1e-5, "×{multiplier}: {err:e} relative");
        assert_eq!(combined.lamps_used, [0]);
    }
}

#[test]
fn switching_one_of_two_lamps_off_leaves_the_other_lamps_light() {
    let mut scene = small_room();
    let mut bulb = Lamp::new(
        "bulb",
        Arc::new(Photometry::isotropic(300.0)),
        [-0.8, 1.9, 0.6],
    );
    bulb.multiplier = 0.0; // off in the scene: still baked, so it can be switched on.
    scene.lamps.push(bulb);
    let layers = layered(&scene);
    assert_eq!(layers.layers.len(), 2);
    assert!(layers.bytes_per_lamp() > 0);

    let only_first = Scene {
        lamps: vec![scene.lamps[0].clone()],
        ..scene.clone()
    };
    let fresh = run(&only_first);
    let on = LampState::of(&scene.lamps[0]);
    let off = LampState {
        on: false,
        ..LampState::of(&scene.lamps[1])
    };
    let combined = layers.combine(&[on, off]).expect("combine");
    let (err, n) = worst(&combined, &fresh);
    assert!(n > 10_000 && err <= 1e-5, "{err:e} over {n}");
    assert_eq!(combined.lamps_used, [0]);

    // Switched on at multiplier 1, the bulb adds light everywhere it reaches.
    let both = layers
        .combine(&[
            on,
            LampState {
                multiplier: 1.0,
                on: true,
                ..off
            },
        ])
        .expect("combine");
    assert_eq!(both.lamps_used, [0, 1]);
    let sum = |o: &BakeOutput| -> f64 {
        o.maps
            .iter()
            .flat_map(|m| m.illuminance().texels.chunks_exact(4))
            .map(|t| f64::from(t[0]))
            .sum()
    };
    assert!(sum(&both) > sum(&combined) * 1.01);
}

#[test]
fn bad_states_are_refused() {
    let scene = small_room();
    let layers = layered(&scene);
    let good = LampState::of(&scene.lamps[0]);
    assert_eq!(
        layers.combine(&[good, good]).unwrap_err(),
        LayerError::Count { given: 2, lamps: 1 }
    );
    for (state, field) in [
        (
            LampState {
                multiplier: -1.0,
                ..good
            },
            "multiplier",
        ),
        (
            LampState {
                multiplier: f32::NAN,
                ..good
            },
            "multiplier",
        ),
        (
            LampState {
                color: [1.0, f32::INFINITY, 1.0],
                ..good
            },
            "color",
        ),
    ] {
        assert_eq!(
            layers.combine(&[state]).unwrap_err(),
            LayerError::State { lamp: 0, field }
        );
    }
    // Huge but finite weights never put an infinity into a map.
    let huge = layers
        .combine(&[LampState {
            multiplier: f32::MAX,
            ..good
        }])
        .expect("combine");
    assert!(
        huge.maps
            .iter()
            .flat_map(|m| m.stages.iter().flatten())
            .all(|i| i.texels.iter().all(|v| v.is_finite()))
    );
}

#[test]
fn a_new_colour_differs_from_a_fresh_bake_only_by_part_of_the_tail() {
    let scene = small_room();
    let layers = layered(&scene);
    let color = [1.0, 0.7, 0.4];
    let mut tinted = scene.clone();
    tinted.lamps[0].color = color;
    let fresh = run(&tinted);
    let combined = layers
        .combine(&[LampState {
            color,
            ..LampState::of(&scene.lamps[0])
        }])
        .expect("combine");
    // The direct light is exact; the total differs by less than the tail it carries.
    let direct = |o: &BakeOutput| {
        o.maps
            .iter()
            .map(|m| m.direct().clone())
            .collect::<Vec<_>>()
    };
    for (a, b) in direct(&combined).iter().zip(direct(&fresh).iter()) {
        for (x, y) in a.texels.iter().zip(&b.texels) {
            assert!(
                (x - y).abs() <= 1e-5 * y.abs().max(1e-3),
                "direct {x} vs {y}"
            );
        }
    }
    let total = |o: &BakeOutput| -> [f64; 3] {
        let mut s = [0.0; 3];
        for t in o
            .maps
            .iter()
            .flat_map(|m| m.illuminance().texels.chunks_exact(4))
        {
            for c in 0..3 {
                s[c] += f64::from(t[c]);
            }
        }
        s
    };
    let (a, b) = (total(&combined), total(&fresh));
    let tail = fresh.report.tail_fraction;
    for c in 0..3 {
        let rel = (a[c] - b[c]).abs() / b[c];
        assert!(
            rel <= tail.max(1e-5),
            "channel {c}: {rel:e} vs tail {tail:e}"
        );
    }
}
