//! The converged method's denoiser is consistent (issue 29): on the box room's floor (4 × 2.5 ×
//! 3 m, albedo 0.5, a 10 cd isotropic lamp 2.25 m above the floor's centre, one bounce, 16
//! texels per metre) the denoised first bounce is measured against a reference luxbake did
//! not compute — the one-bounce integral evaluated by quadrature below — next to the raw
//! estimate of the same bake. As the rays grow the denoised error must follow the raw one
//! (within 1.2× at 1 024 and 4 096 rays), and the band of texels within three texels of the
//! walls, where the filter's kernel is one-sided, must not be biased (±0.5 %). A second case
//! has a steep gradient: a wall lit by a floor's bright spot at grazing angles (see
//! [`grazing_scene`]), its first bounce measured row by row.
//!
//! # The reference
//! The floor sees only the walls and the ceiling, lit directly by the lamp (`E = I cos θ / d²`,
//! nothing in between): their exitance is `M = ρ·E`. The floor's indirect illuminance at `p`
//! is `Σ M(patch)·F(p → patch)` over small patches of the walls and the ceiling, `F` the
//! configuration factor of a differential area at `p` to the patch, exact by Lambert's
//! contour integral `F = (1/2π) Σ_edges γᵢ (n̂ · (rᵢ × rᵢ₊₁)/|rᵢ × rᵢ₊₁|)` (γᵢ the angle
//! between `rᵢ` and `rᵢ₊₁`). Each patch's exitance is the mean over 2 × 2 Gauss points of it;
//! the wall patches are graded from 4 mm at the floor (where a texel 3 cm from the wall sees
//! the wall's bottom under a wide angle) to 5 cm. Checked here: the factors from any floor
//! point to the five faces sum to 1 (a closed box), and halving every patch changes the
//! reference at the floor's edge texels by under 0.02 % (the grazing case's below: 0.05 %).

use luxbake::bake::{BakeOutput, ObjectMaps};
use luxbake::gbuffer::rasterize;
use luxbake::scene::{Albedo, Blur, Object, Quality, Scene, Settings, Transform};
use luxbake::sources::builtin;
use luxbake::sources::meshes::{self, RoomAlbedo};

const SIZE: [f64; 3] = [4.0, 2.5, 3.0];
const RHO: f64 = 0.5;
const CANDELA: f64 = 10.0;
const LAMP: [f64; 3] = [0.0, 2.25, 0.0];
const TEXELS_PER_METRE: f32 = 16.0;

type V3 = [f64; 3];

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}

/// The default preset with `rays` and `blur` at `texels_per_metre`, one bounce, no tail, and
/// the padding (metres) of its denoised bake: raw and denoised bakes get the same layout, the
/// same texels.
fn one_bounce(rays: u32, blur: Blur, texels_per_metre: f32) -> (Settings, f32) {
    let settings = Settings {
        rays,
        bounces: 1,
        tail: false,
        blur,
        texels_per_metre,
        ..Settings::preset(Quality::Default)
    };
    let denoised = Settings {
        blur: Blur::Sigma(1.0),
        ..settings.clone()
    };
    (settings, builtin::padding_m(&denoised, 1.0))
}

/// The box room, one bounce, no tail.
fn box_room(rays: u32, blur: Blur) -> Scene {
    let (settings, padding) = one_bounce(rays, blur, TEXELS_PER_METRE);
    let size = SIZE.map(|s| s as f32);
    Scene {
        objects: vec![Object {
            name: "room".into(),
            mesh: meshes::room(size, RoomAlbedo::uniform([RHO as f32; 3]), padding),
            transform: Transform::IDENTITY,
            albedo: Albedo::grey(1.0),
            receiver: true,
            texel_scale: 1.0,
        }],
        lamps: vec![builtin::isotropic_lamp(CANDELA, LAMP)],
        settings,
    }
}

/// A patch of a wall or the ceiling: its corners, ordered so that the contour integral seen
/// from inside the room is positive, and its mean exitance.
struct Patch {
    corners: [V3; 4],
    exitance: f64,
}

