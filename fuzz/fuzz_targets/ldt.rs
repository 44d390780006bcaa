//! EULUMDAT input: a valid header is kept half the time and the fuzzer's bytes replace the
//! rest, so it gets past the fixed-layout header. Whatever parses must answer queries with
//! finite numbers, convert to LM-63 and write back as EULUMDAT unchanged.
#![no_main]

use libfuzzer_sys::fuzz_target;
use luxbake_ies::{IesVersion, Photometry};

const HEADER: &[u8] = b"Acme\n1\n2\n4\n90\n3\n45\nR\nN\nL\nF\nD\n100\n0\n50\n80\n0\n0\n0\n0\n0\n\
100\n100\n1\n0\n1\n1\nLED\n1000\n3000K\n90\n10\n";

fuzz_target!(|data: &[u8]| {
    let mut input = Vec::with_capacity(data.len() + HEADER.len());
    if data.first().is_some_and(|b| b & 1 == 1) {
        input.extend_from_slice(HEADER);
        input.extend_from_slice(&data[1..]);
    } else {
        input.extend_from_slice(data);
    }
    if let Ok(p) = Photometry::parse(&input) {
        let flux = p.luminous_flux();
        assert!(flux.is_finite() && flux >= 0.0, "flux {flux}");
        let (max, _) = p.max_intensity();
        assert!(max.is_finite());
        assert!(p.intensity([0.2, 0.1, -1.0]).is_finite());
        let written = p.to_ies(IesVersion::Lm63_2002);
        Photometry::parse(written.as_bytes()).expect("written LM-63 parses");
        if let Some(ldt) = p.to_ldt() {
            let q = Photometry::parse(ldt.as_bytes()).expect("written EULUMDAT parses");
            assert!(q == p, "EULUMDAT written back differs");
        }
    }
});
