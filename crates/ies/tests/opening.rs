//! The emitting model of the luminous opening: projected areas against integrals over
//! `Emitter::sample`, Cauchy's formula, the point-model distance, the LM-63 and EULUMDAT
//! shape mapping, and the emitter of every sample file.

use luxbake_ies::{
    Emitter, LuminousOpening, OpeningShape, PhotometricType, Photometry, SolidKind, Units,
};
use luxbake_testkit::fibonacci_sphere;
use proptest::prelude::*;
use std::f64::consts::PI;
use std::path::PathBuf;

const KINDS: [SolidKind; 3] = [SolidKind::Box, SolidKind::Cylinder, SolidKind::Ellipsoid];

/// A function of a surface point and its normal.
type SurfaceFn = dyn Fn([f64; 3], [f64; 3]) -> f64;

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// ∫ over the emitting surface of each `g`, from `Emitter::sample`: the part picked by u[2]
/// does not depend on (u0, u1), so the u[2] line is cut where the picked part changes (found
/// by bisection, to 1e-13) and each part's (u0, u1) square integrated by an n × n midpoint
/// rule at one u[2] inside it. Then only the (u0, u1) rule is approximate.
fn integrate(e: &Emitter, n: usize, gs: &[&SurfaceFn]) -> Vec<f64> {
    let probe = |u2: f64| e.sample([0.31, 0.67, u2]).map(|s| (s.point, s.normal));
    let mut cuts = vec![0.0];
    let mut lo = 0.0;
    while lo < 1.0 {
        let here = probe(lo);
        // The end of this part's stretch.
        let (mut a, mut b) = (lo, 1.0);
        if probe(b) == here {
            cuts.push(1.0);
            break;
        }
        while b - a > 1e-13 {
            let m = 0.5 * (a + b);
            if probe(m) == here { a = m } else { b = m }
        }
        cuts.push(b);
        lo = b;
    }
    let mut out = vec![0.0; gs.len()];
    for w in cuts.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b <= a {
            continue;
        }
        let u2 = 0.5 * (a + b);
        let mut part = vec![0.0; gs.len()];
        for i in 0..n {
            for j in 0..n {
                let u = [(i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64, u2];
                let s = e.sample(u).expect("a sample where the area is above zero");
                for (k, g) in gs.iter().enumerate() {
                    part[k] += g(s.point, s.normal) * s.weight;
                }
            }
        }
        for k in 0..gs.len() {
            out[k] += part[k] / (n * n) as f64 * (b - a);
        }
    }
    out
}

/// Every kind, axis and face set, with generic and degenerate half extents.
fn emitters() -> Vec<Emitter> {
    let mut out = Vec::new();
    for kind in KINDS {
        for axis in 0..3 {
            for half in [
                [0.3, 0.12, 0.05],
                [0.2, 0.2, 0.0],
                [0.1, 0.0, 0.4],
                [0.25, 0.07, 0.25],
            ] {
                let face_sets: &[u8] = if kind == SolidKind::Ellipsoid {
                    &[4]
                } else {
                    &[1, 2, 3, 4, 5, 6, 7]
                };
                for &faces in face_sets {
                    out.push(Emitter {
                        kind,
                        axis,
                        half,
                        faces,
                    });
                }
            }
        }
    }
    out
}

#[test]
fn projected_area_is_the_integral_of_the_visible_cosine_over_samples() {
    let dirs = fibonacci_sphere(24);
    for e in emitters() {
        if e.area() == 0.0 {
            assert!(e.sample([0.5, 0.5, 0.5]).is_none(), "{e:?}");
            continue;
        }
        let gs: Vec<Box<SurfaceFn>> = dirs
            .iter()
            .map(|&d| {
                Box::new(move |_p: [f64; 3], n: [f64; 3]| dot(n, d).max(0.0)) as Box<SurfaceFn>
            })
            .collect();
        let refs: Vec<&SurfaceFn> = gs.iter().map(|g| &**g).collect();
        let got = integrate(&e, 80, &refs);
        for (d, g) in dirs.iter().zip(got) {
            let want = e.projected_area(*d);
            let tol = 5e-4 * e.area() + 1e-12;
            assert!(
                (g - want).abs() < tol,
                "{e:?} {d:?}: sampled {g}, closed form {want}"
            );
        }
    }
}

