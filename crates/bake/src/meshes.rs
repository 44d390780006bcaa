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
//! built-in scenes use [`crate::builtin::CHART_PADDING_TEXELS`] texels.
//!
//! Shared positions along chart seams are computed from the same inputs in the same order, so
//! closed meshes are watertight bit for bit (a ray cannot leak through a seam).

use crate::scene::{Mesh, cross, dot, normalize, sub3 as sub};

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
    p: [f64; 3],
    n: [f64; 3],
    chart_xy: [f64; 2],
    color: [f32; 3],
}

/// Accumulates charts of vertices and triangles, then packs the charts into light-map UVs.
#[derive(Debug, Default)]
struct Builder {
    verts: Vec<Vertex>,
    tris: Vec<[u32; 3]>,
    /// Start vertex of each chart (charts are contiguous vertex ranges).
    chart_starts: Vec<usize>,
    color: Option<[f32; 3]>,
}

impl Builder {
    fn begin_chart(&mut self) {
        self.chart_starts.push(self.verts.len());
    }

    fn vertex(&mut self, p: [f64; 3], n: [f64; 3], chart_xy: [f64; 2]) -> u32 {
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
    fn rect_chart(&mut self, corners: [[f64; 3]; 4]) {
        let n = normalize(cross(
            sub(corners[1], corners[0]),
            sub(corners[3], corners[0]),
        ))
        .unwrap_or([0.0, 1.0, 0.0]);
        self.begin_chart();
        let e1 = normalize(sub(corners[1], corners[0])).unwrap_or([1.0, 0.0, 0.0]);
        let e2 = normalize(sub(corners[3], corners[0])).unwrap_or([0.0, 0.0, 1.0]);
        let v = corners.map(|p| {
            let d = sub(p, corners[0]);
            self.vertex(p, n, [dot(d, e1), dot(d, e2)])
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
                let mut lo = [f64::INFINITY; 2];
                let mut hi = [f64::NEG_INFINITY; 2];
                for v in &self.verts[s..e] {
                    for k in 0..2 {
                        lo[k] = lo[k].min(v.chart_xy[k]);
                        hi[k] = hi[k].max(v.chart_xy[k]);
                    }
                }
                let size = [hi[0] - lo[0], hi[1] - lo[1]];
                ChartBox {
                    range: s..e,
                    lo,
                    size,
                    rotated: size[1] > size[0],
                }
            })
            .collect();
        let cells: Vec<[f64; 2]> = charts
            .iter()
            .map(|c| {
                let [w, h] = if c.rotated {
                    [c.size[1], c.size[0]]
                } else {
                    c.size
                };
                [w + padding, h + padding]
            })
            .collect();
        let (origins, total) = pack(&cells);
        let mut uvs = vec![[0.0f32; 2]; self.verts.len()];
        for (c, o) in charts.iter().zip(&origins) {
            for i in c.range.clone() {
                let local = [
                    self.verts[i].chart_xy[0] - c.lo[0],
                    self.verts[i].chart_xy[1] - c.lo[1],
                ];
                let local = if c.rotated {
                    [local[1], local[0]]
                } else {
                    local
                };
                let u = (o[0] + padding / 2.0 + local[0]) / total[0];
                let v = (o[1] + padding / 2.0 + local[1]) / total[1];
                uvs[i] = [u.clamp(0.0, 1.0) as f32, v.clamp(0.0, 1.0) as f32];
            }
        }
        let colors = self
            .color
            .map(|_| self.verts.iter().map(|v| v.color).collect());
        Mesh {
            positions: self.verts.iter().map(|v| v.p.map(|c| c as f32)).collect(),
            normals: self.verts.iter().map(|v| v.n.map(|c| c as f32)).collect(),
            lightmap_uvs: uvs,
            material_uvs: None,
            colors,
            indices: self.tris,
        }
    }
}

struct ChartBox {
    range: std::ops::Range<usize>,
    lo: [f64; 2],
    size: [f64; 2],
    rotated: bool,
}

/// Shelf packing of `cells` (width, height): returns each cell's origin and the total size.
/// Tries several shelf widths and keeps the smallest total area whose aspect ratio is at most
/// 2:1 (or the smallest area if none is).
/// A candidate packing: total area, whether its aspect is within 2:1, origins, total size.
type Packing = (f64, bool, Vec<[f64; 2]>, [f64; 2]);

fn pack(cells: &[[f64; 2]]) -> (Vec<[f64; 2]>, [f64; 2]) {
    let mut order: Vec<usize> = (0..cells.len()).collect();
    order.sort_by(|&a, &b| {
        cells[b][1]
            .total_cmp(&cells[a][1])
            .then(cells[b][0].total_cmp(&cells[a][0]))
            .then(a.cmp(&b))
    });
    let area: f64 = cells.iter().map(|c| c[0] * c[1]).sum();
    let widest = cells.iter().map(|c| c[0]).fold(0.0f64, f64::max);
    let mut best: Option<Packing> = None;
    for step in 0..=24 {
        let width = (area.sqrt() * (0.8 + 0.05 * f64::from(step))).max(widest);
        let (origins, total) = shelves(cells, &order, width);
        let a = total[0] * total[1];
        let square_enough = total[0] <= 2.0 * total[1] && total[1] <= 2.0 * total[0];
        let better = match &best {
            None => true,
            Some((ba, bs, _, _)) => (square_enough && !bs) || (square_enough == *bs && a < *ba),
        };
        if better {
            best = Some((a, square_enough, origins, total));
        }
    }
    match best {
        Some((_, _, origins, total)) if total[0] > 0.0 && total[1] > 0.0 => (origins, total),
        Some((_, _, origins, _)) => (origins, [1.0, 1.0]),
        None => (Vec::new(), [1.0, 1.0]),
    }
}

fn shelves(cells: &[[f64; 2]], order: &[usize], width: f64) -> (Vec<[f64; 2]>, [f64; 2]) {
    let mut origins = vec![[0.0; 2]; cells.len()];
    let (mut x, mut y, mut shelf_h, mut total_w) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for &i in order {
        let [w, h] = cells[i];
        if x > 0.0 && x + w > width {
            y += shelf_h;
            x = 0.0;
            shelf_h = 0.0;
        }
        origins[i] = [x, y];
        x += w;
        shelf_h = shelf_h.max(h);
        total_w = total_w.max(x);
    }
    (origins, [total_w, y + shelf_h])
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = sub(a, b);
    dot(d, d).sqrt()
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
    map: &dyn Fn([f64; 3]) -> ([f64; 3], [f64; 3]),
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
            let mut q = [0.0; 3];
            q[axis] = fixed;
            q[ua] = tu[i];
            q[va] = tv[j];
            map(q)
        };
        // Metric chart coordinates: arc length along the middle row and column.
        let (jm, im) = (tv.len() / 2, tu.len() / 2);
        let mut su = vec![0.0; tu.len()];
        for i in 1..tu.len() {
            su[i] = su[i - 1] + dist(grid(i, jm).0, grid(i - 1, jm).0);
        }
        let mut sv = vec![0.0; tv.len()];
        for j in 1..tv.len() {
            sv[j] = sv[j - 1] + dist(grid(im, j).0, grid(im, j - 1).0);
        }
        b.begin_chart();
        let base = b.verts.len() as u32;
        for (j, &cv) in sv.iter().enumerate() {
            for (i, &cu) in su.iter().enumerate() {
                let (p, n) = grid(i, j);
                let n = if inward { n.map(|c| -c) } else { n };
                b.vertex(p, n, [cu, cv]);
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
    let id = |q: [f64; 3]| (q, [0.0; 3]);
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
        if let Some(n) = normalize(cross(sub(c, a), sub(d, a))) {
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
        [-s[0] / 2.0, 0.0, -s[2] / 2.0],
        [s[0] / 2.0, s[1], s[2] / 2.0],
        inward,
    );
    b.finish(f64::from(padding))
}

/// One box between corners `lo` and `hi`: a strip chart of the four sides around the longest
/// axis plus two cap charts.
fn box_part(b: &mut Builder, lo: [f64; 3], hi: [f64; 3], inward: bool) {
    let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let a = if ext[0] >= ext[1] && ext[0] >= ext[2] {
        0
    } else if ext[1] >= ext[2] {
        1
    } else {
        2
    };
    let (bx, cx) = ((a + 1) % 3, (a + 2) % 3);
    let point = |av: f64, bv: f64, cv: f64| {
        let mut p = [0.0; 3];
        p[a] = av;
        p[bx] = bv;
        p[cx] = cv;
        p
    };
    let axis_n = |k: usize, sign: f64| {
        let mut n = [0.0; 3];
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
    ];
    b.begin_chart();
    let mut u = 0.0;
    for (n, s, e) in sides {
        let w = ((e[0] - s[0]).powi(2) + (e[1] - s[1]).powi(2)).sqrt();
        let q = [
            b.vertex(point(lo[a], s[0], s[1]), n, [u, 0.0]),
            b.vertex(point(lo[a], e[0], e[1]), n, [u + w, 0.0]),
            b.vertex(point(hi[a], e[0], e[1]), n, [u + w, ext[a]]),
            b.vertex(point(hi[a], s[0], s[1]), n, [u, ext[a]]),
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
            let mut p = [0.0; 3];
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
        [-hx, 0.0, -hz],
        [-hx, 0.0, hz],
        [hx, 0.0, hz],
        [hx, 0.0, -hz],
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
    let map = |q: [f64; 3]| {
        let d = normalize(q).unwrap_or([0.0, 1.0, 0.0]);
        (d.map(|c| c * r), d)
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
            [c[0] - e[0] / 2.0, y0, c[2] - e[2] / 2.0],
            [c[0] + e[0] / 2.0, y1, c[2] + e[2] / 2.0],
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
fn rounded_part(
    b: &mut Builder,
    lo: [f64; 3],
    hi: [f64; 3],
    r: f64,
    bands: usize,
    interior: [usize; 3],
) {
    let c = std::array::from_fn::<f64, 3, _>(|k| (lo[k] + hi[k]) / 2.0);
    let h = std::array::from_fn::<f64, 3, _>(|k| (hi[k] - lo[k]) / 2.0);
    let r = r.min(h[0]).min(h[1]).min(h[2]);
    let tables: [Vec<f64>; 3] = std::array::from_fn(|k| rounded_table(h[k], r, bands, interior[k]));
    let map = |q: [f64; 3]| {
        let inner: [f64; 3] = std::array::from_fn(|k| q[k].clamp(-(h[k] - r), h[k] - r));
        let d = sub(q, inner);
        match normalize(d) {
            Some(n) => (std::array::from_fn(|k| c[k] + inner[k] + r * n[k]), n),
            None => (std::array::from_fn(|k| c[k] + q[k]), [0.0, 1.0, 0.0]),
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
            [x - 0.03, 0.0, z - 0.03],
            [x + 0.03, 0.08, z + 0.03],
            false,
        );
    }
    // Plinth and back frame.
    rounded_part(
        &mut b,
        [-0.85, 0.08, -0.30],
        [0.85, 0.36, 0.42],
        0.02,
        1,
        [3, 1, 2],
    );
    rounded_part(
        &mut b,
        [-0.85, 0.08, -0.45],
        [0.85, 0.85, -0.30],
        0.03,
        1,
        [4, 1, 1],
    );
    // Arms.
    for x in [-1.0, 0.85] {
        rounded_part(
            &mut b,
            [x, 0.08, -0.45],
            [x + 0.15, 0.62, 0.45],
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
            [x0, 0.36, -0.30],
            [x1, 0.50, 0.44],
            0.05,
            2,
            [2, 1, 1],
        );
        rounded_part(
            &mut b,
            [x0, 0.50, -0.30],
            [x1, 0.80, -0.14],
            0.05,
            1,
            [1, 1, 1],
        );
    }
    b.finish(f64::from(padding))
}
