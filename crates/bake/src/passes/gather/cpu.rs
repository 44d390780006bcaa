//! The CPU reference of pass `gather`: a row's rays traced together, in chunks (the
//! semantics the shaders mirror; see [`crate::cpu`]'s docs).

use std::sync::Arc;

use luxbake_bvh::{Hit, Ray, TriangleAttributes};

use crate::backend::offset_origin;
use crate::contract::ParamBlock;
use crate::cpu::hits::{Row, RowKey, WordHash, recorded};
use crate::cpu::kernel::*;
use crate::lightpaths;
use crate::map::{bilinear_footprint, masked_blend};
use crate::rng;
use crate::validity::NARROW_GAP;

use super::GatherParams;

/// The gather for one dispatch: its parameters, and on a grid (stride > 1) the grid corners
/// of its texels when the backend keeps them ([`CoarseMasks`]: which texels are orphans).
pub(crate) struct Pass {
    params: GatherParams,
    masks: Option<Arc<CoarseMasks>>,
}

impl Prepare for Pass {
    fn prepare(words: &[u32], ctx: &Ctx<'_>) -> Pass {
        let params = GatherParams::from_words(words);
        let masks = (params.stride > 1)
            .then(|| ctx.coarse_masks([0, 1], params.stride, params.reach))
            .flatten();
        Pass { params, masks }
    }
}

impl CpuPass for Pass {
    type Scratch = GatherScratch;

    fn row(&self, ctx: &Ctx<'_>, y: u32, texels: &mut [f32], scratch: &mut GatherScratch) {
        let v = ctx.views;
        let views = [v[0], v[1], v[2], v[3], v[4], v[5]];
        let at = [ctx.tile.layer, ctx.tile.x0, y];
        let masks = self.masks.as_deref();
        gather_row(ctx.scene, views, ctx.trav, self.params, masks, at, texels, scratch);
    }
}

/// A gather ray that met the front of a receiver: where the texels of its masked look-up lie
/// in the reflected map ([`View::index`], `usize::MAX` for one outside it, which reads 0) and
/// their weights (`None`: the look-up is zero), and the hit's interpolated shading normal.
#[derive(Clone, Copy)]
pub(crate) struct Lookup {
    pub(crate) texels: [usize; 4],
    pub(crate) weights: Option<[f32; 4]>,
    pub(crate) normal: [f32; 3],
}

/// One texel's gather rays: samples `rays` of the sequence of `texel` (its [`rng::Stream`]),
/// cast from `o` around the unit normal of `frame`.
pub(crate) struct GatherTexel {
    pub(crate) texel: u32,
    pub(crate) rays: std::ops::Range<u32>,
    pub(crate) o: [f32; 3],
    pub(crate) frame: Frame,
    pub(crate) mis: Mis,
    /// The rays drawn uniformly over the hemisphere ([`Frame::uniform_direction`]), not
    /// cosine-weighted: a texel in a narrow gap ([`crate::lightpaths::gather_weight`]).
    pub(crate) uniform: bool,
}

/// Where a gather's hits read their light: `reflected`, or with `direct` (the albedo map and
/// the lamps to evaluate) the lamps' direct light at the hit times the albedo there
/// ([`GatherParams::direct_at_hits`]).
#[derive(Clone, Copy)]
pub(crate) struct Source<'a> {
    pub(crate) reflected: View<'a>,
    pub(crate) direct: Option<(View<'a>, u32)>,
    /// With `direct`: only the hits of texels in narrow gaps ([`GatherTexel::uniform`]) read
    /// the direct light there (the refinement's `narrow_direct`), the others `reflected`.
    pub(crate) gaps_only: bool,
}

impl<'a> Source<'a> {
    /// The source of a gather with `direct_at_hits` (1: on) over `lamp_count` lamps; without
    /// it, with `in_gaps` the texels in narrow gaps still read the direct light at their hits.
    pub(crate) fn new(
        reflected: View<'a>,
        albedo: View<'a>,
        [direct_at_hits, lamp_count]: [u32; 2],
        in_gaps: bool,
    ) -> Source<'a> {
        let everywhere = direct_at_hits != 0;
        Source {
            reflected,
            direct: (everywhere || in_gaps).then_some((albedo, lamp_count)),
            gaps_only: !everywhere,
        }
    }
}

