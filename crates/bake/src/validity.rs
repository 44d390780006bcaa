//! Texel validity: texels inside geometry (the floor under a chair leg or a sofa's base, a
//! wall behind furniture that touches it) are moved out of the occluder, or else made empty.
//!
//! # Decision: on the CPU, at G-buffer time, for every backend
//! [`unocclude`] runs once after the G-buffer is rasterised and the BVH encoded, before any
//! backend uploads the G-buffer, so glow, wgpu and the CPU backend see the same valid texels
//! and the same positions (as they see one rasteriser's output; [`crate::gbuffer`]).
//!
//! # The rule (Unity's back-face tolerance with Godot's unocclude)
//! For every valid texel at position `p` with unit normal `n` (its object at density
//! `texels_per_metre × texel_scale`, texel size `s` metres):
//! 1. **Test.** [`TEST_RAYS`] cosine-weighted directions about `n` (Malley's method by
//!    rejection from the hash sampler of [`crate::rng`], texel index as for the gather, pass
//!    [`RNG_PASS`], seed 0: fixed per texel and bake, identical in native and wasm32 builds)
//!    are cast from `p` offset as the gather offsets it ([`offset_origin`]). A hit is a back face when the triangle's geometric normal (its
//!    counter-clockwise winding) points along the ray. The texel is **occluded** when more than
//!    [`BACK_FACE_TOLERANCE`] of the rays hit a back face within [`TEST_REACH_TEXELS`]` · s`
//!    (the test stops once the answer is known). The short reach keeps the test cheap and
//!    local: texels deep under a large closed object (farther than the reach from its walls)
//!    stay valid and dark, as they are.
//! 2. **Unocclude.** For an occluded texel, [`PUSH_DIRECTIONS`] directions in its tangent
//!    plane (every 45°, from the basis of [`crate::exact::basis`]) are cast from the offset
//!    origin up to `s` (a texel: how far conservative rasterisation reaches past a chart edge).
//!    The nearest back-face hit `t` gives the candidate `p + d·(t + margin)`, `margin =
//!    `[`PUSH_MARGIN`]` · s` (half a texel: past the occluder's wall, on the same plane, and
//!    far enough from it that gather rays do not meet its edges at exact ties). If the test
//!    of step 1 passes there, the texel keeps that position (normal and albedo unchanged).
//! 3. Otherwise the texel is made **empty** (position, normal and albedo all zero, as texels
//!    no chart covers): no pass computes it, the filters and the gather's masked look-up skip
//!    it, and the written maps fill it by dilation where it lies within the padding's reach of
//!    a valid texel (`luxbake-output`).
//!
//! 4. **Narrow.** Every texel still valid then casts one ray along `n` from the offset origin,
//!    up to [`NARROW_REACH_TEXELS`]` · s`: where it meets any surface (the back of a bookcase
//!    2.5 cm from its wall, the wall behind it, a floor under a low plinth), the texel faces
//!    another surface across a gap a few texels wide and its position's w becomes
//!    [`NARROW`] (still valid: every pass tests w > 0.5). The light in such a gap changes over a
//!    texel or two, faster than a reduced-resolution gather's grid can follow: the coarse
//!    gathers trace these texels themselves, as orphans ([`crate::contract::coarse`]). Where
//!    the surface met also lies within [`GAP_FRACTION`] of the room's size, and four rays
//!    tilted 45° off the normal toward the texel's tangent directions meet a surface within
//!    the same distance of its plane (the gap is closed to every side: the back of a bookcase
//!    against a wall, not a chair's slats or legs facing each other, nor a wall behind a thin
//!    bar), w becomes [`NARROW_GAP`] (still narrow: w ≥ [`NARROW`]): light reaches such a gap
//!    through the few directions that leave it, and these texels get more rays in every bounce
//!    ([`crate::scene::Settings::narrow_rays`]). The tilted rays cut the texels in gaps of
//!    `chairs_05` at 24 texels per metre from 1 330 to 200 and leave the real rooms' bookcase,
//!    sideboard and cabinet gaps as they were (lounge 19 918 → 19 333, dining 11 385 →
//!    10 967, office 11 005 → 9 960; docs/performance.md).
//!
//! Only receivers' texels are tested; non-receivers still occlude. As with Unity's back-face
//! tolerance, a texel that mostly sees the back of one-sided geometry (under a single-sided
//! plane facing up, behind a wall of an open model, or anywhere in a mesh with inverted
//! winding) is made empty too.

