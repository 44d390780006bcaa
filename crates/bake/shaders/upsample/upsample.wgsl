// Pass "upsample": fills the texels a reduced-resolution gather left out with the bilinear,
// surface-masked mean of its grid-cell corners (coarse.wgsl; cpu::upsample_texel). Grid
// texels and orphans keep the gathered value.
// Parameters (program::UpsampleParams): the gather's stride and reach.

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let c = lux_texel(gid);
    if (c.x < 0) {
        return;
    }
    let layer = i32(lux_tile.layer);
    if (textureLoad(lux_position, c, layer, 0).w <= 0.5) {
        lux_store(c, vec4<f32>(0.0));
        return;
    }
    let own = textureLoad(lux_src, c, layer, 0);
    let k = lux_coarse_weights(c, lux_pass.stride, lux_pass.reach);
    let total = k.total;
    if (!(total > 0.0)) {
        lux_store(c, own);
        return;
    }
    var sum = vec3<f32>(0.0);
    for (var i = 0; i < 4; i++) {
        if (k.weights[i] > 0.0) {
            sum += k.weights[i] * textureLoad(lux_src, k.corners[i], layer, 0).rgb;
        }
    }
    lux_store(c, vec4<f32>(lux_guard3(vec3<f32>(sum.x / total, sum.y / total, sum.z / total)),
                           1.0));
}
