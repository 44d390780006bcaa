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
//! have equal area at the uniform texel density, so a sum is proportional to the flux):
//! `λ_K = ΣΔ_K / ΣΔ_{K−1}`. In a closed enclosure of uniform albedo ρ every bounce keeps
//! exactly ρ of the flux, so `λ_k = ρ` from the first ratio on and the extrapolation is exact
//! (CIE 171:2006 test case 5.8); in a room it converges geometrically to the dominant mode.
//!
//! # The ratios' trend
//! In a room the ratio still grows when the bake stops: on `chairs_05` at the default
//! λ₂ … λ₁₀ = 0.576, 0.617, 0.638, 0.645, 0.650, 0.656, 0.660 (the first bounces land on
//! what the lamps light, the later ones spread to the ceiling and the furniture), so
//! `λ_K/(1−λ_K)` underestimates the tail — by about 8 % of it at K = 4, where the tail is 8 % of
//! the light: −0.6 % over every surface against Radiance, −1.3 % on the ceiling. From the
//! fourth bounce on, when the last three ratios step in the same direction by shrinking steps
//! ([`Series::ratio_trend`]), the left-out ratios are taken to continue that geometric
//! approach, `λ_{K+i} = λ_∞ − (λ_∞ − λ_K)·qⁱ`, and the tail is `ΔΣ_K · Σ_{n≥1} Π_{i≤n} λ_{K+i}`.
//! A constant ratio (the closed cube) has no trend and keeps the exact plain extrapolation.
//!
//! # Stopping rule
//! After bounce `K ≥ 2` the estimated tail fraction is `τ = T / (E_d + ΣΔ + T)` with
//! `T = ΣΔ_K · λ/(1−λ)` — what the explicit bounces leave out. Explicit bounces stop when either
//! - the tail itself is negligible: `τ < tolerance`; or
//! - the extrapolation is trustworthy: from `K ≥ 3` on, the change of the ratio between
//!   the last two bounces, propagated through `∂T/∂λ = ΣΔ_K / (1 − λ)²`, moves the total by
//!   less than the tolerance: `ΣΔ_K · |λ_K − λ_{K−1}| / ((1 − λ_K)² · total) < tolerance`;
//!
//! or at the hard cap of explicit bounces. λ is clamped to `[0, MAX_RATIO]`, so a noisy or
//! lossless (ρ = 1) estimate never yields an infinite tail.

/// Largest bounce ratio used for the tail (a lossless enclosure would have an infinite
/// series; 0.995 bounds the tail at 199 × the last increment).
pub const MAX_RATIO: f64 = 0.995;
/// Largest rate at which the ratios' steps may shrink for [`Series::ratio_trend`] to
/// extrapolate them: slower than that, the limit lies too far beyond the last ratio to trust.
pub const MAX_TREND_RATE: f64 = 0.8;
/// Most terms of the trend's tail sum (the products fall at least as `MAX_RATIO^n`).
const TAIL_TERMS: usize = 20_000;

/// Energies of a bake's direct light and explicit bounce increments (sums over valid texels).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Series {
    /// Σ of the direct illuminance.
    pub direct: f64,
    /// Σ of each bounce's increment `Δ_k`, `k = 1 ..`.
    pub increments: Vec<f64>,
}

impl Series {
    /// The ratio `λ_K = ΣΔ_K / ΣΔ_{K−1}` of the last two bounces, clamped to
    /// `[0, MAX_RATIO]`; `None` before the second bounce or without light in the previous one.
    pub fn ratio(&self) -> Option<f64> {
        ratio_at(&self.increments, self.increments.len())
    }

    /// The factor `f` with which the last increment estimates the tail (0 without a ratio):
    /// `λ/(1−λ)`, or with a trend of the ratios ([`Series::ratio_trend`]) the sum
    /// `Σ_{n≥1} Π_{i=1..n} λ_{K+i}` of the ratios the trend predicts (see the module docs).
    pub fn tail_factor(&self) -> f64 {
        let Some(now) = self.ratio() else {
            return 0.0;
        };
        let Some((limit, rate)) = self.ratio_trend() else {
            return now / (1.0 - now);
        };
        // λ_{K+i} = limit − (limit − λ_K)·rate^i; the products fall at least as 0.995^n.
        let (mut f, mut product, mut gap) = (0.0, 1.0, limit - now);
        for _ in 0..TAIL_TERMS {
            gap *= rate;
            product *= (limit - gap).clamp(0.0, MAX_RATIO);
            f += product;
            if product <= 1e-12 * f {
                break;
            }
        }
        f
    }

    /// The trend of the last three ratios `λ_{K−2}, λ_{K−1}, λ_K`, when their steps shrink
    /// geometrically at a rate `q = (λ_K − λ_{K−1}) / (λ_{K−1} − λ_{K−2})` in `(0, MAX_TREND_RATE]`:
    /// the limit `λ_∞ = λ_K + (λ_K − λ_{K−1})·q/(1 − q)` (Aitken's Δ², clamped to
    /// `[0, MAX_RATIO]`) and `q`. `None` before the fourth bounce, for a constant ratio (a
    /// closed enclosure of uniform albedo: the plain extrapolation is exact) or for steps that
    /// change sign or do not shrink (noise, not a trend).
    pub fn ratio_trend(&self) -> Option<(f64, f64)> {
        let k = self.increments.len();
        if k < 4 {
            return None;
        }
        let [a, b, c] = [k - 2, k - 1, k].map(|j| ratio_at(&self.increments, j));
        let (a, b, c) = (a?, b?, c?);
        let (d1, d2) = (b - a, c - b);
        if d1 == 0.0 || !d1.is_finite() || !d2.is_finite() {
            return None;
        }
        let rate = d2 / d1;
        if !(rate > 0.0 && rate <= MAX_TREND_RATE) {
            return None;
        }
        let limit = (c + d2 * rate / (1.0 - rate)).clamp(0.0, MAX_RATIO);
        Some((limit, rate))
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
        let total = self.explicit() + self.tail();
        if total > 0.0 {
            self.tail() / total
        } else {
            0.0
        }
    }

