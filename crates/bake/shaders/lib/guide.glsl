// Shared by the denoiser passes (variance, atrous), mirroring luxbake::cpu's Guide: whether a
// tap lies on the centre's surface (inside the layer, valid, the centre's object, within the
// chart reach). For programs reading the slots src, position and normal.

struct LuxGuide {
    ivec3 c;
    ivec2 size;
    vec3 p;
    vec3 n;
    float object;
    float reach2;
    float reachMin2;
};

// cpu::Guide::new with the chart test's [reachMin, reach]: false when the centre's normal
// cannot be normalised.
bool luxGuide(ivec3 c, float reachMin, float reach, out LuxGuide g) {
    vec4 nc = texelFetch(u_normal, c, 0);
    g.c = c;
    g.size = textureSize(u_src, 0).xy;
    g.p = texelFetch(u_position, c, 0).xyz;
    g.object = nc.w;
    g.reach2 = reach * reach;
    g.reachMin2 = reachMin * reachMin;
    return luxNormalize(nc.xyz, g.n);
}

// cpu::Guide::tap: whether the tap at `offset` texels lies on the centre's surface; if so its
// value and the cosine between the normals.
bool luxTap(LuxGuide g, ivec2 offset, out vec4 value, out float cosine) {
    value = vec4(0.0);
    cosine = 0.0;
    ivec2 t = g.c.xy + offset;
    if (t.x < 0 || t.y < 0 || t.x >= g.size.x || t.y >= g.size.y) {
        return false;
    }
    ivec3 tc = ivec3(t, g.c.z);
    value = texelFetch(u_src, tc, 0);
    if (value.a <= 0.5) {
        return false;
    }
    vec4 nt = texelFetch(u_normal, tc, 0);
    if (nt.w != g.object) {
        return false;
    }
    vec3 d = texelFetch(u_position, tc, 0).xyz - g.p;
    float d2 = luxDot(d, d);
    float o2 = float(offset.x * offset.x + offset.y * offset.y);
    int m = max(max(abs(offset.x), abs(offset.y)) - 2, 0);
    if (o2 > 0.0 && !(d2 <= g.reach2 * o2 && d2 >= g.reachMin2 * float(m * m))) {
        return false;
    }
    // The G-buffer's normals are unit: used as stored.
    cosine = luxDot(g.n, nt.xyz);
    return true;
}
