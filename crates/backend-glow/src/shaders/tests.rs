//! The shader library against its CPU originals, through small debug passes rendered into
//! float targets.

use luxbake_bvh::{BuildOptions, Bvh, EncodeOptions, Ray, TriangleAttributes, encode};

use super::{BVH, Traversal};
use crate::gl::TextureArray;
use crate::scene::BvhTextures;
use crate::testutil::{TestRng, context_or_skip, render};

const TRACE_FS: &str = "uniform highp sampler2DArray u_rays;\n\
    uniform float u_tmax;\n\
    uniform int u_any;\n\
    out vec4 o;\n\
    void main() {\n\
        ivec2 p = ivec2(gl_FragCoord.xy);\n\
        vec3 org = texelFetch(u_rays, ivec3(p, 0), 0).xyz;\n\
        vec3 dir = texelFetch(u_rays, ivec3(p, 1), 0).xyz;\n\
        vec3 hit;\n\
        int best = luxTrace(org, dir, 0.0, u_tmax, u_any != 0, hit);\n\
        o = vec4(hit, float(best));\n\
    }\n";

/// Random triangles in a 4 m box plus a closed box of 12 triangles around part of it.
fn scene(seed: u64, n: usize) -> Vec<[[f32; 3]; 3]> {
    let mut rng = TestRng(seed);
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
    let mut rng = TestRng(seed);
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
    for traversal in [Traversal::Mtbvh, Traversal::Tbvh, Traversal::None] {
        let cpu_mode = match traversal {
            Traversal::Mtbvh => luxbake_bvh::Traversal::Mtbvh,
            Traversal::Tbvh => luxbake_bvh::Traversal::Tbvh,
            Traversal::None => luxbake_bvh::Traversal::BruteForce,
        };
        let mut samplers = bvh_tex.samplers(traversal);
        samplers.push(("u_rays", &ray_tex));
        for any in [false, true] {
            let out = render(
                &ctx,
                "debug_trace",
                traversal,
                &[BVH, TRACE_FS],
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
