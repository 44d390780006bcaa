//! Light from a lamp's luminous opening against closed forms, on every backend (issue 27).
//!
//! A synthetic Lambertian luminaire — `I(γ) = I₀·cos γ` below the horizontal, a flat disk or
//! rectangle as its opening — has the uniform luminance `L = I₀ / A` over its opening
//! (`L(ω) = I(ω) / A_proj(ω)`, `A_proj = A·cos γ`), so the illuminance it gives a floor below
//! is known exactly: on the disk's axis `E = π L a² / (a² + h²)`, anywhere under a disk
//! `E = (π L / 2)·(1 − (h² + r² − a²) / √((h² + r² + a²)² − 4a²r²))`, and under any planar
//! polygon Lambert's contour integral `E = (L/2)·|Σᵢ θᵢ (n·ĝᵢ)|` (edges seen under angle θᵢ,
//! ĝᵢ the unit normal of the plane through the receiver and the edge). Every floor texel is
//! compared at h/D = 0.25, 0.5, 1, 2 and 5; the point model's error on the disk's axis is
//! reproduced; and far away (10 D) the opening and the point agree. Each test prints what it
//! measured and counts what it compared ([`luxbake_tests::Tally`]).

use std::sync::Arc;

use luxbake::bake::BakeOutput;
use luxbake::gbuffer::{GBuffer, rasterize};
use luxbake::map::MapImage;
use luxbake::scene::{Albedo, Blur, Lamp, LampModel, Object, Quality, Scene, Settings, Transform};
use luxbake::sources::meshes;
use luxbake::{DirectStage, GpuBackend, Room};
use luxbake_backends::BackendKind;
use luxbake_ies::Photometry;
use luxbake_testkit::RelativeError;
use luxbake_tests::Tally;

const ALL: [BackendKind; 3] = [BackendKind::Cpu, BackendKind::Glow, BackendKind::Wgpu];
/// Peak candela of the synthetic luminaires.
const I0: f64 = 1000.0;
/// Opening samples of the closed-form checks (up to twice that near the opening): the
/// lattice's error stays under the tolerance at h/D = 0.25 (max 0.35 % over the disk's floor,
/// 0.07 % at 1024; the default preset's 48 are checked for noise in the core's tests).
const SAMPLES: u32 = 256;

/// A Lambertian LM-63 file (`I₀ cos γ` below, nothing above) with the luminous opening of
/// the signed `width`, `length` (metres; negative equal values: a disk).
fn lambertian(width: f64, length: f64) -> Arc<Photometry> {
    let angles: Vec<String> = (0..=180).map(|g| g.to_string()).collect();
    let values: Vec<String> = (0..=180)
        .map(|g| {
            let v = if g < 90 {
                I0 * f64::from(g).to_radians().cos()
            } else {
                0.0
            };
            format!("{v:.6}")
        })
        .collect();
    let text = format!(
        "IESNA:LM-63-2002\n[TEST] Lambertian opening\nTILT=NONE\n\
         1 -1 1 181 1 1 2 {width} {length} 0\n1 1 0\n{}\n0\n{}\n",
        angles.join(" "),
        values.join(" ")
    );
    Arc::new(Photometry::parse(text.as_bytes()).expect("synthetic IES"))
}

/// A square floor of side `size` centred under the origin, lit by `lamp` only, direct light.
fn floor_scene(lamp: Lamp, size: f32, texels_per_metre: f32, samples: u32) -> Scene {
    let settings = Settings {
        rays: 1,
        bounces: 0,
        blur: Blur::None,
        texels_per_metre,
        opening_samples: samples,
        ..Settings::paper()
    };
    Scene {
        objects: vec![Object {
            name: "floor".into(),
            mesh: meshes::plane([size; 2], 2.0 / texels_per_metre),
            transform: Transform::IDENTITY,
            albedo: Albedo::grey(0.5),
            receiver: true,
            texel_scale: 1.0,
        }],
        lamps: vec![lamp],
        settings,
    }
}

/// The floor's texels as `(x, z, lux)` (green channel; the lamp is white).
fn texels(scene: &Scene, out: &BakeOutput) -> Vec<(f64, f64, f64)> {
    floor_texels(
        &rasterize(scene, &out.layout),
        out,
        out.maps[0].illuminance(),
    )
}

