//! Physical models of linear time-periodic (LTP) machines, each built into a [`PeriodicSystem`].
//!
//! ```text
//! M(t) y'' + C(t) y' + K(t) y = d(t)            (Eq 2, all entries T-periodic)
//! x = [y; y'],  x' = P(t) x + f(t)                (Eqs 3-4)
//! P = [ 0  I ; -M^-1 K  -M^-1 C ],  f = [ 0 ; M^-1 d ]   (Eq 5)
//! ```
//! The models are front-ends: the gear pair (Eqs 36-46), the forging-press cam mechanism (Eqs 32-35) and
//! the generic second-order system with Fourier or piecewise-constant entries. Solvers only see the
//! [`PeriodicSystem`] trait; models never call solver internals.

pub mod catalog;
pub mod coefficient;
pub mod fourier;
pub mod gear;
pub mod press;
pub mod second_order;

pub use coefficient::{Coefficient, PiecewiseConstant};
pub use fourier::FourierSeries;
pub use gear::{GearPair, GearPairParams, MeshStiffness};
pub use press::PressParams;
pub use second_order::SecondOrderSystem;

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
    /// Times in (0, T) where P or f jump, sorted; empty for smooth coefficients.
    fn breakpoints(&self) -> Vec<f64> {
        Vec::new()
    }
    /// The second-order Fourier form (M, C, K, d as Fourier series of the period), for frequency-domain
    /// solvers; `None` when the coefficients are not finite Fourier series.
    fn fourier_form(&self) -> Option<FourierForm> {
        None
    }
    /// Highest harmonic of 1/T in the coefficients (a lower bound on the resolution a solver needs).
    fn max_harmonic(&self) -> usize;
    /// Period of P(t) alone in s (the period divided by a whole number): the monodromy over T is the
    /// monodromy over this period raised to T / this. Defaults to the full period.
    fn homogeneous_period_s(&self) -> f64 {
        self.period_s()
    }
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

/// What `simulate` reports: a linear function of the state, or a component of x' = P x + f.
#[derive(Clone, Debug, PartialEq)]
pub enum OutputQuantity {
    /// `sum_i weights[i] x_i`.
    Linear {
        /// Weight of each state component.
        weights: Vec<f64>,
        /// Physical unit of the result, e.g. "m/s".
        unit: String,
        /// Name shown to people, e.g. "dq/dt".
        name: String,
    },
    /// Component `index` of x' = P(t) x + f(t) (an acceleration for index >= N).
    Derivative {
        /// State index.
        index: usize,
        /// Physical unit.
        unit: String,
        /// Name shown to people.
        name: String,
    },
}

impl OutputQuantity {
    /// Evaluates the quantity from state `x` and, for `Derivative`, from `xdot = P x + f`.
    pub fn value(&self, x: &[f64], xdot: &[f64]) -> f64 {
        match self {
            Self::Linear { weights, .. } => weights.iter().zip(x).map(|(w, v)| w * v).sum(),
            Self::Derivative { index, .. } => xdot[*index],
        }
    }
    /// Whether `value` needs x'.
    pub fn needs_derivative(&self) -> bool {
        matches!(self, Self::Derivative { .. })
    }
    /// Unit string.
    pub fn unit(&self) -> &str {
        match self {
            Self::Linear { unit, .. } | Self::Derivative { unit, .. } => unit,
        }
    }
    /// Display name.
    pub fn name(&self) -> &str {
        match self {
            Self::Linear { name, .. } | Self::Derivative { name, .. } => name,
        }
    }
}
