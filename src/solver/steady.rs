//! The periodic steady state (Eq 21: (I - Phi) x0 = c_m) and the step-based solvers' tolerance loop by
//! step doubling (Richardson: for a fourth-order method the error of the finer result is about
//! |x_m - x_2m| / 15).

use super::floquet::{Floquet, floquet_warnings};
use super::{Method, RK4_STABILITY_LIMIT, SolverError, SolverOptions, hill, rk4};
use crate::system::PeriodicSystem;
use nalgebra::{DMatrix, DVector};

/// The periodic solution over one period.
#[derive(Clone, Debug)]
pub enum Trajectory {
    /// Node states of a step grid (node-major).
    Grid {
        /// Step grid.
        grid: rk4::Grid,
        /// States at the nodes.
        states: Vec<f64>,
        /// Scheme that produced them (partial steps use it too).
        scheme: rk4::Scheme,
    },
    /// Fourier coefficients from harmonic balance.
    Fourier(hill::HillSolution),
}

/// Periodic steady state with its Floquet analysis and accuracy report.
#[derive(Clone, Debug)]
pub struct SteadyState {
    /// Method actually used (never `Auto`).
    pub method: Method,
    /// Why that method (for `auto`).
    pub reason: String,
    /// Period T in s.
    pub period_s: f64,
    /// Steps (or harmonics) used.
    pub resolution: usize,
    /// Estimated relative error of what is printed: the larger of `state_error` and `multiplier_error`.
    pub error_estimate: f64,
    /// Estimated error of the periodic solution: largest balanced-state error over the period relative to
    /// the largest balanced state |x / d|.
    pub state_error: f64,
    /// Estimated error of the monodromy, so of the multipliers away from repeated ones: n times the largest
    /// entry of the balanced D^-1 (Phi - Phi_exact) D (a bound on its 2-norm) relative to the largest entry
    /// of D^-1 Phi D or 1.
    pub multiplier_error: f64,
    /// Monodromy matrix.
    pub monodromy: DMatrix<f64>,
    /// Floquet analysis.
    pub floquet: Floquet,
    /// Periodic initial state x0.
    pub x0: DVector<f64>,
    /// Condition number of the periodic problem against errors in Phi, balanced state
    /// ([`scaled_condition`]).
    pub cond_i_minus_phi: f64,
    /// Smallest step count above the explicit RK4 stability limit.
    pub stability_limit_steps: usize,
    /// True when the error estimate meets the tolerance and I - Phi is well enough conditioned.
    pub trusted: bool,
    /// Plain-language warnings (unstable, ill-conditioned, below the stability limit, ...).
    pub warnings: Vec<String>,
    /// The solution over one period.
    pub trajectory: Trajectory,
    /// A solution at another resolution whose difference from `trajectory` estimates the error of any
    /// quantity computed from it (lines, RMS, extremes); `None` for a single run.
    pub comparison: Option<Comparison>,
    /// Relative error of the balanced state that rounding may add, included in `state_error`: cond(I -
    /// Phi) eps sqrt(steps) for a step-based solve (plus the product's own rounding floor), the
    /// iterative-refinement correction for harmonic balance.
    pub rounding: f64,
    /// Estimated error of the printed multipliers relative to max(|rho|max, 1): the change of each multiplier
    /// between the two resolutions scaled as it converges (linearly in the monodromy error, or like its
    /// square root for nearly repeated multipliers), plus the rounding of Phi so amplified.
    pub rho_error: f64,
}

/// The second solution of an error estimate: the error of a quantity q computed from the printed solution
/// is about `factor` |q(printed) - q(other)|.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// The other solution.
    pub trajectory: Trajectory,
    /// Factor from the difference to the printed solution's error.
    pub factor: f64,
}

impl SteadyState {
    /// Samples the state at `times` (s, any real; reduced modulo T) into `out` (n per time).
    pub fn states_at(&self, sys: &dyn PeriodicSystem, times: &[f64], out: &mut Vec<f64>) {
        trajectory_states(sys, &self.trajectory, self.period_s, times, out);
    }
}

