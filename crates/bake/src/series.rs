//! Converging the inter-reflection series: when to stop explicit bounces and how large the
//! tail they leave out is.
//!
//! # Derivation
//! With the transport operator `T` (gather after × albedo), the illuminance is the Neumann
//! series `E = E_d + Σ_{k≥1} Δ_k`, `Δ_k = T Δ_{k−1}`, `Δ_0 = E_d`. After a few bounces the
//! increments are dominated by `T`'s largest eigenvalue λ (the power iteration): per texel
//! `Δ_{k+1} ≈ λ Δ_k`, so the bounces left out sum to
//! ```text
//! Σ_{j>K} Δ_j ≈ Δ_K · (λ + λ² + …) = Δ_K · λ / (1 − λ).
//! ```
//! λ is estimated from the energies of successive increments (sums over valid texels, which
//! have about equal area at the uniform texel density, so a sum is about proportional to the
//! flux; see the retention below):
//! `λ_K = ΣΔ_K / ΣΔ_{K−1}`. In a closed enclosure of uniform albedo ρ every bounce keeps
//! exactly ρ of the flux, so `λ_k = ρ` from the first ratio on and the extrapolation is exact
//! (CIE 171:2006 test case 5.8); in a room it converges geometrically to the dominant mode.
//!
//! # The next increment, predicted from the light the last one reflects
//! In a room the ratio still grows when the bake stops: on `chairs_10` at the default
//! λ₂ … λ₁₂ = 0.521, 0.607, 0.623, 0.639, 0.644, 0.648, 0.652, 0.654, 0.657, 0.659, 0.661 (the
//! first bounces land on what the lamps light, the later ones spread to the ceiling and the
//! furniture), so `λ_K/(1−λ_K)` underestimates the tail. Part of the next ratio is known
//! before the next bounce: the next bounce gathers the light the last increment reflects,
//! `ρ·Δ_K`, whose energy `R_K` the bake measures too. The next increment's energy is that
//! light as it lands, `ΣΔ_{K+1} = χ_K · R_K`, where the retention `χ_k = ΣΔ_{k+1} / R_k` is what
//! of the reflected light reaches the receivers as the texel sums count it (not exactly the
//! flux: measured 0.98–1.05 after the first bounce and 1.02–1.15 after the later ones in five
//! rooms). χ depends much less on the bounce than λ does — λ follows where the light lies (the
//! albedo under it), χ only where it goes — and it is estimated from the two bounces before
//! (`χ̂ = (χ_{K−1} + χ_{K−2}) / 2`: the first bounce, gathered at full resolution and with the
//! lamp paths, retains differently from the later ones, and successive retentions alternate
//! slightly). The tail is then
//! ```text
//! T = ΣΔ̂_{K+1} · (1 + λ̂ + λ̂² + …) = ΣΔ_K · λ̂/(1 − λ̂),   ΣΔ̂_{K+1} = χ̂ R_K,  λ̂ = ΣΔ̂_{K+1}/ΣΔ_K:
//! ```
//! the plain extrapolation with the predicted ratio of the next bounce in place of the last
//! measured one, from the fourth bounce on (χ̂ needs two retentions after the first bounce's);
//! before it with `λ_K`. Measured against 30 explicit bounces (`cargo xtask bake --bounces
//! 30`, default rays and strides) on five furnished rooms (docs/performance.md, issue 29), the converged
//! total extrapolated after bounce 5 is off by −0.09 … −0.15 % (with `λ_K`: −0.12 … −0.28 %;
//! with Aitken's trend of the ratios, the rule before this one: −0.11 … −0.28 %), after
//! bounce 6 by −0.03 … −0.07 % (−0.07 … −0.13 %). After bounce 4 no rule is good enough
//! (−0.15 … −0.69 % with any of the three): the stopping rule below waits for bounce 5. A
//! closed enclosure of uniform albedo keeps `χ = 1` and `λ = ρ` and stays exact (CIE
//! 171:2006 test case 5.8).
//!
//! # Stopping rule
//! After bounce `K ≥ 2` the estimated tail fraction is `τ = T / (E_d + ΣΔ + T)` — what the
//! explicit bounces leave out. Explicit bounces stop when either
//! - the tail itself is negligible: `τ < tolerance`; or
//! - the extrapolation has settled: from `K ≥ 5` on (two successive predictions of the next
//!   increment), the converged total estimated after bounce `K` differs from the one
//!   estimated after bounce `K − 1` by less than the tolerance;
//!
//! or at the hard cap of explicit bounces. Before the predictions (`K < 5`) only a negligible
//! tail stops: in a room the first ratios still carry the first bounce's transient (on
//! `chairs_10` a bake that stopped at bounce 4 on the ratios' change read its ceiling 1.6 %
//! low against Radiance; at bounce 5 0.1 %). λ is clamped to `[0, MAX_RATIO]`, so a noisy or
//! lossless (ρ = 1) estimate never yields an infinite tail.

