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

// One tap's weight and value added to a sum of scale sc (its luminance term's; unused by the
// linear filter).
void luxAtrousAdd(vec3 d, float b, float wn, float dl, float sc, bool linear, inout vec3 sum,
                  inout float wsum) {
    float wl;
    if (linear || dl == 0.0) {
        wl = 1.0;
    } else if (sc > 0.0) {
        wl = exp(-(dl * dl) / sc);
    } else {
        wl = 0.0;
    }
    float w = b * wn * wl;
    if (w > 0.0) {
        sum += w * d;
        wsum += w;
    }
}

// A tap on the surface (cosine > 0) with its B3 weight b: into the sum, and into the wide
// one at a quiet centre. The cosine's power: squaring keeps 0 and 1 as they are.
void luxAtrousTap(vec4 t, float cosine, vec4 centre, float b, float scale, float wide,
                  bool quiet, bool linear, inout vec3 sum, inout float wsum,
                  inout vec3 wideSum, inout float wideWsum) {
    float wn = cosine;
    for (uint e = 0u; e < u_normal_log2; ++e) {
        wn *= wn;
    }
    vec3 d = t.rgb - centre.rgb;
    float dl = luxLuminance(d) * u_luminance_scale;
    luxAtrousAdd(d, b, wn, dl, scale, linear, sum, wsum);
    if (quiet) {
        luxAtrousAdd(d, b, wn, dl, wide, linear, wideSum, wideWsum);
    }
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
    // its taps are on the surface, so the kernel stays point-symmetric at a chart's edge. Each
    // tap is one call, with no loop over a pair's sides or the two sums: SwiftShader ran such
    // small loops inside the loop over the taps slowly (docs/performance.md, "SwiftShader: the
    // à-trous taps without inner loops").
    for (int k = 0; k < 12; ++k) {
        int i = k % 5 - 2;
        int j = k / 5 - 2;
        vec4 tn;
        vec4 tf;
        float cn;
        float cf;
        if (luxTap(g, ivec2(i * step, j * step), tn, cn) && cn > 0.0 &&
            luxTap(g, ivec2(-i * step, -j * step), tf, cf) && cf > 0.0) {
            ++pairs;
            float b = luxB3(i) * luxB3(j);
            luxAtrousTap(tn, cn, centre, b, scale, wide, quiet, linear, sum, wsum, wideSum,
                         wideWsum);
            luxAtrousTap(tf, cf, centre, b, scale, wide, quiet, linear, sum, wsum, wideSum,
                         wideWsum);
        }
    }
    vec4 tc;
    float cc;
    if (luxTap(g, ivec2(0), tc, cc) && cc > 0.0) {
        luxAtrousTap(tc, cc, centre, luxB3(0) * luxB3(0), scale, wide, quiet, linear, sum,
                     wsum, wideSum, wideWsum);
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
