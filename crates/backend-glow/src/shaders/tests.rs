//! The shader library against its CPU originals, through small debug passes rendered into
//! float targets.

use luxbake_bvh::{BuildOptions, Bvh, EncodeOptions, Ray, TriangleAttributes, encode};

use luxbake::kept::Variant;
use luxbake::program::Library;
use luxbake::scene::BvhMode;
use luxbake::shader::{glsl_library, glsl_variant};

use super::Pass;
use crate::gl::TextureArray;
use crate::scene::BvhTextures;
use crate::testutil::{context_or_skip, render, with_gl};
use luxbake_testkit::SplitMix64;

/// The prefix and the files of `pass` compiled for traversal `bvh`.
fn program_sources(pass: Pass, bvh: BvhMode) -> (String, Vec<&'static str>) {
    glsl_variant(pass, bvh, Variant::Plain)
}

const TRACE_FS: &str = "uniform highp sampler2DArray u_rays;\n\
    uniform float u_tmax;\n\
    uniform int u_any;\n\
    void main() {\n\
        ivec2 p = ivec2(gl_FragCoord.xy);\n\
        vec3 org = texelFetch(u_rays, ivec3(p, 0), 0).xyz;\n\
        vec3 dir = texelFetch(u_rays, ivec3(p, 1), 0).xyz;\n\
        vec3 hit;\n\
        int best = luxTrace(org, dir, 0.0, u_tmax, u_any != 0, hit);\n\
        o_color = vec4(hit, float(best));\n\
    }\n";

/// Random triangles in a 4 m box plus a closed box of 12 triangles around part of it.
fn scene(seed: u64, n: usize) -> Vec<[[f32; 3]; 3]> {
    let mut rng = SplitMix64::new(seed);
    let mut tris = Vec::with_capacity(n + 12);
    for _ in 0..n {
        let c = [0, 1, 2].map(|_| rng.range(-2.0, 2.0));
        let size = rng.range(0.05, 0.6);
        tris.push([0, 1, 2].map(|_| [0, 1, 2].map(|a| c[a] + rng.range(-size, size))));
    }
    // An axis-aligned box [-1, 1]³: rays along the axes meet its faces edge-on and face-on.
    let v = |x: f32, y: f32, z: f32| [x, y, z];
    let quads = [
        [
            v(-1., -1., -1.),
            v(1., -1., -1.),
            v(1., 1., -1.),
            v(-1., 1., -1.),
        ],
        [
            v(-1., -1., 1.),
            v(1., -1., 1.),
            v(1., 1., 1.),
            v(-1., 1., 1.),
        ],
        [
            v(-1., -1., -1.),
            v(-1., 1., -1.),
            v(-1., 1., 1.),
            v(-1., -1., 1.),
        ],
        [
            v(1., -1., -1.),
            v(1., 1., -1.),
            v(1., 1., 1.),
            v(1., -1., 1.),
        ],
        [
            v(-1., -1., -1.),
            v(1., -1., -1.),
            v(1., -1., 1.),
            v(-1., -1., 1.),
        ],
        [
            v(-1., 1., -1.),
            v(1., 1., -1.),
            v(1., 1., 1.),
            v(-1., 1., 1.),
        ],
    ];
    for q in quads {
        tris.push([q[0], q[1], q[2]]);
        tris.push([q[0], q[2], q[3]]);
    }
    tris
}

/// Rays: random origins and directions, axis-aligned directions (±0 components) and rays
/// aimed exactly at box vertices and edge midpoints.
fn rays(seed: u64, count: usize) -> Vec<Ray> {
    let mut rng = SplitMix64::new(seed);
    (0..count)
        .map(|i| {
            let origin = [0, 1, 2].map(|_| rng.range(-2.5, 2.5));
            let dir = match i % 4 {
                0 | 1 => [0, 1, 2].map(|_| rng.range(-1.0, 1.0)),
                2 => {
                    let mut d = [0.0f32; 3];
                    d[i / 4 % 3] = if i % 8 < 4 { 1.0 } else { -1.0 };
                    if i % 16 < 8 {
                        d = d.map(|c| if c == 0.0 { -0.0 } else { c });
                    }
                    d
                }
                _ => {
                    let target = [0, 1, 2].map(|_| rng.range(0.0, 3.0).floor() - 1.0);
                    [0, 1, 2].map(|a| target[a] - origin[a])
                }
            };
            Ray { origin, dir }
        })
        .collect()
}

