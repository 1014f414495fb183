//! Where models and solvers meet: the linear time-periodic system x' = P(t) x + f(t) (Eq 3) as a trait,
//! and the periodic coefficient types it is built from.
//!
//! ```text
//! M(t) y'' + C(t) y' + K(t) y = d(t)            (Eq 2, all entries T-periodic)
//! x = [y; y'],  x' = P(t) x + f(t)                (Eqs 3-4)
//! P = [ 0  I ; -M^-1 K  -M^-1 C ],  f = [ 0 ; M^-1 d ]   (Eq 5)
//! ```
//! Models (`crate::model`) implement [`PeriodicSystem`]; solvers (`crate::solver`) only see this trait.

pub mod coefficient;
pub mod fourier;
pub mod two_tone;

pub use coefficient::{Coefficient, PiecewiseConstant};
pub use fourier::FourierSeries;
pub use two_tone::TwoToneForm;

use nalgebra::{DMatrix, DVector};

/// Which one-sided limit to take where a coefficient jumps (at a breakpoint).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// lim_{s -> t+} (the value on the piece that starts at t).
    Right,
    /// lim_{s -> t-} (the value on the piece that ends at t).
    Left,
}

/// A linear time-periodic first-order system x' = P(t) x + f(t) of period T (Eq 3).
pub trait PeriodicSystem: Sync {
    /// State dimension n (twice the number of degrees of freedom for a second-order model).
    fn dim(&self) -> usize;
    /// Period T in s.
    fn period_s(&self) -> f64;
    /// Writes P(t) (n x n) and f(t) (n) at time t (s), taking the `side` limit at a breakpoint.
    fn eval(&self, t: f64, side: Side, p: &mut DMatrix<f64>, f: &mut DVector<f64>);
    /// Writes P(t) only (for homogeneous companions); the default evaluates f too and discards it.
    fn eval_matrix(&self, t: f64, side: Side, p: &mut DMatrix<f64>) {
        let mut f = DVector::zeros(self.dim());
        self.eval(t, side, p, &mut f);
    }
    /// Appends P at the equally spaced times t0 + j dt (s), j = 0..count (each n x n column-major, the right
    /// limit at a breakpoint) to `out`; the default evaluates [`PeriodicSystem::eval`] at each time (into one
    /// P and f for all of them), a model may share work between the times.
    fn eval_matrix_uniform(&self, t0: f64, dt: f64, count: usize, out: &mut Vec<f64>) {
        let n = self.dim();
        let (mut p, mut f) = (DMatrix::zeros(n, n), DVector::zeros(n));
        for j in 0..count {
            self.eval(t0 + j as f64 * dt, Side::Right, &mut p, &mut f);
            out.extend_from_slice(p.as_slice());
        }
    }
    /// Times in (0, T) where P or f jump, sorted; empty for smooth coefficients.
    fn breakpoints(&self) -> Vec<f64> {
        Vec::new()
    }
    /// The second-order Fourier form (M, C, K, d as Fourier series of the period), for frequency-domain
    /// solvers; `None` when the coefficients are not finite Fourier series.
    fn fourier_form(&self) -> Option<FourierForm> {
        None
    }
    /// True when P(t) and f(t) are constant between breakpoints: then exact exponentials per piece (the
    /// Magnus scheme) solve the system exactly with one step per piece.
    fn piecewise_constant(&self) -> bool {
        false
    }
    /// Terms summed by one evaluation of P(t) and f(t) (Fourier terms and table pieces over all entries): the
    /// cost of one `eval`, for work estimates before solving.
    fn eval_terms(&self) -> usize {
        self.dim() * self.dim() * (self.max_harmonic() + 1)
    }
    /// Highest harmonic of 1/T in the coefficients (a lower bound on the resolution a solver needs).
    fn max_harmonic(&self) -> usize;
    /// Period of P(t) alone in s (the period divided by a whole number): the monodromy over T is the
    /// monodromy over this period raised to T / this. Defaults to the full period.
    fn homogeneous_period_s(&self) -> f64 {
        self.period_s()
    }
}

/// Greatest common divisor (gcd(a, 0) = a): coupling strides of harmonics, hunting periods of teeth counts.
pub fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// x' = P x + f from an evaluated P and f (written into `out`, length n).
pub fn state_derivative(p: &DMatrix<f64>, f: &DVector<f64>, x: &[f64], out: &mut [f64]) {
    for (r, o) in out.iter_mut().enumerate() {
        *o = f[r] + x.iter().enumerate().map(|(c, v)| p[(r, c)] * v).sum::<f64>();
    }
}

/// Second-order system whose entries are Fourier series of one common base frequency 2 pi / T.
#[derive(Clone, Debug)]
pub struct FourierForm {
    /// Degrees of freedom N.
    pub dof: usize,
    /// Period T in s.
    pub period_s: f64,
    /// Row-major N x N mass, damping and stiffness entries.
    pub mass: Vec<FourierSeries>,
    /// Row-major N x N damping entries.
    pub damping: Vec<FourierSeries>,
    /// Row-major N x N stiffness entries.
    pub stiffness: Vec<FourierSeries>,
    /// N forcing entries.
    pub forcing: Vec<FourierSeries>,
}
