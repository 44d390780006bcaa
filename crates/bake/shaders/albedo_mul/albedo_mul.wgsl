// Pass "albedo multiply" (paper Figure 4, boxes 4 and 8): illuminance (lux) to exitance
// (lm/m^2), dst = (src.rgb * albedo.rgb, src.a).


@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let c = lux_texel(gid);
    if (c.x < 0) {
        return;
    }
    let layer = i32(lux_tile.layer);
    let a = textureLoad(lux_src, c, layer, 0);
    let b = textureLoad(lux_albedo, c, layer, 0);
    lux_store(c, vec4<f32>(lux_guard3(a.rgb * b.rgb), a.a));
}
