// A lamp's luminous opening (luxbake::opening, operation for operation): its parts, its
// samples, its projected area and the per-texel lattice (after common.glsl, whose luxPick it
// uses, rng.glsl, scene.glsl, ies.glsl and lamp.glsl). The opening is lamp rows 6 (half.uvw,
// near) and 7 (kind, axis, faces, 0) (luxLamp); no emitting faces: a point lamp. Row 7's w is
// the opening's size.

struct LuxOpening {
    int kind;
    int axis;
    int faces;
    vec3 halfAxes;
    float near;
    float size;
};

LuxOpening luxOpening(int li) {
    vec4 a = luxLamp(li, 6);
    vec4 b = luxLamp(li, 7);
    LuxOpening o;
    o.kind = int(b.x);
    o.axis = int(b.y);
    o.faces = int(b.z);
    o.halfAxes = a.xyz;
    o.near = a.w;
    o.size = b.w;
    return o;
}

// opening::texel_samples: the samples of a texel d from the centre.
uint luxTexelSamples(LuxOpening o, float d, uint samples) {
    float f = clamp(2.0 * o.size / d, 1.0, 2.0);
    return max(uint(float(samples) * f + 0.5), 1u);
}

// direct cpu::near_opening: the lamp has an opening and p lies within its near distance.
bool luxOpeningNear(LuxOpening o, vec3 lampPos, vec3 p) {
    vec3 to = lampPos - p;
    return o.faces != 0 && sqrt(luxDot(to, to)) < o.near;
}

float luxOpeningOn(LuxOpening o, int bit, float v) {
    return (o.faces & bit) != 0 ? v : 0.0;
}

// opening::part_areas.
void luxOpeningParts(LuxOpening o, out float areas[6]) {
    const float PI = 3.14159265358979;
    const float TAU = 6.28318530717959;
    float a = o.halfAxes.x;
    float b = o.halfAxes.y;
    float c = o.halfAxes.z;
    for (int i = 0; i < 6; ++i) {
        areas[i] = 0.0;
    }
    if (o.kind == 0) {
        float end = 4.0 * a * b;
        areas[0] = luxOpeningOn(o, 1, end);
        areas[1] = luxOpeningOn(o, 2, end);
        areas[2] = luxOpeningOn(o, 4, 4.0 * b * c);
        areas[3] = luxOpeningOn(o, 4, 4.0 * b * c);
        areas[4] = luxOpeningOn(o, 4, 4.0 * a * c);
        areas[5] = luxOpeningOn(o, 4, 4.0 * a * c);
    } else if (o.kind == 1) {
        float end = PI * a * b;
        float mantle = TAU * 2.0 * c * sqrt(0.5 * (a * a + b * b));
        areas[0] = luxOpeningOn(o, 1, end);
        areas[1] = luxOpeningOn(o, 2, end);
        areas[2] = luxOpeningOn(o, 4, mantle);
    } else {
        areas[0] = luxOpeningOn(o, 4, 4.0 * PI * (a * b + b * c + a * c) / 3.0);
    }
}

// The vector whose component `axis` is w and whose other two are xy's, in order (common.glsl's
// luxPick's counterpart for writing).
vec3 luxPlace(int axis, float w, vec2 xy) {
    return vec3(axis == 0 ? w : xy.x, axis == 0 ? xy.x : (axis == 1 ? w : xy.y),
                axis == 2 ? w : xy.y);
}

// opening::to_photometric, opening::to_solid.
vec3 luxToPhotometric(int axis, vec3 s) {
    return axis == 0 ? s.zxy : (axis == 1 ? s.yzx : s);
}

vec3 luxToSolid(int axis, vec3 p) {
    return axis == 0 ? p.yzx : (axis == 1 ? p.zxy : p);
}

// opening::falloff: a draw t in [lo, hi] of the density ~ (s² + t²)^(-3/2) and that density;
// false for an empty range.
bool luxFalloff(float u, float s, float lo, float hi, out float t, out float density) {
    float g0 = lo / sqrt(s * s + lo * lo);
    float g1 = hi / sqrt(s * s + hi * hi);
    float span = g1 - g0;
    t = 0.0;
    density = 0.0;
    if (!(span > 0.0)) {
        return false;
    }
    float q = g0 + u * span;
    t = clamp(s * q / sqrt(max(1.0 - q * q, 0.0)), lo, hi);
    float r2 = s * s + t * t;
    density = s * s / (r2 * sqrt(r2) * span);
    return true;
}

