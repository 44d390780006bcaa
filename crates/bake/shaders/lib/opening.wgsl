// A lamp's luminous opening (luxbake::opening, operation for operation): its parts, its
// samples, its projected area and the per-texel lattice (after rng.wgsl, scene.wgsl, ies.wgsl
// and lamp.wgsl). The opening is the lamp's `opening` (half.uvw, near) and `shape` (kind,
// axis, faces, 0); no emitting faces: a point lamp.

struct LuxOpening {
    kind: i32,
    axis: i32,
    faces: i32,
    half_axes: vec3<f32>,
    near: f32,
    size: f32,
}

fn lux_opening(li: u32) -> LuxOpening {
    let lamp = lux_lamps[li];
    var o: LuxOpening;
    o.kind = i32(lamp.shape.x);
    o.axis = i32(lamp.shape.y);
    o.faces = i32(lamp.shape.z);
    o.half_axes = lamp.opening.xyz;
    o.near = lamp.opening.w;
    o.size = lamp.shape.w;
    return o;
}

// opening::texel_samples: the samples of a texel d from the centre.
fn lux_texel_samples(o: LuxOpening, d: f32, samples: u32) -> u32 {
    let f = clamp(2.0 * o.size / d, 1.0, 2.0);
    return max(u32(f32(samples) * f + 0.5), 1u);
}

// direct cpu::near_opening: the lamp has an opening and p lies within its near distance.
fn lux_opening_near(o: LuxOpening, lamp_pos: vec3<f32>, p: vec3<f32>) -> bool {
    let to = lamp_pos - p;
    return o.faces != 0 && sqrt(lux_dot(to, to)) < o.near;
}

fn lux_opening_on(o: LuxOpening, bit: i32, v: f32) -> f32 {
    return select(0.0, v, (o.faces & bit) != 0);
}

// opening::part_areas.
fn lux_opening_parts(o: LuxOpening) -> array<f32, 6> {
    let a = o.half_axes.x;
    let b = o.half_axes.y;
    let c = o.half_axes.z;
    var areas = array<f32, 6>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    if (o.kind == 0) {
        let end = 4.0 * a * b;
        areas[0] = lux_opening_on(o, 1, end);
        areas[1] = lux_opening_on(o, 2, end);
        areas[2] = lux_opening_on(o, 4, 4.0 * b * c);
        areas[3] = lux_opening_on(o, 4, 4.0 * b * c);
        areas[4] = lux_opening_on(o, 4, 4.0 * a * c);
        areas[5] = lux_opening_on(o, 4, 4.0 * a * c);
    } else if (o.kind == 1) {
        let end = LUX_PI * a * b;
        let mantle = LUX_TAU * 2.0 * c * sqrt(0.5 * (a * a + b * b));
        areas[0] = lux_opening_on(o, 1, end);
        areas[1] = lux_opening_on(o, 2, end);
        areas[2] = lux_opening_on(o, 4, mantle);
    } else {
        areas[0] = lux_opening_on(o, 4, 4.0 * LUX_PI * (a * b + b * c + a * c) / 3.0);
    }
    return areas;
}

// opening::to_photometric, opening::to_solid.
fn lux_to_photometric(axis: i32, s: vec3<f32>) -> vec3<f32> {
    return select(select(s, s.yzx, axis == 1), s.zxy, axis == 0);
}

fn lux_to_solid(axis: i32, p: vec3<f32>) -> vec3<f32> {
    return select(select(p, p.zxy, axis == 1), p.yzx, axis == 0);
}

// opening::falloff: a draw t in [lo, hi] of the density ~ (s² + t²)^(-3/2) and that density;
// `valid` false for an empty range.
struct LuxFalloff {
    valid: bool,
    t: f32,
    density: f32,
}

