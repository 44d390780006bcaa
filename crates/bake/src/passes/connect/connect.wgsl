// Pass "connect" (lightpaths.rs): the lamp paths' part of the first bounce at a texel — K
// points of the pool picked with the Sobol sampler's block draws (lightpaths, "Stratified
// picks"), each joined by a shadow ray and weighted by
// the balance heuristic against a gather of `rays` rays (connect/cpu.rs, operation for
// operation). The pool: lux_path_point (scene.wgsl). With lux_pass.picks > 0 the refinement's
// second estimate: that many further picks continuing the texel's (lux_refine_stream), at the
// texels whose variance estimate (lux_variance) misses lux_pass.max_error only, the sum scaled
// by k / picks. With lux_pass.narrow_picks > 0 the same at the texels in a narrow gap
// (position w >= LUX_NARROW_GAP), whatever their noise: the larger count where both apply, the
// picks' draws spanning the larger of the two counts (ConnectParams::connections_at).

fn lux_run(c: vec2<i32>) -> vec4<f32> {
    let pw = lux_load(lux_position, c);
    if (pw.w <= 0.5) {
        return vec4<f32>(0.0);
    }
    var n: vec3<f32>;
    if (!lux_normalize(lux_load(lux_normal, c).xyz, &n)) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let count = min(lux_pass.count, lux_path_point_count());
    if (count == 0u || lux_pass.k == 0u) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    var picks = lux_pass.k;
    let size = textureDimensions(lux_position).xy;
    var stream: vec2<u32>;
    let refinement = lux_pass.picks > 0u || lux_pass.narrow_picks > 0u;
    if (refinement) {
        picks = select(0u, lux_pass.narrow_picks, pw.w >= LUX_NARROW_GAP);
        if (lux_pass.picks > 0u && lux_refines(lux_load(lux_variance, c), lux_pass.max_error)) {
            picks = max(picks, lux_pass.picks);
        }
        if (picks == 0u) {
            return vec4<f32>(0.0, 0.0, 0.0, 1.0);
        }
        stream = lux_refine_stream(LUX_SAMPLER_SOBOL, size, lux_tile.layer, u32(c.x), u32(c.y),
                                   lux_pass.k, max(lux_pass.picks, lux_pass.narrow_picks));
    } else {
        stream = lux_gather_stream(LUX_SAMPLER_SOBOL, size, lux_tile.layer, u32(c.x), u32(c.y),
                                   1u, lux_pass.k);
    }
    // The idle program (kept::Variant::Idle) runs where no texel gets further connections:
    // without the shadow rays' code, which a SIMD rasteriser would run masked for every texel.
    if (LUX_IDLE != 0u) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let p = pw.xyz;
    let origin = lux_offset_origin(p, n, lux_scene.ray_epsilon);
    let nc = f32(lux_pass.rays);
    // The gather's density per steradian times pi toward a point: cx for its cosine-weighted
    // rays, 1/2 for a gap's uniform ones (lightpaths::gather_weight).
    let uniform_rays = pw.w >= LUX_NARROW_GAP;
    let kf = f32(lux_pass.k);
    var sum = vec3<f32>(0.0);
    for (var s = 0u; s < picks; s++) {
        let u = lux_sobol2(stream.x, stream.y + s, LUX_CONNECT_PASS, lux_pass.seed);
        let j = min(u32(u.x * f32(count)), count - 1u);
        let a = lux_path_point(j, 0u);
        let b = lux_path_point(j, 1u);
        let power = lux_path_point(j, 2u).xyz;
        let to = a.xyz - p;
        let r2 = lux_dot(to, to);
        let r = sqrt(r2);
        if (!(r > 0.0 && lux_finite(r))) {
            continue;
        }
        let w = to / r;
        let cx = lux_dot(n, w);
        let cy = -lux_dot(b.xyz, w);
        if (!(cx > 0.0 && cy > 0.0)) {
            continue;
        }
        let target_point = lux_offset_origin(a.xyz, b.xyz, lux_scene.ray_epsilon);
        let sd = target_point - origin;
        let len = sqrt(lux_dot(sd, sd));
        if (!(len > 0.0)) {
            continue;
        }
        var hit: vec3<f32>;
        if (lux_trace(origin, sd / len, 0.0, len * (1.0 - 1e-4), true, &hit) >= 0) {
            continue;
        }
        let pv = a.w * lux_pass.density_scale;
        let geometry = cx * cy;
        let gathered = select(geometry, 0.5 * cy, uniform_rays);
        let denominator = 3.14159265358979 * kf * pv * r2 + nc * gathered;
        if (!(denominator > 0.0)) {
            continue;
        }
        let f = pv * geometry / denominator;
        sum += f * power;
    }
    var scale = 1.0;
    if (refinement) {
        scale = kf / f32(picks);
    }
    return vec4<f32>(lux_guard3(sum * scale), 1.0);
}