    /// The relative change of the total that the last change of the ratio implies (see the
    /// module docs); `None` before the third bounce.
    pub fn uncertainty(&self) -> Option<f64> {
        let k = self.increments.len();
        let (now, before) = (
            ratio_at(&self.increments, k)?,
            ratio_at(&self.increments, k - 1)?,
        );
        let total = self.explicit() + self.tail();
        let last = self.increments.last().copied().unwrap_or(0.0);
        (total > 0.0).then(|| last * (now - before).abs() / ((1.0 - now).powi(2) * total))
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

    fn geometric(direct: f64, first: f64, ratio: f64, bounces: usize) -> Series {
        Series {
            direct,
            increments: (0..bounces).map(|k| first * ratio.powi(k as i32)).collect(),
        }
    }

    #[test]
    fn a_geometric_series_is_completed_exactly() {
        for rho in [0.5, 0.8, 0.95] {
            // The closed cube: direct 104.17 lx, each bounce keeps ρ of the flux.
            let s = geometric(104.17, 104.17 * rho, rho, 3);
            let converged = s.explicit() + s.tail();
            let exact = 104.17 / (1.0 - rho);
            assert!((converged / exact - 1.0).abs() < 1e-12, "{rho}");
            assert!(s.uncertainty().is_some_and(|u| u < 1e-12), "{rho}");
            assert!(s.converged(0.01), "{rho}");
            // Two bounces give the ratio but no check of it: only a negligible tail stops.
            assert!(!geometric(104.17, 104.17 * rho, rho, 2).converged(0.01));
        }
    }

    #[test]
    fn a_drifting_ratio_keeps_bouncing_and_a_small_tail_stops() {
        // Ratios 0.3 then 0.6: not converged at a 1 % tolerance.
        let s = Series {
            direct: 100.0,
            increments: vec![50.0, 15.0, 9.0],
        };
        assert!(s.uncertainty().expect("three bounces") > 0.01);
        assert!(!s.converged(0.01));
        // A tail under the tolerance stops from the second bounce on.
        let s = Series {
            direct: 100.0,
            increments: vec![1.0, 0.05],
        };
        assert!(s.tail_fraction() < 1e-3);
        assert!(s.converged(0.01));
    }

    #[test]
    fn a_ratio_that_approaches_its_limit_geometrically_is_extrapolated_along_its_trend() {
        // λ_k = 0.7 − 0.2·0.5^k: increments Δ_k = Δ_{k−1}·λ_k.
        let lambda = |k: i32| 0.7 - 0.2 * 0.5f64.powi(k);
        let mut increments = vec![10.0];
        for k in 2..=400 {
            let last = *increments.last().expect("one");
            increments.push(last * lambda(k));
        }
        for bounces in 4..=8 {
            let s = Series {
                direct: 20.0,
                increments: increments[..bounces].to_vec(),
            };
            let exact: f64 = increments[bounces..].iter().sum();
            let (limit, rate) = s.ratio_trend().expect("a trend");
            assert!(
                (limit - 0.7).abs() < 1e-9 && (rate - 0.5).abs() < 1e-9,
                "{limit} {rate}"
            );
            assert!(
                (s.tail() / exact - 1.0).abs() < 1e-9,
                "{bounces}: {} vs {exact}",
                s.tail()
            );
            // The plain extrapolation with the last ratio falls short while the ratio grows.
            let now = s.ratio().expect("ratio");
            let plain = s.increments[bounces - 1] * now / (1.0 - now);
            assert!(
                bounces > 5 || plain < 0.99 * exact,
                "{bounces}: {plain} vs {exact}"
            );
        }
        // Steps that change sign (noise) or do not shrink are no trend.
        let zigzag = Series {
            direct: 1.0,
            increments: vec![1.0, 0.5, 0.3, 0.15, 0.1],
        };
        assert_eq!(zigzag.ratio_trend(), None);
        let speeding = Series {
            direct: 1.0,
            increments: vec![1.0, 0.3, 0.1, 0.04, 0.02],
        };
        assert_eq!(speeding.ratio_trend(), None);
    }

    #[test]
    fn degenerate_series_stay_finite() {
        let none = Series::default();
        assert!(!none.converged(0.01));
        assert_eq!(none.tail(), 0.0);
        let dark = Series {
            direct: 0.0,
            increments: vec![0.0],
        };
        assert!(dark.converged(0.01));
        assert_eq!(dark.tail_fraction(), 0.0);
        let lossless = Series {
            direct: 1.0,
            increments: vec![1.0, 1.0, 1.0],
        };
        assert_eq!(lossless.ratio(), Some(MAX_RATIO));
        assert!(lossless.tail().is_finite());
        assert!(lossless.tail_fraction() < 1.0);
        let growing = Series {
            direct: 1.0,
            increments: vec![1.0, 3.0],
        };
        assert_eq!(growing.ratio(), Some(MAX_RATIO));
    }
}