/// Largest bounce ratio used for the tail (a lossless enclosure would have an infinite
/// series; 0.995 bounds the tail at 199 × the last increment).
pub const MAX_RATIO: f64 = 0.995;
/// The first bounce whose tail is extrapolated from the predicted next increment
/// ([`Series::predicted_next`]): its retention estimate needs two retentions after the first
/// bounce's.
pub const FIRST_PREDICTED: usize = 4;

/// Energies of a bake's direct light and explicit bounce increments (sums over valid texels).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Series {
    /// Σ of the direct illuminance.
    pub direct: f64,
    /// Σ of each bounce's increment `Δ_k`, `k = 1 ..`.
    pub increments: Vec<f64>,
    /// Σ of the light each increment reflects, `ρ·Δ_k`, `k = 1 ..` (what the next bounce
    /// gathers).
    pub reflected: Vec<f64>,
}

impl Series {
    /// The ratio `λ_K = ΣΔ_K / ΣΔ_{K−1}` of the last two bounces, clamped to
    /// `[0, MAX_RATIO]`; `None` before the second bounce or without light in the previous one.
    pub fn ratio(&self) -> Option<f64> {
        ratio_at(&self.increments, self.increments.len())
    }

    /// The factor `f` with which the last increment estimates the tail (0 without a ratio):
    /// `λ/(1−λ)` with, from bounce [`FIRST_PREDICTED`] on, the predicted next ratio
    /// `λ̂ = ΣΔ̂_{K+1}/ΣΔ_K` ([`Series::predicted_next`]), before it the last one, `λ_K` (see
    /// the module docs).
    pub fn tail_factor(&self) -> f64 {
        let Some(now) = self.ratio() else {
            return 0.0;
        };
        let last = self.increments.last().copied().unwrap_or(0.0);
        let ratio = match self.predicted_next() {
            Some(next) if last > 0.0 => (next / last).clamp(0.0, MAX_RATIO),
            _ => now,
        };
        ratio / (1.0 - ratio)
    }

    /// The energy `ΣΔ̂_{K+1} = χ̂ · R_K` the next bounce's increment is predicted to have:
    /// the light the last increment reflects times the mean retention `χ̂` of the two bounces
    /// before (see the module docs). `None` before bounce [`FIRST_PREDICTED`], without the
    /// reflected energies, or where a retention is not finite.
    pub fn predicted_next(&self) -> Option<f64> {
        let k = self.increments.len();
        if k < FIRST_PREDICTED || self.reflected.len() < k {
            return None;
        }
        let retention = |j: usize| {
            let (landed, reflected) = (self.increments[j], self.reflected[j - 1]);
            (reflected > 0.0 && landed.is_finite() && landed >= 0.0).then(|| landed / reflected)
        };
        let chi = 0.5 * (retention(k - 1)? + retention(k - 2)?);
        let next = chi * self.reflected[k - 1];
        next.is_finite().then_some(next.max(0.0))
    }

    /// Σ of the explicit illuminance: direct plus every increment.
    pub fn explicit(&self) -> f64 {
        self.direct + self.increments.iter().sum::<f64>()
    }

    /// The estimated tail energy `ΣΔ_K · f`.
    pub fn tail(&self) -> f64 {
        self.increments.last().copied().unwrap_or(0.0) * self.tail_factor()
    }

    /// The estimated tail as a fraction of the converged total: `T / (explicit + T)`.
    pub fn tail_fraction(&self) -> f64 {
        let total = self.total();
        if total > 0.0 {
            self.tail() / total
        } else {
            0.0
        }
    }

    /// The converged total `E_d + ΣΔ + T` estimated after the last bounce.
    pub fn total(&self) -> f64 {
        self.explicit() + self.tail()
    }

    /// The relative change of the estimated converged total from the bounce before to the
    /// last one, when both extrapolated with a predicted next increment (see the module docs);
    /// `None` before bounce [`FIRST_PREDICTED`]` + 1`.
    pub fn uncertainty(&self) -> Option<f64> {
        let k = self.increments.len();
        if k <= FIRST_PREDICTED {
            return None;
        }
        let before = self.head(k - 1)?;
        before.predicted_next()?;
        let (now, then) = (self.total(), before.total());
        (now > 0.0 && then.is_finite()).then(|| (now - then).abs() / now)
    }

    /// The series of the first `k` bounces; `None` when fewer were recorded (of their
    /// increments or of the light they reflect).
    fn head(&self, k: usize) -> Option<Series> {
        Some(Series {
            direct: self.direct,
            increments: self.increments.get(..k)?.to_vec(),
            reflected: self.reflected.get(..k)?.to_vec(),
        })
    }

