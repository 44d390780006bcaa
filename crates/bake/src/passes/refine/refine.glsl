// Pass "refine": progressive refinement of the first gather (`u_first`, u_first_rays rays).
// A texel whose relative standard error, estimated as sqrt(variance) / mean luminance of its
// 5x5 window from the variance pass over the first gather (not its own luminance: a decision
// on the texel's own noisy value would keep the texels that came out high, a bias), is over u_max_error gets u_rays more rays
// (rng::Stream::refine's draws) and the ray-count-weighted mean of
// both; every other texel keeps the first gather's value (cpu.rs). With u_lamp_paths > 0 the
// further rays are weighted against the lamp paths as the first u_first_rays were and, with
// the refinement's own connections (u_connected, the connect pass with picks), make a second
// estimate, averaged with the first by ray count. A texel in a narrow gap (position w >=
// LUX_NARROW_GAP) gets u_narrow_rays further rays whatever its noise, the larger count where both
// apply (RefineParams::more); every texel's draws span the larger of the two counts. With
// u_narrow_direct such a texel takes the second estimate alone, its rays reading the lamps'
// direct light at their hits (RefineParams::narrow_direct).

vec4 luxRun(ivec3 c) {
    vec4 pos = texelFetch(u_position, c, 0);
    vec4 first = texelFetch(u_first, c, 0);
    if (pos.w <= 0.5) {
        return vec4(0.0);
    }
    vec3 n;
    if (!luxNormalize(texelFetch(u_normal, c, 0).xyz, n)) {
        return first;
    }
    bool gap = pos.w >= LUX_NARROW_GAP;
    uint more = gap ? u_narrow_rays : 0u;
    if (u_rays > 0u && luxRefines(texelFetch(u_variance, c, 0), u_max_error)) {
        more = max(more, u_rays);
    }
    if (more == 0u) {
        return first;
    }
    // The idle program (kept::Variant::Idle) runs where no texel gets further rays: without
    // the rays' code, which a SIMD rasteriser would run masked for every texel.
    if (LUX_IDLE != 0u) {
        return first;
    }
    uvec3 layerSize = uvec3(textureSize(u_position, 0));
    uvec2 stream = luxRefineStream(u_sampler, layerSize.xy, uint(c.z), uint(c.x), uint(c.y),
                                   u_first_rays, max(u_rays, u_narrow_rays));
    vec3 origin = luxOffsetOrigin(pos.xyz, n, u_ray_epsilon);
    bool replaces = gap && u_narrow_direct != 0u;
    vec3 sum = luxGatherSum(origin, n, stream, 0u, more, u_sampler, u_bounce, u_seed,
                            u_lamp_paths, u_first_rays, u_density_scale, int(u_lamp_count),
                            replaces ? 1u : u_direct_at_hits, gap);
    vec3 paths = u_lamp_paths > 0u ? texelFetch(u_connected, c, 0).rgb : vec3(0.0);
    float kept = replaces ? 0.0 : float(u_first_rays);
    float total = kept + float(more);
    vec3 m = kept * first.rgb + sum + float(more) * paths;
    return vec4(luxGuard3(vec3(m.x / total, m.y / total, m.z / total)), 1.0);
}
