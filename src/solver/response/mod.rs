//! What `simulate` prints about a periodic solution, computed from the solution itself and independent of
//! the solver's step grid: the Fourier lines Z_k, the RMS and the extremes of a probe z(t) (a linear
//! function of the state x, or of its derivative x' = P x + f) over one period.
//!
//! ```text
//! z(t) = Re Z_0 + 2 Re sum_k Z_k e^{i k w t},  Z_k = (1/T) int_0^T z(t) e^{-i k w t} dt,  rms^2 = (1/T) int z^2
//! ```
//! - harmonic balance: Z_k are the solution's own coefficients, rms by Parseval over all its harmonics;
//! - piecewise-constant coefficients stepped by exact exponentials: on a piece x^ = [x; 1] moves by
//!   exp(A^ tau), A^ = [P f; 0 0], and z = c^T x^, so every integral is exact (Van Loan's block exponentials):
//!   int_0^h c^T exp((A^ - i k w) tau) dtau is the corner of exp([[0, c^T], [0, A^ - i k w]] h), and
//!   int_0^h exp(A^T tau) c c^T exp(A^ tau) dtau = F22^T F12 of exp([[-A^T, c c^T], [0, A^]] h);
//! - rk4 steps: the dense output is the cubic Hermite interpolant of the node states and slopes x' = P x + f
//!   (fourth order, like the nodes); for a linear probe z is a cubic on each step, so its lines (moments of
//!   the Hermite basis against e^{-i k w h s} on runs of equal steps), RMS and extremes (roots of z') are
//!   closed forms;
//! - otherwise (a derivative probe, magnus4 on smooth coefficients): 4-point Gauss-Legendre quadrature on
//!   sub-intervals of every step, short enough that (|lambda|max + k w) h_sub is small, on that dense output
//!   (magnus4: a partial step from a node).
//!
//! Extremes (where not in closed form) come from a global search: every sample interval of the whole period whose bound
//! max(z_i, z_i+1) + h^2 |z''| / 8 reaches the best sample is refined by golden section on the solution.

use super::steady::{SteadyState, Trajectory};
use super::{SolverError, SolverOptions};
use super::{hill::HillSolution, rk4};
use crate::system::{PeriodicSystem, Side};
use nalgebra::{Complex, DMatrix, DVector};

mod dense;
mod piecewise;
#[cfg(test)]
mod tests;

pub use dense::grid_states;
use dense::{gauss_response, hermite_response};
use piecewise::piecewise_response;

type C64 = Complex<f64>;

/// A probe of the state: `weights . x` or, with `derivative`, `weights . x'` where x' = P(t) x + f(t).
#[derive(Clone, Debug, PartialEq)]
pub struct Probe {
    /// Weight of each state component (length n).
    pub weights: Vec<f64>,
    /// Probe x' instead of x.
    pub derivative: bool,
}

impl Probe {
    /// The row c of z = c^T [x; 1] for P and f on a piece.
    fn row(&self, p: &DMatrix<f64>, f: &DVector<f64>) -> DVector<f64> {
        let n = self.weights.len();
        let mut c = DVector::zeros(n + 1);
        if self.derivative {
            for (r, w) in self.weights.iter().enumerate().filter(|(_, w)| **w != 0.0) {
                for j in 0..n {
                    c[j] += w * p[(r, j)];
                }
                c[n] += w * f[r];
            }
        } else {
            c.rows_mut(0, n).copy_from_slice(&self.weights);
        }
        c
    }

    fn value(&self, x: &[f64], p: &DMatrix<f64>, f: &DVector<f64>) -> f64 {
        if self.derivative {
            let mut xdot = vec![0.0; x.len()];
            crate::system::state_derivative(p, f, x, &mut xdot);
            self.weights.iter().zip(&xdot).map(|(w, v)| w * v).sum()
        } else {
            self.weights.iter().zip(x).map(|(w, v)| w * v).sum()
        }
    }
}