/// Per texel of `texels`, the sum of the reflected exitance seen along its rays (see the
/// module docs), pushed to `sums` (cleared first), the directions drawn with the gather's
/// `[sampler, bounce, seed]`; `chunks` are the stage buffers, reused from call to call. The
/// rays are processed as a stream, in chunks of about `CHUNK_RAYS`, one stage at a time over
/// a chunk: their directions, their closest hits, the hits' shading and look-up footprints
/// (each prefetching the look-up's texels), then — after the next chunk's traversal — the
/// look-ups' texels (independent loads whose cache misses overlap, instead of each stalling
/// the next ray's traversal) and last each texel's contributions, added in ray order as one
/// ray at a time would. Each stage is a short loop that keeps its own code and data hot
/// (docs/performance.md, issue 15, measures the stages and the alternatives).
#[allow(clippy::too_many_arguments)]
pub(crate) fn gather_sums(
    scene: &CpuScene,
    source: Source<'_>,
    trav: Trav,
    [sampler_id, bounce, seed]: [u32; 3],
    texels: &[GatherTexel],
    hits: &mut Hits<'_>,
    [ahead, behind]: &mut [GatherChunk; 2],
    sums: &mut Vec<[f32; 3]>,
) {
    let first = texels.iter().map(|t| t.rays.start).min().unwrap_or(0);
    let end = texels.iter().map(|t| t.rays.end).max().unwrap_or(0);
    let sampler = rng::Sampler::from_id(sampler_id);
    let draws = rng::PassDraws::new(sampler, bounce, seed, first..end);
    // Chunks of texels with about CHUNK_RAYS rays (at least one texel each), software
    // pipelined: chunk k's rays are traced and their look-ups prefetched, then chunk k - 1's
    // look-ups fetched and summed, so that a whole chunk's traversal lies between a look-up's
    // prefetch and its fetch.
    sums.clear();
    let mut rest = texels;
    let mut pending: &[GatherTexel] = &[];
    while !rest.is_empty() {
        let mut rays = 0;
        let n = rest
            .iter()
            .position(|t| {
                rays += t.rays.len();
                rays > CHUNK_RAYS
            })
            .unwrap_or(rest.len())
            .max(1);
        let (chunk, tail) = rest.split_at(n);
        ahead.trace(scene, source.reflected, trav, &draws, chunk, hits);
        behind.sum(scene, source, trav, pending, sums);
        std::mem::swap(ahead, behind);
        pending = chunk;
        rest = tail;
    }
    behind.sum(scene, source, trav, pending, sums);
}

/// Where [`gather_sums`]' hits come from ([`crate::cpu::hits`]).
pub(crate) enum Hits<'a> {
    /// Traced.
    Trace,
    /// Traced, and pushed here in ray order ([`recorded`]).
    Record(Vec<Hit>),
    /// Replayed from a recorded row, from its ray `.1` on.
    Replay(&'a Row, usize),
}

/// The rays of one chunk of [`gather_sums`]: few enough that the chunk's buffers and
/// prefetched look-up texels (about 330 bytes a ray) stay in a core's L2 cache and mostly in
/// its L1 (1 024 rays a chunk fetched 1.5 times slower; docs/performance.md, issue 15), enough
/// that a chunk's traversal (tens of microseconds) hides a prefetch's latency.
pub(crate) const CHUNK_RAYS: usize = 256;

/// One chunk's stage buffers in [`gather_sums`], reused from chunk to chunk.
#[derive(Default)]
pub(crate) struct GatherChunk {
    pub(crate) dirs: Vec<[f32; 3]>,
    pub(crate) traced: Vec<Option<Hit>>,
    pub(crate) lookups: Vec<Option<Lookup>>,
    pub(crate) fetched: Vec<[[f32; 4]; 4]>,
}