// opening::toward: a point (x, y) of a flat part and its density per area, for a receiver h
// in front of its plane with its foot at foot.
bool luxToward(vec2 u, float h, vec2 foot, vec2 ext, bool ellipse, out vec2 xy,
               out float density) {
    xy = vec2(0.0);
    density = 0.0;
    if (!(h > 0.0 && ext.x > 0.0 && ext.y > 0.0)) {
        return false;
    }
    float outside = max(abs(foot.y) - ext.y, 0.0);
    float sx = sqrt(h * h + outside * outside);
    float dx;
    float px;
    if (!luxFalloff(u.x, sx, -ext.x - foot.x, ext.x - foot.x, dx, px)) {
        return false;
    }
    float x = clamp(foot.x + dx, -ext.x, ext.x);
    float halfChord = ext.y;
    if (ellipse) {
        float q = x / ext.x;
        halfChord = ext.y * sqrt(max(1.0 - q * q, 0.0));
    }
    float sy = sqrt(h * h + dx * dx);
    float dy;
    float py;
    if (!luxFalloff(u.y, sy, -halfChord - foot.y, halfChord - foot.y, dy, py)) {
        return false;
    }
    float y = clamp(foot.y + dy, -halfChord, halfChord);
    density = px * py;
    xy = vec2(x, y);
    return density > 0.0 && luxFinite(density);
}

// opening::flat_part: a flat part's plane (the axis of its normal in (u, v, w), its side, its
// in-plane half-extents, ellipse?); false for a curved part.
bool luxFlatPart(LuxOpening o, int part, out int axis, out float side, out vec2 ext,
                 out bool ellipse) {
    float a = o.halfAxes.x;
    float b = o.halfAxes.y;
    float c = o.halfAxes.z;
    axis = 2;
    side = 1.0;
    ext = vec2(0.0);
    ellipse = false;
    if (o.kind == 0) {
        if (part < 2) {
            axis = 2;
            side = part == 0 ? -1.0 : 1.0;
            ext = vec2(a, b);
        } else if (part < 4) {
            axis = 0;
            side = part == 2 ? 1.0 : -1.0;
            ext = vec2(b, c);
        } else {
            axis = 1;
            side = part == 4 ? 1.0 : -1.0;
            ext = vec2(a, c);
        }
        return true;
    }
    if (o.kind == 1 && part < 2) {
        axis = 2;
        side = part == 0 ? -1.0 : 1.0;
        ext = vec2(a, b);
        ellipse = true;
        return true;
    }
    return false;
}

// opening::visible_areas: the parts' areas a receiver (photometric frame) can see.
void luxVisibleAreas(LuxOpening o, vec3 receiver, out float areas[6]) {
    luxOpeningParts(o, areas);
    vec3 r = luxToSolid(o.axis, receiver);
    for (int part = 0; part < 6; ++part) {
        int axis;
        float side;
        vec2 ext;
        bool ellipse;
        if (luxFlatPart(o, part, axis, side, ext, ellipse)) {
            float h = side * (luxPick(r, axis) - side * luxPick(o.halfAxes, axis));
            if (!(h > 0.0)) {
                areas[part] = 0.0;
            }
        }
    }
}

// opening::counts: n samples shared among the parts in proportion to their areas, at least
// one per part of positive area.
void luxCounts(float areas[6], uint n, out uint counts[6]) {
    float total = 0.0;
    for (int i = 0; i < 6; ++i) {
        total += areas[i];
        counts[i] = 0u;
    }
    if (!(total > 0.0)) {
        return;
    }
    for (int i = 0; i < 6; ++i) {
        if (areas[i] > 0.0) {
            counts[i] = max(uint(float(n) * areas[i] / total + 0.5), 1u);
        }
    }
}

