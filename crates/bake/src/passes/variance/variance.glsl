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

// The smallest of the four directions' estimates over the taps `ok` (cpu::window_variances).
float luxWindowVariance(float lum[25], bool ok[25]) {
    ivec2 dirs[4] = ivec2[4](ivec2(1, 0), ivec2(0, 1), ivec2(1, 1), ivec2(1, -1));
    bool found = false;
    float best = 0.0;
    for (int e = 0; e < 4; ++e) {
        float sum = 0.0;
        uint n = 0u;
        for (int k = 0; k < 25; ++k) {
            int i = k % 5 + dirs[e].x;
            int j = k / 5 + dirs[e].y;
            if (i < 0 || i >= 5 || j < 0 || j >= 5) {
                continue;
            }
            int b = j * 5 + i;
            if (ok[k] && ok[b]) {
                float diff = lum[b] - lum[k];
                sum += diff * diff;
                n += 1u;
            }
        }
        if (n >= u_min_pairs && n > 0u) {
            float v = sum / float(2u * n);
            if (!found || v < best) {
                best = v;
                found = true;
            }
        }
    }
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
    // The window, row by row: the luminance of each tap on the surface.
    float lum[25];
    bool ok[25];
    for (int k = 0; k < 25; ++k) {
        vec4 t;
        float cosine;
        ok[k] = luxTap(g, ivec2(k % 5 - 2, k / 5 - 2), t, cosine)
            && cosine >= LUX_BLUR_NORMAL_COS;
        lum[k] = ok[k] ? luxLuminance(t.rgb) * u_luminance_scale : 0.0;
    }
    float withCentre = luxWindowVariance(lum, ok);
    ok[12] = false;
    float withoutCentre = luxWindowVariance(lum, ok);
    // The mean luminance without the centre (cpu::variance_texel), for refinement and the
    // denoiser's wide term (atrous).
    float sum = 0.0;
    uint count = 0u;
    for (int k = 0; k < 25; ++k) {
        if (ok[k]) {
            sum += lum[k];
            count += 1u;
        }
    }
    float mean = count > 0u ? luxGuard(sum / float(count)) : 0.0;
    return vec4(withCentre, mean, withoutCentre, direct);
}