/// Lines, RMS and extremes of a probe over one period.
#[derive(Clone, Debug)]
pub struct Response {
    /// Z_k for k = 0..=kmax (z = Re Z_0 + 2 Re sum Z_k e^{i k w t}).
    pub lines: Vec<C64>,
    /// RMS over one period (mean included).
    pub rms: f64,
    /// Largest value over the period.
    pub max: f64,
    /// Smallest value over the period.
    pub min: f64,
    /// Largest |z| change per unit change of the balanced state z_b = x / d relative to its largest value
    /// over the period: an error e of the balanced state moves z by at most `gain` e.
    pub gain: f64,
    /// How far an extreme may lie beyond `max` or `min` in intervals the search did not refine (it refines
    /// at most 4096 per extreme, fewer on a harmonic-balance solution of many lines, the most promising
    /// first): 0 when every interval that could hold one was.
    pub extreme_slack: f64,
}

impl Response {
    /// One-sided amplitudes |Z_0|, 2 |Z_k|.
    pub fn amplitudes(&self) -> Vec<f64> {
        self.lines.iter().enumerate().map(|(k, c)| if k == 0 { c.norm() } else { 2.0 * c.norm() }).collect()
    }
}

/// Sub-interval length parameter: 4-point Gauss-Legendre integrates e^{i theta s} z over a sub-interval of
/// phase theta with relative error about 2.9e-7 (theta / 2)^8 (and z^2 about 2.9e-7 theta^8); theta is
/// chosen so that this is a hundredth of `tolerance`.
fn phase_per_interval(tolerance: f64) -> f64 {
    (tolerance.max(1e-15) / 100.0 / 2.9e-7).powf(0.125).clamp(0.05, 1.0)
}

/// The response of `probe` along `traj` (period `period_s`, kmax lines, `d` the state scales, `tolerance`
/// the accuracy the quadrature must stay far below).
pub fn response(
    sys: &dyn PeriodicSystem,
    traj: &Trajectory,
    period_s: f64,
    probe: &Probe,
    kmax: usize,
    d: &[f64],
    tolerance: f64,
) -> Response {
    match traj {
        Trajectory::Fourier(sol) => fourier_response(sol, probe, kmax, period_s, d, None).0,
        Trajectory::Grid { grid, states, scheme } if *scheme == rk4::Scheme::Magnus4 && sys.piecewise_constant() => {
            piecewise_response(sys, grid, states, probe, kmax, period_s, d, tolerance)
        }
        Trajectory::Grid { grid, states, scheme } if *scheme == rk4::Scheme::Rk4 && !probe.derivative => {
            hermite_response(sys, grid, states, probe, kmax, period_s, d)
                .unwrap_or_else(|| gauss_response(sys, grid, states, *scheme, probe, kmax, period_s, d, tolerance))
        }
        Trajectory::Grid { grid, states, scheme } => {
            gauss_response(sys, grid, states, *scheme, probe, kmax, period_s, d, tolerance)
        }
    }
}

/// Largest balanced state max_i |x_i / d_i| over node-major `states`.
fn balanced_scale(states: &[f64], d: &[f64]) -> f64 {
    states.chunks(d.len()).flat_map(|x| x.iter().zip(d).map(|(v, s)| (v / s).abs())).fold(0.0, f64::max)
}

/// |c . D| over the state part: how much z moves per unit balanced state.
fn row_gain(c: &DVector<f64>, d: &[f64]) -> f64 {
    d.iter().enumerate().map(|(i, s)| (c[i] * s).abs()).sum()
}