#[test]
fn traversal_matches_the_cpu_oracle_for_every_mode() {
    let Some(ctx) = context_or_skip("traversal_matches_the_cpu_oracle_for_every_mode") else {
        return;
    };
    let seed = 0x5EED_0001;
    let tris = scene(seed, 300);
    let bvh = Bvh::build(&tris, &BuildOptions::default()).unwrap();
    let attrs = vec![TriangleAttributes::default(); tris.len()];
    let enc = encode(&bvh, &tris, &attrs, &EncodeOptions::default()).unwrap();
    let size = [64u32, 64];
    let rays = rays(seed, (size[0] * size[1]) as usize);
    let gl = ctx.gl().unwrap();
    let bvh_tex = BvhTextures::upload(gl, &enc).unwrap();
    let ray_tex = TextureArray::new(gl, "rays", size[0], size[1], 2).unwrap();
    let mut data = Vec::new();
    for layer in 0..2 {
        for r in &rays {
            let v = if layer == 0 { r.origin } else { r.dir };
            data.extend_from_slice(&[v[0], v[1], v[2], 0.0]);
        }
    }
    ray_tex.upload(gl, "rays", 0, &data).unwrap();
    let t_max = 1.0e30f32;
    for traversal in [BvhMode::Mtbvh, BvhMode::Tbvh, BvhMode::None] {
        let cpu_mode = match traversal {
            BvhMode::Wide | BvhMode::Mtbvh => luxbake_bvh::Traversal::Mtbvh,
            BvhMode::Tbvh => luxbake_bvh::Traversal::Tbvh,
            BvhMode::None => luxbake_bvh::Traversal::BruteForce,
        };
        let mut samplers = bvh_tex.samplers(traversal);
        samplers.push(("u_rays", &ray_tex));
        for any in [false, true] {
            let out = render(
                &ctx,
                "debug_trace",
                traversal,
                &[
                    glsl_library(Library::Common),
                    glsl_library(Library::Bvh),
                    TRACE_FS,
                ],
                &samplers,
                |gl, p| {
                    bvh_tex.set_uniforms(gl, p);
                    p.set_f32(gl, "u_tmax", t_max);
                    p.set_i32(gl, "u_any", i32::from(any));
                },
                size,
            );
            let mut hits = 0;
            let mut inexact = 0;
            for (i, r) in rays.iter().enumerate() {
                let g = &out[i * 4..i * 4 + 4];
                let ctx_msg = || {
                    format!("seed {seed:#x}, {traversal:?}, any {any}, ray {i} {r:?}, gpu {g:?}")
                };
                if any {
                    let cpu = enc.any_hit(r, 0.0, t_max, cpu_mode);
                    assert_eq!(g[3] >= 0.0, cpu, "{}", ctx_msg());
                    hits += usize::from(cpu);
                    continue;
                }
                match enc.closest_hit(r, 0.0, t_max, cpu_mode) {
                    None => assert_eq!(g[3], -1.0, "{}", ctx_msg()),
                    Some(h) => {
                        hits += 1;
                        if g[0] != h.t || g[1] != h.u || g[2] != h.v {
                            inexact += 1;
                        }
                        assert_eq!(g[3], h.triangle as f32, "{} cpu {h:?}", ctx_msg());
                        let rel = ((g[0] - h.t) / h.t).abs();
                        assert!(rel <= 1e-6, "t rel err {rel}: {} cpu {h:?}", ctx_msg());
                        assert!(
                            (g[1] - h.u).abs() <= 1e-5 && (g[2] - h.v).abs() <= 1e-5,
                            "{}",
                            ctx_msg()
                        );
                    }
                }
            }
            eprintln!("{traversal:?} any {any}: {hits} hits, {inexact} inexact");
            assert!(
                hits > rays.len() / 4,
                "too few hits ({hits}) to test anything"
            );
        }
    }
    bvh_tex.delete(gl);
    ray_tex.delete(gl);
}

