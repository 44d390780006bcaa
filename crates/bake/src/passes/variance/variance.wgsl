// Pass "variance": the noise variance of the luminance at a texel, for the atrous pass's
// edge-stopping and for refinement (cpu::variance_texel; the derivation is
// program::atrous_steps'). In the 5x5 window of taps on the centre's surface facing within 25
// degrees, for each direction (1, 0), (0, 1), (1, 1), (1, -1) with at least min_pairs pairs of
// taps: half the mean squared luminance difference of the pairs; the smallest wins (the
// direction along the signal's edges sees only noise). No direction: 0. Output (variance,
// then with the centre left out -- refinement's decision must not depend on the centre's own
// noise -- the mean luminance of the taps and their variance, and the luminance of the texel's
// direct light (`direct`), against which refinement weighs the noise: refine::refines).

// A window tap (i, j), -2..2 each: whether it lies on the centre's surface facing within
// LUX_BLUR_NORMAL_COS, and then its luminance in the pass's units (else 0).
fn lux_window_tap(g: LuxGuide, i: i32, j: i32, lum: ptr<function, f32>) -> bool {
    var t: vec4<f32>;
    var cosine: f32;
    let ok = lux_tap(g, vec2<i32>(i, j), &t, &cosine) && cosine >= LUX_BLUR_NORMAL_COS;
    *lum = select(0.0, lux_luminance(t.rgb) * lux_pass.luminance_scale, ok);
    return ok;
}

// A pair of taps, k and b = k + the direction: (the squared luminance difference, 1) for the
// estimate with the centre and, unless the pair touches it, for the one without; zeros where
// a tap is off the surface. Added to a direction's sums, zeros change nothing.
fn lux_pair(ok_k: bool, lum_k: f32, ok_b: bool, lum_b: f32, centre: bool) -> vec4<f32> {
    if (!(ok_k && ok_b)) {
        return vec4<f32>(0.0);
    }
    let diff = lum_b - lum_k;
    let d2 = diff * diff;
    return select(vec4<f32>(d2, 1.0, d2, 1.0), vec4<f32>(d2, 1.0, 0.0, 0.0), centre);
}

// One direction's estimate of cpu::window_variances (its pairs' sum and count): taken as `best`
// when it has enough pairs and is the first so or smaller.
fn lux_consider(sum: f32, count: f32, found: ptr<function, bool>, best: ptr<function, f32>) {
    let n = u32(count);
    if (n >= lux_pass.min_pairs && n > 0u) {
        let v = sum / f32(2u * n);
        if (!*found || v < *best) {
            *best = v;
            *found = true;
        }
    }
}

// cpu::window_variances' choice for one estimate: the smallest of the directions' with enough
// pairs, in the order (1, 0), (0, 1), (1, 1), (1, -1) (the components of `sums` and
// `counts`), else 0.
fn lux_smallest(sums: vec4<f32>, counts: vec4<f32>) -> f32 {
    var found = false;
    var best = 0.0;
    lux_consider(sums.x, counts.x, &found, &best);
    lux_consider(sums.y, counts.y, &found, &best);
    lux_consider(sums.z, counts.z, &found, &best);
    lux_consider(sums.w, counts.w, &found, &best);
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
    // The window row by row, two rows held at a time (no array: a variable index into one
    // makes drivers keep it in memory, and naga's SPIR-V copy it at every access): each
    // direction's pairs (cpu::window_variances) are summed in the order of their first tap,
    // row-major, as a pass over the whole window would. Per direction (1, 0), (0, 1), (1, 1),
    // (1, -1): (sum, count) with the centre, then without.
    var d10 = vec4<f32>(0.0);
    var d01 = vec4<f32>(0.0);
    var d11 = vec4<f32>(0.0);
    var d1m = vec4<f32>(0.0);
    var p0 = 0.0;
    var p1 = 0.0;
    var p2 = 0.0;
    var p3 = 0.0;
    var p4 = 0.0;
    var q0 = false;
    var q1 = false;
    var q2 = false;
    var q3 = false;
    var q4 = false;
    // The mean luminance of the taps but the centre (cpu::variance_texel), for refinement and
    // the denoiser's wide term (atrous).
    var sum = 0.0;
    var count = 0u;
    for (var j = 0; j < 5; j++) {
        var l0: f32;
        var l1: f32;
        var l2: f32;
        var l3: f32;
        var l4: f32;
        let k0 = lux_window_tap(g, -2, j - 2, &l0);
        let k1 = lux_window_tap(g, -1, j - 2, &l1);
        let k2 = lux_window_tap(g, 0, j - 2, &l2);
        let k3 = lux_window_tap(g, 1, j - 2, &l3);
        let k4 = lux_window_tap(g, 2, j - 2, &l4);
        // The centre is tap (2, 2): in this row when j = 2, in the one before when j = 3.
        let here = j == 2;
        let before = j == 3;
        d10 += lux_pair(k0, l0, k1, l1, false);
        d10 += lux_pair(k1, l1, k2, l2, here);
        d10 += lux_pair(k2, l2, k3, l3, here);
        d10 += lux_pair(k3, l3, k4, l4, false);
        if (j > 0) {
            d01 += lux_pair(q0, p0, k0, l0, false);
            d01 += lux_pair(q1, p1, k1, l1, false);
            d01 += lux_pair(q2, p2, k2, l2, here || before);
            d01 += lux_pair(q3, p3, k3, l3, false);
            d01 += lux_pair(q4, p4, k4, l4, false);
            d11 += lux_pair(q0, p0, k1, l1, false);
            d11 += lux_pair(q1, p1, k2, l2, here);
            d11 += lux_pair(q2, p2, k3, l3, before);
            d11 += lux_pair(q3, p3, k4, l4, false);
            d1m += lux_pair(k0, l0, q1, p1, false);
            d1m += lux_pair(k1, l1, q2, p2, before);
            d1m += lux_pair(k2, l2, q3, p3, here);
            d1m += lux_pair(k3, l3, q4, p4, false);
        }
        // The mean's taps in order, the centre left out (a tap off the surface adds its 0).
        sum += l0;
        sum += l1;
        sum += select(l2, 0.0, here);
        sum += l3;
        sum += l4;
        count += u32(k0) + u32(k1) + u32(k2 && !here) + u32(k3) + u32(k4);
        p0 = l0;
        p1 = l1;
        p2 = l2;
        p3 = l3;
        p4 = l4;
        q0 = k0;
        q1 = k1;
        q2 = k2;
        q3 = k3;
        q4 = k4;
    }
    let with_centre = lux_smallest(vec4<f32>(d10.x, d01.x, d11.x, d1m.x),
                                   vec4<f32>(d10.y, d01.y, d11.y, d1m.y));
    let without_centre = lux_smallest(vec4<f32>(d10.z, d01.z, d11.z, d1m.z),
                                      vec4<f32>(d10.w, d01.w, d11.w, d1m.w));
    var mean = 0.0;
    if (count > 0u) {
        mean = lux_guard(sum / f32(count));
    }
    return vec4<f32>(with_centre, mean, without_centre, direct);
}
