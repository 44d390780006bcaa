// Stackless BVH traversal over the encoded data of luxbake-bvh, line for line the CPU code of
// `luxbake_bvh::traverse` (WatertightRay::new / hits_box / hits_triangle, EncodedScene::walk /
// brute_force) and the glow backend's bvh.glsl. The LUX_* layout constants are generated from
// `luxbake_bvh::layout::wgsl_constants` and prefixed at run time, so the two cannot drift; the
// data is read through lux_bounds_at / lux_link_at / lux_triangle_at (bvh_buffers.wgsl or
// bvh_textures.wgsl).
//
// LUX_TRAVERSAL (a generated const) is LUX_TRAVERSAL_MTBVH (lux_links = the 6-layer MTBVH
// links, layer = dominant ray direction), LUX_TRAVERSAL_TBVH (the 1-layer TBVH links) or
// LUX_TRAVERSAL_NONE (every triangle tested).

// traverse::dominant_axis: ties prefer x, then y.
fn lux_dominant_axis(d: vec3<f32>) -> i32 {
    let a = abs(d);
    if (a.x >= a.y && a.x >= a.z) {
        return 0;
    }
    if (a.y >= a.z) {
        return 1;
    }
    return 2;
}

// traverse::dominant_direction: the MTBVH link layer, 2 * axis + (negative ? 1 : 0).
fn lux_dominant_direction(d: vec3<f32>) -> i32 {
    let k = lux_dominant_axis(d);
    return 2 * k + select(0, 1, d[k] < 0.0);
}

// traverse::WatertightRay.
struct LuxRay {
    origin: vec3<f32>,
    kx: i32,
    ky: i32,
    kz: i32,
    sx: f32,
    sy: f32,
    sz: f32,
    inv: vec3<f32>,
    parallel: vec3<bool>,
}

// WatertightRay::new; false for a zero or non-finite direction (no hit).
fn lux_ray_setup(origin: vec3<f32>, dir: vec3<f32>, r: ptr<function, LuxRay>) -> bool {
    let kz = lux_dominant_axis(dir);
    if (!lux_finite3(dir) || !lux_finite3(origin) || dir[kz] == 0.0) {
        return false;
    }
    var kx = kz + 1;
    if (kx == 3) {
        kx = 0;
    }
    var ky = kx + 1;
    if (ky == 3) {
        ky = 0;
    }
    if (dir[kz] < 0.0) {
        let tmp = kx;
        kx = ky;
        ky = tmp;
    }
    (*r).origin = origin;
    (*r).kx = kx;
    (*r).ky = ky;
    (*r).kz = kz;
    (*r).parallel = abs(dir) < vec3<f32>(LUX_PARALLEL_EPSILON);
    (*r).inv = vec3<f32>(1.0) / select(dir, vec3<f32>(1.0), (*r).parallel);
    (*r).sx = dir[kx] / dir[kz];
    (*r).sy = dir[ky] / dir[kz];
    (*r).sz = 1.0 / dir[kz];
    return true;
}

// WatertightRay::hits_box: slab test on [t_min, t_max], entry and exit widened by LUX_BOX_SLACK.
fn lux_hits_box(r: LuxRay, bmin: vec3<f32>, bmax: vec3<f32>, t_min: f32, t_max: f32) -> bool {
    var box_near = -LUX_BIG;
    var box_far = LUX_BIG;
    for (var a = 0; a < 3; a++) {
        let t0 = (bmin[a] - r.origin[a]) * r.inv[a];
        let t1 = (bmax[a] - r.origin[a]) * r.inv[a];
        let inside = bmin[a] <= r.origin[a] && r.origin[a] <= bmax[a];
        var lo = min(t0, t1);
        var hi = max(t0, t1);
        if (r.parallel[a]) {
            lo = select(LUX_BIG, -LUX_BIG, inside);
            hi = select(-LUX_BIG, LUX_BIG, inside);
        }
        box_near = max(box_near, lo);
        box_far = min(box_far, hi);
    }
    let t_near = max(t_min, box_near - abs(box_near) * LUX_BOX_SLACK);
    let t_far = min(t_max, box_far + abs(box_far) * LUX_BOX_SLACK);
    return t_near <= t_far;
}

