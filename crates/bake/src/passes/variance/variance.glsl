// Pass "variance": the noise variance of the luminance at a texel, for the atrous pass's
// edge-stopping and for refinement (cpu::variance_texel; the derivation is
// program::atrous_steps'). In the 5x5 window of taps on the centre's surface facing within 25
// degrees, for each direction (1, 0), (0, 1), (1, 1), (1, -1) with at least u_min_pairs pairs
// of taps: half the mean squared luminance difference of the pairs; the smallest wins (the
// direction along the signal's edges sees only noise). No direction: 0. Output (variance,
// then with the centre left out -- refinement's decision must not depend on the centre's own
// noise -- the mean luminance of the taps and their variance, and the luminance of the texel's
// direct light (u_direct), against which refinement weighs the noise: refine::refines).
// Parameters (program::VarianceParams): u_reach = the chart test's farthest distance per
// texel of offset, metres; u_min_pairs; u_luminance_scale, a power of two every luminance is
// multiplied by first (its squares stay inside f32; the output is in those units).

// A window tap (i, j), -2..2 each: whether it lies on the centre's surface facing within
// LUX_BLUR_NORMAL_COS, and then its luminance in the pass's units (else 0).
bool luxWindowTap(LuxGuide g, int i, int j, out float lum) {
    vec4 t;
    float cosine;
    bool ok = luxTap(g, ivec2(i, j), t, cosine) && cosine >= LUX_BLUR_NORMAL_COS;
    lum = ok ? luxLuminance(t.rgb) * u_luminance_scale : 0.0;
    return ok;
}

// A pair of taps, k and b = k + the direction: (the squared luminance difference, 1) for the
// estimate with the centre and, unless the pair touches it, for the one without; zeros where
// a tap is off the surface. Added to a direction's sums, zeros change nothing.
vec4 luxPair(bool okK, float lumK, bool okB, float lumB, bool centre) {
    if (!(okK && okB)) {
        return vec4(0.0);
    }
    float diff = lumB - lumK;
    float d2 = diff * diff;
    return centre ? vec4(d2, 1.0, 0.0, 0.0) : vec4(d2, 1.0, d2, 1.0);
}

// One direction's estimate of cpu::window_variances (its pairs' sum and count): taken as `best`
// when it has enough pairs and is the first so or smaller.
void luxConsider(float sum, float count, inout bool found, inout float best) {
    uint n = uint(count);
    if (n >= u_min_pairs && n > 0u) {
        float v = sum / float(2u * n);
        if (!found || v < best) {
            best = v;
            found = true;
        }
    }
}

// cpu::window_variances' choice for one estimate: the smallest of the directions' with enough
// pairs, in the order (1, 0), (0, 1), (1, 1), (1, -1) (the components of `sums` and
// `counts`), else 0.
float luxSmallest(vec4 sums, vec4 counts) {
    bool found = false;
    float best = 0.0;
    luxConsider(sums.x, counts.x, found, best);
    luxConsider(sums.y, counts.y, found, best);
    luxConsider(sums.z, counts.z, found, best);
    luxConsider(sums.w, counts.w, found, best);
    return luxGuard(best);
}

vec4 luxRun(ivec3 c) {
    if (texelFetch(u_src, c, 0).a <= 0.5) {
        return vec4(0.0);
    }
    // The texel's direct light, for refinement's decision (refine::refines).
    float direct = luxGuard(luxLuminance(texelFetch(u_direct, c, 0).rgb) * u_luminance_scale);
    LuxGuide g;
    if (!luxGuide(c, 0.0, u_reach, g)) {
        return vec4(0.0, 0.0, 0.0, direct);
    }
    // The window row by row, two rows held at a time (no array: a variable index into one
    // makes drivers keep it in memory): each direction's pairs (cpu::window_variances) are
    // summed in the order of their first tap, row-major, as a pass over the whole window would.
    // Per direction (1, 0), (0, 1), (1, 1), (1, -1): (sum, count) with the centre, then without.
    vec4 d10 = vec4(0.0);
    vec4 d01 = vec4(0.0);
    vec4 d11 = vec4(0.0);
    vec4 d1m = vec4(0.0);
    float p0 = 0.0;
    float p1 = 0.0;
    float p2 = 0.0;
    float p3 = 0.0;
    float p4 = 0.0;
    bool q0 = false;
    bool q1 = false;
    bool q2 = false;
    bool q3 = false;
    bool q4 = false;
    // The mean luminance of the taps but the centre (cpu::variance_texel), for refinement and
    // the denoiser's wide term (atrous).
    float sum = 0.0;
    uint count = 0u;
    for (int j = 0; j < 5; ++j) {
        float l0;
        float l1;
        float l2;
        float l3;
        float l4;
        bool k0 = luxWindowTap(g, -2, j - 2, l0);
        bool k1 = luxWindowTap(g, -1, j - 2, l1);
        bool k2 = luxWindowTap(g, 0, j - 2, l2);
        bool k3 = luxWindowTap(g, 1, j - 2, l3);
        bool k4 = luxWindowTap(g, 2, j - 2, l4);
        // The centre is tap (2, 2): in this row when j = 2, in the one before when j = 3.
        bool here = j == 2;
        bool before = j == 3;
        d10 += luxPair(k0, l0, k1, l1, false);
        d10 += luxPair(k1, l1, k2, l2, here);
        d10 += luxPair(k2, l2, k3, l3, here);
        d10 += luxPair(k3, l3, k4, l4, false);
        if (j > 0) {
            d01 += luxPair(q0, p0, k0, l0, false);
            d01 += luxPair(q1, p1, k1, l1, false);
            d01 += luxPair(q2, p2, k2, l2, here || before);
            d01 += luxPair(q3, p3, k3, l3, false);
            d01 += luxPair(q4, p4, k4, l4, false);
            d11 += luxPair(q0, p0, k1, l1, false);
            d11 += luxPair(q1, p1, k2, l2, here);
            d11 += luxPair(q2, p2, k3, l3, before);
            d11 += luxPair(q3, p3, k4, l4, false);
            d1m += luxPair(k0, l0, q1, p1, false);
            d1m += luxPair(k1, l1, q2, p2, before);
            d1m += luxPair(k2, l2, q3, p3, here);
            d1m += luxPair(k3, l3, q4, p4, false);
        }
        // The mean's taps in order, the centre left out (a tap off the surface adds its 0).
        sum += l0;
        sum += l1;
        sum += here ? 0.0 : l2;
        sum += l3;
        sum += l4;
        count += uint(k0) + uint(k1) + uint(k2 && !here) + uint(k3) + uint(k4);
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
    float withCentre = luxSmallest(vec4(d10.x, d01.x, d11.x, d1m.x),
                                   vec4(d10.y, d01.y, d11.y, d1m.y));
    float withoutCentre = luxSmallest(vec4(d10.z, d01.z, d11.z, d1m.z),
                                      vec4(d10.w, d01.w, d11.w, d1m.w));
    float mean = count > 0u ? luxGuard(sum / float(count)) : 0.0;
    return vec4(withCentre, mean, withoutCentre, direct);
}
