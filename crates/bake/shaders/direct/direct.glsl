// Pass "direct" (paper Figure 4, box 2): illuminance from the pass's lamps, with shadow rays
// through the BVH (cpu::direct_texel, operation for operation).
//
// Evaluates the first u_lamp_count uploaded lamps (luxLamp, scene.glsl).

void main() {
    ivec3 c = luxTexel();
    vec4 pos = texelFetch(u_position, c, 0);
    vec4 nrm = texelFetch(u_normal, c, 0);
    if (pos.w <= 0.5) {
        o_color = vec4(0.0);
        return;
    }
    vec3 p = pos.xyz;
    vec3 n;
    if (!luxNormalize(nrm.xyz, n)) {
        o_color = vec4(0.0, 0.0, 0.0, 1.0);
        return;
    }
    vec3 e = vec3(0.0);
    for (int li = 0; li < int(u_lamp_count); ++li) {
        vec4 l0 = luxLamp(li, 0);
        vec3 lampPos = l0.xyz;
        int table = int(l0.w);
        vec3 to = lampPos - p;
        float d2 = luxDot(to, to);
        float d = sqrt(d2);
        if (!(d > 0.0 && luxFinite(d))) {
            continue;
        }
        vec3 w = vec3(to.x / d, to.y / d, to.z / d);
        float cosTheta = luxDot(n, w);
        if (!(cosTheta > 0.0)) {
            continue;
        }
        vec3 back = -w;
        vec3 photometric = vec3(luxDot(luxLamp(li, 1).xyz, back), luxDot(luxLamp(li, 2).xyz, back),
                                luxDot(luxLamp(li, 3).xyz, back));
        float intensity = luxIesSample(table, ivec2(luxLamp(li, 5).yz), photometric);
        if (!(intensity > 0.0)) {
            continue;
        }
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
    o_color = vec4(luxGuard3(e), 1.0);
}
