// Pass "albedo multiply" (paper Figure 4, boxes 4 and 8): illuminance (lux) to exitance
// (lm/m^2), dst = (src.rgb * albedo.rgb, src.a).


fn lux_run(c: vec2<i32>) -> vec4<f32> {
    let a = lux_load(lux_src, c);
    let b = lux_load(lux_albedo, c);
    return vec4<f32>(lux_guard3(a.rgb * b.rgb), a.a);
}
