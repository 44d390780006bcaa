//! The GLSL ES 3.00 programs: the core's shader sources (`luxbake::shader`, one file per pass
//! under `crates/bake/src/passes/<pass>/`, side by side with its WGSL twin) after the generated
//! prefix of the program's signature. Every program is `#version 300 es` + precision (this
//! crate's header) + [`luxbake::shader::glsl_prefix`] + its library files + its pass file.

pub(crate) use luxbake::program::Program as Pass;
use luxbake::scene::BvhMode;
use luxbake::shader;

/// Which program of a pass a draw runs: the pass's own, or for the gather with kept hits
/// (`GlowBackend::keep_gather_hits`) the trace pass that writes them or the gather that reads
/// them back.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Variant {
    Plain,
    Trace,
    Replay,
}

impl Variant {
    /// The variants of `pass`: the gather has all three, every other pass its own program.
    #[cfg(test)]
    pub(crate) fn of(pass: Pass) -> &'static [Variant] {
        if pass == Pass::Gather {
            &[Variant::Plain, Variant::Trace, Variant::Replay]
        } else {
            &[Variant::Plain]
        }
    }
}

/// The prefix and the files of `pass` compiled for traversal `bvh`.
pub(crate) fn program_sources(pass: Pass, bvh: BvhMode) -> (String, Vec<&'static str>) {
    (shader::glsl_prefix(pass, bvh), shader::glsl_sources(pass))
}

/// The label, prefix and files of `variant` of `pass` for traversal `bvh`: the trace pass is
/// the gather's prefix with `luxbake::shader::glsl_gather_trace_sources`, the replay the
/// gather's program after `luxbake::shader::GLSL_GATHER_REPLAY`.
pub(crate) fn variant_sources(
    pass: Pass,
    bvh: BvhMode,
    variant: Variant,
) -> (String, String, Vec<&'static str>) {
    let (mut prefix, sources) = program_sources(pass, bvh);
    match variant {
        Variant::Plain => (pass.label().to_owned(), prefix, sources),
        Variant::Trace => (
            format!("{} (trace)", pass.label()),
            prefix,
            shader::glsl_gather_trace_sources(),
        ),
        Variant::Replay => {
            prefix.push_str(shader::GLSL_GATHER_REPLAY);
            (format!("{} (replay)", pass.label()), prefix, sources)
        }
    }
}

#[cfg(test)]
mod tests;