/// The response of a harmonic-balance solution and the times of its extremes (s). With `near` (the times of
/// another solution's extremes and a window half-width, s), the extremes are searched only within those
/// windows: the comparison solution of an error estimate, whose extremes are the printed one's moved by
/// its error.
fn fourier_response(
    sol: &HillSolution,
    probe: &Probe,
    kmax: usize,
    period_s: f64,
    d: &[f64],
    near: Option<([f64; 2], f64)>,
) -> (Response, [f64; 2]) {
    let h = sol.harmonics;
    let z: Vec<C64> = (0..=h)
        .map(|k| {
            let s: C64 = probe.weights.iter().enumerate().map(|(c, w)| sol.coefficient(c, k) * *w).sum::<C64>();
            if probe.derivative { s * C64::new(0.0, k as f64 * sol.omega) } else { s }
        })
        .collect();
    let rms = (z[0].re * z[0].re + 2.0 * z.iter().skip(1).map(|c| c.norm_sqr()).sum::<f64>()).sqrt();
    // a rigorous bound on |z''| from the coefficients: sum 2 |Z_k| (k w)^2
    let curvature: f64 = z.iter().enumerate().map(|(k, c)| 2.0 * c.norm() * (k as f64 * sol.omega).powi(2)).sum();
    // the refinement evaluates only the harmonics present (a long period's solution is mostly zeros: the
    // unforced residue classes): e^{i k w t} chained from the previous present harmonic by the phasor of the
    // gap, one sin_cos per distinct gap (a gear's lines sit on a few regular gaps: mesh harmonics and their
    // sidebands)
    let present: Vec<(usize, C64)> =
        z.iter().enumerate().skip(1).filter(|(_, c)| c.norm_sqr() > 0.0).map(|(k, c)| (k, *c)).collect();
    let sparse = 4 * present.len() < h;
    let mut gaps: Vec<usize> = present.iter().scan(0, |last, &(k, _)| Some(k - std::mem::replace(last, k))).collect();
    let mut distinct = gaps.clone();
    distinct.sort_unstable();
    distinct.dedup();
    let chained = distinct.len() <= 64;
    for g in &mut gaps {
        *g = distinct.partition_point(|d| d < g);
    }
    let value = |t: f64| {
        if !sparse {
            return fourier_value(&z, sol.omega, t);
        }
        if !chained {
            return present.iter().fold(z[0].re, |acc, (k, c)| {
                let (s, co) = (*k as f64 * sol.omega * t).sin_cos();
                acc + 2.0 * (c.re * co - c.im * s)
            });
        }
        let steps: Vec<C64> = distinct.iter().map(|g| C64::from_polar(1.0, *g as f64 * sol.omega * t)).collect();
        let mut e = C64::new(1.0, 0.0);
        present.iter().zip(&gaps).fold(z[0].re, |acc, ((_, c), g)| {
            e *= steps[*g];
            acc + 2.0 * (c * e).re
        })
    };
    // one evaluation costs a complex product per harmonic (dense) or a sin_cos per line present (~5 of
    // them): the intervals refined are as many as the budget allows, the rest reported as slack
    let cost = if sparse { 5 * present.len() } else { h }.max(1) as f64;
    let refined = ((REFINE_BUDGET / (GOLDEN_EVALUATIONS * cost)) as usize).clamp(16, MAX_CANDIDATES);
    let (max, min, slack, at) = match near {
        Some((at, w)) => {
            let local = |sign: f64, t: f64| {
                let (v, _) = golden(&|x| sign * value(x), t - w, t + w);
                sign * v.max(sign * value(t))
            };
            (local(1.0, at[0]), local(-1.0, at[1]), 0.0, at)
        }
        None => {
            // samples at 2 H per period; where the search leaves intervals unrefined (a strong harmonic near
            // H: a pinion error of order 1e5), once more at 8 H, whose tighter bounds leave fewer
            let mut m = sample_count(h);
            let mut rounds = 0;
            loop {
                let dt = period_s / m as f64;
                let spec: Vec<(f64, f64)> =
                    (0..=m / 2).map(|k| z.get(k).map_or((0.0, 0.0), |c| (c.re * m as f64, c.im * m as f64))).collect();
                let mut zs = crate::signal::spectrum::Fft::new().inverse(&spec, m);
                zs.push(zs[0]);
                let mut ts: Vec<f64> = (0..=m).map(|i| i as f64 * dt).collect();
                ts[m] = period_s;
                let found = extremes(&[Segment { ts, zs, curvature: Some(curvature) }], &|_, t| value(t), refined);
                if found.2 <= 0.0 || rounds == 1 || m >= 1 << 22 {
                    break found;
                }
                m = (4 * m).min(1 << 22);
                rounds += 1;
            }
        }
    };
    // |dz| <= sum_c |w_c| e size_c for a relative coefficient error e per component (the measure of
    // harmonic balance's estimates: sum_n |dY_n| over sum_n |Y_n|, times n w for velocities)
    let gain: f64 = probe
        .weights
        .iter()
        .enumerate()
        .filter(|(_, w)| **w != 0.0)
        .map(|(c, w)| {
            let size: f64 = (0..=h)
                .map(|k| {
                    let kw = if probe.derivative { k as f64 * sol.omega } else { 1.0 };
                    sol.coefficient(c, k).norm() * kw * if k == 0 { 1.0 } else { 2.0 }
                })
                .sum();
            w.abs() * size
        })
        .sum();
    let _ = d;
    let mut lines = z;
    lines.resize(kmax + 1, C64::new(0.0, 0.0));
    (Response { lines, rms, max, min, gain, extreme_slack: slack }, at)
}