impl GatherChunk {
    /// The first stages over `texels`' rays: directions, closest hits (from `hits`),
    /// shading and look-up footprints (prefetched).
    pub(crate) fn trace(
        &mut self,
        scene: &CpuScene,
        reflected: View<'_>,
        trav: Trav,
        draws: &rng::PassDraws,
        texels: &[GatherTexel],
        hits: &mut Hits<'_>,
    ) {
        let GatherChunk {
            dirs,
            traced,
            lookups,
            ..
        } = self;
        directions(dirs, draws, texels);
        traced.clear();
        if let Hits::Replay(row, next) = hits {
            traced.extend((*next..*next + dirs.len()).map(|i| row.hit(i)));
            *next += dirs.len();
        } else {
            let mut rest = dirs.iter();
            for t in texels {
                for &dir in rest.by_ref().take(t.rays.len()) {
                    let ray = Ray { origin: t.o, dir };
                    traced.push(scene.closest_hit(&ray, 0.0, f32::INFINITY, trav));
                }
            }
            if let Hits::Record(row) = hits {
                row.extend(traced.iter().map(|&h| recorded(h)));
            }
        }
        lookups.clear();
        lookups.extend(traced.iter().zip(dirs.iter()).map(|(hit, &dir)| {
            hit.as_ref()
                .and_then(|hit| gather_lookup(scene, reflected, hit, dir))
        }));
    }

    /// The last stages over `texels` (those of the last [`GatherChunk::trace`]): the
    /// look-ups' texels, then each texel's sum, pushed to `sums`.
    pub(crate) fn sum(
        &mut self,
        scene: &CpuScene,
        source: Source<'_>,
        trav: Trav,
        texels: &[GatherTexel],
        sums: &mut Vec<[f32; 3]>,
    ) {
        let reflected = source.reflected;
        let GatherChunk {
            dirs,
            traced,
            lookups,
            fetched,
        } = self;
        fetched.clear();
        fetched.extend(lookups.iter().map(|lookup| match lookup {
            Some(Lookup {
                texels: [a, b, c, d],
                weights: Some(_),
                ..
            }) => [
                reflected.at_offset(*a),
                reflected.at_offset(*b),
                reflected.at_offset(*c),
                reflected.at_offset(*d),
            ],
            _ => [[0.0; 4]; 4],
        }));
        let mut rest = lookups
            .iter()
            .zip(fetched.iter())
            .zip(traced.iter().zip(dirs.iter()));
        sums.extend(texels.iter().map(|t| {
            let mut sum = [0.0f32; 3];
            for ((lookup, texels), (hit, &dir)) in rest.by_ref().take(t.rays.len()) {
                let (Some(lookup), Some(hit)) = (lookup, hit) else {
                    continue;
                };
                // The hit's point, for the direct light there and the lamp paths' weight.
                let y = [0, 1, 2].map(|c| t.o[c] + hit.t * dir[c]);
                let direct = source.direct.filter(|_| !source.gaps_only || t.uniform);
                let at_hit = direct.and_then(|(albedo, lamps)| {
                    // The shaders' test; the direct texel normalizes the normal itself.
                    normalize(lookup.normal)?;
                    let e = crate::passes::direct::cpu::points_at(scene, trav, lamps, y, lookup.normal)?;
                    // The albedo where the reflected map is read, with its mask and weights.
                    let a = lookup.weights.map_or([0.0; 3], |w| {
                        let at = |i: usize| {
                            let r = albedo.at_offset(lookup.texels[i]);
                            [r[0], r[1], r[2], texels[i][3]]
                        };
                        masked_blend([(at(0), w[0]), (at(1), w[1]), (at(2), w[2]), (at(3), w[3])])
                    });
                    Some([a[0] * e[0], a[1] * e[1], a[2] * e[2]])
                });
                let m = at_hit.unwrap_or_else(|| {
                    lookup.weights.map_or([0.0; 3], |w| {
                        masked_blend([
                            (texels[0], w[0]),
                            (texels[1], w[1]),
                            (texels[2], w[2]),
                            (texels[3], w[3]),
                        ])
                    })
                });
                // Nothing to weigh where the hit reflects no light (the weight is finite):
                // the sum's bits are those of adding `weight × 0`.
                if m == [0.0; 3] {
                    continue;
                }
                let weight = gather_weight(scene, hit, y, lookup.normal, dir, t);
                for c in 0..3 {
                    sum[c] += weight * m[c];
                }
            }
            sum
        }));
    }
}