/// `[0, len]` cut into cells: graded from `first` metres at 0 by `ratio` up to `most`, then
/// uniform (`graded = false`: uniform `most`).
fn cuts(len: f64, first: f64, ratio: f64, most: f64, graded: bool) -> Vec<f64> {
    let mut c = vec![0.0];
    let mut h = if graded { first } else { most };
    while *c.last().unwrap() < len - 1e-9 {
        let next = (c.last().unwrap() + h).min(len);
        // No sliver at the end.
        let next = if len - next < 0.5 * h { len } else { next };
        c.push(next);
        h = (h * ratio).min(most);
    }
    c
}

/// A rectangle of a surface: corner `origin`, sides along the unit vectors `u` and `v` of
/// lengths `lengths`, unit normal `normal` (toward the receivers).
struct Face {
    origin: V3,
    u: V3,
    v: V3,
    lengths: [f64; 2],
    normal: V3,
}

/// An isotropic lamp of `candela` at `position` lighting a surface of albedo `rho`.
#[derive(Clone, Copy)]
struct Light {
    candela: f64,
    position: V3,
    rho: f64,
}

/// `face` cut at `us` × `vs` (distances along `u` and `v`) into patches, each with the mean
/// exitance over 2 × 2 Gauss points under `light` (`None`: exitance 1, for the closed-box
/// check).
fn face_patches(face: &Face, us: &[f64], vs: &[f64], light: Option<Light>) -> Vec<Patch> {
    let g = 0.5 / 3f64.sqrt();
    let at = |a: f64, b: f64| -> V3 {
        [0, 1, 2].map(|k| face.origin[k] + a * face.u[k] + b * face.v[k])
    };
    let mut out = Vec::new();
    for j in 0..vs.len() - 1 {
        for i in 0..us.len() - 1 {
            let (a0, a1, b0, b1) = (us[i], us[i + 1], vs[j], vs[j + 1]);
            let exitance = match light {
                None => 1.0,
                Some(l) => {
                    let mut m = 0.0;
                    for ga in [0.5 - g, 0.5 + g] {
                        for gb in [0.5 - g, 0.5 + g] {
                            let q = at(a0 + ga * (a1 - a0), b0 + gb * (b1 - b0));
                            let d = sub(l.position, q);
                            let r = norm(d);
                            m += l.rho * l.candela * dot(face.normal, d).max(0.0) / (r * r * r);
                        }
                    }
                    m / 4.0
                }
            };
            let corners = [at(a0, b0), at(a1, b0), at(a1, b1), at(a0, b1)];
            out.push(Patch { corners, exitance });
        }
    }
    out
}

/// The box room's walls' and ceiling's patches, each `scale` times the size described in the
/// module docs, with their exitance (`uniform`: 1 everywhere, for the closed-box check).
fn patches(scale: f64, uniform: bool) -> Vec<Patch> {
    let [hx, hy, hz] = [SIZE[0] / 2.0, SIZE[1], SIZE[2] / 2.0];
    let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    let wall = |origin: V3, u: V3, length: f64, normal: V3| Face {
        origin,
        u,
        v: y,
        lengths: [length, hy],
        normal,
    };
    let faces = [
        wall([-hx, 0.0, -hz], x, 2.0 * hx, z),
        wall([-hx, 0.0, hz], x, 2.0 * hx, [0.0, 0.0, -1.0]),
        wall([-hx, 0.0, -hz], z, 2.0 * hz, x),
        wall([hx, 0.0, -hz], z, 2.0 * hz, [-1.0, 0.0, 0.0]),
        Face {
            origin: [-hx, hy, -hz],
            u: x,
            v: z,
            lengths: [2.0 * hx, 2.0 * hz],
            normal: [0.0, -1.0, 0.0],
        },
    ];
    let light = (!uniform).then_some(Light {
        candela: CANDELA,
        position: LAMP,
        rho: RHO,
    });
    let mut out = Vec::new();
    for (k, face) in faces.iter().enumerate() {
        let us = cuts(face.lengths[0], 0.05 * scale, 1.0, 0.05 * scale, false);
        // Walls are graded toward the floor, where the floor's edge texels see them closest.
        let vs = cuts(face.lengths[1], 0.004 * scale, 1.25, 0.05 * scale, k < 4);
        out.extend(face_patches(face, &us, &vs, light));
    }
    out
}