/// Samples the state of `trajectory` (period `period_s`) at `times` (s, any real; reduced modulo T) into
/// `out` (n per time).
pub fn trajectory_states(
    sys: &dyn PeriodicSystem,
    trajectory: &Trajectory,
    period_s: f64,
    times: &[f64],
    out: &mut Vec<f64>,
) {
    let n = sys.dim();
    let scheme = match trajectory {
        Trajectory::Grid { scheme, .. } => *scheme,
        Trajectory::Fourier(_) => rk4::Scheme::Rk4,
    };
    let mut st = rk4::Stepper::with_scheme(sys, scheme);
    let mut x = vec![0.0; n];
    out.clear();
    out.reserve(times.len() * n);
    for &t in times {
        let tau = t.rem_euclid(period_s);
        match trajectory {
            Trajectory::Grid { grid, states, .. } => rk4::state_at(&mut st, grid, states, tau, &mut x),
            Trajectory::Fourier(h) => h.state(tau, &mut x),
        }
        out.extend_from_slice(&x);
    }
}

struct Attempt {
    run: rk4::Rk4Run,
    floquet: Floquet,
    x0: DVector<f64>,
    states: Vec<f64>,
    cond: f64,
}

fn attempt(sys: &dyn PeriodicSystem, grid: &rk4::Grid, scheme: rk4::Scheme, d: &[f64]) -> Result<Attempt, SolverError> {
    let run = rk4::monodromy_with(sys, grid, scheme);
    if run.monodromy.iter().chain(run.forcing.iter()).any(|v| !v.is_finite()) {
        return Err(SolverError::NonFinite { what: format!("monodromy matrix after {} steps", grid.steps()) });
    }
    let floquet = Floquet::from_monodromy(&run.monodromy, sys.period_s())?;
    let n = sys.dim();
    let a = DMatrix::identity(n, n) - &run.monodromy;
    let cond = scaled_condition(&a, d);
    let x0 = a.lu().solve(&run.forcing).ok_or(SolverError::Singular)?;
    if !cond.is_finite() || x0.iter().any(|v| !v.is_finite()) {
        return Err(SolverError::Singular);
    }
    let states = rk4::trajectory_with(sys, grid, &x0, scheme);
    Ok(Attempt { run, floquet, x0, states, cond })
}

/// [`multiplier_change`](super::floquet::multiplier_change) of `printed` against `other` on the balanced
/// monodromy.
fn rho_change(printed: &Attempt, other: &Attempt, factors: (f64, f64), rounding: f64, d: &[f64]) -> f64 {
    let n = d.len();
    let b = DMatrix::from_fn(n, n, |i, j| printed.run.monodromy[(i, j)] * d[j] / d[i]);
    let departure = super::floquet::departure_from_normality(&b);
    super::floquet::multiplier_change(&printed.floquet, &other.floquet, factors, rounding, departure, b.amax())
}

/// One RK4 run of `steps` steps (breakpoints on step ends) without the step-doubling estimate: the periodic
/// solution and multipliers at that resolution, with `error_estimate` NaN and `trusted` false. For callers
/// that check the resolution themselves and use differences of runs on one grid (the fault responses of
/// `identify`, tested against harmonic balance); it costs a third of a checked run.
///
/// # Errors
/// Fewer steps than the explicit stability limit; a singular or non-finite product.
pub fn solve_once(sys: &dyn PeriodicSystem, steps: usize) -> Result<SteadyState, SolverError> {
    let period = sys.period_s();
    let limit = (period * super::max_rate(sys) / RK4_STABILITY_LIMIT).ceil() as usize;
    if steps < limit {
        return Err(SolverError::Unsupported(format!(
            "{steps} steps is below the explicit RK4 stability limit of {limit} steps"
        )));
    }
    let grid = rk4::Grid::new(period, &sys.breakpoints(), steps);
    let run = attempt(sys, &grid, rk4::Scheme::Rk4, &state_scales(sys))?;
    Ok(SteadyState {
        method: Method::Rk4,
        reason: "one run of fixed steps, no error estimate".into(),
        period_s: period,
        resolution: grid.steps(),
        error_estimate: f64::NAN,
        state_error: f64::NAN,
        multiplier_error: f64::NAN,
        monodromy: run.run.monodromy,
        floquet: run.floquet,
        x0: run.x0,
        cond_i_minus_phi: run.cond,
        stability_limit_steps: limit,
        trusted: false,
        warnings: vec!["one run of fixed steps: no error estimate".into()],
        trajectory: Trajectory::Grid { grid, states: run.states, scheme: rk4::Scheme::Rk4 },
        comparison: None,
        rounding: f64::NAN,
        rho_error: f64::NAN,
    })
}

