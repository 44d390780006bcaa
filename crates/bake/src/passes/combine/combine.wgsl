// Pass "combine" (paper Figure 4, box 6): direct + indirect illuminance, weighted
// (lux_pass.a_weight * a + lux_pass.b_weight * b; the paper's combine has both weights 1),
// clamped at 0 unless signed (the bias correction's residual, program::correction_steps).

fn lux_run(c: vec2<i32>) -> vec4<f32> {
    let a = lux_load(lux_direct, c);
    let b = lux_load(lux_indirect, c);
    let s = lux_pass.a_weight * a.rgb + lux_pass.b_weight * b.rgb;
    if (lux_pass.signed != 0u) {
        return vec4<f32>(lux_guard_signed3(s), a.a);
    }
    return vec4<f32>(lux_guard3(s), a.a);
}
