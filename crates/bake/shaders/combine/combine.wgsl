// Pass "combine" (paper Figure 4, box 6): direct + indirect illuminance.


@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let c = lux_texel(gid);
    if (c.x < 0) {
        return;
    }
    let layer = i32(lux_tile.layer);
    let a = textureLoad(lux_direct, c, layer, 0);
    let b = textureLoad(lux_indirect, c, layer, 0);
    lux_store(c, vec4<f32>(lux_guard3(a.rgb + b.rgb), a.a));
}
