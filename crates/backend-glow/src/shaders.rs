//! The GLSL ES 3.00 programs: the core's shader sources (`luxbake::shader`, one file per pass
//! under `crates/bake/src/passes/<pass>/`, side by side with its WGSL twin) after the generated
//! prefix of the program's signature. Every program is `#version 300 es` + precision (this
//! crate's header) + [`luxbake::shader::glsl_prefix`] + its library files + its pass file.

pub(crate) use luxbake::program::Program as Pass;
use luxbake::scene::BvhMode;
use luxbake::shader;

/// The prefix and the files of `pass` compiled for traversal `bvh`.
pub(crate) fn program_sources(pass: Pass, bvh: BvhMode) -> (String, Vec<&'static str>) {
    (shader::glsl_prefix(pass, bvh), shader::glsl_sources(pass))
}

#[cfg(test)]
mod tests;
