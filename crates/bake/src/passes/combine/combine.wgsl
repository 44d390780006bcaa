// Pass "combine" (paper Figure 4, box 6): direct + indirect illuminance, weighted
// (lux_pass.a_weight * a + lux_pass.b_weight * b; the paper's combine has both weights 1).

fn lux_run(c: vec2<i32>) -> vec4<f32> {
    let layer = i32(lux_tile.layer);
    let a = textureLoad(lux_direct, c, layer, 0);
    let b = textureLoad(lux_indirect, c, layer, 0);
    return vec4<f32>(lux_guard3(lux_pass.a_weight * a.rgb + lux_pass.b_weight * b.rgb), a.a);
}
