// Pass "combine" (paper Figure 4, box 6): direct + indirect illuminance, weighted
// (u_a_weight * a + u_b_weight * b; the paper's combine has both weights 1), clamped at 0
// unless u_signed (the bias correction's residual, program::correction_steps).

vec4 luxRun(ivec3 c) {
    vec4 a = texelFetch(u_direct, c, 0);
    vec4 b = texelFetch(u_indirect, c, 0);
    vec3 s = u_a_weight * a.rgb + u_b_weight * b.rgb;
    return vec4(u_signed != 0u ? luxGuardSigned3(s) : luxGuard3(s), a.a);
}
