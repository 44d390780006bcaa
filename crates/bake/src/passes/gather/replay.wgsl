// The gather's ray when it replays kept hits (luxbake::kept; lib/gather_hit.wgsl's twin): the
// hit ray `k` of the dispatch had when trace.wgsl cast it, read from plane `k` of lux_hits at
// the texel's place in the grid's plane (kept::HitPlane: every `stride`-th column and row of
// the tile); an orphan of a coarse grid keeps none and traces. `texel` is lux_texel_index of
// the texel, which gives back its column and row. lux_hits is declared by
// shader::wgsl_gather_replay_source.

// The grid's plane of the tile: its first column and row (grid units) and its size.
fn lux_hit_plane() -> vec4<u32> {
    let s = max(lux_pass.stride, 1u);
    let first = (vec2<u32>(lux_tile.x0, lux_tile.y0) + vec2<u32>(s - 1u)) / s;
    let last = (vec2<u32>(lux_tile.x0 + lux_tile.width, lux_tile.y0 + lux_tile.height)
                - vec2<u32>(1u)) / s;
    return vec4<u32>(first, last - first + vec2<u32>(1u));
}

fn lux_gather_hit(origin: vec3<f32>, dir: vec3<f32>, texel: u32, k: u32,
                  hit: ptr<function, vec3<f32>>) -> i32 {
    let s = max(lux_pass.stride, 1u);
    let x = texel % lux_tile.layer_w;
    let y = (texel / lux_tile.layer_w) % lux_tile.layer_h;
    if (x % s != 0u || y % s != 0u) {
        return lux_trace(origin, dir, 0.0, lux_scene.t_far, false, hit);
    }
    let plane = lux_hit_plane();
    let at = vec2<u32>(x / s, y / s) - plane.xy;
    let kept = lux_hits[(k * plane.w + at.y) * plane.z + at.x];
    *hit = kept.xzw;
    return i32(kept.y);
}
