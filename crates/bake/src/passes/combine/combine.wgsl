// Pass "combine" (paper Figure 4, box 6): direct + indirect illuminance, weighted
// (lux_pass.a_weight * a + lux_pass.b_weight * b; the paper's combine has both weights 1).

fn lux_run(c: vec2<i32>) -> vec4<f32> {
    let a = lux_load(lux_direct, c);
    let b = lux_load(lux_indirect, c);
    return vec4<f32>(lux_guard3(lux_pass.a_weight * a.rgb + lux_pass.b_weight * b.rgb), a.a);
}
