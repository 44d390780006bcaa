// Shared by the denoiser passes (variance, atrous), mirroring luxbake::cpu's Guide: whether a
// tap lies on the centre's surface (inside the layer, valid, the centre's object, within the
// chart reach). For programs reading the slots src, position and normal.

struct LuxGuide {
    c: vec2<i32>,
    p: vec3<f32>,
    n: vec3<f32>,
    object: f32,
    reach2: f32,
    reach_min2: f32,
}

// cpu::Guide::new with the chart test's [reach_min, reach]: false when the centre's normal
// cannot be normalised.
fn lux_guide(c: vec2<i32>, reach_min: f32, reach: f32, g: ptr<function, LuxGuide>) -> bool {
    let nc = lux_load(lux_normal, c);
    (*g).c = c;
    (*g).p = lux_load(lux_position, c).xyz;
    (*g).object = nc.w;
    (*g).reach2 = reach * reach;
    (*g).reach_min2 = reach_min * reach_min;
    var n: vec3<f32>;
    let ok = lux_normalize(nc.xyz, &n);
    (*g).n = n;
    return ok;
}

// cpu::Guide::tap: whether the tap at `offset` texels lies on the centre's surface; if so its
// value and the cosine between the normals.
fn lux_tap(g: LuxGuide, offset: vec2<i32>, value: ptr<function, vec4<f32>>,
           cosine: ptr<function, f32>) -> bool {
    *value = vec4<f32>(0.0);
    *cosine = 0.0;
    let t = g.c + offset;
    if (t.x < 0 || t.y < 0 || t.x >= i32(lux_tile.layer_w) || t.y >= i32(lux_tile.layer_h)) {
        return false;
    }
    *value = lux_load(lux_src, t);
    if ((*value).a <= 0.5) {
        return false;
    }
    let nt = lux_load(lux_normal, t);
    if (nt.w != g.object) {
        return false;
    }
    let d = lux_load(lux_position, t).xyz - g.p;
    let d2 = lux_dot(d, d);
    let o2 = f32(offset.x * offset.x + offset.y * offset.y);
    let m = max(max(abs(offset.x), abs(offset.y)) - 2, 0);
    if (o2 > 0.0 && !(d2 <= g.reach2 * o2 && d2 >= g.reach_min2 * f32(m * m))) {
        return false;
    }
    // The G-buffer's normals are unit: used as stored.
    *cosine = lux_dot(g.n, nt.xyz);
    return true;
}
