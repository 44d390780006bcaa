//! Calculation points: from a world point on a baked surface to the light-map UV where its
//! value is stored (what `cargo xtask measure` and the tests read).
//!
//! [`locate`] finds the receiving object's triangle closest to the point (exact closest point
//! on each world-space triangle, in `f64`), and accepts it when the distance is within the
//! tolerance. The light-map UV is the barycentric interpolation of the triangle's UVs at that
//! closest point; the value is then read with the masked bilinear rule of [`crate::map`].
//!
//! [`direct_at`] computes the direct illuminance at the points themselves instead, as a
//! lighting-calculation program does at its calculation points: the direct pass run on a
//! G-buffer of the points (shadow rays, each lamp's model as a bake of the room chooses it,
//! its luminous opening sampled with as many points as asked). A light map holds the direct
//! light at its texels' centres and interpolates between them, which is off where the light
//! bends within a texel — a luminaire's cut-off, the foot of a wall washer, a shadow edge;
//! at a point the direct light has no such error.
//!
//! [`indirect_at`] does the same for the inter-reflected light: a final gather at the point
//! itself, each ray read from the baked exitance maps where it meets a surface. The maps'
//! texels and their interpolation then enter only through the light the point sees, averaged
//! over its hemisphere, not through the point's own texels (a narrow strip of a few texels, the
//! rim of a chair seat's underside).

use glam::{DVec2, DVec3, Vec2, Vec3};
use luxbake_bvh::Ray;
use rayon::prelude::*;

use crate::backend::{GpuBackend, SceneData, offset_origin};
use crate::bake::BakeError;
use crate::graph::{TexDesc, TexFormat};
use crate::prepare::{Lamps, Room};
use crate::program::{DirectParams, Params, Program, TilePlan};
use crate::scene::{Lamp, Scene, Settings};

/// A point located on a receiving surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Object index.
    pub object: usize,
    /// Light-map UV of the point.
    pub uv: [f32; 2],
    /// Distance from the query point to the surface, metres.
    pub distance: f64,
    /// The closest point of the surface, world, metres.
    pub position: [f64; 3],
    /// The surface's unit normal there, world: the vertex normals interpolated and
    /// transformed as the G-buffer does; the face's own (counter-clockwise front) where they
    /// cancel.
    pub normal: [f64; 3],
}

/// Barycentric weights `(w0, w1, w2)` of the point of triangle `abc` closest to `p`
/// (Ericson, *Real-Time Collision Detection*, 5.1.5), robust for degenerate triangles.
pub fn closest_barycentric(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return DVec3::X;
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return DVec3::Y;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return DVec3::new(1.0 - v, v, 0.0);
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return DVec3::Z;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return DVec3::new(1.0 - w, 0.0, w);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return DVec3::new(0.0, 1.0 - w, w);
    }
    let denom = va + vb + vc;
    if denom == 0.0 || !denom.is_finite() {
        return DVec3::X;
    }
    let v = vb / denom;
    let w = vc / denom;
    DVec3::new(1.0 - v - w, v, w)
}

