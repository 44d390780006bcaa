//! One test per reading rule, on small hand-made files with known answers.

use luxbake_ies::{
    Format, IesError, IesVersion, Limits, OpeningShape, ParseOptions, PhotometricType, Photometry,
    Symmetry, Tilt, Units,
};
use std::f64::consts::PI;

/// An LM-63 file: `head` (version line and keywords), `tilt` (the TILT line and any data),
/// the two header lines and the angle/candela data.
fn ies(head: &str, tilt: &str, header: &str, data: &str) -> String {
    format!("{head}\n{tilt}\n{header}\n1 1 50\n{data}\n")
}

/// A 2002 type C file with `nv` vertical, `nh` horizontal angles.
fn type_c(v: &[f64], h: &[f64], cd: &[f64]) -> String {
    let list = |x: &[f64]| {
        x.iter()
            .map(|a| a.to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    ies(
        "IESNA:LM-63-2002\n[TEST] t",
        "TILT=NONE",
        &format!("1 1000 1 {} {} 1 2 0 0 0", v.len(), h.len()),
        &format!("{}\n{}\n{}", list(v), list(h), list(cd)),
    )
}

/// The header line of one 1000 lm lamp, multiplier 1, two vertical angles and one plane, type
/// C, metres.
const HEADER: &str = "1 1000 1 2 1 1 2 0 0 0";

/// A file of one plane at γ 0 and 90° (100 cd at the nadir, none at 90°) with `head`, `tilt`
/// and the header line `header`.
fn nadir(head: &str, tilt: &str, header: &str) -> String {
    ies(head, tilt, header, "0 90\n0\n100 0")
}

fn parse(s: &str) -> Photometry {
    Photometry::parse(s.as_bytes()).unwrap_or_else(|e| panic!("{e}\n{s}"))
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs()).max(1.0)
}

const COSINE_1DEG_STEPS: usize = 91;

fn cosine_file(step: usize) -> String {
    let v: Vec<f64> = (0..=90 / step).map(|i| (i * step) as f64).collect();
    let cd: Vec<f64> = v.iter().map(|g| 1000.0 * g.to_radians().cos()).collect();
    type_c(&v, &[0.0], &cd)
}

// ---------------------------------------------------------------- versions and header lines

#[test]
fn versions_are_recognised() {
    let body = "TILT=NONE\n1 1000 1 2 1 1 2 0 0 0\n1 1 50\n0 90\n0\n100 0\n";
    for (head, format) in [
        ("", Format::Lm63_1986),
        ("IESNA91\n[TEST] a", Format::Lm63_1991),
        ("IESNA:LM-63-1991\n[TEST] a", Format::Lm63_1991),
        ("IESNA:LM-63-1995\n[TEST] a", Format::Lm63_1995),
        ("IESNA:LM-63-2002\n[TEST] a", Format::Lm63_2002),
        ("IES:LM-63-2019\n[TEST] a", Format::Lm63_2019),
    ] {
        let p = parse(&format!("{head}\n{body}"));
        assert_eq!(p.format(), format, "{head}");
        assert_eq!(p.intensity([0.0, 0.0, -1.0]), 100.0);
    }
}

#[test]
fn lm63_1986_label_lines_are_kept() {
    let p = parse(
        "REPORT NUMBER: 1\n  CATALOG NUMBER: x\nTILT=NONE\n1 1000 1 2 1 1 2 0 0 0\n1 1 50\n0 90\n0\n100 0\n",
    );
    assert_eq!(p.format(), Format::Lm63_1986);
    let labels: Vec<_> = p
        .keywords()
        .iter()
        .map(|k| (k.key.as_str(), k.value.as_str()))
        .collect();
    assert_eq!(
        labels,
        [("", "REPORT NUMBER: 1"), ("", "CATALOG NUMBER: x")]
    );
}

#[test]
fn lm63_2019_file_generation_type_is_not_a_multiplier() {
    let text = nadir(
        "IES:LM-63-2019\n[TEST] a\n[FILEGENINFO] made by hand\n[ISSUEDATE] 2024-01-01",
        "TILT=NONE",
        "1 -1 1 2 1 1 2 0 0 0",
    )
    .replace("1 1 50", "1 1.10001 50");
    let p = parse(&text);
    assert_eq!(p.file_generation_type(), Some(1.10001));
    assert_eq!(p.intensity([0.0, 0.0, -1.0]), 100.0);
    assert_eq!(p.keyword("FILEGENINFO"), Some("made by hand"));
    assert_eq!(p.keyword("issuedate"), Some("2024-01-01"));
}

#[test]
fn ballast_lamp_factor_multiplies_only_in_old_versions() {
    for (head, expect) in [
        ("IESNA91\n[TEST] a", 50.0),
        ("IESNA:LM-63-2002\n[TEST] a", 100.0),
    ] {
        let text = nadir(head, "TILT=NONE", HEADER).replace("1 1 50", "1 0.5 50");
        assert_eq!(parse(&text).intensity([0.0, 0.0, -1.0]), expect, "{head}");
    }
}

#[test]
fn multipliers_and_header_values() {
    let text = nadir(
        "IESNA:LM-63-2002\n[TEST] a",
        "TILT=NONE",
        "3 1200 2.5 2 1 1 1 -0.5 -0.5 0",
    )
    .replace("1 1 50", "0.8 1 42.5");
    let p = parse(&text);
    assert_eq!(p.lamp_count(), 3);
    assert_eq!(p.lumens_per_lamp(), Some(1200.0));
    assert_eq!(p.lumens_header(), Some(3600.0));
    assert_eq!(p.candela_multiplier(), 2.5);
    assert_eq!(p.ballast_factor(), 0.8);
    assert_eq!(p.input_watts(), 42.5);
    assert_eq!(p.units(), Units::Feet);
    assert_eq!(p.photometric_type(), PhotometricType::C);
    assert_eq!(p.intensity([0.0, 0.0, -1.0]), 100.0 * 2.5 * 0.8);
    let o = p.luminous_opening();
    assert_eq!(o.shape, OpeningShape::Circular);
    assert!(close(o.width, 0.1524, 1e-12));
    // Absolute photometry.
    let abs = parse(&type_c(&[0.0, 90.0], &[0.0], &[1.0, 0.0]).replace("1 1000 1", "1 -1 1"));
    assert_eq!(abs.lumens_per_lamp(), None);
    assert_eq!(abs.lumens_header(), None);
    assert_eq!(abs.flux_ratio(), None);
}

#[test]
fn opening_shapes_follow_the_signs() {
    use OpeningShape as S;
    use luxbake_ies::LuminousOpening as L;
    for ((w, l, h), shape) in [
        ((0.0, 0.0, 0.0), S::Point),
        ((1.0, 2.0, 0.0), S::Rectangular),
        ((1.0, 2.0, 0.5), S::RectangularWithLuminousSides),
        ((-1.0, -1.0, 0.0), S::Circular),
        ((-1.0, -2.0, 0.0), S::Ellipse),
        ((-1.0, -1.0, 2.0), S::VerticalCylinder),
        ((-1.0, -2.0, 2.0), S::VerticalEllipticalCylinder),
        ((-1.0, -1.0, -1.0), S::Sphere),
        ((-1.0, -2.0, -3.0), S::Ellipsoid),
        ((-1.0, 2.0, -1.0), S::HorizontalCylinderAlong0),
        ((-1.0, 2.0, -3.0), S::HorizontalEllipticalCylinderAlong0),
        ((2.0, -1.0, -1.0), S::HorizontalCylinderAlong90),
        ((2.0, -1.0, -3.0), S::HorizontalEllipticalCylinderAlong90),
        ((-1.0, 0.0, -1.0), S::VerticalCircleFacing0),
        ((-1.0, 0.0, -2.0), S::VerticalEllipseFacing0),
        ((0.0, -1.0, -1.0), S::VerticalCircleFacing90),
        ((0.0, -1.0, -2.0), S::VerticalEllipseFacing90),
        ((1.0, 0.0, 0.0), S::Other),
    ] {
        assert_eq!(
            L::from_signed(w, l, h, Units::Meters).shape,
            shape,
            "{w} {l} {h}"
        );
    }
}

// ---------------------------------------------------------------- keywords and text

#[test]
fn keywords_in_order_with_more_joined() {
    let p = parse(&nadir(
        "IESNA:LM-63-2002\n[TEST] T1  \n[LUMINAIRE] first line\n[MORE] second line\n[_CUSTOM]x\n[TEST] again",
        "TILT=NONE",
        HEADER,
    ));
    let kw: Vec<_> = p
        .keywords()
        .iter()
        .map(|k| (k.key.as_str(), k.value.as_str()))
        .collect();
    assert_eq!(
        kw,
        [
            ("TEST", "T1"),
            ("LUMINAIRE", "first line\nsecond line"),
            ("_CUSTOM", "x"),
            ("TEST", "again")
        ]
    );
    assert!(p.warnings().is_empty());
}

#[test]
fn stray_lines_in_the_keyword_block_are_warnings() {
    let p = parse(&nadir(
        "IESNA:LM-63-2002\n[MORE] orphan\nno brackets here",
        "TILT=NONE",
        HEADER,
    ));
    assert_eq!(p.warnings().len(), 2);
    assert_eq!(p.warnings()[0].line, 2);
    assert_eq!(p.warnings()[1].line, 3);
}

#[test]
fn crlf_lf_cr_and_wrapping_and_commas_read_the_same() {
    let base = parse(&type_c(
        &[0.0, 45.0, 90.0],
        &[0.0, 90.0],
        &[10.0, 5.0, 0.0, 12.0, 6.0, 0.0],
    ));
    let variants = [
        type_c(&[0.0, 45.0, 90.0], &[0.0, 90.0], &[10.0, 5.0, 0.0, 12.0, 6.0, 0.0]).replace('\n', "\r\n"),
        type_c(&[0.0, 45.0, 90.0], &[0.0, 90.0], &[10.0, 5.0, 0.0, 12.0, 6.0, 0.0]).replace('\n', "\r"),
        "IESNA:LM-63-2002\n[TEST] t\nTILT=NONE\n1\n1000 1 3\n2 1 2 0\n0 0 1\n1 50 0,45,\n90 0\n,90 10 5 0\n12\n6\n0\n".into(),
    ];
    for v in variants {
        let p = parse(&v);
        assert_eq!(p.vertical_angles(), base.vertical_angles());
        assert_eq!(p.horizontal_angles(), base.horizontal_angles());
        assert_eq!(p.candela_row(1), base.candela_row(1));
    }
}

#[test]
fn latin1_and_utf8_text() {
    let mut bytes = b"IESNA:LM-63-2002\n[LUMINAIRE] 30\xB0 beam\n".to_vec();
    bytes.extend_from_slice(b"TILT=NONE\n1 1000 1 2 1 1 2 0 0 0\n1 1 50\n0 90\n0\n100 0\n");
    assert_eq!(
        Photometry::parse(&bytes).unwrap().keyword("LUMINAIRE"),
        Some("30° beam")
    );
    let utf8 = "IESNA:LM-63-2002\n[LUMINAIRE] 30° beam\nTILT=NONE\n1 1000 1 2 1 1 2 0 0 0\n1 1 50\n0 90\n0\n100 0\n";
    assert_eq!(parse(utf8).keyword("LUMINAIRE"), Some("30° beam"));
    let bom = format!("\u{FEFF}{utf8}");
    assert_eq!(parse(&bom).format(), Format::Lm63_2002);
}

#[test]
fn trailing_garbage_is_a_warning_with_its_line() {
    let text = type_c(&[0.0, 90.0], &[0.0], &[100.0, 0.0]) + "\n\nEND OF FILE\n";
    let p = parse(&text);
    assert_eq!(p.warnings().len(), 1);
    assert_eq!(p.warnings()[0].line, 11);
    assert!(p.warnings()[0].message.contains("END"));
}

// ---------------------------------------------------------------- tilt

const TILT_BLOCK: &str = "TILT=INCLUDE\n1\n3\n0 45 90\n1 0.8 0.5";

#[test]
fn tilt_include_is_parsed_and_applied() {
    let p = parse(&nadir("IESNA:LM-63-2002\n[TEST] a", TILT_BLOCK, HEADER));
    let Tilt::Include(d) = p.tilt() else {
        panic!("{:?}", p.tilt())
    };
    assert_eq!(d.lamp_geometry, 1);
    assert_eq!(d.angles, [0.0, 45.0, 90.0]);
    assert_eq!(d.factors, [1.0, 0.8, 0.5]);
    let down = [0.0, 0.0, -1.0];
    assert_eq!(p.intensity(down), 100.0);
    assert_eq!(p.intensity_tilted(down, 45.0), 80.0);
    assert!(close(p.intensity_tilted(down, 67.5), 65.0, 1e-12));
    assert_eq!(p.intensity_tilted(down, 120.0), 50.0);
    assert_eq!(p.tilt().factor(-5.0), 1.0);
}

/// Every tilted query scales by the factor interpolated at the tilt: the flux, the peak and
/// each value of the shaders' table (at 0° the untilted queries).
#[test]
fn tilted_queries_scale_by_the_interpolated_factor() {
    let p = parse(&ies(
        "IESNA:LM-63-2002\n[TEST] a",
        TILT_BLOCK,
        "1 1000 1 3 1 1 2 0 0 0",
        "0 45 90\n0\n100 60 0",
    ));
    let (flux, (peak, peak_dir), table) = (p.luminous_flux(), p.max_intensity(), p.gpu_table());
    assert_eq!(p.gpu_table_tilted(0.0), table);
    // 30°: two thirds of the way from 1 to 0.8; 45° a listed angle; 120° past the last one.
    for (tilt, factor) in [(30.0, 1.0 - 0.2 * 30.0 / 45.0), (45.0, 0.8), (120.0, 0.5)] {
        assert!(close(p.tilt().factor(tilt), factor, 1e-12), "{tilt}");
        assert!(close(p.luminous_flux_tilted(tilt), flux * factor, 1e-12));
        let (m, dir) = p.max_intensity_tilted(tilt);
        assert!(close(m, peak * factor, 1e-12) && dir == peak_dir);
        let tilted = p.gpu_table_tilted(tilt);
        assert_eq!((tilted.width, tilted.height), (table.width, table.height));
        for (a, b) in tilted.values.iter().zip(&table.values) {
            assert!((f64::from(*a) - f64::from(*b) * factor).abs() <= 1e-5 * f64::from(*b));
        }
        let d = [0.3, 0.1, -0.8];
        assert!(close(
            p.intensity_tilted(d, tilt),
            p.intensity(d) * factor,
            1e-12
        ));
    }
}

#[test]
fn tilt_file_needs_a_resolver() {
    let text = nadir("IESNA:LM-63-2002\n[TEST] a", "TILT=lamp.tlt", HEADER);
    match Photometry::parse(text.as_bytes()) {
        Err(e @ IesError::TiltFileUnresolved { line: 3, .. }) => {
            assert!(e.to_string().contains("lamp.tlt"), "{e}")
        }
        other => panic!("{other:?}"),
    }
    let resolver = |name: &str| (name == "lamp.tlt").then(|| b"2\n2\n0 90\n1 0.5\n".to_vec());
    let options = ParseOptions {
        tilt_resolver: Some(&resolver),
        ..ParseOptions::default()
    };
    let p = Photometry::parse_with(text.as_bytes(), &options).unwrap();
    match p.tilt() {
        Tilt::File { name, data } => {
            assert_eq!(name, "lamp.tlt");
            assert_eq!(data.lamp_geometry, 2);
            assert_eq!(data.factors, [1.0, 0.5]);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(p.intensity_tilted([0.0, 0.0, -1.0], 90.0), 50.0);
    // Written out, the tilt data is included so the file stands alone.
    let written = p.to_ies(IesVersion::Lm63_2002);
    assert!(matches!(parse(&written).tilt(), Tilt::Include(_)));
    // A resolver that does not know the file, and a malformed tilt file.
    let unknown = |_: &str| None;
    let options = ParseOptions {
        tilt_resolver: Some(&unknown),
        ..ParseOptions::default()
    };
    assert!(matches!(
        Photometry::parse_with(text.as_bytes(), &options),
        Err(IesError::TiltFileUnresolved { .. })
    ));
    let bad = |_: &str| Some(b"2\n2\n0 x\n".to_vec());
    let options = ParseOptions {
        tilt_resolver: Some(&bad),
        ..ParseOptions::default()
    };
    match Photometry::parse_with(text.as_bytes(), &options) {
        Err(IesError::TiltFile { name, source }) => {
            assert_eq!(name, "lamp.tlt");
            assert_eq!(source.line(), Some(3));
        }
        other => panic!("{other:?}"),
    }
}

// ---------------------------------------------------------------- frame and symmetry

/// A 2002 file of photometric type `t` (3: A, 2: B) with V −90, 0, 90, the H angles `h` (three)
/// and the candela 1 to 9.
fn type_ab(t: u32, h: &str) -> Photometry {
    parse(&ies(
        "IESNA:LM-63-2002\n[TEST] a",
        "TILT=NONE",
        &format!("1 -1 1 3 3 {t} 2 0 0 0"),
        &format!("-90 0 90\n{h}\n1 2 3\n4 5 6\n7 8 9"),
    ))
}

/// `p`'s intensity toward each direction is exactly its value.
fn assert_intensities(p: &Photometry, cases: &[([f64; 3], f64)]) {
    for &(d, want) in cases {
        assert_eq!(p.intensity(d), want, "{d:?}");
    }
}

/// `p.direction_at(a, b)` is `want` to 1e-15.
fn assert_direction(p: &Photometry, (a, b): (f64, f64), want: [f64; 3]) {
    let d = p.direction_at(a, b);
    for k in 0..3 {
        assert!((d[k] - want[k]).abs() < 1e-15, "{a} {b}: {d:?} vs {want:?}");
    }
}

/// Type C direction formula: d(γ, C) = (sin γ cos C, sin γ sin C, −cos γ).
#[test]
fn type_c_frame() {
    // A distinct value per plane at γ = 90° shows where each plane points.
    let p = parse(&type_c(
        &[0.0, 90.0],
        &[0.0, 90.0, 180.0, 270.0, 360.0],
        &[5.0, 1.0, 5.0, 2.0, 5.0, 3.0, 5.0, 4.0, 5.0, 1.0],
    ));
    assert_eq!(p.symmetry(), Symmetry::Full);
    assert_intensities(
        &p,
        &[
            ([1.0, 0.0, 0.0], 1.0),  // C0 → +X
            ([0.0, 2.0, 0.0], 2.0),  // C90 → +Y
            ([-1.0, 0.0, 0.0], 3.0), // C180 → −X
            ([0.0, -1.0, 0.0], 4.0), // C270 → −Y
            ([0.0, 0.0, -3.0], 5.0), // nadir → −Z
            ([0.0, 0.0, 1.0], 0.0),  // zenith, not measured
        ],
    );
    for (g, c) in [(30.0_f64, 40.0_f64), (120.0, 300.0)] {
        let (gr, cr) = (g.to_radians(), c.to_radians());
        assert_direction(
            &p,
            (g, c),
            [gr.sin() * cr.cos(), gr.sin() * cr.sin(), -gr.cos()],
        );
    }
}

/// Type A: V elevation (+Z up), H plane about +Z, photometric axis +X.
#[test]
fn type_a_frame() {
    let p = type_ab(3, "-90 0 90");
    assert_eq!(p.photometric_type(), PhotometricType::A);
    assert_eq!(p.symmetry(), Symmetry::NoneAB);
    assert_intensities(
        &p,
        &[
            ([1.0, 0.0, 0.0], 5.0),  // V 0, H 0: the photometric axis
            ([0.0, 1.0, 0.0], 8.0),  // H +90 → +Y
            ([0.0, -1.0, 0.0], 2.0), // H −90 → −Y
            ([-1.0, 0.0, 0.0], 0.0), // behind: not measured
        ],
    );
    assert!(close(p.intensity([0.0, 0.0, 1.0]), 6.0, 1e-12)); // V +90 → +Z (pole: mean of 3, 6, 9)
    assert!(close(
        p.intensity_at(30.0, 20.0),
        p.intensity(p.direction_at(30.0, 20.0)),
        1e-12
    ));
    let (v, h) = (30f64.to_radians(), 20f64.to_radians());
    assert_direction(
        &p,
        (30.0, 20.0),
        [v.cos() * h.cos(), v.cos() * h.sin(), v.sin()],
    );
}

/// Type B: V plane about the transverse axis +Y (positive up toward +Z), H lateral (+Y).
#[test]
fn type_b_frame() {
    let p = type_ab(2, "-90 0 90");
    assert_eq!(p.photometric_type(), PhotometricType::B);
    assert_intensities(
        &p,
        &[
            ([1.0, 0.0, 0.0], 5.0),  // photometric axis +X
            ([0.0, 0.0, 1.0], 6.0),  // V +90 → +Z
            ([0.0, 0.0, -1.0], 4.0), // V −90 → −Z
            ([-1.0, 0.0, 0.0], 0.0),
        ],
    );
    assert!(close(p.intensity([0.0, 1.0, 0.0]), 8.0, 1e-12)); // H +90 → +Y (pole: mean 7 8 9)
    let (v, h) = (30f64.to_radians(), 20f64.to_radians());
    assert_direction(
        &p,
        (30.0, 20.0),
        [h.cos() * v.cos(), h.sin(), h.cos() * v.sin()],
    );
}

#[test]
fn type_a_and_b_lateral_symmetry_mirrors() {
    for t in [3, 2] {
        let p = type_ab(t, "0 45 90");
        assert_eq!(p.symmetry(), Symmetry::Lateral);
        for (v, h) in [(10.0, 30.0), (-40.0, 70.0), (0.0, 45.0)] {
            let a = p.intensity_at(v, h);
            assert!(close(a, p.intensity_at(v, -h), 1e-12), "type {t} {v} {h}");
        }
        assert_eq!(p.intensity_at(0.0, 45.0), 5.0);
        assert_eq!(p.intensity_at(0.0, -45.0), 5.0);
    }
}

#[test]
fn type_c_symmetries_expand() {
    let v = [0.0, 45.0, 90.0];
    // Three planes `h`, γ 0, 45 and 90 each: 9 at the nadir, 1, 2 and 3 at 45°, 0 at 90°.
    let planes = |h: &[f64]| {
        parse(&type_c(
            &v,
            h,
            &[9.0, 1.0, 0.0, 9.0, 2.0, 0.0, 9.0, 3.0, 0.0],
        ))
    };
    // 0–90: quadrant.
    let q = planes(&[0.0, 30.0, 90.0]);
    assert_eq!(q.symmetry(), Symmetry::Quadrant);
    for c in [30.0, 150.0, 210.0, 330.0] {
        assert!(close(q.intensity_at(45.0, c), 2.0, 1e-12), "{c}");
    }
    // 0–180: mirror about the 0–180 plane.
    let b = planes(&[0.0, 60.0, 180.0]);
    assert_eq!(b.symmetry(), Symmetry::Bilateral0To180);
    assert!(close(b.intensity_at(45.0, 300.0), 2.0, 1e-12));
    assert!(close(b.intensity_at(45.0, 60.0), 2.0, 1e-12));
    // 90–270: mirror about the 90–270 plane (C ↦ 180 − C).
    let m = planes(&[90.0, 120.0, 270.0]);
    assert_eq!(m.symmetry(), Symmetry::Bilateral90To270);
    assert!(close(m.intensity_at(45.0, 60.0), 2.0, 1e-12));
    assert!(close(m.intensity_at(45.0, 120.0), 2.0, 1e-12));
    assert!(close(
        m.intensity_at(45.0, 0.0),
        m.intensity_at(45.0, 180.0),
        1e-12
    ));
    // One plane: rotational.
    let r = parse(&type_c(&v, &[0.0], &[9.0, 2.0, 0.0]));
    assert_eq!(r.symmetry(), Symmetry::Rotational);
    for c in [0.0, 77.0, 181.0, 359.0] {
        assert!(close(r.intensity_at(45.0, c), 2.0, 1e-12));
    }
    // 0 to less than 360: wraps from the last plane back to 0.
    let w = parse(&type_c(
        &v,
        &[0.0, 120.0, 240.0],
        &[9.0, 0.0, 0.0, 9.0, 3.0, 0.0, 9.0, 6.0, 0.0],
    ));
    assert_eq!(w.symmetry(), Symmetry::Full);
    assert!(close(w.intensity_at(45.0, 300.0), 3.0, 1e-12));
    // Not a known range.
    let bad = Photometry::parse(type_c(&v, &[10.0, 90.0], &[0.0; 6]).as_bytes());
    assert!(
        matches!(bad, Err(IesError::UnsupportedAngles { line: 7, .. })),
        "{bad:?}"
    );
}

#[test]
fn vertical_ranges() {
    let lower = parse(&type_c(&[0.0, 90.0], &[0.0], &[10.0, 10.0]));
    assert_eq!(lower.intensity_at(90.0, 0.0), 10.0);
    assert_eq!(lower.intensity_at(90.5, 0.0), 0.0);
    let upper = parse(&type_c(&[90.0, 180.0], &[0.0], &[10.0, 10.0]));
    assert_eq!(upper.intensity_at(89.5, 0.0), 0.0);
    assert_eq!(upper.intensity([0.0, 0.0, 1.0]), 10.0);
    assert!(close(upper.luminous_flux(), 20.0 * PI, 1e-12));
    let full = parse(&type_c(&[0.0, 180.0], &[0.0], &[10.0, 10.0]));
    assert!(close(full.luminous_flux(), 40.0 * PI, 1e-12));
}

#[test]
fn continuous_at_poles_and_seams() {
    // Nadir values disagree between planes; the 360° plane disagrees with the 0° plane.
    let p = parse(&type_c(
        &[0.0, 10.0, 90.0],
        &[0.0, 90.0, 180.0, 270.0, 360.0],
        &[
            8.0, 5.0, 0.0, 10.0, 6.0, 0.0, 12.0, 7.0, 0.0, 10.0, 6.0, 0.0, 10.0, 9.0, 0.0,
        ],
    ));
    let nadir = p.intensity([0.0, 0.0, -1.0]);
    for c in [0.0, 45.0, 123.0, 300.0] {
        let near = p.intensity_at(1e-7, c);
        assert!((near - nadir).abs() < 1e-5, "{c}: {near} vs {nadir}");
    }
    let (a, b) = (
        p.intensity_at(10.0, 1e-7),
        p.intensity_at(10.0, 360.0 - 1e-7),
    );
    assert!((a - b).abs() < 1e-6, "{a} {b}");
    assert_eq!(p.intensity_at(10.0, 0.0), 7.0); // mean of the 0° and 360° planes
}

// ---------------------------------------------------------------- closed forms

#[test]
fn cosine_flux_is_pi_i0() {
    for (step, tol) in [(5, 1e-3), (1, 5e-5)] {
        let p = parse(&cosine_file(step));
        let rel = p.luminous_flux() / (1000.0 * PI) - 1.0;
        println!("cos, {step}° steps: relative flux error {rel:+.2e}");
        assert!(rel.abs() < tol, "{step}: {rel}");
    }
    assert_eq!(
        parse(&cosine_file(1)).vertical_angles().len(),
        COSINE_1DEG_STEPS
    );
}

#[test]
fn isotropic_flux_is_four_pi_i0() {
    let p = Photometry::isotropic(100.0);
    assert!(close(p.luminous_flux(), 400.0 * PI, 1e-14));
    assert_eq!(p.lumens_header(), Some(400.0 * PI));
    for d in [
        [1.0, 2.0, 3.0],
        [0.0, 0.0, -1.0],
        [-1e-300, 0.0, 0.0],
        [1e300, 1e300, 0.0],
    ] {
        assert_eq!(p.intensity(d), 100.0);
    }
    assert_eq!(p.intensity([0.0; 3]), 0.0);
    assert_eq!(p.intensity([f64::NAN, 0.0, 1.0]), 0.0);
    assert_eq!(p.intensity([f64::INFINITY, 0.0, 1.0]), 0.0);
    assert_eq!(Photometry::isotropic(f64::NAN).luminous_flux(), 0.0);
    let file = parse(&type_c(&[0.0, 90.0, 180.0], &[0.0], &[7.0, 7.0, 7.0]));
    assert!(close(file.luminous_flux(), 28.0 * PI, 1e-14));
}

#[test]
fn max_intensity_and_direction() {
    let p = parse(&type_c(
        &[0.0, 30.0, 90.0],
        &[0.0, 90.0],
        &[5.0, 9.0, 0.0, 5.0, 7.0, 0.0],
    ));
    let (cd, d) = p.max_intensity();
    assert_eq!(cd, 9.0);
    let g = 30f64.to_radians();
    // Quadrant-symmetric: the first of the equal maxima, C 0° (+X).
    assert!((d[0] - g.sin()).abs() < 1e-12 && d[1].abs() < 1e-12 && (d[2] + g.cos()).abs() < 1e-12);
}

// ---------------------------------------------------------------- errors

#[test]
fn errors_name_the_line_and_what_was_expected() {
    let good = type_c(&[0.0, 90.0], &[0.0], &[100.0, 0.0]);
    let cases: Vec<(String, usize)> = vec![
        (good.replace("100 0", "100 x"), 8),
        (good.replace("100 0", "100 NaN"), 8),
        (good.replace("100 0", "100 inf"), 8),
        (good.replace("100 0", "100"), 8),
        (good.replace("1 1000 1 2 1 1 2", "1 1000 1 2.5 1 1 2"), 4),
        (good.replace("1 1000 1 2 1 1 2", "1 1000 1 2 1 4 2"), 4),
        (good.replace("1 1000 1 2 1 1 2", "1 1000 1 2 1 1 3"), 4),
        (good.replace("1 1000 1 2 1 1 2", "1 -5 1 2 1 1 2"), 4),
        (good.replace("0 90\n0\n", "0 -90\n0\n"), 6),
        (good.replace("0 90\n0\n", "-10 90\n0\n"), 6),
        (good.replace("0 90\n0\n", "0 190\n0\n"), 6),
        (good.replace("100 0", "-100 0"), 8),
    ];
    for (text, line) in cases {
        let e = Photometry::parse(text.as_bytes()).expect_err(&text);
        assert_eq!(e.line(), Some(line), "{e}\n{text}");
        assert!(e.to_string().starts_with(&format!("line {line}:")), "{e}");
    }
    assert!(matches!(
        Photometry::parse(b"IESNA:LM-63-2002\n[TEST] x\n"),
        Err(IesError::MissingTilt)
    ));
    assert!(matches!(Photometry::parse(b"  \n\n"), Err(IesError::Empty)));
    assert!(matches!(
        Photometry::parse(good.replace("0 90\n0\n", "90 0\n0\n").as_bytes()),
        Err(IesError::NotIncreasing { line: 6, .. })
    ));
}

#[test]
fn absurd_counts_hit_the_limits() {
    let good = type_c(&[0.0, 90.0], &[0.0], &[100.0, 0.0]);
    for (header, what) in [
        ("1 1000 1 1000000000 1 1 2", "vertical"),
        ("1 1000 1 4000 4000 1 2", "candela"),
    ] {
        let text = good.replace("1 1000 1 2 1 1 2", header);
        match Photometry::parse(text.as_bytes()) {
            Err(e @ IesError::LimitExceeded { line: 4, .. }) => {
                assert!(e.to_string().contains(what), "{e}")
            }
            other => panic!("{other:?}"),
        }
    }
    let small = ParseOptions {
        limits: Limits {
            max_bytes: 10,
            ..Limits::default()
        },
        ..ParseOptions::default()
    };
    assert!(matches!(
        Photometry::parse_with(good.as_bytes(), &small),
        Err(IesError::TooLarge { limit: 10, .. })
    ));
    let tilt = ies(
        "IESNA:LM-63-2002",
        "TILT=INCLUDE\n1\n99999999\n0",
        "1 1 1 2 1 1 2 0 0 0",
        "",
    );
    assert!(matches!(
        Photometry::parse(tilt.as_bytes()),
        Err(IesError::LimitExceeded { .. })
    ));
}

// ---------------------------------------------------------------- EULUMDAT

/// A EULUMDAT file with `mc` planes every `360/mc`°, γ 0..180 every `dg`°, and the stored
/// planes' intensities from `value(c, g)` in cd/klm; 1000 lm lamp, LORL 100 %.
fn ldt(isym: u8, mc: usize, dg: f64, value: impl Fn(f64, f64) -> f64) -> String {
    let dc = 360.0 / mc as f64;
    let ng = (180.0 / dg) as usize + 1;
    let mut s = format!("Acme\n1\n{isym}\n{mc}\n{dc}\n{ng}\n{dg}\nR1\nLum\nL-1\nf.ldt\n2024\n");
    s += "100\n0\n50\n80\n0\n0\n0\n0\n0\n100\n100\n1\n0\n1\n1\nLED\n1000\n3000K\n90\n10\n";
    for _ in 0..10 {
        s += "0.5\n";
    }
    let cs: Vec<f64> = (0..mc).map(|i| i as f64 * dc).collect();
    for c in &cs {
        s += &format!("{c}\n");
    }
    for j in 0..ng {
        s += &format!("{}\n", j as f64 * dg);
    }
    let stored: Vec<f64> = match isym {
        0 => cs.clone(),
        1 => vec![0.0],
        2 => cs[..=mc / 2].to_vec(),
        3 => cs[mc / 4..=3 * mc / 4].to_vec(),
        _ => cs[..=mc / 4].to_vec(),
    };
    for c in stored {
        for j in 0..ng {
            s += &format!("{}\n", value(c, j as f64 * dg));
        }
    }
    s
}

#[test]
fn eulumdat_symmetries_expand_like_lm63() {
    // A distribution with both mirror symmetries, so every Isym describes the same lamp.
    let f = |c: f64, g: f64| {
        let (c, g) = (c.to_radians(), g.to_radians());
        if g > PI / 2.0 {
            0.0
        } else {
            300.0 * g.cos() * (1.0 + 0.3 * (2.0 * c).cos() * g.sin())
        }
    };
    let full = parse(&ldt(0, 24, 5.0, f));
    assert_eq!(full.format(), Format::Eulumdat);
    assert_eq!(full.symmetry(), Symmetry::Full);
    assert_eq!(full.candela_multiplier(), 1.0);
    assert_eq!(full.lumens_header(), Some(1000.0));
    assert_eq!(full.keyword("MANUFAC"), Some("Acme"));
    let ldt_info = full.ldt().unwrap();
    assert_eq!(ldt_info.lamp_sets[0].watts, 10.0);
    assert_eq!(full.luminous_opening().shape, OpeningShape::Circular);
    for (isym, sym) in [
        (2, Symmetry::Bilateral0To180),
        (3, Symmetry::Bilateral90To270),
        (4, Symmetry::Quadrant),
    ] {
        let p = parse(&ldt(isym, 24, 5.0, f));
        assert_eq!(p.symmetry(), sym);
        for (g, c) in [
            (20.0, 10.0),
            (45.0, 100.0),
            (70.0, 200.0),
            (85.0, 275.0),
            (30.0, 345.0),
        ] {
            let (a, b) = (p.intensity_at(g, c), full.intensity_at(g, c));
            assert!(close(a, b, 1e-12), "Isym {isym} at {g} {c}: {a} vs {b}");
        }
    }
    let rot = parse(&ldt(1, 24, 5.0, |_, _| 100.0));
    assert_eq!(rot.symmetry(), Symmetry::Rotational);
    assert!(close(rot.luminous_flux(), 400.0 * PI, 1e-12));
    // Written as LM-63, the same intensities.
    let back = parse(&full.to_ies(IesVersion::Lm63_2002));
    for (g, c) in [(20.0, 10.0), (45.0, 100.0), (89.0, 300.0)] {
        assert!(close(
            back.intensity_at(g, c),
            full.intensity_at(g, c),
            1e-12
        ));
    }
}

#[test]
fn eulumdat_errors() {
    let good = ldt(4, 24, 5.0, |_, _| 1.0);
    assert!(Photometry::parse(good.as_bytes()).is_ok());
    let bad_isym = good.replacen("Acme\n1\n4\n", "Acme\n1\n7\n", 1);
    assert_eq!(
        Photometry::parse(bad_isym.as_bytes()).unwrap_err().line(),
        Some(3)
    );
    let bad_mc = ldt(3, 22, 5.0, |_, _| 1.0);
    assert!(matches!(
        Photometry::parse(bad_mc.as_bytes()),
        Err(IesError::UnsupportedAngles { .. })
    ));
    let decimal_comma = good.replace("\n0.5\n", "\n0,5\n");
    assert_eq!(parse(&decimal_comma).ldt().unwrap().direct_ratios[0], 0.5);
    let garbage = good.clone() + "extra\n";
    assert_eq!(parse(&garbage).warnings().len(), 1);
    let truncated = &good[..good.len() / 2];
    assert!(matches!(
        Photometry::parse(truncated.as_bytes()),
        Err(IesError::UnexpectedEof { .. } | IesError::Syntax { .. })
    ));
}

/// The one lamp set of [`ldt`] (lamps, type, flux, colour, CRI, watts).
const ONE_SET: &str = "1\n1\nLED\n1000\n3000K\n90\n10\n";
/// Three lamp sets, field by field: 2 + 1 + 1 lamps, 2600 + 1300 + 600 lm, 64 + 32 + 10 W.
const THREE_SETS: &str = "3\n2\n1\n1\nT5\nT5\nLED\n2600\n1300\n600\n3000K\n3000K\n4000K\n\
    80\n80\n90\n64\n32\n10\n";

#[test]
fn eulumdat_lamp_sets_are_all_fitted() {
    let one = parse(&ldt(1, 24, 5.0, |_, _| 100.0));
    let text = ldt(1, 24, 5.0, |_, _| 100.0).replacen(ONE_SET, THREE_SETS, 1);
    let p = parse(&text);
    let sets = &p.ldt().unwrap().lamp_sets;
    assert_eq!(sets.len(), 3);
    assert_eq!(
        sets.iter()
            .map(|s| (
                s.count,
                s.lamp_type.as_str(),
                s.flux,
                s.color.as_str(),
                s.watts
            ))
            .collect::<Vec<_>>(),
        [
            (2, "T5", 2600.0, "3000K", 64.0),
            (1, "T5", 1300.0, "3000K", 32.0),
            (1, "LED", 600.0, "4000K", 10.0)
        ]
    );
    assert_eq!(sets[2].cri, "90");
    // 100 cd/klm of 4500 lm: 450 cd, 4.5 times the one 1000 lm set.
    assert_eq!(p.candela_multiplier(), 4.5);
    assert_eq!(p.intensity_at(30.0, 0.0), 450.0);
    assert!(close(p.luminous_flux(), 4.5 * one.luminous_flux(), 1e-12));
    assert_eq!((p.lamp_count(), p.lumens_header()), (4, Some(4500.0)));
    assert_eq!(
        (p.lumens_per_lamp(), p.input_watts()),
        (Some(1125.0), 106.0)
    );
    assert_eq!(p.keyword("LAMP"), Some("T5\nT5\nLED"));
    // Written as LM-63: the same intensities, lamps, lumens and watts, every lamp type.
    let back = parse(&p.to_ies(IesVersion::Lm63_2002));
    assert_eq!(back.intensity_at(30.0, 0.0), 450.0);
    assert_eq!((back.lamp_count(), back.lumens_header()), (4, Some(4500.0)));
    assert_eq!(back.input_watts(), 106.0);
    assert_eq!(back.keyword("LAMP"), Some("T5\nT5\nLED"));
    // Absolute photometry: negative counts in every set, the intensities still per klm of
    // the total flux.
    let absolute = parse(&text.replacen("3\n2\n1\n1\n", "3\n-2\n-1\n-1\n", 1));
    assert_eq!(absolute.lumens_per_lamp(), None);
    assert_eq!(absolute.intensity_at(30.0, 0.0), 450.0);
}

#[test]
fn eulumdat_inconsistent_lamp_sets_are_errors() {
    let text = ldt(1, 24, 5.0, |_, _| 100.0).replacen(ONE_SET, THREE_SETS, 1);
    let mixed = text.replacen("3\n2\n1\n1\n", "3\n2\n-1\n1\n", 1);
    match Photometry::parse(mixed.as_bytes()) {
        Err(e @ IesError::OutOfRange { line: 28, .. }) => {
            let m = e.to_string();
            assert!(m.contains("lamp set 2") && m.contains("-1"), "{m}");
        }
        other => panic!("{other:?}"),
    }
    // Sums that overflow.
    let huge = text.replacen("\n64\n32\n10\n", "\n1e308\n1e308\n10\n", 1);
    match Photometry::parse(huge.as_bytes()) {
        Err(e @ IesError::OutOfRange { line: 26, .. }) => {
            assert!(e.to_string().contains("total wattage"), "{e}")
        }
        other => panic!("{other:?}"),
    }
    // Fewer sets than announced: the file ends early or a field is read as the wrong one.
    let short = ldt(1, 24, 5.0, |_, _| 100.0).replacen("\n1\n1\nLED\n", "\n2\n1\nLED\n", 1);
    assert!(Photometry::parse(short.as_bytes()).is_err());
}

// ---------------------------------------------------------------- writer

#[test]
fn writer_round_trips_2002_and_2019() {
    let text = ies(
        "IESNA:LM-63-2002\n[TEST] a\n[LUMINAIRE] one\n[MORE] two\n[MORE]",
        TILT_BLOCK,
        "2 850.5 1.25 3 5 1 1 0.5 1.5 0.25",
        "0 45 90\n0 22.5 45 67.5 90\n10 5 0 11 6 0 12 7 0 13 8 0 14 9 0.000001",
    );
    let p = parse(&text);
    assert_eq!(parse(&p.to_ies(IesVersion::Lm63_2002)), p);
    let p19 = parse(&p.to_ies(IesVersion::Lm63_2019));
    assert_eq!(p19.format(), Format::Lm63_2019);
    assert_eq!(parse(&p19.to_ies(IesVersion::Lm63_2019)), p19);
    assert_eq!(p19.keyword("LUMINAIRE"), Some("one\ntwo\n"));
}

#[test]
fn angles_closer_than_a_micro_degree_are_rejected() {
    let close_v = type_c(&[0.0, 1e-9, 90.0], &[0.0], &[1.0, 1.0, 0.0]);
    assert!(matches!(
        Photometry::parse(close_v.as_bytes()),
        Err(IesError::NotIncreasing { line: 6, .. })
    ));
    let close_h = type_c(&[0.0, 90.0], &[0.0, 1e-300, 90.0], &[1.0; 6]);
    assert!(Photometry::parse(close_h.as_bytes()).is_err());
}

/// Type A data lies on a γ/C grid (γ = V + 90°, C = H), so the GPU table holds its nodes
/// exactly; away from the edge of the measured planes (H = ±60° here) it matches to f32
/// rounding.
#[test]
fn gpu_table_for_type_a() {
    let v: Vec<f64> = (0..=12).map(|i| -90.0 + 15.0 * f64::from(i)).collect();
    let h = [-60.0, -20.0, 0.0, 35.0, 60.0];
    let cd: Vec<f64> = h
        .iter()
        .flat_map(|hh| v.iter().map(move |vv| 200.0 + vv + 0.5 * hh))
        .collect();
    let list = |x: &[f64]| {
        x.iter()
            .map(|a| a.to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    let p = parse(&ies(
        "IESNA:LM-63-2002\n[TEST] a",
        "TILT=NONE",
        &format!("1 -1 1 {} {} 3 2 0 0 0", v.len(), h.len()),
        &format!("{}\n{}\n{}", list(&v), list(&h), list(&cd)),
    ));
    let t = p.gpu_table();
    let mut checked = 0;
    for i in 0..2000 {
        let z = 1.0 - 2.0 * (f64::from(i) + 0.5) / 2000.0;
        let phi = 2.399_963 * f64::from(i);
        let r = (1.0 - z * z).sqrt();
        let d = [r * phi.cos(), r * phi.sin(), z];
        let c = d[1].atan2(d[0]).to_degrees();
        if c.abs() > 59.0 {
            continue;
        }
        let s = f64::from(t.sample([d[0] as f32, d[1] as f32, d[2] as f32]));
        assert!(
            (s - p.intensity(d)).abs() < 1e-3,
            "{d:?}: {s} vs {}",
            p.intensity(d)
        );
        checked += 1;
    }
    assert!(checked > 500);
}
