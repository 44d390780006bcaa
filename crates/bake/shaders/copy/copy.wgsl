// Pass "copy" (paper Figure 4, box 2 -> 3 and 6 -> 7): texel-for-texel copy.


@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let c = lux_texel(gid);
    if (c.x < 0) {
        return;
    }
    lux_store(c, textureLoad(lux_src, c, i32(lux_tile.layer), 0));
}