/// The texels of `map`, a map of the floor of `out` (whose G-buffer is `g`), as `(x, z, lux)`.
fn floor_texels(g: &GBuffer, out: &BakeOutput, map: &MapImage) -> Vec<(f64, f64, f64)> {
    out.maps[0]
        .texels(g, map)
        .map(|(p, t)| (p[0], p[2], f64::from(t[1])))
        .collect()
}

/// The lamp models compared on a disk's axis.
const MODELS: [LampModel; 2] = [LampModel::Point, LampModel::Area];

/// The floor's texels ([`texels`]) under a Lambertian disk of diameter `d`, `h` above its
/// centre, as each of [`MODELS`] (`None`: skipped); `floor` is [`floor_scene`]'s size,
/// density and opening samples.
fn point_and_area(
    tally: &mut Tally,
    backend: BackendKind,
    d: f64,
    h: f64,
    (size, texels_per_metre, samples): (f32, f32, u32),
) -> Option<[Vec<(f64, f64, f64)>; 2]> {
    let mut t = [Vec::new(), Vec::new()];
    for (t, model) in t.iter_mut().zip(MODELS) {
        let mut lamp = Lamp::new("disk", lambertian(-d, -d), [0.0, h, 0.0]);
        lamp.model = model;
        let scene = floor_scene(lamp, size, texels_per_metre, samples);
        *t = texels(&scene, &tally.bake(backend, &scene)?);
    }
    Some(t)
}

/// Illuminance of a horizontal receiver at horizontal distance `r` from the axis of a
/// downward-facing Lambertian disk of radius `a` and luminance `l`, `h` above it.
fn disk(l: f64, a: f64, h: f64, r: f64) -> f64 {
    let s = h * h + r * r + a * a;
    std::f64::consts::FRAC_PI_2
        * l
        * (1.0 - (h * h + r * r - a * a) / (s * s - 4.0 * a * a * r * r).sqrt())
}

/// Lambert's contour integral: illuminance at the origin, normal `n`, from a planar polygon of
/// uniform luminance `l` with vertices `v` (relative to the receiver, in order).
fn polygon(l: f64, v: &[[f64; 3]], n: [f64; 3]) -> f64 {
    0.5 * l * lambert_terms(v, n)[0].abs()
}

/// Lambert's contour integral's terms for the polygon `v` seen from the origin with normal `n`
/// ([`polygon`]): their sum and the sum of their magnitudes.
fn lambert_terms(v: &[[f64; 3]], n: [f64; 3]) -> [f64; 2] {
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let [mut sum, mut magnitude] = [0.0; 2];
    for i in 0..v.len() {
        let (a, b) = (v[i], v[(i + 1) % v.len()]);
        let c = cross(a, b);
        let len = dot(c, c).sqrt();
        if len > 0.0 {
            let theta = (dot(a, b) / (dot(a, a) * dot(b, b)).sqrt())
                .clamp(-1.0, 1.0)
                .acos();
            sum += theta * dot(n, c) / len;
            magnitude += (theta * dot(n, c) / len).abs();
        }
    }
    [sum, magnitude]
}

/// Illuminance at floor point `(x, z)` under a downward-facing rectangle of luminance `l`,
/// `a` long (along C0 = +x) and `b` wide (along C90 = −z), `h` above the origin
/// ([`polygon`]).
fn rectangle(l: f64, [a, b]: [f64; 2], h: f64, [x, z]: [f64; 2]) -> f64 {
    let v = [
        [-a / 2.0 - x, h, -b / 2.0 - z],
        [a / 2.0 - x, h, -b / 2.0 - z],
        [a / 2.0 - x, h, b / 2.0 - z],
        [-a / 2.0 - x, h, b / 2.0 - z],
    ];
    polygon(l, &v, [0.0, 1.0, 0.0])
}

/// The corner formula for a rectangle `a × b` parallel to the receiver, `h` above it, with
/// the receiver under one corner.
fn corner(l: f64, a: f64, b: f64, h: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    0.5 * l * (x / sx * (y / sx).atan() + y / sy * (x / sy).atan())
}

#[test]
fn lamberts_contour_integral_gives_the_corner_formula() {
    for (a, b, h) in [(0.6, 0.1, 0.2), (1.0, 1.0, 1.0), (0.3, 2.0, 0.05)] {
        let v = [[0.0, h, 0.0], [a, h, 0.0], [a, h, b], [0.0, h, b]];
        let (p, c) = (polygon(1.0, &v, [0.0, 1.0, 0.0]), corner(1.0, a, b, h));
        assert!((p - c).abs() < 1e-12 * c, "{a} {b} {h}: {p} vs {c}");
    }
}

