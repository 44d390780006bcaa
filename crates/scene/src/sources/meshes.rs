//! Procedural meshes with clean light-map UVs: the room, box, plane, sphere and the furniture
//! (chair, sofa) of the built-in scenes.
//!
//! Every generator returns a [`Mesh`] in object space (metres, +Y up) whose light-map UVs are
//! unique: the surface is cut into *charts* (a box face, a strip of four box sides, a
//! cube-sphere face), each chart is laid out flat at metric scale (1 chart unit = 1 m of
//! surface, up to the small distortion of curved charts), the charts are packed with a shelf
//! packer into a rectangle with `padding` metres between any two charts (and `padding / 2` to
//! the rectangle's border), and the rectangle is mapped onto [0, 1]² (u and v scaled
//! separately, so one metre of surface spans the same number of texels along u and v once the
//! layout sizes the rectangle). Pass `padding` = (padding in texels) / (texels per metre); the
//! built-in scenes use [`crate::chart_padding_texels`] texels.
//!
//! Shared positions along chart seams are computed from the same inputs in the same order, so
//! closed meshes are watertight bit for bit (a ray cannot leak through a seam).

use glam::{DVec2, DVec3, Vec2Swizzles, dvec3};

use crate::{Mesh, normalize_f64};

/// Per-part albedos of the room (linear RGB), applied as vertex colours.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoomAlbedo {
    /// Floor (y = 0).
    pub floor: [f32; 3],
    /// The four walls.
    pub walls: [f32; 3],
    /// Ceiling (y = height).
    pub ceiling: [f32; 3],
}