/// `luxDivMod(u_a0 + x + 64 y, u_b)` at fragment (x, y): (quotient, remainder).
const DIVMOD_FS: &str = "uniform int u_a0;\n\
    uniform int u_b;\n\
    void main() {\n\
        ivec2 p = ivec2(gl_FragCoord.xy);\n\
        ivec2 qr = luxDivMod(u_a0 + p.x + 64 * p.y, u_b);\n\
        o_color = vec4(float(qr.x), float(qr.y), 0.0, 0.0);\n\
    }\n";

#[test]
fn div_mod_without_an_integer_division_is_floor_division() {
    let Some(ctx) = context_or_skip("div_mod_without_an_integer_division_is_floor_division") else {
        return;
    };
    let max: i32 = 1 << 24;
    let mut checked = 0;
    for b in [1, 2, 3, 7, 64, 255, 1000, 4093, 65_537, 1 << 23, max - 1] {
        // 4096 consecutive dividends from each start: below and above zero, up to the largest,
        // and across multiples of b, where a quotient off by one would show.
        for a0 in [
            -max + 1,
            -4096,
            0,
            (max / b / 2) * b - 2048,
            b * 3 - 2048,
            max - 4096,
        ] {
            let out = render(
                &ctx,
                "debug_divmod",
                BvhMode::None,
                &[glsl_library(Library::Common), DIVMOD_FS],
                &[],
                |gl, p| {
                    p.set_i32(gl, "u_a0", a0);
                    p.set_i32(gl, "u_b", b);
                },
                [64, 64],
            );
            for (i, qr) in out.chunks_exact(4).enumerate() {
                let a = a0 + i as i32;
                let want = [a.div_euclid(b) as f32, a.rem_euclid(b) as f32];
                assert_eq!(qr[..2], want, "{a} / {b}");
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 11 * 6 * 4096);
}

/// `u_what` 0: the hash's bits (16 per channel) and the hash sampler's uniforms; 1: the Sobol
/// sampler's bits; 2: both samplers' uniforms through `luxSample2` with their generated ids;
/// 3: the Sobol sampler's gather stream (`rng::Stream`; stride `u_pass - 1`, `u_sample` rays);
/// 4: its refinement stream (`u_seed` rays, then `u_sample` more); 5: the hash sampler's
/// gather stream (16 bits per channel).
const RNG_FS: &str = "uniform uint u_sample;\n\
    uniform uint u_pass;\n\
    uniform uint u_seed;\n\
    uniform int u_layer;\n\
    uniform int u_what;\n\
    out vec4 o;\n\
    vec2 halves(uint h) { return vec2(float(h & 0xffffu), float(h >> 16u)); }\n\
    void main() {\n\
        uvec2 p = uvec2(gl_FragCoord.xy);\n\
        uint t = luxTexelIndex(uvec2(97u, 61u), uint(u_layer), p.x, p.y);\n\
        if (u_what == 0) {\n\
            uint h = luxHash(t, u_sample, u_pass, u_seed);\n\
            o = vec4(halves(h), luxUniform2(t, u_sample, u_pass, u_seed));\n\
        } else if (u_what == 1) {\n\
            uvec2 b = luxSobol2Bits(t, u_sample, u_pass, u_seed);\n\
            o = vec4(halves(b.x), halves(b.y));\n\
        } else if (u_what == 2) {\n\
            o = vec4(luxSample2(LUX_SAMPLER_HASH, t, u_sample, u_pass, u_seed),\n\
                     luxSample2(LUX_SAMPLER_SOBOL, t, u_sample, u_pass, u_seed));\n\
        } else {\n\
            uvec2 size = uvec2(97u, 61u);\n\
            uint layer = uint(u_layer);\n\
            uvec2 s = u_what == 3\n\
                ? luxGatherStream(LUX_SAMPLER_SOBOL, size, layer, p.x, p.y, u_pass - 1u, u_sample)\n\
                : u_what == 4\n\
                ? luxRefineStream(LUX_SAMPLER_SOBOL, size, layer, p.x, p.y, u_seed, u_sample)\n\
                : luxGatherStream(LUX_SAMPLER_HASH, size, layer, p.x, p.y, u_pass - 1u, u_sample);\n\
            o = vec4(halves(s.x), halves(s.y));\n\
        }\n\
    }\n";

#[test]
fn rng_is_bit_exact() {
    use luxbake::rng::{Draw, Sampler, Stream, hash, sobol2_bits, texel_index, uniform2};
    let Some(ctx) = context_or_skip("rng_is_bit_exact") else {
        return;
    };
    let size = [97u32, 61];
    let halves = |h: u32| [(h & 0xffff) as f32, (h >> 16) as f32];
    for (sample, pass, seed, layer) in [
        (0u32, 1u32, 0u32, 0i32),
        (255, 3, 0xDEAD_BEEF, 5),
        (u32::MAX - 2, 2, 7, 1),
    ] {
        for what in 0..6 {
            let out = render(
                &ctx,
                "debug_rng",
                BvhMode::None,
                &[glsl_library(Library::Rng), RNG_FS],
                &[],
                |gl, p| {
                    p.set_u32(gl, "u_sample", sample);
                    p.set_u32(gl, "u_pass", pass);
                    p.set_u32(gl, "u_seed", seed);
                    p.set_i32(gl, "u_layer", layer);
                    p.set_i32(gl, "u_what", what);
                },
                size,
            );
            for y in 0..size[1] {
                for x in 0..size[0] {
                    let t = texel_index(size, layer as u32, x, y);
                    let expected: [f32; 4] = match what {
                        0 => {
                            let [a, b] = halves(hash(t, sample, pass, seed));
                            let [u0, u1] = uniform2(t, sample, pass, seed);
                            [a, b, u0, u1]
                        }
                        1 => {
                            let [bx, by] = sobol2_bits(t, sample, pass, seed);
                            let ([a, b], [c, d]) = (halves(bx), halves(by));
                            [a, b, c, d]
                        }
                        2 => {
                            let [h0, h1] = Sampler::Hash.uniform2(t, sample, pass, seed);
                            let [s0, s1] = Sampler::Sobol.uniform2(t, sample, pass, seed);
                            [h0, h1, s0, s1]
                        }
                        _ => {
                            let at = [layer as u32, x, y];
                            let s = match what {
                                3 => Stream::gather(Sampler::Sobol, size, at, pass - 1, sample),
                                4 => Stream::refine(Sampler::Sobol, size, at, seed, sample),
                                _ => Stream::gather(Sampler::Hash, size, at, pass - 1, sample),
                            };
                            let ([a, b], [c, d]) = (halves(s.key), halves(s.first));
                            [a, b, c, d]
                        }
                    };
                    let i = ((y * size[0] + x) * 4) as usize;
                    assert_eq!(
                        out[i..i + 4],
                        expected,
                        "texel ({x}, {y}) layer {layer}, sample {sample}, output {what}"
                    );
                }
            }
        }
    }
}

const IES_FS: &str = "uniform highp sampler2DArray u_dirs;\n\
    uniform int u_table;\n\
    uniform ivec2 u_size;\n\
    void main() {\n\
        vec3 d = texelFetch(u_dirs, luxTexel(), 0).xyz;\n\
        o_color = vec4(luxIesSample(u_table, u_size, d), luxProxySample(u_table, u_size.y, d),\n\
                       0.0, 1.0);\n\
    }\n";

#[test]
fn ies_sampling_and_the_density_proxy_match_the_cpu() {
    use luxbake_ies::{GpuTable, Photometry};
    let Some(ctx) = context_or_skip("ies_sampling_and_the_density_proxy_match_the_cpu") else {
        return;
    };
    // The repo's downlight (rotationally symmetric) and a random asymmetric table.
    let downlight = Photometry::parse(include_bytes!("../../../scene/lamps/luxbake_downlight.ies"))
        .unwrap()
        .gpu_table();
    let mut rng = SplitMix64::new(7);
    let (w, h) = (24u32, 13u32);
    let random = GpuTable {
        width: w,
        height: h,
        values: (0..w * h).map(|_| rng.range(0.0, 1000.0)).collect(),
    };
    let tables = [downlight, random];
    let size = [64u32, 64];
    let dirs = luxbake_testkit::photometric_test_directions(&mut rng, (size[0] * size[1]) as usize);
    let gl = ctx.gl().unwrap();
    let dir_tex = TextureArray::new(gl, "dirs", size[0], size[1], 1).unwrap();
    let data: Vec<f32> = dirs.iter().flat_map(|d| [d[0], d[1], d[2], 0.0]).collect();
    dir_tex.upload(gl, "dirs", 0, &data).unwrap();
    let caps = ctx.capabilities();
    let ies = crate::scene::ies_texture(gl, caps, &tables).unwrap();
    for (ti, table) in tables.iter().enumerate() {
        let out = render(
            &ctx,
            "debug_ies",
            BvhMode::None,
            &[
                glsl_library(Library::Common),
                glsl_library(Library::Ies),
                IES_FS,
            ],
            &[("u_dirs", &dir_tex), ("u_ies", &ies)],
            |gl, p| {
                p.set_i32(gl, "u_table", ti as i32);
                p.set_ivec2(gl, "u_size", [table.width as i32, table.height as i32]);
                p.set_i32(gl, "u_layer", 0);
            },
            size,
        );
        let max = table.values.iter().fold(0.0f32, |m, &v| m.max(v));
        let proxy = luxbake::lightpaths::DensityProxy::new(table);
        let (mut worst, mut worst_proxy) = (0.0f32, 0.0f32);
        for (i, d) in dirs.iter().enumerate() {
            let cpu = table.sample(*d);
            let err = (out[i * 4] - cpu).abs() / max;
            worst = worst.max(err);
            assert!(
                err <= 1e-5,
                "table {ti}, dir {d:?}: gpu {} cpu {cpu}",
                out[i * 4]
            );
            // The density proxy's grid, stored below the table.
            let cpu = proxy.sample(*d);
            let err = (out[i * 4 + 1] - cpu).abs() / max;
            worst_proxy = worst_proxy.max(err);
            assert!(
                err <= 1e-5,
                "table {ti}, dir {d:?}: gpu proxy {} cpu {cpu}",
                out[i * 4 + 1]
            );
        }
        assert!(
            dirs.iter()
                .enumerate()
                .filter(|&(i, _)| out[i * 4 + 1] > 0.1 * max)
                .count()
                > dirs.len() / 10,
            "table {ti}: the proxy read nothing"
        );
        eprintln!(
            "table {ti} ({}x{}): worst error {worst:e} of the maximum, its density proxy \
             {worst_proxy:e}",
            table.width, table.height
        );
    }
    ies.delete(gl);
    dir_tex.delete(gl);
}

#[test]
fn every_pass_program_compiles_for_every_traversal() {
    with_gl("every_pass_program_compiles_for_every_traversal", |gl| {
        for pass in Pass::ALL {
            for t in [BvhMode::Mtbvh, BvhMode::Tbvh, BvhMode::None] {
                for &v in Variant::of(pass) {
                    let (prefix, sources) = glsl_variant(pass, t, v);
                    let p = crate::gl::Program::new(gl, &v.label(pass), &prefix, &sources)
                        .unwrap_or_else(|e| panic!("{e}"));
                    p.delete(gl);
                }
            }
        }
    });
}

/// `source` (GLSL ES 3.00 as the GL backend compiles it, after the `#version` header) as the
/// Vulkan-flavoured GLSL 4.50 that naga's front end reads: every `sampler2DArray` becomes a
/// `texture2DArray` combined with one sampler by a macro of the same name, every other loose
/// uniform its own uniform block, the output a located `out`. The statements themselves are
/// untouched, so naga type-checks and validates exactly the code the driver compiles.
fn as_vulkan_glsl(source: &str) -> String {
    let mut out = String::from(
        "#version 450 core\nlayout(set = 0, binding = 0) uniform sampler lux_sampler;\n",
    );
    let mut binding = 1;
    for line in source.lines() {
        let code = line.split("//").next().unwrap_or("").trim();
        let words: Vec<&str> = code.trim_end_matches(';').split_whitespace().collect();
        match words.as_slice() {
            ["uniform", "highp", "sampler2DArray", name] if code.ends_with(';') => {
                out.push_str(&format!(
                    "layout(set = 0, binding = {binding}) uniform texture2DArray {name}_tex;\n\
                     #define {name} sampler2DArray({name}_tex, lux_sampler)\n"
                ));
            }
            ["uniform", ty, name] if code.ends_with(';') => {
                out.push_str(&format!(
                    "layout(set = 1, binding = {binding}) uniform Lux_{name} {{ {ty} {name}; }};\n"
                ));
            }
            ["out", "vec4", name] if code.ends_with(';') => {
                out.push_str(&format!("layout(location = 0) out vec4 {name};\n"));
            }
            ["precision", ..] => {}
            _ => {
                out.push_str(line);
                out.push('\n');
                continue;
            }
        }
        binding += 1;
    }
    out
}

#[test]
fn every_program_validates_with_naga_for_every_traversal() {
    let mut checked = 0;
    let variants: usize = Pass::ALL.iter().map(|&p| Variant::of(p).len()).sum();
    for pass in Pass::ALL {
        for t in [BvhMode::Mtbvh, BvhMode::Tbvh, BvhMode::None] {
            for &v in Variant::of(pass) {
                let (prefix, sources) = glsl_variant(pass, t, v);
                let glsl = std::iter::once(prefix.as_str())
                    .chain(sources)
                    .collect::<Vec<_>>()
                    .join("\n");
                let source = as_vulkan_glsl(&glsl);
                let label = format!("{} {t:?}", v.label(pass));
                let mut frontend = naga::front::glsl::Frontend::default();
                let options = naga::front::glsl::Options::from(naga::ShaderStage::Fragment);
                let module = frontend.parse(&options, &source).unwrap_or_else(|e| {
                    panic!("{label}: {}", e.emit_to_string(&source));
                });
                naga::valid::Validator::new(
                    naga::valid::ValidationFlags::all(),
                    naga::valid::Capabilities::all(),
                )
                .validate(&module)
                .unwrap_or_else(|e| panic!("{label}: {}", e.emit_to_string(&source)));
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 3 * variants);
    assert_eq!(
        variants,
        Pass::ALL.len() + 4,
        "the gather's trace and replay, the refine and connect passes' idle programs"
    );
    // The check can fail: an undeclared name is rejected.
    let (prefix, _) = program_sources(Pass::Copy, BvhMode::None);
    let broken = as_vulkan_glsl(&format!(
        "{prefix}out vec4 o_color;\nvoid main() {{ o_color = texelFetch(u_src, ivec3(0), 0) * u_missing; }}\n"
    ));
    let options = naga::front::glsl::Options::from(naga::ShaderStage::Fragment);
    assert!(
        naga::front::glsl::Frontend::default()
            .parse(&options, &broken)
            .is_err()
    );
}