fn lux_falloff(u: f32, s: f32, lo: f32, hi: f32) -> LuxFalloff {
    var res: LuxFalloff;
    let g0 = lo / sqrt(s * s + lo * lo);
    let g1 = hi / sqrt(s * s + hi * hi);
    let span = g1 - g0;
    if (!(span > 0.0)) {
        return res;
    }
    let q = g0 + u * span;
    res.t = clamp(s * q / sqrt(max(1.0 - q * q, 0.0)), lo, hi);
    let r2 = s * s + res.t * res.t;
    res.density = s * s / (r2 * sqrt(r2) * span);
    res.valid = true;
    return res;
}

// opening::toward: a point (x, y) of a flat part and its density per area (in z), for a
// receiver h in front of its plane with its foot at foot; density 0: none.
fn lux_toward(u: vec2<f32>, h: f32, foot: vec2<f32>, ext: vec2<f32>, ellipse: bool) -> vec3<f32> {
    if (!(h > 0.0 && ext.x > 0.0 && ext.y > 0.0)) {
        return vec3<f32>(0.0);
    }
    let outside = max(abs(foot.y) - ext.y, 0.0);
    let sx = sqrt(h * h + outside * outside);
    let fx = lux_falloff(u.x, sx, -ext.x - foot.x, ext.x - foot.x);
    if (!fx.valid) {
        return vec3<f32>(0.0);
    }
    let dx = fx.t;
    let x = clamp(foot.x + dx, -ext.x, ext.x);
    var half_chord = ext.y;
    if (ellipse) {
        let q = x / ext.x;
        half_chord = ext.y * sqrt(max(1.0 - q * q, 0.0));
    }
    let sy = sqrt(h * h + dx * dx);
    let fy = lux_falloff(u.y, sy, -half_chord - foot.y, half_chord - foot.y);
    if (!fy.valid) {
        return vec3<f32>(0.0);
    }
    let y = clamp(foot.y + fy.t, -half_chord, half_chord);
    let density = fx.density * fy.density;
    if (!(density > 0.0 && lux_finite(density))) {
        return vec3<f32>(0.0);
    }
    return vec3<f32>(x, y, density);
}

// opening::flat_part: a flat part's plane (the axis of its normal in (u, v, w), its side, its
// in-plane half-extents, ellipse?); `flat` false for a curved part.
struct LuxFlatPart {
    flat: bool,
    axis: i32,
    side: f32,
    ext: vec2<f32>,
    ellipse: bool,
}

fn lux_flat_part(o: LuxOpening, part: i32) -> LuxFlatPart {
    let a = o.half_axes.x;
    let b = o.half_axes.y;
    let c = o.half_axes.z;
    var f: LuxFlatPart;
    f.axis = 2;
    f.side = 1.0;
    if (o.kind == 0) {
        f.flat = true;
        if (part < 2) {
            f.axis = 2;
            f.side = select(1.0, -1.0, part == 0);
            f.ext = vec2<f32>(a, b);
        } else if (part < 4) {
            f.axis = 0;
            f.side = select(-1.0, 1.0, part == 2);
            f.ext = vec2<f32>(b, c);
        } else {
            f.axis = 1;
            f.side = select(-1.0, 1.0, part == 4);
            f.ext = vec2<f32>(a, c);
        }
    } else if (o.kind == 1 && part < 2) {
        f.flat = true;
        f.axis = 2;
        f.side = select(1.0, -1.0, part == 0);
        f.ext = vec2<f32>(a, b);
        f.ellipse = true;
    }
    return f;
}

// opening::visible_areas: the parts' areas a receiver (photometric frame) can see.
fn lux_visible_areas(o: LuxOpening, receiver: vec3<f32>) -> array<f32, 6> {
    var areas = lux_opening_parts(o);
    let r = lux_to_solid(o.axis, receiver);
    for (var part = 0; part < 6; part++) {
        let f = lux_flat_part(o, part);
        if (f.flat) {
            let h = f.side * (r[f.axis] - f.side * o.half_axes[f.axis]);
            if (!(h > 0.0)) {
                areas[part] = 0.0;
            }
        }
    }
    return areas;
}