#[test]
fn sample_weights_integrate_to_the_area() {
    for e in emitters() {
        if e.area() == 0.0 {
            continue;
        }
        let one = |_: [f64; 3], _: [f64; 3]| 1.0;
        let got = integrate(&e, 200, &[&one])[0];
        // The midpoint rule meets kinks and square-root ends in the area element of collapsed
        // solids: 5e-4.
        assert!(
            (got / e.area() - 1.0).abs() < 5e-4,
            "{e:?}: {got} vs {}",
            e.area()
        );
    }
}

#[test]
fn mean_projected_area_of_a_closed_convex_emitter_is_a_quarter_of_its_area() {
    let dirs = fibonacci_sphere(40_000);
    for (kind, half) in [
        (SolidKind::Box, [0.3, 0.1, 0.05]),
        (SolidKind::Cylinder, [0.2, 0.08, 0.3]),
        (SolidKind::Cylinder, [0.1, 0.1, 0.02]),
        (SolidKind::Ellipsoid, [0.4, 0.15, 0.1]),
        (SolidKind::Ellipsoid, [0.2, 0.2, 0.2]),
    ] {
        for axis in 0..3 {
            let e = Emitter {
                kind,
                axis,
                half,
                faces: 7,
            };
            let mean: f64 =
                dirs.iter().map(|&d| e.projected_area(d)).sum::<f64>() / dirs.len() as f64;
            assert!(
                (mean / (e.area() / 4.0) - 1.0).abs() < 1e-4,
                "{e:?}: {mean}"
            );
        }
    }
}

#[test]
fn areas_in_closed_form() {
    let b = Emitter {
        kind: SolidKind::Box,
        axis: 2,
        half: [0.224, 0.224, 0.036],
        faces: 7,
    };
    let want = 2.0 * 0.448 * 0.448 + 4.0 * 0.448 * 0.072;
    assert!((b.area() - want).abs() < 1e-12);
    let c = Emitter {
        kind: SolidKind::Cylinder,
        axis: 1,
        half: [0.1, 0.1, 0.5],
        faces: 4,
    };
    assert!((c.area() - 2.0 * PI * 0.1 * 1.0).abs() < 1e-12);
    let s = Emitter {
        kind: SolidKind::Ellipsoid,
        axis: 0,
        half: [0.5; 3],
        faces: 4,
    };
    assert!((s.area() - PI).abs() < 1e-12);
    // A sphere shows πr² in every direction; a flat disk πr²|cos|.
    for d in fibonacci_sphere(50) {
        assert!((s.projected_area(d) - PI / 4.0).abs() < 1e-12);
    }
}

#[test]
fn point_model_error_on_a_disk_axis_and_the_five_times_rule() {
    let d = 0.2; // diameter, m
    let a = d / 2.0;
    let disk = Emitter {
        kind: SolidKind::Cylinder,
        axis: 2,
        half: [a, a, 0.0],
        faces: Emitter::END_NEG,
    };
    // ⟨ρ²⟩ = a²/2, so sqrt(2⟨ρ²⟩/1 %) = 10a = 5 D.
    assert!((disk.mean_square_radius() - a * a / 2.0).abs() < 1e-15);
    assert!((disk.point_model_distance(0.01) / (5.0 * d) - 1.0).abs() < 1e-12);
    // The exact on-axis error of the point model, (E_area − E_point)/E_point = −a²/(a² + h²),
    // against the table, and E_area integrated over the disk's samples (uniform luminance,
    // receiver facing up at distance h below).
    let one = |_: [f64; 3], _: [f64; 3]| 1.0;
    let area = disk.area();
    for (h_over_d, percent) in [(5.0, -0.99), (3.0, -2.70), (2.0, -5.88), (1.0, -20.0)] {
        let h = h_over_d * d;
        let exact = -a * a / (a * a + h * h) * 100.0;
        assert!((exact - percent).abs() < 0.005, "h/D {h_over_d}: {exact} %");
        let receiver = [0.0, 0.0, -h];
        let e = move |p: [f64; 3], n: [f64; 3]| {
            let r = [receiver[0] - p[0], receiver[1] - p[1], receiver[2] - p[2]];
            let r2 = dot(r, r);
            let cos_emit = dot(n, r) / r2.sqrt();
            let cos_recv = -r[2] / r2.sqrt();
            cos_emit * cos_recv / r2
        };
        let e_area = integrate(&disk, 400, &[&e, &one]);
        let e_point = e_area[1] / (h * h); // I on axis = L·A, L = 1
        assert!((e_area[1] / area - 1.0).abs() < 1e-9);
        let err = (e_area[0] - e_point) / e_point * 100.0;
        assert!(
            (err - exact).abs() < 0.01,
            "h/D {h_over_d}: {err} vs {exact}"
        );
        // The estimate 2⟨ρ²⟩/h² is the leading term.
        let estimate = -2.0 * disk.mean_square_radius() / (h * h) * 100.0;
        assert!((estimate - exact).abs() <= exact.abs() * (a * a / (h * h)) * 1.01 + 1e-12);
    }
}

