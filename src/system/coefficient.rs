//! A periodic scalar coefficient: a Fourier series or a piecewise-constant table.

use super::{FourierSeries, Side};

/// Piecewise-constant periodic function: `values[j]` on `[starts[j], starts[j+1])`, repeated with period
/// `period_s`. `starts[0]` is 0 and starts are increasing and below the period.
#[derive(Clone, Debug, PartialEq)]
pub struct PiecewiseConstant {
    /// Period in s.
    pub period_s: f64,
    /// Start time of each piece in s.
    pub starts: Vec<f64>,
    /// Value on each piece.
    pub values: Vec<f64>,
}

impl PiecewiseConstant {
    /// Value at t, taking the `side` limit at a jump. A time within 1e-9 of the period from a jump counts as
    /// on it: jump times computed as `start + cycle * period` by a caller differ from `starts` by rounding,
    /// and taking the wrong side there would cost a step-based solver its order of accuracy.
    pub fn eval(&self, t: f64, side: Side) -> f64 {
        let tol = 1e-9 * self.period_s;
        let mut tau = t.rem_euclid(self.period_s);
        if self.period_s - tau <= tol {
            tau -= self.period_s; // just before the next period's start: the same as just before 0
        }
        // position of the first start beyond tau (Right) or at/beyond tau (Left), jumps within tol counted
        let idx = match side {
            Side::Right => self.starts.partition_point(|&s| s <= tau + tol),
            Side::Left => self.starts.partition_point(|&s| s < tau - tol),
        };
        let j = if idx == 0 { self.values.len() - 1 } else { idx - 1 };
        self.values[j]
    }

    /// Time average over one period.
    pub fn mean(&self) -> f64 {
        let mut sum = 0.0;
        for (j, v) in self.values.iter().enumerate() {
            let end = self.starts.get(j + 1).copied().unwrap_or(self.period_s);
            sum += v * (end - self.starts[j]);
        }
        sum / self.period_s
    }

    /// Jump times of one period in (0, period) plus 0 when the function jumps across the period end.
    pub fn jumps(&self) -> Vec<f64> {
        let n = self.values.len();
        (0..n).filter(|&j| self.values[j] != self.values[(j + n - 1) % n]).map(|j| self.starts[j]).collect()
    }
}

/// A periodic coefficient of a second-order system.
#[derive(Clone, Debug, PartialEq)]
pub enum Coefficient {
    /// Smooth: truncated Fourier series.
    Fourier(FourierSeries),
    /// Piecewise constant (for example a rectangular mesh stiffness).
    Piecewise(PiecewiseConstant),
}

impl Coefficient {
    /// A constant coefficient.
    pub fn constant(v: f64) -> Self {
        Self::Fourier(FourierSeries::constant(v))
    }
    /// Value at t.
    pub fn eval(&self, t: f64, side: Side) -> f64 {
        match self {
            Self::Fourier(s) => s.eval(t),
            Self::Piecewise(p) => p.eval(t, side),
        }
    }
    /// True when the value never changes.
    pub fn is_constant(&self) -> bool {
        match self {
            Self::Fourier(s) => s.is_constant(),
            Self::Piecewise(p) => p.values.iter().all(|&v| v == p.values[0]),
        }
    }
    /// Jump times within one period of the coefficient.
    pub fn jumps(&self) -> Vec<f64> {
        match self {
            Self::Fourier(_) => Vec::new(),
            Self::Piecewise(p) => p.jumps(),
        }
    }
    /// Highest harmonic (0 for piecewise, which has infinitely many; callers treat it separately).
    pub fn harmonics(&self) -> usize {
        match self {
            Self::Fourier(s) => s.harmonics(),
            Self::Piecewise(_) => 0,
        }
    }
    /// Time average.
    pub fn mean(&self) -> f64 {
        match self {
            Self::Fourier(s) => s.mean,
            Self::Piecewise(p) => p.mean(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn piecewise_eval_works() {
        let p = PiecewiseConstant { period_s: 2.0, starts: vec![0.0, 0.5, 1.5], values: vec![1.0, 2.0, 3.0] };
        assert_eq!(p.eval(0.25, Side::Right), 1.0);
        assert_eq!(p.eval(0.5, Side::Right), 2.0);
        assert_eq!(p.eval(0.5, Side::Left), 1.0);
        assert_eq!(p.eval(0.0, Side::Left), 3.0);
        assert_eq!(p.eval(2.0, Side::Right), 1.0);
        assert_eq!(p.eval(-0.25, Side::Right), 3.0);
        assert!((p.mean() - (0.5 + 2.0 + 1.5) / 2.0).abs() < 1e-15);
        assert_eq!(p.jumps(), vec![0.0, 0.5, 1.5]);
        // a jump time off by rounding still takes the side asked for
        let near = 0.5 * (1.0 + 4.0 * f64::EPSILON);
        assert_eq!(p.eval(near, Side::Left), 1.0);
        assert_eq!(p.eval(0.5 * (1.0 - 4.0 * f64::EPSILON), Side::Right), 2.0);
        assert_eq!(p.eval(2.0 * (1.0 - f64::EPSILON), Side::Right), 1.0);
        assert_eq!(p.eval(2.0 * (1.0 - f64::EPSILON), Side::Left), 3.0);
    }
}
