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

pub mod eigen;
pub mod hill;
pub mod rk4;

use crate::model::{PeriodicSystem, Side};
use nalgebra::{Complex, DMatrix, DVector};

/// Errors of the solver layer.
#[derive(Debug, thiserror::Error)]
pub enum SolverError {
    /// A matrix or vector contained NaN or infinity.
    #[error("non-finite values in {what}")]
    NonFinite {
        /// What was non-finite.
        what: String,
    },
    /// The eigenvalue iteration did not converge.
    #[error("eigenvalues of a {n}x{n} matrix did not converge (QR iteration limit reached)")]
    EigenFailed {
        /// Matrix size.
        n: usize,
    },
    /// I - Phi is singular: a Floquet multiplier equals 1 and no unique periodic solution exists.
    #[error("I - Phi is singular (a Floquet multiplier equals 1): no unique periodic solution")]
    Singular,
    /// The requested tolerance needs more steps than allowed.
    #[error(
        "the periodic solution cannot meet tolerance {tolerance:e}: {steps} steps (or harmonics) still leave an estimated error of {estimate:.2e}{}; raise solver.tolerance",
        conditioning(*cond)
    )]
    ToleranceNotReached {
        /// Condition number of I - Phi at the last attempt (NaN when unknown).
        cond: f64,
        /// Requested tolerance.
        tolerance: f64,
        /// Steps of the last attempt.
        steps: usize,
        /// Error estimate of the last attempt.
        estimate: f64,
    },
    /// The requested method is not available for this system.
    #[error("{0}")]
    Unsupported(String),
}

fn conditioning(cond: f64) -> String {
    if cond.is_finite() && cond > 1e4 {
        format!(" because cond(I - Phi) = {cond:.2e}: a Floquet multiplier near +1 amplifies every error")
    } else {
        String::new()
    }
}

/// Which solver to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The paper's RK4 product method (Eqs 15-21).
    Rk4,
    /// Harmonic balance (Hill's method) with a companion RK4 monodromy for the multipliers.
    Hill,
    /// Fourth-order Magnus integrator (A-stable, for stiff systems), steps on the jumps.
    Magnus,
    /// Cheapest available method meeting the tolerance.
    Auto,
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
    /// Relative accuracy asked of the multipliers and the periodic solution.
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

/// Floquet multipliers and what they say about stability.
#[derive(Clone, Debug)]
pub struct Floquet {
    /// Multipliers rho_k, by decreasing modulus.
    pub multipliers: Vec<Complex<f64>>,
    /// Exponents lambda_k = ln(rho_k) / T in 1/s (principal logarithm; `None` for rho = 0).
    pub exponents: Vec<Option<Complex<f64>>>,
    /// |rho|max.
    pub rho_max: f64,
    /// |rho|max < 1.
    pub stable: bool,
}

impl Floquet {
    /// Multipliers of `phi` for a period `period_s`.
    ///
    /// # Errors
    /// From [`eigen::eigenvalues`].
    pub fn from_monodromy(phi: &DMatrix<f64>, period_s: f64) -> Result<Self, SolverError> {
        let multipliers = eigen::eigenvalues(phi)?;
        let rho_max = multipliers.iter().map(|r| r.norm()).fold(0.0, f64::max);
        let exponents = multipliers.iter().map(|r| (r.norm() > 0.0).then(|| r.ln() / period_s)).collect();
        Ok(Self { multipliers, exponents, rho_max, stable: rho_max < 1.0 })
    }
}

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
    /// Method actually used.
    pub method: &'static str,
    /// Why that method (for `auto`).
    pub reason: String,
    /// Period T in s.
    pub period_s: f64,
    /// Steps (or harmonics) used.
    pub resolution: usize,
    /// Estimated relative error of multipliers and periodic solution.
    pub error_estimate: f64,
    /// Monodromy matrix.
    pub monodromy: DMatrix<f64>,
    /// Floquet analysis.
    pub floquet: Floquet,
    /// Periodic initial state x0.
    pub x0: DVector<f64>,
    /// 2-norm condition number of I - Phi.
    pub cond_i_minus_phi: f64,
    /// Smallest step count above the explicit RK4 stability limit.
    pub stability_limit_steps: usize,
    /// True when the error estimate meets the tolerance and I - Phi is well enough conditioned.
    pub trusted: bool,
    /// Plain-language warnings (unstable, ill-conditioned, below the stability limit, ...).
    pub warnings: Vec<String>,
    /// The solution over one period.
    pub trajectory: Trajectory,
}

