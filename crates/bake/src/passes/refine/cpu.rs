//! The CPU reference of pass `refine` (the semantics the shaders mirror).

use crate::backend::offset_origin;
use crate::passes::gather::cpu::{GatherChunk, GatherTexel, Hits, Mis, gather_sums};
use crate::rng;
use crate::cpu::kernel::*;

use super::RefineParams;

/// The refinement for one dispatch.
pub(crate) type Pass = RefineParams;

impl TexelPass for RefineParams {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, at: Texel) -> [f32; 4] {
        let [pos_map, nrm_map, reflected, first_map, variance, connected] = ctx.maps();
        let (scene, params) = (ctx.scene, *self);
        let pos = pos_map.fetch(at);
        let first = first_map.fetch(at);
        if pos[3] <= 0.5 {
            return [0.0; 4];
        }
        let n = normalize(xyz(nrm_map.fetch(at)));
        let (Some(n), 1..) = (n, params.rays) else {
            return first;
        };
        let noise = variance.fetch(at);
    if noise[2].max(0.0).sqrt() <= params.max_error * noise[1] {
        return first;
    }
    let stream = rng::Stream::refine(
        rng::Sampler::from_id(params.sampler),
        scene.layer_size,
        [at.layer, at.x, at.y],
        params.first_rays,
        params.rays,
    );
    let texel = GatherTexel {
        texel: stream.key,
        rays: stream.first..stream.first + params.rays,
        o: offset_origin(xyz(pos), n, scene.ray_epsilon),
        frame: Frame::new(n),
        mis: Mis {
            rays: params.first_rays,
            lamp_paths: params.lamp_paths,
            density_scale: params.density_scale,
            lamp_count: params.lamp_count,
        },
    };
    let sampler = [params.sampler, params.bounce, params.seed];
    let mut sums = Vec::with_capacity(1);
    let mut chunks = [GatherChunk::default(), GatherChunk::default()];
    gather_sums(
        scene,
        reflected,
        ctx.trav,
        sampler,
        &[texel],
        &mut Hits::Trace,
        &mut chunks,
        &mut sums,
    );
    let [sum] = sums[..] else {
        return first;
    };
    // The second estimate's lamp-path part `C₂` (see the module docs):
    // `(N·first + Σ + rays·C₂) / (N + rays)`.
    let paths = if params.lamp_paths > 0 {
        connected.fetch(at)
    } else {
        [0.0; 4]
    };
    let total = (params.first_rays + params.rays) as f32;
    let (k, more) = (params.first_rays as f32, params.rays as f32);
    let refined = |c: usize| guard((k * first[c] + sum[c] + more * paths[c]) / total);
    [refined(0), refined(1), refined(2), 1.0]
}
}
