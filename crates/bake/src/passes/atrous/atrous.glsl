// Pass "atrous": one iteration of the edge-stopping a-trous wavelet filter (Dammertz et al.
// 2010, SVGF; cpu::atrous_texel, program::atrous_steps). 5x5 taps u_step texels apart on the
// centre's surface, weighted by the B3 spline, a power of the normals' cosine and a Gaussian
// of the luminance difference in units of the centre's noise (the variance map). The sum is
// taken relative to the centre, which is itself a tap: a constant field is returned exactly.
// Parameters (program::AtrousParams): u_step = 2^i; u_reach, u_reach_min: the chart test's
// farthest and nearest distance per texel of offset, metres; u_normal_log2: the cosine's exponent is 2^u_normal_log2; u_variance_scale =
// sigma_l^2 x the noise factor of the iterations before; u_luminance_scale: the variance
// pass's power of two, applied to the luminance differences.

float luxB3(int i) {
    return i == 0 ? 0.375 : (i == 1 || i == -1 ? 0.25 : 0.0625);
}

vec4 luxRun(ivec3 c) {
    vec4 centre = texelFetch(u_src, c, 0);
    if (centre.a <= 0.5) {
        return vec4(0.0);
    }
    vec4 kept = vec4(luxGuard3(centre.rgb), 1.0);
    LuxGuide g;
    if (!luxGuide(c, u_reach_min, u_reach, g)) {
        return kept;
    }
    float scale = u_variance_scale * texelFetch(u_variance, c, 0).r;
    // A step beyond the layer only reaches the centre (and cannot overflow).
    int step = u_step;
    if ((step < -g.size.x && step < -g.size.y) || (step > g.size.x && step > g.size.y)) {
        step = 0;
    }
    vec3 sum = vec3(0.0);
    float wsum = 0.0;
    for (int j = -2; j <= 2; ++j) {
        for (int i = -2; i <= 2; ++i) {
            vec4 t;
            float cosine;
            if (!luxTap(g, ivec2(i * step, j * step), t, cosine) || !(cosine > 0.0)) {
                continue;
            }
            float wn = cosine;
            for (uint k = 0u; k < u_normal_log2; ++k) {
                if (wn == 0.0 || wn == 1.0) {
                    break;
                }
                wn *= wn;
            }
            vec3 d = t.rgb - centre.rgb;
            float dl = luxLuminance(d) * u_luminance_scale;
            float wl;
            if (dl == 0.0) {
                wl = 1.0;
            } else if (scale > 0.0) {
                wl = exp(-(dl * dl) / scale);
            } else {
                wl = 0.0;
            }
            float w = luxB3(i) * luxB3(j) * wn * wl;
            if (!(w > 0.0)) {
                continue;
            }
            sum += w * d;
            wsum += w;
        }
    }
    if (wsum > 0.0) {
        return vec4(luxGuard3(vec3(centre.r + sum.x / wsum, centre.g + sum.y / wsum,
                                   centre.b + sum.z / wsum)), 1.0);
    }
    return kept;
}