use luxbake_bvh::{EncodedScene, Ray, WideBvh};
use rayon::prelude::*;

use crate::backend::{SceneBvh, offset_origin};
use crate::exact::{basis, cross, dot, mad, normalize, sub};
use crate::gbuffer::GBuffer;
use crate::program::RowKind;

use crate::rng;
use crate::scene::Scene;

/// Rays of the back-face test per texel.
pub const TEST_RAYS: u32 = 8;
/// How far the test rays look, in texels of the object's density.
pub const TEST_REACH_TEXELS: f32 = 32.0;
/// Largest fraction of back-face hits of a valid texel.
pub const BACK_FACE_TOLERANCE: f32 = 0.5;
/// Tangent directions tried when pushing a texel out of its occluder: every 45°, as
/// `(cos, sin)` constants (no `sin`/`cos` call, whose last bit differs between the native and
/// the wasm32 maths libraries: the G-buffer is computed on either).
pub const PUSH_DIRECTIONS: [[f32; 2]; 8] = {
    let h = std::f32::consts::FRAC_1_SQRT_2;
    [
        [1.0, 0.0],
        [h, h],
        [0.0, 1.0],
        [-h, h],
        [-1.0, 0.0],
        [-h, -h],
        [0.0, -1.0],
        [h, -h],
    ]
};
/// Draws per test direction before it falls back to the normal (a draw is kept with
/// probability π/4: all 16 miss with probability 2·10⁻¹¹).
pub const DISK_DRAWS: u32 = 16;
/// How far past the occluder's wall a pushed texel lands, in texels.
pub const PUSH_MARGIN: f32 = 0.5;
/// The RNG pass of the test's directions (no bake pass uses it).
pub const RNG_PASS: u32 = 0xF00D;
/// How far a texel's normal ray looks for a surface facing it (step 4), in texels: a gap up to
/// 1.5 grid cells of the default's later bounces (stride 4), 9.4 cm at 64 texels per metre.
pub const NARROW_REACH_TEXELS: f32 = 6.0;
/// The position's w of a valid texel that faces another surface within
/// [`NARROW_REACH_TEXELS`] (module docs, step 4); 1 for the other valid texels.
pub const NARROW: f32 = 2.0;
/// The position's w of a narrow texel ([`NARROW`]) whose gap is also narrow against the room
/// and closed to its sides: the surface it faces lies within [`GAP_FRACTION`] of the room's
/// size, and so do the surfaces its rays tilted 45° meet (module docs, step 4). Such texels get
/// more rays in every bounce ([`crate::scene::Settings::narrow_rays`]).
pub const NARROW_GAP: f32 = 3.0;
/// A narrow texel's gap counts against the room ([`NARROW_GAP`]) when it is at most this
/// fraction of the largest side of the valid texels' bounding box: 1/64, 7.8 cm in a room 5 m
/// long (the back of a bookcase, a cabinet or a sideboard standing 2.5–7.5 cm from a wall),
/// not a chair's seat over its crossbars. A fraction, so that a room bakes alike at any scale.
pub const GAP_FRACTION: f32 = 1.0 / 64.0;

/// What [`unocclude`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Unoccluded {
    /// Valid texels tested.
    pub tested: u64,
    /// Texels moved out of an occluder.
    pub moved: u64,
    /// Texels made empty.
    pub removed: u64,
    /// Valid texels facing another surface within [`NARROW_REACH_TEXELS`] (marked [`NARROW`]
    /// or [`NARROW_GAP`]).
    pub narrow: u64,
    /// Of those, the texels whose gap is narrow against the room (marked [`NARROW_GAP`]).
    pub gaps: u64,
}

