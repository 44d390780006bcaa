// The gather's ray loop, shared by the gather and refine passes (cpu::gather_rays, operation
// for operation). For programs reading the slot `reflected`; objects' regions are in
// lux_regions (scene.wgsl); non-receivers reflect nothing.

// exact::basis: orthonormal basis around unit n (Duff et al. 2017); copysign via the sign bit.
fn lux_basis(n: vec3<f32>, t: ptr<function, vec3<f32>>, b: ptr<function, vec3<f32>>) {
    let s = select(1.0, -1.0, lux_sign_bit(n.z));
    let a = -1.0 / (s + n.z);
    let bb = n.x * n.y * a;
    *t = vec3<f32>(1.0 + s * n.x * n.x * a, s * bb, -s * n.x);
    *b = vec3<f32>(bb, s + n.y * n.y * a, -n.y);
}

// cpu::Frame::cosine_direction, or with `uniform` Frame::uniform_direction (the rays of a
// texel in a narrow gap, lightpaths::gather_weight).
fn lux_gather_direction(n: vec3<f32>, u: vec2<f32>, uniform_rays: bool) -> vec3<f32> {
    var t: vec3<f32>;
    var b: vec3<f32>;
    lux_basis(n, &t, &b);
    let r = select(sqrt(u.x), sqrt(max(u.x * (2.0 - u.x), 0.0)), uniform_rays);
    let phi = 6.28318530717959 * u.y;
    let x = r * cos(phi);
    let y = r * sin(phi);
    let z = select(sqrt(max(1.0 - u.x, 0.0)), 1.0 - u.x, uniform_rays);
    return vec3<f32>(t.x * x + b.x * y + n.x * z, t.y * x + b.y * y + n.y * z,
                     t.z * x + b.z * y + n.z * z);
}

// map::sample_masked: masked bilinear look-up of light-map UV `uv` in a region of the
// reflected map; with `albedo` the albedo map's (slot `albedo`) with the reflected map's mask
// and weights (gather::GatherParams::direct_at_hits).
fn lux_sample_masked(layer: i32, offset: vec2<i32>, size: vec2<i32>, uv: vec2<f32>,
                     albedo: bool) -> vec3<f32> {
    if (size.x == 0 || size.y == 0 || !lux_finite(uv.x) || !lux_finite(uv.y)) {
        return vec3<f32>(0.0);
    }
    let fx = clamp(uv.x * f32(size.x) - 0.5, 0.0, f32(size.x - 1));
    let fy = clamp(uv.y * f32(size.y) - 0.5, 0.0, f32(size.y - 1));
    let x0f = floor(fx);
    let y0f = floor(fy);
    let tx = fx - x0f;
    let ty = fy - y0f;
    let x0 = i32(x0f);
    let y0 = i32(y0f);
    let x1 = min(x0 + 1, size.x - 1);
    let y1 = min(y0 + 1, size.y - 1);
    // Variables, not values: naga's SPIR-V copies an array value at every access with a
    // variable index.
    var xs = array<vec2<i32>, 4>(vec2<i32>(x0, y0), vec2<i32>(x1, y0), vec2<i32>(x0, y1),
                                 vec2<i32>(x1, y1));
    var ws = array<f32, 4>((1.0 - tx) * (1.0 - ty), tx * (1.0 - ty), (1.0 - tx) * ty, tx * ty);
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var i = 0; i < 4; i++) {
        let t = textureLoad(lux_reflected, offset + xs[i], layer, 0);
        if (t.a > 0.5) {
            var v = t.rgb;
            if (albedo) {
                v = textureLoad(lux_albedo, offset + xs[i], layer, 0).rgb;
            }
            sum += ws[i] * v;
            wsum += ws[i];
        }
    }
    if (wsum > 0.0) {
        return vec3<f32>(sum.x / wsum, sum.y / wsum, sum.z / wsum);
    }
    return vec3<f32>(0.0);
}

// lightpaths::density: the lamps' unshadowed luminance-weighted illuminance at y (unit normal
// n) over the first `lamps` uploaded lamps, each lamp's intensity from its density proxy, the
// lamp paths' density proxy.
fn lux_lamp_density(y: vec3<f32>, n: vec3<f32>, lamps: u32) -> f32 {
    var sum = 0.0;
    let count = min(lamps, arrayLength(&lux_lamps));
    for (var li = 0u; li < count; li++) {
        let lamp = lux_lamps[li];
        let to = lamp.position.xyz - y;
        let d2 = lux_dot(to, to);
        if (!(d2 > 0.0 && lux_finite(d2))) {
            continue;
        }
        let c = lux_dot(n, to);
        if (!(c > 0.0)) {
            continue;
        }
        let back = -to;
        let photometric = vec3<f32>(lux_dot(lamp.m0.xyz, back), lux_dot(lamp.m1.xyz, back),
                                    lux_dot(lamp.m2.xyz, back));
        let intensity = lux_proxy_sample(lamp.table.x + lamp.table.y * lamp.table.z, photometric);
        if (intensity > 0.0) {
            sum += lux_luminance(lamp.scale.xyz) * (intensity * c / (d2 * sqrt(d2)));
        }
    }
    return sum;
}

