//! The sample files in `../shared/photometry` (read at test time; third-party files are never
//! copied into the repository) and the bundled default lamp.

use luxbake_ies::{Format, IesVersion, PhotometricType, Photometry};
use luxbake_testkit::fibonacci_sphere;
use std::path::PathBuf;

/// `../shared/photometry`, or `None` after [`luxbake_testkit::skip_or_fail`] (which fails
/// `test` under CI).
fn shared_photometry(test: &str) -> Option<PathBuf> {
    luxbake_testkit::shared_data(test, "photometry")
}

/// Every sample file (name, bytes), the bundled lamp first; only the bundled lamp when
/// `../shared/photometry` is missing (after [`shared_photometry`]'s skip-or-fail for `test`).
fn samples(test: &str) -> Vec<(String, Vec<u8>)> {
    let mut out = vec![(
        "luxbake_downlight.ies".to_owned(),
        DOWNLIGHT.as_bytes().to_vec(),
    )];
    let Some(dir) = shared_photometry(test) else {
        return out;
    };
    for sub in [dir.clone(), dir.join("real-world")] {
        let mut paths: Vec<_> = std::fs::read_dir(&sub)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| {
                let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
                ext.eq_ignore_ascii_case("ies") || ext.eq_ignore_ascii_case("ldt")
            })
            .collect();
        paths.sort();
        for p in paths {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            out.push((name, std::fs::read(&p).unwrap()));
        }
    }
    assert!(
        out.len() >= 23,
        "expected 22 shared sample files, found {}",
        out.len() - 1
    );
    out
}

const DOWNLIGHT: &str = include_str!("../../scene/lamps/luxbake_downlight.ies");

/// Lumens published for the file: `[_ABSOLUTELUMENS]` for absolute photometry, or for EULUMDAT
/// the header lumens times the light output ratio (LORL). (The luxpy IES file's ratio is checked
/// against its EULUMDAT twin in `ies_and_ldt_versions_of_the_same_luminaire_agree`.)
fn reference_lumens(p: &Photometry) -> Option<f64> {
    if let Some(l) = p.keyword("_ABSOLUTELUMENS") {
        return l.trim().parse().ok();
    }
    // Relative photometry: only EULUMDAT states the light output ratio.
    let header = p.lumens_header()?;
    p.ldt().map(|ldt| header * ldt.light_output_ratio / 100.0)
}