impl SteadyState {
    /// Samples the state at `times` (s, any real; reduced modulo T) into `out` (n per time).
    pub fn states_at(&self, sys: &dyn PeriodicSystem, times: &[f64], out: &mut Vec<f64>) {
        let n = sys.dim();
        let mut st = rk4::Stepper::new(sys);
        let mut x = vec![0.0; n];
        out.clear();
        out.reserve(times.len() * n);
        for &t in times {
            let tau = t.rem_euclid(self.period_s);
            match &self.trajectory {
                Trajectory::Grid { grid, states, scheme } => {
                    if *scheme != rk4::Scheme::Rk4 {
                        st = rk4::Stepper::with_scheme(sys, *scheme);
                    }
                    rk4::state_at(&mut st, grid, states, tau, &mut x)
                }
                Trajectory::Fourier(h) => h.state(tau, &mut x),
            }
            out.extend_from_slice(&x);
        }
    }
}

/// Largest |eigenvalue| of P(t) over 32 times per period and both sides of every breakpoint, in 1/s.
pub fn max_rate(sys: &dyn PeriodicSystem) -> f64 {
    let n = sys.dim();
    let (mut p, mut f) = (DMatrix::zeros(n, n), DVector::zeros(n));
    let t_end = sys.period_s();
    let mut times: Vec<(f64, Side)> = (0..32).map(|i| (t_end * i as f64 / 32.0, Side::Right)).collect();
    for b in sys.breakpoints() {
        times.push((b, Side::Left));
        times.push((b, Side::Right));
    }
    let mut best: f64 = 0.0;
    for (t, side) in times {
        sys.eval(t, side, &mut p, &mut f);
        let r = eigen::eigenvalues(&p).map_or_else(|_| p.norm(), |ev| ev.iter().map(|e| e.norm()).fold(0.0, f64::max));
        best = best.max(r);
    }
    best
}

/// RK4's stability interval along the imaginary and negative real axes is about 2.78.
pub const RK4_STABILITY_LIMIT: f64 = 2.78;

/// Periodic steady state and Floquet multipliers of `sys`.
///
/// # Errors
/// [`SolverError`] when the monodromy is non-finite, its eigenvalues fail, I - Phi is exactly singular,
/// or the tolerance cannot be reached within `max_steps`.
pub fn solve(sys: &dyn PeriodicSystem, opts: &SolverOptions) -> Result<SteadyState, SolverError> {
    match opts.method {
        Method::Rk4 => solve_rk4(sys, opts, "requested"),
        Method::Hill => solve_hill(sys, opts, "requested".into()),
        Method::Magnus => solve_steps(sys, opts, "requested", rk4::Scheme::Magnus4),
        Method::Auto => match sys.fourier_form() {
            Some(_) if opts.steps.is_none() => solve_hill(
                sys,
                opts,
                "auto: smooth Fourier coefficients, so harmonic balance is spectrally accurate and needs no time steps"
                    .into(),
            ),
            Some(_) => solve_rk4(sys, opts, "auto: solver.steps fixes a step count, so the step-based rk4 product"),
            None => {
                // stiff when the explicit stability limit alone asks for far more steps than the coefficients'
                // resolution: then the A-stable Magnus scheme, else the cheaper rk4 product
                let limit = sys.period_s() * max_rate(sys) / RK4_STABILITY_LIMIT;
                let resolution = (16 * sys.max_harmonic()).max(16 * (sys.breakpoints().len() + 1)) as f64;
                if limit > 8.0 * resolution {
                    let why = format!(
                        "auto: coefficients jump and the system is stiff (rk4 needs {limit:.0} steps for stability alone): A-stable magnus4 with steps on the jumps"
                    );
                    solve_steps(sys, opts, &why, rk4::Scheme::Magnus4)
                } else {
                    solve_rk4(
                        sys,
                        opts,
                        "auto: coefficients jump, so the rk4 product with steps on the jumps (harmonic balance would converge only algebraically)",
                    )
                }
            }
        },
    }
}

