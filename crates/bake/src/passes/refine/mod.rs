//! Pass `refine`: the program's signature, its parameter block and its shaders
//! (refine.glsl, refine.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the
//! shaders mirror.
//!
//! Progressive refinement of a gather: a texel whose variance estimate
//! ([`Program::Variance`](crate::program::Program::Variance) of the first gather: `√variance / mean
//! luminance` of its 5×5
//! window without the texel itself, and the texel's direct light: "Against the light the
//! maps report" below) shows a relative standard error over
//! [`RefineParams::max_error`] gets `rays`
//! more rays, continuing its sequence, averaged with the first gather's by ray count; every
//! other texel keeps the first gather's value. The decision leaves the texel's own value
//! out: deciding on its own noisy estimate keeps the texels that came out high and refines
//! those that came out low (measured: +5.5 % on `chairs_05` at a target of 0.3 when
//! divided by the texel's own luminance; −2 % on the box room while its own value was in
//! the variance). Then kept and refined texels are both unbiased.
//!
//! # Against the light the maps report
//! The maps report the total, direct and indirect light, and the first bounce's noise counts
//! in it only as much as the first bounce makes of it: a texel under the lamp, whose
//! illuminance is mostly direct, is well known however noisy its first gather. The error is
//! therefore taken relative to the light known at the texel when the refinement decides,
//! `√variance / (mean + E_d)`, `E_d` the luminance of the texel's own direct light (the
//! variance pass's fourth channel). The direct light carries no noise of the gather (a point
//! lamp's none, an opening's lattice its own), so deciding on it biases nothing. Measured
//! (`bench refcheck --seeds 4`, CPU, hq references; `chairs_05`'s texels refined, and the
//! held-out rooms' furniture mean |rel| %, `chairs_01` / `chairs_03` / `chairs_10`): against
//! the first gather alone at a target of 0.3, 31 % of the texels refined (the room 17 %,
//! the chairs 54 %) and 0.98 / 0.85 / 1.01 %; against the light known, 15 % (the room 2 %,
//! the chairs 34 %) and 1.00 / 0.86 / 1.02 %; at 0.2, 24 % and 0.93 / 0.81 / 0.98 % (at 0.15,
//! 33 %, the same). The room's lit walls and floor, refined before, gained nothing from it
//! (every other surface kind's mean |rel| the same within 0.02 %). The indirect light alone
//! is refined less where the direct light dominates it: in the test
//! `refinement_keeps_the_lamp_paths` (the first bounce's indirect light against 512 rays)
//! 18.5 % relative RMS instead of 13.8 %.
//!
//! With lamp paths ([`crate::lightpaths`]) the first gather's value `X₁ = G₁ + C₁` is the sum
//! of two multiple-importance parts: its `N` rays' weighted mean `G₁` and the texel's `K`
//! connections to the lamp paths `C₁`, both weighted by the balance heuristic for `N` rays
//! and `K` paths. The refinement makes a second estimate `X₂ = G₂ + C₂` of the same kind:
//! `rays` further rays and `K·rays/N` (rounded, at least 1) further connections (the connect
//! pass with [`ConnectParams::picks`](crate::passes::connect::ConnectParams::picks), slot
//! `connected`), each weighted by the same heuristic (for `N` and `K`: the weights depend on
//! the strategies' ratio, which stays), so that `G₂` and `C₂` estimate what `G₁` and `C₁` do;
//! the refined value is `(N·X₁ + rays·X₂) / (N + rays)`. Both parts get more samples: more
//! rays alone (the connections' part kept) brought `chairs_01`'s furniture from 1.23 to 1.13 %
//! only, and a plain gather averaged with the first value (unbiased too) adds its larger noise
//! where the connections carry the light (`sofa_01`'s furniture 1.65 → 2.16 %).
//!
//! # Narrow gaps
//! A texel in a narrow gap ([`crate::validity::NARROW_GAP`]: its surface faces another within
//! a few texels and a 64th of the room's size, and the gap is closed to its sides) gets
//! [`RefineParams::narrow_rays`] further rays whatever its noise (and its second estimate
//! `K·narrow_rays/N` connections). In such a gap the light comes from the few directions that
//! leave it, most of it after bounces inside the gap, so a few rays give
//! skewed, heavy noise — the points behind a bookcase 2.5 cm from a wall read −21 … +40 % at
//! 8 rays, four seeds — over a few per cent of a room's texels (`crate::validity`). The
//! decision reads no estimate, so it biases nothing. The later bounces' gathers are refined
//! the same way, after the gather and before the upsample of a reduced one (the graph's
//! `refine_narrow`, with `rays` 0 and no lamp paths); [`narrow_more`] sets the counts
//! ([`crate::scene::Settings::narrow_rays`] in all in the first two bounces, half as many in
//! each bounce after, [`narrow_rays_in`]; within a budget). The halving follows the light:
//! a bounce's noise counts in the reported light as much as the bounce's light does, and
//! each bounce brings about half as much as the one before (the manifests' `bounce_ratio`
//! 0.50–0.64 in the demo room and the three real rooms), so rays in proportion to it spend
//! them where they lower the error most. Measured on the lounge's gap (`bench refcheck`, four
//! seeds, `default` with 64 gap rays, furniture mean |rel|): 64 rays in every bounce 0.957 %,
//! halved from the third bounce 0.976 % for a third of the later bounces' refinement time,
//! halved from the second 1.074 %. Where a texel is both
//! narrow and refined for its noise it takes the larger count ([`RefineParams::more`]); every texel
//! draws from [`Stream::refine`](crate::rng::Stream::refine) with the larger of the two counts
//! as its span, so the draws of a block's texels never overlap whatever count each takes.
//!
//! ## The direct light at a gap's mouth
//! Without [`GatherParams::direct_at_hits`](crate::passes::gather::GatherParams::direct_at_hits)
//! a gather ray reads the direct light where it lands from the direct map, bilinearly between
//! texels. At a gap's open side the lamps light its walls at grazing incidence over the first
//! centimetre or so and then not at all, a step the map's texels (1.6 cm at 64 texels per
//! metre) spread inward, and a gap's first bounce is mostly that light: along the lounge's
//! slot (`default`, sixteen seeds, against ten Radiance points traced across it,
//! `bench/results/real-rooms-2026-12-07c/slot-profile`) the bake read +6.5 … +11 % over the
//! 10 cm next to the open side with every denoiser setting, and −1.6 … +2.3 % on the layout
//! without the denoiser's padding, where the texels fall elsewhere. So with
//! [`RefineParams::narrow_direct`] (the graph sets it when the bake does not read the direct
//! light at every hit) a texel in a narrow gap takes the refinement's estimate alone, all its
//! `narrow_rays` reading the lamps' direct light at their hits (a shadow ray per ray and
//! lamp, as [`GatherParams::direct_at_hits`](crate::passes::gather::GatherParams::direct_at_hits)
//! does everywhere) instead of averaging in the first gather's rays, which read the map;
//! every other texel's rays still read the map. The refinement's estimate is unbiased on its
//! own (its rays and connections weighted by the same heuristic as the first's), so dropping
//! the first gather's few rays there biases nothing. Measured (sixteen seeds, against
//! Radiance): the slot's six points within 10 cm of the open side −4.8 … +2.9 %; the real
//! rooms' furniture
//! (mean |rel| / bias %) lounge 1.015 / −0.08 → 0.945 / −0.21, dining 0.670 → 0.653, office
//! 0.572 → 0.561, every other surface kind the same to the third decimal.

