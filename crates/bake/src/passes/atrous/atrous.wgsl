// Pass "atrous": one iteration of the edge-stopping a-trous wavelet filter (Dammertz et al.
// 2010, SVGF; cpu::atrous_texel, program::atrous_steps). 5x5 taps lux_pass.step texels apart
// on the centre's surface, weighted by the B3 spline, a power of the normals' cosine and a
// Gaussian of the luminance difference in units of the centre's noise (the variance map), in
// mirrored pairs (program::atrous_steps, "Mirrored pairs"). The sum is taken relative to the
// centre, which is itself a tap: a constant field is returned exactly. Inside a wide chart with
// little noise (every pair counts, variance under lux_pass.wide_max_relative_variance x the
// window's squared mean; program::atrous_steps, "Wide charts with little noise") the scale is
// lux_pass.wide_variance_scale: both sums are taken there, the one that counts known at the end.
// lux_pass.narrow_variance_scale: lux_pass.variance_scale at a centre in a narrow gap
// (position w >= LUX_NARROW_GAP), whose first bounce has more rays; lux_pass.narrow_keep: such
// a centre keeps its value (the iteration's taps reach beyond the gap, program::atrous_steps,
// "Narrow gaps").
// lux_pass.linear: the bias correction's filter of two luminances (program::correction_steps):
// no luminance term, the variance map not read.

fn lux_b3(i: i32) -> f32 {
    return select(select(0.0625, 0.25, i == 1 || i == -1), 0.375, i == 0);
}

fn lux_run(c: vec2<i32>) -> vec4<f32> {
    let centre = lux_load(lux_src, c);
    if (centre.a <= 0.5) {
        return vec4<f32>(0.0);
    }
    let linear = lux_pass.linear != 0u;
    let kept = vec4<f32>(lux_guard3(centre.rgb), 1.0);
    let narrow = lux_load(lux_position, c).w >= LUX_NARROW_GAP;
    if (narrow && lux_pass.narrow_keep != 0u) {
        return kept;
    }
    var g: LuxGuide;
    if (!lux_guide(c, lux_pass.reach_min, lux_pass.reach, &g)) {
        return kept;
    }
    // The linear filter does not read the variance map.
    var v = vec4<f32>(0.0);
    if (!linear) {
        v = lux_load(lux_variance, c);
    }
    let scale = select(lux_pass.variance_scale, lux_pass.narrow_variance_scale, narrow) * v.r;
    let wide = lux_pass.wide_variance_scale * v.r;
    let quiet = !linear && lux_pass.wide_max_relative_variance > 0.0 &&
                v.r < lux_pass.wide_max_relative_variance * (v.g * v.g);
    // A step beyond the layer only reaches the centre (and cannot overflow).
    let size = vec2<i32>(i32(lux_tile.layer_w), i32(lux_tile.layer_h));
    var step = lux_pass.step;
    if ((step < -size.x && step < -size.y) || (step > size.x && step > size.y)) {
        step = 0;
    }
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    var wide_sum = vec3<f32>(0.0);
    var wide_wsum = 0.0;
    var pairs = 0;
    // Taps in mirrored pairs o, -o (the centre alone last): a pair counts only when both of
    // its taps are on the surface, so the kernel stays point-symmetric at a chart's edge.
    for (var k = 0; k < 13; k++) {
        let i = k % 5 - 2;
        let j = k / 5 - 2;
        var tn: vec4<f32>;
        var tf: vec4<f32>;
        var cn: f32;
        var cf: f32;
        if (!lux_tap(g, vec2<i32>(i * step, j * step), &tn, &cn) || !(cn > 0.0)) {
            continue;
        }
        let pair = k != 12;
        if (pair && (!lux_tap(g, vec2<i32>(-i * step, -j * step), &tf, &cf) || !(cf > 0.0))) {
            continue;
        }
        if (pair) {
            pairs++;
        }
        let sides = select(1, 2, pair);
        for (var side = 0; side < sides; side++) {
            let t = select(tf, tn, side == 0);
            var wn = select(cf, cn, side == 0);
            for (var e = 0u; e < lux_pass.normal_log2; e++) {
                if (wn == 0.0 || wn == 1.0) {
                    break;
                }
                wn *= wn;
            }
            let d = t.rgb - centre.rgb;
            let dl = lux_luminance(d) * lux_pass.luminance_scale;
            let sets = select(1, 2, quiet);
            for (var s = 0; s < sets; s++) {
                let sc = select(wide, scale, s == 0);
                var wl: f32;
                if (linear || dl == 0.0) {
                    wl = 1.0;
                } else if (sc > 0.0) {
                    wl = exp(-(dl * dl) / sc);
                } else {
                    wl = 0.0;
                }
                let w = lux_b3(i) * lux_b3(j) * wn * wl;
                if (!(w > 0.0)) {
                    continue;
                }
                if (s == 0) {
                    sum += w * d;
                    wsum += w;
                } else {
                    wide_sum += w * d;
                    wide_wsum += w;
                }
            }
        }
    }
    if (quiet && pairs == 12) {
        sum = wide_sum;
        wsum = wide_wsum;
    }
    if (wsum > 0.0) {
        return vec4<f32>(lux_guard3(vec3<f32>(centre.r + sum.x / wsum, centre.g + sum.y / wsum,
                                              centre.b + sum.z / wsum)), 1.0);
    }
    return kept;
}
