//! Evenly spread test directions.

/// `n` unit directions on a Fibonacci sphere (z from `1 − 1/n` down to `−1 + 1/n`, successive
/// points a golden angle apart about z): an even, deterministic spread over the whole sphere.
pub fn fibonacci_sphere(n: usize) -> Vec<[f64; 3]> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            [r * phi.cos(), r * phi.sin(), z]
        })
        .collect()
}

/// `n` directions for testing an intensity-table look-up (any length, as the look-ups take
/// them): the poles, C = 0 reached from both sides of the wrap (±0 and ±10⁻⁹ across it), the
/// −x axis, the zero vector and a non-unit vector, then directions drawn uniformly from
/// `[−2, 2]³` with `rng`.
pub fn photometric_test_directions(rng: &mut crate::SplitMix64, n: usize) -> Vec<[f32; 3]> {
    let mut dirs: Vec<[f32; 3]> = vec![
        [0.0, 0.0, -1.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [1.0, -0.0, 0.0],
        [1.0, 1e-9, 0.3],
        [1.0, -1e-9, -0.3],
        [-1.0, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        [3.0, 4.0, -12.0],
    ];
    while dirs.len() < n {
        dirs.push([0, 1, 2].map(|_| rng.range(-2.0, 2.0)));
    }
    dirs
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_directions_spread_over_the_sphere() {
        let d = fibonacci_sphere(1000);
        assert_eq!(d.len(), 1000);
        let mut mean = [0.0; 3];
        for v in &d {
            let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            assert!((len - 1.0).abs() < 1e-12);
            for k in 0..3 {
                mean[k] += v[k] / 1000.0;
            }
        }
        assert!(mean.iter().all(|m| m.abs() < 1e-2), "{mean:?}");
    }
}