// opening::counts: n samples shared among the parts in proportion to their areas, at least
// one per part of positive area.
// `areas` by pointer: naga's SPIR-V copies an array value at every access with a variable
// index.
fn lux_counts(areas: ptr<function, array<f32, 6>>, n: u32) -> array<u32, 6> {
    var counts = array<u32, 6>(0u, 0u, 0u, 0u, 0u, 0u);
    var total = 0.0;
    for (var i = 0; i < 6; i++) {
        total += (*areas)[i];
    }
    if (!(total > 0.0)) {
        return counts;
    }
    for (var i = 0; i < 6; i++) {
        if ((*areas)[i] > 0.0) {
            counts[i] = max(u32(f32(n) * (*areas)[i] / total + 0.5), 1u);
        }
    }
    return counts;
}

// opening::sample_part toward a receiver (photometric frame): `valid` false when it lies
// behind the flat part, or for a degenerate point.
struct LuxOpeningSample {
    valid: bool,
    point: vec3<f32>,
    normal: vec3<f32>,
    weight: f32,
}

fn lux_opening_sample_part(o: LuxOpening, part: i32, u: vec2<f32>, receiver: vec3<f32>) -> LuxOpeningSample {
    var res: LuxOpeningSample;
    let a = o.half_axes.x;
    let b = o.half_axes.y;
    let c = o.half_axes.z;
    var p: vec3<f32>;
    var n: vec3<f32>;
    var element: f32;
    let f = lux_flat_part(o, part);
    if (f.flat) {
        let r = lux_to_solid(o.axis, receiver);
        let i = select(0, 1, f.axis == 0);
        let j = select(2, 1, f.axis == 2);
        let plane = f.side * o.half_axes[f.axis];
        let h = f.side * (r[f.axis] - plane);
        let t = lux_toward(u, h, vec2<f32>(r[i], r[j]), f.ext, f.ellipse);
        if (!(t.z > 0.0)) {
            return res;
        }
        p = vec3<f32>(0.0);
        p[f.axis] = plane;
        p[i] = t.x;
        p[j] = t.y;
        n = vec3<f32>(0.0);
        n[f.axis] = f.side;
        element = 1.0 / t.z;
    } else if (o.kind == 1) {
        let s0 = 2.0 * u.x - 1.0;
        let phi = LUX_TAU * u.y;
        let sn = sin(phi);
        let cs = cos(phi);
        let g = vec3<f32>(b * cs, a * sn, 0.0);
        let len = sqrt(lux_dot(g, g));
        if (!(len > 0.0)) {
            return res;
        }
        p = vec3<f32>(a * cs, b * sn, c * s0);
        n = vec3<f32>(g.x / len, g.y / len, 0.0);
        element = LUX_TAU * 2.0 * c * len;
    } else {
        let z = 1.0 - 2.0 * u.x;
        let rr = sqrt(max(1.0 - z * z, 0.0));
        let phi = LUX_TAU * u.y;
        let s = vec3<f32>(rr * cos(phi), rr * sin(phi), z);
        let g = vec3<f32>(b * c * s.x, a * c * s.y, a * b * s.z);
        let len = sqrt(lux_dot(g, g));
        if (!(len > 0.0)) {
            return res;
        }
        p = vec3<f32>(a * s.x, b * s.y, c * s.z);
        n = vec3<f32>(g.x / len, g.y / len, g.z / len);
        element = 4.0 * LUX_PI * len;
    }
    res.valid = true;
    res.weight = element;
    res.point = lux_to_photometric(o.axis, p);
    res.normal = lux_to_photometric(o.axis, n);
    return res;
}

