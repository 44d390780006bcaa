// Pass "direct" (paper Figure 4, box 2): illuminance from the pass's lamps, with shadow rays
// through the BVH (cpu::direct_texel, operation for operation); near a lamp's luminous
// opening, lux_pass.samples points of it (lux_opening_*, opening.wgsl). With
// lux_pass.chunk_samples > 0 an opening's samples are split over dispatches, each adding its
// share to the one before (lux_prior); the lamps without an opening come with the first. With
// lux_pass.points_only = 1 every lamp is a point (the preview of the direct light).

// cpu::OpeningView::point: lattice point k of count on part `part` of lamp li's opening as
// the texel at p sees it, before the point's shadow ray: its share `value`, its geometric
// share `geom` (the control variate's) and the ray's end x, back, r, r2; valid false when it
// gives p nothing whatever the ray finds.
struct LuxOpeningPoint {
    valid: bool,
    value: f32,
    geom: f32,
    x: vec3<f32>,
    back: vec3<f32>,
    r: f32,
    r2: f32,
}

fn lux_opening_point(li: u32, o: LuxOpening, part: i32, k: u32, count: u32, shift: vec2<u32>,
                     receiver: vec3<f32>, p: vec3<f32>, n: vec3<f32>, off2: f32) -> LuxOpeningPoint {
    var res: LuxOpeningPoint;
    res.valid = false;
    let lamp = lux_lamps[li];
    let lamp_pos = lamp.position.xyz;
    let m0 = lamp.m0.xyz;
    let m1 = lamp.m1.xyz;
    let m2 = lamp.m2.xyz;
    let s = lux_opening_sample_part(o, part, lux_opening_lattice(k, count, shift), receiver);
    if (!s.valid) {
        return res;
    }
    let q = s.point;
    let x = vec3<f32>(lamp_pos.x + q.x * m0.x + q.y * m1.x + q.z * m2.x,
                      lamp_pos.y + q.x * m0.y + q.y * m1.y + q.z * m2.y,
                      lamp_pos.z + q.x * m0.z + q.y * m1.z + q.z * m2.z);
    let to = x - p;
    let r2 = lux_dot(to, to);
    let r = sqrt(r2);
    if (!(r > 0.0 && lux_finite(r))) {
        return res;
    }
    let w = vec3<f32>(to.x / r, to.y / r, to.z / r);
    let cos_p = lux_dot(n, w);
    if (!(cos_p > 0.0)) {
        return res;
    }
    let back = -w;
    let emit = vec3<f32>(lux_dot(m0, back), lux_dot(m1, back), lux_dot(m2, back));
    let cos_x = lux_dot(s.normal, emit);
    if (!(cos_x > 0.0)) {
        return res;
    }
    let area = lux_opening_projected_area(o, emit);
    if (!(area > 0.0)) {
        return res;
    }
    let intensity = lux_ies_sample(lamp.table.x, vec2<i32>(lamp.table.yz), emit);
    if (!(intensity > 0.0)) {
        return res;
    }
    let r2e = max(max(r2, off2), s.weight / (LUX_PI * f32(count)));
    res.valid = true;
    res.value = intensity * cos_x * s.weight / area * cos_p / r2e;
    res.geom = cos_x * s.weight * cos_p / r2;
    res.x = x;
    res.back = back;
    res.r = r;
    res.r2 = r2;
    return res;
}

