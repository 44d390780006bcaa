// Pass "direct" (paper Figure 4, box 2): illuminance from the pass's lamps, with shadow rays
// through the BVH (cpu::direct_texel, operation for operation).
//
// Evaluates the first u_lamp_count uploaded lamps (luxLamp, scene.glsl).

vec4 luxRun(ivec3 c) {
    vec4 pos = texelFetch(u_position, c, 0);
    vec4 nrm = texelFetch(u_normal, c, 0);
    if (pos.w <= 0.5) {
        return vec4(0.0);
    }
    vec3 p = pos.xyz;
    vec3 n;
    if (!luxNormalize(nrm.xyz, n)) {
        return vec4(0.0, 0.0, 0.0, 1.0);
    }
    vec3 e = vec3(0.0);
    for (int li = 0; li < int(u_lamp_count); ++li) {
        vec3 lampPos = luxLamp(li, 0).xyz;
        float d2;
        float d;
        vec3 w;
        float cosTheta;
        float intensity;
        if (!luxLampToward(li, p, n, d2, d, w, cosTheta, intensity)) {
            continue;
        }
        vec3 back = -w;
        vec3 o0 = luxOffsetOrigin(p, n, u_ray_epsilon);
        vec3 off = o0 - p;
        float off2 = luxDot(off, off);
        vec3 origin = 16.0 * off2 > d2 ? p + n * (0.25 * d) : o0;
        vec3 dir = lampPos - origin;
        float len = sqrt(luxDot(dir, dir));
        vec3 lampOff = luxOffsetOrigin(lampPos, back, u_ray_epsilon) - lampPos;
        float stopShort = min(sqrt(luxDot(lampOff, lampOff)), 0.25 * d);
        float tMax = 1.0 - stopShort / len;
        vec3 hit;
        if (len > 0.0 && tMax > 0.0 && luxTrace(origin, dir, 0.0, tMax, true, hit) >= 0) {
            continue;
        }
        float k = intensity * cosTheta / max(d2, off2);
        e += k * luxLamp(li, 4).rgb;
    }
    return vec4(luxGuard3(e), 1.0);
}
