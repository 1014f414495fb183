//! Periodic steady state and Floquet stability of a [`PeriodicSystem`].
//!
//! ```text
//! Phi = monodromy matrix (Eq 8), rho_k = eig(Phi) Floquet multipliers (Eqs 9-10)
//! lambda_k = ln(rho_k) / T Floquet exponents (Eq 11)
//! asymptotically stable  <=>  |rho|max < 1
//! T-periodic solution exists and is unique  <=>  no rho_k = 1;  (I - Phi) x0 = c_m   (Eq 21)
//! ```
//! The step count comes from the requested tolerance by step doubling (Richardson: for a fourth-order
//! method the error of the finer result is about |x_m - x_2m| / 15), starting above the explicit
//! stability limit h |lambda(P)|max < 2.78 of RK4.

mod band;
pub mod companion;
pub mod eigen;
pub mod error;
pub mod floquet;
pub mod hill;
pub mod magnus;
pub mod quasi;
pub mod response;
pub mod rk4;
pub mod steady;

pub use error::SolverError;
pub use floquet::{Floquet, condition_number};
pub use steady::{SteadyState, Trajectory};

use crate::system::{PeriodicSystem, Side};
use nalgebra::DMatrix;
use steady::{solve_rk4, solve_steps};

/// Which solver to use (in scenes and output: `rk4`, `hill`, `magnus4`, `auto`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Method {
    /// The paper's RK4 product method (Eqs 15-21).
    #[serde(rename = "rk4")]
    Rk4,
    /// Harmonic balance (Hill's method) with a companion RK4 monodromy for the multipliers.
    #[serde(rename = "hill")]
    Hill,
    /// Fourth-order Magnus integrator (A-stable, for stiff systems), steps on the jumps.
    #[serde(rename = "magnus4")]
    Magnus,
    /// Cheapest available method meeting the tolerance.
    #[serde(rename = "auto")]
    Auto,
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl Method {
    /// Name used in scenes and output.
    pub fn name(self) -> &'static str {
        match self {
            Self::Rk4 => "rk4",
            Self::Hill => "hill",
            Self::Magnus => "magnus4",
            Self::Auto => "auto",
        }
    }
}

/// Solver options.
///
/// Defaults: `method = Auto`, `tolerance = 1e-8`, `steps = None` (chosen from the tolerance),
/// `max_steps = 4_000_000`.
#[derive(Clone, Debug)]
pub struct SolverOptions {
    /// Method.
    pub method: Method,
    /// Accuracy asked of the periodic solution (relative to its largest value in the balanced state) and of
    /// the monodromy matrix and multipliers (relative to max(|Phi|, 1): against the unit circle).
    pub tolerance: f64,
    /// Fixed step count for a step-based method.
    pub steps: Option<usize>,
    /// Fixed truncation order H for harmonic balance.
    pub harmonics: Option<usize>,
    /// Upper bound on the steps the tolerance loop may use.
    pub max_steps: usize,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self { method: Method::Auto, tolerance: 1e-8, steps: None, harmonics: None, max_steps: 4_000_000 }
    }
}

/// Largest |eigenvalue| of P(t) over 32 times per period and both sides of every breakpoint, in 1/s.
pub fn max_rate(sys: &dyn PeriodicSystem) -> f64 {
    rate_at(sys, 32)
}

