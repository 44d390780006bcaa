//! The à-trous denoiser's programs (`Program::Variance`, `Program::Atrous`, and the bias
//! correction's `Program::Combine` steps) run directly on
//! every backend, pass by pass as `luxbake::program::atrous_steps` lists them, on the same
//! synthetic light map and G-buffer (two layers: a floor chart with a contact shadow and a dark
//! corner, a second object touching it, a second chart of the floor's object next to it in the
//! map but 30 m away, a wall chart, holes, a curved chart and a lonely texel). Every pass's
//! output must match the CPU reference within a relative error of 1e-5 (the drivers' `exp`).
//! A GPU backend without a driver is skipped outside CI and fails in CI.

use luxbake::backend::{Dispatch, GpuBackend, SceneData};
use luxbake::graph::{TexDesc, TexFormat};
use luxbake::map::MapImage;
use luxbake::prepare::SceneBvh;
use luxbake::program::{
    AtrousConfig, CombineParams, Params, Program, TilePlan, atrous_steps, correction_steps,
};
use luxbake::rng;
use luxbake::scene::BvhMode;
use luxbake_backends::BackendKind;
use luxbake_backends::image_diff::diff;
use luxbake_bvh::{BuildOptions, Bvh, EncodeOptions, EncodedScene, TriangleAttributes, encode};
use luxbake_tests::Tally;

const SIZE: [u32; 2] = [48, 40];
const LAYERS: u32 = 2;
/// Texel size, metres.
const H: f32 = 0.05;
const MAX_RELATIVE_ERROR: f64 = 1e-5;

/// The uploaded textures: light map, position, normal (every layer, row 0 first).
struct Input {
    map: Vec<f32>,
    position: Vec<f32>,
    normal: Vec<f32>,
}

fn input() -> Input {
    let n = (SIZE[0] * SIZE[1] * LAYERS) as usize;
    let mut inp = Input {
        map: vec![0.0; 4 * n],
        position: vec![0.0; 4 * n],
        normal: vec![0.0; 4 * n],
    };
    let noise = |i: usize| {
        let [u0, u1] = rng::uniform2(i as u32, 0, 0, 21);
        (
            (-2.0 * (1.0 - u0).ln()).sqrt() * (std::f32::consts::TAU * u1).cos(),
            u1,
        )
    };
    let mut set = |l: u32, x: u32, y: u32, value: f32, p: [f32; 3], nrm: [f32; 3], object: u32| {
        let i = ((l * SIZE[1] + y) * SIZE[0] + x) as usize;
        let (g, u) = noise(i);
        let v = (value * (1.0 + 0.15 * g)).max(0.0);
        // A tint, so that the channels differ.
        inp.map[4 * i..4 * i + 4].copy_from_slice(&[v, 0.8 * v + 0.05 * u, 0.6 * v, 1.0]);
        inp.position[4 * i..4 * i + 4].copy_from_slice(&[p[0], p[1], p[2], 1.0]);
        inp.normal[4 * i..4 * i + 4].copy_from_slice(&[nrm[0], nrm[1], nrm[2], object as f32]);
    };
    let fx = |x: u32| (x as f32 + 0.5) * H;
    let fy = fx;
    for y in 0..SIZE[1] {
        for x in 0..SIZE[0] {
            let up = [0.0, 1.0, 0.0];
            match x {
                // The floor: lit, a contact shadow from x = 10, a dark corner of mostly exact
                // zeros (rays that found no light) at the bottom, a hole.
                0..20 if (14..17).contains(&y) && (4..7).contains(&x) => {}
                0..20 => {
                    let lit = if x < 10 { 2.0 } else { 0.5 };
                    let dark = y >= 30 && noise((y * 97 + x) as usize).1 > 0.2;
                    let v = if dark { 0.0 } else { lit };
                    set(0, x, y, v, [fx(x), 0.0, fy(y)], up, 0);
                }
                // A second object touching the floor in the map and the world.
                20..24 => set(0, x, y, 5.0, [fx(x), 0.0, fy(y)], up, 1),
                // A gap, then a wall chart facing +X and another floor chart 30 m away.
                24 => {}
                _ if y < 6 => set(0, x, y, 3.0, [0.0, fy(6 - y), fx(x)], [1.0, 0.0, 0.0], 0),
                _ => set(0, x, y, 1.0, [fx(x), 0.0, fy(y) + 30.0], up, 0),
            }
            // Layer 1: a cylinder of radius 0.5 m around the Y axis (object 2) with a
            // gradient, and a lonely texel.
            if x < 40 {
                let a = fx(x) / 0.5;
                let (s, c) = a.sin_cos();
                let p = [0.5 * c, fy(y), 0.5 * s];
                set(1, x, y, 0.2 + 0.05 * x as f32, p, [c, 0.0, s], 2);
            } else if (x, y) == (44, 20) {
                set(1, x, y, 7.0, [9.0, 9.0, 9.0], [0.0, 0.0, 1.0], 3);
            }
        }
    }
    inp
}