/// Relative errors of the texels where the exact illuminance is at least `floor` of its peak.
fn errors(t: &[(f64, f64, f64)], exact: impl Fn(f64, f64) -> f64, floor: f64) -> RelativeError {
    let peak = t.iter().map(|&(x, z, _)| exact(x, z)).fold(0.0, f64::max);
    t.iter()
        .map(|&(x, z, e)| (e, exact(x, z)))
        .filter(|&(_, want)| want >= floor * peak)
        .collect()
}

#[test]
fn disk_and_rectangle_openings_match_the_closed_forms_on_every_backend() {
    let d = 0.4f64;
    let (a, b) = (0.6f64, 0.15f64);
    let l_disk = I0 / (std::f64::consts::PI * d * d / 4.0);
    let l_rect = I0 / (a * b);
    /// The exact illuminance at floor point (x, z) with the opening h above the origin.
    type Exact<'a> = &'a dyn Fn(f64, f64, f64) -> f64;
    let disk_exact = |h: f64, x: f64, z: f64| disk(l_disk, d / 2.0, h, (x * x + z * z).sqrt());
    let rect_exact = |h: f64, x: f64, z: f64| rectangle(l_rect, [a, b], h, [x, z]);
    let openings: [(&str, Arc<Photometry>, f64, Exact<'_>); 2] = [
        ("disk", lambertian(-d, -d), d, &disk_exact),
        ("rectangle", lambertian(b, a), a, &rect_exact),
    ];
    let mut tally = Tally::new("opening_closed_forms");
    'backends: for backend in ALL {
        for ratio in [0.25, 0.5, 1.0, 2.0, 5.0] {
            for (name, photometry, size, exact) in &openings {
                let h = ratio * size;
                let mut lamp = Lamp::new(*name, photometry.clone(), [0.0, h, 0.0]);
                lamp.model = LampModel::Area;
                let scene = floor_scene(lamp, 3.0, 24.0, SAMPLES);
                let Some(out) = tally.bake(backend, &scene) else {
                    continue 'backends;
                };
                let t = texels(&scene, &out);
                let err = errors(&t, |x, z| exact(h, x, z), 0.01);
                println!(
                    "{backend} {name} h/D = {ratio}: {} texels, max |rel| {:.3} %, mean {:.3} %",
                    err.n,
                    100.0 * err.max,
                    100.0 * err.mean()
                );
                assert!(
                    err.n > 100 && err.max < 0.005,
                    "{backend} {name} h/D {ratio}: max {}",
                    err.max
                );
                tally.compared(1);
            }
        }
    }
    tally.finish();
}

/// Under a Lambertian opening `photometry` (its size `size`) at h/D = 0.25, 1 and 5 over a
/// floor, on every backend at the default preset's 48 samples: every floor texel with the
/// control variate (probe stride 4) within 10⁻⁴ of `exact(h, x, z)`, and the lattice alone
/// (every point with its ray, stride 0) off by more than 5·10⁻⁴ somewhere, so that the
/// comparison can tell them apart.
fn wholly_seen_is_the_closed_form(
    tally: &str,
    photometry: &Arc<Photometry>,
    size: f64,
    exact: &dyn Fn(f64, f64, f64) -> f64,
) {
    let mut tally = Tally::new(tally);
    'backends: for backend in ALL {
        for ratio in [0.25, 1.0, 5.0] {
            let h = ratio * size;
            let mut worst = [0.0f64; 2];
            for (probes, worst) in [4, 0].into_iter().zip(&mut worst) {
                let mut lamp = Lamp::new("opening", photometry.clone(), [0.0, h, 0.0]);
                lamp.model = LampModel::Area;
                let mut scene = floor_scene(lamp, 3.0, 24.0, 48);
                scene.settings.opening_probe_stride = probes;
                let Some(out) = tally.bake(backend, &scene) else {
                    continue 'backends;
                };
                let err = errors(&texels(&scene, &out), |x, z| exact(h, x, z), 0.01);
                println!(
                    "{backend} h/D = {ratio}, probe stride {probes}: {} texels, max |rel| {:.4} %, \
                     mean {:.4} %",
                    err.n,
                    100.0 * err.max,
                    100.0 * err.mean()
                );
                assert!(err.n > 400, "{backend} h/D {ratio}: {} texels", err.n);
                *worst = err.max;
            }
            assert!(
                worst[0] < 1e-4 && worst[1] > 5e-4,
                "{backend} h/D {ratio}: with the control variate {}, the lattice alone {}",
                worst[0],
                worst[1]
            );
            tally.compared(1);
        }
    }
    tally.finish();
}