/// The receiving surface point closest to `point` within `tolerance` metres, if any.
/// Objects without a light map (`receiver == false`) are ignored.
pub fn locate(scene: &Scene, point: [f64; 3], tolerance: f64) -> Option<SurfacePoint> {
    let point = DVec3::from(point);
    let mut best: Option<SurfacePoint> = None;
    for (o, obj) in scene.objects.iter().enumerate() {
        if !obj.receiver {
            continue;
        }
        let m = &obj.mesh;
        let world: Vec<DVec3> = m
            .positions
            .iter()
            .map(|p| DVec3::from(obj.transform.point_f64(p.map(f64::from))))
            .collect();
        for tri in &m.indices {
            let idx = tri.map(|i| i as usize);
            let (Some(&a), Some(&b), Some(&c)) =
                (world.get(idx[0]), world.get(idx[1]), world.get(idx[2]))
            else {
                continue;
            };
            let w = closest_barycentric(point, a, b, c);
            let d = point.distance(a * w.x + b * w.y + c * w.z);
            if d.is_nan() || d > tolerance || best.is_some_and(|b| b.distance <= d) {
                continue;
            }
            let uvs = idx.map(|i| {
                m.lightmap_uvs
                    .get(i)
                    .map_or(DVec2::ZERO, |&uv| Vec2::from(uv).as_dvec2())
            });
            let uv = (uvs[0] * w.x + uvs[1] * w.y + uvs[2] * w.z)
                .as_vec2()
                .to_array();
            let shading = idx.map(|i| {
                m.normals
                    .get(i)
                    .map_or(DVec3::ZERO, |n| Vec3::from(*n).as_dvec3())
            });
            let n = shading[0] * w.x + shading[1] * w.y + shading[2] * w.z;
            let face = (b - a).cross(c - a);
            let normal = obj
                .transform
                .normal_f64(n.to_array())
                .or_else(|| face.try_normalize().map(|v| v.to_array()))
                .unwrap_or([0.0, 0.0, 0.0]);
            best = Some(SurfacePoint {
                object: o,
                uv,
                distance: d,
                position: (a * w.x + b * w.y + c * w.z).to_array(),
                normal,
            });
        }
    }
    best
}

/// A calculation point of [`direct_at`]: a world position on a receiving surface and the
/// unit normal of the side that receives the light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalcPoint {
    /// World position, metres.
    pub position: [f64; 3],
    /// Unit normal (the receiving side).
    pub normal: [f64; 3],
}