/// Samples per period of the extreme search on a harmonic-balance solution of H harmonics: a power of two,
/// at least 2 H (the branch and bound is exact whatever the spacing; denser samples only prune more
/// intervals, and on the gear scenes cost more than the refinements they saved).
fn sample_count(h: usize) -> usize {
    (2 * h).max(1024).next_power_of_two().min(1 << 22)
}

/// z(t) = Re Z_0 + 2 Re sum_k Z_k e^{i k w t}: one complex multiplication per harmonic.
pub fn fourier_value(z: &[C64], omega: f64, t: f64) -> f64 {
    let step = C64::from_polar(1.0, omega * t);
    let mut e = C64::new(1.0, 0.0);
    let mut acc = z.first().map_or(0.0, |c| c.re);
    for c in z.iter().skip(1) {
        e *= step;
        acc += 2.0 * (c * e).re;
    }
    acc
}

/// Samples of z on one step (times increasing, ends included) and, when known, a bound on |z''| over it.
struct Segment {
    ts: Vec<f64>,
    zs: Vec<f64>,
    curvature: Option<f64>,
}

/// Most intervals refined per extreme: beyond it the search reports how much the others could still add.
const MAX_CANDIDATES: usize = 4096;

/// Harmonic evaluations one extreme's refinement of a harmonic-balance solution may spend (a fraction of a
/// second on one core): 1e4 or 1e5 error lines of equal size (issue 29) made all 4096 intervals allowed
/// reach the best sample, up to 3.4e10 evaluations per extreme and minutes. A solution of up to 580
/// harmonics may still refine all 4096; the search usually stops after a few.
const REFINE_BUDGET: f64 = 3e8;

/// Evaluations of one golden-section refinement ([`golden`]: two, then one per step).
const GOLDEN_EVALUATIONS: f64 = 42.0;

/// Global maximum and minimum of z over `segments`: every interval whose upper bound
/// max(z_i, z_i+1) + h^2 |z''| / 8 reaches the best sample is refined by golden section on `value(segment,
/// t)`, at most `max_candidates` of them (the bound of the next one left gives the slack). |z''| is the
/// segment's bound when given, else twice the largest second divided difference of the neighbouring samples.
/// Returns the maximum, the minimum, the slack and the times of the two extremes.
fn extremes(
    segments: &[Segment],
    value: &dyn Fn(usize, f64) -> f64,
    max_candidates: usize,
) -> (f64, f64, f64, [f64; 2]) {
    let mut out = [0.0; 2];
    let mut at = [0.0; 2];
    let mut slack: f64 = 0.0;
    for (slot, sign) in [1.0, -1.0].into_iter().enumerate() {
        let (mut best, mut best_t) = (f64::NEG_INFINITY, 0.0);
        for (v, t) in segments.iter().flat_map(|s| s.zs.iter().zip(&s.ts)) {
            if sign * v > best {
                (best, best_t) = (sign * v, *t);
            }
        }
        let mut candidates: Vec<(f64, usize, usize)> = Vec::new();
        for (j, s) in segments.iter().enumerate() {
            let m = s.ts.len();
            let dd: Vec<f64> = (1..if s.curvature.is_some() { 0 } else { m.saturating_sub(1) })
                .map(|i| {
                    let (h0, h1) = (s.ts[i] - s.ts[i - 1], s.ts[i + 1] - s.ts[i]);
                    if h0 <= 0.0 || h1 <= 0.0 {
                        return 0.0;
                    }
                    2.0 * ((s.zs[i + 1] - s.zs[i]) / h1 - (s.zs[i] - s.zs[i - 1]) / h0).abs() / (h0 + h1)
                })
                .collect();
            for i in 0..m.saturating_sub(1) {
                let h = s.ts[i + 1] - s.ts[i];
                let c2 = match &s.curvature {
                    Some(c) => *c,
                    None => {
                        let near = |k: usize| dd.get(k).copied().unwrap_or(0.0);
                        2.0 * near(i.wrapping_sub(1)).max(near(i)).max(near(i + 1))
                    }
                };
                let top = (sign * s.zs[i]).max(sign * s.zs[i + 1]);
                let ub = top + h * h / 8.0 * c2;
                if ub >= best {
                    candidates.push((ub, j, i));
                }
            }
        }
        // branch and bound: the most promising first, until no interval left can beat what was found
        candidates.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut found = best;
        let mut left = f64::NEG_INFINITY;
        for (n, &(ub, j, i)) in candidates.iter().enumerate() {
            if ub <= found {
                break;
            }
            if n == max_candidates {
                left = ub;
                break;
            }
            let s = &segments[j];
            let f = |t: f64| sign * value(j, t);
            let (v, t) = golden(&f, s.ts[i], s.ts[i + 1]);
            if v > found {
                (found, best_t) = (v, t);
            }
        }
        slack = slack.max(left - found);
        out[slot] = sign * found;
        at[slot] = best_t;
    }
    (out[0], out[1], slack, at)
}

