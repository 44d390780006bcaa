//! The CPU reference of pass `refine` (the semantics the shaders mirror): a row's refined
//! texels' rays traced together, as the gather's ([`gather_sums`]).

use crate::backend::offset_origin;
use crate::cpu::kernel::*;
use crate::passes::gather::cpu::{GatherScratch, GatherTexel, Hits, Mis, Source, gather_sums};
use crate::rng;

use super::RefineParams;
use crate::validity::NARROW_GAP;

/// The refinement for one dispatch.
pub(crate) type Pass = RefineParams;

impl CpuPass for RefineParams {
    type Scratch = GatherScratch;

    fn row(&self, ctx: &Ctx<'_>, y: u32, out: &mut [f32], scratch: &mut GatherScratch) {
        let [pos_map, nrm_map, reflected, first_map, variance, connected, albedo] = ctx.maps();
        let (scene, params) = (ctx.scene, *self);
        scratch.texels.clear();
        scratch.at.clear();
        let sampler = rng::Sampler::from_id(params.sampler);
        let layer = ctx.tile.layer;
        // Every texel keeps the first gather's value (0 where invalid) unless it is refined.
        for (i, texel) in out.chunks_exact_mut(4).enumerate() {
            let here = Texel {
                layer,
                x: ctx.tile.x0 + i as u32,
                y,
            };
            let pos = pos_map.fetch(here);
            if pos[3] <= 0.5 {
                texel.copy_from_slice(&[0.0; 4]);
                continue;
            }
            texel.copy_from_slice(&first_map.fetch(here));
            // A texel the refinement passes over (most) reads no more.
            let more = params.more(pos[3] >= NARROW_GAP, || variance.fetch(here));
            if more == 0 {
                continue;
            }
            let Some(n) = normalize(xyz(nrm_map.fetch(here))) else {
                continue;
            };
            let at_texel = [layer, here.x, y];
            let stream = rng::Stream::refine(
                sampler,
                scene.layer_size,
                at_texel,
                params.first_rays,
                params.span(),
            );
            scratch.texels.push(GatherTexel {
                texel: stream.key,
                rays: stream.first..stream.first + more,
                o: offset_origin(xyz(pos), n, scene.ray_epsilon),
                frame: Frame::new(n),
                mis: Mis {
                    rays: params.first_rays,
                    lamp_paths: params.lamp_paths,
                    density_scale: params.density_scale,
                    lamp_count: params.lamp_count,
                },
                uniform: pos[3] >= NARROW_GAP,
            });
            scratch.at.push(i);
        }
        if scratch.texels.is_empty() {
            return;
        }
        let draws = [params.sampler, params.bounce, params.seed];
        gather_sums(
            scene,
            Source::new(
                reflected,
                albedo,
                [params.direct_at_hits, params.lamp_count],
                params.narrow_direct != 0,
            ),
            ctx.trav,
            draws,
            &scratch.texels,
            &mut Hits::Trace,
            &mut scratch.chunks,
            &mut scratch.sums,
        );
        for ((sum, &i), t) in scratch.sums.iter().zip(&scratch.at).zip(&scratch.texels) {
            let more = t.rays.len() as f32;
            // A texel in a gap with `narrow_direct` takes the second estimate alone (module
            // docs, "Narrow gaps").
            let k = if params.replaces(t.uniform) {
                0.0
            } else {
                params.first_rays as f32
            };
            let total = k + more;
            let here = Texel {
                layer,
                x: ctx.tile.x0 + i as u32,
                y,
            };
            let first = first_map.fetch(here);
            // The second estimate's lamp-path part `C₂` (see the module docs):
            // `(N·first + Σ + rays·C₂) / (N + rays)`.
            let paths = if params.lamp_paths > 0 {
                connected.fetch(here)
            } else {
                [0.0; 4]
            };
            let refined = |c: usize| guard((k * first[c] + sum[c] + more * paths[c]) / total);
            out[4 * i..4 * i + 4].copy_from_slice(&[refined(0), refined(1), refined(2), 1.0]);
        }
    }
}