// lightpaths::gather_weight: a gather hit's share of the reflected exitance (1 for the
// cosine-weighted rays, 2 cx for a gap's uniform ones) times the balance heuristic against `k`
// lamp paths.
fn lux_gather_weight(rays: u32, k: u32, scale: f32, density: f32, r: f32, cx: f32,
                     cy: f32, uniform_rays: bool) -> f32 {
    let pdf = select(cx, 0.5, uniform_rays);
    let share = select(1.0, 2.0 * cx, uniform_rays);
    if (k == 0u) {
        return share;
    }
    let v = 3.14159265358979 * f32(k) * (scale * density) * (r * r);
    if (!(v > 0.0)) {
        return share;
    }
    let g = f32(rays) * (pdf * cy);
    let d = g + v;
    if (lux_finite(d)) {
        return share * (g / d);
    }
    return 0.0;
}

// cpu::gather_rays: the sum of the reflected exitance seen along rays `first_ray .. first_ray + count`
// of the texel's draws (`stream`: rng::Stream's key and first index), cast from `origin` around
// the unit normal `n`, each weighted against `lamp_paths` lamp paths of a gather of `mis_rays`
// rays (lightpaths; 0: weight 1). `texel` (lux_texel_index) places a replayed hit. With
// direct_at_hits = 1 a hit away from every lamp's opening reads the lamps' direct light there
// times its albedo (lux_point_lamps_at, gather::GatherParams::direct_at_hits). With `uniform`
// (a texel in a narrow gap) the rays are drawn uniformly over the hemisphere and weighted by
// their share (lux_gather_weight).
fn lux_gather_sum(origin: vec3<f32>, n: vec3<f32>, texel: u32, stream: vec2<u32>,
                  first_ray: u32, count: u32,
                  sampler_id: u32, bounce: u32, seed: u32, lamp_paths: u32, mis_rays: u32,
                  density_scale: f32, lamps: u32, direct_at_hits: u32,
                  uniform_rays: bool) -> vec3<f32> {
    let objects = lux_scene.object_count;
    var sum = vec3<f32>(0.0);
    for (var s = first_ray; s < first_ray + count; s++) {
        let dir = lux_gather_direction(n, lux_sample2(sampler_id, stream.x, stream.y + s, bounce,
                                                      seed), uniform_rays);
        var hit: vec3<f32>;
        let tri = lux_gather_hit(origin, dir, texel, s - first_ray, &hit);
        if (tri < 0) {
            continue;
        }
        let tc = lux_triangle_coord(tri);
        let uv2_object = lux_triangle_at(tc, LUX_TRI_UV2_OBJECT_LAYER);
        let object = i32(uv2_object.z);
        if (object < 0 || object >= objects) {
            continue;
        }
        let region0 = lux_regions[2 * object];
        if (region0.w == 0u) {
            continue;
        }
        let region1 = lux_regions[2 * object + 1];
        let u = hit.y;
        let v = hit.z;
        let w0 = 1.0 - u - v;
        let n0 = lux_triangle_at(tc, LUX_TRI_N0_LAYER).xyz;
        let n1 = lux_triangle_at(tc, LUX_TRI_N1_LAYER).xyz;
        let n2 = lux_triangle_at(tc, LUX_TRI_N2_LAYER).xyz;
        let nh = vec3<f32>(w0 * n0.x + u * n1.x + v * n2.x, w0 * n0.y + u * n1.y + v * n2.y,
                           w0 * n0.z + u * n1.z + v * n2.z);
        if (!(lux_dot(nh, dir) < 0.0)) {
            continue;
        }
        let uv01 = lux_triangle_at(tc, LUX_TRI_UV01_LAYER);
        let uv = vec2<f32>(w0 * uv01.x + u * uv01.z + v * uv2_object.x,
                           w0 * uv01.y + u * uv01.w + v * uv2_object.y);
        // The hit's point, for the direct light there and the lamp paths' weight.
        let y = vec3<f32>(origin.x + hit.x * dir.x, origin.y + hit.x * dir.y,
                          origin.z + hit.x * dir.z);
        var m: vec3<f32>;
        var e: vec3<f32>;
        if (direct_at_hits != 0u && lux_gather_direct(y, nh, lamps, &e)) {
            let a = lux_sample_masked(i32(region0.x), vec2<i32>(region0.yz),
                                      vec2<i32>(region1.xy), uv, true);
            m = vec3<f32>(a.x * e.x, a.y * e.y, a.z * e.z);
        } else {
            m = lux_sample_masked(i32(region0.x), vec2<i32>(region0.yz), vec2<i32>(region1.xy),
                                  uv, false);
        }
        var weight = select(1.0, 2.0 * lux_dot(n, dir), uniform_rays);
        // Nothing to weigh where the hit reflects no light (cpu::GatherChunk::sum).
        if (lamp_paths > 0u && (m.x != 0.0 || m.y != 0.0 || m.z != 0.0)) {
            var ny: vec3<f32>;
            if (!lux_normalize(nh, &ny)) {
                ny = vec3<f32>(0.0);
            }
            let density = lux_lamp_density(y, ny, lamps);
            weight = lux_gather_weight(mis_rays, lamp_paths, density_scale, density, hit.x,
                                       lux_dot(n, dir), -lux_dot(ny, dir), uniform_rays);
        }
        sum += weight * m;
    }
    return sum;
}