/// Where a texel sees the whole of a rectangle (a box's face), its share is the closed form of
/// the rectangle's geometry times its luminance toward the texel plus the probes' estimate of
/// the rest (`luxbake::opening`, "Control variate"): under a Lambertian rectangle, whose
/// luminance is the same toward every texel, that is the closed form itself at the default
/// preset's 48 samples (within 0.01 %, the table's interpolation), where the lattice alone
/// (every point with its ray, `opening_probe_stride` 0) is off by up to 0.09 % at five times
/// the opening's size and 0.66 % at a quarter of it.
#[test]
fn a_wholly_seen_rectangle_is_its_closed_form_at_the_default_samples_on_every_backend() {
    let (a, b) = (0.6f64, 0.15f64);
    let l_rect = I0 / (a * b);
    let exact = |h: f64, x: f64, z: f64| rectangle(l_rect, [a, b], h, [x, z]);
    wholly_seen_is_the_closed_form("opening_rectangle_control", &lambertian(b, a), a, &exact);
}

/// The same for a disk (a cylinder's circular end, `luxbake::opening::disk_control`): every
/// floor texel that sees a Lambertian disk whole is its closed form at the default preset's 48
/// samples (within 0.004 %), where the lattice alone is off by up to 0.46 % at five times the
/// disk's diameter and 1.5 % at a quarter of it.
#[test]
fn a_wholly_seen_disk_is_its_closed_form_at_the_default_samples_on_every_backend() {
    let d = 0.4f64;
    let l_disk = I0 / (std::f64::consts::PI * d * d / 4.0);
    let exact = |h: f64, x: f64, z: f64| disk(l_disk, d / 2.0, h, (x * x + z * z).sqrt());
    wholly_seen_is_the_closed_form("opening_disk_control", &lambertian(-d, -d), d, &exact);
}

/// Under a 2 cm Lambertian opening `photometry` `h` over a 4 m floor, which the floor's far
/// texels see at a grazing angle: more than a hundred lit texels where `cancels(x, z)` (the
/// closed form's terms, in f64, cancel past `luxbake::opening::CONTROL_MAX_CANCELLATION`), and
/// every backend's floor the CPU's within `within` relative at the texels over `lit` of the
/// peak.
fn refused_alike(
    tally: &str,
    photometry: Arc<Photometry>,
    [h, lit, within]: [f64; 3],
    cancels: &dyn Fn(f64, f64) -> bool,
) {
    let mut lamp = Lamp::new("small", photometry, [0.0, h, 0.0]);
    lamp.model = LampModel::Area;
    let mut scene = floor_scene(lamp, 4.0, 24.0, 48);
    scene.settings.opening_probe_stride = 4;
    let mut tally = Tally::new(tally);
    let Some(cpu) = tally.bake(BackendKind::Cpu, &scene) else {
        tally.finish();
        return;
    };
    let want = texels(&scene, &cpu);
    let peak = want.iter().map(|t| t.2).fold(0.0, f64::max);
    let lit = |t: &(f64, f64, f64)| t.2 >= lit * peak;
    let cancelling = (want.iter().filter(|t| lit(t)))
        .filter(|&&(x, z, _)| cancels(x, z))
        .count();
    assert!(
        cancelling > 100,
        "{cancelling} texels whose terms cancel past the bound"
    );
    for backend in [BackendKind::Glow, BackendKind::Wgpu] {
        let Some(out) = tally.bake(backend, &scene) else {
            continue;
        };
        let got = texels(&scene, &out);
        assert_eq!(got.len(), want.len());
        let worst = (want.iter().zip(&got))
            .filter(|(w, _)| lit(w))
            .map(|(w, g)| (g.2 - w.2).abs() / w.2)
            .fold(0.0, f64::max);
        println!(
            "{backend}: {cancelling} texels cancel past the bound; worst |rel| against the CPU {worst:.2e}"
        );
        assert!(worst <= within, "{backend}: {worst}");
        tally.compared(1);
    }
    tally.finish();
}