/// The directions of `texels`' rays, in order, pushed to `dirs` (cleared first): with AVX2
/// where the CPU has it, the same operations bit for bit (integer operations and IEEE
/// arithmetic, no fused multiply-adds), the hash sampler's draws then four to a vector.
pub(crate) fn directions(dirs: &mut Vec<[f32; 3]>, draws: &rng::PassDraws, texels: &[GatherTexel]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (just checked).
        unsafe { directions_avx2(dirs, draws, texels) };
        return;
    }
    directions_inline(dirs, draws, texels);
}

/// [`directions`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) fn directions_avx2(dirs: &mut Vec<[f32; 3]>, draws: &rng::PassDraws, texels: &[GatherTexel]) {
    directions_inline(dirs, draws, texels);
}

/// [`directions`] for the instruction set of the caller.
#[inline(always)]
pub(crate) fn directions_inline(dirs: &mut Vec<[f32; 3]>, draws: &rng::PassDraws, texels: &[GatherTexel]) {
    dirs.clear();
    for t in texels {
        let d = draws.texel(t.texel);
        if t.uniform {
            dirs.extend(t.rays.clone().map(|s| t.frame.uniform_direction(d.uniform2(s))));
            continue;
        }
        let mut s = t.rays.start;
        while t.rays.end - s >= 4 {
            dirs.extend(t.frame.cosine_directions4(d.uniform2x4(s)));
            s += 4;
        }
        dirs.extend((s..t.rays.end).map(|s| t.frame.cosine_direction(d.uniform2(s))));
    }
}

/// The interpolated shading normal of `hit` on a triangle with `attr`.
#[inline]
pub(crate) fn shading_normal(attr: &TriangleAttributes, hit: &Hit) -> [f32; 3] {
    // Written out per component (no array::map closures, which the dev profile does not
    // always inline on this hot path).
    let w0 = 1.0 - hit.u - hit.v;
    let [n0, n1, n2] = attr.normals;
    [
        w0 * n0[0] + hit.u * n1[0] + hit.v * n2[0],
        w0 * n0[1] + hit.u * n1[1] + hit.v * n2[1],
        w0 * n0[2] + hit.u * n1[2] + hit.v * n2[2],
    ]
}

/// The weight of texel `t`'s gather ray along `dir` that met `hit` at `y` (a front hit of a
/// receiver, interpolated shading normal `nh`): 1, or with lamp paths the balance heuristic
/// against them ([`crate::lightpaths`]).
#[inline]
pub(crate) fn gather_weight(
    scene: &CpuScene,
    hit: &Hit,
    y: [f32; 3],
    nh: [f32; 3],
    dir: [f32; 3],
    t: &GatherTexel,
) -> f32 {
    let mis = t.mis;
    if mis.lamp_paths == 0 {
        return if t.uniform { 2.0 * dot(t.frame.n, dir) } else { 1.0 };
    }
    let ny = normalize(nh).unwrap_or([0.0; 3]);
    let lamps = &scene.lamps[..(mis.lamp_count as usize).min(scene.lamps.len())];
    let lamp_density = lightpaths::density(lamps, &scene.proxies, y, ny);
    lightpaths::gather_weight(
        mis.rays,
        mis.lamp_paths,
        mis.density_scale,
        lamp_density,
        hit.t,
        dot(t.frame.n, dir),
        -dot(ny, dir),
        t.uniform,
    )
}

