// Pass "variance": the noise variance of the luminance at a texel, for the atrous pass's
// edge-stopping and for refinement (cpu::variance_texel; the derivation is
// program::atrous_steps'). In the 5x5 window of taps on the centre's surface facing within 25
// degrees, for each direction (1, 0), (0, 1), (1, 1), (1, -1) with at least min_pairs pairs of
// taps: half the mean squared luminance difference of the pairs; the smallest wins (the
// direction along the signal's edges sees only noise). No direction: 0. Output (variance,
// then with the centre left out -- refinement's decision must not depend on the centre's own
// noise -- the mean luminance of the taps and their variance, and the luminance of the texel's
// direct light (`direct`), against which refinement weighs the noise: refine::refines).

// The smallest of the four directions' estimates over the taps `ok` (cpu::window_variances).
// The window is read through pointers: indexing an array value with a variable index makes
// naga's SPIR-V copy the whole array at every access (on lavapipe the pass took 7.5 times
// glow's on llvmpipe).
fn lux_window_variance(lum: ptr<function, array<f32, 25>>, ok: ptr<function, array<bool, 25>>)
    -> f32 {
    var dirs = array<vec2<i32>, 4>(vec2<i32>(1, 0), vec2<i32>(0, 1), vec2<i32>(1, 1),
                                   vec2<i32>(1, -1));
    var found = false;
    var best = 0.0;
    for (var e = 0; e < 4; e++) {
        var sum = 0.0;
        var n = 0u;
        for (var k = 0; k < 25; k++) {
            let i = k % 5 + dirs[e].x;
            let j = k / 5 + dirs[e].y;
            if (i < 0 || i >= 5 || j < 0 || j >= 5) {
                continue;
            }
            let b = j * 5 + i;
            if ((*ok)[k] && (*ok)[b]) {
                let diff = (*lum)[b] - (*lum)[k];
                sum += diff * diff;
                n += 1u;
            }
        }
        if (n >= lux_pass.min_pairs && n > 0u) {
            let v = sum / f32(2u * n);
            if (!found || v < best) {
                best = v;
                found = true;
            }
        }
    }
    return lux_guard(best);
}

fn lux_run(c: vec2<i32>) -> vec4<f32> {
    if (lux_load(lux_src, c).a <= 0.5) {
        return vec4<f32>(0.0);
    }
    // The texel's direct light, for refinement's decision (refine::refines).
    let direct = lux_guard(lux_luminance(lux_load(lux_direct, c).rgb) * lux_pass.luminance_scale);
    var g: LuxGuide;
    if (!lux_guide(c, 0.0, lux_pass.reach, &g)) {
        return vec4<f32>(0.0, 0.0, 0.0, direct);
    }
    // The window, row by row: the luminance of each tap on the surface.
    var lum: array<f32, 25>;
    var ok: array<bool, 25>;
    for (var k = 0; k < 25; k++) {
        var t: vec4<f32>;
        var cosine: f32;
        ok[k] = lux_tap(g, vec2<i32>(k % 5 - 2, k / 5 - 2), &t, &cosine)
            && cosine >= LUX_BLUR_NORMAL_COS;
        lum[k] = select(0.0, lux_luminance(t.rgb) * lux_pass.luminance_scale, ok[k]);
    }
    let with_centre = lux_window_variance(&lum, &ok);
    ok[12] = false;
    let without_centre = lux_window_variance(&lum, &ok);
    // The mean luminance without the centre (cpu::variance_texel), for refinement and the
    // denoiser's wide term (atrous).
    var sum = 0.0;
    var count = 0u;
    for (var k = 0; k < 25; k++) {
        if (ok[k]) {
            sum += lum[k];
            count += 1u;
        }
    }
    var mean = 0.0;
    if (count > 0u) {
        mean = lux_guard(sum / f32(count));
    }
    return vec4<f32>(with_centre, mean, without_centre, direct);
}
