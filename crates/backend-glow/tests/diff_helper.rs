//! The image-diff helper itself: it measures what it claims and writes the failure images.

mod common;

use common::{Tolerance, diff, write_failure_images};
use luxbake::map::MapImage;

fn image(values: &[f32]) -> MapImage {
    MapImage {
        width: values.len() as u32,
        height: 1,
        texels: values.iter().flat_map(|&v| [v, v, v, 1.0]).collect(),
    }
}

#[test]
fn identical_images_have_no_error() {
    let a = image(&[1.0, 2.0, 3.0, 0.0]);
    let s = diff(&a, &a);
    assert_eq!(
        (s.texels, s.mask_mismatches, s.rel_rmse, s.p99, s.max),
        (4, 0, 0.0, 0.0, 0.0)
    );
    assert!(s.within(Tolerance {
        rel_rmse: 0.0,
        p99: 0.0
    }));
}

#[test]
fn errors_are_relative_and_the_percentile_ignores_one_outlier_in_a_hundred() {
    let expected = image(&[2.0; 200]);
    let mut values = vec![2.0; 200];
    values[17] = 3.0; // one texel of 200 off by 50 %
    let actual = image(&values);
    let s = diff(&expected, &actual);
    assert_eq!(s.texels, 200);
    assert!((s.max - 0.5).abs() < 1e-12, "{s:?}");
    assert_eq!(s.p99, 0.0, "{s:?}");
    // sqrt(3 · 1²) / sqrt(600 · 2²)
    assert!(
        (s.rel_rmse - (3.0f64 / 2400.0).sqrt()).abs() < 1e-12,
        "{s:?}"
    );
    assert!(!s.within(Tolerance {
        rel_rmse: 1e-3,
        p99: 1.0
    }));
    // Two texels in 100 off: now the percentile sees them.
    values[18] = 3.0;
    values[19] = 3.0;
    let s = diff(&expected, &image(&values));
    assert!((s.p99 - 0.5).abs() < 1e-12, "{s:?}");
}

#[test]
fn mask_mismatches_fail_any_tolerance() {
    let a = image(&[1.0, 1.0]);
    let mut b = a.clone();
    b.texels[7] = 0.0;
    let s = diff(&a, &b);
    assert_eq!(s.mask_mismatches, 1);
    assert!(!s.within(Tolerance {
        rel_rmse: 1.0,
        p99: 1.0
    }));
}

#[test]
fn failure_images_are_written() {
    let dir = std::env::temp_dir().join(format!("luxbake-glow-diff-{}", std::process::id()));
    let a = image(&[1.0, 2.0, 3.0]);
    let b = image(&[1.0, 2.5, 3.0]);
    write_failure_images(&dir, "stage", &a, &b);
    for suffix in ["expected", "actual", "difference"] {
        let path = dir.join(format!("stage_{suffix}.png"));
        let bytes = std::fs::read(&path).expect("image written");
        assert_eq!(&bytes[1..4], b"PNG", "{}", path.display());
    }
    std::fs::remove_dir_all(&dir).expect("clean up");
}