/// The distance to the first hit along `dir` from `o` within `t_max`, and whether it is a back
/// face.
fn first_hit(
    (bvh, wide): (&EncodedScene, &WideBvh),
    o: [f32; 3],
    dir: [f32; 3],
    t_max: f32,
) -> Option<(f32, bool)> {
    let hit = wide.closest_hit(&Ray { origin: o, dir }, 0.0, t_max)?;
    let [a, b, c] = bvh.triangle_positions(hit.triangle);
    let ng = cross(sub(b, a), sub(c, a));
    Some((hit.t, dot(ng, dir) > 0.0))
}

/// Whether more than [`BACK_FACE_TOLERANCE`] of the test rays from `p` hit a back face within
/// `reach`. Stops as soon as the answer is known (an open texel needs half the rays).
fn occluded(
    bvh: (&EncodedScene, &WideBvh),
    texel: u32,
    (p, n): ([f32; 3], [f32; 3]),
    eps: f32,
    reach: f32,
) -> bool {
    let o = offset_origin(p, n, eps);
    let limit = (BACK_FACE_TOLERANCE * TEST_RAYS as f32).floor() as u32;
    let (mut back, mut other) = (0u32, 0u32);
    for s in 0..TEST_RAYS {
        let dir = test_direction(n, texel, s);
        if let Some((_, true)) = first_hit(bvh, o, dir, reach) {
            back += 1;
            if back > limit {
                return true;
            }
        } else {
            other += 1;
            if other >= TEST_RAYS - limit {
                return false;
            }
        }
    }
    false
}

/// Test ray `s` of `texel`: cosine-weighted about the unit normal `n` by Malley's method, a
/// uniform point of the unit disk (rejection from the square, draws of the hash sampler at
/// indices `s·DISK_DRAWS + j`) lifted onto the hemisphere. Only multiplications, additions
/// and a square root, so native and wasm32 builds draw the same directions bit for bit.
fn test_direction(n: [f32; 3], texel: u32, s: u32) -> [f32; 3] {
    let (t, b) = basis(n);
    for j in 0..DISK_DRAWS {
        let [u0, u1] = rng::uniform2(texel, s * DISK_DRAWS + j, RNG_PASS, 0);
        let (x, y) = (2.0 * u0 - 1.0, 2.0 * u1 - 1.0);
        let r2 = x * x + y * y;
        if r2 < 1.0 {
            let z = (1.0 - r2).sqrt();
            return [0, 1, 2].map(|c| x * t[c] + y * b[c] + z * n[c]);
        }
    }
    n
}

/// The outcome for one texel.
enum Outcome {
    Keep,
    Move([f32; 3]),
    Remove,
}

