//! Test support: a headless context, or a skip by the workspace's rule (`luxbake_testkit`).

use crate::{GlContext, GlowError};

/// A headless context; without a driver `None` after [`luxbake_testkit::skip_or_fail`] (which
/// fails the test under CI).
pub(crate) fn context_or_skip(test: &str) -> Option<GlContext> {
    luxbake_testkit::or_skip(test, GlContext::headless(), GlowError::is_driver_missing)
}

/// Runs `body` on a headless context's GL, or skips as [`context_or_skip`] does.
pub(crate) fn with_gl(test: &str, body: impl FnOnce(&glow::Context)) {
    if let Some(ctx) = context_or_skip(test) {
        body(ctx.gl().unwrap());
    }
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