impl RoomAlbedo {
    /// The same albedo everywhere.
    pub fn uniform(rgb: [f32; 3]) -> RoomAlbedo {
        RoomAlbedo {
            floor: rgb,
            walls: rgb,
            ceiling: rgb,
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Vertex {
    p: DVec3,
    n: DVec3,
    chart_xy: DVec2,
    color: [f32; 3],
}

/// Accumulates charts of vertices and triangles, then packs the charts into light-map UVs.
#[derive(Debug, Default)]
struct Builder {
    verts: Vec<Vertex>,
    tris: Vec<[u32; 3]>,
    /// Start vertex of each chart (charts are contiguous vertex ranges).
    chart_starts: Vec<usize>,
    /// Colour of the vertices emitted next (`None`: white).
    color: Option<[f32; 3]>,
    /// Whether any vertex got a colour (then the mesh carries vertex colours).
    colored: bool,
}

impl Builder {
    fn begin_chart(&mut self) {
        self.chart_starts.push(self.verts.len());
    }

    fn vertex(&mut self, p: DVec3, n: DVec3, chart_xy: DVec2) -> u32 {
        self.colored |= self.color.is_some();
        self.verts.push(Vertex {
            p,
            n,
            chart_xy,
            color: self.color.unwrap_or([1.0; 3]),
        });
        (self.verts.len() - 1) as u32
    }

    /// Two triangles over the quad `a b c d` (counter-clockwise seen from the front).
    fn quad(&mut self, [a, b, c, d]: [u32; 4]) {
        self.tris.push([a, b, c]);
        self.tris.push([a, c, d]);
    }

    /// A flat rectangle as one chart: corners counter-clockwise seen from the front.
    fn rect_chart(&mut self, corners: [DVec3; 4]) {
        let (side1, side2) = (corners[1] - corners[0], corners[3] - corners[0]);
        let n = normalize_f64(side1.cross(side2)).unwrap_or(DVec3::Y);
        self.begin_chart();
        let e1 = normalize_f64(side1).unwrap_or(DVec3::X);
        let e2 = normalize_f64(side2).unwrap_or(DVec3::Z);
        let v = corners.map(|p| {
            let d = p - corners[0];
            self.vertex(p, n, DVec2::new(d.dot(e1), d.dot(e2)))
        });
        self.quad(v);
    }

    /// Packs the charts and emits the mesh.
    fn finish(self, padding: f64) -> Mesh {
        let padding = if padding.is_finite() && padding > 0.0 {
            padding
        } else {
            0.0
        };
        let mut ends = self.chart_starts.clone();
        ends.remove(0);
        ends.push(self.verts.len());
        // Bounding box of each chart; rotate portrait charts to landscape for the shelves.
        let charts: Vec<ChartBox> = self
            .chart_starts
            .iter()
            .zip(&ends)
            .map(|(&s, &e)| {
                // f64::min/max per component: glam's min/max compare, which treats NaN
                // differently.
                let (lo, hi) = self.verts[s..e].iter().fold(
                    (DVec2::INFINITY, DVec2::NEG_INFINITY),
                    |(lo, hi), v| {
                        let p = v.chart_xy;
                        (
                            DVec2::new(lo.x.min(p.x), lo.y.min(p.y)),
                            DVec2::new(hi.x.max(p.x), hi.y.max(p.y)),
                        )
                    },
                );
                let size = hi - lo;
                ChartBox {
                    range: s..e,
                    lo,
                    size,
                    rotated: size.y > size.x,
                }
            })
            .collect();
        let cells: Vec<DVec2> = charts
            .iter()
            .map(|c| if c.rotated { c.size.yx() } else { c.size } + padding)
            .collect();
        let (origins, total) = pack(&cells);
        let mut uvs = vec![[0.0f32; 2]; self.verts.len()];
        for (c, &o) in charts.iter().zip(&origins) {
            for i in c.range.clone() {
                let local = self.verts[i].chart_xy - c.lo;
                let local = if c.rotated { local.yx() } else { local };
                let uv = (o + padding / 2.0 + local) / total;
                uvs[i] = [uv.x.clamp(0.0, 1.0) as f32, uv.y.clamp(0.0, 1.0) as f32];
            }
        }
        let colors = self
            .colored
            .then(|| self.verts.iter().map(|v| v.color).collect());
        Mesh {
            positions: self
                .verts
                .iter()
                .map(|v| v.p.as_vec3().to_array())
                .collect(),
            normals: self
                .verts
                .iter()
                .map(|v| v.n.as_vec3().to_array())
                .collect(),
            lightmap_uvs: uvs,
            material_uvs: None,
            colors,
            indices: self.tris,
        }
    }
}

struct ChartBox {
    range: std::ops::Range<usize>,
    lo: DVec2,
    size: DVec2,
    rotated: bool,
}

/// Shelf packing of `cells` (width, height): returns each cell's origin and the total size.
/// Tries several shelf widths and keeps the smallest total area whose aspect ratio is at most
/// 2:1 (or the smallest area if none is).
/// A candidate packing: total area, whether its aspect is within 2:1, origins, total size.
type Packing = (f64, bool, Vec<DVec2>, DVec2);

fn pack(cells: &[DVec2]) -> (Vec<DVec2>, DVec2) {
    let mut order: Vec<usize> = (0..cells.len()).collect();
    order.sort_by(|&a, &b| {
        cells[b]
            .y
            .total_cmp(&cells[a].y)
            .then(cells[b].x.total_cmp(&cells[a].x))
            .then(a.cmp(&b))
    });
    let area: f64 = cells.iter().map(|c| c.x * c.y).sum();
    let widest = cells.iter().map(|c| c.x).fold(0.0f64, f64::max);
    let mut best: Option<Packing> = None;
    for step in 0..=24 {
        let width = (area.sqrt() * (0.8 + 0.05 * f64::from(step))).max(widest);
        let (origins, total) = shelves(cells, &order, width);
        let a = total.x * total.y;
        let square_enough = total.x <= 2.0 * total.y && total.y <= 2.0 * total.x;
        let better = match &best {
            None => true,
            Some((ba, bs, _, _)) => (square_enough && !bs) || (square_enough == *bs && a < *ba),
        };
        if better {
            best = Some((a, square_enough, origins, total));
        }
    }
    match best {
        Some((_, _, origins, total)) if total.x > 0.0 && total.y > 0.0 => (origins, total),
        Some((_, _, origins, _)) => (origins, DVec2::ONE),
        None => (Vec::new(), DVec2::ONE),
    }
}

fn shelves(cells: &[DVec2], order: &[usize], width: f64) -> (Vec<DVec2>, DVec2) {
    let mut origins = vec![DVec2::ZERO; cells.len()];
    let (mut x, mut y, mut shelf_h, mut total_w) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for &i in order {
        let DVec2 { x: w, y: h } = cells[i];
        if x > 0.0 && x + w > width {
            y += shelf_h;
            x = 0.0;
            shelf_h = 0.0;
        }
        origins[i] = DVec2::new(x, y);
        x += w;
        shelf_h = shelf_h.max(h);
        total_w = total_w.max(x);
    }
    (origins, DVec2::new(total_w, y + shelf_h))
}

/// Emits the six faces of a cube-topology grid surface, one chart per face. `tables[a]` are
/// the grid coordinates along axis `a` (ascending, at least two); `map` takes a point of the
/// grid box's surface (world axis order) to a surface position and outward unit normal.
/// Faces are counter-clockwise seen from outside, or from inside (normals flipped) when
/// `inward`. `color(axis, sign)` sets the vertex colour per face.
fn cube_grid(
    b: &mut Builder,
    tables: [&[f64]; 3],
    inward: bool,
    map: &dyn Fn(DVec3) -> (DVec3, DVec3),
    color: &dyn Fn(usize, bool) -> Option<[f32; 3]>,
) {
    // (axis, positive side, u axis, v axis) with u × v = outward normal.
    const FACES: [(usize, bool, usize, usize); 6] = [
        (0, true, 1, 2),
        (0, false, 2, 1),
        (1, true, 2, 0),
        (1, false, 0, 2),
        (2, true, 0, 1),
        (2, false, 1, 0),
    ];
    for (axis, positive, ua, va) in FACES {
        b.color = color(axis, positive);
        let fixed = if positive {
            tables[axis][tables[axis].len() - 1]
        } else {
            tables[axis][0]
        };
        let (tu, tv) = (tables[ua], tables[va]);
        let grid = |i: usize, j: usize| {
            let mut q = DVec3::ZERO;
            q[axis] = fixed;
            q[ua] = tu[i];
            q[va] = tv[j];
            map(q)
        };
        // Metric chart coordinates: arc length along the middle row and column.
        let (jm, im) = (tv.len() / 2, tu.len() / 2);
        let mut su = vec![0.0; tu.len()];
        for i in 1..tu.len() {
            su[i] = su[i - 1] + grid(i, jm).0.distance(grid(i - 1, jm).0);
        }
        let mut sv = vec![0.0; tv.len()];
        for j in 1..tv.len() {
            sv[j] = sv[j - 1] + grid(im, j).0.distance(grid(im, j - 1).0);
        }
        b.begin_chart();
        let base = b.verts.len() as u32;
        for (j, &cv) in sv.iter().enumerate() {
            for (i, &cu) in su.iter().enumerate() {
                let (p, n) = grid(i, j);
                let n = if inward { -n } else { n };
                b.vertex(p, n, DVec2::new(cu, cv));
            }
        }
        let row = tu.len() as u32;
        for j in 0..tv.len() as u32 - 1 {
            for i in 0..row - 1 {
                let a = base + j * row + i;
                let q = [a, a + 1, a + row + 1, a + row];
                if inward {
                    b.quad([q[0], q[3], q[2], q[1]]);
                } else {
                    b.quad(q);
                }
            }
        }
    }
    b.color = None;
}

/// The inward-facing room: floor at y = 0 centred on the origin, `size` = [x, height, z]
/// metres, normals pointing into the room, one chart per face (12 triangles), vertex colours
/// from `albedo`.
pub fn room(size: [f32; 3], albedo: RoomAlbedo, padding: f32) -> Mesh {
    let h = size.map(|s| f64::from(s.abs()) / 2.0);
    let mut b = Builder::default();
    let tables: [Vec<f64>; 3] = [vec![-h[0], h[0]], vec![0.0, 2.0 * h[1]], vec![-h[2], h[2]]];
    // Normals are set per face afterwards (edge points belong to several faces).
    let id = |q: DVec3| (q, DVec3::ZERO);
    cube_grid(
        &mut b,
        [&tables[0], &tables[1], &tables[2]],
        true,
        &id,
        &|axis, positive| {
            Some(match (axis, positive) {
                (1, false) => albedo.floor,
                (1, true) => albedo.ceiling,
                _ => albedo.walls,
            })
        },
    );
    set_flat_normals(&mut b);
    b.finish(f64::from(padding))
}

/// Replaces every vertex normal by its triangle's geometric normal (all triangles of a flat
/// chart share vertices only within one plane).
fn set_flat_normals(b: &mut Builder) {
    for t in &b.tris {
        let [a, c, d] = t.map(|i| b.verts[i as usize].p);
        if let Some(n) = normalize_f64((c - a).cross(d - a)) {
            for &i in t {
                b.verts[i as usize].n = n;
            }
        }
    }
}

/// An axis-aligned box with its base centred on the origin (y from 0 to `size[1]`), outward
/// normals (or inward when `inward`), 12 triangles. Charts: the four sides around the
/// longest axis as one strip, and the two end caps.
pub fn cuboid(size: [f32; 3], inward: bool, padding: f32) -> Mesh {
    let s = size.map(|v| f64::from(v.abs()));
    let mut b = Builder::default();
    box_part(
        &mut b,
        dvec3(-s[0] / 2.0, 0.0, -s[2] / 2.0),
        dvec3(s[0] / 2.0, s[1], s[2] / 2.0),
        inward,
    );
    b.finish(f64::from(padding))
}

/// One box between corners `lo` and `hi`: a strip chart of the four sides around the longest
/// axis plus two cap charts.
fn box_part(b: &mut Builder, lo: DVec3, hi: DVec3, inward: bool) {
    let ext = hi - lo;
    let a = if ext[0] >= ext[1] && ext[0] >= ext[2] {
        0
    } else if ext[1] >= ext[2] {
        1
    } else {
        2
    };
    let (bx, cx) = ((a + 1) % 3, (a + 2) % 3);
    let point = |av: f64, bv: f64, cv: f64| {
        let mut p = DVec3::ZERO;
        p[a] = av;
        p[bx] = bv;
        p[cx] = cv;
        p
    };
    let axis_n = |k: usize, sign: f64| {
        let mut n = DVec3::ZERO;
        n[k] = if inward { -sign } else { sign };
        n
    };
    // Strip around axis a: faces +b, +c, −b, −c, walking counter-clockwise about +a.
    // Each side: (normal, start (b, c), end (b, c)).
    let sides = [
        (axis_n(bx, 1.0), [hi[bx], lo[cx]], [hi[bx], hi[cx]]),
        (axis_n(cx, 1.0), [hi[bx], hi[cx]], [lo[bx], hi[cx]]),
        (axis_n(bx, -1.0), [lo[bx], hi[cx]], [lo[bx], lo[cx]]),
        (axis_n(cx, -1.0), [lo[bx], lo[cx]], [hi[bx], lo[cx]]),
    ]
    .map(|(n, s, e)| (n, DVec2::from(s), DVec2::from(e)));
    b.begin_chart();
    let mut u = 0.0;
    for (n, s, e) in sides {
        let w = s.distance(e);
        let q = [
            b.vertex(point(lo[a], s.x, s.y), n, DVec2::new(u, 0.0)),
            b.vertex(point(lo[a], e.x, e.y), n, DVec2::new(u + w, 0.0)),
            b.vertex(point(hi[a], e.x, e.y), n, DVec2::new(u + w, ext[a])),
            b.vertex(point(hi[a], s.x, s.y), n, DVec2::new(u, ext[a])),
        ];
        if inward {
            b.quad([q[0], q[3], q[2], q[1]]);
        } else {
            b.quad(q);
        }
        u += w;
    }
    // Caps: +a with (u, v) = (b, c) since b × c = a; −a with (c, b).
    for (av, first, second) in [(hi[a], bx, cx), (lo[a], cx, bx)] {
        let corner = |s1: f64, s2: f64| {
            let mut p = DVec3::ZERO;
            p[a] = av;
            p[first] = s1;
            p[second] = s2;
            p
        };
        let c = [
            corner(lo[first], lo[second]),
            corner(hi[first], lo[second]),
            corner(hi[first], hi[second]),
            corner(lo[first], hi[second]),
        ];
        if inward {
            b.rect_chart([c[0], c[3], c[2], c[1]]);
        } else {
            b.rect_chart(c);
        }
    }
}

/// A horizontal plane centred on the origin, `size` = [x, z] metres, normal +Y, 2 triangles.
pub fn plane(size: [f32; 2], padding: f32) -> Mesh {
    let (hx, hz) = (
        f64::from(size[0].abs()) / 2.0,
        f64::from(size[1].abs()) / 2.0,
    );
    let mut b = Builder::default();
    b.rect_chart([
        dvec3(-hx, 0.0, -hz),
        dvec3(-hx, 0.0, hz),
        dvec3(hx, 0.0, hz),
        dvec3(hx, 0.0, -hz),
    ]);
    b.finish(f64::from(padding))
}

/// Default number of grid segments per cube-face edge of [`sphere`]: 6 · 2 · 32² = 12,288
/// triangles, facets within 0.15 % of the radius.
pub const SPHERE_SEGMENTS: u32 = 32;

/// A cube-sphere of `radius` centred on the origin: each of the six cube faces is an
/// equal-angle grid of `segments`² quads (one chart per face), vertices on the sphere with
/// radial normals, outward or `inward` (normals toward the centre, counter-clockwise seen
/// from inside). `segments` is clamped to 1..=256.
pub fn sphere(radius: f32, segments: u32, inward: bool, padding: f32) -> Mesh {
    let n = segments.clamp(1, 256) as usize;
    let r = f64::from(radius.abs());
    // tan of equally spaced angles in [−45°, 45°], exactly antisymmetric, ±1 at the ends.
    let mut t = vec![0.0f64; n + 1];
    for i in 0..=n / 2 {
        let angle =
            -std::f64::consts::FRAC_PI_4 + std::f64::consts::FRAC_PI_2 * i as f64 / n as f64;
        t[i] = if i == 0 { -1.0 } else { angle.tan() };
        t[n - i] = -t[i];
    }
    if n.is_multiple_of(2) {
        t[n / 2] = 0.0;
    }
    let map = |q: DVec3| {
        let d = normalize_f64(q).unwrap_or(DVec3::Y);
        (d * r, d)
    };
    let mut b = Builder::default();
    cube_grid(&mut b, [&t, &t, &t], inward, &map, &|_, _| None);
    b.finish(f64::from(padding))
}

/// Triangles of [`chair`]: 20 boxes of 12 (with the room's 12, the paper's 252 of `chairs_01`).
pub const CHAIR_TRIANGLES: usize = 240;

/// A dining chair built from 20 boxes (240 triangles): four legs, seat, four aprons, four
/// stretchers, two back posts, a top rail, a lower back rail and three slats. Feet on y = 0,
/// seat centred on the origin in x and z, seat top at 0.46 m, back rest toward −Z (a person
/// sitting on it faces +Z), overall 0.45 × 0.92 × 0.44 m. Parts touch without overlapping.
pub fn chair(padding: f32) -> Mesh {
    let mut b = Builder::default();
    let mut part = |c: [f64; 3], e: [f64; 3], y0: f64, y1: f64| {
        box_part(
            &mut b,
            dvec3(c[0] - e[0] / 2.0, y0, c[2] - e[2] / 2.0),
            dvec3(c[0] + e[0] / 2.0, y1, c[2] + e[2] / 2.0),
            false,
        );
    };
    let leg = 0.035;
    let (lx, lz) = (0.19, 0.18);
    let inner_x = 2.0 * lx - leg; // between the legs' inner faces, along x
    let inner_z = 2.0 * lz - leg;
    // Legs.
    for (x, z) in [(-lx, lz), (lx, lz), (-lx, -lz), (lx, -lz)] {
        part([x, 0.0, z], [leg, 0.0, leg], 0.0, 0.43);
    }
    // Seat.
    part([0.0, 0.0, 0.005], [0.45, 0.0, 0.44], 0.43, 0.46);
    // Aprons: front, back, left, right.
    part([0.0, 0.0, lz], [inner_x, 0.0, 0.02], 0.37, 0.43);
    part([0.0, 0.0, -lz], [inner_x, 0.0, 0.02], 0.37, 0.43);
    part([-lx, 0.0, 0.0], [0.02, 0.0, inner_z], 0.37, 0.43);
    part([lx, 0.0, 0.0], [0.02, 0.0, inner_z], 0.37, 0.43);
    // Stretchers: left, right, front, and the middle one between left and right.
    part([-lx, 0.0, 0.0], [0.02, 0.0, inner_z], 0.12, 0.15);
    part([lx, 0.0, 0.0], [0.02, 0.0, inner_z], 0.12, 0.15);
    part([0.0, 0.0, lz], [inner_x, 0.0, 0.02], 0.12, 0.15);
    part([0.0, 0.0, 0.0], [2.0 * lx - 0.02, 0.0, 0.02], 0.12, 0.15);
    // Back posts standing on the seat.
    part([-lx, 0.0, -lz], [leg, 0.0, leg], 0.46, 0.92);
    part([lx, 0.0, -lz], [leg, 0.0, leg], 0.46, 0.92);
    // Top rail, lower back rail, three slats.
    part([0.0, 0.0, -lz], [inner_x, 0.0, 0.02], 0.80, 0.90);
    part([0.0, 0.0, -lz], [inner_x, 0.0, 0.02], 0.52, 0.56);
    for x in [-0.09, 0.0, 0.09] {
        part([x, 0.0, -lz], [0.04, 0.0, 0.015], 0.56, 0.80);
    }
    b.finish(f64::from(padding))
}

/// Grid coordinates along one axis of a rounded box of half-extent `h` and corner radius
/// `r`: `bands` segments over each 45° half of a rounded edge and `interior` segments across
/// the flat middle; exactly antisymmetric.
fn rounded_table(h: f64, r: f64, bands: usize, interior: usize) -> Vec<f64> {
    let flat = h - r;
    let mut half = Vec::new();
    for i in 0..bands {
        let phi = std::f64::consts::FRAC_PI_4 * (bands - i) as f64 / bands as f64;
        half.push(if i == 0 { -h } else { -flat - r * phi.tan() });
    }
    let mut t = half.clone();
    for i in 0..=interior {
        let x = -flat + 2.0 * flat * i as f64 / interior as f64;
        t.push(x);
    }
    t.extend(half.iter().rev().map(|x| -x));
    // Exact antisymmetry of the flat part.
    let n = t.len();
    for i in 0..n / 2 {
        t[n - 1 - i] = -t[i];
    }
    if n % 2 == 1 {
        t[n / 2] = 0.0;
    }
    t
}

/// One rounded box between `lo` and `hi` (corner radius `r`) with `bands` segments per 45° of
/// rounding and `interior[axis]` segments across each flat part; six charts.
fn rounded_part(b: &mut Builder, lo: DVec3, hi: DVec3, r: f64, bands: usize, interior: [usize; 3]) {
    let c = (lo + hi) / 2.0;
    let h = (hi - lo) / 2.0;
    let r = r.min(h.x).min(h.y).min(h.z);
    let tables: [Vec<f64>; 3] = std::array::from_fn(|k| rounded_table(h[k], r, bands, interior[k]));
    let flat = h - r;
    let map = |q: DVec3| {
        // f64::clamp per component (glam's clamp compares, which treats NaN differently).
        let inner = DVec3::from_array(std::array::from_fn(|k| q[k].clamp(-flat[k], flat[k])));
        match normalize_f64(q - inner) {
            Some(n) => (c + inner + r * n, n),
            None => (c + q, DVec3::Y),
        }
    };
    cube_grid(
        b,
        [&tables[0], &tables[1], &tables[2]],
        false,
        &map,
        &|_, _| None,
    );
}

/// Triangles of [`sofa`] (with the room's 12, the paper's 2,036 of `sofa_01`).
pub const SOFA_TRIANGLES: usize = 2024;

/// A three-seat sofa of rounded boxes: plinth, back, two arms, three seat and three back
/// cushions, on four block feet (2,024 triangles). Feet on y = 0, centred on the origin in x
/// and z, back toward −Z (seated people face +Z), overall 2.0 × 0.85 × 0.9 m.
pub fn sofa(padding: f32) -> Mesh {
    let mut b = Builder::default();
    // Feet.
    for (x, z) in [(-0.92, 0.36), (0.92, 0.36), (-0.92, -0.38), (0.92, -0.38)] {
        box_part(
            &mut b,
            dvec3(x - 0.03, 0.0, z - 0.03),
            dvec3(x + 0.03, 0.08, z + 0.03),
            false,
        );
    }
    // Plinth and back frame.
    rounded_part(
        &mut b,
        dvec3(-0.85, 0.08, -0.30),
        dvec3(0.85, 0.36, 0.42),
        0.02,
        1,
        [3, 1, 2],
    );
    rounded_part(
        &mut b,
        dvec3(-0.85, 0.08, -0.45),
        dvec3(0.85, 0.85, -0.30),
        0.03,
        1,
        [4, 1, 1],
    );
    // Arms.
    for x in [-1.0, 0.85] {
        rounded_part(
            &mut b,
            dvec3(x, 0.08, -0.45),
            dvec3(x + 0.15, 0.62, 0.45),
            0.04,
            1,
            [1, 1, 2],
        );
    }
    // Seat cushions (finely rounded) and back cushions.
    let width = 1.7 / 3.0;
    for i in 0..3 {
        let x0 = -0.85 + width * f64::from(i);
        let x1 = x0 + width;
        rounded_part(
            &mut b,
            dvec3(x0, 0.36, -0.30),
            dvec3(x1, 0.50, 0.44),
            0.05,
            2,
            [2, 1, 1],
        );
        rounded_part(
            &mut b,
            dvec3(x0, 0.50, -0.30),
            dvec3(x1, 0.80, -0.14),
            0.05,
            1,
            [1, 1, 1],
        );
    }
    b.finish(f64::from(padding))
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use glam::Vec3;

    use super::*;

    const D: f32 = 64.0;
    const PAD: f32 = 4.0 / D;

    fn all_meshes() -> Vec<(&'static str, Mesh, bool)> {
        // (name, mesh, inward)
        vec![
            (
                "room",
                room([5.0, 2.6, 4.0], RoomAlbedo::uniform([0.5; 3]), PAD),
                true,
            ),
            ("box", cuboid([1.0, 0.5, 2.0], false, PAD), false),
            ("inward box", cuboid([1.0, 0.5, 2.0], true, PAD), true),
            ("sphere", sphere(1.0, 8, false, PAD), false),
            ("inward sphere", sphere(1.0, 8, true, PAD), true),
            ("chair", chair(4.0 / (D * 2.8)), false),
            ("sofa", sofa(4.0 / (D * 1.9)), false),
        ]
    }

    /// The positions of a triangle's corners, in double precision.
    fn corners(m: &Mesh, t: &[u32; 3]) -> [DVec3; 3] {
        t.map(|i| Vec3::from(m.positions[i as usize]).as_dvec3())
    }

    fn signed_volume(m: &Mesh) -> f64 {
        m.indices
            .iter()
            .map(|t| {
                let [a, b, c] = corners(m, t);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn triangle_counts() {
        assert_eq!(
            room([5.0, 2.6, 4.0], RoomAlbedo::uniform([0.5; 3]), PAD).triangle_count(),
            12
        );
        assert_eq!(cuboid([1.0; 3], false, PAD).triangle_count(), 12);
        assert_eq!(plane([2.0, 1.0], PAD).triangle_count(), 2);
        assert_eq!(sphere(1.0, 8, true, PAD).triangle_count(), 6 * 2 * 64);
        assert_eq!(
            sphere(1.0, SPHERE_SEGMENTS, true, PAD).triangle_count(),
            12_288
        );
        assert_eq!(chair(PAD).triangle_count(), CHAIR_TRIANGLES);
        assert_eq!(sofa(PAD).triangle_count(), SOFA_TRIANGLES);
        assert_eq!(CHAIR_TRIANGLES, 240);
        assert_eq!(SOFA_TRIANGLES, 2024);
    }

    #[test]
    fn meshes_are_valid_and_uvs_in_unit_square() {
        for (name, m, _) in all_meshes() {
            m.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
            for uv in &m.lightmap_uvs {
                assert!(
                    uv.iter().all(|c| (0.0..=1.0).contains(c)),
                    "{name}: uv {uv:?}"
                );
            }
            for n in &m.normals {
                let l = n.iter().map(|c| c * c).sum::<f32>().sqrt();
                assert!((l - 1.0).abs() < 1e-5, "{name}: normal {n:?}");
            }
        }
    }

    /// Every directed edge (by exact position) has a reversed twin: closed, consistently
    /// oriented, and seams match bit for bit.
    #[test]
    fn closed_meshes_are_watertight() {
        for (name, m, _) in all_meshes() {
            let mut edges: HashMap<([u32; 3], [u32; 3]), i32> = HashMap::new();
            let key = |i: u32| m.positions[i as usize].map(f32::to_bits);
            for t in &m.indices {
                for k in 0..3 {
                    let (a, b) = (key(t[k]), key(t[(k + 1) % 3]));
                    *edges.entry((a, b)).or_default() += 1;
                    *edges.entry((b, a)).or_default() -= 1;
                }
            }
            let open = edges.values().filter(|&&v| v != 0).count();
            assert_eq!(open, 0, "{name}: {open} unmatched directed edges");
        }
    }

    #[test]
    fn orientation_and_volume() {
        for (name, m, inward) in all_meshes() {
            let v = signed_volume(&m);
            assert_eq!(v < 0.0, inward, "{name}: signed volume {v}");
            // Vertex normals agree with the winding.
            for t in &m.indices {
                let [a, b, c] = corners(&m, t);
                let g = normalize_f64((b - a).cross(c - a)).expect("non-degenerate");
                for &i in t {
                    let n = Vec3::from(m.normals[i as usize]).as_dvec3();
                    assert!(g.dot(n) > 0.7, "{name}: normal {n:?} against winding {g:?}");
                }
            }
        }
        let room_v = signed_volume(&room([5.0, 2.6, 4.0], RoomAlbedo::uniform([0.5; 3]), PAD));
        assert!((room_v + 5.0 * 2.6 * 4.0).abs() < 1e-3, "{room_v}");
        let box_v = signed_volume(&cuboid([1.0, 0.5, 2.0], false, PAD));
        assert!((box_v - 1.0).abs() < 1e-6, "{box_v}");
        let s = signed_volume(&sphere(1.0, SPHERE_SEGMENTS, false, PAD));
        let exact = 4.0 / 3.0 * std::f64::consts::PI;
        assert!((s / exact - 1.0).abs() < 0.005, "{s} vs {exact}");
    }

    #[test]
    fn sphere_vertices_on_sphere_and_facets_close() {
        let m = sphere(2.0, SPHERE_SEGMENTS, true, PAD);
        for (p, n) in m.positions.iter().zip(&m.normals) {
            let r = p.iter().map(|c| c * c).sum::<f32>().sqrt();
            assert!((r - 2.0).abs() < 1e-5, "{r}");
            // Inward: the normal points to the centre.
            let d: f32 = p.iter().zip(n).map(|(a, b)| a * b).sum();
            assert!(d < -1.99, "{d}");
        }
        // Facet centroids within 0.2 % of the radius: the closed-sphere test stays exact.
        for t in &m.indices {
            let [a, b, c] = corners(&m, t);
            let r = ((a + b + c) / 3.0).length();
            assert!(r > 2.0 * 0.998, "{r}");
        }
    }

    #[test]
    fn room_parts_have_their_albedo() {
        let a = RoomAlbedo {
            floor: [0.1; 3],
            walls: [0.2; 3],
            ceiling: [0.3; 3],
        };
        let m = room([4.0, 2.5, 3.0], a, PAD);
        let colors = m.colors.as_ref().expect("room has vertex colours");
        for t in &m.indices {
            let ys = t.map(|i| m.positions[i as usize][1]);
            let c = colors[t[0] as usize];
            if ys.iter().all(|&y| y == 0.0) {
                assert_eq!(c, a.floor);
            } else if ys.iter().all(|&y| y == 2.5) {
                assert_eq!(c, a.ceiling);
            } else {
                assert_eq!(c, a.walls);
            }
        }
    }

    /// Within the charts, no two triangles overlap: every point of a fine sample grid lies
    /// strictly inside at most one triangle.
    #[test]
    fn triangles_do_not_overlap_in_uv() {
        for (name, m, _) in all_meshes() {
            let n = 512usize;
            let mut hits = vec![0u8; n * n];
            for t in &m.indices {
                let p = t.map(|i| m.lightmap_uvs[i as usize].map(|c| f64::from(c) * n as f64));
                let area2 = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
                    - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
                let lo = [0, 1].map(|k| {
                    p.iter()
                        .map(|q| q[k])
                        .fold(f64::INFINITY, f64::min)
                        .floor()
                        .max(0.0) as usize
                });
                let hi = [0, 1]
                    .map(|k| (p.iter().map(|q| q[k]).fold(0.0, f64::max).ceil() as usize).min(n));
                for y in lo[1]..hi[1] {
                    for x in lo[0]..hi[0] {
                        let q = [x as f64 + 0.5, y as f64 + 0.5];
                        let e = |a: [f64; 2], b: [f64; 2]| {
                            ((b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0])) / area2
                        };
                        let l = [e(p[1], p[2]), e(p[2], p[0]), e(p[0], p[1])];
                        if l.iter().all(|&v| v > 1e-9) {
                            hits[y * n + x] += 1;
                        }
                    }
                }
            }
            let worst = hits.iter().max().copied().unwrap_or(0);
            assert!(
                worst <= 1,
                "{name}: a UV point lies inside {worst} triangles"
            );
        }
    }
}
