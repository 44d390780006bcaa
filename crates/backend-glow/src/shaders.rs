//! The GLSL ES 3.00 programs: the core's shader sources (`luxbake::shader`, one file per pass
//! under `crates/bake/src/passes/<pass>/`, side by side with its WGSL twin) after the generated
//! prefix of the program's signature. Every program is `#version 300 es` + precision (this
//! crate's header) + [`luxbake::shader::glsl_prefix`] + its library files + its pass file;
//! the gather's trace pass and replay for kept hits are `luxbake::shader::glsl_variant`'s.

pub(crate) use luxbake::program::Program as Pass;

#[cfg(test)]
mod tests;
