// Pass "combine" (paper Figure 4, box 6): direct + indirect illuminance, weighted
// (u_a_weight * a + u_b_weight * b; the paper's combine has both weights 1), clamped at 0; or
// by u_mode the bias correction's steps (program::correction_steps): the luminances of a and
// b (1), a scaled by b.r / b.g (2). As cpu::combine_texel.

vec4 luxRun(ivec3 c) {
    vec4 a = texelFetch(u_direct, c, 0);
    vec4 b = texelFetch(u_indirect, c, 0);
    if (u_mode == 1u) {
        return vec4(luxGuard(luxLuminance(a.rgb)), luxGuard(luxLuminance(b.rgb)), 0.0, a.a);
    }
    if (u_mode == 2u) {
        float r = b.g > 0.0 ? b.r / b.g : 1.0;
        return vec4(luxGuard3(a.rgb * r), a.a);
    }
    vec3 s = u_a_weight * a.rgb + u_b_weight * b.rgb;
    return vec4(luxGuard3(s), a.a);
}
