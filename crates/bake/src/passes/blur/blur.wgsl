// Pass "blur" (paper Figure 4, boxes 3 and 7): one axis of the separable Gaussian, over valid
// texels of the centre's object whose normal is within 25 degrees of the centre's
// (cpu::blur_texel). The empty texels between charts and the edges of the layer are skipped
// explicitly, so nothing bleeds in and no clamping of out-of-range loads is relied on.


fn lux_run(c: vec2<i32>) -> vec4<f32> {
    let centre = lux_load(lux_src, c);
    if (centre.a <= 0.5) {
        return vec4<f32>(0.0);
    }
    let nc = lux_load(lux_normal, c);
    let object = nc.w;
    var n0: vec3<f32>;
    if (!lux_normalize(nc.xyz, &n0)) {
        return centre;
    }
    let size = vec2<i32>(i32(lux_tile.layer_w), i32(lux_tile.layer_h));
    let step = vec2<i32>(lux_pass.step_x, lux_pass.step_y);
    let radius = clamp(lux_pass.radius, 0, LUX_MAX_BLUR_RADIUS);
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var k = -radius; k <= radius; k++) {
        let t = c + k * step;
        if (t.x < 0 || t.y < 0 || t.x >= size.x || t.y >= size.y) {
            continue;
        }
        let tv = lux_load(lux_src, t);
        if (tv.a <= 0.5) {
            continue;
        }
        let nt = lux_load(lux_normal, t);
        if (nt.w != object) {
            continue;
        }
        var n1: vec3<f32>;
        if (!lux_normalize(nt.xyz, &n1) || !(lux_dot(n0, n1) >= LUX_BLUR_NORMAL_COS)) {
            continue;
        }
        let w = exp(f32(k * k) * lux_pass.inv);
        sum += w * tv.rgb;
        wsum += w;
    }
    if (wsum > 0.0) {
        return vec4<f32>(lux_guard3(vec3<f32>(sum.x / wsum, sum.y / wsum, sum.z / wsum)), 1.0);
    }
    return centre;
}
