//! Harmonic balance (Hill's method) for linear periodic second-order systems.
//!
//! ```text
//! M(t) y'' + C(t) y' + K(t) y = d(t),  all Fourier series of w = 2 pi / T
//! y(t) = sum_{n=-H..H} Y_n exp(i n w t)
//! harmonic n:  sum_m [ -(m w)^2 M_{n-m} + i m w C_{n-m} + K_{n-m} ] Y_m = D_n
//! ```
//! Coefficient harmonics k couple Y_m to Y_{m+k}; if every k is a multiple of g, the harmonics split into
//! g independent residue classes (n mod g), each a banded system of half-bandwidth (h_c / g) blocks. The gear
//! over one pinion revolution has g = 14 (mesh harmonics only) and over the hunting period g = 546: each
//! class is then tiny. Spectrally accurate for smooth coefficients; H grows until the estimated truncation
//! error is below the tolerance: the first-order error of the dropped harmonics (the residual beyond H
//! solved on a ring of 2 h_c harmonics, fed back inside through the class's own factors), else the change
//! of the solution between successive H. Where the diagonal blocks dominate beyond a truncation, the H to
//! solve is predicted from a smaller solution continued outward by forward substitution, so a gear pair
//! needs one small and one final solve instead of a ladder.

use super::SolverError;
use super::band::solve_refined;
use super::companion::companion_monodromy;
use super::floquet::{Floquet, floquet_warnings};
use super::steady::{SteadyState, Trajectory};
use super::{Method, RK4_STABILITY_LIMIT, SolverOptions};
use crate::system::FourierForm;
use crate::system::PeriodicSystem;
use crate::system::gcd;
use nalgebra::Complex;
use nalgebra::{DMatrix, DVector};

type C64 = Complex<f64>;

mod classes;
mod tail;
#[cfg(test)]
mod tests;

use classes::{Classes, complex};
use tail::{Tail, continuation, tail_size};

/// The periodic solution as Fourier coefficients of y (`coeffs[i][n + H]` for DOF i, harmonic n).
#[derive(Clone, Debug)]
pub struct HillSolution {
    /// Base angular frequency w in rad/s.
    pub omega: f64,
    /// Truncation order H.
    pub harmonics: usize,
    /// Y_n per DOF.
    pub coeffs: Vec<Vec<C64>>,
    /// Coupling stride g (gcd of the coefficient harmonics).
    pub stride: usize,
}

impl HillSolution {
    /// Complex Fourier coefficient X_c(k), k >= 0, of state component c (c < N: y_c; c >= N: y'_{c-N} =
    /// i k w Y_{c-N}(k)), so that x_c(t) = Re X_c(0) + 2 Re sum_k X_c(k) e^{i k w t}. Zero beyond H.
    pub fn coefficient(&self, c: usize, k: usize) -> Complex<f64> {
        let n = self.coeffs.len();
        if k > self.harmonics || c >= 2 * n {
            return Complex::new(0.0, 0.0);
        }
        let y = self.coeffs[c % n][self.harmonics + k];
        if c < n { y } else { y * Complex::new(0.0, k as f64 * self.omega) }
    }

    /// State [y; y'] at time t.
    pub fn state(&self, t: f64, out: &mut [f64]) {
        let n = self.coeffs.len();
        let h = self.harmonics as isize;
        let (s1, c1) = (self.omega * t).sin_cos();
        let e1 = C64::new(c1, s1);
        for i in 0..n {
            let y = &self.coeffs[i];
            let (mut acc_y, mut acc_v) = (y[h as usize].re, 0.0);
            let mut e = C64::new(1.0, 0.0);
            for k in 1..=h {
                e *= e1;
                let (p, m) = (y[(h + k) as usize], y[(h - k) as usize]);
                let term = p * e + m * e.conj();
                acc_y += term.re;
                let kw = k as f64 * self.omega;
                acc_v += (C64::new(0.0, kw) * (p * e - m * e.conj())).re;
            }
            out[i] = acc_y;
            out[n + i] = acc_v;
        }
    }
}

/// Solves the harmonic-balance system with truncation order `h_trunc`; returns the solution and the
/// relative size of its iterative-refinement correction (the rounding error of the solve, in the measure of
/// [`difference`]).
///
/// # Errors
/// [`SolverError::Singular`] when a class system is singular (a harmonic in resonance).
pub fn solve_order(form: &FourierForm, h_trunc: usize) -> Result<(HillSolution, f64), SolverError> {
    solve_order_with(form, h_trunc, true, false).map(|(s, r, _)| (s, r))
}