/// Where the closed form of a rectangle's control variate is refused because Lambert's terms
/// cancel past single precision (`luxbake::opening::CONTROL_MAX_CANCELLATION`), every backend
/// refuses it ([`refused_alike`], a 2 cm square 0.3 m up, texels over 10⁻⁴ of the peak, within
/// 2·10⁻⁴). Measured: 1.1·10⁻⁴ on glow and wgpu, single precision's rounding; shaders that took
/// the closed form there read up to 6.5·10⁻² off.
#[test]
fn a_rectangles_control_variate_is_refused_alike_on_every_backend() {
    let (side, h) = (0.02f64, 0.3f64);
    let bound = f64::from(luxbake::opening::CONTROL_MAX_CANCELLATION);
    let cancels = |x: f64, z: f64| {
        let c = side / 2.0;
        let v = [
            [-c - x, h, -c - z],
            [c - x, h, -c - z],
            [c - x, h, c - z],
            [-c - x, h, c - z],
        ];
        let [sum, magnitude] = lambert_terms(&v, [0.0, 1.0, 0.0]);
        magnitude > bound * sum.abs()
    };
    refused_alike(
        "opening_control_refused",
        lambertian(side, side),
        [h, 1e-4, 2e-4],
        &cancels,
    );
}

/// The same for a disk's closed form (`luxbake::opening::disk_control`), a 2 cm disk: its
/// terms `n·f` and `2·((n·f)·|d|² − (n·d)(d·f)) / (|d|² + R² + s)` cancel only as the two
/// cosines' product falls (at 0.3 m over the floor nowhere on it past the bound), so the disk
/// hangs 5 cm over it, and its terms' magnitudes add to more than the bound times their sum
/// beyond some 0.65 m — where the light is under 10⁻⁵ of the peak, so every lit texel counts
/// (over 10⁻⁹ of it). Measured: glow and wgpu 2.2·10⁻⁴ off the CPU there (the 48 points'
/// sums at grazing texels in single precision; elsewhere 6·10⁻⁷), within 10⁻³; shaders
/// without the bound read 4.2·10⁻³ off.
#[test]
fn a_disks_control_variate_is_refused_alike_on_every_backend() {
    let (d, h) = (0.02f64, 0.05f64);
    let bound = f64::from(luxbake::opening::CONTROL_MAX_CANCELLATION);
    let cancels = |x: f64, z: f64| {
        // The floor's normal n = +y, the disk's downward face f = −y, its centre less the
        // texel.
        let (r2, dv) = (d * d / 4.0, [-x, h, -z]);
        let dd = dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2];
        let (nf, nd, df) = (-1.0, dv[1], -dv[1]);
        let s = ((dd - r2) * (dd - r2) + 4.0 * r2 * df * df).sqrt();
        let denominator = dd + r2 + s;
        let sum = nf - 2.0 * (nf * dd - nd * df) / denominator;
        let magnitude = f64::abs(nf) + 2.0 * (f64::abs(nf) * dd + (nd * df).abs()) / denominator;
        magnitude > bound * sum.abs()
    };
    refused_alike(
        "opening_disk_control_refused",
        lambertian(-d, -d),
        [h, 1e-9, 1e-3],
        &cancels,
    );
}

