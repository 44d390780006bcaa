//! LM-63 input (any bytes; the `IESNA:LM-63-2002` line is prepended half the time so the
//! fuzzer spends its effort past the version line). Whatever parses must answer every query
//! with finite numbers and survive a write/parse round trip.
#![no_main]

use libfuzzer_sys::fuzz_target;
use luxbake_ies::{IesVersion, Photometry};

fuzz_target!(|data: &[u8]| {
    let mut input = Vec::with_capacity(data.len() + 17);
    if data.first().is_some_and(|b| b & 1 == 1) {
        input.extend_from_slice(b"IESNA:LM-63-2002\n");
        input.extend_from_slice(&data[1..]);
    } else {
        input.extend_from_slice(data);
    }
    let resolver = |name: &str| (name.len() < 8).then(|| b"1 2 0 90 1 0.5".to_vec());
    let options = luxbake_ies::ParseOptions {
        tilt_resolver: Some(&resolver),
        ..Default::default()
    };
    if let Ok(p) = Photometry::parse_with(&input, &options) {
        luxbake_fuzz_check(&p);
        let q = Photometry::parse(p.to_ies(IesVersion::Lm63_2019).as_bytes())
            .expect("written LM-63 parses");
        assert_eq!(q.to_ies(IesVersion::Lm63_2019), p.to_ies(IesVersion::Lm63_2019));
    }
});

fn luxbake_fuzz_check(p: &Photometry) {
    let flux = p.luminous_flux();
    assert!(flux.is_finite() && flux >= 0.0, "flux {flux}");
    let (max, dir) = p.max_intensity();
    assert!(max.is_finite() && max >= 0.0);
    for d in [dir, [0.0, 0.0, -1.0], [1.0, -2.0, 0.5], [0.0; 3]] {
        let i = p.intensity(d);
        assert!(i.is_finite() && i >= 0.0 && i <= max * (1.0 + 1e-9) + 1e-300, "{i} > {max}");
    }
    assert!(p.intensity_at(37.0, 123.0).is_finite());
}
