// The wgpu backend's trace pass for kept gather hits (luxbake::kept; trace.glsl's twin): the
// dispatch's rays of each grid texel of the tile (kept::HitPlane; one invocation per texel of
// the plane) — gather.wgsl's prologue and lib/gather.wgsl's rays, operation for operation —
// cast and their closest hits written to plane k of lux_hits (declared by
// shader::wgsl_gather_trace_source) at the texel's place in the grid's plane:
// (t, triangle, u, v), triangle -1 where the texel casts no such ray or the ray meets
// nothing. The gather compiled to replay (replay.wgsl) reads these instead of tracing.

// The grid's plane of the tile (replay.wgsl's lux_hit_plane, which the replay reads).
fn lux_trace_plane() -> vec4<u32> {
    let s = max(lux_pass.stride, 1u);
    let first = (vec2<u32>(lux_tile.x0, lux_tile.y0) + vec2<u32>(s - 1u)) / s;
    let last = (vec2<u32>(lux_tile.x0 + lux_tile.width, lux_tile.y0 + lux_tile.height)
                - vec2<u32>(1u)) / s;
    return vec4<u32>(first, last - first + vec2<u32>(1u));
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let grid = lux_trace_plane();
    if (gid.x >= grid.z || gid.y >= grid.w) {
        return;
    }
    let stride = max(lux_pass.stride, 1u);
    let c = vec2<i32>((grid.xy + gid.xy) * stride);
    let none = vec4<f32>(0.0, -1.0, 0.0, 0.0);
    // The dispatch's planes: the chunk's share of the gather's rays (kept::HitKey::rays).
    var planes = lux_pass.rays - min(lux_pass.first_ray, lux_pass.rays);
    if (lux_pass.chunk_rays > 0u) {
        planes = min(lux_pass.chunk_rays, planes);
    }
    let at = gid.y * grid.z + gid.x;
    let plane = grid.z * grid.w;
    let pos = lux_load(lux_position, c);
    let nrm = lux_load(lux_normal, c);
    var n: vec3<f32>;
    var count = 0u;
    var rays = 0u;
    if (pos.w > 0.5) {
        rays = lux_coarse_rays(c, lux_pass.stride, lux_pass.reach, lux_pass.rays,
                               lux_pass.orphan_rays);
    }
    if (rays > lux_pass.first_ray && lux_normalize(nrm.xyz, &n)) {
        count = min(planes, rays - lux_pass.first_ray);
        let texel = lux_texel_index(vec2<u32>(lux_tile.layer_w, lux_tile.layer_h),
                                    lux_tile.layer, u32(c.x), u32(c.y));
        let origin = lux_offset_origin(pos.xyz, n, lux_scene.ray_epsilon);
        for (var k = 0u; k < count; k++) {
            let s = lux_pass.first_ray + k;
            let dir = lux_cosine_direction(n, lux_sample2(lux_pass.sampler, texel, s,
                                                          lux_pass.bounce, lux_pass.seed));
            var hit: vec3<f32>;
            let tri = lux_trace(origin, dir, 0.0, lux_scene.t_far, false, &hit);
            if (tri >= 0) {
                lux_hits[k * plane + at] = vec4<f32>(hit.x, f32(tri), hit.y, hit.z);
            } else {
                lux_hits[k * plane + at] = none;
            }
        }
    }
    for (var k = count; k < planes; k++) {
        lux_hits[k * plane + at] = none;
    }
}