pub(crate) mod cpu;

/// Whether the refinement refines a texel whose variance estimate (the variance pass's
/// texel: `[variance, window mean luminance, variance without the texel, the texel's direct
/// luminance]`) is `noise`: the first gather's standard error over the light known at the
/// texel — the window's mean first bounce and the texel's own direct light — over
/// `max_error` (module docs, "Against the light the maps report"). The refine pass and the
/// connect pass of its second connections take the same decision (`luxRefines` /
/// `lux_refines` in the shaders).
// `!(x <= y)` on purpose: a NaN estimate refines, as in the shaders.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn refines(noise: [f32; 4], max_error: f32) -> bool {
    !(noise[2].max(0.0).sqrt() <= max_error * (noise[1] + noise[3]))
}

use crate::contract::{param_block, signature};

/// The further rays (or connections) of a texel that is `narrow`, with variance estimate
/// `noise` (read only when `by_noise` > 0): the larger of `by_gap` (when narrow) and
/// `by_noise` (when it misses the target `max_error`). The refine pass
/// ([`RefineParams::more`]) and the connect pass of its second connections
/// ([`ConnectParams::connections_at`](crate::passes::connect::ConnectParams::connections_at))
/// decide alike.
pub(crate) fn larger_count(
    narrow: bool,
    [by_gap, by_noise]: [u32; 2],
    noise: impl FnOnce() -> [f32; 4],
    max_error: f32,
) -> u32 {
    let gap = if narrow { by_gap } else { 0 };
    let refined = if by_noise > 0 && refines(noise(), max_error) {
        by_noise
    } else {
        0
    };
    gap.max(refined)
}