    /// Whether explicit bounces can stop at `tolerance` (see the module docs).
    pub fn converged(&self, tolerance: f64) -> bool {
        let k = self.increments.len();
        if k == 0 {
            return false;
        }
        if self.explicit() <= 0.0 || self.increments.last().is_some_and(|&e| e <= 0.0) {
            // No light, or a bounce that adds nothing: nothing is left to converge.
            return true;
        }
        (k >= 2 && self.tail_fraction() < tolerance)
            || self.uncertainty().is_some_and(|u| u < tolerance)
    }
}

/// `λ` of bounce `k` (1-based) from `increments`.
fn ratio_at(increments: &[f64], k: usize) -> Option<f64> {
    if k < 2 {
        return None;
    }
    let (prev, last) = (*increments.get(k - 2)?, *increments.get(k - 1)?);
    (prev > 0.0 && last.is_finite()).then(|| (last / prev).clamp(0.0, MAX_RATIO))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed enclosure of uniform albedo `rho`: each bounce keeps `rho` of the flux, all of
    /// which lands (retention 1).
    fn geometric(direct: f64, first: f64, rho: f64, bounces: usize) -> Series {
        let increments: Vec<f64> = (0..bounces).map(|k| first * rho.powi(k as i32)).collect();
        Series {
            direct,
            reflected: increments.iter().map(|e| rho * e).collect(),
            increments,
        }
    }

    /// Two surfaces with albedos `rho` that pass light to each other: bounce `k + 1` lands
    /// `landing[i][j]` of what surface `i` reflects on surface `j` (each row sums to the
    /// retention). Returns the series of `bounces` bounces and the exact tail after each.
    fn two_surfaces(
        rho: [f64; 2],
        landing: [[f64; 2]; 2],
        first: [f64; 2],
        bounces: usize,
    ) -> (Series, Vec<f64>) {
        let mut x = first;
        let mut s = Series {
            direct: 100.0,
            ..Series::default()
        };
        for _ in 0..4000 {
            let m = [rho[0] * x[0], rho[1] * x[1]];
            s.increments.push(x[0] + x[1]);
            s.reflected.push(m[0] + m[1]);
            x = [0, 1].map(|j| m[0] * landing[0][j] + m[1] * landing[1][j]);
        }
        let tails = (0..=bounces)
            .map(|k| s.increments[k..].iter().sum())
            .collect();
        s.increments.truncate(bounces);
        s.reflected.truncate(bounces);
        (s, tails)
    }

    #[test]
    fn a_geometric_series_is_completed_exactly() {
        for rho in [0.5, 0.8, 0.95] {
            // The closed cube: direct 104.17 lx, each bounce keeps ρ of the flux.
            let exact = 104.17 / (1.0 - rho);
            for bounces in 2..=6 {
                let s = geometric(104.17, 104.17 * rho, rho, bounces);
                assert!((s.total() / exact - 1.0).abs() < 1e-12, "{rho} {bounces}");
                assert_eq!(s.uncertainty().is_some(), bounces > FIRST_PREDICTED);
            }
            let s = geometric(104.17, 104.17 * rho, rho, FIRST_PREDICTED + 1);
            assert!(s.uncertainty().is_some_and(|u| u < 1e-12), "{rho}");
            assert!(s.converged(0.01), "{rho}");
            // Before two predictions only a negligible tail stops.
            assert!(!geometric(104.17, 104.17 * rho, rho, FIRST_PREDICTED).converged(0.01));
        }
    }

    #[test]
    fn the_next_increment_is_predicted_from_the_light_the_last_one_reflects() {
        // A dark floor (0.3) that the lamp lights and a bright ceiling (0.8), each keeping
        // three quarters of what it reflects, a fifth landing on the other: the ratio of
        // successive bounces grows from 0.29 to 0.62 as the light moves to the ceiling (as in
        // a room), while every bounce retains 0.95 of what it reflects.
        let landing = [[0.75, 0.2], [0.2, 0.75]];
        let (s, tails) = two_surfaces([0.3, 0.8], landing, [10.0, 0.0], 12);
        for (k, &exact) in tails.iter().enumerate().take(12).skip(FIRST_PREDICTED) {
            let head = s.head(k).expect("k bounces");
            let next = head.predicted_next().expect("a prediction");
            assert!((next / s.increments[k] - 1.0).abs() < 1e-12, "{k}");
            // Low while the ratio still grows, but nearer the exact tail than the last
            // ratio's extrapolation: by a factor 3 from bounce 4 on (−10 % against −33 %).
            let now = head.ratio().expect("a ratio");
            let plain = head.increments[k - 1] * now / (1.0 - now);
            let tail = head.tail();
            assert!(tail <= exact, "{k}: {tail} {exact}");
            assert!(
                3.0 * (exact - tail) < exact - plain,
                "{k}: {tail} {plain} {exact}"
            );
        }
        // The estimates of the total settle: each change smaller than the one before.
        let changes: Vec<f64> = (FIRST_PREDICTED + 1..=12)
            .map(|k| {
                s.head(k)
                    .and_then(|h| h.uncertainty())
                    .expect("two predictions")
            })
            .collect();
        assert!(changes.windows(2).all(|w| w[1] < w[0]), "{changes:?}");
    }

    #[test]
    fn a_small_tail_stops_early_and_a_changing_estimate_keeps_bouncing() {
        // A tail under the tolerance stops from the second bounce on.
        let s = Series {
            direct: 100.0,
            increments: vec![1.0, 0.05],
            reflected: vec![0.5, 0.025],
        };
        assert!(s.tail_fraction() < 1e-3);
        assert!(s.converged(0.01));
        // Two predictions that disagree by more than the tolerance: not converged.
        let s = Series {
            direct: 100.0,
            increments: vec![60.0, 30.0, 18.0, 11.0, 8.0],
            reflected: vec![30.0, 18.0, 11.0, 8.0, 7.5],
        };
        assert!(s.uncertainty().expect("two predictions") > 0.01);
        assert!(!s.converged(0.01));
    }

    #[test]
    fn a_furnished_rooms_series_stops_where_each_preset_asks() {
        use crate::scene::{Quality, Settings};
        // `chairs_10` at `final` (CPU, 64 texels/m, seed 0): the energies the bake measured
        // after each of its nine bounces (its manifest's `stats.series`).
        let full = Series {
            direct: 42_812_811.25,
            increments: vec![
                17_014_013.375,
                8_874_070.75,
                5_387_196.937_5,
                3_356_420.062_5,
                2_141_689.953_125,
                1_379_286.265_625,
                894_673.898_437_5,
                583_247.710_937_5,
                381_811.589_843_75,
            ],
            reflected: vec![
                8_861_058.187_5,
                4_675_906.343_75,
                2_978_679.109_375,
                1_868_601.843_75,
                1_210_823.937_5,
                785_497.894_531_25,
                513_965.191_406_25,
                337_296.75,
                222_252.968_75,
            ],
        };
        let stop = |tolerance: f64| {
            (1..=full.increments.len())
                .find(|&k| full.head(k).expect("k bounces").converged(tolerance))
        };
        let tolerance = |q| f64::from(Settings::preset(q).tail_tolerance);
        assert_eq!(stop(tolerance(Quality::Default)), Some(5));
        // The old `final` tolerance (0.2 %) stopped at bounce 6, where the tail, put where
        // the sixth bounce's light lies, read the points 0.1 % high; `final` runs to 9.
        assert_eq!(stop(0.002), Some(6));
        assert_eq!(stop(tolerance(Quality::Final)), Some(9));
        // The converged totals estimated after bounces 6 and 9 differ by 0.04 %: the tail's
        // energy was right, its place is what the later bounces fix.
        let (six, nine) = (full.head(6).expect("six").total(), full.total());
        assert!((six / nine - 1.0).abs() < 5e-4, "{six} {nine}");
    }

    #[test]
    fn degenerate_series_stay_finite() {
        let none = Series::default();
        assert!(!none.converged(0.01));
        assert_eq!(none.tail(), 0.0);
        let dark = Series {
            direct: 0.0,
            increments: vec![0.0],
            reflected: vec![0.0],
        };
        assert!(dark.converged(0.01));
        assert_eq!(dark.tail_fraction(), 0.0);
        let lossless = Series {
            direct: 1.0,
            increments: vec![1.0; 5],
            reflected: vec![1.0; 5],
        };
        assert_eq!(lossless.ratio(), Some(MAX_RATIO));
        assert!(lossless.tail().is_finite());
        assert!(lossless.tail_fraction() < 1.0);
        let growing = Series {
            direct: 1.0,
            increments: vec![1.0, 3.0],
            reflected: vec![0.5, 1.5],
        };
        assert_eq!(growing.ratio(), Some(MAX_RATIO));
        // Nothing reflected, or retentions that cannot be measured: no prediction, or none
        // of light that is not there.
        let black = Series {
            direct: 1.0,
            increments: vec![1.0, 0.5, 0.25, 0.125],
            reflected: vec![0.5, 0.25, 0.125, 0.0],
        };
        assert_eq!(black.predicted_next(), Some(0.0));
        assert_eq!(black.tail(), 0.0);
        let unmeasured = Series {
            reflected: vec![0.0; 4],
            ..black.clone()
        };
        assert_eq!(unmeasured.predicted_next(), None);
        assert!(unmeasured.tail() > 0.0 && unmeasured.tail().is_finite());
        let infinite = Series {
            reflected: vec![f64::INFINITY; 4],
            ..black
        };
        assert!(infinite.tail().is_finite());
    }
}