struct Attempt {
    run: rk4::Rk4Run,
    floquet: Floquet,
    x0: DVector<f64>,
    states: Vec<f64>,
    cond: f64,
}

fn attempt(sys: &dyn PeriodicSystem, grid: &rk4::Grid, scheme: rk4::Scheme) -> Result<Attempt, SolverError> {
    let run = rk4::monodromy_with(sys, grid, scheme);
    if run.monodromy.iter().chain(run.forcing.iter()).any(|v| !v.is_finite()) {
        return Err(SolverError::NonFinite { what: format!("monodromy matrix after {} steps", grid.steps()) });
    }
    let floquet = Floquet::from_monodromy(&run.monodromy, sys.period_s())?;
    let n = sys.dim();
    let a = DMatrix::identity(n, n) - &run.monodromy;
    let cond = condition_number(&a);
    let x0 = a.lu().solve(&run.forcing).ok_or(SolverError::Singular)?;
    if !cond.is_finite() || x0.iter().any(|v| !v.is_finite()) {
        return Err(SolverError::Singular);
    }
    let states = rk4::trajectory_with(sys, grid, &x0, scheme);
    Ok(Attempt { run, floquet, x0, states, cond })
}

/// Relative difference of two attempts, the second on the refined grid of the first.
fn difference(coarse: &Attempt, fine: &Attempt, n: usize) -> f64 {
    let mut worst: f64 = 0.0;
    for c in 0..n {
        let scale = fine.states.iter().skip(c).step_by(n).fold(0.0f64, |a, v| a.max(v.abs()));
        let diff = (0..coarse.run.grid.nodes.len())
            .map(|i| (coarse.states[i * n + c] - fine.states[2 * i * n + c]).abs())
            .fold(0.0, f64::max);
        if scale > 0.0 {
            worst = worst.max(diff / scale);
        }
    }
    // the monodromy itself, not its eigenvalues: nearly repeated multipliers (at a stability boundary) move
    // like the square root of a perturbation, while Phi, its trace and |rho|max decisions do not
    let scale = fine.run.monodromy.amax().max(f64::MIN_POSITIVE);
    worst.max((&coarse.run.monodromy - &fine.run.monodromy).amax() / scale)
}

fn solve_rk4(sys: &dyn PeriodicSystem, opts: &SolverOptions, reason: &str) -> Result<SteadyState, SolverError> {
    solve_steps(sys, opts, reason, rk4::Scheme::Rk4)
}