/// The most rays the refinements in narrow gaps add in one bounce, as a fraction
/// `1 / NARROW_BUDGET` of the first bounce's gather rays over the room: 4, a quarter.
pub const NARROW_BUDGET: u64 = 4;

/// The rays per texel in a narrow gap that bounce `bounce` (1-based) aims at, of
/// [`crate::scene::Settings::narrow_rays`] `narrow_rays`: all of them in the first two
/// bounces, half as many in each bounce after (module docs, "Narrow gaps"): a gap's light
/// shrinks from bounce to bounce as the room's does, and a bounce's noise counts in the
/// total only as much as its light, so the rays follow the light.
pub fn narrow_rays_in(narrow_rays: u32, bounce: u32) -> u32 {
    narrow_rays
        .checked_shr(bounce.saturating_sub(2))
        .unwrap_or(0)
}

/// The rays a bounce of `rays` rays per texel adds at each texel in a narrow gap: up to
/// `narrow_rays` there, and in all at most a quarter ([`NARROW_BUDGET`]) of the first
/// bounce's rays (`first_rays` per texel) over the room, whose `[narrow, valid]` texels
/// `texels` are: where gaps hold more of a room's texels, each gets fewer (module docs,
/// "Narrow gaps"). 0 where the room has no texel in a gap.
pub fn narrow_more(narrow_rays: u32, rays: u32, first_rays: u32, [narrow, valid]: [u64; 2]) -> u32 {
    if narrow == 0 {
        return 0;
    }
    let budget = u128::from(first_rays) * u128::from(valid)
        / (u128::from(NARROW_BUDGET) * u128::from(narrow));
    narrow_rays
        .saturating_sub(rays)
        .min(u32::try_from(budget).unwrap_or(u32::MAX))
}