#[test]
fn every_sample_parses_and_integrates() {
    println!(
        "{:<28} {:<10} {:<4} {:>10} {:>11} {:>8}",
        "file", "format", "type", "header lm", "integr. lm", "ratio"
    );
    for (name, bytes) in samples("every_sample_parses_and_integrates") {
        let p = Photometry::parse(&bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
        let flux = p.luminous_flux();
        println!(
            "{:<28} {:<10} {:<4} {:>10} {:>11.1} {:>8}",
            name,
            p.format().name(),
            p.photometric_type().name(),
            p.lumens_header()
                .map_or("abs.".into(), |l| format!("{l:.1}")),
            flux,
            p.flux_ratio().map_or("-".into(), |r| format!("{r:.4}"))
        );
        assert!(flux.is_finite() && flux > 0.0, "{name}");
        assert!(p.warnings().is_empty(), "{name}: {:?}", p.warnings());
        let (max, dir) = p.max_intensity();
        assert!(max > 0.0, "{name}");
        let n = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
        assert!((n - 1.0).abs() < 1e-12, "{name}");
        assert!((p.intensity(dir) - max).abs() <= 1e-9 * max, "{name}");
    }
}

/// Files whose publisher states the luminaire lumens: ours must agree within 0.4 % (1 % for
/// the type B floodlight).
#[test]
fn integrated_lumens_match_published_lumens() {
    for (name, bytes) in samples("integrated_lumens_match_published_lumens") {
        let p = Photometry::parse(&bytes).unwrap();
        let Some(reference) = reference_lumens(&p) else {
            continue;
        };
        let rel = p.luminous_flux() / reference - 1.0;
        println!("{name}: integrated/reference - 1 = {rel:+.5}");
        // The type B floodlight's lab figure differs by 0.9 % (lab zonal integration).
        let tol = if p.photometric_type() == PhotometricType::B {
            0.01
        } else {
            0.004
        };
        assert!(rel.abs() < tol, "{name}: {rel}");
    }
}

#[test]
fn ies_and_ldt_versions_of_the_same_luminaire_agree() {
    let Some(dir) = shared_photometry("ies_and_ldt_versions_of_the_same_luminaire_agree") else {
        return;
    };
    let ies =
        Photometry::parse(&std::fs::read(dir.join("luxpy_test_lid_file.ies")).unwrap()).unwrap();
    let ldt =
        Photometry::parse(&std::fs::read(dir.join("luxpy_test_lid_file.ldt")).unwrap()).unwrap();
    assert_eq!(ldt.format(), Format::Eulumdat);
    let rel = ies.luminous_flux() / ldt.luminous_flux() - 1.0;
    assert!(rel.abs() < 1e-3, "{rel}");
    let (mi, _) = ies.max_intensity();
    let (ml, _) = ldt.max_intensity();
    assert!((mi / ml - 1.0).abs() < 2e-3, "{mi} {ml}");
}

/// Tolerance of `GpuTable::sample` against `Photometry::intensity`, relative to the peak:
/// types C and A: 99 % of 20 000 directions within 1e-4, all within 2 % (the exceptions lie in
/// the one table cell where a measured range ends on a non-zero value); type B (resampled at
/// 0.5°): 99 % within 1e-3, all within 5e-3.
#[test]
fn gpu_table_reproduces_intensity() {
    let dirs = fibonacci_sphere(20_000);
    for (name, bytes) in samples("gpu_table_reproduces_intensity") {
        let p = Photometry::parse(&bytes).unwrap();
        let table = p.gpu_table();
        assert!(table.width <= 2048 && table.height >= 2, "{name}");
        assert_eq!(table.values.len(), (table.width * table.height) as usize);
        let (max, _) = p.max_intensity();
        let mut errs: Vec<f64> = dirs
            .iter()
            .map(|&d| {
                let s = table.sample([d[0] as f32, d[1] as f32, d[2] as f32]) as f64;
                (s - p.intensity(d)).abs() / max
            })
            .collect();
        errs.sort_by(f64::total_cmp);
        let p99 = errs[errs.len() * 99 / 100];
        let worst = errs[errs.len() - 1];
        println!(
            "{name}: table {}x{}, p99 {p99:.2e}, max {worst:.2e}",
            table.width, table.height
        );
        let (t99, tmax) = if p.photometric_type() == PhotometricType::B {
            (1e-3, 5e-3)
        } else {
            (1e-4, 2e-2)
        };
        assert!(p99 < t99 && worst < tmax, "{name}: p99 {p99}, max {worst}");
    }
}

#[test]
fn written_samples_parse_back_equal() {
    for (name, bytes) in samples("written_samples_parse_back_equal") {
        let p = Photometry::parse(&bytes).unwrap();
        for v in [IesVersion::Lm63_2002, IesVersion::Lm63_2019] {
            let text = p.to_ies(v);
            let q = Photometry::parse(text.as_bytes()).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(q.format(), v.format());
            if p.format() == v.format() {
                assert_eq!(p, q, "{name}");
            }
            assert_eq!(q.to_ies(v), text, "{name}: writing is stable");
            for d in fibonacci_sphere(500) {
                let (a, b) = (p.intensity(d), q.intensity(d));
                assert!((a - b).abs() <= 1e-9 * a.abs().max(1.0), "{name}: {a} {b}");
            }
        }
        // EULUMDAT files are also written back as EULUMDAT, losslessly; LM-63 data is not.
        match p.to_ldt() {
            Some(text) => assert_eq!(Photometry::parse(text.as_bytes()).unwrap(), p, "{name}"),
            None => assert_ne!(p.format(), Format::Eulumdat, "{name}"),
        }
    }
}

/// Every prefix of every sample file: no panic; every prefix that stops before the last
/// number starts is an error (a prefix cut inside or after the last number can be a complete
/// file: `…0.00` cut to `…0.0`).
#[test]
fn truncated_prefixes_are_errors_never_panics() {
    let files = samples("truncated_prefixes_are_errors_never_panics");
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get());
    let next = std::sync::atomic::AtomicUsize::new(0);
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| {
                loop {
                    let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some((name, bytes)) = files.get(k) else {
                        break;
                    };
                    check_prefixes(name, bytes);
                }
            });
        }
    });
}

fn check_prefixes(name: &str, bytes: &[u8]) {
    let sep = |b: &u8| b.is_ascii_whitespace() || *b == b',';
    let end = bytes.iter().rposition(|b| !sep(b)).map_or(0, |i| i + 1);
    let last_start = bytes[..end].iter().rposition(sep).map_or(0, |i| i + 1);
    for n in 0..bytes.len() {
        let r = Photometry::parse(&bytes[..n]);
        if n < last_start {
            assert!(r.is_err(), "{name}: prefix of {n} bytes parsed");
        }
    }
}

#[test]
fn downlight_header_lumens_match_integrated_flux() {
    let p = Photometry::parse(DOWNLIGHT.as_bytes()).unwrap();
    assert_eq!(p.format(), Format::Lm63_2002);
    assert_eq!(p.keyword("MANUFAC"), Some("luxbake (synthetic)"));
    let header = p.lumens_header().unwrap();
    assert!((p.luminous_flux() / header - 1.0).abs() < 1e-4);
    assert!((1400.0..1600.0).contains(&header));
    // Beam angle (full angle at half the peak) in the C0 plane: 60–70°.
    let (peak, _) = p.max_intensity();
    let half = (0..9000)
        .map(|i| i as f64 * 0.01)
        .find(|&g| p.intensity_at(g, 0.0) < 0.5 * peak)
        .unwrap();
    assert!((30.0..35.0).contains(&half), "{half}");
    assert_eq!(p.intensity_at(91.0, 0.0), 0.0);
    // Mildly asymmetric: a 90° rotation visibly changes the pattern at 45°.
    let ratio = p.intensity_at(45.0, 0.0) / p.intensity_at(45.0, 90.0);
    assert!((1.1..1.3).contains(&ratio), "{ratio}");
}