/// The direct illuminance, lux (RGB, before albedo), at each of `points` in the prepared
/// `room` lit by `lamps`, computed by `backend`'s direct pass at the points (see the module
/// docs) with `settings` and `opening_samples` points per luminous opening (the direct
/// pass's rule: up to twice that near an opening, [`crate::opening::texel_samples`]). A
/// point gets what a texel centred there with that normal would get; the lamps' models are
/// those a bake of `room` under `lamps` with `settings` picks. Points are processed in
/// batches that fit the backend's textures; after each the backend frees its textures and
/// scene ([`GpuBackend::release`]), as a bake does when its maps are read back.
///
/// On a backend whose driver cuts long shader loops ([`crate::Limits::loop_iterations`]:
/// Mesa's llvmpipe and lavapipe) an opening's samples are split over dispatches of
/// [`crate::graph::DIRECT_CHUNK_SAMPLES`], each adding to the one before, as in a bake.
pub fn direct_at<B: GpuBackend>(
    backend: &mut B,
    room: &Room,
    lamps: &[Lamp],
    settings: &Settings,
    opening_samples: u32,
    points: &[CalcPoint],
) -> Result<Vec<[f32; 3]>, BakeError<B::Error>> {
    let name = backend.name();
    let be = |source| BakeError::Backend {
        backend: name,
        source,
    };
    // The traversal a bake of the room uses.
    let bvh = if room.triangles <= crate::bake::BRUTE_FORCE_MAX_TRIANGLES {
        crate::scene::BvhMode::None
    } else {
        settings.bvh
    };
    let direct_only = Settings {
        bounces: 0,
        opening_samples,
        ..settings.clone()
    };
    let lamps = Lamps::prepare(room, &room.place_lamps(lamps), &direct_only);
    let (_, chunk) = backend.limits().loop_chunks();
    let params: Vec<Params> = DirectParams {
        lamp_count: u32::try_from(lamps.params.len()).unwrap_or(u32::MAX),
        seed: settings.seed,
        samples: opening_samples,
        openings: u32::try_from(lamps.params.iter().filter(|l| l.opening.is_some()).count())
            .unwrap_or(u32::MAX),
        ..DirectParams::default()
    }
    .chunked(chunk)
    .into_iter()
    .map(Params::Direct)
    .collect();
    // As the room's geometry is moved back toward the origin, bit for bit.
    let shift = room.shift.unwrap_or([0.0; 3]);
    let width = backend.limits().max_texture_size.clamp(1, 4096) as usize;
    let mut out = Vec::with_capacity(points.len());
    for batch in points.chunks(width * width) {
        // A square of texels, as a light map's layer is.
        let side = (batch.len() as f64).sqrt().ceil() as usize;
        let size = [side as u32, batch.len().div_ceil(side.max(1)) as u32];
        let texels = size[0] as usize * size[1] as usize;
        let (mut position, mut normal) = (vec![0.0f32; 4 * texels], vec![0.0f32; 4 * texels]);
        for (i, p) in batch.iter().enumerate() {
            let at = [0, 1, 2].map(|c| (p.position[c] + -shift[c]) as f32);
            position[4 * i..4 * i + 4].copy_from_slice(&[at[0], at[1], at[2], 1.0]);
            let n = p.normal.map(|c| c as f32);
            normal[4 * i..4 * i + 4].copy_from_slice(&[n[0], n[1], n[2], 0.0]);
        }
        let desc = |label| TexDesc {
            label,
            size,
            layers: 1,
            format: TexFormat::Rgba32F,
        };
        let run = |backend: &mut B| -> Result<Vec<f32>, B::Error> {
            let textures = [
                backend.create_texture(&desc("position"))?,
                backend.create_texture(&desc("normal"))?,
                backend.create_texture(&desc("direct"))?,
                backend.create_texture(&desc("direct_spare"))?,
            ];
            backend.upload(&textures[0], 0, &position)?;
            backend.upload(&textures[1], 0, &normal)?;
            let scene = backend.upload_scene(&SceneData {
                bvh: &room.bvh,
                lamps: &lamps.params,
                ies_tables: &lamps.tables,
                regions: &[],
                layer_size: size,
                layers: 1,
                ray_epsilon: room.ray_epsilon,
                lamp_paths: &[],
            })?;
            // The chunks alternate between the two last textures, the last writing `direct`
            // (`position` stands in for the prior of the first, which reads none).
            let mut prior = 0;
            for (c, chunk) in params.iter().enumerate() {
                let out = if (params.len() - 1 - c).is_multiple_of(2) {
                    2
                } else {
                    3
                };
                let words = chunk.words();
                let plan = TilePlan::new(size, 1, chunk.work_per_texel(), backend.tile_work());
                for tile in plan.tiles() {
                    backend.dispatch(&crate::backend::Dispatch {
                        label: "direct at points",
                        program: Program::Direct,
                        bvh,
                        reads: &[&textures[0], &textures[1], &textures[prior]],
                        write: &textures[out],
                        scene: &scene,
                        params: &words,
                        tile,
                        idle: false,
                        narrow: true,
                    })?;
                }
                prior = out;
            }
            let texels = backend.read_back(&textures[2], 0)?;
            backend.release()?;
            Ok(texels)
        };
        let texels = run(backend).map_err(be)?;
        out.extend(
            texels
                .chunks_exact(4)
                .take(batch.len())
                .map(|t| [t[0], t[1], t[2]]),
        );
    }
    Ok(out)
}

/// Where the ray from `origin` along `dir` (in the room's frame) first meets a surface, when it
/// meets its front (the interpolated shading normal facing the ray, as the bakes' gather
/// reads a hit): the surface's object and its light-map UV there.
fn front_hit(room: &Room, origin: [f32; 3], dir: [f32; 3]) -> Option<(usize, [f32; 2])> {
    let hit = room
        .bvh
        .wide
        .closest_hit(&Ray { origin, dir }, 0.0, f32::INFINITY)?;
    let attr = room.bvh.encoded.triangle_attributes(hit.triangle);
    let (n, uv) = crate::exact::interpolate(&attr, hit.u, hit.v);
    let facing = crate::exact::dot(n, dir);
    // A NaN facing counts as behind, as in the bakes' gather.
    if facing.is_nan() || facing >= 0.0 {
        return None;
    }
    Some((attr.object as usize, uv))
}