// opening::sample_part toward a receiver (photometric frame): false when it lies behind the
// flat part, or for a degenerate point.
bool luxOpeningSamplePart(LuxOpening o, int part, vec2 u, vec3 receiver, out vec3 point,
                          out vec3 normal, out float weight) {
    const float PI = 3.14159265358979;
    const float TAU = 6.28318530717959;
    point = vec3(0.0);
    normal = vec3(0.0);
    weight = 0.0;
    float a = o.halfAxes.x;
    float b = o.halfAxes.y;
    float c = o.halfAxes.z;
    vec3 p;
    vec3 n;
    float element;
    int planeAxis;
    float side;
    vec2 ext;
    bool ellipse;
    if (luxFlatPart(o, part, planeAxis, side, ext, ellipse)) {
        vec3 r = luxToSolid(o.axis, receiver);
        int i = planeAxis == 0 ? 1 : 0;
        int j = planeAxis == 2 ? 1 : 2;
        float plane = side * luxPick(o.halfAxes, planeAxis);
        float h = side * (luxPick(r, planeAxis) - plane);
        vec2 xy;
        float density;
        if (!luxToward(u, h, vec2(luxPick(r, i), luxPick(r, j)), ext, ellipse, xy, density)) {
            return false;
        }
        p = luxPlace(planeAxis, plane, xy);
        n = luxPlace(planeAxis, side, vec2(0.0));
        element = 1.0 / density;
    } else if (o.kind == 1) {
        float s0 = 2.0 * u.x - 1.0;
        float phi = TAU * u.y;
        float sn = sin(phi);
        float cs = cos(phi);
        vec3 g = vec3(b * cs, a * sn, 0.0);
        float len = sqrt(luxDot(g, g));
        if (!(len > 0.0)) {
            return false;
        }
        p = vec3(a * cs, b * sn, c * s0);
        n = vec3(g.x / len, g.y / len, 0.0);
        element = TAU * 2.0 * c * len;
    } else {
        float z = 1.0 - 2.0 * u.x;
        float rr = sqrt(max(1.0 - z * z, 0.0));
        float phi = TAU * u.y;
        vec3 s = vec3(rr * cos(phi), rr * sin(phi), z);
        vec3 g = vec3(b * c * s.x, a * c * s.y, a * b * s.z);
        float len = sqrt(luxDot(g, g));
        if (!(len > 0.0)) {
            return false;
        }
        p = vec3(a * s.x, b * s.y, c * s.z);
        n = vec3(g.x / len, g.y / len, g.z / len);
        element = 4.0 * PI * len;
    }
    weight = element;
    point = luxToPhotometric(o.axis, p);
    normal = luxToPhotometric(o.axis, n);
    return true;
}

// opening::projected_area: the emitting parts' projected area seen from photometric
// direction w.
float luxOpeningProjectedArea(LuxOpening o, vec3 w) {
    const float PI = 3.14159265358979;
    vec3 s = luxToSolid(o.axis, w);
    float a = o.halfAxes.x;
    float b = o.halfAxes.y;
    float c = o.halfAxes.z;
    int endBit = s.z < 0.0 ? 1 : 2;
    float ends = (o.faces & endBit) != 0 ? abs(s.z) : 0.0;
    bool sides = (o.faces & 4) != 0;
    if (o.kind == 0) {
        float area = 4.0 * a * b * ends;
        if (sides) {
            area += 4.0 * b * c * abs(s.x) + 4.0 * a * c * abs(s.y);
        }
        return area;
    }
    if (o.kind == 1) {
        float area = PI * a * b * ends;
        if (sides) {
            area += 4.0 * c * sqrt(a * a * s.y * s.y + b * b * s.x * s.x);
        }
        return area;
    }
    if (!sides) {
        return 0.0;
    }
    float x = b * c * s.x;
    float y = a * c * s.y;
    float z = a * b * s.z;
    return PI * sqrt(x * x + y * y + z * z);
}

// opening::facing: a flat part that the receiver lies in front of (the axis of its normal,
// its plane's coordinate, its side, its half-extents); false for a curved part or a receiver on
// or behind its plane.
bool luxFacing(LuxOpening o, int part, vec3 receiver, out int axis, out float plane,
               out float side, out vec2 ext) {
    bool ellipse;
    plane = 0.0;
    if (!luxFlatPart(o, part, axis, side, ext, ellipse)) {
        return false;
    }
    vec3 r = luxToSolid(o.axis, receiver);
    plane = side * luxPick(o.halfAxes, axis);
    return side * (luxPick(r, axis) - plane) > 0.0;
}

// opening::closed_form: a closed form gIn whose terms sum to `sum` with magnitudes adding to
// `magnitude`, and the unit direction toward the receiver from the part's centre (`centre`:
// the centre less the receiver); false where the terms cancel past
// opening::CONTROL_MAX_CANCELLATION or a value is not finite and positive.
bool luxClosedForm(float sum, float magnitude, float gIn, vec3 centre, out float g,
                   out vec3 toward) {
    g = gIn;
    float d = sqrt(luxDot(centre, centre));
    toward = vec3(-centre.x / d, -centre.y / d, -centre.z / d);
    return magnitude <= LUX_CONTROL_MAX_CANCELLATION * abs(sum) && g > 0.0 && luxFinite(g) &&
           d > 0.0 && luxFinite(d);
}