// cpu::from_opening: the illuminance at p from lattice points of lamp li's opening
// (lux_texel_samples of lux_pass.samples), shared among the parts p can see, before the
// lamp's scale, each with its shadow ray unless the probes all see the opening
// (cpu::sees_all: the points k = 0, probe_stride, 2·probe_stride, … of each part that give
// light); the points whose index over the parts lies in [first, end).
fn lux_from_opening(li: u32, o: LuxOpening, p: vec3<f32>, n: vec3<f32>, o0: vec3<f32>, off2: f32,
                    shift: vec2<u32>, first: u32, end: u32) -> f32 {
    let lamp = lux_lamps[li];
    let lamp_pos = lamp.position.xyz;
    let m0 = lamp.m0.xyz;
    let m1 = lamp.m1.xyz;
    let m2 = lamp.m2.xyz;
    // The receiver in the lamp's photometric frame: M·(p − centre).
    let rel = p - lamp_pos;
    let receiver = vec3<f32>(lux_dot(m0, rel), lux_dot(m1, rel), lux_dot(m2, rel));
    let n_texel = lux_texel_samples(o, sqrt(lux_dot(rel, rel)), lux_pass.samples);
    // Variables, read with a variable index (see opening.wgsl's lux_counts).
    var areas = lux_visible_areas(o, receiver);
    var counts = lux_counts(&areas, n_texel);
    // A chunk past the texel's points adds nothing (and asks no probe).
    var total = 0u;
    for (var part = 0; part < 6; part++) {
        total += counts[part];
    }
    if (first >= total) {
        return 0.0;
    }
    // cpu::sees_all, and where every probe sees the opening, cpu::control: each share of a
    // part with a closed form (a rectangle, a disk) from its probes alone (cv_parts: those
    // parts; cv_sum: the shares of those whose first point is this chunk's).
    var occluder = -1;
    var trace = true;
    var cv_parts = 0u;
    var cv_sum = 0.0;
    let stride = lux_pass.probe_stride;
    if (stride > 1u) {
        // The receiver's normal in the photometric frame.
        let normal = vec3<f32>(lux_dot(m0, n), lux_dot(m1, n), lux_dot(m2, n));
        var seen = false;
        var blocked = false;
        var base = 0u;
        for (var part = 0; part < 6 && !blocked; part++) {
            let count = counts[part];
            let lo = min(first - min(first, base), count);
            let hi = min(end - min(end, base), count);
            base += count;
            if (count == 0u) {
                continue;
            }
            let control = lux_part_control(o, part, receiver, normal);
            var cv = control.valid;
            var luminance = 0.0;
            if (cv) {
                let area = lux_opening_projected_area(o, control.toward);
                luminance = lux_ies_sample(lamp.table.x, vec2<i32>(lamp.table.yz), control.toward) / area;
                cv = area > 0.0 && luminance > 0.0 && lux_finite(luminance);
            }
            var residual = 0.0;
            var square = 0.0;
            var probes = 0u;
            for (var k = 0u; k < count; k += stride) {
                let pt = lux_opening_point(li, o, part, k, count, shift, receiver, p, n, off2);
                if (!pt.valid) {
                    cv = false;
                    continue;
                }
                if (!lux_sees(p, n, o0, off2, pt.x, pt.back, pt.r, pt.r2, &occluder)) {
                    blocked = true;
                    break;
                }
                seen = true;
                let d = pt.value - luminance * pt.geom;
                residual += d;
                square += d * d;
                probes += 1u;
            }
            // The probes' own estimate of their mean's error (cpu::control).
            let nf = f32(probes);
            let estimate = luminance * control.g + residual / nf;
            let mean = residual / nf;
            let variance = max(square / nf - mean * mean, 0.0) / (nf - 1.0);
            cv = cv && probes >= LUX_CONTROL_MIN_PROBES
                && variance <= LUX_CONTROL_MAX_ERROR * LUX_CONTROL_MAX_ERROR * estimate * estimate;
            if (cv && !blocked) {
                cv_parts |= 1u << u32(part);
                if (lo == 0u && hi > 0u) {
                    cv_sum += estimate;
                }
            }
        }
        trace = blocked || !seen;
    }
    if (trace) {
        cv_parts = 0u;
        cv_sum = 0.0;
    }
    var sum = cv_sum;
    // Index of the part's first point among all the opening's.
    var base = 0u;
    for (var part = 0; part < 6; part++) {
        let count = counts[part];
        let nf = f32(count);
        var part_sum = 0.0;
        let lo = min(first - min(first, base), count);
        let hi = min(end - min(end, base), count);
        base += count;
        if ((cv_parts & (1u << u32(part))) != 0u) {
            continue;
        }
        for (var k = lo; k < hi; k++) {
            let pt = lux_opening_point(li, o, part, k, count, shift, receiver, p, n, off2);
            if (!pt.valid) {
                continue;
            }
            if (trace && !lux_sees(p, n, o0, off2, pt.x, pt.back, pt.r, pt.r2, &occluder)) {
                continue;
            }
            part_sum += pt.value;
        }
        if (count > 0u) {
            sum += part_sum / nf;
        }
    }
    return sum;
}

fn lux_run(c: vec2<i32>) -> vec4<f32> {
    let pos = lux_load(lux_position, c);
    let nrm = lux_load(lux_normal, c);
    if (pos.w <= 0.5) {
        return vec4<f32>(0.0);
    }
    let p = pos.xyz;
    var n: vec3<f32>;
    if (!lux_normalize(nrm.xyz, &n)) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let texel = lux_texel_index(textureDimensions(lux_position).xy, lux_tile.layer, u32(c.x),
                                u32(c.y));
    let o0 = lux_offset_origin(p, n, lux_scene.ray_epsilon);
    let off = o0 - p;
    let off2 = lux_dot(off, off);
    // A chunk of the opening samples: flattened indices first..end of each opening's.
    let first = lux_pass.first_sample;
    var end = 0xffffffffu;
    if (lux_pass.chunk_samples > 0u) {
        end = first + min(lux_pass.chunk_samples, 0xffffffffu - first);
    }
    var e = vec3<f32>(0.0);
    if (first > 0u) {
        e = lux_load(lux_prior, c).rgb;
    }
    let count = min(lux_pass.lamp_count, arrayLength(&lux_lamps));
    var occluder = -1;
    for (var li = 0u; li < count; li++) {
        let lamp = lux_lamps[li];
        let lamp_pos = lamp.position.xyz;
        let opening = lux_opening(li);
        if (lux_pass.points_only == 0u && lux_opening_near(opening, lamp_pos, p)) {
            let shift = lux_opening_shift(texel, li, lux_pass.seed);
            let k = lux_from_opening(li, opening, p, n, o0, off2, shift, first, end);
            e += k * lamp.scale.xyz;
            continue;
        }
        // A lamp without an opening is the first chunk's.
        if (first > 0u) {
            continue;
        }
        var k: vec3<f32>;
        if (lux_point_lamp(li, p, n, o0, off2, &occluder, &k)) {
            e += k;
        }
    }
    return vec4<f32>(lux_guard3(e), 1.0);
}
