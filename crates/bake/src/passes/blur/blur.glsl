// Pass "blur" (paper Figure 4, boxes 3 and 7): one axis of the separable Gaussian, over valid
// texels of the centre's object whose normal is within 25 degrees of the centre's (cpu::blur_texel).
// The empty texels between charts and the edges of the layer are skipped explicitly, so nothing
// bleeds in and no wrap or clamp mode is relied on.
// Parameters (program::BlurParams): u_step_x, u_step_y = (1, 0) for the U axis, (0, 1) for V;
// u_radius = program::blur_radius(sigma); u_inv = -1 / (2 sigma^2), computed on the CPU.

vec4 luxRun(ivec3 c) {
    vec4 centre = texelFetch(u_src, c, 0);
    if (centre.a <= 0.5) {
        return vec4(0.0);
    }
    vec4 nc = texelFetch(u_normal, c, 0);
    float object = nc.w;
    vec3 n0;
    if (!luxNormalize(nc.xyz, n0)) {
        return centre;
    }
    ivec2 size = textureSize(u_src, 0).xy;
    vec3 sum = vec3(0.0);
    float wsum = 0.0;
    for (int k = -u_radius; k <= u_radius; ++k) {
        ivec2 t = c.xy + k * ivec2(u_step_x, u_step_y);
        if (t.x < 0 || t.y < 0 || t.x >= size.x || t.y >= size.y) {
            continue;
        }
        ivec3 tc = ivec3(t, c.z);
        vec4 tv = texelFetch(u_src, tc, 0);
        if (tv.a <= 0.5) {
            continue;
        }
        vec4 nt = texelFetch(u_normal, tc, 0);
        if (nt.w != object) {
            continue;
        }
        vec3 n1;
        if (!luxNormalize(nt.xyz, n1) || !(luxDot(n0, n1) >= LUX_BLUR_NORMAL_COS)) {
            continue;
        }
        float w = exp(float(k * k) * u_inv);
        sum += w * tv.rgb;
        wsum += w;
    }
    if (wsum > 0.0) {
        return vec4(luxGuard3(vec3(sum.x / wsum, sum.y / wsum, sum.z / wsum)), 1.0);
    }
    return centre;
}