/// Largest |eigenvalue| of P(t) over `samples` times per period and both sides of every breakpoint, 1/s
/// (a quick plausibility check can take a few samples; the solvers take 32).
pub fn rate_at(sys: &dyn PeriodicSystem, samples: usize) -> f64 {
    let n = sys.dim();
    let samples = samples.max(1);
    // P at the equally spaced times in one call (a model shares work between them: the gear pair's mesh
    // by turned phasors, not a sine and cosine of every coefficient harmonic per time), then both sides of
    // every breakpoint
    let mut ps = Vec::with_capacity(samples * n * n);
    sys.eval_matrix_uniform(0.0, sys.period_s() / samples as f64, samples, &mut ps);
    let mut p = DMatrix::zeros(n, n);
    for b in sys.breakpoints() {
        for side in [Side::Left, Side::Right] {
            sys.eval_matrix(b, side, &mut p);
            ps.extend_from_slice(p.as_slice());
        }
    }
    let rate = |column_major: &[f64]| {
        let p = DMatrix::from_column_slice(n, n, column_major);
        eigen::eigenvalues(&p).map_or_else(|_| p.norm(), |ev| ev.iter().map(|e| e.norm()).fold(0.0, f64::max))
    };
    // a Schur decomposition per time: worth the threads from 8 states on (a 16-DOF chain: 29 % of its
    // run on one core), not for the gear pair's 2
    if n >= 8 {
        use rayon::prelude::*;
        ps.par_chunks(n * n).map(rate).reduce(|| 0.0, f64::max)
    } else {
        ps.chunks(n * n).map(rate).fold(0.0, f64::max)
    }
}

/// Work budget in floating-point operations (about 10 s on one core of the development machine): a solve
/// estimated above it is refused with the estimate, or (for `auto`) handed to a cheaper method.
pub const WORK_BUDGET_FLOPS: f64 = 1e10;

/// Estimated work of harmonic balance (see [`hill::work_estimate`]) on `form` (the system's Fourier form);
/// infinite without one.
pub fn hill_work(sys: &dyn PeriodicSystem, form: Option<&crate::system::FourierForm>) -> f64 {
    form.map_or(f64::INFINITY, |f| hill::work_estimate(f, sys.max_harmonic()))
}

/// Estimated work of the step-based tolerance loop: at least 4 K steps (and twice the explicit stability
/// limit), two grids per attempt, about three attempts, three evaluations of `eval_terms` per step plus
/// the block product n^2 (n + 1).
/// `rate` is [`max_rate`] of `sys` (1/s).
pub fn step_work(sys: &dyn PeriodicSystem, rate: f64) -> f64 {
    let n = sys.dim() as f64;
    let limit = sys.period_s() * rate / RK4_STABILITY_LIMIT;
    let steps = (4.0 * sys.max_harmonic() as f64).max(2.0 * limit).max(64.0);
    let per_step = 3.0 * (4.0 * sys.eval_terms() as f64 + n * n * (n + 1.0) * 2.0);
    steps * 6.0 * 3.0 * per_step
}

fn too_much(what: &str, flops: f64) -> SolverError {
    SolverError::Unsupported(format!(
        "{what} would take about {flops:.1e} floating-point operations (~{:.0} s), beyond the budget of {WORK_BUDGET_FLOPS:.0e}: reduce the number of harmonics or error terms, or the period",
        flops / 1e9
    ))
}

/// Refuses, before any grid is allocated, a system whose explicit stability limit alone asks for more RK4
/// steps per period than `max_steps` (every method but a pure Magnus run needs an RK4 product somewhere:
/// the multiplier companion of harmonic balance, the rk4 product itself). Non-finite coefficients are
/// refused too.
///
/// # Errors
/// [`SolverError::TooMuchWork`] or [`SolverError::NonFinite`].
/// `rate` is [`max_rate`] of `sys` (1/s).
pub fn check_work(sys: &dyn PeriodicSystem, opts: &SolverOptions, rate: f64) -> Result<(), SolverError> {
    if !rate.is_finite() {
        return Err(SolverError::NonFinite { what: "coefficients of the system (P(t))".into() });
    }
    let needed = sys.period_s() * rate / RK4_STABILITY_LIMIT;
    let explicit_needed = opts.method != Method::Magnus;
    if explicit_needed && 8.0 * needed > opts.max_steps as f64 {
        return Err(SolverError::TooMuchWork { rate, period_s: sys.period_s(), needed, limit: opts.max_steps });
    }
    Ok(())
}