// opening::rectangle_control: flat part `part` of a box's geometric integral
// G = ∫ cos θx · cos θp / r² dA toward a receiver with unit normal n (both photometric), by
// Lambert's formula over its four corners, and the unit direction from its centre toward the
// receiver; false for a part that the receiver does not see wholly, or whose formula's terms
// cancel too much. The face (axis, plane, ext) is luxFacing's.
bool luxRectangleControl(LuxOpening o, int axis, float plane, vec2 ext, vec3 receiver, vec3 n,
                         out float g, out vec3 toward) {
    g = 0.0;
    toward = vec3(0.0);
    vec3 v0 = luxToPhotometric(o.axis, luxPlace(axis, plane, vec2(-ext.x, -ext.y))) - receiver;
    vec3 v1 = luxToPhotometric(o.axis, luxPlace(axis, plane, vec2(ext.x, -ext.y))) - receiver;
    vec3 v2 = luxToPhotometric(o.axis, luxPlace(axis, plane, vec2(ext.x, ext.y))) - receiver;
    vec3 v3 = luxToPhotometric(o.axis, luxPlace(axis, plane, vec2(-ext.x, ext.y))) - receiver;
    if (!(luxDot(n, v0) > 0.0 && luxDot(n, v1) > 0.0 && luxDot(n, v2) > 0.0 &&
          luxDot(n, v3) > 0.0)) {
        return false;
    }
    float sum = 0.0;
    float magnitude = 0.0;
    bool ok = true;
    for (int e = 0; e < 4; ++e) {
        vec3 a = e == 0 ? v0 : (e == 1 ? v1 : (e == 2 ? v2 : v3));
        vec3 b = e == 0 ? v1 : (e == 1 ? v2 : (e == 2 ? v3 : v0));
        vec3 c = vec3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
        float len = sqrt(luxDot(c, c));
        ok = ok && len > 0.0;
        float term = luxAtan2(len, luxDot(a, b)) * (luxDot(n, c) / len);
        sum += term;
        magnitude += abs(term);
    }
    vec3 centre = luxToPhotometric(o.axis, luxPlace(axis, plane, vec2(0.0))) - receiver;
    return luxClosedForm(sum, magnitude, 0.5 * abs(sum), centre, g, toward) && ok;
}

// opening::disk_control: a cylinder's circular end's geometric integral toward a receiver
// with unit normal n, in closed form (Lambert's formula on its rim), and the unit direction from
// its centre toward the receiver; false for a part that the receiver does not see wholly, or
// whose formula's terms cancel too much. The end (axis, plane, side, its radius) is luxFacing's.
bool luxDiskControl(LuxOpening o, int axis, float plane, float side, float radius,
                    vec3 receiver, vec3 n, out float g, out vec3 toward) {
    g = 0.0;
    toward = vec3(0.0);
    vec3 d = luxToPhotometric(o.axis, luxPlace(axis, plane, vec2(0.0))) - receiver;
    vec3 f = luxToPhotometric(o.axis, luxPlace(axis, side, vec2(0.0)));
    float nf = luxDot(n, f);
    float nd = luxDot(n, d);
    float df = luxDot(d, f);
    float dd = luxDot(d, d);
    if (!(nd - radius * sqrt(max(1.0 - nf * nf, 0.0)) > 0.0)) {
        return false;
    }
    float r2 = radius * radius;
    float q = dd - r2;
    float s = sqrt(q * q + 4.0 * r2 * (df * df));
    float denominator = dd + r2 + s;
    float inner = nf * dd - nd * df;
    float sum = nf - 2.0 * inner / denominator;
    float magnitude = abs(nf) + 2.0 * (abs(nf) * dd + abs(nd * df)) / denominator;
    return luxClosedForm(sum, magnitude, LUX_PI * r2 / s * abs(sum), d, g, toward);
}

// opening::part_control: a box's face's or a cylinder's circular end's closed form; false for
// any other part and where the receiver is not in front of it.
bool luxPartControl(LuxOpening o, int part, vec3 receiver, vec3 n, out float g,
                    out vec3 toward) {
    g = 0.0;
    toward = vec3(0.0);
    int axis;
    float plane;
    float side;
    vec2 ext;
    if (!luxFacing(o, part, receiver, axis, plane, side, ext)) {
        return false;
    }
    if (o.kind == 0) {
        return luxRectangleControl(o, axis, plane, ext, receiver, n, g, toward);
    }
    return o.kind == 1 && ext.x == ext.y &&
           luxDiskControl(o, axis, plane, side, ext.x, receiver, n, g, toward);
}

// opening::shift and opening::lattice.
uvec2 luxOpeningShift(uint texel, uint lamp, uint seed) {
    uint h0 = luxHash(texel, lamp, LUX_OPENING_PASS, seed);
    return uvec2(h0, luxPcg(h0));
}

vec2 luxOpeningLattice(uint k, uint n, uvec2 shift) {
    float a = (float(k) + 0.5) / float(n) + luxUnit(shift.x);
    return vec2(a - floor(a), luxUnit(k * LUX_PHI + shift.y));
}
