//! The CPU reference of pass `energy`: a row of the source summed in runs, in f32, in the
//! shaders' order.

use super::RUN;
use crate::cpu::kernel::*;

parameterless_pass! {
    /// The row sum.
    Pass
}

impl TexelPass for Pass {
    fn texel(&self, ctx: &Ctx<'_>, Texel { layer, x, .. }: Texel) -> [f32; 4] {
        let Some(src) = ctx.views.first() else {
            return [0.0, 0.0, 0.0, 1.0];
        };
        let width = src.size[0];
        let mut total = 0.0f32;
        let mut x0 = 0;
        while x0 < width {
            let mut run = 0.0f32;
            for sx in x0..(x0 + RUN).min(width) {
                let t = src.fetch(Texel { layer, x: sx, y: x });
                if t[3] > 0.5 {
                    run += (t[0] + t[1]) + t[2];
                }
            }
            total += run;
            x0 += RUN;
        }
        [total, 0.0, 0.0, 1.0]
    }
}
