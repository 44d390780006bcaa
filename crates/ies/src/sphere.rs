//! The full-sphere intensity model every file is expanded into at load.
//!
//! A [`Sphere`] is a grid over two angles about a polar axis: θ ∈ [0, π] measured from the
//! pole at −axis, and φ around the axis. Types C and A use the polar axis +Z with φ = 0 toward
//! +X and φ = π/2 toward +Y; type B uses the polar axis +Y with φ = 0 toward +X and φ = π/2
//! toward +Z (see the crate docs). Values are interpolated bilinearly in (θ, φ); outside the
//! measured θ range, and outside the measured φ range of a grid that does not go all the way
//! round, the intensity is zero.

use std::f64::consts::{PI, TAU};

/// Angular slack, in radians, when deciding whether a direction lies on a grid edge.
const EPS: f64 = 1e-9;

/// Which axis is the grid's polar axis (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Axis {
    /// Polar axis +Z: photometric types C and A.
    Z,
    /// Polar axis +Y: photometric type B.
    Y,
}

/// Direction for grid angles (radians) about `axis`.
pub(crate) fn direction(axis: Axis, theta: f64, phi: f64) -> [f64; 3] {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    match axis {
        Axis::Z => [st * cp, st * sp, -ct],
        Axis::Y => [st * cp, -ct, st * sp],
    }
}

/// Grid angles (θ, φ) in radians of a direction about `axis`; φ in (−π, π]. The direction need
/// not be unit length; the zero vector gives (π/2, 0).
pub(crate) fn angles(axis: Axis, d: [f64; 3]) -> (f64, f64) {
    let [x, y, z] = d;
    match axis {
        Axis::Z => (x.hypot(y).atan2(-z), y.atan2(x)),
        Axis::Y => (x.hypot(z).atan2(-y), z.atan2(x)),
    }
}

/// The expanded full-sphere grid.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Sphere {
    pub(crate) axis: Axis,
    /// θ nodes in degrees, strictly increasing, within [0, 180].
    pub(crate) theta_deg: Vec<f64>,
    /// φ nodes in degrees, strictly increasing; when `periodic`, less than 360° apart end to end.
    pub(crate) phi_deg: Vec<f64>,
    theta: Vec<f64>,
    phi: Vec<f64>,
    /// Whether φ goes all the way round (the last node connects to the first + 360°).
    pub(crate) periodic: bool,
    /// Values in candela, `values[i_phi * theta.len() + j_theta]`.
    values: Vec<f64>,
}

impl Sphere {
    /// Builds a grid. `values[i * theta_deg.len() + j]` is the value at `phi_deg[i]`,
    /// `theta_deg[j]`. When a θ node is a pole (0° or 180°) its values are replaced by their
    /// mean, so the intensity is continuous at the pole whatever the file says.
    ///
    /// The caller guarantees non-empty, strictly increasing lists of matching size.
    pub(crate) fn new(
        axis: Axis,
        theta_deg: Vec<f64>,
        phi_deg: Vec<f64>,
        mut values: Vec<f64>,
        periodic: bool,
    ) -> Sphere {
        let nt = theta_deg.len();
        let np = phi_deg.len();
        debug_assert_eq!(values.len(), nt * np);
        for (j, &t) in theta_deg.iter().enumerate() {
            if t == 0.0 || t == 180.0 {
                let sum: f64 = (0..np).filter_map(|i| values.get(i * nt + j)).sum();
                let mean = sum / np as f64;
                for i in 0..np {
                    if let Some(v) = values.get_mut(i * nt + j) {
                        *v = mean;
                    }
                }
            }
        }
        Sphere {
            axis,
            theta: theta_deg.iter().map(|d| d.to_radians()).collect(),
            phi: phi_deg.iter().map(|d| d.to_radians()).collect(),
            theta_deg,
            phi_deg,
            periodic,
            values,
        }
    }

    /// The node value at φ index `i_phi`, θ index `j_theta` (0 outside the grid).
    pub(crate) fn value(&self, i_phi: usize, j_theta: usize) -> f64 {
        self.values
            .get(i_phi * self.theta.len() + j_theta)
            .copied()
            .unwrap_or(0.0)
    }

    /// Interpolated value at a direction (any length; zero or non-finite gives 0).
    pub(crate) fn eval_dir(&self, d: [f64; 3]) -> f64 {
        let m = d[0].abs().max(d[1].abs()).max(d[2].abs());
        if !(m > 0.0 && m.is_finite()) {
            return 0.0;
        }
        let d = [d[0] / m, d[1] / m, d[2] / m];
        let (theta, phi) = angles(self.axis, d);
        self.eval(theta, phi)
    }

    /// Interpolated value at grid angles in radians (θ from the −axis pole, φ any real).
    pub(crate) fn eval(&self, theta: f64, phi: f64) -> f64 {
        if !(theta.is_finite() && phi.is_finite()) {
            return 0.0;
        }
        let (Some(&t0), Some(&tl)) = (self.theta.first(), self.theta.last()) else {
            return 0.0;
        };
        if theta < t0 - EPS || theta > tl + EPS {
            return 0.0;
        }
        let (j0, j1, ft) = bracket(&self.theta, theta.clamp(t0, tl));
        let Some((i0, i1, fp)) = self.phi_cell(phi) else {
            return 0.0;
        };
        let a = self.value(i0, j0) * (1.0 - ft) + self.value(i0, j1) * ft;
        let b = self.value(i1, j0) * (1.0 - ft) + self.value(i1, j1) * ft;
        a * (1.0 - fp) + b * fp
    }