/// Configuration factor from a differential area at `p` with unit normal `n` to the polygon
/// `corners`, which lies wholly in front of it (Lambert's contour integral; its sign follows
/// the corners' order, so the magnitude is taken).
fn factor(p: V3, n: V3, corners: &[V3; 4]) -> f64 {
    let mut sum = 0.0;
    for i in 0..4 {
        let (a, b) = (sub(corners[i], p), sub(corners[(i + 1) % 4], p));
        let c = cross(a, b);
        let cn = norm(c);
        if cn == 0.0 {
            continue;
        }
        let gamma = cn.atan2(dot(a, b));
        sum += gamma * dot(n, c) / cn;
    }
    sum.abs() / (2.0 * std::f64::consts::PI)
}

/// The reference indirect illuminance at each of `points` (normal `n`) from `patches`.
fn reference_at(points: &[V3], n: V3, patches: &[Patch]) -> Vec<f64> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = points.len().div_ceil(threads).max(1);
    std::thread::scope(|s| {
        let jobs: Vec<_> = points
            .chunks(chunk)
            .map(|ps| {
                s.spawn(move || {
                    ps.iter()
                        .map(|&p| {
                            patches
                                .iter()
                                .map(|q| q.exitance * factor(p, n, &q.corners))
                                .sum::<f64>()
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        jobs.into_iter()
            .flat_map(|j| j.join().expect("thread"))
            .collect()
    })
}

/// The box room's reference at floor points.
fn reference(points: &[V3], patches: &[Patch]) -> Vec<f64> {
    reference_at(points, [0.0, 1.0, 0.0], patches)
}

/// A floor texel: its map coordinates, its G-buffer position and its distance from the
/// nearest wall, in texels.
struct FloorTexel {
    x: u32,
    y: u32,
    p: V3,
    wall_texels: f64,
}

fn floor_texels(scene: &Scene, out: &BakeOutput) -> Vec<FloorTexel> {
    let g = rasterize(scene, &out.layout);
    let maps = &out.maps[0];
    let r = maps.region;
    let mut texels = Vec::new();
    for y in 0..r.size[1] {
        for x in 0..r.size[0] {
            let i = g.index(r.layer, r.offset[0] + x, r.offset[1] + y);
            if g.position[i + 3] <= 0.5 || g.normal[i + 1] < 0.9 {
                continue;
            }
            let p = [0, 1, 2].map(|k| f64::from(g.position[i + k]));
            let wall = (SIZE[0] / 2.0 - p[0].abs()).min(SIZE[2] / 2.0 - p[2].abs());
            texels.push(FloorTexel {
                x,
                y,
                p: [p[0], 0.0, p[2]],
                wall_texels: wall * f64::from(TEXELS_PER_METRE),
            });
        }
    }
    texels
}

/// Photometric Y of the indirect illuminance (total − direct) at texel `(x, y)` of `maps`.
fn indirect_at(maps: &ObjectMaps, x: u32, y: u32) -> f64 {
    let lum = |v: [f32; 4]| {
        0.2126 * f64::from(v[0]) + 0.7152 * f64::from(v[1]) + 0.0722 * f64::from(v[2])
    };
    lum(maps.illuminance().texel(x, y)) - lum(maps.direct().texel(x, y))
}

/// The indirect illuminance of the floor texels.
fn indirect(out: &BakeOutput, texels: &[FloorTexel]) -> Vec<f64> {
    texels
        .iter()
        .map(|t| indirect_at(&out.maps[0], t.x, t.y))
        .collect()
}

/// Relative RMSE, and the mean relative error of the texels nearer than 3 texels to a wall
/// and of the others.
fn errors(got: &[f64], want: &[f64], texels: &[FloorTexel]) -> (f64, f64, f64) {
    let (mut sq, mut band, mut nb, mut inner, mut ni) = (0.0, 0.0, 0, 0.0, 0);
    for ((g, w), t) in got.iter().zip(want).zip(texels) {
        let e = g / w - 1.0;
        sq += e * e;
        if t.wall_texels < 3.0 {
            band += e;
            nb += 1;
        } else {
            inner += e;
            ni += 1;
        }
    }
    assert!(nb > 100 && ni > 1000, "{nb} band, {ni} inner texels");
    (
        (sq / got.len() as f64).sqrt(),
        band / f64::from(nb),
        inner / f64::from(ni),
    )
}

#[test]
fn the_reference_quadrature_closes_the_box_and_has_converged() {
    let uniform = patches(1.0, true);
    for p in [
        [0.0, 0.0, 0.0],
        [1.97, 0.0, 1.47],
        [-1.99, 0.0, 0.3],
        [0.5, 0.0, -1.49],
    ] {
        let f: f64 = reference(&[p], &uniform)[0];
        assert!((f - 1.0).abs() < 1e-9, "{p:?}: {f}");
    }
    let edge = [
        [1.97, 0.0, 0.2],
        [0.1, 0.0, -1.47],
        [1.97, 0.0, 1.47],
        [0.0; 3],
    ];
    let (a, b) = (
        reference(&edge, &patches(1.0, false)),
        reference(&edge, &patches(0.5, false)),
    );
    for (x, y) in a.iter().zip(&b) {
        assert!((x / y - 1.0).abs() < 2e-4, "{x} vs {y}");
    }
    // The grazing case's wall, from its foot up.
    let wall = [
        [0.0, 0.001, -1.5],
        [0.0, 0.03, -1.5],
        [0.0, 0.2, -1.5],
        [1.9, 0.001, -1.5],
        [-1.0, 0.45, -1.5],
    ];
    let n = [0.0, 0.0, 1.0];
    let (a, b) = (
        reference_at(&wall, n, &grazing_patches(GRAZING_PATCH_SCALE)),
        reference_at(&wall, n, &grazing_patches(GRAZING_PATCH_SCALE / 2.0)),
    );
    for (x, y) in a.iter().zip(&b) {
        println!("grazing reference {x} vs {y} with patches halved");
        assert!((x / y - 1.0).abs() < 5e-4, "{x} vs {y}");
    }
}

/// The indirect illuminance of the floor's texels of `scene`'s bake and the reference at
/// their positions (`cache`: the last positions and reference, reused when a bake has the
/// same texels).
fn floor_errors(scene: &Scene, cache: &mut Option<(Vec<V3>, Vec<f64>)>) -> (f64, f64, f64) {
    let out = luxbake_backend_cpu::bake(scene).expect("bake");
    let texels = floor_texels(scene, &out);
    let points: Vec<V3> = texels.iter().map(|t| t.p).collect();
    if cache.as_ref().is_none_or(|(p, _)| *p != points) {
        let want = reference(&points, &patches(1.0, false));
        *cache = Some((points, want));
    }
    let want = &cache.as_ref().expect("reference").1;
    let got = indirect(&out, &texels);
    let mut line = String::from("  bias by texels from a wall:");
    for (lo, hi) in [
        (0.0, 0.6),
        (0.6, 1.6),
        (1.6, 2.6),
        (2.6, 4.0),
        (4.0, 8.0),
        (8.0, 1e9),
    ] {
        let (mut b, mut n) = (0.0, 0);
        for i in 0..texels.len() {
            if (lo..hi).contains(&texels[i].wall_texels) {
                b += got[i] / want[i] - 1.0;
                n += 1;
            }
        }
        line += &format!(" [{lo}, {hi}) {:+.2} %", 100.0 * b / f64::from(n.max(1)));
    }
    println!("{line}");
    errors(&got, want, &texels)
}

#[test]
fn the_denoised_first_bounce_follows_the_raw_one_as_rays_grow() {
    let mut cache = None;
    let mut report = Vec::new();
    for rays in [1024u32, 4096] {
        let (raw_rmse, raw_band, raw_inner) = floor_errors(&box_room(rays, Blur::None), &mut cache);
        let (den_rmse, den_band, den_inner) =
            floor_errors(&box_room(rays, Blur::Sigma(1.0)), &mut cache);
        println!(
            "{rays} rays: relative RMSE raw {:.3} %, denoised {:.3} % ({:.2}×); bias within 3 \
             texels of the walls raw {:+.3} %, denoised {:+.3} %; inside raw {:+.3} %, \
             denoised {:+.3} %",
            100.0 * raw_rmse,
            100.0 * den_rmse,
            den_rmse / raw_rmse,
            100.0 * raw_band,
            100.0 * den_band,
            100.0 * raw_inner,
            100.0 * den_inner
        );
        report.push((rays, raw_rmse, den_rmse, den_band, den_inner));
    }
    for (rays, raw, den, band, inner) in report {
        assert!(den <= 1.2 * raw, "{rays} rays: denoised {den} vs raw {raw}");
        assert!(band.abs() < 0.005, "{rays} rays: edge band bias {band}");
        assert!(inner.abs() < 0.005, "{rays} rays: inner bias {inner}");
    }
}

/// The grazing case: a floor (4 × 3 m, albedo 0.5) and one wall standing on its far edge,
/// lit by a 100 cd isotropic lamp 0.3 m above the floor and 0.3 m in front of the wall. The
/// floor's exitance peaks under the lamp and the wall sees it at grazing angles, so the
/// wall's first bounce falls steeply with height over its lowest half metre.
fn grazing_scene(rays: u32, blur: Blur) -> Scene {
    let (settings, padding) = one_bounce(rays, blur, GRAZING_TEXELS_PER_METRE);
    let plane = |name: &str, size: [f32; 2], transform: Transform| Object {
        name: name.into(),
        mesh: meshes::plane(size, padding),
        transform,
        albedo: Albedo::grey(0.5),
        receiver: true,
        texel_scale: 1.0,
    };
    Scene {
        objects: vec![
            plane("floor", [4.0, 3.0], Transform::IDENTITY),
            plane(
                "wall",
                [4.0, 2.5],
                Transform::from_trs([0.0, 1.25, -1.5], [90.0, 0.0, 0.0], [1.0; 3]),
            ),
        ],
        lamps: vec![builtin::isotropic_lamp(100.0, GRAZING_LAMP)],
        settings,
    }
}

const GRAZING_LAMP: V3 = [0.0, 0.3, -1.2];
const GRAZING_TEXELS_PER_METRE: f32 = 32.0;
/// The grazing case's floor patches: 1.25 cm across, 1 mm to 1.25 cm deep from the wall out.
const GRAZING_PATCH_SCALE: f64 = 0.5;

/// The grazing case's floor patches, graded toward the wall.
fn grazing_patches(scale: f64) -> Vec<Patch> {
    let floor = Face {
        origin: [-2.0, 0.0, -1.5],
        u: [1.0, 0.0, 0.0],
        v: [0.0, 0.0, 1.0],
        lengths: [4.0, 3.0],
        normal: [0.0, 1.0, 0.0],
    };
    let us = cuts(4.0, 0.025 * scale, 1.0, 0.025 * scale, false);
    let vs = cuts(3.0, 0.002 * scale, 1.25, 0.025 * scale, true);
    let light = Light {
        candela: 100.0,
        position: GRAZING_LAMP,
        rho: 0.5,
    };
    face_patches(&floor, &us, &vs, Some(light))
}

/// Per row of the wall's lowest half metre (texels above the floor), the mean relative error
/// of the wall's indirect illuminance against the quadrature, and the relative RMSE over the
/// rows.
fn grazing_rows(
    rays: u32,
    blur: Blur,
    reference: &mut Option<(Vec<V3>, Vec<f64>)>,
) -> (Vec<f64>, f64) {
    grazing_rows_of(grazing_scene(rays, blur), reference)
}

/// [`grazing_rows`] of a grazing scene.
fn grazing_rows_of(scene: Scene, reference: &mut Option<(Vec<V3>, Vec<f64>)>) -> (Vec<f64>, f64) {
    let out = luxbake_backend_cpu::bake(&scene).expect("bake");
    let g = rasterize(&scene, &out.layout);
    let maps = &out.maps[1];
    assert_eq!(maps.name, "wall");
    let r = maps.region;
    let rows = (0.5 * GRAZING_TEXELS_PER_METRE) as usize;
    let mut texels = Vec::new();
    for y in 0..r.size[1] {
        for x in 0..r.size[0] {
            let i = g.index(r.layer, r.offset[0] + x, r.offset[1] + y);
            let p = [0, 1, 2].map(|k| f64::from(g.position[i + k]));
            let row = (p[1] * f64::from(GRAZING_TEXELS_PER_METRE)) as usize;
            if g.position[i + 3] > 0.5 && g.normal[i + 2] > 0.9 && row < rows {
                texels.push((x, y, p, row));
            }
        }
    }
    let points: Vec<V3> = texels.iter().map(|t| t.2).collect();
    if reference.as_ref().is_none_or(|(p, _)| *p != points) {
        let want = reference_at(
            &points,
            [0.0, 0.0, 1.0],
            &grazing_patches(GRAZING_PATCH_SCALE),
        );
        *reference = Some((points, want));
    }
    let want = &reference.as_ref().expect("reference").1;
    let (mut sum, mut n, mut sq) = (vec![0.0; rows], vec![0usize; rows], 0.0);
    for (t, w) in texels.iter().zip(want) {
        let got = indirect_at(maps, t.0, t.1);
        let err = got / w - 1.0;
        sum[t.3] += err;
        n[t.3] += 1;
        sq += err * err;
    }
    assert!(n.iter().all(|&n| n >= 100), "{n:?} texels per row");
    let rows: Vec<f64> = sum.iter().zip(&n).map(|(s, &n)| s / n as f64).collect();
    (rows, (sq / texels.len() as f64).sqrt())
}

/// The wall's first bounce under the grazing case, raw and through the à-trous filter alone
/// (the default's denoiser without its bias correction, the next test's subject), at the
/// default preset's 8 rays and at 64 and 1 024: the filtered rows' bias falls as the rays grow
/// (the filter is consistent on a steep gradient too), and from 1 024 rays on every row is
/// within 1 % and the filtered error under 1.2× the raw one. At 8 rays the rows over the
/// lowest 10 cm are still a few per cent low (the early iterations' wide luminance term
/// averages across the gradient's curvature), which the correction takes out.
#[test]
fn a_wall_lit_at_grazing_incidence_keeps_its_steep_first_bounce() {
    let mut reference = None;
    let mut mean_bias = Vec::new();
    for rays in [8, 64, 1024] {
        let (raw, raw_rmse) = grazing_rows(rays, Blur::None, &mut reference);
        let mut filtered = grazing_scene(rays, Blur::Sigma(1.0));
        filtered.settings.denoise_correction = false;
        let (den, den_rmse) = grazing_rows_of(filtered, &mut reference);
        let want = &reference.as_ref().expect("reference").1;
        let worst = den.iter().fold(0.0f64, |m, b| m.max(b.abs()));
        let mean = den.iter().map(|b| b.abs()).sum::<f64>() / den.len() as f64;
        println!(
            "{rays} rays: the wall's lowest 0.5 m ({:.2} … {:.2} lx): relative RMSE raw {:.2} %, \
             denoised {:.2} %; denoised rows' bias mean |·| {:.2} %, worst {:.2} %",
            want.iter().cloned().fold(f64::INFINITY, f64::min),
            want.iter().cloned().fold(0.0, f64::max),
            100.0 * raw_rmse,
            100.0 * den_rmse,
            100.0 * mean,
            100.0 * worst
        );
        for (k, (r, d)) in raw.iter().zip(&den).enumerate() {
            println!(
                "  row {k}: raw {:+.3} %, denoised {:+.3} %",
                100.0 * r,
                100.0 * d
            );
        }
        assert!(den_rmse < raw_rmse, "{rays} rays: {den_rmse} vs {raw_rmse}");
        if rays >= 1024 {
            assert!(den_rmse <= 1.2 * raw_rmse, "{rays} rays");
            assert!(worst < 0.01, "{rays} rays: a row {worst} off");
        } else {
            assert!(worst < 0.04, "{rays} rays: a row {worst} off");
        }
        mean_bias.push(mean);
    }
    assert!(
        mean_bias.windows(2).all(|w| w[1] < w[0]),
        "the rows' bias does not fall with the rays: {mean_bias:?}"
    );
}

/// A scene with the denoiser's bias correction on ([`Settings::denoise_correction`], as the
/// default preset has it).
fn corrected(mut scene: Scene) -> Scene {
    scene.settings.denoise_correction = true;
    scene
}

/// Seeds over which the grazing case's rows are averaged in the correction's test.
const GRAZING_SEEDS: u32 = 3;

/// The denoiser's bias correction against the same independent quadratures: on the box
/// room's floor it keeps what the denoiser keeps (at 1 024 and 4 096 rays at most 1.2× the raw
/// estimate's relative RMSE, the bias within 3 texels of the walls and inside within 0.5 %),
/// and on the wall lit at grazing incidence, where the light bends within a few texels, its
/// rows over three seeds are less than half as biased as without it at the default's 8 rays
/// (within 0.5 % of the closed form on average) and at 1 024, about as biased at 64 (where it
/// overshoots), and converge as the rays grow.
#[test]
fn the_bias_correction_keeps_the_closed_forms() {
    let mut cache = None;
    for rays in [1024u32, 4096] {
        let (raw, _, _) = floor_errors(&box_room(rays, Blur::None), &mut cache);
        let (rmse, band, inner) =
            floor_errors(&corrected(box_room(rays, Blur::Sigma(1.0))), &mut cache);
        println!(
            "{rays} rays, corrected: relative RMSE {:.3} % ({:.2}× raw); bias within 3 texels \
             of the walls {:+.3} %, inside {:+.3} %",
            100.0 * rmse,
            rmse / raw,
            100.0 * band,
            100.0 * inner
        );
        assert!(
            rmse <= 1.2 * raw,
            "{rays} rays: corrected {rmse} vs raw {raw}"
        );
        assert!(band.abs() < 0.005, "{rays} rays: edge band bias {band}");
        assert!(inner.abs() < 0.005, "{rays} rays: inner bias {inner}");
    }
    let mut reference = None;
    let mut means = Vec::new();
    for rays in [8, 64, 1024] {
        let mean = |rows: &[f64]| rows.iter().map(|b| b.abs()).sum::<f64>() / rows.len() as f64;
        // A row's bias over three seeds: one bake's row means still carry its noise (a few
        // tenths of a per cent at 64 rays), which hid the bias in either direction.
        let mut over_seeds = |correction: bool| {
            let mut sum: Vec<f64> = Vec::new();
            let mut rmse = 0.0;
            for seed in 0..GRAZING_SEEDS {
                let mut scene = grazing_scene(rays, Blur::Sigma(1.0));
                scene.settings.seed = seed;
                scene.settings.denoise_correction = correction;
                let (rows, e) = grazing_rows_of(scene, &mut reference);
                sum.resize(rows.len(), 0.0);
                sum.iter_mut().zip(&rows).for_each(|(s, r)| *s += r);
                rmse += e;
            }
            let n = f64::from(GRAZING_SEEDS);
            (sum.iter().map(|s| s / n).collect::<Vec<f64>>(), rmse / n)
        };
        let (plain, _) = over_seeds(false);
        let (rows, rmse) = over_seeds(true);
        let (_, raw_rmse) = grazing_rows(rays, Blur::None, &mut reference);
        println!(
            "{rays} rays at grazing incidence, {GRAZING_SEEDS} seeds: rows' bias mean |·| \
             {:.2} % corrected, {:.2} % without; relative RMSE {:.2} % corrected, {:.2} % raw",
            100.0 * mean(&rows),
            100.0 * mean(&plain),
            100.0 * rmse,
            100.0 * raw_rmse
        );
        // The correction is applied and at the default's 8 rays and at 1 024 lowers the rows'
        // bias by half or more (measured over three seeds: 0.42 against 1.12 %, 0.09 against
        // 0.27 %). At 64 rays it overshoots: the rows read +0.4 % on average where the filter
        // alone reads −0.5 % (0.58 against 0.54 % mean |·|), as the narrower luminance term
        // leaves less to correct and the wide linear filter spreads the lowest rows' residual
        // up the wall.
        if rays == 64 {
            assert!(mean(&rows) < 1.25 * mean(&plain), "{rays} rays");
        } else {
            assert!(mean(&rows) < 0.5 * mean(&plain), "{rays} rays");
        }
        // Issue 29: at the default (8 rays) within 0.5 % of the closed form, row by row on
        // average.
        if rays == 8 {
            assert!(mean(&rows) < 0.005, "{rays} rays: {}", mean(&rows));
        }
        assert!(rmse < raw_rmse, "{rays} rays: {rmse} vs {raw_rmse}");
        means.push(mean(&rows));
    }
    // It converges: at 1 024 rays under half of what it is at 8 or 64.
    assert!(
        means[2] < 0.5 * means[0].min(means[1]),
        "the rows' bias does not fall with the rays: {means:?}"
    );
}
