// A lamp seen from a surface point, for the direct pass
// (with scene.wgsl and ies.wgsl).

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