fn complex_forcing(forcing: &[crate::system::FourierSeries]) -> (Vec<Vec<C64>>, usize) {
    let hf = forcing.iter().map(|s| s.harmonics()).max().unwrap_or(0);
    (forcing.iter().map(|s| complex(s, hf)).collect(), hf)
}

/// [`solve_order`], with the iterative refinement only when `refine` (else the rounding returned is 0).
/// The third value is the first-order truncation error of the solution (see `Classes::tail`), in the
/// measure of [`difference`]; infinite when a ring beyond H is singular.
fn solve_order_with(
    form: &FourierForm,
    h_trunc: usize,
    refine: bool,
    want_tail: bool,
) -> Result<(HillSolution, f64, Option<Tail>), SolverError> {
    solve_order_extended(form, h_trunc, refine, want_tail, None)
}

/// What [`solve_order_extended`] continues beyond H ([`Classes::extend`]), and when.
#[derive(Clone, Copy, Debug)]
struct Extension {
    /// The highest harmonic continued to.
    h_cap: usize,
    /// A side stops where a band of its harmonics falls below this fraction of its class's largest.
    negligible: f64,
    /// No continuation when the first-order truncation error is at most this (the truncation is kept).
    unless_met: f64,
}

/// [`solve_order_with`], and with a tail that does not meet `extension.unless_met`, where the outside block
/// is diagonally dominant, the solution continued beyond H ([`Classes::extend`], in [`Tail::beyond`]).
fn solve_order_extended(
    form: &FourierForm,
    h_trunc: usize,
    refine: bool,
    want_tail: bool,
    extension: Option<Extension>,
) -> Result<(HillSolution, f64, Option<Tail>), SolverError> {
    let classes = Classes::new(form, h_trunc);
    let (forcing, hf) = complex_forcing(&form.forcing);
    solve_classes(&classes, &forcing, hf, refine, want_tail, extension)
}

/// [`solve_order_extended`] on the operator `classes` (truncated at its H) with complex forcing
/// coefficients `forcing[i][n + hf]`.
fn solve_classes(
    classes: &Classes,
    forcing: &[Vec<C64>],
    hf: usize,
    refine: bool,
    want_tail: bool,
    extension: Option<Extension>,
) -> Result<(HillSolution, f64, Option<Tail>), SolverError> {
    let h_trunc = classes.h as usize;
    let dof = classes.nd;
    let mut coeffs = vec![vec![C64::new(0.0, 0.0); 2 * h_trunc + 1]; dof];
    let mut rounding = coeffs.clone();
    let mut sums = vec![[0.0; 2]; dof];
    let mut delta: f64 = 0.0;
    let h2 = h_trunc + 2 * classes.co.h;
    let mut corr = vec![vec![C64::new(0.0, 0.0); 2 * h2 + 1]; dof];
    for r in 0..=classes.count() / 2 {
        let members = classes.members(r);
        let Some(rhs) = (!members.is_empty()).then(|| classes.rhs(&members, forcing, hf)).flatten() else {
            continue;
        };
        let (x, dx, lu, pivots) = solve_refined(classes.matrix(&members), rhs, refine).ok_or(SolverError::Singular)?;
        let weight = if r != 0 && 2 * r != classes.count() { 2.0 } else { 1.0 };
        if want_tail {
            let d = classes.tail(&members, &x, &lu, &pivots, forcing, hf, weight, &mut sums, &mut corr);
            delta = delta.max(d);
        }
        classes.store(r, &members, &x, &mut coeffs);
        classes.store(r, &members, &dx, &mut rounding);
    }
    let solution = classes.solution(coeffs)?;
    let rounding =
        if refine { relative_size(&HillSolution { coeffs: rounding, ..solution.clone() }, &solution) } else { 0.0 };
    if !want_tail {
        return Ok((solution, rounding, None));
    }
    // the factor on the first-order error: 1.25 / (1 - delta) where the outside block is dominated by its
    // diagonal (the gear scenes: the first-order error matches the true one within 1 % from 1e-4 to 1e-25
    // in this measure, fig8a, fig8b, light damping, H = 146..703); 6 where it is not (a cam's varying
    // mass, the press cases: 0.35 to 1.45 times the true error from 1e-1 to 1e-15, H = 24..118)
    let factor = if delta < 0.5 { 1.25 / (1.0 - delta) } else { 6.0 };
    let tail = if delta.is_finite() { factor * tail_size(&sums, &solution) } else { f64::INFINITY };
    // the solution plus its first-order correction, to H + 2 hc
    for (c, y) in corr.iter_mut().zip(&solution.coeffs) {
        for (k, v) in y.iter().enumerate() {
            c[k + h2 - h_trunc] += v;
        }
    }
    let corrected = HillSolution { harmonics: h2, coeffs: corr, ..solution.clone() };
    // the continuation holds only where the outside is diagonally dominant
    let beyond = extension
        .filter(|e| delta < 0.5 && e.h_cap > h_trunc && (tail > e.unless_met || tail.is_nan()))
        .and_then(|e| continuation(classes, &solution, forcing, hf, e));
    Ok((solution, rounding, Some(Tail { size: tail, factor, corrected, beyond })))
}