    /// The φ cell (two node indices and the weight of the second) holding `phi`, or `None`
    /// outside a non-periodic grid.
    fn phi_cell(&self, phi: f64) -> Option<(usize, usize, f64)> {
        let n = self.phi.len();
        let (&p0, &pl) = (self.phi.first()?, self.phi.last()?);
        let mut p = (phi - p0).rem_euclid(TAU) + p0;
        if p >= p0 + TAU - EPS {
            p = p0;
        }
        if n == 1 {
            return (self.periodic || p <= p0 + EPS).then_some((0, 0, 0.0));
        }
        if self.periodic {
            if p >= pl {
                let f = ((p - pl) / (p0 + TAU - pl)).clamp(0.0, 1.0);
                return Some((n - 1, 0, f));
            }
            return Some(bracket(&self.phi, p));
        }
        if p > pl + EPS {
            return None;
        }
        Some(bracket(&self.phi, p.min(pl)))
    }

    /// Exact integral of the interpolated values over the sphere, ∫ I dΩ (lumens for candela).
    pub(crate) fn integral(&self) -> f64 {
        let nt = self.theta.len();
        // Per θ cell, the integrals of the two linear weights times sin θ.
        let mut theta_weights = Vec::with_capacity(nt.saturating_sub(1));
        for w in self.theta.windows(2) {
            let (t0, t1) = (w[0], w[1]);
            let dt = t1 - t0;
            let s1 = (t1.sin() - t0.sin()) / dt - t1.cos();
            let s0 = (t0.cos() - t1.cos()) - s1;
            theta_weights.push((s0, s1));
        }
        // θ-integral of the interpolant along the φ node i.
        let column = |i: usize| -> f64 {
            theta_weights
                .iter()
                .enumerate()
                .map(|(j, &(s0, s1))| self.value(i, j) * s0 + self.value(i, j + 1) * s1)
                .sum()
        };
        let n = self.phi.len();
        let cols: Vec<f64> = (0..n).map(column).collect();
        if n == 1 {
            return if self.periodic { cols[0] * TAU } else { 0.0 };
        }
        let mut total: f64 = self
            .phi
            .windows(2)
            .zip(cols.windows(2))
            .map(|(p, c)| (p[1] - p[0]) * 0.5 * (c[0] + c[1]))
            .sum();
        if self.periodic {
            let gap = self.phi[0] + TAU - self.phi[n - 1];
            total += gap * 0.5 * (cols[n - 1] + cols[0]);
        }
        total
    }

    /// The largest node value and its grid angles (radians). Bilinear interpolation never
    /// exceeds its corner values, so this is the maximum over all directions.
    pub(crate) fn max(&self) -> (f64, f64, f64) {
        let nt = self.theta.len().max(1);
        let mut best = (0.0, PI, 0.0);
        let mut found = false;
        for (k, &v) in self.values.iter().enumerate() {
            if !found || v > best.0 {
                let t = self.theta.get(k % nt).copied().unwrap_or(0.0);
                let p = self.phi.get(k / nt).copied().unwrap_or(0.0);
                best = (v, t, p);
                found = true;
            }
        }
        best
    }
}

/// For `x` within `[list[0], list[last]]`: the bracketing node indices and the weight of the
/// second. A single-node list gives `(0, 0, 0.0)`.
fn bracket(list: &[f64], x: f64) -> (usize, usize, f64) {
    let n = list.len();
    if n < 2 {
        return (0, 0, 0.0);
    }
    let k = list.partition_point(|&a| a <= x);
    let j = k.saturating_sub(1).min(n - 2);
    let (a, b) = (list[j], list[j + 1]);
    let f = ((x - a) / (b - a)).clamp(0.0, 1.0);
    (j, j + 1, f)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn constant(periodic: bool, phi: Vec<f64>) -> Sphere {
        let n = phi.len();
        Sphere::new(Axis::Z, vec![0.0, 180.0], phi, vec![2.0; 2 * n], periodic)
    }

    #[test]
    fn constant_integrates_to_four_pi() {
        for phi in [vec![0.0], vec![0.0, 90.0, 200.0]] {
            let s = constant(true, phi);
            assert!((s.integral() - 8.0 * PI).abs() < 1e-12);
        }
    }

    #[test]
    fn bounded_half_integrates_to_half() {
        let s = constant(false, vec![-90.0, 90.0]);
        assert!((s.integral() - 4.0 * PI).abs() < 1e-12);
        assert_eq!(s.eval(1.0, PI), 0.0);
        assert_eq!(s.eval(1.0, 0.3), 2.0);
        assert_eq!(s.eval(1.0, -PI / 2.0), 2.0);
    }

    #[test]
    fn directions_round_trip() {
        for axis in [Axis::Z, Axis::Y] {
            for &(t, p) in &[(0.3, 0.2), (2.0, -1.0), (1.0, 3.0)] {
                let d = direction(axis, t, p);
                let (t2, p2) = angles(axis, d);
                assert!((t - t2).abs() < 1e-12 && (p - p2).abs() < 1e-12, "{axis:?}");
            }
        }
    }

    #[test]
    fn pole_is_averaged() {
        let s = Sphere::new(
            Axis::Z,
            vec![0.0, 90.0],
            vec![0.0, 180.0],
            vec![1.0, 5.0, 3.0, 5.0],
            true,
        );
        assert_eq!(s.eval(0.0, 0.0), 2.0);
        assert_eq!(s.eval(0.0, 1.0), 2.0);
    }
}