/// The RNG pass of [`indirect_at`]'s per-point lattice shift.
pub const GATHER_AT_PASS: u32 = 0x6761_7468;

/// The indirect illuminance, lux (RGB, before albedo), at each of `points` of the prepared
/// `room`: a final gather of `rays` cosine-distributed rays from the point (a Fibonacci
/// lattice over the hemisphere, shifted per point by the hash of [`crate::rng`], pass
/// [`GATHER_AT_PASS`], with `seed`), each ray that meets the front of a receiver reading
/// `exitance(object, uv)` there — the baked exitance (albedo × total illuminance, lux) at that
/// light-map UV — and the mean of what they read: `E = π·mean(L) = mean(M)` for a Lambertian
/// surroundings. Rays that leave the scene, meet a surface from behind or a non-receiver
/// (`exitance` gives what it gives for it: zero where it has no map) add nothing. A point
/// gets the light reflected onto it by every baked bounce; the direct part is
/// [`direct_at`]'s. On the CPU, in parallel over the points.
///
/// A point in a narrow gap ([`gathers_uniformly`]) draws its lattice uniformly over the
/// hemisphere instead, each ray weighted `2 cos θ` (`E = mean(2 cos θ · M)`), as the bakes'
/// texels there do (`crate::passes::refine`, "Narrow gaps"): its light comes from the few
/// grazing directions that leave the gap, which cosine-distributed rays seldom draw.
pub fn indirect_at(
    room: &Room,
    points: &[CalcPoint],
    rays: u32,
    seed: u32,
    exitance: &(dyn Fn(usize, [f32; 2]) -> [f32; 3] + Sync),
) -> Vec<[f32; 3]> {
    let rays = rays.max(1);
    let uniform = gathers_uniformly(room, points);
    points
        .par_iter()
        .zip(&uniform)
        .enumerate()
        .map(|(i, (point, &uniform))| {
            let Some((origin, n)) = gather_origin(room, point) else {
                return [0.0; 3];
            };
            let frame = crate::cpu::kernel::Frame::new(n);
            let lattice_shift = {
                let h = crate::rng::hash(i as u32, 0, GATHER_AT_PASS, seed);
                [h, crate::rng::pcg(h)]
            };
            let mut sum = [0.0f64; 3];
            for k in 0..rays {
                let u = crate::opening::lattice(k, rays, lattice_shift);
                let (dir, weight) = if uniform {
                    let dir = frame.uniform_direction(u);
                    (dir, 2.0 * f64::from(crate::exact::dot(n, dir)))
                } else {
                    (frame.cosine_direction(u), 1.0)
                };
                let Some((object, uv)) = front_hit(room, origin, dir) else {
                    continue;
                };
                let m = exitance(object, uv);
                for c in 0..3 {
                    if m[c].is_finite() {
                        sum[c] += weight * f64::from(m[c]);
                    }
                }
            }
            sum.map(|v| (v / f64::from(rays)) as f32)
        })
        .collect()
}

/// Per point of `points`, whether [`indirect_at`] gathers there with rays drawn uniformly over
/// the hemisphere: where a texel at the point, at the room's density, would lie in a narrow
/// gap ([`crate::validity::point_in_gap`]).
pub fn gathers_uniformly(room: &Room, points: &[CalcPoint]) -> Vec<bool> {
    let gap = crate::validity::room_gap(&room.gbuffer.position);
    points
        .par_iter()
        .map(|point| gather_origin(room, point).is_some_and(|(o, n)| in_gap(room, o, n, gap)))
        .collect()
}

