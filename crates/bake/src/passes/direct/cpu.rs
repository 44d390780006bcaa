//! The CPU reference of pass `direct` (the semantics the shaders mirror).

use luxbake_bvh::Ray;

use crate::backend::{LampView, lamp_toward, offset_origin};
use crate::cpu::kernel::*;

use super::DirectParams;

/// The direct pass for one dispatch.
pub(crate) type Pass = DirectParams;

impl TexelPass for DirectParams {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, layer: u32, x: u32, y: u32) -> [f32; 4] {
        let v = ctx.views;
        direct_texel(
            ctx.scene,
            *self,
            ctx.trav,
            v[0].fetch(layer, x, y),
            v[1].fetch(layer, x, y),
        )
    }
}

/// The direct illuminance at one texel (see the module docs).
pub(crate) fn direct_texel(
    scene: &CpuScene,
    params: DirectParams,
    trav: Trav,
    pos: [f32; 4],
    nrm: [f32; 4],
) -> [f32; 4] {
    if pos[3] <= 0.5 {
        return [0.0; 4];
    }
    let p = xyz(pos);
    let Some(n) = normalize(xyz(nrm)) else {
        return [0.0, 0.0, 0.0, 1.0];
    };
    let mut e = [0.0f32; 3];
    for lamp in scene.lamps.iter().take(params.lamp_count as usize) {
        let Some(LampView {
            d2,
            d,
            w,
            cos,
            intensity,
        }) = lamp_toward(lamp, &scene.tables, p, n)
        else {
            continue;
        };
        let o0 = offset_origin(p, n, scene.ray_epsilon);
        let off = sub(o0, p);
        let off2 = dot(off, off);
        let o = if 16.0 * off2 > d2 {
            mad(p, n, 0.25 * d)
        } else {
            o0
        };
        let dir = sub(lamp.position, o);
        let len = dot(dir, dir).sqrt();
        let back = [-w[0], -w[1], -w[2]];
        let lamp_off = sub(
            offset_origin(lamp.position, back, scene.ray_epsilon),
            lamp.position,
        );
        let stop = dot(lamp_off, lamp_off).sqrt().min(0.25 * d);
        let t_max = 1.0 - stop / len;
        if len > 0.0 && t_max > 0.0 && scene.any_hit(&Ray { origin: o, dir }, 0.0, t_max, trav) {
            continue;
        }
        let k = intensity * cos / d2.max(off2);
        for (ec, sc) in e.iter_mut().zip(lamp.scale) {
            *ec += k * sc;
        }
    }
    [guard(e[0]), guard(e[1]), guard(e[2]), 1.0]
}
