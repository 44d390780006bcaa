// Pass "atrous": one iteration of the edge-stopping a-trous wavelet filter (Dammertz et al.
// 2010, SVGF; cpu::atrous_texel, program::atrous_steps). 5x5 taps lux_pass.step texels apart
// on the centre's surface, weighted by the B3 spline, a power of the normals' cosine and a
// Gaussian of the luminance difference in units of the centre's noise (the variance map). The
// sum is taken relative to the centre, which is itself a tap: a constant field is returned
// exactly.

fn lux_b3(i: i32) -> f32 {
    return select(select(0.0625, 0.25, i == 1 || i == -1), 0.375, i == 0);
}

fn lux_run(c: vec2<i32>) -> vec4<f32> {
    let centre = lux_load(lux_src, c);
    if (centre.a <= 0.5) {
        return vec4<f32>(0.0);
    }
    let kept = vec4<f32>(lux_guard3(centre.rgb), 1.0);
    var g: LuxGuide;
    if (!lux_guide(c, lux_pass.reach_min, lux_pass.reach, &g)) {
        return kept;
    }
    let scale = lux_pass.variance_scale * lux_load(lux_variance, c).r;
    // A step beyond the layer only reaches the centre (and cannot overflow).
    let size = vec2<i32>(i32(lux_tile.layer_w), i32(lux_tile.layer_h));
    var step = lux_pass.step;
    if ((step < -size.x && step < -size.y) || (step > size.x && step > size.y)) {
        step = 0;
    }
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var j = -2; j <= 2; j++) {
        for (var i = -2; i <= 2; i++) {
            var t: vec4<f32>;
            var cosine: f32;
            if (!lux_tap(g, vec2<i32>(i * step, j * step), &t, &cosine) || !(cosine > 0.0)) {
                continue;
            }
            var wn = cosine;
            for (var k = 0u; k < lux_pass.normal_log2; k++) {
                if (wn == 0.0 || wn == 1.0) {
                    break;
                }
                wn *= wn;
            }
            let d = t.rgb - centre.rgb;
            let dl = lux_luminance(d) * lux_pass.luminance_scale;
            var wl: f32;
            if (dl == 0.0) {
                wl = 1.0;
            } else if (scale > 0.0) {
                wl = exp(-(dl * dl) / scale);
            } else {
                wl = 0.0;
            }
            let w = lux_b3(i) * lux_b3(j) * wn * wl;
            if (!(w > 0.0)) {
                continue;
            }
            sum += w * d;
            wsum += w;
        }
    }
    if (wsum > 0.0) {
        return vec4<f32>(lux_guard3(vec3<f32>(centre.r + sum.x / wsum, centre.g + sum.y / wsum,
                                              centre.b + sum.z / wsum)), 1.0);
    }
    return kept;
}