/// The ray origin and unit normal of a final gather at `point` of the prepared `room` (moved
/// with the room, offset as the bakes offset a texel's rays); `None` without a normal.
fn gather_origin(room: &Room, point: &CalcPoint) -> Option<([f32; 3], [f32; 3])> {
    let shift = room.shift.unwrap_or([0.0; 3]);
    let p = [0, 1, 2].map(|c| (point.position[c] + -shift[c]) as f32);
    let n = crate::exact::normalize(point.normal.map(|c| c as f32))?;
    Some((offset_origin(p, n, room.ray_epsilon), n))
}

/// [`crate::validity::point_in_gap`] at the room's texel size (its `texels_per_metre`).
fn in_gap(room: &Room, origin: [f32; 3], n: [f32; 3], gap: f32) -> bool {
    let s = 1.0 / room.scene.settings.texels_per_metre;
    s.is_finite()
        && s > 0.0
        && crate::validity::point_in_gap((&room.bvh.encoded, &room.bvh.wide), origin, n, s, gap)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_point_regions() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        assert_eq!(
            closest_barycentric(DVec3::new(0.25, 0.25, 1.0), a, b, c),
            DVec3::new(0.5, 0.25, 0.25)
        );
        assert_eq!(
            closest_barycentric(DVec3::new(-1.0, -1.0, 0.0), a, b, c),
            DVec3::new(1.0, 0.0, 0.0)
        );
        assert_eq!(
            closest_barycentric(DVec3::new(2.0, -0.1, 0.0), a, b, c),
            DVec3::new(0.0, 1.0, 0.0)
        );
        assert_eq!(
            closest_barycentric(DVec3::new(0.5, -1.0, 0.0), a, b, c),
            DVec3::new(0.5, 0.5, 0.0)
        );
        // Degenerate (all points equal): vertex a, no NaN.
        let w = closest_barycentric(DVec3::new(1.0, 2.0, 3.0), a, a, a);
        assert!(w.is_finite());
    }

    /// A gather ray reads the light map where it meets a surface: the object and UV of
    /// [`front_hit`] are those [`locate`] finds at the hit's world point (the exact closest
    /// point of the receiving triangle, in `f64`), for random rays through a furnished room.
    #[test]
    fn a_gather_hit_reads_the_uv_of_the_point_it_meets() {
        let settings = Settings {
            texels_per_metre: 8.0,
            ..Settings::default()
        };
        let scene = Scene::builtin_with_settings("chairs_01", settings).expect("chairs_01");
        let room = Room::prepare(&scene, &scene.settings, crate::Limits::WEBGL2, &mut |_| {})
            .expect("room");
        let shift = room.shift.unwrap_or([0.0; 3]);
        let (mut same, mut other) = (0, 0);
        for k in 0..4000u32 {
            let r = |j: u32| crate::rng::unit_f32(crate::rng::hash(k, j, 7, 0));
            let origin = [-2.0 + 4.0 * r(0), 0.1 + 2.2 * r(1), -1.6 + 3.2 * r(2)];
            let z = 2.0 * r(3) - 1.0;
            let (s, a) = ((1.0 - z * z).max(0.0).sqrt(), std::f32::consts::TAU * r(4));
            let dir = [s * a.cos(), z, s * a.sin()];
            let Some((object, uv)) = front_hit(&room, origin, dir) else {
                continue;
            };
            let hit = room
                .bvh
                .wide
                .closest_hit(&Ray { origin, dir }, 0.0, f32::INFINITY)
                .expect("hit");
            let world = [0, 1, 2].map(|c| f64::from(origin[c] + dir[c] * hit.t) + shift[c]);
            let Some(sp) = locate(&scene, world, 1e-3) else {
                continue;
            };
            // Where two objects touch the closest triangle may be the other's.
            if sp.object != object {
                other += 1;
                continue;
            }
            same += 1;
            for c in 0..2 {
                assert!(
                    (sp.uv[c] - uv[c]).abs() < 1e-4,
                    "ray {k}: uv {uv:?} against {:?} at {world:?}",
                    sp.uv
                );
            }
        }
        assert!(
            same > 1000 && other * 50 < same,
            "{same} same, {other} other"
        );
    }
}
