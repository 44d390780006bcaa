// The gather's ray (lib/gather.wgsl's lux_gather_sum): ray `k` of the dispatch, cast from
// `origin` along `dir` to its closest hit, hit = (t, u, v); the encoded triangle or -1. The
// gather compiled to replay kept hits (luxbake::kept) has passes/gather/replay.wgsl's instead.
fn lux_gather_hit(origin: vec3<f32>, dir: vec3<f32>, texel: u32, k: u32,
                  hit: ptr<function, vec3<f32>>) -> i32 {
    return lux_trace(origin, dir, 0.0, lux_scene.t_far, false, hit);
}