// WatertightRay::hits_triangle: true with (t, u, v) when t is in (t_min, t_max).
fn lux_hits_triangle(r: LuxRay, p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>, t_min: f32,
                     t_max: f32, tuv: ptr<function, vec3<f32>>) -> bool {
    let a = p0 - r.origin;
    let b = p1 - r.origin;
    let c = p2 - r.origin;
    let ax = a[r.kx] - r.sx * a[r.kz];
    let ay = a[r.ky] - r.sy * a[r.kz];
    let bx = b[r.kx] - r.sx * b[r.kz];
    let by = b[r.ky] - r.sy * b[r.kz];
    let cx = c[r.kx] - r.sx * c[r.kz];
    let cy = c[r.ky] - r.sy * c[r.kz];
    // Edge functions, all in the antisymmetric form e(P, Q) = P.x * Q.y - P.y * Q.x.
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
        return false;
    }
    let det = u + v + w;
    if (det == 0.0) {
        return false;
    }
    let az = r.sz * a[r.kz];
    let bz = r.sz * b[r.kz];
    let cz = r.sz * c[r.kz];
    let t = (u * az + v * bz + w * cz) / det;
    if (!(t > t_min && t < t_max)) {
        return false;
    }
    *tuv = vec3<f32>(t, v / det, w / det);
    return true;
}

// EncodedScene::coord_of for the triangle data.
fn lux_triangle_coord(t: i32) -> vec2<i32> {
    let w = max(i32(lux_scene.tri_w), 1);
    return vec2<i32>(t % w, t / w);
}

// EncodedScene::triangle_test: three fetches, then the watertight test.
fn lux_triangle_test(r: LuxRay, t: i32, t_min: f32, t_max: f32,
                     tuv: ptr<function, vec3<f32>>) -> bool {
    let c = lux_triangle_coord(t);
    let p0 = lux_triangle_at(c, LUX_TRI_P0_LAYER).xyz;
    let p1 = lux_triangle_at(c, LUX_TRI_P1_LAYER).xyz;
    let p2 = lux_triangle_at(c, LUX_TRI_P2_LAYER).xyz;
    return lux_hits_triangle(r, p0, p1, p2, t_min, t_max, tuv);
}

// EncodedScene::closest_hit / any_hit: the encoded index of the closest (or, with any_hit, the
// first found) triangle hit with t in (t_min, t_max), or -1; *hit = (t, u, v).
fn lux_trace(origin: vec3<f32>, dir: vec3<f32>, t_min: f32, t_max: f32, any_hit: bool,
             hit: ptr<function, vec3<f32>>) -> i32 {
    *hit = vec3<f32>(t_max, 0.0, 0.0);
    var r: LuxRay;
    if (!lux_ray_setup(origin, dir, &r)) {
        return -1;
    }
    var closest = t_max;
    var best = -1;
    var bary = vec2<f32>(0.0);
    var tuv = vec3<f32>(0.0);
    let triangle_count = lux_scene.triangle_count;
    if (LUX_TRAVERSAL == LUX_TRAVERSAL_NONE) {
        // EncodedScene::brute_force.
        for (var t = 0; t < triangle_count; t++) {
            if (lux_triangle_test(r, t, t_min, closest, &tuv)) {
                closest = tuv.x;
                best = t;
                bary = tuv.yz;
                if (any_hit) {
                    break;
                }
            }
        }
    } else {
        // EncodedScene::walk.
        var layer = 0;
        if (LUX_TRAVERSAL == LUX_TRAVERSAL_MTBVH) {
            layer = lux_dominant_direction(dir);
        }
        var node = vec2<i32>(LUX_ROOT_X, LUX_ROOT_Y);
        var done = false;
        for (var steps = 0; steps < lux_scene.node_count && node.x >= 0 && !done; steps++) {
            let lo = lux_bounds_at(node, LUX_BOUNDS_MIN_LAYER);
            let hi = lux_bounds_at(node, LUX_BOUNDS_MAX_LAYER);
            let link = lux_link_at(node, layer);
            if (lux_hits_box(r, lo.xyz, hi.xyz, t_min, closest)) {
                let end = min(i32(hi.w), triangle_count);
                for (var t = max(i32(lo.w), 0); t < end; t++) {
                    if (lux_triangle_test(r, t, t_min, closest, &tuv)) {
                        closest = tuv.x;
                        best = t;
                        bary = tuv.yz;
                        if (any_hit) {
                            done = true;
                            break;
                        }
                    }
                }
                node = vec2<i32>(link.xy);
            } else {
                node = vec2<i32>(link.zw);
            }
        }
    }
    *hit = vec3<f32>(closest, bary);
    return best;
}