/// RK4's stability interval along the imaginary and negative real axes is about 2.78.
pub const RK4_STABILITY_LIMIT: f64 = 2.78;

/// Periodic steady state and Floquet multipliers of `sys`.
///
/// # Errors
/// [`SolverError`] when the monodromy is non-finite, its eigenvalues fail, I - Phi is exactly singular,
/// or the tolerance cannot be reached within `max_steps`.
pub fn solve(sys: &dyn PeriodicSystem, opts: &SolverOptions) -> Result<SteadyState, SolverError> {
    // the largest rate of P(t) (32 eigenvalue problems) is computed once and handed on
    let rate = max_rate(sys);
    check_work(sys, opts, rate)?;
    // the Fourier form (series products: the costliest set-up of a long period) is built once too
    let form = sys.fourier_form();
    let (hill_cost, step_cost) = (hill_work(sys, form.as_ref()), step_work(sys, rate));
    let free = opts.steps.is_none() && opts.harmonics.is_none();
    match opts.method {
        Method::Hill if free && hill_cost.is_finite() && hill_cost > WORK_BUDGET_FLOPS => {
            return Err(too_much("harmonic balance", hill_cost));
        }
        Method::Rk4 | Method::Magnus if free && step_cost > WORK_BUDGET_FLOPS => {
            return Err(too_much("time stepping", step_cost));
        }
        Method::Auto if free && hill_cost > WORK_BUDGET_FLOPS && step_cost > WORK_BUDGET_FLOPS => {
            return Err(too_much("the cheapest solver", hill_cost.min(step_cost)));
        }
        _ => {}
    }
    match opts.method {
        Method::Rk4 => solve_rk4(sys, opts, "requested", rate),
        Method::Hill => hill::solve_steady(sys, form, opts, "requested".into(), rate),
        Method::Magnus => solve_steps(sys, opts, "requested", rk4::Scheme::Magnus4, rate),
        Method::Auto => match form {
            Some(_) if opts.steps.is_none() && hill_cost > WORK_BUDGET_FLOPS => solve_rk4(
                sys,
                opts,
                "auto: harmonic balance would exceed the work budget with this many coefficient harmonics, so the rk4 product",
                rate,
            ),
            Some(f) if opts.steps.is_none() => hill::solve_steady(
                sys,
                Some(f),
                opts,
                "auto: smooth Fourier coefficients, so harmonic balance is spectrally accurate and needs no time steps"
                    .into(),
                rate,
            ),
            Some(_) => {
                solve_rk4(sys, opts, "auto: solver.steps fixes a step count, so the step-based rk4 product", rate)
            }
            None if sys.piecewise_constant() && opts.steps.is_none() => solve_steps(
                sys,
                opts,
                "auto: coefficients are piecewise constant, so magnus4 (exact exponentials) with one step per piece is exact",
                rk4::Scheme::Magnus4,
                rate,
            ),
            None => {
                // stiff when the explicit stability limit alone asks for far more steps than the coefficients'
                // resolution: then the A-stable Magnus scheme, else the cheaper rk4 product
                let limit = sys.period_s() * rate / RK4_STABILITY_LIMIT;
                let resolution = (16 * sys.max_harmonic()).max(16 * (sys.breakpoints().len() + 1)) as f64;
                if limit > 8.0 * resolution {
                    let why = format!(
                        "auto: coefficients jump and the system is stiff (rk4 needs {limit:.0} steps for stability alone): A-stable magnus4 with steps on the jumps"
                    );
                    solve_steps(sys, opts, &why, rk4::Scheme::Magnus4, rate)
                } else {
                    solve_rk4(
                        sys,
                        opts,
                        "auto: coefficients jump, so the rk4 product with steps on the jumps (harmonic balance would converge only algebraically)",
                        rate,
                    )
                }
            }
        },
    }
}