param_block! {
    /// Parameters of [`Program::Refine`](crate::program::Program::Refine): progressive refinement
    /// of a gather of `first_rays`
    /// rays per texel (see [`Program::Refine`](crate::program::Program::Refine)).
    RefineParams as "LuxRefineParams" {
        /// Further rays per texel that misses the target: the draws of
        /// [`Stream::refine`](crate::rng::Stream::refine) (with the hash sampler samples
        /// `first_rays .. first_rays + rays` of the texel's sequence).
        rays: u32,
        /// Bounce number, 1-based (the `pass` input of the RNG hash).
        bounce: u32,
        /// Seed of the RNG hash.
        seed: u32,
        /// The direction sampler's id ([`Sampler::id`](crate::rng::Sampler::id)).
        sampler: u32,
        /// Rays of the first gather.
        first_rays: u32,
        /// The target: a texel whose estimated relative standard error (√variance / the
        /// window's mean luminance, [`Program::Variance`](crate::program::Program::Variance)) is at
        /// most this is kept as it is.
        max_error: f32,
        /// Lamp paths per texel of the first gather (`K`,
        /// [`GatherParams::lamp_paths`](crate::passes::gather::GatherParams::lamp_paths)): the
        /// further rays are weighted against them and the slot `connected` holds their part;
        /// 0: none (the slot is not read).
        lamp_paths: u32,
        /// [`crate::lightpaths::LampPaths::density_scale`].
        density_scale: f32,
        /// Uploaded lamps the lamp paths' density sums over.
        lamp_count: u32,
        /// [`GatherParams::direct_at_hits`](crate::passes::gather::GatherParams::direct_at_hits)
        /// of the first gather: the further rays read their hits as it did.
        direct_at_hits: u32,
        /// Further rays at every texel in a narrow gap ([`crate::validity::NARROW_GAP`]), whatever
        /// its noise (module docs, "Narrow gaps"); 0: none.
        narrow_rays: u32,
        /// 1: a texel in a narrow gap takes its refinement's estimate alone, its rays reading
        /// the lamps' direct light at their hits (module docs, "Narrow gaps"); 0: the
        /// first gather's and the refinement's averaged by ray count there too.
        narrow_direct: u32,
    }
}

impl RefineParams {
    /// The span of the draws of every texel ([`Stream::refine`](crate::rng::Stream::refine)'s
    /// `more`): the larger of the two counts.
    pub fn span(&self) -> u32 {
        self.rays.max(self.narrow_rays)
    }

    /// Further rays at a texel that is `narrow` (position w ≥ [`crate::validity::NARROW_GAP`]),
    /// with variance estimate `noise` (read only when [`RefineParams::rays`] > 0): the larger
    /// of the narrow count (when narrow) and the refinement's (when it misses the target).
    pub fn more(&self, narrow: bool, noise: impl FnOnce() -> [f32; 4]) -> u32 {
        larger_count(narrow, [self.narrow_rays, self.rays], noise, self.max_error)
    }

    /// Whether a refined texel that is `narrow` takes the refinement's estimate alone
    /// ([`RefineParams::narrow_direct`]).
    pub fn replaces(&self, narrow: bool) -> bool {
        narrow && self.narrow_direct != 0
    }
}

signature! {
    refine {
        reads: ["position", "normal", "reflected", "first", "variance", "connected", "albedo"],
        // The lamps and their tables: the gather loop weights the rays against the lamp
        // paths.
        scene: [bvh, lamps, regions],
        params: RefineParams,
        libraries: [Common, Rng, Scene, Bvh, Ies, Lamp, Gather],
    }
}

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]).
pub fn work(p: &RefineParams) -> u64 {
    u64::from(p.span())
}

#[cfg(test)]
mod tests {
    use super::{RefineParams, narrow_more, narrow_rays_in, refines};
    use crate::passes::connect::ConnectParams;

