// Pass "combine" (paper Figure 4, box 6): direct + indirect illuminance, weighted
// (lux_pass.a_weight * a + lux_pass.b_weight * b; the paper's combine has both weights 1),
// clamped at 0; or by lux_pass.mode the bias correction's steps (program::correction_steps):
// the luminances of a and b (1), a scaled by b.r / b.g (2). As cpu::combine_texel.

fn lux_run(c: vec2<i32>) -> vec4<f32> {
    let a = lux_load(lux_direct, c);
    let b = lux_load(lux_indirect, c);
    if (lux_pass.mode == 1u) {
        return vec4<f32>(lux_guard(lux_luminance(a.rgb)), lux_guard(lux_luminance(b.rgb)), 0.0,
                         a.a);
    }
    if (lux_pass.mode == 2u) {
        var r = 1.0;
        if (b.g > 0.0) {
            r = b.r / b.g;
        }
        return vec4<f32>(lux_guard3(a.rgb * r), a.a);
    }
    let s = lux_pass.a_weight * a.rgb + lux_pass.b_weight * b.rgb;
    return vec4<f32>(lux_guard3(s), a.a);
}
