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

/// `<n> values, max rel err <max>, mean <mean>` (the errors in scientific notation).
impl std::fmt::Display for RelativeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} values, max rel err {:.2e}, mean {:.2e}",
            self.n,
            self.max,
            self.mean()
        )
    }
}

/// The errors of `(got, want)` pairs, as [`RelativeError::add`] adds them.
impl FromIterator<(f64, f64)> for RelativeError {
    fn from_iter<I: IntoIterator<Item = (f64, f64)>>(pairs: I) -> Self {
        let mut e = RelativeError::default();
        for (got, want) in pairs {
            e.add(got, want);
        }
        e
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
        let collected: RelativeError = [(1.1, 1.0), (-3.0, -4.0)].into_iter().collect();
        assert_eq!(collected, e);
        assert_eq!(e.to_string(), "2 values, max rel err 2.50e-1, mean 1.75e-1");
    }
}
