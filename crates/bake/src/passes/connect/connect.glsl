// Pass "connect" (lightpaths.rs): the lamp paths' part of the first bounce at a texel — K
// points of the pool picked with the Sobol sampler's block draws (lightpaths, "Stratified
// picks"), each joined by a shadow ray and weighted by
// the balance heuristic against a gather of u_rays rays (connect/cpu.rs, operation for
// operation). The pool: luxPathPoint (scene.glsl). With u_picks > 0 the refinement's second
// estimate: u_picks further picks continuing the texel's (luxRefineStream), at the texels whose
// variance estimate (u_variance) misses u_max_error only, the sum scaled by u_k / u_picks.
// With u_narrow_picks > 0 the same at the texels in a narrow gap (position w >= LUX_NARROW_GAP),
// whatever their noise: the larger count where both apply, the picks' draws spanning the
// larger of the two counts (ConnectParams::connections_at).

vec4 luxRun(ivec3 c) {
    vec4 pw = texelFetch(u_position, c, 0);
    if (pw.w <= 0.5) {
        return vec4(0.0);
    }
    vec3 n;
    if (!luxNormalize(texelFetch(u_normal, c, 0).xyz, n)) {
        return vec4(0.0, 0.0, 0.0, 1.0);
    }
    uint count = min(u_count, luxPathPointCount());
    if (count == 0u || u_k == 0u) {
        return vec4(0.0, 0.0, 0.0, 1.0);
    }
    uint picks = u_k;
    uvec2 size = uvec2(textureSize(u_position, 0).xy);
    uvec2 stream;
    bool refinement = u_picks > 0u || u_narrow_picks > 0u;
    if (refinement) {
        picks = pw.w >= LUX_NARROW_GAP ? u_narrow_picks : 0u;
        if (u_picks > 0u && luxRefines(texelFetch(u_variance, c, 0), u_max_error)) {
            picks = max(picks, u_picks);
        }
        if (picks == 0u) {
            return vec4(0.0, 0.0, 0.0, 1.0);
        }
        stream = luxRefineStream(LUX_SAMPLER_SOBOL, size, uint(c.z), uint(c.x), uint(c.y), u_k,
                                 max(u_picks, u_narrow_picks));
    } else {
        stream = luxGatherStream(LUX_SAMPLER_SOBOL, size, uint(c.z), uint(c.x), uint(c.y), 1u,
                                 u_k);
    }
    // The idle program (kept::Variant::Idle) runs where no texel gets further connections:
    // without the shadow rays' code, which a SIMD rasteriser would run masked for every texel.
    if (LUX_IDLE != 0u) {
        return vec4(0.0, 0.0, 0.0, 1.0);
    }
    vec3 p = pw.xyz;
    vec3 origin = luxOffsetOrigin(p, n, u_ray_epsilon);
    float nc = float(u_rays);
    // The gather's density per steradian times pi toward a point: cx for its cosine-weighted
    // rays, 1/2 for a gap's uniform ones (lightpaths::gather_weight).
    bool uniformRays = pw.w >= LUX_NARROW_GAP;
    float kf = float(u_k);
    vec3 sum = vec3(0.0);
    for (uint s = 0u; s < picks; ++s) {
        vec2 u = luxSobol2(stream.x, stream.y + s, LUX_CONNECT_PASS, u_seed);
        uint j = min(uint(u.x * float(count)), count - 1u);
        vec4 a = luxPathPoint(j, 0);
        vec4 b = luxPathPoint(j, 1);
        vec3 power = luxPathPoint(j, 2).rgb;
        vec3 to = a.xyz - p;
        float r2 = luxDot(to, to);
        float r = sqrt(r2);
        if (!(r > 0.0 && luxFinite(r))) {
            continue;
        }
        vec3 w = to / r;
        float cx = luxDot(n, w);
        float cy = -luxDot(b.xyz, w);
        if (!(cx > 0.0 && cy > 0.0)) {
            continue;
        }
        vec3 target = luxOffsetOrigin(a.xyz, b.xyz, u_ray_epsilon);
        vec3 sd = target - origin;
        float len = sqrt(luxDot(sd, sd));
        if (!(len > 0.0)) {
            continue;
        }
        vec3 hit;
        if (luxTrace(origin, sd / len, 0.0, len * (1.0 - 1e-4), true, hit) >= 0) {
            continue;
        }
        float pv = a.w * u_density_scale;
        float geometry = cx * cy;
        float gathered = uniformRays ? 0.5 * cy : geometry;
        float denominator = 3.14159265358979 * kf * pv * r2 + nc * gathered;
        if (!(denominator > 0.0)) {
            continue;
        }
        float f = pv * geometry / denominator;
        sum += f * power;
    }
    float scale = refinement ? kf / float(picks) : 1.0;
    return vec4(luxGuard3(sum * scale), 1.0);
}