#[test]
fn mean_square_radius_in_closed_form_and_by_samples() {
    let r2 = |p: [f64; 3], _: [f64; 3]| dot(p, p);
    for e in emitters() {
        if e.area() == 0.0 {
            assert_eq!(e.mean_square_radius(), 0.0);
            continue;
        }
        let got = integrate(&e, 200, &[&r2])[0] / e.area();
        let want = e.mean_square_radius();
        assert!((got / want - 1.0).abs() < 1e-3, "{e:?}: {got} vs {want}");
    }
    // A sphere of radius r: r²; a closed cube of half side s: s² + 2s²/3.
    let s = Emitter {
        kind: SolidKind::Ellipsoid,
        axis: 2,
        half: [0.3; 3],
        faces: 4,
    };
    assert!((s.mean_square_radius() / 0.09 - 1.0).abs() < 1e-10);
    let cube = Emitter {
        kind: SolidKind::Box,
        axis: 2,
        half: [0.3; 3],
        faces: 7,
    };
    assert!((cube.mean_square_radius() / (0.09 * 5.0 / 3.0) - 1.0).abs() < 1e-12);
}

#[test]
fn degenerate_sizes_give_no_nan() {
    let halves = [
        [0.0, 0.0, 0.0],
        [0.2, 0.0, 0.0],
        [0.0, 0.3, 0.0],
        [0.0, 0.0, 0.1],
        [0.2, 0.1, 0.0],
        [0.2, 0.0, 0.1],
        [1e-300, 0.2, 0.1],
        [f64::NAN, 0.2, 0.1],
        [-1.0, 0.2, 0.1],
    ];
    for kind in KINDS {
        for half in halves {
            for faces in [0, 1, 3, 4, 7] {
                let e = Emitter {
                    kind,
                    axis: 2,
                    half,
                    faces,
                };
                assert!(e.area().is_finite() && e.area() >= 0.0, "{e:?}");
                assert!(e.mean_square_radius().is_finite(), "{e:?}");
                assert!(!e.point_model_distance(0.01).is_nan(), "{e:?}");
                for d in fibonacci_sphere(20) {
                    let a = e.projected_area(d);
                    assert!(a.is_finite() && a >= 0.0, "{e:?}");
                }
                for k in 0..50 {
                    let u = [
                        (k as f64 * 0.37) % 1.0,
                        (k as f64 * 0.61) % 1.0,
                        k as f64 / 50.0,
                    ];
                    match e.sample(u) {
                        None => assert_eq!(e.area(), 0.0, "{e:?}"),
                        Some(s) => {
                            let n = dot(s.normal, s.normal);
                            assert!((n - 1.0).abs() < 1e-12, "{e:?} {s:?}");
                            assert!(s.point.iter().all(|x| x.is_finite()), "{e:?}");
                            assert!(s.weight.is_finite() && s.weight >= 0.0, "{e:?}");
                        }
                    }
                }
            }
        }
    }
    // A zero-thickness ellipsoid is a two-sided elliptic disk: area 2πab, normals ±w.
    let flat = Emitter {
        kind: SolidKind::Ellipsoid,
        axis: 2,
        half: [0.2, 0.1, 0.0],
        faces: 4,
    };
    assert!((flat.area() - 2.0 * PI * 0.02).abs() < 1e-12);
    let s = flat.sample([0.3, 0.4, 0.5]).unwrap();
    assert_eq!(s.normal, [0.0, 0.0, 1.0]);
}

