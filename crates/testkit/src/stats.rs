//! Error statistics of tests that compare computed values with expected ones.

/// The largest and the mean relative error `|got − want| / |want|` of the values added.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct RelativeError {
    /// The largest relative error (0 before any value).
    pub max: f64,
    /// The sum of the relative errors.
    pub sum: f64,
    /// How many values were added.
    pub n: usize,
}

impl RelativeError {
    /// Adds the error of `got` against `want`.
    pub fn add(&mut self, got: f64, want: f64) {
        let e = (got - want).abs() / want.abs();
        self.max = self.max.max(e);
        self.sum += e;
        self.n += 1;
    }

    /// The mean relative error (0 before any value).
    pub fn mean(&self) -> f64 {
        self.sum / self.n.max(1) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn largest_and_mean() {
        let mut e = RelativeError::default();
        assert_eq!(e.mean(), 0.0);
        e.add(1.1, 1.0);
        e.add(-3.0, -4.0);
        assert_eq!(e.n, 2);
        assert!((e.max - 0.25).abs() < 1e-12);
        assert!((e.mean() - 0.175).abs() < 1e-12);
    }
}