/// Scales of the state components that make them comparable: the diagonal d of a balancing of |P(t)|
/// averaged over the period (z = x / d is the balanced state). For a second-order model this divides each
/// velocity by about its natural frequency, so metres and metres per second are not mixed in error
/// measures and condition numbers.
pub fn state_scales(sys: &dyn PeriodicSystem) -> Vec<f64> {
    let n = sys.dim();
    let samples = 32;
    let mut ps = Vec::with_capacity(samples * n * n);
    sys.eval_matrix_uniform(0.0, sys.period_s() / samples as f64, samples, &mut ps);
    let mut mean = DMatrix::<f64>::zeros(n, n);
    for p in ps.chunks(n * n) {
        mean += DMatrix::from_column_slice(n, n, p).abs();
    }
    if mean.iter().any(|v| !v.is_finite()) {
        return vec![1.0; n];
    }
    super::eigen::balance(&mut mean)
}

/// Condition number of the periodic problem (I - Phi) x0 = c (Eq 21) against errors in Phi, in the
/// balanced state B = D^-1 Phi D: kappa = ||(I - B)^-1||_2 max(||B||_2, 1). A relative error e of Phi moves
/// x0 by about kappa e relative. Equal to cond(I - Phi) when Phi is small (strong damping); unlike it, large
/// when I - Phi is small in every direction (both multipliers within 1e-13 of +1 give cond(I - Phi) ~ 1 but
/// kappa ~ 1e13).
pub fn scaled_condition(a: &DMatrix<f64>, d: &[f64]) -> f64 {
    let n = a.nrows();
    let scaled = DMatrix::from_fn(n, n, |i, j| a[(i, j)] * d[j] / d[i]);
    let phi = DMatrix::identity(n, n) - &scaled;
    let smax = |m: DMatrix<f64>| {
        nalgebra::linalg::SVD::try_new(m, false, false, f64::EPSILON, 200 * n.max(1)).map(|s| s.singular_values.max())
    };
    let (Some(phi_norm), Some(inverse_norm)) = (smax(phi), scaled.try_inverse().and_then(smax)) else {
        return f64::INFINITY;
    };
    if inverse_norm.is_finite() { inverse_norm * phi_norm.max(1.0) } else { f64::INFINITY }
}

/// Largest change between two attempts (the second on the refined grid of the first): of the balanced
/// state z = x / d, relative to the largest |z| over the period; and of the monodromy.
fn difference(coarse: &Attempt, fine: &Attempt, d: &[f64]) -> Change {
    let n = d.len();
    let scale = fine.states.chunks(n).flat_map(|x| x.iter().zip(d).map(|(v, s)| (v / s).abs())).fold(0.0, f64::max);
    let mut state: f64 = 0.0;
    if scale > 0.0 {
        for (i, xc) in coarse.states.chunks(n).enumerate() {
            let xf = &fine.states[2 * i * n..(2 * i + 1) * n];
            for c in 0..n {
                state = state.max((xc[c] - xf[c]).abs() / d[c] / scale);
            }
        }
    }
    // the monodromy itself, not its eigenvalues: nearly repeated multipliers (at a stability boundary) move
    // like the square root of a perturbation, while Phi, its trace and |rho|max decisions do not. Measured
    // in the balanced state (D^-1 Phi D is free of units) relative to max(|Phi|, 1): multipliers matter
    // against the unit circle, so a strongly damped Phi of size 0.01 need not be known to 1e-8 of itself
    let balanced = |m: &DMatrix<f64>| DMatrix::from_fn(n, n, |i, j| m[(i, j)] * d[j] / d[i]);
    let (c, f) = (balanced(&coarse.run.monodromy), balanced(&fine.run.monodromy));
    // n times the largest entry bounds the 2-norm of the change, and through it (Bauer-Fike) the
    // multipliers' change for a normal Phi
    Change { state, monodromy: n as f64 * (&c - &f).amax() / f.amax().max(1.0) }
}

/// Changes of the state and of the monodromy between two attempts, or their estimated errors.
#[derive(Clone, Copy, Debug)]
struct Change {
    state: f64,
    monodromy: f64,
}

impl Change {
    fn scaled(self, k: f64) -> Self {
        Self { state: self.state * k, monodromy: self.monodromy * k }
    }
    fn max(self) -> f64 {
        self.state.max(self.monodromy)
    }
}