/// A random emitter: kind, axis, half extents (some zero) and faces.
fn any_emitter() -> impl Strategy<Value = Emitter> {
    let half = prop::array::uniform3(prop_oneof![Just(0.0), 0.001f64..2.0]);
    (0usize..3, 0u8..3, half, 1u8..8).prop_map(|(k, axis, half, faces)| {
        let kind = KINDS[k];
        Emitter {
            kind,
            axis,
            half,
            faces: if kind == SolidKind::Ellipsoid {
                4
            } else {
                faces
            },
        }
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// E[weight] = area and E[max(0, n·d)·weight] = projected area; every sample lies on the
    /// solid with a unit normal.
    #[test]
    fn sampling_identity(e in any_emitter(), z in -1.0f64..1.0, phi in 0.0f64..6.3) {
        let r = (1.0 - z * z).sqrt();
        let d = [r * phi.cos(), r * phi.sin(), z];
        prop_assume!(e.area() > 1e-9);
        let one = |_: [f64; 3], _: [f64; 3]| 1.0;
        let cos = move |_: [f64; 3], n: [f64; 3]| dot(n, d).max(0.0);
        let got = integrate(&e, 96, &[&one, &cos]);
        prop_assert!((got[0] / e.area() - 1.0).abs() < 1e-3, "{:?}: {:?}", e, got);
        prop_assert!((got[1] - e.projected_area(d)).abs() < 1e-3 * e.area());
        for k in 0..20 {
            let u = [(k as f64 * 0.618) % 1.0, (k as f64 * 0.414) % 1.0, (k as f64 + 0.5) / 20.0];
            let s = e.sample(u).unwrap();
            prop_assert!((dot(s.normal, s.normal) - 1.0).abs() < 1e-12);
            for i in 0..3 {
                prop_assert!(s.point[i].abs() <= 2.0 + 1e-12);
            }
        }
    }
}

// ---------------------------------------------------------------- the mapping

#[test]
fn lm63_1995_and_2002_tables_differ_where_the_standards_do() {
    use OpeningShape as S;
    let y95 = |w, l, h| LuminousOpening::from_signed_lm63_1995(w, l, h, Units::Meters);
    let y02 = |w, l, h| LuminousOpening::from_signed(w, l, h, Units::Meters);
    assert_eq!(y95(-1.0, 2.0, -3.0).shape, S::Ellipsoid);
    assert_eq!(
        y02(-1.0, 2.0, -3.0).shape,
        S::HorizontalEllipticalCylinderAlong0
    );
    assert_eq!(y95(-1.0, 0.0, -1.0).shape, S::Sphere);
    assert_eq!(y02(-1.0, 0.0, -1.0).shape, S::VerticalCircleFacing0);
    let c = y95(-0.5, 0.0, 0.0);
    assert_eq!(
        (c.shape, c.width, c.length, c.height),
        (S::Circular, 0.5, 0.5, 0.0)
    );
    let v = y95(-0.5, 0.0, 0.2);
    assert_eq!((v.shape, v.length), (S::VerticalCylinder, 0.5));
    let h0 = y95(0.0, 2.0, -0.3);
    assert_eq!(
        (h0.shape, h0.width, h0.length),
        (S::HorizontalCylinderAlong0, 0.3, 2.0)
    );
    let h90 = y95(2.0, 0.0, -0.3);
    assert_eq!(
        (h90.shape, h90.width, h90.length),
        (S::HorizontalCylinderAlong90, 2.0, 0.3)
    );
    assert_eq!(y95(-1.0, 2.0, 0.0).shape, S::Ellipse);
    assert_eq!(y95(1.0, -2.0, 0.5).shape, S::VerticalEllipticalCylinder);
    // Shared patterns read alike.
    for (w, l, h) in [
        (1.0, 2.0, 0.0),
        (1.0, 2.0, 0.5),
        (-1.0, -1.0, 0.0),
        (0.0, 0.0, 0.0),
    ] {
        assert_eq!(y95(w, l, h), y02(w, l, h));
    }
    // The format picks the table.
    let file = |version: &str| {
        format!("{version}TILT=NONE\n1 -1 1 2 1 1 2 -0.1 0.4 -0.2\n1 1 0\n0 90\n0\n10 0\n")
    };
    let old = Photometry::parse(file("IESNA:LM-63-1995\n").as_bytes()).unwrap();
    assert_eq!(old.luminous_opening().shape, S::Ellipsoid);
    assert_eq!(old.emitter().unwrap().kind, SolidKind::Ellipsoid);
    let new = Photometry::parse(file("IESNA:LM-63-2002\n").as_bytes()).unwrap();
    assert_eq!(
        new.luminous_opening().shape,
        S::HorizontalEllipticalCylinderAlong0
    );
    let e = new.emitter().unwrap();
    assert_eq!(
        (e.kind, e.axis, e.half),
        (SolidKind::Cylinder, 0, [0.05, 0.1, 0.2])
    );
}

/// A type C LM-63-2002 file with the given signed opening and 0–180° data, `up` cd above the
/// horizontal and `down` below.
fn type_c(dims: [f64; 3], down: f64, up: f64) -> Photometry {
    let text = format!(
        "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 5 1 1 2 {} {} {}\n1 1 0\n0 45 90 135 180\n0\n\
         {down} {down} 0 {up} {up}\n",
        dims[0], dims[1], dims[2]
    );
    Photometry::parse(text.as_bytes()).unwrap()
}

#[test]
fn every_shape_maps_to_its_solid() {
    use SolidKind::{Box as B, Cylinder as C, Ellipsoid as E};
    for (dims, kind, axis, half, faces) in [
        ([0.2, 0.6, 0.0], B, 2, [0.3, 0.1, 0.0], 1),
        ([0.2, 0.6, 0.1], B, 2, [0.3, 0.1, 0.05], 5),
        ([-0.2, -0.2, 0.0], C, 2, [0.1, 0.1, 0.0], 1),
        ([-0.2, -0.4, 0.0], C, 2, [0.2, 0.1, 0.0], 1),
        ([-0.2, -0.2, 0.3], C, 2, [0.1, 0.1, 0.15], 5),
        ([-0.2, -0.4, -0.6], E, 2, [0.2, 0.1, 0.3], 4),
        ([-0.2, 1.0, -0.2], C, 0, [0.1, 0.1, 0.5], 4 | 3),
        ([1.0, -0.2, -0.4], C, 1, [0.2, 0.1, 0.5], 4 | 3),
        ([-0.2, 0.0, -0.4], C, 0, [0.1, 0.2, 0.0], 3),
        ([0.0, -0.2, -0.4], C, 1, [0.2, 0.1, 0.0], 3),
        ([0.2, -0.6, 0.1], B, 2, [0.3, 0.1, 0.05], 5),
    ] {
        let p = type_c(dims, 100.0, 0.0);
        let e = p.emitter().unwrap_or_else(|| panic!("{dims:?}"));
        assert_eq!(
            (e.kind, e.axis, e.half, e.faces),
            (kind, axis, half, faces),
            "{dims:?}"
        );
    }
    assert!(type_c([0.0, 0.0, 0.0], 100.0, 0.0).emitter().is_none());
    assert!(type_c([0.3, 0.0, 0.0], 100.0, 0.0).emitter().is_none()); // a segment
    // Uplight only: the top; both: both ends.
    assert_eq!(
        type_c([0.2, 0.6, 0.0], 0.0, 50.0).emitter().unwrap().faces,
        2
    );
    assert_eq!(
        type_c([0.2, 0.6, 0.1], 10.0, 50.0).emitter().unwrap().faces,
        7
    );
}

#[test]
fn luminance_times_projected_area_is_the_intensity() {
    let p = type_c([-0.2, -0.2, 0.3], 100.0, 40.0);
    let e = p.emitter().unwrap();
    for d in fibonacci_sphere(200) {
        let l = p.opening_luminance(d);
        let i = p.intensity(d);
        assert!(
            (l * e.projected_area(d) - i).abs() < 1e-9 * i.max(1.0),
            "{d:?}"
        );
    }
    assert_eq!(p.opening_luminance([0.0; 3]), 0.0);
    // Straight down from a 0.2 m disk: I / (π 0.1²).
    let down = p.opening_luminance([0.0, 0.0, -2.0]);
    assert!((down - 100.0 / (PI * 0.01)).abs() < 1e-9);
}

// ---------------------------------------------------------------- sample files

fn shared(test: &str) -> Option<PathBuf> {
    luxbake_testkit::shared_data(test, "photometry")
}

fn read(dir: &std::path::Path, name: &str) -> Photometry {
    Photometry::parse(&std::fs::read(dir.join(name)).unwrap()).unwrap()
}

/// Whether the file has light strictly inside the hemisphere `d · a > 0`, on a fine grid of
/// directions (independent of how the crate decides it).
fn has_light_toward(p: &Photometry, a: [f64; 3]) -> bool {
    (0..=720).any(|i| {
        let z = -1.0 + 2.0 * i as f64 / 720.0;
        let r = (1.0 - z * z).max(0.0).sqrt();
        (0..144).any(|k| {
            let phi = k as f64 * 2.5f64.to_radians();
            let d = [r * phi.cos(), r * phi.sin(), z];
            dot(d, a) > 1e-9 && p.intensity(d) > 0.0
        })
    })
}

#[test]
fn every_sample_file_gets_an_emitter_consistent_with_its_signs_and_candela() {
    let Some(dir) = shared("every_sample_file_gets_an_emitter_consistent_with_its_signs") else {
        return;
    };
    let mut names = Vec::new();
    for sub in [dir.clone(), dir.join("real-world")] {
        for entry in std::fs::read_dir(&sub).unwrap() {
            let path = entry.unwrap().path();
            let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
            if ext.eq_ignore_ascii_case("ies") || ext.eq_ignore_ascii_case("ldt") {
                names.push(path);
            }
        }
    }
    assert!(names.len() >= 22, "{names:?}");
    for path in names {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let p = Photometry::parse(&std::fs::read(&path).unwrap()).unwrap();
        let o = p.luminous_opening();
        let Some(e) = p.emitter() else {
            assert_eq!(o.shape, OpeningShape::Point, "{name}");
            continue;
        };
        // Sizes: the opening's extents, turned for types A and B.
        let mut ext = [o.length, o.width, o.height];
        if p.photometric_type() != PhotometricType::C {
            ext = [o.height, o.width, o.length]; // types A, B: (X, Y, Z) → (Z, Y, −X)
        }
        let [iu, iv, iw] = e.frame();
        for (k, i) in [iu, iv, iw].into_iter().enumerate() {
            assert!(
                (2.0 * e.half[k] - ext[i]).abs() < 1e-12,
                "{name}: {e:?} {o:?}"
            );
        }
        // Ends: lit where the file has light that way.
        let mut axis = [0.0; 3];
        axis[iw] = 1.0;
        let neg = has_light_toward(&p, axis.map(|x| -x));
        let pos = has_light_toward(&p, axis);
        assert_eq!(e.faces & 1 != 0, neg, "{name}: {e:?}");
        assert_eq!(e.faces & 2 != 0, pos, "{name}: {e:?}");
        assert_eq!(e.faces & 4 != 0, e.half[2] > 0.0, "{name}: {e:?}");
        // No light is lost: where the file shines, the emitter shows area, and the luminance
        // gives back the intensity.
        for d in fibonacci_sphere(3000) {
            let i = p.intensity(d);
            let a = e.projected_area(d);
            if i > 0.0 && d.iter().all(|x| x.abs() > 1e-6) {
                assert!(a > 0.0, "{name}: {d:?} has {i} cd and no emitting area");
                let l = p.opening_luminance(d);
                assert!((l * a / i - 1.0).abs() < 1e-9, "{name}");
            }
        }
        assert!(e.point_model_distance(0.01) > 0.0);
    }
}

#[test]
fn real_world_emitters() {
    let Some(dir) = shared("real_world_emitters") else {
        return;
    };
    let rw = dir.join("real-world");
    // rw_1: a 0.448 × 0.448 × 0.072 m box lit all round (it has up- and downlight).
    let p = read(&rw, "rw_1.IES");
    let e = p.emitter().unwrap();
    assert_eq!((e.kind, e.axis, e.faces), (SolidKind::Box, 2, 7));
    for (h, want) in e.half.iter().zip([0.224, 0.224, 0.036]) {
        assert!((h - want).abs() < 5e-4, "{e:?}");
    }
    assert!(p.intensity([0.0, 0.0, -1.0]) > 0.0 && has_light_toward(&p, [0.0, 0.0, 1.0]));
    // rw_5: a flat 0.614 × 0.063 m rectangle, length along C0, with no uplight: bottom only.
    let p = read(&rw, "rw_5.IES");
    let e = p.emitter().unwrap();
    assert!(!has_light_toward(&p, [0.0, 0.0, 1.0]));
    assert_eq!(
        (e.kind, e.axis, e.faces),
        (SolidKind::Box, 2, Emitter::END_NEG)
    );
    assert_eq!(e.part_names(), ["bottom"]);
    assert!((2.0 * e.half[0] - 0.614).abs() < 5e-4 && (2.0 * e.half[1] - 0.063).abs() < 5e-4);
    assert_eq!(e.half[2], 0.0);
    // rw_4: a vertical cylinder 0.318 m across, 0.035 m high.
    let e = read(&rw, "rw_4.IES").emitter().unwrap();
    assert_eq!((e.kind, e.axis), (SolidKind::Cylinder, 2));
    assert!(e.faces & Emitter::SIDES != 0 && (2.0 * e.half[2] - 0.035).abs() < 5e-4);
    // A type B floodlight: its opening faces the beam (+X), width lateral, length vertical.
    let p = read(&rw, "rw_flood_2.2.ies");
    let e = p.emitter().unwrap();
    assert_eq!(
        (e.kind, e.axis, e.faces),
        (SolidKind::Box, 0, Emitter::END_POS)
    );
    assert_eq!(e.part_names(), ["+x"]);
    let o = p.luminous_opening();
    assert_eq!(e.half, [o.width / 2.0, o.length / 2.0, 0.0]); // u = Y, v = Z
    assert!(e.projected_area([1.0, 0.0, 0.0]) > 0.0);
}

#[test]
fn the_luxpy_pair_disagrees_and_the_ldt_reading_is_right() {
    let Some(dir) = shared("the_luxpy_pair_disagrees_and_the_ldt_reading_is_right") else {
        return;
    };
    let ldt = read(&dir, "luxpy_test_lid_file.ldt");
    let ies = read(&dir, "luxpy_test_lid_file.ies");
    // The LDT's luminous area: length 80 mm (along C0), width 1966 mm (along C90).
    let e = ldt.emitter().unwrap();
    assert_eq!(e.axis, 2);
    assert!((e.half[0] - 0.040).abs() < 1e-12 && (e.half[1] - 0.983).abs() < 1e-12);
    // The converted IES file names the 1966 mm its length, along C0.
    let f = ies.emitter().unwrap();
    assert!((f.half[0] - 0.983).abs() < 1e-12 && (f.half[1] - 0.040).abs() < 1e-12);
    // The data: a batwing in C0 (peak near 60°), narrower in C90 — the plane across an
    // extruded linear lens is C0, so the run lies along C90, as the LDT says.
    assert!(ldt.intensity_at(60.0, 0.0) > 1.2 * ldt.intensity_at(0.0, 0.0));
    assert!(ldt.intensity_at(60.0, 90.0) < ldt.intensity_at(0.0, 90.0));
}

#[test]
fn ldt_heights_make_luminous_sides_with_the_largest_height() {
    let Some(dir) = shared("ldt_heights_make_luminous_sides_with_the_largest_height") else {
        return;
    };
    let text = std::fs::read_to_string(dir.join("luxpy_test_lid_file.ldt")).unwrap();
    let eol = if text.contains("\r\n") { "\r\n" } else { "\n" };
    let mut lines: Vec<String> = text.split(eol).map(str::to_owned).collect();
    // Lines 18–21: heights at C0, C90, C180, C270.
    for (k, h) in [(17, "0"), (18, "30"), (19, "12"), (20, "0")] {
        lines[k] = h.to_owned();
    }
    let p = Photometry::parse(lines.join(eol).as_bytes()).unwrap();
    let o = p.luminous_opening();
    assert_eq!(o.shape, OpeningShape::RectangularWithLuminousSides);
    assert!((o.height - 0.030).abs() < 1e-12);
    let e = p.emitter().unwrap();
    assert_eq!(
        (e.faces & Emitter::SIDES, e.half[2]),
        (Emitter::SIDES, 0.015)
    );
    // Width 0: a round area of diameter `length`, a vertical cylinder with the height.
    lines[16] = "0".to_owned();
    let p = Photometry::parse(lines.join(eol).as_bytes()).unwrap();
    let o = p.luminous_opening();
    assert_eq!(o.shape, OpeningShape::VerticalCylinder);
    assert!((o.width - 0.080).abs() < 1e-12 && (o.length - 0.080).abs() < 1e-12);
    // The header keeps all four heights and writes them back.
    assert_eq!(p.ldt().unwrap().luminous_height_mm, [0.0, 30.0, 12.0, 0.0]);
    let back = Photometry::parse(p.to_ldt().unwrap().as_bytes()).unwrap();
    assert_eq!(back.luminous_opening(), o);
}