// opening::rectangle_control: flat part `part` of a box's geometric integral
// G = ∫ cos θx · cos θp / r² dA toward a receiver with unit normal n (both photometric), by
// Lambert's formula over its four corners (`g`), and the unit direction from its centre toward
// the receiver; `valid` false for a part that is no rectangle or that the receiver does not
// see wholly.
struct LuxControl {
    valid: bool,
    g: f32,
    toward: vec3<f32>,
}

fn lux_rectangle_corner(o: LuxOpening, f: LuxFlatPart, plane: f32, xy: vec2<f32>,
                        receiver: vec3<f32>) -> vec3<f32> {
    let i = select(0, 1, f.axis == 0);
    let j = select(2, 1, f.axis == 2);
    var c = vec3<f32>(0.0);
    c[f.axis] = plane;
    c[i] = xy.x;
    c[j] = xy.y;
    return lux_to_photometric(o.axis, c) - receiver;
}

// opening::facing: a flat part that the receiver lies in front of; `flat` false for a curved
// part or a receiver on or behind its plane (`f.side * o.half_axes[f.axis]`).
fn lux_facing(o: LuxOpening, part: i32, receiver: vec3<f32>) -> LuxFlatPart {
    var f = lux_flat_part(o, part);
    let r = lux_to_solid(o.axis, receiver);
    f.flat = f.flat && f.side * (r[f.axis] - f.side * o.half_axes[f.axis]) > 0.0;
    return f;
}

// opening::closed_form: a closed form g whose terms sum to `sum` with magnitudes adding to
// `magnitude`, and the unit direction toward the receiver from the part's centre (`centre`:
// the centre less the receiver); `valid` false where the terms cancel past
// opening::CONTROL_MAX_CANCELLATION or a value is not finite and positive.
fn lux_closed_form(sum: f32, magnitude: f32, g: f32, centre: vec3<f32>) -> LuxControl {
    var res: LuxControl;
    let d = sqrt(lux_dot(centre, centre));
    res.valid = magnitude <= LUX_CONTROL_MAX_CANCELLATION * abs(sum) && g > 0.0 && lux_finite(g) &&
        d > 0.0 && lux_finite(d);
    res.g = g;
    res.toward = vec3<f32>(-centre.x / d, -centre.y / d, -centre.z / d);
    return res;
}

