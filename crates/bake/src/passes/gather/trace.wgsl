// The wgpu backend's trace pass for kept gather hits (luxbake::kept; trace.glsl's twin): the
// dispatch's rays of each texel of the tile — gather.wgsl's prologue and lib/gather.wgsl's
// rays, operation for operation — cast and their closest hits written to plane k of lux_hits
// (declared by shader::wgsl_gather_trace_source) at the texel's place in the tile:
// (t, triangle, u, v), triangle -1 where the ray meets nothing; the planes past a texel's rays
// are left as they are (the replay never reads them). The gather compiled to replay
// (replay.wgsl) reads these instead of tracing. In a dispatch of a strided gather's grid
// texels alone (TileParams::grid ≥ 2) the places are the compact tile's.

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let c = lux_texel(gid);
    if (c.x < 0) {
        return;
    }
    let none = vec4<f32>(0.0, -1.0, 0.0, 0.0);
    let at = gid.y * lux_tile.width + gid.x;
    let plane = lux_tile.width * lux_tile.height;
    let pos = lux_load(lux_position, c);
    let nrm = lux_load(lux_normal, c);
    var n: vec3<f32>;
    var rays = 0u;
    // The tile's dispatch before its grid's (TileParams::grid 1) keeps no hit of a grid texel.
    let s = i32(lux_pass.stride);
    let grid_texel = lux_tile.grid == 1u && s > 1 && c.x % s == 0 && c.y % s == 0;
    if (pos.w > 0.5 && !grid_texel) {
        rays = lux_coarse_rays(c, lux_pass.stride, lux_pass.reach, lux_pass.rays,
                               lux_pass.orphan_rays);
    }
    if (rays > lux_pass.first_ray && lux_normalize(nrm.xyz, &n)) {
        // The texel's share of the chunk: no more planes than the dispatch keeps
        // (luxbake::kept::HitKey::rays, which a texel's rays never exceed).
        var count = rays - lux_pass.first_ray;
        if (lux_pass.chunk_rays > 0u) {
            count = min(lux_pass.chunk_rays, count);
        }
        let stream = lux_gather_stream(lux_pass.sampler,
                                       vec2<u32>(lux_tile.layer_w, lux_tile.layer_h),
                                       lux_tile.layer, u32(c.x), u32(c.y), lux_pass.stride, rays);
        let origin = lux_offset_origin(pos.xyz, n, lux_scene.ray_epsilon);
        for (var k = 0u; k < count; k++) {
            let s = lux_pass.first_ray + k;
            let dir = lux_gather_direction(n, lux_sample2(lux_pass.sampler, stream.x,
                                                          stream.y + s, lux_pass.bounce,
                                                          lux_pass.seed),
                                           pos.w >= LUX_NARROW_GAP);
            var hit: vec3<f32>;
            let tri = lux_trace(origin, dir, 0.0, lux_scene.t_far, false, &hit);
            if (tri >= 0) {
                lux_hits[k * plane + at] = vec4<f32>(hit.x, f32(tri), hit.y, hit.z);
            } else {
                lux_hits[k * plane + at] = none;
            }
        }
    }
}
