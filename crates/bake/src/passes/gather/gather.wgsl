// Pass "gather" (paper Figure 4, box 5): one bounce of indirect illuminance, the mean reflected
// exitance seen along lux_pass.rays cosine-weighted rays (cpu::gather_texel, operation for
// operation; uniform rays, weighted 2 cos, at a texel in a narrow gap:
// lightpaths::gather_weight). With lux_pass.stride > 1 only the coarse grid's texels (lux_pass.rays) and its
// orphans (lux_pass.orphan_rays) are gathered (coarse.wgsl); the others are written as 0 for
// the upsample pass to fill. With lux_pass.lamp_paths > 0 each hit is weighted against the
// lamp paths, whose part (lux_connected, computed by the connect pass)
// is added. With lux_pass.chunk_rays > 0 a texel's rays are split over dispatches, each
// adding its share to the one before (lux_prior).

fn lux_run(c: vec2<i32>) -> vec4<f32> {
    // The wgpu backend's strided gather in two (program::coarse::grid_tile): the tile's
    // dispatch (TileParams::grid 1) leaves the grid texels to the grid's after it.
    let s = i32(lux_pass.stride);
    if (lux_tile.grid == 1u && s > 1 && c.x % s == 0 && c.y % s == 0) {
        return vec4<f32>(0.0);
    }
    let pos = lux_load(lux_position, c);
    let nrm = lux_load(lux_normal, c);
    if (pos.w <= 0.5) {
        return vec4<f32>(0.0);
    }
    var n: vec3<f32>;
    let rays = lux_coarse_rays(c, lux_pass.stride, lux_pass.reach, lux_pass.rays,
                               lux_pass.orphan_rays);
    if (!lux_normalize(nrm.xyz, &n) || rays == 0u) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let layer_size = vec2<u32>(lux_tile.layer_w, lux_tile.layer_h);
    let texel = lux_texel_index(layer_size, lux_tile.layer, u32(c.x), u32(c.y));
    let stream = lux_gather_stream(lux_pass.sampler, layer_size, lux_tile.layer, u32(c.x),
                                   u32(c.y), lux_pass.stride, rays);
    let origin = lux_offset_origin(pos.xyz, n, lux_scene.ray_epsilon);
    // A chunk of the rays (chunk_rays > 0): those from first_ray on, added to the chunks
    // before (lux_prior); the lamp paths' part comes with the first chunk.
    let first = min(lux_pass.first_ray, rays);
    var count = rays - first;
    if (lux_pass.chunk_rays > 0u) {
        count = min(lux_pass.chunk_rays, rays - first);
    }
    let sum = lux_gather_sum(origin, n, texel, stream, first, count, lux_pass.sampler,
                             lux_pass.bounce, lux_pass.seed, lux_pass.lamp_paths, rays,
                             lux_pass.density_scale, lux_pass.lamp_count,
                             lux_pass.direct_at_hits, pos.w >= LUX_NARROW_GAP);
    let inv = 1.0 / f32(rays);
    var paths = vec3<f32>(0.0);
    if (lux_pass.lamp_paths > 0u && lux_pass.first_ray == 0u) {
        paths = lux_load(lux_connected, c).rgb;
    }
    var prior = vec3<f32>(0.0);
    if (lux_pass.first_ray > 0u) {
        prior = lux_load(lux_prior, c).rgb;
    }
    return vec4<f32>(lux_guard3(prior + (sum * inv + paths)), 1.0);
}