    /// A texel's further rays and connections: the narrow count in a gap whatever the noise
    /// (the estimate not even read), the refinement's where the noise misses the target, the
    /// larger where both apply; the draws span the larger count, the connections' sum is
    /// scaled by `k` over the texel's own count.
    #[test]
    fn a_texel_in_a_narrow_gap_is_refined_whatever_its_noise() {
        let quiet = [0.0, 10.0, 0.0, 0.0];
        let noisy = [0.0, 10.0, 16.0, 0.0];
        let unread = || -> [f32; 4] { panic!("the estimate is read without refinement by noise") };
        let narrow = RefineParams {
            first_rays: 8,
            narrow_rays: 56,
            max_error: 0.3,
            ..RefineParams::default()
        };
        assert_eq!(narrow.more(true, unread), 56);
        assert_eq!(narrow.more(false, unread), 0);
        assert_eq!(narrow.span(), 56);
        let both = RefineParams { rays: 8, ..narrow };
        assert_eq!(both.more(true, || quiet), 56);
        assert_eq!(both.more(true, || noisy), 56);
        assert_eq!(both.more(false, || noisy), 8);
        assert_eq!(both.more(false, || quiet), 0);
        let more = RefineParams { rays: 80, ..narrow };
        assert_eq!((more.more(true, || noisy), more.more(true, || quiet)), (80, 56));
        assert_eq!(more.span(), 80);
        let first = ConnectParams {
            rays: 8,
            k: 4,
            ..ConnectParams::default()
        };
        assert!(!first.is_refinement());
        assert_eq!(first.connections_at(true, unread), 4);
        assert_eq!(first.scale(4), 1.0);
        let narrow = first.refinement(0, 0.3, 56);
        assert!(narrow.is_refinement());
        assert_eq!((narrow.picks, narrow.narrow_picks), (0, 28));
        assert_eq!(narrow.connections_at(true, unread), 28);
        assert_eq!(narrow.connections_at(false, unread), 0);
        assert_eq!(narrow.scale(28), 4.0 / 28.0);
        let both = first.refinement(8, 0.3, 56);
        assert_eq!(both.connections(), 28);
        assert_eq!(both.connections_at(false, || noisy), 4);
        assert_eq!(both.connections_at(true, || noisy), 28);
        assert_eq!(both.connections_at(false, || quiet), 0);
        // Up to 64 rays where a gap holds 1 % of the room's texels; where it holds 10 %, a
        // quarter of 8 rays over the room is 20 a texel there; none where no texel is in one.
        // All 64 in the first two bounces, then half as many in each.
        let shares: Vec<u32> = (1..=9).map(|k| narrow_rays_in(64, k)).collect();
        assert_eq!(shares, [64, 64, 32, 16, 8, 4, 2, 1, 0]);
        assert_eq!(narrow_rays_in(64, u32::MAX), 0);
        assert_eq!(narrow_rays_in(0, 1), 0);
        assert_eq!(narrow_more(64, 8, 8, [1, 100]), 56);
        assert_eq!(narrow_more(64, 16, 8, [1, 100]), 48);
        assert_eq!(narrow_more(64, 8, 8, [10, 100]), 20);
        assert_eq!(narrow_more(64, 16, 8, [10, 100]), 20);
        assert_eq!(narrow_more(64, 8, 8, [0, 100]), 0);
        assert_eq!(narrow_more(8, 8, 8, [1, 100]), 0);
        assert_eq!(narrow_more(64, 8, 8, [u64::MAX, u64::MAX]), 2);
        // Without rays in narrow gaps the refinement is the one before.
        let before = first.refinement(8, 0.3, 0);
        assert_eq!((before.picks, before.narrow_picks), (4, 0));
        assert_eq!(before.connections_at(true, || quiet), 0);
    }

    /// The decision weighs the first gather's noise against the light known at the texel: the
    /// same noise refines a texel in the shade and not one the lamp lights ten times as
    /// brightly; a NaN estimate refines; no noise never does.
    #[test]
    fn the_direct_light_a_texel_gets_counts_against_its_noise() {
        // Standard error 4 over a mean first bounce of 10: 0.4 of it.
        let shade = [0.0, 10.0, 16.0, 0.0];
        assert!(refines(shade, 0.3));
        assert!(!refines(shade, 0.5));
        // With 100 of direct light the error is 4 of 110 known.
        let lit = [0.0, 10.0, 16.0, 100.0];
        assert!(!refines(lit, 0.3));
        assert!(refines(lit, 0.03));
        assert!(refines([0.0, f32::NAN, 16.0, 100.0], 0.3));
        assert!(!refines([0.0, 0.0, 0.0, 0.0], 0.3));
    }
}