#[test]
fn the_point_models_error_on_a_disks_axis_and_its_far_field() {
    let d = 0.2f64;
    let mut tally = Tally::new("opening_point_model_table");
    for backend in ALL {
        // (h/D, (E_area − E_point) / E_point on the axis): −1/(1 + (2h/D)²).
        for (ratio, table) in [(1.0, -0.20), (2.0, -0.059), (3.0, -0.027), (5.0, -0.0099)] {
            let h = ratio * d;
            let Some(t) = point_and_area(&mut tally, backend, d, h, (0.5, 64.0, 256)) else {
                return tally.finish();
            };
            let axis: Vec<f64> = MODELS
                .iter()
                .zip(&t)
                .map(|(model, t)| {
                    // The texel nearest the axis, corrected to the axis by the closed forms'
                    // ratio there (texel centres are a third of a texel off it at most).
                    let &(x, z, e) = t
                        .iter()
                        .min_by(|p, q| (p.0.hypot(p.1)).total_cmp(&q.0.hypot(q.1)))
                        .expect("texels");
                    let r = x.hypot(z);
                    let exact_at = |r: f64| match model {
                        LampModel::Point => I0 * h.powi(2) / (h * h + r * r).powi(2),
                        _ => disk(I0 / (std::f64::consts::PI * d * d / 4.0), d / 2.0, h, r),
                    };
                    e * exact_at(0.0) / exact_at(r)
                })
                .collect();
            let got = (axis[1] - axis[0]) / axis[0];
            let want = -1.0 / (1.0 + (2.0 * ratio).powi(2));
            println!(
                "{backend} h/D = {ratio}: point model's error {:.2} % (closed form {:.2} %, the issue's table {:.2} %)",
                100.0 * got,
                100.0 * want,
                100.0 * table
            );
            assert!(
                (got - want).abs() < 0.002,
                "{backend} h/D {ratio}: {got} vs {want}"
            );
            assert!((want - table).abs() < 0.0006 + 0.02 * table.abs());
            tally.compared(1);
        }
        // 10 D away the opening gives what the point gives, within 0.3 %.
        let h = 10.0 * d;
        let Some(t) = point_and_area(&mut tally, backend, d, h, (3.0, 8.0, 64)) else {
            return tally.finish();
        };
        let sums = t.map(|t| t.iter().map(|t| t.2).sum::<f64>());
        let rel = (sums[1] - sums[0]).abs() / sums[0];
        println!("{backend} 10 D: area vs point {:.3} %", 100.0 * rel);
        assert!(rel < 0.003, "{backend}: {rel}");
        tally.compared(1);
    }
    tally.finish();
}

/// A bake that hands its direct light over first ([`luxbake::bake_room_direct_first`]) with a
/// lamp that bakes its opening hands over a preview before it, every lamp a point: on every
/// backend the preview is the point's inverse-square and cosine law `E = I(θ) cos θ / r²`
/// (under the Lambertian disk `I₀ cos θ · cos θ / r² = I₀ h² / r⁴`), and the direct light
/// after it the disk's closed form, both at every floor texel.
#[test]
fn the_preview_of_an_openings_direct_light_is_the_point_on_every_backend() {
    let d = 0.4f64;
    let h = d;
    let l_disk = I0 / (std::f64::consts::PI * d * d / 4.0);
    let mut lamp = Lamp::new("disk", lambertian(-d, -d), [0.0, h, 0.0]);
    lamp.model = LampModel::Area;
    let mut scene = floor_scene(lamp, 3.0, 24.0, SAMPLES);
    scene.settings = Settings {
        bounces: 0,
        blur: Blur::None,
        texels_per_metre: 24.0,
        opening_samples: SAMPLES,
        ..Settings::preset(Quality::Default)
    };
    let mut tally = Tally::new("opening_preview");
    for backend in ALL {
        let Some(mut b) = tally.open(backend) else {
            continue;
        };
        let room = Room::prepare(&scene, &scene.settings, b.limits(), &mut |_| {}).expect("room");
        let mut shown = Vec::new();
        let out = luxbake::bake_room_direct_first(
            &mut b,
            &room,
            &scene.lamps,
            &scene.settings,
            &mut |_| {},
            &mut |stage, maps| shown.push((stage, maps[0].illuminance().clone())),
        )
        .unwrap_or_else(|e| panic!("{backend} bake: {e}"));
        let stages: Vec<DirectStage> = shown.iter().map(|s| s.0).collect();
        assert_eq!(
            stages,
            [DirectStage::Preview, DirectStage::Direct],
            "{backend}"
        );
        let g = rasterize(&scene, &out.layout);
        let floor = |map: &MapImage| floor_texels(&g, &out, map);
        let point = errors(
            &floor(&shown[0].1),
            |x, z| {
                let r2 = h * h + x * x + z * z;
                I0 * h * h / (r2 * r2)
            },
            0.01,
        );
        let opening = errors(
            &floor(&shown[1].1),
            |x, z| disk(l_disk, d / 2.0, h, (x * x + z * z).sqrt()),
            0.01,
        );
        println!(
            "{backend}: preview against the point {} texels, max |rel| {:.3} %; direct light \
             against the disk {} texels, max {:.3} %",
            point.n,
            100.0 * point.max,
            opening.n,
            100.0 * opening.max
        );
        assert!(point.n > 100 && point.max < 0.005, "{backend} preview");
        assert!(opening.n > 100 && opening.max < 0.005, "{backend} direct");
        tally.compared(1);
    }
    tally.finish();
}