/// Tests every valid texel of `g` and moves or removes the occluded ones (module docs).
/// `eps` is the ray offset's size term ([`crate::backend::ray_epsilon`]).
pub fn unocclude(g: &mut GBuffer, scene: &Scene, bvh: &SceneBvh, eps: f32) -> Unoccluded {
    // Always the 8-wide BVH (the fastest CPU traversal), whatever the bake's `bvh` setting, so
    // the G-buffer does not depend on it (traversals differ only at exact ties).
    let bvh = (&*bvh.encoded, &*bvh.wide);
    let (w, h) = (g.layer_size[0], g.layer_size[1]);
    let texels = g.layers as usize * w as usize * h as usize;
    let outcomes: Vec<(usize, Outcome)> = (0..texels)
        .into_par_iter()
        .filter(|&i| g.position[4 * i + 3] > 0.5)
        .map(|i| {
            let pw = &g.position[4 * i..4 * i + 4];
            let nw = &g.normal[4 * i..4 * i + 4];
            let p = [pw[0], pw[1], pw[2]];
            let n = [nw[0], nw[1], nw[2]];
            let Some(n) = normalize(n) else {
                return (i, Outcome::Keep);
            };
            let (x, y) = (
                (i % w as usize) as u32,
                ((i / w as usize) % h as usize) as u32,
            );
            let layer = (i / (w as usize * h as usize)) as u32;
            let texel = rng::texel_index(g.layer_size, layer, x, y);
            let Some(s) = texel_size(scene, nw[3]) else {
                return (i, Outcome::Keep);
            };
            let reach = TEST_REACH_TEXELS * s;
            if !occluded(bvh, texel, (p, n), eps, reach) {
                return (i, Outcome::Keep);
            }
            let (t, b) = basis(n);
            let o = offset_origin(p, n, eps);
            let nearest = PUSH_DIRECTIONS
                .iter()
                .filter_map(|&[ca, sa]| {
                    let d = [0, 1, 2].map(|c| ca * t[c] + sa * b[c]);
                    match first_hit(bvh, o, d, s) {
                        Some((hit, true)) => Some((hit, d)),
                        _ => None,
                    }
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((hit, d)) = nearest {
                let step = hit + PUSH_MARGIN * s;
                let q = mad(p, d, step);
                if !occluded(bvh, texel, (q, n), eps, reach) {
                    return (i, Outcome::Move(q));
                }
            }
            (i, Outcome::Remove)
        })
        .filter(|(_, o)| !matches!(o, Outcome::Keep))
        .collect();
    let mut stats = Unoccluded {
        tested: g.valid_texels(),
        ..Unoccluded::default()
    };
    for (i, outcome) in outcomes {
        match outcome {
            Outcome::Keep => {}
            Outcome::Move(q) => {
                g.position[4 * i..4 * i + 3].copy_from_slice(&q);
                stats.moved += 1;
            }
            Outcome::Remove => {
                for a in [&mut g.position, &mut g.normal, &mut g.albedo] {
                    a[4 * i..4 * i + 4].fill(0.0);
                }
                stats.removed += 1;
            }
        }
    }
    (stats.narrow, stats.gaps) = mark_narrow(g, scene, bvh, eps);
    stats
}

/// Whether the rays from `o` tilted 45° off the unit normal `n` toward the four tangent
/// directions of [`basis`] all meet a surface within `gap` of `o`'s plane (`gap·√2` along
/// them): the texel's gap is closed to every side, as behind a bookcase against a wall, not
/// open as between a chair's slats or legs or behind a thin bar (module docs, step 4).
fn enclosed(bvh: (&EncodedScene, &WideBvh), o: [f32; 3], n: [f32; 3], gap: f32) -> bool {
    let (t, b) = basis(n);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let reach = gap * std::f32::consts::SQRT_2;
    [[h, 0.0], [0.0, h], [-h, 0.0], [0.0, -h]]
        .iter()
        .all(|&[ct, cb]| {
            let d = [0, 1, 2].map(|c| h * n[c] + ct * t[c] + cb * b[c]);
            first_hit(bvh, o, d, reach).is_some()
        })
}

/// World size of a texel of object `object` (the normal's w), metres; `None` where the
/// object's density gives none.
fn texel_size(scene: &Scene, object: f32) -> Option<f32> {
    let scale = scene
        .objects
        .get(object as usize)
        .map_or(1.0, |o| o.texel_scale);
    let s = 1.0 / (scene.settings.texels_per_metre * scale);
    (s.is_finite() && s > 0.0).then_some(s)
}

/// The gap against the room of a G-buffer's `position` map ([`GAP_FRACTION`] of the largest
/// side of its valid texels' bounding box), metres.
pub fn room_gap(position: &[f32]) -> f32 {
    let (lo, hi) = position.chunks_exact(4).filter(|p| p[3] > 0.5).fold(
        ([f32::MAX; 3], [f32::MIN; 3]),
        |(lo, hi), p| {
            (
                [0, 1, 2].map(|c| lo[c].min(p[c])),
                [0, 1, 2].map(|c| hi[c].max(p[c])),
            )
        },
    );
    let size = (0..3).map(|c| hi[c] - lo[c]).fold(0.0f32, f32::max);
    GAP_FRACTION * size
}

/// Per row of a G-buffer's `position` map of rows `width` texels wide (layer by layer, rows
/// top to bottom), what it holds ([`crate::program::RowKind`]), from the values the shaders
/// test.
pub fn row_kinds(position: &[f32], width: u32) -> Vec<RowKind> {
    position
        .chunks(4 * (width as usize).max(1))
        .map(|row| {
            let texels = row.chunks_exact(4);
            if texels.clone().any(|p| p[3] >= NARROW) {
                RowKind::Narrow
            } else if texels.clone().all(|p| p[3] <= 0.5) {
                // The gather's own test of an invalid texel (a NaN is not one).
                RowKind::Empty
            } else {
                RowKind::Plain
            }
        })
        .collect()
}

/// Whether a point whose offset origin is `o`, with unit normal `n`, on a surface of texel
/// size `s` metres, lies in a narrow gap as a texel there would ([`NARROW_GAP`], module docs,
/// step 4): its normal ray meets a surface within [`NARROW_REACH_TEXELS`]` · s` and `gap`
/// ([`room_gap`]), and the gap is closed to its sides.
pub fn point_in_gap(
    bvh: (&EncodedScene, &WideBvh),
    o: [f32; 3],
    n: [f32; 3],
    s: f32,
    gap: f32,
) -> bool {
    narrow_class(bvh, o, n, s, gap) == Some(true)
}

/// Step 4's test at offset origin `o` with unit normal `n`, texel size `s`: `None` where the
/// normal ray meets no surface within [`NARROW_REACH_TEXELS`]` · s` (not narrow), else whether
/// the gap is also narrow against the room (`gap`, [`room_gap`]) and closed to its sides.
fn narrow_class(
    bvh: (&EncodedScene, &WideBvh),
    o: [f32; 3],
    n: [f32; 3],
    s: f32,
    gap: f32,
) -> Option<bool> {
    let (t, _) = first_hit(bvh, o, n, NARROW_REACH_TEXELS * s)?;
    Some(t <= gap && enclosed(bvh, o, n, gap))
}

/// Step 4 of the module docs: marks every valid texel whose normal ray meets a surface within
/// [`NARROW_REACH_TEXELS`] texels with w = [`NARROW`], or [`NARROW_GAP`] where that surface
/// also lies within [`GAP_FRACTION`] of the room's size and the gap is closed to its sides
/// ([`enclosed`]); returns how many of each (`[narrow, of them in gaps]`).
fn mark_narrow(
    g: &mut GBuffer,
    scene: &Scene,
    bvh: (&EncodedScene, &WideBvh),
    eps: f32,
) -> (u64, u64) {
    let position = &g.position;
    let normal = &g.normal;
    let gap = room_gap(position);
    let narrow: Vec<(usize, bool)> = (0..position.len() / 4)
        .into_par_iter()
        .filter_map(|i| {
            let (pw, nw) = (&position[4 * i..4 * i + 4], &normal[4 * i..4 * i + 4]);
            if pw[3] <= 0.5 {
                return None;
            }
            let n = normalize([nw[0], nw[1], nw[2]])?;
            let s = texel_size(scene, nw[3])?;
            let o = offset_origin([pw[0], pw[1], pw[2]], n, eps);
            Some((i, narrow_class(bvh, o, n, s, gap)?))
        })
        .collect();
    let mut gaps = 0;
    for &(i, in_gap) in &narrow {
        g.position[4 * i + 3] = if in_gap { NARROW_GAP } else { NARROW };
        gaps += u64::from(in_gap);
    }
    (narrow.len() as u64, gaps)
}
