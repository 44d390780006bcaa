//! Pass `direct`: the program's signature, its parameter block and its shaders
//! (direct.glsl, direct.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the
//! shaders mirror.
//!
//! Direct illuminance with shadow rays: from each lamp's photometric centre, or, for texels
//! near a lamp with a luminous opening, from [`DirectParams::samples`] points of the opening
//! ([`crate::opening`]).

pub(crate) mod cpu;

use crate::contract::{param_block, signature};

param_block! {
    /// Parameters of [`Program::Direct`](crate::program::Program::Direct): the lamps are the
    /// scene's uploaded lamps.
    DirectParams as "LuxDirectParams" {
        /// Lamps to evaluate (the first `lamp_count` of the uploaded lamps).
        lamp_count: u32,
        /// Seed of the RNG hash (the openings' lattice shift).
        seed: u32,
        /// Points of a lamp's opening per texel near it, from twice the opening's size on (up
        /// to twice as many nearer, [`crate::opening::texel_samples`]).
        samples: u32,
        /// Lamps with an opening among the first `lamp_count` (for the tile plan).
        openings: u32,
        /// With [`DirectParams::chunk_samples`]: the first of each opening's samples (counted
        /// over its parts in order) this dispatch takes; from the second chunk on (> 0) the
        /// slot `prior` holds the chunks before, which the output adds to, and the lamps
        /// without an opening (done by the first chunk) are not evaluated again.
        first_sample: u32,
        /// Most samples of one opening one dispatch takes (0: all): a texel's opening samples
        /// split over dispatches, each adding its share (a part's `sum / count`) to the ones
        /// before, so that one shader invocation stays within a driver's loop limit
        /// ([`crate::Limits::loop_iterations`]).
        chunk_samples: u32,
        /// Opening samples per visibility probe (0 or 1: none, every sample casts its shadow
        /// ray): a texel near an opening first casts the shadow rays of every
        /// `probe_stride`-th point of each part's lattice that gives it light; when all of
        /// them reach the opening the other points are taken as seen without a ray, else
        /// every point casts its own ([`crate::opening`], "Probes").
        probe_stride: u32,
        /// 1: every lamp from its photometric centre, its opening left out even where a texel
        /// lies within [`crate::opening::OpeningParams::near`] — the preview of the direct
        /// light a bake hands over before an opening's direct pass has run
        /// ([`crate::graph::BakeGraph::preview`]); 0: as the lamps say.
        points_only: u32,
    }
}

signature! {
    direct {
        reads: ["position", "normal", "prior"],
        scene: [bvh, lamps],
        params: DirectParams,
        libraries: [Common, Rng, Scene, Bvh, Ies, Lamp, Opening],
    }
}

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]): one shadow ray
/// per lamp, and at most twice `samples` per lamp with an opening
/// ([`crate::opening::texel_samples`]), or a chunk of them, after the probes of every
/// `probe_stride`-th (one more per part).
pub fn work(p: &DirectParams) -> u64 {
    let most = 2 * u64::from(p.samples);
    let mut per_opening = most;
    if p.chunk_samples > 0 {
        per_opening = per_opening.min(u64::from(p.chunk_samples));
    }
    if p.probe_stride > 1 {
        per_opening += most.div_ceil(u64::from(p.probe_stride)) + 6;
    }
    u64::from(p.lamp_count) + u64::from(p.openings) * per_opening
}

impl DirectParams {
    /// This direct pass split into passes that take at most `chunk_samples` of an opening's
    /// samples per texel (0: one pass, unchanged), in order: as many as a texel near an
    /// opening needs (twice `samples`, [`crate::opening::texel_samples`]), one without
    /// openings.
    pub fn chunked(self, chunk_samples: u32) -> Vec<DirectParams> {
        let chunks = if chunk_samples == 0 || self.openings == 0 {
            1
        } else {
            self.samples.saturating_mul(2).div_ceil(chunk_samples).max(1)
        };
        (0..chunks)
            .map(|c| DirectParams {
                first_sample: c * chunk_samples,
                chunk_samples: if chunks > 1 { chunk_samples } else { 0 },
                ..self
            })
            .collect()
    }
}