/// The gather ray along `dir` that met `hit`: when it met the front of a receiver, its masked
/// look-up in `reflected` (see the module docs), its rows prefetched; `None` adds nothing.
#[inline]
pub(crate) fn gather_lookup(
    scene: &CpuScene,
    reflected: View<'_>,
    hit: &Hit,
    dir: [f32; 3],
) -> Option<Lookup> {
    let attr = scene.attributes(hit.triangle)?;
    let Some(Some(region)) = scene.regions.get(attr.object as usize) else {
        return None;
    };
    let normal = shading_normal(attr, hit);
    let facing = dot(normal, dir);
    if facing.is_nan() || facing >= 0.0 {
        return None;
    }
    let w0 = 1.0 - hit.u - hit.v;
    let [uv0, uv1, uv2] = attr.uvs;
    let uv = [
        w0 * uv0[0] + hit.u * uv1[0] + hit.v * uv2[0],
        w0 * uv0[1] + hit.u * uv1[1] + hit.v * uv2[1],
    ];
    let Some(c) = bilinear_footprint(region.size, uv) else {
        return Some(Lookup {
            texels: [usize::MAX; 4],
            weights: None,
            normal,
        });
    };
    let [(t0, w0), (t1, w1), (t2, w2), (t3, w3)] = c;
    let texels = match reflected.rect_origin(region) {
        Some(origin) => {
            let row = 4 * reflected.size[0] as usize;
            let at = |[x, y]: [u32; 2]| origin + 4 * x as usize + row * y as usize;
            [at(t0), at(t1), at(t2), at(t3)]
        }
        None => {
            let [ox, oy] = region.offset;
            let at = |[x, y]: [u32; 2]| {
                reflected
                    .index(region.layer, ox.saturating_add(x), oy.saturating_add(y))
                    .unwrap_or(usize::MAX)
            };
            [at(t0), at(t1), at(t2), at(t3)]
        }
    };
    // The look-up's texels, asked for now: the look-ups are fetched after the next chunk's
    // traversal and their texels are usually not cached (the maps are megabytes). Each row
    // of two texels lies on one cache line or straddles two.
    prefetch(reflected.data, texels[0]);
    prefetch(reflected.data, texels[1]);
    prefetch(reflected.data, texels[2]);
    prefetch(reflected.data, texels[3]);
    Some(Lookup {
        texels,
        weights: Some([w0, w1, w2, w3]),
        normal,
    })
}

/// The gather's multiple-importance-sampling weights ([`crate::lightpaths`]): none when
/// `lamp_paths` is 0.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Mis {
    /// Rays per texel of the gather (`N_C`).
    pub(crate) rays: u32,
    /// Lamp paths per texel (`K`).
    pub(crate) lamp_paths: u32,
    /// [`crate::lightpaths::LampPaths::density_scale`].
    pub(crate) density_scale: f32,
    /// Uploaded lamps the density sums over.
    pub(crate) lamp_count: u32,
}

#[cfg(test)]
impl Mis {
    /// No lamp paths.
    pub(crate) const NONE: Mis = Mis {
        rays: 0,
        lamp_paths: 0,
        density_scale: 0.0,
        lamp_count: 0,
    };
}

/// The buffers of [`gather_row`], reused from row to row.
#[derive(Default)]
pub(crate) struct GatherScratch {
    /// The row's texels with rays.
    pub(crate) texels: Vec<GatherTexel>,
    /// Their columns in the row, from `x0`.
    pub(crate) at: Vec<usize>,
    /// The stage buffers of [`gather_sums`].
    pub(crate) chunks: [GatherChunk; 2],
    /// Per texel of `texels`, its sum.
    pub(crate) sums: Vec<[f32; 3]>,
}

/// Row `[layer, x0, y, width]`'s key among the recorded gather rows and the hash of its
/// `texels`' rays' starts: index, ray range, origin and normal ([`crate::cpu::hits`]).
fn row_key(
    params: &GatherParams,
    trav: Trav,
    row: [u32; 4],
    texels: &[GatherTexel],
) -> (RowKey, u64) {
    let key = RowKey {
        rays: [
            params.sampler,
            params.bounce,
            params.seed,
            params.stride,
            params.rays,
            params.orphan_rays,
            params.first_ray,
            params.chunk_rays,
        ],
        traversal: trav.id(),
        row,
    };
    let mut h = WordHash::new();
    for t in texels {
        h.add(t.texel);
        h.add(t.rays.start);
        h.add(t.rays.end);
        h.add(u32::from(t.uniform));
        for c in t.o.into_iter().chain(t.frame.n) {
            h.add(c.to_bits());
        }
    }
    (key, h.finish())
}

