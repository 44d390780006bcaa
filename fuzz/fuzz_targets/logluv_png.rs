//! A web light map (`luxbake_output::logluv::decode_logluv_png`: an 8-bit RGBA LogLuv PNG, as
//! a catalogue row's `web.glb` embeds it) from any bytes. Whatever decodes is finite,
//! non-negative light with alpha 1, and its own PNG of the decoded map decodes to as many
//! texels.
#![no_main]

use libfuzzer_sys::fuzz_target;
use luxbake_output::logluv::{decode_logluv_png, encode_logluv_png};

fuzz_target!(|data: &[u8]| {
    if let Ok(map) = decode_logluv_png(data) {
        assert_eq!(map.texels.len(), 4 * map.width as usize * map.height as usize);
        for t in map.texels.chunks_exact(4) {
            assert!(t[..3].iter().all(|v| v.is_finite() && *v >= 0.0), "{t:?}");
            assert_eq!(t[3], 1.0);
        }
        let again = decode_logluv_png(&encode_logluv_png(&map).expect("encodes"))
            .expect("its own PNG decodes");
        assert_eq!(again.texels.len(), map.texels.len());
    }
});
