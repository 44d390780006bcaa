// Pass "refine": progressive refinement of the first gather (lux_first, first_rays rays). A
// texel whose relative standard error, estimated as sqrt(variance) / mean luminance of its
// 5x5 window from the variance pass over the first gather (not its own luminance: a decision
// on the texel's own noisy value would keep the texels that came out high, a bias), is over lux_pass.max_error gets lux_pass.rays more rays
// (rng::Stream::refine's draws) and the ray-count-weighted mean of
// both; every other texel keeps the first gather's value (cpu.rs). With lux_pass.lamp_paths > 0
// the further rays are weighted against the lamp paths as the first first_rays were and, with
// the refinement's own connections (lux_connected, the connect pass with picks), make a second
// estimate, averaged with the first by ray count. A texel in a narrow gap (position w >=
// LUX_NARROW_GAP) gets lux_pass.narrow_rays further rays whatever its noise, the larger count
// where both apply (RefineParams::more); every texel's draws span the larger of the two.
// With lux_pass.narrow_direct such a texel takes the second estimate alone, its rays reading
// the lamps' direct light at their hits (RefineParams::narrow_direct).

fn lux_run(c: vec2<i32>) -> vec4<f32> {
    let pos = lux_load(lux_position, c);
    let first = lux_load(lux_first, c);
    if (pos.w <= 0.5) {
        return vec4<f32>(0.0);
    }
    var n: vec3<f32>;
    if (!lux_normalize(lux_load(lux_normal, c).xyz, &n)) {
        return first;
    }
    let gap = pos.w >= LUX_NARROW_GAP;
    var rays = select(0u, lux_pass.narrow_rays, gap);
    if (lux_pass.rays > 0u && lux_refines(lux_load(lux_variance, c), lux_pass.max_error)) {
        rays = max(rays, lux_pass.rays);
    }
    if (rays == 0u) {
        return first;
    }
    // The idle program (kept::Variant::Idle) runs where no texel gets further rays: without
    // the rays' code, which a SIMD rasteriser would run masked for every texel.
    if (LUX_IDLE != 0u) {
        return first;
    }
    let layer_size = vec2<u32>(lux_tile.layer_w, lux_tile.layer_h);
    let texel = lux_texel_index(layer_size, lux_tile.layer, u32(c.x), u32(c.y));
    let stream = lux_refine_stream(lux_pass.sampler, layer_size, lux_tile.layer, u32(c.x),
                                   u32(c.y), lux_pass.first_rays,
                                   max(lux_pass.rays, lux_pass.narrow_rays));
    let origin = lux_offset_origin(pos.xyz, n, lux_scene.ray_epsilon);
    let replaces = gap && lux_pass.narrow_direct != 0u;
    let sum = lux_gather_sum(origin, n, texel, stream, 0u, rays, lux_pass.sampler,
                             lux_pass.bounce, lux_pass.seed, lux_pass.lamp_paths,
                             lux_pass.first_rays, lux_pass.density_scale, lux_pass.lamp_count,
                             select(lux_pass.direct_at_hits, 1u, replaces), gap);
    var paths = vec3<f32>(0.0);
    if (lux_pass.lamp_paths > 0u) {
        paths = lux_load(lux_connected, c).rgb;
    }
    let kept = select(f32(lux_pass.first_rays), 0.0, replaces);
    let total = kept + f32(rays);
    let m = kept * first.rgb + sum + f32(rays) * paths;
    return vec4<f32>(lux_guard3(vec3<f32>(m.x / total, m.y / total, m.z / total)), 1.0);
}