fn lux_rectangle_control(o: LuxOpening, part: i32, receiver: vec3<f32>, n: vec3<f32>) -> LuxControl {
    var res: LuxControl;
    res.valid = false;
    let f = lux_facing(o, part, receiver);
    if (o.kind != 0 || !f.flat) {
        return res;
    }
    let plane = f.side * o.half_axes[f.axis];
    var v = array<vec3<f32>, 4>(
        lux_rectangle_corner(o, f, plane, vec2<f32>(-f.ext.x, -f.ext.y), receiver),
        lux_rectangle_corner(o, f, plane, vec2<f32>(f.ext.x, -f.ext.y), receiver),
        lux_rectangle_corner(o, f, plane, vec2<f32>(f.ext.x, f.ext.y), receiver),
        lux_rectangle_corner(o, f, plane, vec2<f32>(-f.ext.x, f.ext.y), receiver),
    );
    var sum = 0.0;
    var magnitude = 0.0;
    var ok = true;
    for (var e = 0; e < 4; e++) {
        let a = v[e];
        let b = v[(e + 1) % 4];
        ok = ok && lux_dot(n, a) > 0.0;
        let c = vec3<f32>(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
        let len = sqrt(lux_dot(c, c));
        ok = ok && len > 0.0;
        let term = lux_atan2(len, lux_dot(a, b)) * (lux_dot(n, c) / len);
        sum += term;
        magnitude += abs(term);
    }
    let centre = lux_rectangle_corner(o, f, plane, vec2<f32>(0.0), receiver);
    res = lux_closed_form(sum, magnitude, 0.5 * abs(sum), centre);
    res.valid = res.valid && ok;
    return res;
}

// opening::disk_control: a cylinder's circular end's geometric integral toward a receiver
// with unit normal n, in closed form (Lambert's formula on its rim), and the unit direction from
// its centre toward the receiver; `valid` false for a part that is no circle, that the receiver
// does not see wholly, or whose formula's terms cancel too much.
fn lux_disk_control(o: LuxOpening, part: i32, receiver: vec3<f32>, n: vec3<f32>) -> LuxControl {
    var res: LuxControl;
    res.valid = false;
    let fp = lux_facing(o, part, receiver);
    if (o.kind != 1 || !fp.flat || fp.ext.x != fp.ext.y) {
        return res;
    }
    let radius = fp.ext.x;
    var c = vec3<f32>(0.0);
    c[fp.axis] = fp.side * o.half_axes[fp.axis];
    var f = vec3<f32>(0.0);
    f[fp.axis] = fp.side;
    let d = lux_to_photometric(o.axis, c) - receiver;
    f = lux_to_photometric(o.axis, f);
    let nf = lux_dot(n, f);
    let nd = lux_dot(n, d);
    let df = lux_dot(d, f);
    let dd = lux_dot(d, d);
    if (!(nd - radius * sqrt(max(1.0 - nf * nf, 0.0)) > 0.0)) {
        return res;
    }
    let r2 = radius * radius;
    let q = dd - r2;
    let s = sqrt(q * q + 4.0 * r2 * (df * df));
    let denominator = dd + r2 + s;
    let inner = nf * dd - nd * df;
    let sum = nf - 2.0 * inner / denominator;
    let magnitude = abs(nf) + 2.0 * (abs(nf) * dd + abs(nd * df)) / denominator;
    return lux_closed_form(sum, magnitude, LUX_PI * r2 / s * abs(sum), d);
}

// opening::projected_area: the emitting parts' projected area seen from photometric
// direction w.
fn lux_opening_projected_area(o: LuxOpening, w: vec3<f32>) -> f32 {
    let s = lux_to_solid(o.axis, w);
    let a = o.half_axes.x;
    let b = o.half_axes.y;
    let c = o.half_axes.z;
    let end_bit = select(2, 1, s.z < 0.0);
    let ends = select(0.0, abs(s.z), (o.faces & end_bit) != 0);
    let sides = (o.faces & 4) != 0;
    if (o.kind == 0) {
        var area = 4.0 * a * b * ends;
        if (sides) {
            area += 4.0 * b * c * abs(s.x) + 4.0 * a * c * abs(s.y);
        }
        return area;
    }
    if (o.kind == 1) {
        var area = LUX_PI * a * b * ends;
        if (sides) {
            area += 4.0 * c * sqrt(a * a * s.y * s.y + b * b * s.x * s.x);
        }
        return area;
    }
    if (!sides) {
        return 0.0;
    }
    let x = b * c * s.x;
    let y = a * c * s.y;
    let z = a * b * s.z;
    return LUX_PI * sqrt(x * x + y * y + z * z);
}

// opening::part_control: a box's face's or a cylinder's circular end's closed form.
fn lux_part_control(o: LuxOpening, part: i32, receiver: vec3<f32>, n: vec3<f32>) -> LuxControl {
    if (o.kind == 0) {
        return lux_rectangle_control(o, part, receiver, n);
    }
    return lux_disk_control(o, part, receiver, n);
}

// opening::shift and opening::lattice.
fn lux_opening_shift(texel: u32, lamp: u32, seed: u32) -> vec2<u32> {
    let h0 = lux_hash(texel, lamp, LUX_OPENING_PASS, seed);
    return vec2<u32>(h0, lux_pcg(h0));
}

fn lux_opening_lattice(k: u32, n: u32, shift: vec2<u32>) -> vec2<f32> {
    let a = (f32(k) + 0.5) / f32(n) + lux_unit(shift.x);
    return vec2<f32>(a - floor(a), lux_unit(k * LUX_PHI + shift.y));
}
