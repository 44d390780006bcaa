// Pass "direct" (paper Figure 4, box 2): illuminance from the pass's lamps, with shadow rays
// through the BVH (cpu::direct_texel, operation for operation).


fn lux_run(c: vec2<i32>) -> vec4<f32> {
    let layer = i32(lux_tile.layer);
    let pos = textureLoad(lux_position, c, layer, 0);
    let nrm = textureLoad(lux_normal, c, layer, 0);
    if (pos.w <= 0.5) {
        return vec4<f32>(0.0);
    }
    let p = pos.xyz;
    var n: vec3<f32>;
    if (!lux_normalize(nrm.xyz, &n)) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    var e = vec3<f32>(0.0);
    let count = min(lux_pass.lamp_count, arrayLength(&lux_lamps));
    for (var li = 0u; li < count; li++) {
        let lamp = lux_lamps[li];
        let lamp_pos = lamp.position.xyz;
        let view = lux_lamp_toward(li, p, n);
        if (!view.valid) {
            continue;
        }
        let d2 = view.d2;
        let d = view.d;
        let cos_theta = view.cos_theta;
        let intensity = view.intensity;
        let back = -view.w;
        let o0 = lux_offset_origin(p, n, lux_scene.ray_epsilon);
        let off = o0 - p;
        let off2 = lux_dot(off, off);
        var origin = o0;
        if (16.0 * off2 > d2) {
            origin = p + n * (0.25 * d);
        }
        let dir = lamp_pos - origin;
        let len = sqrt(lux_dot(dir, dir));
        let lamp_off = lux_offset_origin(lamp_pos, back, lux_scene.ray_epsilon) - lamp_pos;
        let stop_short = min(sqrt(lux_dot(lamp_off, lamp_off)), 0.25 * d);
        let t_max = 1.0 - stop_short / len;
        var hit: vec3<f32>;
        if (len > 0.0 && t_max > 0.0 && lux_trace(origin, dir, 0.0, t_max, true, &hit) >= 0) {
            continue;
        }
        let k = intensity * cos_theta / max(d2, off2);
        e += k * lamp.scale.xyz;
    }
    return vec4<f32>(lux_guard3(e), 1.0);
}
