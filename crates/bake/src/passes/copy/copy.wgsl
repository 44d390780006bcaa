// Pass "copy" (paper Figure 4, box 2 -> 3 and 6 -> 7): texel-for-texel copy.


fn lux_run(c: vec2<i32>) -> vec4<f32> {
    return lux_load(lux_src, c);
}
