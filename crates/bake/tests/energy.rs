//! The checks' reduction (`Program::Energy`, applied twice): a map's valid texels summed on
//! the backend into one texel per layer agree with the host's f64 sum, masked texels are left
//! out, and a bake whose f32 sum would overflow still decides on the map (no NaN, the same
//! bounces as at a sane scale).

use luxbake::GpuBackend;
use luxbake::backend::{Dispatch, SceneData};
use luxbake::bake::{Room, bake};
use luxbake::graph::{TexDesc, TexFormat};
use luxbake::program::{Program, TilePlan};
use luxbake::scene::{BvhMode, Quality, Scene, Settings};
use luxbake_backend_cpu::CpuBackend;
use luxbake_testkit::SplitMix64;

fn settings() -> Settings {
    Settings {
        rays: 4,
        texels_per_metre: 8.0,
        ..Settings::preset(Quality::Default)
    }
}

#[test]
fn two_reductions_sum_a_map_as_the_host_does() {
    let scene = Scene::builtin_with_settings("chairs_01", settings()).expect("scene");
    let mut backend = CpuBackend::new();
    let room = Room::prepare(&scene, &scene.settings, backend.limits(), &mut |_| {}).expect("room");
    let [w, h] = room.layout.layer_size;
    let layers = room.layout.layers;
    let uploaded = backend
        .upload_scene(&SceneData {
            bvh: &room.bvh,
            lamps: &[],
            ies_tables: &[],
            regions: &room.layout.regions,
            layer_size: [w, h],
            layers,
            ray_epsilon: room.ray_epsilon,
            lamp_paths: &[],
        })
        .expect("scene");
    let desc = |label, size| TexDesc {
        label,
        size,
        layers,
        format: TexFormat::Rgba32F,
    };
    let map = backend.create_texture(&desc("map", [w, h])).expect("map");
    let rows = backend.create_texture(&desc("rows", [h, 1])).expect("rows");
    let total = backend
        .create_texture(&desc("total", [1, 1]))
        .expect("total");
    let mut rng = SplitMix64::new(7);
    let mut want = vec![0.0f64; layers as usize];
    for l in 0..layers {
        let texels: Vec<f32> = (0..w * h)
            .flat_map(|_| {
                let valid = rng.f32() < 0.7;
                let rgb = [0; 3].map(|_| rng.range(0.0, 1e4));
                [rgb[0], rgb[1], rgb[2], if valid { 1.0 } else { 0.0 }]
            })
            .collect();
        want[l as usize] = texels
            .chunks_exact(4)
            .filter(|t| t[3] > 0.5)
            .map(|t| t[..3].iter().map(|&v| f64::from(v)).sum::<f64>())
            .sum();
        backend.upload(&map, l, &texels).expect("upload");
    }
    for (read, write, size) in [(&map, &rows, [h, 1]), (&rows, &total, [1, 1])] {
        for tile in TilePlan::new(size, layers, 1, u64::MAX).tiles() {
            backend
                .dispatch(&Dispatch {
                    label: "energy",
                    program: Program::Energy,
                    bvh: BvhMode::None,
                    reads: &[read],
                    write,
                    scene: &uploaded,
                    params: &[],
                    tile,
                    idle: false,
                    narrow: true,
                })
                .expect("reduce");
        }
    }
    for l in 0..layers {
        let got = backend.read_back(&total, l).expect("read back");
        assert_eq!(got.len(), 4, "one texel per layer");
        let rel = (f64::from(got[0]) - want[l as usize]).abs() / want[l as usize];
        assert!(
            want[l as usize] > 1e6 && rel < 2e-6,
            "layer {l}: {} vs {}",
            got[0],
            want[l as usize]
        );
        assert_eq!(got[3], 1.0);
    }
}

#[test]
fn a_bake_too_bright_for_an_f32_sum_decides_on_the_map() {
    // The paper method (no denoiser, whose variance of such values would overflow first), its
    // bounces decided by the energy checks.
    let paper = Settings {
        rays: 4,
        bounces: 40,
        texels_per_metre: 8.0,
        ..Settings::paper()
    };
    let sane = Scene::builtin_with_settings("chairs_01", paper).expect("scene");
    let mut bright = sane.clone();
    // 1e35 × the lamp: each texel stays finite, the sum of a layer's texels does not in f32.
    const SCALE: f64 = 1e35;
    bright.lamps[0].multiplier = SCALE as f32;
    let a = bake(&mut CpuBackend::new(), &sane, &sane.settings, &mut |_| {}).expect("sane");
    let b = bake(
        &mut CpuBackend::new(),
        &bright,
        &bright.settings,
        &mut |_| {},
    )
    .expect("bright");
    assert_eq!(a.report.bounces_run, b.report.bounces_run);
    let mut compared = 0;
    for (ma, mb) in a.maps.iter().zip(&b.maps) {
        let (ta, tb) = (&ma.illuminance().texels, &mb.illuminance().texels);
        for (x, y) in ta.chunks_exact(4).zip(tb.chunks_exact(4)) {
            for c in 0..3 {
                assert!(y[c].is_finite());
                let want = f64::from(x[c]) * SCALE;
                let tolerance = 1e-4 * want.abs().max(1e20);
                assert!((f64::from(y[c]) - want).abs() <= tolerance, "{x:?} {y:?}");
                compared += 1;
            }
        }
    }
    assert!(compared > 1000);
    let direct: f64 = a
        .maps
        .iter()
        .flat_map(|m| m.direct().texels.chunks_exact(4))
        .map(|t| t[..3].iter().map(|&v| f64::from(v)).sum::<f64>())
        .sum();
    assert!(
        direct * SCALE > 4.0 * f64::from(f32::MAX),
        "no f32 sum overflows"
    );
    assert!(
        (2..40).contains(&a.report.bounces_run),
        "the checks decided nothing: {} bounces",
        a.report.bounces_run
    );
}
