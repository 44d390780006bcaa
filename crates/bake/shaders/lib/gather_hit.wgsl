// The gather's ray (lib/gather.wgsl's lux_gather_sum): ray `k` of the dispatch, cast from
// `origin` along `dir` to its closest hit, hit = (t, u, v); the encoded triangle or -1. The
// gather compiled to replay kept hits (luxbake::kept) has passes/gather/replay.wgsl's instead.
fn lux_gather_hit(origin: vec3<f32>, dir: vec3<f32>, texel: u32, k: u32,
                  hit: ptr<function, vec3<f32>>) -> i32 {
    return lux_trace(origin, dir, 0.0, lux_scene.t_far, false, hit);
}

// The direct light at a gather hit y (interpolated normal nh) from the first `lamps` lamps
// (lux_point_lamps_at, after the normal is normalised); false where the hit reads the map. The
// replay (passes/gather/replay.wgsl) has a twin that always reads the map: a gather with the
// direct light at its hits keeps no hits (kept::replayable).
fn lux_gather_direct(y: vec3<f32>, nh: vec3<f32>, lamps: u32, e: ptr<function, vec3<f32>>)
    -> bool {
    var nd: vec3<f32>;
    return lux_normalize(nh, &nd) && lux_point_lamps_at(y, nd, lamps, e);
}