fn solve_steps(
    sys: &dyn PeriodicSystem,
    opts: &SolverOptions,
    reason: &str,
    scheme: rk4::Scheme,
) -> Result<SteadyState, SolverError> {
    let period = sys.period_s();
    let breaks = sys.breakpoints();
    let n = sys.dim();
    let rate = max_rate(sys);
    let limit = (period * rate / RK4_STABILITY_LIMIT).ceil() as usize;
    let mut warnings = Vec::new();
    let (grid, fine, estimate) = if let Some(steps) = opts.steps {
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
        let coarse = attempt(sys, &grid, scheme).map_err(explain)?;
        let fine = attempt(sys, &grid.refined(), scheme).map_err(explain)?;
        // error of the coarse result: |x_m - x_2m| (1 + 1/15)
        let est = difference(&coarse, &fine, n) * 16.0 / 15.0;
        (grid, coarse, est)
    } else {
        // an explicit scheme must start above its stability limit; Magnus is A-stable
        let stable_start = if scheme == rk4::Scheme::Rk4 { 2 * limit } else { 0 };
        let mut m = stable_start.max(4 * sys.max_harmonic()).max(64).max(2 * (breaks.len() + 1));
        loop {
            let grid = rk4::Grid::new(period, &breaks, m);
            let coarse = attempt(sys, &grid, scheme)?;
            let fine_grid = grid.refined();
            let fine = attempt(sys, &fine_grid, scheme)?;
            let est = difference(&coarse, &fine, n) / 15.0;
            if est <= opts.tolerance {
                break (fine_grid, fine, est);
            }
            if fine_grid.steps() >= opts.max_steps {
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
    let roundoff = fine.cond * f64::EPSILON * (grid.steps() as f64).sqrt();
    let mut trusted = estimate <= opts.tolerance && roundoff <= opts.tolerance;
    if roundoff > opts.tolerance {
        warnings.push(format!(
            "I - Phi is ill-conditioned (cond {:.3e}): rounding alone may cost {:.1e} relative error, above the tolerance",
            fine.cond, roundoff
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
    floquet_warnings(&mut floquet, opts.tolerance.max(estimate), estimate, &mut warnings);
    Ok(SteadyState {
        method: if scheme == rk4::Scheme::Rk4 { "rk4" } else { "magnus4" },
        reason: reason.to_string(),
        period_s: period,
        resolution: grid.steps(),
        error_estimate: estimate,
        monodromy: fine.run.monodromy,
        floquet,
        x0: fine.x0,
        cond_i_minus_phi: fine.cond,
        stability_limit_steps: limit,
        trusted,
        warnings,
        trajectory: Trajectory::Grid { grid, states: fine.states, scheme },
    })
}

/// P(t) over its own period with no forcing: the companion system whose monodromy gives the multipliers.
struct Homogeneous<'a> {
    sys: &'a dyn PeriodicSystem,
    period_s: f64,
}

impl PeriodicSystem for Homogeneous<'_> {
    fn dim(&self) -> usize {
        self.sys.dim()
    }
    fn period_s(&self) -> f64 {
        self.period_s
    }
    fn eval(&self, t: f64, side: Side, p: &mut DMatrix<f64>, f: &mut DVector<f64>) {
        self.sys.eval_matrix(t, side, p);
        f.fill(0.0);
    }
    fn breakpoints(&self) -> Vec<f64> {
        self.sys.breakpoints().into_iter().filter(|&b| b < self.period_s * (1.0 - 1e-12)).collect()
    }
    fn max_harmonic(&self) -> usize {
        let k = (self.sys.period_s() / self.period_s).round().max(1.0) as usize;
        self.sys.max_harmonic() / k
    }
}

/// Monodromy over the full period from the companion over the homogeneous period: Phi = Phi_h^k. The
/// companion's tolerance is divided by k because relative multiplier errors grow k-fold.
fn companion_monodromy(
    sys: &dyn PeriodicSystem,
    opts: &SolverOptions,
) -> Result<(DMatrix<f64>, f64, usize), SolverError> {
    let th = sys.homogeneous_period_s();
    let k = (sys.period_s() / th).round().max(1.0) as usize;
    let hom = Homogeneous { sys, period_s: sys.period_s() / k as f64 };
    let (phi_h, est, steps) = romberg_monodromy(&hom, opts.tolerance / k as f64, opts.max_steps)?;
    let mut phi = DMatrix::identity(sys.dim(), sys.dim());
    for _ in 0..k {
        phi = &phi_h * phi;
    }
    Ok((phi, est * k as f64, steps))
}

/// Monodromy by RK4 at m, 2m and 4m steps with two Richardson eliminations (the RK4 error expands in
/// h^4, h^5, ...): R1 = (16 Phi_2m - Phi_m) / 15 is fifth order, R2 = (32 R1(2m) - R1(m)) / 31 sixth order,
/// and |R2 - R1(2m)| estimates the error. m doubles until the estimate, relative to |Phi|, meets `tol`.
fn romberg_monodromy(
    sys: &dyn PeriodicSystem,
    tol: f64,
    max_steps: usize,
) -> Result<(DMatrix<f64>, f64, usize), SolverError> {
    let period = sys.period_s();
    let breaks = sys.breakpoints();
    let limit = (period * max_rate(sys) / RK4_STABILITY_LIMIT).ceil() as usize;
    let mut m = (2 * limit).max(sys.max_harmonic() * 2).max(16);
    let run = |steps: usize| -> Result<DMatrix<f64>, SolverError> {
        let r = rk4::monodromy(sys, &rk4::Grid::new(period, &breaks, steps));
        if r.monodromy.iter().any(|v| !v.is_finite()) {
            return Err(SolverError::NonFinite { what: format!("companion monodromy after {steps} steps") });
        }
        Ok(r.monodromy)
    };
    let (mut a, mut b) = (run(m)?, run(2 * m)?);
    let mut previous: Option<DMatrix<f64>> = None;
    let mut total = 3 * m;
    loop {
        let c = run(4 * m)?;
        total += 4 * m;
        let r1a = (&b * 16.0 - &a) / 15.0;
        let r1b = (&c * 16.0 - &b) / 15.0;
        let r2 = (&r1b * 32.0 - &r1a) / 31.0;
        let scale = r2.amax().max(f64::MIN_POSITIVE);
        // sixth order: the error of R2(m) is about |R2(m) - R2(m/2)| / (2^6 - 1); before a second R2 exists,
        // the fifth-order |R2 - R1(2m)| bounds it
        let est = match &previous {
            Some(p) => (&r2 - p).amax() / scale / 63.0,
            None => (&r2 - &r1b).amax() / scale,
        };
        if est <= tol {
            return Ok((r2, est, total));
        }
        if 4 * m >= max_steps {
            return Err(SolverError::ToleranceNotReached {
                cond: f64::NAN,
                tolerance: tol,
                steps: 4 * m,
                estimate: est,
            });
        }
        m *= 2;
        (a, b) = (b, c);
        previous = Some(r2);
    }
}

fn solve_hill(sys: &dyn PeriodicSystem, opts: &SolverOptions, reason: String) -> Result<SteadyState, SolverError> {
    let form = sys.fourier_form().ok_or_else(|| {
        SolverError::Unsupported(
            "harmonic balance needs Fourier-series coefficients; this scene has jumps (use rk4 or auto)".into(),
        )
    })?;
    let (sol, est) = match opts.harmonics {
        Some(h) if h < sys.max_harmonic() => {
            return Err(SolverError::Unsupported(format!(
                "solver.harmonics = {h} is below the highest harmonic of the scene's coefficients ({}): the truncated system cannot represent them",
                sys.max_harmonic()
            )));
        }
        Some(h) => {
            // fixed H: its error is estimated against 1.25 H
            let sol = hill::solve_order(&form, h)?;
            let finer = hill::solve_order(&form, (h * 5).div_ceil(4).max(h + 1))?;
            let est = hill::difference(&sol, &finer);
            (sol, est)
        }
        None => hill::solve(&form, sys.max_harmonic(), opts.tolerance, 1 << 20)?,
    };
    let (monodromy, phi_err, companion_steps) = companion_monodromy(sys, opts)?;
    let period = sys.period_s();
    let floquet = Floquet::from_monodromy(&monodromy, period)?;
    let n = sys.dim();
    let a = DMatrix::identity(n, n) - &monodromy;
    let cond = condition_number(&a);
    let mut x0 = DVector::zeros(n);
    sol.state(0.0, x0.as_mut_slice());
    let mut warnings = Vec::new();
    let estimate = est.max(phi_err);
    let mut trusted = estimate <= opts.tolerance;
    // harmonic balance solves (I - Phi)-like systems in the frequency domain: near a multiplier of 1 the
    // Hill matrix is nearly singular in the same way
    let roundoff = cond * f64::EPSILON * 100.0;
    if roundoff > opts.tolerance {
        trusted = false;
        warnings.push(format!(
            "I - Phi is ill-conditioned (cond {cond:.3e}): a multiplier is near +1 and rounding may cost {roundoff:.1e} relative error"
        ));
    }
    let mut floquet = floquet;
    floquet_warnings(&mut floquet, opts.tolerance.max(phi_err), phi_err, &mut warnings);
    let limit = (period * max_rate(sys) / RK4_STABILITY_LIMIT).ceil() as usize;
    Ok(SteadyState {
        method: "hill",
        reason: format!(
            "{reason}; {} harmonics in {} independent classes (coupling stride {}), multipliers from an rk4 companion of {} steps over {:.6} s",
            sol.harmonics,
            sol.stride.min(2 * sol.harmonics + 1),
            sol.stride,
            companion_steps,
            sys.homogeneous_period_s()
        ),
        period_s: period,
        resolution: sol.harmonics,
        error_estimate: estimate,
        monodromy,
        floquet,
        x0,
        cond_i_minus_phi: cond,
        stability_limit_steps: limit,
        trusted,
        warnings,
        trajectory: Trajectory::Fourier(sol),
    })
}

/// Stability warnings shared by all solvers: marginal (|rho|max = 1 within `accuracy`, then marked not
/// stable), unstable, a multiplier near +1, nearly repeated multipliers.
fn floquet_warnings(floquet: &mut Floquet, accuracy: f64, phi_error: f64, warnings: &mut Vec<String>) {
    if (floquet.rho_max - 1.0).abs() <= accuracy {
        // on the unit circle within the accuracy: bounded at best, never asymptotically stable
        floquet.stable = false;
        warnings.push(format!(
            "|rho|max = {:.12} equals 1 within the accuracy: marginally stable at best (not asymptotically stable)",
            floquet.rho_max
        ));
    } else if !floquet.stable {
        warnings.push(format!(
            "unstable: |rho|max = {} > 1; the periodic solution exists but is not the attractor (free vibration grows)",
            fmt_rho(floquet.rho_max)
        ));
    }
    if let Some(r) = floquet.multipliers.iter().map(|r| (r - 1.0).norm()).reduce(f64::min) {
        if r < 1e-6 {
            warnings.push(format!("a Floquet multiplier lies within {r:.1e} of +1 (near resonance)"));
        }
    }
    repeated_warning(floquet, phi_error, warnings);
}

/// Nearly repeated multipliers (as at a parametric-resonance boundary) are sensitive like the square root of
/// the monodromy error: say how far their values can be trusted.
fn repeated_warning(f: &Floquet, phi_error: f64, warnings: &mut Vec<String>) {
    let m = &f.multipliers;
    let scale = f.rho_max.max(f64::MIN_POSITIVE);
    for i in 0..m.len() {
        for j in i + 1..m.len() {
            if (m[i] - m[j]).norm() < 1e-3 * scale && m[i].norm() > 1e-6 * scale {
                let spread = phi_error.max(f64::EPSILON).sqrt() * scale;
                warnings.push(format!(
                    "multipliers {i} and {j} nearly coincide ({:.6}{:+.6}i): near a stability boundary their values are only good to about {spread:.1e}; the monodromy itself meets the tolerance",
                    m[i].re, m[i].im
                ));
                return;
            }
        }
    }
}

/// 2-norm condition number by an SVD with a bounded number of sweeps (nalgebra's plain
/// `singular_values()` iterates without limit); infinite when singular or not converged.
pub fn condition_number(a: &DMatrix<f64>) -> f64 {
    match nalgebra::linalg::SVD::try_new(a.clone(), false, false, f64::EPSILON, 200 * a.nrows().max(1)) {
        Some(svd) => {
            let (smax, smin) = (svd.singular_values.max(), svd.singular_values.min());
            if smin > 0.0 && smax.is_finite() { smax / smin } else { f64::INFINITY }
        }
        None => f64::INFINITY,
    }
}

fn fmt_rho(r: f64) -> String {
    if r < 1e3 { format!("{r:.6}") } else { format!("{r:.3e}") }
}
