// Pass "gather" (paper Figure 4, box 5): one bounce of indirect illuminance, the mean reflected
// exitance seen along `u_rays` cosine-weighted rays (cpu::gather_texel, operation for operation;
// uniform rays, weighted 2 cos, at a texel in a narrow gap: lightpaths::gather_weight).
// With u_stride > 1 only the coarse grid's texels (u_rays) and its orphans (u_orphan_rays) are
// gathered (coarse.glsl); the others are written as 0 for the upsample pass to fill. With
// u_lamp_paths > 0 each hit is weighted against the lamp paths, whose part (u_connected,
// computed by the connect pass) is added. With u_chunk_rays > 0 a texel's rays are split
// over dispatches, each adding its share to the one before (u_prior).
// The glow backend draws a strided gather in two (coarse.glsl): the grid texels alone, then
// the tile, whose grid texels copy that draw's values from u_grid_values (texel
// c.xy / u_stride − u_grid_origin of layer 0).

vec4 luxRun(ivec3 c) {
    c = luxGridTexel(c);
    if (luxGridCopied(c, u_stride)) {
        return texelFetch(u_grid_values, ivec3(c.xy / int(u_stride) - u_grid_origin, 0), 0);
    }
    vec4 pos = texelFetch(u_position, c, 0);
    vec4 nrm = texelFetch(u_normal, c, 0);
    if (pos.w <= 0.5) {
        return vec4(0.0);
    }
    vec3 n;
    uint rays = luxCoarseRays(c, u_stride, u_reach, u_rays, u_orphan_rays);
    if (!luxNormalize(nrm.xyz, n) || rays == 0u) {
        return vec4(0.0, 0.0, 0.0, 1.0);
    }
    uvec3 layerSize = uvec3(textureSize(u_position, 0));
    uvec2 stream = luxGatherStream(u_sampler, layerSize.xy, uint(c.z), uint(c.x), uint(c.y),
                                   u_stride, rays);
    vec3 origin = luxOffsetOrigin(pos.xyz, n, u_ray_epsilon);
    // A chunk of the rays (u_chunk_rays > 0): those from u_first_ray on, added to the chunks
    // before (u_prior); the lamp paths' part comes with the first chunk.
    uint first = min(u_first_ray, rays);
    uint count = u_chunk_rays > 0u ? min(u_chunk_rays, rays - first) : rays - first;
    vec3 sum = luxGatherSum(origin, n, stream, first, count, u_sampler, u_bounce, u_seed,
                            u_lamp_paths, rays, u_density_scale, int(u_lamp_count),
                            u_direct_at_hits, pos.w >= LUX_NARROW_GAP);
    float inv = 1.0 / float(rays);
    vec3 paths = u_lamp_paths > 0u && u_first_ray == 0u ? texelFetch(u_connected, c, 0).rgb
                                                         : vec3(0.0);
    vec3 prior = u_first_ray > 0u ? texelFetch(u_prior, c, 0).rgb : vec3(0.0);
    return vec4(luxGuard3(prior + (sum * inv + paths)), 1.0);
}
