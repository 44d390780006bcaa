// Pass "upsample": fills the texels a reduced-resolution gather left out with the bilinear,
// surface-masked mean of its grid-cell corners (coarse.wgsl; cpu::upsample_texel). Grid
// texels and orphans keep the gathered value.
// Parameters (program::UpsampleParams): the gather's stride and reach.

fn lux_run(c: vec2<i32>) -> vec4<f32> {
    if (lux_load(lux_position, c).w <= 0.5) {
        return vec4<f32>(0.0);
    }
    let own = lux_load(lux_src, c);
    // A variable: its arrays are read with a variable index (see coarse.wgsl).
    var k = lux_coarse_weights(c, lux_pass.stride, lux_pass.reach);
    let total = k.total;
    if (!(total > 0.0)) {
        return own;
    }
    var sum = vec3<f32>(0.0);
    for (var i = 0; i < 4; i++) {
        if (k.weights[i] > 0.0) {
            sum += k.weights[i] * lux_load(lux_src, k.corners[i]).rgb;
        }
    }
    return vec4<f32>(lux_guard3(vec3<f32>(sum.x / total, sum.y / total, sum.z / total)), 1.0);
}
