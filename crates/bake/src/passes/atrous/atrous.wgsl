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

// One tap's weight and value added to a sum of scale sc (its luminance term's; unused by the
// linear filter).
fn lux_atrous_add(d: vec3<f32>, b: f32, wn: f32, dl: f32, sc: f32, linear: bool,
                  sum: ptr<function, vec3<f32>>, wsum: ptr<function, f32>) {
    var wl: f32;
    if (linear || dl == 0.0) {
        wl = 1.0;
    } else if (sc > 0.0) {
        wl = exp(-(dl * dl) / sc);
    } else {
        wl = 0.0;
    }
    let w = b * wn * wl;
    if (w > 0.0) {
        *sum += w * d;
        *wsum += w;
    }
}

// A tap on the surface (cosine > 0) with its B3 weight b: into the sum, and into the wide
// one at a quiet centre. The cosine's power: squaring keeps 0 and 1 as they are.
fn lux_atrous_tap(t: vec4<f32>, cosine: f32, centre: vec4<f32>, b: f32, scale: f32, wide: f32,
                  quiet: bool, linear: bool, sum: ptr<function, vec3<f32>>,
                  wsum: ptr<function, f32>, wide_sum: ptr<function, vec3<f32>>,
                  wide_wsum: ptr<function, f32>) {
    var wn = cosine;
    for (var e = 0u; e < lux_pass.normal_log2; e++) {
        wn *= wn;
    }
    let d = t.rgb - centre.rgb;
    let dl = lux_luminance(d) * lux_pass.luminance_scale;
    lux_atrous_add(d, b, wn, dl, scale, linear, sum, wsum);
    if (quiet) {
        lux_atrous_add(d, b, wn, dl, wide, linear, wide_sum, wide_wsum);
    }
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
    // its taps are on the surface, so the kernel stays point-symmetric at a chart's edge. Each
    // tap is one call, with no loop over a pair's sides or the two sums, as in atrous.glsl.
    for (var k = 0; k < 12; k++) {
        let i = k % 5 - 2;
        let j = k / 5 - 2;
        var tn: vec4<f32>;
        var tf: vec4<f32>;
        var cn: f32;
        var cf: f32;
        if (lux_tap(g, vec2<i32>(i * step, j * step), &tn, &cn) && cn > 0.0 &&
            lux_tap(g, vec2<i32>(-i * step, -j * step), &tf, &cf) && cf > 0.0) {
            pairs++;
            let b = lux_b3(i) * lux_b3(j);
            lux_atrous_tap(tn, cn, centre, b, scale, wide, quiet, linear, &sum, &wsum,
                           &wide_sum, &wide_wsum);
            lux_atrous_tap(tf, cf, centre, b, scale, wide, quiet, linear, &sum, &wsum,
                           &wide_sum, &wide_wsum);
        }
    }
    var tc: vec4<f32>;
    var cc: f32;
    if (lux_tap(g, vec2<i32>(0), &tc, &cc) && cc > 0.0) {
        lux_atrous_tap(tc, cc, centre, lux_b3(0) * lux_b3(0), scale, wide, quiet, linear, &sum,
                       &wsum, &wide_sum, &wide_wsum);
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