pub(super) fn solve_rk4(
    sys: &dyn PeriodicSystem,
    opts: &SolverOptions,
    reason: &str,
    rate: f64,
) -> Result<SteadyState, SolverError> {
    solve_steps(sys, opts, reason, rk4::Scheme::Rk4, rate)
}

pub(super) fn solve_steps(
    sys: &dyn PeriodicSystem,
    opts: &SolverOptions,
    reason: &str,
    scheme: rk4::Scheme,
    rate: f64,
) -> Result<SteadyState, SolverError> {
    let period = sys.period_s();
    let breaks = sys.breakpoints();
    let d = state_scales(sys);
    let limit = (period * rate / RK4_STABILITY_LIMIT).ceil() as usize;
    let mut warnings = Vec::new();
    // (printed grid, printed attempt, its estimated changes, the other grid and attempt, factor from their
    // difference to the printed one's error, the same for multipliers in the linear and square-root regimes)
    let (grid, fine, estimate, other_grid, other, factors) = if let Some(steps) = opts.steps {
        if steps < limit && scheme == rk4::Scheme::Rk4 {
            warnings.push(format!(
                "{steps} steps is below the explicit RK4 stability limit of {limit} steps (h |lambda|max > {RK4_STABILITY_LIMIT}): the result is not trustworthy"
            ));
        }
        let grid = rk4::Grid::new(period, &breaks, steps);
        let below = steps < limit && scheme == rk4::Scheme::Rk4;
        let explain = |e: SolverError| {
            if below {
                SolverError::Unsupported(format!(
                    "solver.steps = {steps} is below the explicit RK4 stability limit of {limit} steps and the product diverged ({e}); use at least {limit} steps or method magnus4/hill"
                ))
            } else {
                e
            }
        };
        let coarse = attempt(sys, &grid, scheme, &d).map_err(explain)?;
        let fine = attempt(sys, &grid.refined(), scheme, &d).map_err(explain)?;
        // error of the coarse result: |x_m - x_2m| (1 + 1/15)
        let est = difference(&coarse, &fine, &d).scaled(16.0 / 15.0);
        // the coarse result is printed: its error is |x_m - x_2m| / (1 - 2^-4), or / (1 - 2^-2) for a
        // multiplier that moves like the square root of the monodromy's error
        let fine_grid = grid.refined();
        (grid, coarse, est, fine_grid, fine, (16.0 / 15.0, 4.0 / 3.0))
    } else {
        // an explicit scheme must start above its stability limit; Magnus is A-stable
        let stable_start = if scheme == rk4::Scheme::Rk4 { 2 * limit } else { 0 };
        let mut m = if scheme == rk4::Scheme::Magnus4 && sys.piecewise_constant() {
            breaks.len() + 1 // exact on each piece: the doubling only confirms it
        } else {
            stable_start.max(4 * sys.max_harmonic()).max(64).max(2 * (breaks.len() + 1))
        };
        let mut previous = f64::INFINITY;
        let mut met_at: Option<usize> = None;
        loop {
            let grid = rk4::Grid::new(period, &breaks, m);
            let coarse = attempt(sys, &grid, scheme, &d)?;
            let fine_grid = grid.refined();
            let fine = attempt(sys, &fine_grid, scheme, &d)?;
            // Richardson: the finer result's error is about |x_m - x_2m| / 15; twice that, because the
            // asymptotic estimate fell a few percent short of the true error on the gear scenes
            // rounding amplified by cond(I - Phi) does not fall with more steps: refuse at once
            let roundoff = fine.cond * f64::EPSILON * (fine_grid.steps() as f64).sqrt();
            if roundoff > opts.tolerance && fine.x0.amax() > 0.0 {
                return Err(SolverError::IllConditioned {
                    cond: fine.cond,
                    roundoff,
                    tolerance: opts.tolerance,
                    nearest: super::floquet::nearest_to_one(&fine.floquet),
                });
            }
            let change = difference(&coarse, &fine, &d).scaled(2.0 / 15.0);
            // the multipliers too: near a stability boundary their error exceeds the monodromy's
            let floor = 10.0 * f64::EPSILON * (fine_grid.steps() as f64).sqrt();
            let rho = rho_change(&fine, &coarse, (2.0 / 15.0, (2.0f64 / 15.0).sqrt()), floor, &d);
            // the state and the monodromy must meet the tolerance; the multipliers get at most 16 times the
            // steps that met it (beyond, the result is printed with its honest, larger multiplier error)
            if met_at.is_none() && change.max() <= opts.tolerance {
                met_at = Some(fine_grid.steps());
            }
            let est = if met_at.is_some() { rho.max(change.max()) } else { change.max() };
            let stalled = est > 0.5 * previous && est < 1e-10;
            let enough = met_at
                .is_some_and(|s| fine_grid.steps() >= 16 * s || stalled || 2 * fine_grid.steps() > opts.max_steps);
            if est <= opts.tolerance || enough {
                // the fine result is printed: twice the Richardson factor 1/15 (or 1/3 for a multiplier that
                // moves like the square root of the monodromy's error: sqrt(2/15) covers it)
                break (fine_grid, fine, change, grid, coarse, (2.0 / 15.0, (2.0f64 / 15.0).sqrt()));
            }
            // a fourth-order change shrinks 16-fold per doubling; one that no longer halves is rounding, which
            // more steps only make worse: stop at once instead of running to the step cap
            previous = est;
            if fine_grid.steps() >= opts.max_steps || stalled {
                return Err(SolverError::ToleranceNotReached {
                    cond: fine.cond,
                    tolerance: opts.tolerance,
                    steps: fine_grid.steps(),
                    estimate: est,
                });
            }
            let ratio = (est / opts.tolerance).powf(0.25) * 1.1;
            let next = ((grid.steps() as f64) * ratio).ceil() as usize;
            // at least double (the fine grid is already computed), never beyond the cap (the next fine grid
            // doubles it); a cap below the doubling is caught by the check above on the next round
            m = next.max(2 * grid.steps()).min((opts.max_steps / 2).max(grid.steps() + 1));
        }
    };
    // a zero periodic solution (no forcing) has nothing for rounding to spoil
    // the reported error bounds the product's own rounding too (an exact scheme's step-doubling change can
    // be below it), and that rounding of Phi amplified by the conditioning of the (I - Phi) solve
    let floor = 10.0 * f64::EPSILON * (grid.steps() as f64).sqrt();
    // (ten roundings of Phi: the products of the tests' near-resonant cases carried 3 to 5, whatever their
    // step count, where eps sqrt(steps) overstated rk4's a hundredfold)
    let roundoff = if fine.x0.amax() > 0.0 { fine.cond * 10.0 * f64::EPSILON } else { 0.0 };
    let (state_error, multiplier_error) = (estimate.state.max(floor) + roundoff, estimate.monodromy.max(floor));
    let rho_error = rho_change(&fine, &other, factors, floor, &d);
    let estimate = state_error.max(multiplier_error).max(rho_error);
    let mut trusted = estimate <= opts.tolerance && roundoff <= opts.tolerance;
    if roundoff > opts.tolerance {
        warnings.push(format!(
            "I - Phi is ill-conditioned (cond {:.3e} on the balanced state{}): rounding alone may cost {:.1e} relative error, above the tolerance",
            fine.cond,
            super::floquet::nearest_to_one(&fine.floquet),
            roundoff
        ));
    }
    if opts.steps.is_some() && estimate > opts.tolerance {
        warnings.push(format!(
            "with {} steps the estimated error {:.2e} is above the tolerance {:.1e}",
            grid.steps(),
            estimate,
            opts.tolerance
        ));
        trusted = false;
    }
    let mut floquet = fine.floquet;
    floquet_warnings(&mut floquet, opts.tolerance.max(estimate), rho_error, &mut warnings);
    super::floquet::untrusted_multipliers(rho_error, opts.tolerance, &mut warnings);
    Ok(SteadyState {
        method: if scheme == rk4::Scheme::Rk4 { Method::Rk4 } else { Method::Magnus },
        reason: reason.to_string(),
        period_s: period,
        resolution: grid.steps(),
        error_estimate: estimate,
        state_error,
        multiplier_error,
        monodromy: fine.run.monodromy,
        floquet,
        x0: fine.x0,
        cond_i_minus_phi: fine.cond,
        stability_limit_steps: limit,
        trusted,
        warnings,
        trajectory: Trajectory::Grid { grid, states: fine.states, scheme },
        comparison: Some(Comparison {
            trajectory: Trajectory::Grid { grid: other_grid, states: other.states, scheme },
            factor: factors.0,
        }),
        rounding: roundoff + floor,
        rho_error,
    })
}
