// Pass "atrous": one iteration of the edge-stopping a-trous wavelet filter (Dammertz et al.
// 2010, SVGF; cpu::atrous_texel, program::atrous_steps). 5x5 taps u_step texels apart on the
// centre's surface, weighted by the B3 spline, a power of the normals' cosine and a Gaussian
// of the luminance difference in units of the centre's noise (the variance map), in mirrored
// pairs (program::atrous_steps, "Mirrored pairs"). The sum is taken relative to the centre,
// which is itself a tap: a constant field is returned exactly.
// Parameters (program::AtrousParams): u_step = 2^i; u_reach, u_reach_min: the chart test's
// farthest and nearest distance per texel of offset, metres; u_normal_log2: the cosine's exponent is 2^u_normal_log2; u_variance_scale =
// sigma_l^2 x the noise factor of the iterations before; u_luminance_scale: the variance
// pass's power of two, applied to the luminance differences; u_wide_variance_scale: the scale
// inside a wide chart with little noise (every pair counts, variance under
// u_wide_max_relative_variance x the window's squared mean; program::atrous_steps, "Wide charts
// with little noise"): both sums are taken there, the one that counts known at the end.
// u_narrow_variance_scale: u_variance_scale at a centre in a narrow gap (position w >=
// LUX_NARROW_GAP), whose first bounce has more rays; u_narrow_keep: such a centre keeps its value
// (the iteration's taps reach beyond the gap, program::atrous_steps, "Narrow gaps"). u_linear: the bias correction's filter of two luminances (program::correction_steps): no
// luminance term, the variance map not read.

float luxB3(int i) {
    return i == 0 ? 0.375 : (i == 1 || i == -1 ? 0.25 : 0.0625);
}

vec4 luxRun(ivec3 c) {
    vec4 centre = texelFetch(u_src, c, 0);
    if (centre.a <= 0.5) {
        return vec4(0.0);
    }
    bool linear = u_linear != 0u;
    vec4 kept = vec4(luxGuard3(centre.rgb), 1.0);
    bool narrow = texelFetch(u_position, c, 0).w >= LUX_NARROW_GAP;
    if (narrow && u_narrow_keep != 0u) {
        return kept;
    }
    LuxGuide g;
    if (!luxGuide(c, u_reach_min, u_reach, g)) {
        return kept;
    }
    // The linear filter does not read the variance map.
    vec4 v = linear ? vec4(0.0) : texelFetch(u_variance, c, 0);
    float scale = (narrow ? u_narrow_variance_scale : u_variance_scale) * v.r;
    float wide = u_wide_variance_scale * v.r;
    bool quiet = !linear && u_wide_max_relative_variance > 0.0 &&
                 v.r < u_wide_max_relative_variance * (v.g * v.g);
    // A step beyond the layer only reaches the centre (and cannot overflow).
    int step = u_step;
    if ((step < -g.size.x && step < -g.size.y) || (step > g.size.x && step > g.size.y)) {
        step = 0;
    }
    vec3 sum = vec3(0.0);
    float wsum = 0.0;
    vec3 wideSum = vec3(0.0);
    float wideWsum = 0.0;
    int pairs = 0;
    // Taps in mirrored pairs o, -o (the centre alone last): a pair counts only when both of
    // its taps are on the surface, so the kernel stays point-symmetric at a chart's edge.
    for (int k = 0; k < 13; ++k) {
        int i = k % 5 - 2;
        int j = k / 5 - 2;
        vec4 tn;
        vec4 tf;
        float cn;
        float cf;
        if (!luxTap(g, ivec2(i * step, j * step), tn, cn) || !(cn > 0.0)) {
            continue;
        }
        bool pair = k != 12;
        if (pair && (!luxTap(g, ivec2(-i * step, -j * step), tf, cf) || !(cf > 0.0))) {
            continue;
        }
        if (pair) {
            ++pairs;
        }
        for (int side = 0; side < (pair ? 2 : 1); ++side) {
            vec4 t = side == 0 ? tn : tf;
            float wn = side == 0 ? cn : cf;
            for (uint e = 0u; e < u_normal_log2; ++e) {
                if (wn == 0.0 || wn == 1.0) {
                    break;
                }
                wn *= wn;
            }
            vec3 d = t.rgb - centre.rgb;
            float dl = luxLuminance(d) * u_luminance_scale;
            for (int s = 0; s < (quiet ? 2 : 1); ++s) {
                float sc = s == 0 ? scale : wide;
                float wl;
                if (linear || dl == 0.0) {
                    wl = 1.0;
                } else if (sc > 0.0) {
                    wl = exp(-(dl * dl) / sc);
                } else {
                    wl = 0.0;
                }
                float w = luxB3(i) * luxB3(j) * wn * wl;
                if (!(w > 0.0)) {
                    continue;
                }
                if (s == 0) {
                    sum += w * d;
                    wsum += w;
                } else {
                    wideSum += w * d;
                    wideWsum += w;
                }
            }
        }
    }
    if (quiet && pairs == 12) {
        sum = wideSum;
        wsum = wideWsum;
    }
    if (wsum > 0.0) {
        vec3 r = vec3(centre.r + sum.x / wsum, centre.g + sum.y / wsum, centre.b + sum.z / wsum);
        return vec4(luxGuard3(r), 1.0);
    }
    return kept;
}