/// Largest value of `f` on [a, b] by golden section (40 steps: the bracket shrinks by 4e-9, so the value,
/// quadratic near the maximum, is within 2e-17 (b - a)^2 |f''| of it).
fn golden(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> (f64, f64) {
    let (mut a, mut b) = (a, b);
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..40 {
        if fc > fd {
            b = d;
            (d, fd) = (c, fc);
            c = b - r * (b - a);
            fc = f(c);
        } else {
            a = c;
            (c, fc) = (d, fd);
            d = a + r * (b - a);
            fd = f(d);
        }
    }
    if fc > fd { (fc, c) } else { (fd, d) }
}

/// Estimated relative error of each printed quantity (`error_estimate` of the steady state is the largest).
#[derive(serde::Serialize, Debug, Clone, Copy)]
pub struct Estimates {
    /// Periodic state, relative to the largest balanced state over the period (rounding included).
    pub state: f64,
    /// Balanced monodromy, relative to max(|Phi|, 1).
    pub monodromy: f64,
    /// Multipliers, relative to max(|rho|max, 1).
    pub multipliers: f64,
    /// Line amplitudes (`orders`), relative to the largest line.
    pub orders: f64,
    /// RMS, relative to itself.
    pub rms: f64,
    /// Peak-to-peak, relative to itself or to the largest |value| when that is larger (a nearly constant
    /// output); it includes what the extreme search left unrefined.
    pub peak_to_peak: f64,
}

impl Estimates {
    /// The largest estimate of the output's quantities (lines, RMS, peak-to-peak); NaN counts as infinite.
    pub fn output(&self) -> f64 {
        let worst = self.orders.max(self.rms).max(self.peak_to_peak);
        if self.orders.is_nan() || self.rms.is_nan() || self.peak_to_peak.is_nan() { f64::INFINITY } else { worst }
    }
}

/// |a - b| / scale, 0 when the difference is 0.
fn relative(diff: f64, scale: f64) -> f64 {
    if diff == 0.0 { 0.0 } else { diff / scale.max(f64::MIN_POSITIVE) }
}

/// The response of `probe` along the printed solution of `steady` and the estimated error of each quantity:
/// the change of each between the printed solution and the one it was compared with (times the solver's
/// factor), plus the rounding of the state (`SteadyState::rounding`) carried to the output.
pub fn estimated_response(
    sys: &dyn PeriodicSystem,
    steady: &SteadyState,
    probe: &Probe,
    kmax: usize,
    tolerance: f64,
) -> (Response, Estimates) {
    let d = super::steady::state_scales(sys);
    // a harmonic-balance pair: the comparison's extremes are searched near the printed ones only
    let (main, near) = match &steady.trajectory {
        Trajectory::Fourier(sol) => {
            let (r, at) = fourier_response(sol, probe, kmax, steady.period_s, &d, None);
            (r, Some((at, steady.period_s / sample_count(sol.harmonics) as f64)))
        }
        traj => (response(sys, traj, steady.period_s, probe, kmax, &d, tolerance), None),
    };
    let top = main.amplitudes().iter().fold(0.0f64, |a, v| a.max(*v));
    // peak-to-peak relative to itself, or to the output's size when smaller (a constant output)
    let p2p = main.max - main.min;
    let p2p_scale = p2p.max(main.max.abs()).max(main.min.abs());
    let rounding = if steady.rounding.is_finite() { steady.rounding * main.gain } else { f64::INFINITY };
    let (mut orders, mut rms, mut peak) = (
        relative(rounding, top),
        relative(rounding, main.rms),
        relative(2.0 * rounding + 2.0 * main.extreme_slack, p2p_scale),
    );
    match &steady.comparison {
        Some(c) => {
            let other = match (&c.trajectory, near) {
                (Trajectory::Fourier(sol), Some(near)) => {
                    fourier_response(sol, probe, kmax, steady.period_s, &d, Some(near)).0
                }
                (traj, _) => response(sys, traj, steady.period_s, probe, kmax, &d, tolerance),
            };
            // the printed amplitudes' change (a phase change of a resonant line is not printed)
            let lines =
                main.amplitudes().iter().zip(other.amplitudes()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            orders += c.factor * relative(lines, top);
            rms += c.factor * relative((main.rms - other.rms).abs(), main.rms);
            peak += c.factor * relative((p2p - (other.max - other.min)).abs(), p2p_scale);
        }
        None => (orders, rms, peak) = (f64::NAN, f64::NAN, f64::NAN),
    }
    let estimates = Estimates {
        state: steady.state_error,
        monodromy: steady.multiplier_error,
        multipliers: steady.rho_error,
        orders,
        rms,
        peak_to_peak: peak,
    };
    (main, estimates)
}

/// Solves `sys` and computes the response of `probe` (lines up to `kmax(T)` for the period T) with its
/// estimates, folded into `error_estimate` and the trust. The solver's loop meets the tolerance on the state
/// and the monodromy; a line, the RMS or the peak-to-peak relative to its own size can need more: then it
/// solves again with the tolerance tightened by what they missed (at most a thousandfold).
///
/// # Errors
/// Solver failures.
pub fn solve_response(
    sys: &dyn PeriodicSystem,
    opts: &SolverOptions,
    probe: &Probe,
    kmax: &dyn Fn(f64) -> usize,
) -> Result<(SteadyState, Response, Estimates), SolverError> {
    let tolerance = opts.tolerance;
    let mut asked = opts.clone();
    let (mut steady, resp, est) = loop {
        let steady = super::solve(sys, &asked)?;
        let (resp, est) = estimated_response(sys, &steady, probe, kmax(steady.period_s), tolerance);
        let worst = est.output();
        // intervals the extreme search left unrefined (its work budget) do not shrink with the tolerance
        let p2p_scale = (resp.max - resp.min).max(resp.max.abs()).max(resp.min.abs());
        let unrefined = relative(2.0 * resp.extreme_slack, p2p_scale) > tolerance;
        let retry = steady.trusted
            && !unrefined
            && worst > tolerance
            && worst.is_finite()
            && asked.steps.is_none()
            && asked.harmonics.is_none()
            && asked.tolerance > tolerance / 1e3;
        if !retry {
            break (steady, resp, est);
        }
        asked.tolerance *= (0.5 * tolerance / worst).max(1e-3);
    };
    let worst = est.output();
    steady.error_estimate = steady.error_estimate.max(worst);
    let p2p_scale = (resp.max - resp.min).max(resp.max.abs()).max(resp.min.abs());
    let slack = relative(2.0 * resp.extreme_slack, p2p_scale);
    if slack > tolerance {
        steady.warnings.push(format!(
            "the extreme search over this many lines stopped at its work budget: the peak-to-peak is known to {slack:.1e} relative (a looser solver.tolerance accepts that)"
        ));
    }
    if worst > tolerance && steady.trusted {
        steady.trusted = false;
        steady.warnings.push(format!(
            "the output's lines, rms or peak-to-peak are estimated to {worst:.1e} relative, above the tolerance"
        ));
    }
    Ok((steady, resp, est))
}
