// A lamp seen from a surface point, for the direct pass and the gather's direct light at its
// hits (with scene.wgsl, bvh.wgsl and ies.wgsl).

// backend::lamp_toward: uploaded lamp `li` seen unshadowed from surface point p with unit
// normal n (lux_lamps, scene.wgsl): `valid` false when the lamp stands at p, behind the surface
// or dark toward it; else its distance squared, distance, unit direction toward the lamp, the
// cosine at the surface and the intensity toward p (candela, before the lamp's scale).
struct LuxLampView {
    valid: bool,
    d2: f32,
    d: f32,
    w: vec3<f32>,
    cos_theta: f32,
    intensity: f32,
}

fn lux_lamp_toward(li: u32, p: vec3<f32>, n: vec3<f32>) -> LuxLampView {
    let lamp = lux_lamps[li];
    var v: LuxLampView;
    let to = lamp.position.xyz - p;
    v.d2 = lux_dot(to, to);
    v.d = sqrt(v.d2);
    if (!(v.d > 0.0 && lux_finite(v.d))) {
        return v;
    }
    v.w = vec3<f32>(to.x / v.d, to.y / v.d, to.z / v.d);
    v.cos_theta = lux_dot(n, v.w);
    if (!(v.cos_theta > 0.0)) {
        return v;
    }
    let back = -v.w;
    let photometric = vec3<f32>(lux_dot(lamp.m0.xyz, back), lux_dot(lamp.m1.xyz, back),
                                lux_dot(lamp.m2.xyz, back));
    v.intensity = lux_ies_sample(lamp.table.x, vec2<i32>(lamp.table.yz), photometric);
    v.valid = v.intensity > 0.0;
    return v;
}

// cpu::Start::sees: nothing lies between texel p (unit normal n, offset origin o0, offset
// squared off2) and x, r away (r2 its square), back the unit direction from x toward p.
// *occluder: the triangle that blocked the texel's last ray (-1: none yet), tested first; it
// blocks most of the texel's next rays and spares their traversal (the same answer: a ray that
// hits it would hit a leaf the traversal reaches).
fn lux_sees(p: vec3<f32>, n: vec3<f32>, o0: vec3<f32>, off2: f32, x: vec3<f32>, back: vec3<f32>,
            r: f32, r2: f32, occluder: ptr<function, i32>) -> bool {
    var origin = o0;
    if (16.0 * off2 > r2) {
        origin = p + n * (0.25 * r);
    }
    let dir = x - origin;
    let len = sqrt(lux_dot(dir, dir));
    let x_off = lux_offset_origin(x, back, lux_scene.ray_epsilon) - x;
    let stop_short = min(sqrt(lux_dot(x_off, x_off)), 0.25 * r);
    let t_max = 1.0 - stop_short / len;
    if (!(len > 0.0 && t_max > 0.0)) {
        return true;
    }
    if (*occluder >= 0) {
        var ray: LuxRay;
        var tuv = vec3<f32>(0.0);
        if (lux_ray_setup(origin, dir, &ray)
            && lux_triangle_test(ray, *occluder, 0.0, t_max, &tuv)) {
            return false;
        }
    }
    var hit: vec3<f32>;
    let t = lux_trace(origin, dir, 0.0, t_max, true, &hit);
    if (t >= 0) {
        *occluder = t;
        return false;
    }
    return true;
}

// cpu::direct_texel's point term: uploaded lamp li as a point from its photometric centre,
// seen from p (unit normal n, offset origin o0, offset squared off2) through its shadow ray
// (lux_sees, *occluder its cache): false when it gives p nothing, else its illuminance *k.
fn lux_point_lamp(li: u32, p: vec3<f32>, n: vec3<f32>, o0: vec3<f32>, off2: f32,
                  occluder: ptr<function, i32>, k: ptr<function, vec3<f32>>) -> bool {
    *k = vec3<f32>(0.0);
    let lamp = lux_lamps[li];
    let view = lux_lamp_toward(li, p, n);
    if (!view.valid) {
        return false;
    }
    if (!lux_sees(p, n, o0, off2, lamp.position.xyz, -view.w, view.d, view.d2, occluder)) {
        return false;
    }
    *k = view.intensity * view.cos_theta / max(view.d2, off2) * lamp.scale.xyz;
    return true;
}

// passes::direct::cpu::points_at: the direct illuminance *e at a gather hit p (unit normal n)
// from the first `lamps` uploaded lamps, each as a point from its photometric centre with its
// shadow ray (the direct pass's sum with points_only = 1); false where p lies within a lamp's
// opening's near distance (opening.wgsl's lux_opening_near).
fn lux_point_lamps_at(p: vec3<f32>, n: vec3<f32>, lamps: u32, e: ptr<function, vec3<f32>>)
    -> bool {
    *e = vec3<f32>(0.0);
    let count = min(lamps, arrayLength(&lux_lamps));
    for (var li = 0u; li < count; li++) {
        let lamp = lux_lamps[li];
        let to = lamp.position.xyz - p;
        if (i32(lamp.shape.z) != 0 && sqrt(lux_dot(to, to)) < lamp.opening.w) {
            return false;
        }
    }
    let o0 = lux_offset_origin(p, n, lux_scene.ray_epsilon);
    let off = o0 - p;
    let off2 = lux_dot(off, off);
    var occluder = -1;
    var sum = vec3<f32>(0.0);
    for (var li = 0u; li < count; li++) {
        var k: vec3<f32>;
        if (lux_point_lamp(li, p, n, o0, off2, &occluder, &k)) {
            sum += k;
        }
    }
    *e = lux_guard3(sum);
    return true;
}