/// A component's size in the measure of [`difference`]: sum_n |Y_n| over its coefficients `y` (harmonics
/// -H..=H), each times |n| w (w = `omega`, rad/s) for the velocity.
fn component_size(y: &[C64], omega: f64, velocity: bool) -> f64 {
    let h = (y.len() / 2) as f64;
    let term = |i: usize, v: &C64| v.norm_sqr().sqrt() * if velocity { ((i as f64 - h) * omega).abs() } else { 1.0 };
    // four partial sums: one sum's additions in a row bound the loop (the hunting period: 27809
    // coefficients per component, four sums per solve)
    let mut acc = [0.0; 4];
    let quads = y.chunks_exact(4);
    let rest = quads.remainder();
    for (q, quad) in quads.enumerate() {
        for (l, (a, v)) in acc.iter_mut().zip(quad).enumerate() {
            *a += term(4 * q + l, v);
        }
    }
    let done = y.len() - rest.len();
    let tail: f64 = rest.iter().enumerate().map(|(l, v)| term(done + l, v)).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// Harmonic balance of one operator (the mass, damping and stiffness of `form`; its own forcing is
/// ignored) for many forcings at truncation order `h_trunc`: each residue class is factored once and
/// solved for every right-hand side. The response to forcing j is `result[j]`.
///
/// # Errors
/// [`SolverError::Singular`] when a forced class is singular; non-finite coefficients.
pub fn solve_many(
    form: &FourierForm,
    h_trunc: usize,
    forcings: &[Vec<crate::system::FourierSeries>],
) -> Result<Vec<HillSolution>, SolverError> {
    let classes = Classes::new(form, h_trunc);
    let forcing: Vec<(Vec<Vec<C64>>, usize)> = forcings.iter().map(|f| complex_forcing(f)).collect();
    let mut coeffs = vec![vec![vec![C64::new(0.0, 0.0); 2 * h_trunc + 1]; form.dof]; forcings.len()];
    for r in 0..=classes.count() / 2 {
        let members = classes.members(r);
        if members.is_empty() {
            continue;
        }
        let rhs: Vec<Option<Vec<C64>>> = forcing.iter().map(|(f, hf)| classes.rhs(&members, f, *hf)).collect();
        if rhs.iter().all(Option::is_none) {
            continue;
        }
        let mut lu = classes.matrix(&members);
        let pivots = lu.factor().ok_or(SolverError::Singular)?;
        for (j, b) in rhs.into_iter().enumerate() {
            let Some(mut b) = b else { continue };
            lu.solve_factored(&pivots, &mut b);
            classes.store(r, &members, &b, &mut coeffs[j]);
        }
    }
    coeffs.into_iter().map(|c| classes.solution(c)).collect()
}

/// Relative difference between two solutions (the second with more harmonics): per state component, the
/// bound sum_n |dY_n| (times n w for velocities) over the component's size sum_n |Y_n|.
pub fn difference(a: &HillSolution, b: &HillSolution) -> f64 {
    let (ha, hb) = (a.harmonics as isize, b.harmonics as isize);
    let delta: Vec<Vec<C64>> = (0..a.coeffs.len())
        .map(|i| {
            (-hb..=hb)
                .map(|n| {
                    let ya = if n.abs() <= ha { a.coeffs[i][(n + ha) as usize] } else { C64::new(0.0, 0.0) };
                    b.coeffs[i][(n + hb) as usize] - ya
                })
                .collect()
        })
        .collect();
    relative_size(&HillSolution { coeffs: delta, ..b.clone() }, b)
}

/// Size of `delta` relative to `of` (same truncation): per state component, sum_n |dY_n| (times n w for
/// velocities) over sum_n |Y_n|, the largest over components; a bound on the time-domain change.
fn relative_size(delta: &HillSolution, of: &HillSolution) -> f64 {
    let mut worst: f64 = 0.0;
    for (d, y) in delta.coeffs.iter().zip(&of.coeffs) {
        for velocity in [false, true] {
            let size = component_size(y, of.omega, velocity);
            if size > 0.0 {
                worst = worst.max(component_size(d, of.omega, velocity) / size);
            }
        }
    }
    worst
}

/// Harmonic balance to a tolerance: H from h_max (at least 8) until the estimated error is below
/// `tolerance`, at most `max_harmonics`. Where the outside of a truncation is diagonally dominant, the next
/// H is predicted from the solution continued beyond a smaller one (see [`solve_compared`]); elsewhere H
/// grows by 1.25 (by 1.6 while the estimate is above 1000 times the tolerance). The estimate is the first-
/// order truncation error; where that is not at hand, the change between successive H (it bounds the error
/// of the smaller one; with two changes the geometric rate gives the larger one's, times a safety factor
/// 10). Returns the solution, its truncation error estimate and its rounding error (see [`solve_order`]).
///
/// # Errors
/// Singular classes, or the tolerance not reached.
pub fn solve(
    form: &FourierForm,
    max_harmonic: usize,
    tolerance: f64,
    max_harmonics: usize,
) -> Result<(HillSolution, f64, f64), SolverError> {
    solve_compared(form, max_harmonic, tolerance, max_harmonics).map(|r| (r.solution, r.estimate, r.rounding))
}

/// A harmonic-balance solution with the smaller truncation it was compared with.
pub struct Compared {
    /// The solution.
    pub solution: HillSolution,
    /// Its estimated truncation error ([`difference`] measure).
    pub estimate: f64,
    /// Its rounding error (see [`solve_order`]).
    pub rounding: f64,
    /// The solution it is compared with: the solution plus its first-order truncation error (to H + 2 hc,
    /// hc the coefficients' highest harmonic) where that is at hand, else the previous (smaller) truncation.
    pub previous: HillSolution,
    /// `estimate` over the difference of the two: what turns the change of any quantity between them into
    /// the solution's error.
    pub factor: f64,
}

/// [`solve`], keeping the previous truncation for estimates of derived quantities.
///
/// # Errors
/// Singular classes, or the tolerance not reached.
pub fn solve_compared(
    form: &FourierForm,
    max_harmonic: usize,
    tolerance: f64,
    max_harmonics: usize,
) -> Result<Compared, SolverError> {
    let start = max_harmonic.max(8);
    // Each truncation after the first is predicted from a solution continued beyond the previous one (a
    // band product per class, where the outside is diagonally dominant: `Tail::predict`), aiming at half
    // the tolerance, to at most 4 H (or H + 8 hc) harmonics; the prediction only chooses H, the estimate of
    // the H printed is its own first-order error. The first prediction comes from a smaller truncation,
    // where the diagonal blocks start to dominate (fig8a: 35 harmonics, then 330 at 1e-10, where growing
    // by 1.6 and 1.25 from 146 took four solves, 146-234-293-367).
    let hc = coefficient_harmonics(form);
    let target = 0.5 * tolerance;
    let extension = |h: usize| Extension {
        h_cap: (4 * h).max(h + 8 * hc).min(max_harmonics.max(h)),
        negligible: 1e-2 * target,
        unless_met: tolerance,
    };
    let mut predicted = None;
    let mut prev: Option<HillSolution> = None;
    // the operator and forcing are set up once for every truncation
    let mut classes = Classes::new(form, start);
    let (forcing, hf) = complex_forcing(&form.forcing);
    if let Some(h0) = predictor_truncation(&classes, start) {
        classes.set_truncation(h0);
        let (sol, _, tail) = solve_classes(&classes, &forcing, hf, false, true, Some(extension(h0)))?;
        predicted = tail.and_then(|t| t.predict(&sol, target)).map(|p| p.max(start));
        prev = Some(sol);
    }
    // Where the first-order truncation error (`Tail`) is at hand, it is the estimate (times its factor), and
    // the solution plus that error is the comparison (the same factor on every derived quantity's change):
    // the geometric rate of the changes below overstated the error up to 1e4x (the convergence accelerates
    // with H: press case 2 at 1e-8).
    let met = |tail: Option<Tail>| tail.filter(|t| t.size.is_finite() && t.size <= tolerance);
    // the rounding is measured once, at the first truncation that can be printed: it comes from the low,
    // nearly resonant harmonics, which every larger truncation holds alike, while the harmonics added
    // later are dominated by -(n w)^2 M and well conditioned (a refinement at every order cost 30 % of a
    // sweep)
    let mut rounding: Option<f64> = None;
    let mut last_change: Option<f64> = None;
    let mut h = start;
    let mut next_h = predicted.unwrap_or(start);
    loop {
        let refine = rounding.is_none();
        classes.set_truncation(next_h);
        let (next, r, tail) = solve_classes(&classes, &forcing, hf, refine, true, Some(extension(next_h)))?;
        let rounding = *rounding.get_or_insert(r);
        let tail_size = tail.as_ref().map(|t| t.size).filter(|v| v.is_finite());
        predicted = tail.as_ref().and_then(|t| t.predict(&next, target));
        if let Some(t) = met(tail) {
            return Ok(Compared {
                solution: next,
                estimate: t.size,
                rounding,
                previous: t.corrected,
                factor: t.factor,
            });
        }
        // without a first-order error (a ring beyond H singular): the change between successive H. Spectral
        // convergence is geometric with a rate r = change / last change per growth step: the larger H's
        // error is about change r / (1 - r); ten times that is the estimate (three times fell short by 30 %
        // on the light-damping gear). Without a rate yet (the first change) the plain change is the
        // estimate: it bounds the smaller H's error, so the larger one's too (measured 12x above the truth on
        // fig8a at 1e-6, tests/solver_matrix.rs).
        let change = prev.as_ref().filter(|p| p.harmonics >= start).map(|p| difference(p, &next));
        let est = match (tail_size, change, last_change) {
            (Some(t), _, _) => t,
            (None, Some(c), Some(l)) if c < l => {
                let r = c / l;
                (10.0 * c * r / (1.0 - r)).min(c)
            }
            (None, Some(c), _) => c,
            (None, None, _) => f64::INFINITY,
        };
        // a change at the rounding level is rounding: more harmonics cannot lower it
        if let Some(c) = change
            && (est <= tolerance || c <= 4.0 * rounding)
        {
            let factor = if c > 0.0 { est / c } else { 1.0 };
            let previous = prev.take().unwrap_or_else(|| next.clone());
            return Ok(Compared { solution: next, estimate: est, rounding, previous, factor });
        }
        last_change = change;
        if next_h >= max_harmonics {
            return Err(SolverError::ToleranceNotReached { cond: f64::NAN, tolerance, steps: next_h, estimate: est });
        }
        h = h.max(next_h);
        let growth = if est > 1e3 * tolerance { 1.6 } else { 1.25 };
        let grown = ((h as f64 * growth).ceil() as usize).max(h + 1);
        // a prediction is followed, but by at least a tenth more harmonics (its estimate was not met at H)
        next_h = predicted.map_or(grown, |p| p.max((h as f64 * 1.1).ceil() as usize).max(h + 1));
        prev = Some(next);
    }
}

/// The truncation whose continuation predicts the first one solved ([`solve_compared`]) on `classes`: where every
/// harmonic up to `start` beyond it has a dominant diagonal block, and at least the coupling stride (every
/// class has members) and 8; `None` when that is not below `start` (then `start` is solved first).
fn predictor_truncation(classes: &Classes, start: usize) -> Option<usize> {
    let n0 = classes.dominant_from(start as isize)? as usize;
    let h0 = n0.max(classes.stride).max(8);
    (h0 < start).then_some(h0)
}

/// The highest harmonic hc of the mass, damping and stiffness of `form`.
fn coefficient_harmonics(form: &FourierForm) -> usize {
    form.mass.iter().chain(&form.damping).chain(&form.stiffness).map(|s| s.harmonics()).max().unwrap_or(0)
}

/// Estimated floating-point work of harmonic balance at truncation H = `h` on `form`: the band LU of each
/// residue class (mod the coupling stride g) with N (2H + 1) / g unknowns and a band of N (2 hc / g + 1),
/// complex (x4), half the classes (conjugate symmetry), about four truncation orders tried:
/// 16 N (2H + 1) (N (2 hc / g + 1))^2. Against measured times for hc = 50..400 on one DOF: within 3x.
pub fn work_estimate(form: &FourierForm, h: usize) -> f64 {
    let hc = form.mass.iter().chain(&form.damping).chain(&form.stiffness).map(|s| s.harmonics()).max().unwrap_or(0);
    let mut g = 0usize;
    for s in form.mass.iter().chain(&form.damping).chain(&form.stiffness) {
        for k in 1..=s.harmonics() {
            if s.cos[k - 1] != 0.0 || s.sin[k - 1] != 0.0 {
                g = gcd(g, k);
            }
        }
    }
    let n = form.dof as f64;
    let band = n * (2.0 * hc as f64 / g.max(1) as f64 + 1.0);
    16.0 * n * (2.0 * h as f64 + 1.0) * band * band
}

/// Harmonic-balance steady state with multipliers from the companion monodromy.
pub(super) fn solve_steady(
    sys: &dyn PeriodicSystem,
    form: Option<FourierForm>,
    opts: &SolverOptions,
    reason: String,
    rate: f64,
) -> Result<SteadyState, SolverError> {
    let form = form.ok_or_else(|| {
        SolverError::Unsupported(
            "harmonic balance needs Fourier-series coefficients; this scene has jumps (use rk4 or auto)".into(),
        )
    })?;
    let (sol, truncation, rounding, previous, factor) = match opts.harmonics {
        Some(h) if h < sys.max_harmonic() => {
            return Err(SolverError::Unsupported(format!(
                "solver.harmonics = {h} is below the highest harmonic of the scene's coefficients ({}): the truncated system cannot represent them",
                sys.max_harmonic()
            )));
        }
        Some(h) => {
            // fixed H: its error is estimated against 1.25 H
            let (sol, rounding) = solve_order(&form, h)?;
            let (finer, _) = solve_order(&form, (h * 5).div_ceil(4).max(h + 1))?;
            let est = difference(&sol, &finer);
            (sol, est, rounding, finer, 1.0)
        }
        None => {
            let c = solve_compared(&form, sys.max_harmonic(), opts.tolerance, 1 << 20)?;
            (c.solution, c.estimate, c.rounding, c.previous, c.factor)
        }
    };
    let d = super::steady::state_scales(sys);
    let companion = companion_monodromy(sys, opts, rate, &d)?;
    let (monodromy, phi_err, companion_steps) = (companion.monodromy, companion.error, companion.steps);
    let period = sys.period_s();
    let floquet = Floquet::from_monodromy(&monodromy, period)?;
    // the companion's better (higher-order) monodromy: the change of each multiplier to it is that
    // multiplier's error (twice, as for the monodromy), whether it moves linearly or like a square root
    let better = Floquet::from_monodromy(&companion.better, period)?;
    let b = DMatrix::from_fn(sys.dim(), sys.dim(), |i, j| monodromy[(i, j)] * d[j] / d[i]);
    let departure = super::floquet::departure_from_normality(&b);
    let rho_error =
        super::floquet::multiplier_change(&floquet, &better, (2.0, 2.0), 100.0 * f64::EPSILON, departure, b.amax());
    let n = sys.dim();
    let a = DMatrix::identity(n, n) - &monodromy;
    // reported, not judged: harmonic balance never solves with I - Phi; its own system's rounding is
    // measured by the iterative-refinement correction (`rounding`)
    let cond = super::steady::scaled_condition(&a, &d);
    let mut x0 = DVector::zeros(n);
    sol.state(0.0, x0.as_mut_slice());
    let mut warnings = Vec::new();
    let floor = 100.0 * f64::EPSILON;
    let (state_error, multiplier_error) = ((truncation + rounding).max(floor), phi_err.max(floor));
    let estimate = state_error.max(multiplier_error).max(rho_error);
    let mut trusted = estimate <= opts.tolerance;
    if rounding > opts.tolerance {
        trusted = false;
        warnings.push(format!(
            "the harmonic-balance system is ill-conditioned: rounding left a relative error of {rounding:.1e} (measured by iterative refinement), above the tolerance{}",
            super::floquet::nearest_to_one(&floquet)
        ));
    }
    let mut floquet = floquet;
    floquet_warnings(&mut floquet, opts.tolerance.max(phi_err).max(rho_error), rho_error, &mut warnings);
    super::floquet::untrusted_multipliers(rho_error, opts.tolerance, &mut warnings);
    let limit = (period * rate / RK4_STABILITY_LIMIT).ceil() as usize;
    Ok(SteadyState {
        method: Method::Hill,
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
        state_error,
        multiplier_error,
        monodromy,
        floquet,
        x0,
        cond_i_minus_phi: cond,
        stability_limit_steps: limit,
        trusted,
        warnings,
        trajectory: Trajectory::Fourier(sol),
        comparison: Some(super::steady::Comparison { trajectory: Trajectory::Fourier(previous), factor }),
        rounding,
        rho_error,
    })
}
