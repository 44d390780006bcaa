//! Test support: a headless context, or a skip by the workspace's rule (`luxbake_testkit`).

use crate::{GlContext, GlowError};

/// A headless context; without a driver `None` after [`luxbake_testkit::skip_or_fail`] (which
/// fails the test under CI).
pub(crate) fn context_or_skip(test: &str) -> Option<GlContext> {
    luxbake_testkit::or_skip(test, GlContext::headless(), GlowError::is_driver_missing)
}

use crate::gl::{Program, Target, TextureArray};
use luxbake::scene::BvhMode;
use luxbake::shader;

/// Runs one debug fragment program over a `size` target (one layer) and reads it back.
/// `fragment` is appended to the generated constants for `traversal`; `set` sets the program's uniforms.
pub(crate) fn render(
    ctx: &GlContext,
    label: &str,
    traversal: BvhMode,
    fragment: &[&str],
    samplers: &[(&str, &TextureArray)],
    set: impl Fn(&glow::Context, &Program),
    size: [u32; 2],
) -> Vec<f32> {
    let gl = ctx.gl().unwrap();
    let program = Program::new(gl, label, &shader::glsl_constants(traversal), fragment).unwrap();
    let out = TextureArray::new(gl, label, size[0], size[1], 1).unwrap();
    let target = Target::new(gl).unwrap();
    target.bind(gl, label, &out, 0).unwrap();
    program.use_with(gl, label, samplers).unwrap();
    set(gl, &program);
    target.draw(gl, label, [0, 0, size[0], size[1]]).unwrap();
    let texels = target.read(gl, label, &out, 0).unwrap();
    program.delete(gl);
    target.delete(gl);
    out.delete(gl);
    texels
}

/// A tiny deterministic generator for test data (SplitMix64).
pub(crate) struct TestRng(pub(crate) u64);

impl TestRng {
    /// The next value in [0, 1).
    pub(crate) fn f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 24) as f32
    }

    /// The next value in [lo, hi).
    pub(crate) fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
}