/// One triangle: the scene every backend needs uploaded, though no program here reads it.
fn one_triangle() -> EncodedScene {
    let tris = vec![[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]];
    let attrs = vec![TriangleAttributes {
        normals: [[0.0, 1.0, 0.0]; 3],
        uvs: [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
        object: 0,
    }];
    let bvh = Bvh::build(&tris, &BuildOptions::default()).expect("bvh");
    encode(&bvh, &tris, &attrs, &EncodeOptions::default()).expect("encode")
}

/// Runs `steps` on `backend` (textures 0–2 the input, 3 the variance, 4 and 5 the à-trous
/// iterations' ping-pong, 6 and 7 the bias correction's, 8 its result) in small row tiles;
/// returns every pass's output, all layers. A [`CombineParams::PAIR`] step pairs the map with
/// the last à-trous output, the linear iterations filter the pair, and
/// [`CombineParams::RATIO`] scales that output by the filtered pair.
fn run<B: GpuBackend>(
    backend: &mut B,
    inp: &Input,
    steps: &[(Program, Params)],
) -> Result<Vec<Vec<f32>>, B::Error> {
    let labels = [
        "map", "position", "normal", "variance", "ping", "pong", "pair", "pair2", "out",
    ];
    let mut tex = Vec::new();
    for label in labels {
        tex.push(backend.create_texture(&TexDesc {
            label,
            size: SIZE,
            layers: LAYERS,
            format: TexFormat::Rgba32F,
        })?);
    }
    let per_layer = (4 * SIZE[0] * SIZE[1]) as usize;
    for (t, data) in [&inp.map, &inp.position, &inp.normal]
        .into_iter()
        .enumerate()
    {
        for l in 0..LAYERS as usize {
            backend.upload(&tex[t], l as u32, &data[l * per_layer..(l + 1) * per_layer])?;
        }
    }
    let bvh = SceneBvh::new(one_triangle());
    let scene = backend.upload_scene(&SceneData {
        bvh: &bvh,
        lamps: &[],
        ies_tables: &[],
        regions: &[],
        layer_size: SIZE,
        layers: LAYERS,
        ray_epsilon: 1e-4,
        lamp_paths: &[],
    })?;
    let mut outputs = Vec::new();
    let (mut current, mut filtered) = (0, 0);
    for (k, (program, params)) in steps.iter().enumerate() {
        let (reads, write) = match params {
            // The map stands in for the direct light too (alpha: its luminance).
            Params::Variance(_) => (vec![0, 1, 2, 0], 3),
            Params::Atrous(a) if a.linear != 0 => {
                (vec![current, 3, 1, 2], if current == 6 { 7 } else { 6 })
            }
            Params::Atrous(_) => (vec![current, 3, 1, 2], 4 + k % 2),
            Params::Combine(c) if *c == CombineParams::PAIR => {
                filtered = current;
                (vec![0, current], 6)
            }
            Params::Combine(c) if *c == CombineParams::RATIO => (vec![filtered, current], 8),
            other => panic!("not a denoiser step: {other:?}"),
        };
        let reads: Vec<&B::Texture> = reads.iter().map(|&r| &tex[r]).collect();
        let words = params.words();
        // About three rows per tile: tiles read rows outside themselves.
        let plan = TilePlan::new(SIZE, LAYERS, params.work_per_texel(), 4000);
        for tile in plan.tiles() {
            backend.dispatch(&Dispatch {
                label: program.label(),
                program: *program,
                bvh: BvhMode::None,
                reads: &reads,
                write: &tex[write],
                scene: &scene,
                params: &words,
                tile,
                idle: false,
                narrow: true,
            })?;
        }
        let mut out = Vec::new();
        for l in 0..LAYERS {
            out.extend(backend.read_back(&tex[write], l)?);
        }
        outputs.push(out);
        // The variance map is read beside the map, never filtered.
        if !matches!(params, Params::Variance(_)) {
            current = write;
        }
    }
    Ok(outputs)
}

fn layer_image(data: &[f32], layer: usize) -> MapImage {
    let n = (4 * SIZE[0] * SIZE[1]) as usize;
    MapImage {
        width: SIZE[0],
        height: SIZE[1],
        texels: data[layer * n..(layer + 1) * n].to_vec(),
    }
}

#[test]
fn the_denoiser_passes_agree_across_backends() {
    let test = "atrous::the_denoiser_passes_agree_across_backends";
    // The default (without a scene size, no wide term), and a filter with the wide term from
    // its first iteration on, in every texel inside a wide chart (a scene of 100 m: every
    // iteration's taps reach less than 1/32 of it).
    let config = AtrousConfig::new(5, H);
    let quiet = AtrousConfig {
        wide_max_relative_variance: 1.0,
        early_iterations: 0,
        scene_size: 100.0,
        ..config
    };
    let default = agree_across_backends(test, &atrous_steps(&config), &input()).0;
    let wide = agree_across_backends(test, &atrous_steps(&quiet), &input()).0;
    // The wide term is taken (where a GPU backend ran too, it agreed on it).
    let changed = default
        .chunks_exact(4)
        .zip(wide.chunks_exact(4))
        .filter(|(a, b)| a[3] > 0.5 && a != b)
        .count();
    assert!(changed > 100, "the wide term changed {changed} texels");
}

/// The whole bias-corrected denoiser as the graph chains it (`atrous_steps`, the luminances
/// of the map and of the à-trous output side by side, `correction_steps`' linear filter of
/// them, the output scaled by their ratio) agrees across backends pass by pass, and the
/// correction changes the à-trous output.
#[test]
fn the_bias_correction_agrees_across_backends() {
    let test = "atrous::the_bias_correction_agrees_across_backends";
    let inp = input();
    let config = AtrousConfig::new(5, H).with_correction(true);
    let mut steps = atrous_steps(&config);
    let denoised = steps.len() - 1;
    steps.push((Program::Combine, Params::Combine(CombineParams::PAIR)));
    let correction = correction_steps(&config);
    assert_eq!(correction.len(), 6);
    steps.extend(correction);
    steps.push((Program::Combine, Params::Combine(CombineParams::RATIO)));
    let (last, outputs) = agree_across_backends(test, &steps, &inp);
    let changed = last
        .chunks_exact(4)
        .zip(outputs[denoised].chunks_exact(4))
        .filter(|(a, b)| b[3] > 0.5 && a[..3] != b[..3])
        .count();
    assert!(changed > 1000, "the correction changed {changed} texels");
}

/// Every pass of `steps` (the denoiser's) on every backend, from the map of `inp`, against
/// the CPU's: the CPU's last output, and every pass's.
fn agree_across_backends(
    test: &str,
    steps: &[(Program, Params)],
    inp: &Input,
) -> (Vec<f32>, Vec<Vec<f32>>) {
    let mut tally = Tally::new(test);
    let mut results = Vec::new();
    for b in BackendKind::ALL {
        let Some(mut opened) = tally.open(b) else {
            continue;
        };
        let out = run(&mut opened, inp, steps).map_err(|e| e.to_string());
        results.push((
            b,
            out.unwrap_or_else(|e| panic!("{test}: {}: {e}", b.name())),
        ));
    }
    let (cpu, reference) = &results[0];
    assert_eq!(*cpu, BackendKind::Cpu);
    // The filter changes the map (so the comparison is not of copies).
    let last = reference.last().expect("outputs");
    let changed = last
        .chunks_exact(4)
        .zip(inp.map.chunks_exact(4))
        .filter(|(a, b)| b[3] > 0.5 && a[..3] != b[..3])
        .count();
    assert!(changed > 1000, "{changed} texels changed");
    for (b, out) in &results[1..] {
        for (k, (program, _)) in steps.iter().enumerate() {
            let mut texels = 0;
            let mut bits = 0;
            let mut worst = 0.0f64;
            for layer in 0..LAYERS as usize {
                let (e, a) = (
                    layer_image(&reference[k], layer),
                    layer_image(&out[k], layer),
                );
                let s = diff(&e, &a);
                assert_eq!(s.mask_mismatches, 0, "{} pass {k} layer {layer}", b.name());
                texels += s.texels;
                worst = worst.max(s.max);
                bits += e
                    .texels
                    .chunks_exact(4)
                    .zip(a.texels.chunks_exact(4))
                    .filter(|(e, a)| e[3] > 0.5 && e == a)
                    .count();
            }
            println!(
                "cpu-vs-{} pass {k} ({}): {texels} texels, {bits} bit-identical, max relative \
                 error {worst:.2e}",
                b.name(),
                program.label()
            );
            assert!(texels > 1000, "{texels}");
            assert!(
                worst <= MAX_RELATIVE_ERROR,
                "cpu-vs-{} pass {k} ({}): max relative error {worst:e}",
                b.name(),
                program.label()
            );
        }
        tally.compared(1);
    }
    tally.finish();
    (last.clone(), reference.clone())
}
