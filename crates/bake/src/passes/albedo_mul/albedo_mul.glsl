// Pass "albedo multiply" (paper Figure 4, boxes 4 and 8): illuminance (lux) to exitance
// (lm/m^2), dst = (src.rgb * albedo.rgb, src.a).

vec4 luxRun(ivec3 c) {
    vec4 a = texelFetch(u_src, c, 0);
    vec4 b = texelFetch(u_albedo, c, 0);
    return vec4(luxGuard3(a.rgb * b.rgb), a.a);
}