/// The gathered indirect illuminance at texels `x0 ..` of row `y` (`out`: RGBA per texel; see
/// the module docs), their rays traced together ([`gather_sums`]); with
/// [`GatherParams::stride`] > 1 only grid texels and orphans are gathered ([`coarse_rays`]),
/// the others written as 0 for [`upsample_texel`].
#[allow(clippy::too_many_arguments)]
pub(crate) fn gather_row(
    scene: &CpuScene,
    [pos_map, nrm_map, reflected, connected, prior, albedo]: [View<'_>; 6],
    trav: Trav,
    params: GatherParams,
    masks: Option<&CoarseMasks>,
    [layer, x0, y]: [u32; 3],
    out: &mut [f32],
    scratch: &mut GatherScratch,
) {
    let GatherScratch {
        texels,
        at,
        chunks,
        sums,
    } = scratch;
    texels.clear();
    at.clear();
    let sampler = rng::Sampler::from_id(params.sampler);
    for (i, texel) in out.chunks_exact_mut(4).enumerate() {
        let x = x0 + i as u32;
        let here = Texel { layer, x, y };
        let pos = pos_map.fetch(here);
        if pos[3] <= 0.5 {
            texel.copy_from_slice(&[0.0; 4]);
            continue;
        }
        texel.copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
        let Some(n) = normalize(xyz(nrm_map.fetch(here))) else {
            continue;
        };
        let rays = coarse_rays([pos_map, nrm_map], &params, masks, here);
        if rays == 0 {
            continue;
        }
        // A chunk of the rays (see `GatherParams::chunk_rays`).
        let first = params.first_ray.min(rays);
        let count = if params.chunk_rays > 0 {
            params.chunk_rays.min(rays - first)
        } else {
            rays - first
        };
        let stream = rng::Stream::gather(sampler, scene.layer_size, [layer, x, y], params.stride, rays);
        texels.push(GatherTexel {
            texel: stream.key,
            rays: stream.first + first..stream.first + first + count,
            o: offset_origin(xyz(pos), n, scene.ray_epsilon),
            frame: Frame::new(n),
            mis: Mis {
                rays,
                lamp_paths: params.lamp_paths,
                density_scale: params.density_scale,
                lamp_count: params.lamp_count,
            },
            uniform: pos[3] >= NARROW_GAP,
        });
        at.push(i);
    }
    let draws = [params.sampler, params.bounce, params.seed];
    // The row's hits replayed when they were recorded for these rays, else traced (and
    // recorded while the budget allows).
    let width = (out.len() / 4) as u32;
    let cache = scene
        .hits
        .as_deref()
        .filter(|_| !texels.is_empty())
        .map(|c| (c, row_key(&params, trav, [layer, x0, y, width], texels)));
    let rays: usize = texels.iter().map(|t| t.rays.len()).sum();
    let row = cache.and_then(|(c, (key, inputs))| c.row(&scene.bvh, &key, inputs, rays));
    let mut hits = match (&row, cache) {
        (Some(row), _) => Hits::Replay(row, 0),
        (None, Some((c, _))) if c.has_room(rays) => Hits::Record(Vec::with_capacity(rays)),
        _ => Hits::Trace,
    };
    let source = Source::new(
        reflected,
        albedo,
        [params.direct_at_hits, params.lamp_count],
        false,
    );
    gather_sums(scene, source, trav, draws, texels, &mut hits, chunks, sums);
    if let Some((c, (key, inputs))) = cache {
        if let Hits::Record(recorded) = hits {
            c.record(&scene.bvh, key, inputs, recorded);
        }
        c.count(rays, row.is_some());
    }
    for ((t, sum), &i) in texels.iter().zip(sums.iter()).zip(at.iter()) {
        let inv = 1.0 / t.mis.rays as f32;
        let here = Texel {
            layer,
            x: x0 + i as u32,
            y,
        };
        let c = if params.lamp_paths > 0 && params.first_ray == 0 {
            connected.fetch(here)
        } else {
            [0.0; 4]
        };
        let p = if params.first_ray > 0 {
            prior.fetch(here)
        } else {
            [0.0; 4]
        };
        out[4 * i..4 * i + 4].copy_from_slice(&[
            guard(p[0] + (sum[0] * inv + c[0])),
            guard(p[1] + (sum[1] * inv + c[1])),
            guard(p[2] + (sum[2] * inv + c[2])),
            1.0,
        ]);
    }
}
