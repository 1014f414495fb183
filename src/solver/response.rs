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

/// States of a grid trajectory at `times` (each in [0, T]): a partial step of `scheme` from the node at or
/// before it.
pub fn grid_states(
    sys: &dyn PeriodicSystem,
    grid: &rk4::Grid,
    states: &[f64],
    scheme: rk4::Scheme,
    times: &[f64],
    out: &mut Vec<f64>,
) {
    let n = sys.dim();
    let mut st = rk4::Stepper::with_scheme(sys, scheme);
    let mut x = vec![0.0; n];
    out.clear();
    out.reserve(times.len() * n);
    for &t in times {
        rk4::state_at(&mut st, grid, states, t, &mut x);
        out.extend_from_slice(&x);
    }
}

const GAUSS_NODES: [f64; 4] =
    [-0.861_136_311_594_052_6, -0.339_981_043_584_856_3, 0.339_981_043_584_856_3, 0.861_136_311_594_052_6];
const GAUSS_WEIGHTS: [f64; 4] =
    [0.347_854_845_137_453_9, 0.652_145_154_862_546_1, 0.652_145_154_862_546_1, 0.347_854_845_137_453_9];

/// Node values of a grid trajectory: per step the slopes x' = P x + f at its start (right limit) and end
/// (left limit), and the probe there.
struct NodeSlopes {
    start: Vec<f64>,
    end: Vec<f64>,
    z_start: Vec<f64>,
    z_end: Vec<f64>,
}

fn node_slopes(sys: &dyn PeriodicSystem, grid: &rk4::Grid, states: &[f64], probe: &Probe) -> NodeSlopes {
    let n = sys.dim();
    let m = grid.steps();
    let (mut p, mut f) = (DMatrix::zeros(n, n), DVector::zeros(n));
    let mut out =
        NodeSlopes { start: vec![0.0; m * n], end: vec![0.0; m * n], z_start: vec![0.0; m], z_end: vec![0.0; m] };
    for (j, w) in grid.nodes.windows(2).enumerate() {
        let (xa, xb) = (&states[j * n..(j + 1) * n], &states[(j + 1) * n..(j + 2) * n]);
        sys.eval(w[0], Side::Right, &mut p, &mut f);
        crate::system::state_derivative(&p, &f, xa, &mut out.start[j * n..(j + 1) * n]);
        out.z_start[j] = probe.value(xa, &p, &f);
        sys.eval(w[1], Side::Left, &mut p, &mut f);
        crate::system::state_derivative(&p, &f, xb, &mut out.end[j * n..(j + 1) * n]);
        out.z_end[j] = probe.value(xb, &p, &f);
    }
    out
}

/// The cubic Hermite interpolant of step j at time t from its end states and slopes: an RK4 trajectory's
/// dense output. Its error, h^4 |x''''| / 384, is of the scheme's own order and below the global error of
/// the nodes (which gather the local errors of about 1 / (zeta w h) steps), so the printed quantities keep
/// fourth order and the comparison of two resolutions still estimates their error.
fn hermite(grid: &rk4::Grid, states: &[f64], slopes: &NodeSlopes, j: usize, t: f64, x: &mut [f64]) {
    let n = x.len();
    let (ta, tb) = (grid.nodes[j], grid.nodes[j + 1]);
    let h = tb - ta;
    let s = ((t - ta) / h).clamp(0.0, 1.0);
    let (s2, s3) = (s * s, s * s * s);
    let (h00, h10, h01, h11) = (2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, 3.0 * s2 - 2.0 * s3, s3 - s2);
    for (c, out) in x.iter_mut().enumerate() {
        *out = h00 * states[j * n + c]
            + h01 * states[(j + 1) * n + c]
            + h * (h10 * slopes.start[j * n + c] + h11 * slopes.end[j * n + c]);
    }
}

/// Z_k = sum_i v_i e^{-i k w t_i}, k = 0..=kmax: each point's phasor advanced by one multiplication per
/// harmonic, in four independent lanes of separate real and imaginary parts (so the loop runs at the
/// multipliers' throughput and vectorises).
fn phasor_sums(values: &[f64], times: &[f64], omega: f64, kmax: usize) -> Vec<C64> {
    let m = values.len();
    let (mut cr, mut ci): (Vec<f64>, Vec<f64>) =
        times.iter().map(|t| (omega * t).sin_cos()).map(|(s, c)| (c, -s)).unzip();
    let (mut er, mut ei) = (values.to_vec(), vec![0.0; m]);
    // padded to a multiple of four with zero values (their phasors stay zero)
    let padded = m.div_ceil(4) * 4;
    for v in [&mut cr, &mut ci, &mut er, &mut ei] {
        v.resize(padded, 0.0);
    }
    let mut lines = Vec::with_capacity(kmax + 1);
    for _ in 0..=kmax {
        let (mut sr, mut si) = ([0.0f64; 4], [0.0f64; 4]);
        for (((a, b), c), d) in
            er.chunks_exact_mut(4).zip(ei.chunks_exact_mut(4)).zip(cr.chunks_exact(4)).zip(ci.chunks_exact(4))
        {
            for l in 0..4 {
                let (x, y) = (a[l], b[l]);
                sr[l] += x;
                si[l] += y;
                a[l] = x * c[l] - y * d[l];
                b[l] = x * d[l] + y * c[l];
            }
        }
        lines.push(C64::new((sr[0] + sr[1]) + (sr[2] + sr[3]), (si[0] + si[1]) + (si[2] + si[3])));
    }
    lines
}

/// M_p(phi) = int_0^1 s^p e^{-i phi s} ds for p = 0..=3: the series for |phi| < 1.5 (no cancellation), else
/// integration by parts upwards, M_0 = (1 - e^{-i phi}) / (i phi), M_p = (p M_{p-1} - e^{-i phi}) / (i phi).
fn power_moments(phi: f64) -> [C64; 4] {
    let mut out = [C64::new(0.0, 0.0); 4];
    if phi.abs() < 1.5 {
        // (-i phi)^j / j! until far below rounding (|phi|^30 / 30! < 1e-26)
        let mut term = C64::new(1.0, 0.0);
        for j in 0..30 {
            for (p, o) in out.iter_mut().enumerate() {
                *o += term / (j + p + 1) as f64;
            }
            term *= C64::new(0.0, -phi) / (j + 1) as f64;
        }
    } else {
        let e = C64::from_polar(1.0, -phi);
        let i_phi = C64::new(0.0, phi);
        out[0] = (C64::new(1.0, 0.0) - e) / i_phi;
        for p in 1..4 {
            out[p] = (out[p - 1] * p as f64 - e) / i_phi;
        }
    }
    out
}

/// Exact lines, RMS and extremes of a linear probe along the cubic Hermite dense output of an rk4 trajectory
/// (the same dense output as [`gauss_response`]): on each step z(t_j + h s) = a0 + a1 s + a2 s^2 + a3 s^3 from
/// the probe and its slope c . x' at both ends, so
/// - RMS: int z^2 in closed form per step;
/// - extremes: the step ends and the roots of the quadratic z' inside;
/// - lines: on a run of equal steps, int_0^1 z(s) e^{-i phi s} ds (phi = k w h) is a combination of the four
///   moments M_p(phi) of the Hermite basis, so Z_k needs only two phasor sums over the run's nodes (of z and
///   of h z'), not one per quadrature point.
///
/// `None` when the grid has more than one run per 16 steps (a table of many short pieces), where the
/// per-run moments would cost more than quadrature.
#[allow(clippy::too_many_arguments)]
fn hermite_response(
    sys: &dyn PeriodicSystem,
    grid: &rk4::Grid,
    states: &[f64],
    probe: &Probe,
    kmax: usize,
    period_s: f64,
    d: &[f64],
) -> Option<Response> {
    let n = sys.dim();
    let m = grid.steps();
    let period = sys.period_s();
    let breaks = rk4::sorted_breaks(sys);
    // runs of equal steps with no jump of the coefficients inside: [first step, end step)
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut first = 0;
    for j in 1..=m {
        let h0 = grid.nodes[first + 1] - grid.nodes[first];
        let split = j == m
            || rk4::is_break(&breaks, grid.nodes[j], period)
            || ((grid.nodes[j + 1] - grid.nodes[j]) - h0).abs() > 1e-9 * h0;
        if split {
            runs.push((first, j));
            first = j;
        }
    }
    if 16 * runs.len() > m.max(16) {
        return None;
    }
    let slopes = node_slopes(sys, grid, states, probe);
    let dot = |v: &[f64]| probe.weights.iter().zip(v).map(|(w, x)| w * x).sum::<f64>();
    let zd_start: Vec<f64> = slopes.start.chunks(n).map(dot).collect();
    let zd_end: Vec<f64> = slopes.end.chunks(n).map(dot).collect();
    // RMS and extremes step by step
    let (mut square, mut max, mut min) = (0.0, f64::NEG_INFINITY, f64::INFINITY);
    for j in 0..m {
        let h = grid.nodes[j + 1] - grid.nodes[j];
        let (z0, z1, d0, d1) = (slopes.z_start[j], slopes.z_end[j], h * zd_start[j], h * zd_end[j]);
        let a = [z0, d0, 3.0 * (z1 - z0) - 2.0 * d0 - d1, 2.0 * (z0 - z1) + d0 + d1];
        let mut integral = 0.0;
        for p in 0..4 {
            for q in 0..4 {
                integral += a[p] * a[q] / (p + q + 1) as f64;
            }
        }
        square += h * integral;
        let at = |s: f64| a[0] + s * (a[1] + s * (a[2] + s * a[3]));
        let mut consider = |v: f64| {
            max = f64::max(max, v);
            min = f64::min(min, v);
        };
        consider(z0);
        consider(z1);
        // z'(s) / 1 = a1 + 2 a2 s + 3 a3 s^2
        let (qa, qb, qc) = (3.0 * a[3], 2.0 * a[2], a[1]);
        if qa.abs() > 1e-300 {
            let disc = qb * qb - 4.0 * qa * qc;
            if disc >= 0.0 {
                // the stable pair of roots: q = -(b + sign(b) sqrt(disc)) / 2, s = q / a and c / q
                let q = -0.5 * (qb + qb.signum() * disc.sqrt());
                for s in [q / qa, if q != 0.0 { qc / q } else { f64::NAN }] {
                    if s > 0.0 && s < 1.0 {
                        consider(at(s));
                    }
                }
            }
        } else if qb.abs() > 1e-300 {
            let s = -qc / qb;
            if s > 0.0 && s < 1.0 {
                consider(at(s));
            }
        }
    }
    // lines, run by run
    let omega = 2.0 * std::f64::consts::PI / period_s;
    let mut lines = vec![C64::new(0.0, 0.0); kmax + 1];
    for &(j0, j1) in &runs {
        let steps = j1 - j0;
        let h = (grid.nodes[j1] - grid.nodes[j0]) / steps as f64;
        // node values of the run: z_i and h z'_i (the right slope, the left one at the run's last node)
        let times = &grid.nodes[j0..=j1];
        let mut zv: Vec<f64> = slopes.z_start[j0..j1].to_vec();
        zv.push(slopes.z_end[j1 - 1]);
        let mut dv: Vec<f64> = zd_start[j0..j1].iter().map(|v| h * v).collect();
        dv.push(h * zd_end[j1 - 1]);
        let sz = phasor_sums(&zv, times, omega, kmax);
        let sd = phasor_sums(&dv, times, omega, kmax);
        // phasors of the run's end nodes, advanced harmonic by harmonic
        let (r0, r1) = (C64::from_polar(1.0, -omega * times[0]), C64::from_polar(1.0, -omega * times[steps]));
        let (mut e0, mut e1) = (C64::new(1.0, 0.0), C64::new(1.0, 0.0));
        let (z_first, z_last, d_first, d_last) = (zv[0], zv[steps], dv[0], dv[steps]);
        for (k, line) in lines.iter_mut().enumerate() {
            let phi = k as f64 * omega * h;
            let mo = power_moments(phi);
            // the Hermite basis h00, h01, h10, h11 against e^{-i phi s}
            let ba = mo[3] * 2.0 - mo[2] * 3.0 + mo[0];
            let bb = mo[2] * 3.0 - mo[3] * 2.0;
            let bc = mo[3] - mo[2] * 2.0 + mo[1];
            let bd = mo[3] - mo[2];
            let shift = C64::from_polar(1.0, phi);
            let z_lo = sz[k] - e1 * z_last; // nodes 0..K-1
            let z_hi = sz[k] - e0 * z_first; // nodes 1..K
            let d_lo = sd[k] - e1 * d_last;
            let d_hi = sd[k] - e0 * d_first;
            *line += (ba * z_lo + bb * shift * z_hi + bc * d_lo + bd * shift * d_hi) * (h / period_s);
            e0 *= r0;
            e1 *= r1;
        }
    }
    let gain = row_gain(&probe.row(&DMatrix::zeros(n, n), &DVector::zeros(n)), d) * balanced_scale(states, d);
    Some(Response { lines, rms: (square / period_s).max(0.0).sqrt(), max, min, gain, extreme_slack: 0.0 })
}

#[allow(clippy::too_many_arguments)]
fn gauss_response(
    sys: &dyn PeriodicSystem,
    grid: &rk4::Grid,
    states: &[f64],
    scheme: rk4::Scheme,
    probe: &Probe,
    kmax: usize,
    period_s: f64,
    d: &[f64],
    tolerance: f64,
) -> Response {
    let n = sys.dim();
    let omega = 2.0 * std::f64::consts::PI / period_s;
    let rate = super::max_rate(sys);
    let theta = phase_per_interval(tolerance);
    let band = rate + omega * (kmax.max(sys.max_harmonic()) as f64);
    // per step: the start node, the Gauss points of its sub-intervals, the end node
    let mut times = Vec::new();
    let mut weights = Vec::new();
    let mut owner = Vec::new();
    for (j, w) in grid.nodes.windows(2).enumerate() {
        let h = w[1] - w[0];
        let q = ((h * band / theta).ceil() as usize).max(1);
        let hs = h / q as f64;
        for s in 0..q {
            let mid = w[0] + (s as f64 + 0.5) * hs;
            for (x, g) in GAUSS_NODES.iter().zip(GAUSS_WEIGHTS) {
                times.push(mid + 0.5 * hs * x);
                weights.push(0.5 * hs * g);
                owner.push(j);
            }
        }
    }
    let slopes = node_slopes(sys, grid, states, probe);
    // the dense output: cubic Hermite on the nodes for rk4 (no evaluation of P), a partial step of the
    // scheme from the node before for magnus4 (A-stable steps can be far longer than 1 / |lambda|, where a
    // cubic through the ends would miss the fast transients inside the step)
    let hermite_output = scheme == rk4::Scheme::Rk4;
    let mut xs = Vec::new();
    if hermite_output {
        xs.resize(times.len() * n, 0.0);
        for (i, (&t, &j)) in times.iter().zip(&owner).enumerate() {
            hermite(grid, states, &slopes, j, t, &mut xs[i * n..(i + 1) * n]);
        }
    } else {
        grid_states(sys, grid, states, scheme, &times, &mut xs);
    }
    let (mut p, mut f) = (DMatrix::zeros(n, n), DVector::zeros(n));
    let mut gain_row: f64 = 0.0;
    let mut zs = Vec::with_capacity(times.len());
    for (i, &t) in times.iter().enumerate() {
        if probe.derivative {
            sys.eval(t, Side::Right, &mut p, &mut f);
            gain_row = gain_row.max(row_gain(&probe.row(&p, &f), d));
        }
        zs.push(probe.value(&xs[i * n..(i + 1) * n], &p, &f));
    }
    if !probe.derivative {
        gain_row = row_gain(&probe.row(&p, &f), d);
    }
    let scaled: Vec<f64> = zs.iter().zip(&weights).map(|(z, w)| z * w / period_s).collect();
    let lines = phasor_sums(&scaled, &times, omega, kmax);
    let rms = (zs.iter().zip(&weights).map(|(z, w)| z * z * w).sum::<f64>() / period_s).max(0.0).sqrt();
    // segments per step: start node (right limit), the Gauss points, end node (left limit)
    let mut segments = Vec::with_capacity(grid.steps());
    let mut at = 0;
    for (j, w) in grid.nodes.windows(2).enumerate() {
        let mut ts = vec![w[0]];
        let mut vs = vec![slopes.z_start[j]];
        while at < owner.len() && owner[at] == j {
            ts.push(times[at]);
            vs.push(zs[at]);
            at += 1;
        }
        ts.push(w[1]);
        vs.push(slopes.z_end[j]);
        segments.push(Segment { ts, zs: vs, curvature: None });
    }
    let value = |j: usize, t: f64| {
        let mut x = states[j * n..(j + 1) * n].to_vec();
        if hermite_output {
            hermite(grid, states, &slopes, j, t, &mut x);
        } else if t > grid.nodes[j] {
            let mut st = rk4::Stepper::with_scheme(sys, scheme);
            st.step(grid.nodes[j], t, &mut x, &[1.0], false);
        }
        let (mut p, mut f) = (DMatrix::zeros(n, n), DVector::zeros(n));
        if probe.derivative {
            sys.eval(t, if t >= grid.nodes[j + 1] { Side::Left } else { Side::Right }, &mut p, &mut f);
        }
        probe.value(&x, &p, &f)
    };
    let (max, min, slack, _) = extremes(&segments, &value, MAX_CANDIDATES);
    let gain = gain_row * balanced_scale(states, d);
    Response { lines, rms, max, min, gain, extreme_slack: slack }
}

/// The augmented matrix [P f; 0 0] (n + 1) of a piece.
fn augmented(p: &DMatrix<f64>, f: &DVector<f64>) -> DMatrix<f64> {
    let n = p.nrows();
    let mut a = DMatrix::zeros(n + 1, n + 1);
    a.view_mut((0, 0), (n, n)).copy_from(p);
    a.view_mut((0, n), (n, 1)).copy_from(f);
    a
}

/// int_0^h c^T exp(B tau) dtau for a complex B (n + 1): the corner row of exp([[0, c^T], [0, B]] h).
fn integral_row(c: &DVector<f64>, b: &DMatrix<C64>, h: f64) -> Vec<C64> {
    let m = b.nrows();
    let mut big = DMatrix::<C64>::zeros(m + 1, m + 1);
    for j in 0..m {
        big[(0, j + 1)] = C64::new(c[j] * h, 0.0);
        for i in 0..m {
            big[(i + 1, j + 1)] = b[(i, j)] * h;
        }
    }
    let e = big.exp();
    (0..m).map(|j| e[(0, j + 1)]).collect()
}

/// Gram matrix int_0^h exp(A^T tau) c c^T exp(A tau) dtau (Van Loan: F22^T F12 of exp([[-A^T, c c^T],
/// [0, A]] h)).
fn gram(a: &DMatrix<f64>, c: &DVector<f64>, h: f64) -> DMatrix<f64> {
    let m = a.nrows();
    let mut big = DMatrix::zeros(2 * m, 2 * m);
    big.view_mut((0, 0), (m, m)).copy_from(&(-a.transpose() * h));
    big.view_mut((0, m), (m, m)).copy_from(&(c * c.transpose() * h));
    big.view_mut((m, m), (m, m)).copy_from(&(a * h));
    let e = big.exp();
    let f12 = e.view((0, m), (m, m)).clone_owned();
    let f22 = e.view((m, m), (m, m)).clone_owned();
    f22.transpose() * f12
}

/// Exact lines, RMS and extremes on piecewise-constant coefficients (see the module docs). Each step lies
/// inside one piece; it is cut into q equal sub-pieces with (|A| + kmax w) h / q <= 1 so that every block
/// exponential is of modest norm, and the sub-pieces share their exponentials.
#[allow(clippy::too_many_arguments)]
fn piecewise_response(
    sys: &dyn PeriodicSystem,
    grid: &rk4::Grid,
    states: &[f64],
    probe: &Probe,
    kmax: usize,
    period_s: f64,
    d: &[f64],
    tolerance: f64,
) -> Response {
    let n = sys.dim();
    let omega = 2.0 * std::f64::consts::PI / period_s;
    let theta = phase_per_interval(tolerance);
    let (mut p, mut f) = (DMatrix::zeros(n, n), DVector::zeros(n));
    let mut lines = vec![C64::new(0.0, 0.0); kmax + 1];
    let mut square = 0.0;
    let mut segments = Vec::with_capacity(grid.steps());
    let mut pieces = Vec::with_capacity(grid.steps());
    let mut gain_row: f64 = 0.0;
    // balanced coordinates: x^ = Dh z^ with Dh = diag(d, 1), so A^ becomes Dh^-1 A^ Dh (norm ~ |lambda|)
    let dh: Vec<f64> = d.iter().copied().chain([1.0]).collect();
    for (j, w) in grid.nodes.windows(2).enumerate() {
        let h = w[1] - w[0];
        sys.eval(0.5 * (w[0] + w[1]), Side::Right, &mut p, &mut f);
        let a_raw = augmented(&p, &f);
        let c_raw = probe.row(&p, &f);
        gain_row = gain_row.max(row_gain(&c_raw, d));
        let a = DMatrix::from_fn(n + 1, n + 1, |r, s| a_raw[(r, s)] * dh[s] / dh[r]);
        let c = DVector::from_fn(n + 1, |r, _| c_raw[r] * dh[r]);
        let norm = a.view((0, 0), (n, n)).abs().row_sum().max();
        let q = ((h * (norm + omega * kmax as f64) / theta).ceil() as usize).max(1);
        let hs = h / q as f64;
        let e_sub = (&a * hs).exp();
        let g = gram(&a, &c, hs);
        // int over a sub-piece of e^{-i k w tau} c^T exp(A tau) = row_k; phases from the sub-piece start
        let rows: Vec<Vec<C64>> = (0..=kmax)
            .map(|k| {
                let b = DMatrix::from_fn(n + 1, n + 1, |r, s| {
                    C64::new(a[(r, s)], if r == s { -(k as f64) * omega } else { 0.0 })
                });
                integral_row(&c, &b, hs)
            })
            .collect();
        // four samples per sub-piece for the extremes: exp(A hs i / 4)
        let quarter = (&a * (0.25 * hs)).exp();
        let mut zb = DVector::from_fn(n + 1, |r, _| if r < n { states[j * n + r] / d[r] } else { 1.0 });
        let mut ts = Vec::with_capacity(4 * q + 1);
        let mut vs = Vec::with_capacity(4 * q + 1);
        for s in 0..q {
            let t0 = w[0] + s as f64 * hs;
            square += (zb.transpose() * &g * &zb)[(0, 0)];
            for (k, row) in rows.iter().enumerate() {
                let v: C64 = row.iter().zip(zb.iter()).map(|(r, x)| r * *x).sum();
                lines[k] += v * C64::from_polar(1.0, -(k as f64) * omega * t0) / period_s;
            }
            let mut y = zb.clone();
            for i in 0..4 {
                ts.push(t0 + 0.25 * hs * i as f64);
                vs.push(c.dot(&y));
                y = &quarter * y;
            }
            zb = &e_sub * zb;
        }
        ts.push(w[1]);
        vs.push(c.dot(&zb));
        segments.push(Segment { ts, zs: vs, curvature: None });
        pieces.push((a, c));
    }
    let value = |j: usize, t: f64| {
        let (a, c) = &pieces[j];
        let x0 = DVector::from_fn(n + 1, |r, _| if r < n { states[j * n + r] / d[r] } else { 1.0 });
        c.dot(&((a * (t - grid.nodes[j])).exp() * x0))
    };
    let (max, min, slack, _) = extremes(&segments, &value, MAX_CANDIDATES);
    let gain = gain_row * balanced_scale(states, d);
    Response { lines, rms: (square / period_s).max(0.0).sqrt(), max, min, gain, extreme_slack: slack }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether t lies on the first half [0, 1/2) of the unit period, taking the `side` limit at a jump.
    fn first_half(t: f64, side: Side) -> bool {
        let tau = t.rem_euclid(1.0);
        if side == Side::Right { tau < 0.5 } else { tau > 0.0 && tau <= 0.5 }
    }

    /// A test system of period 1 whose coefficients jump at 1/2: `dim` states, P and f written by
    /// `coefficients(t, on the first half)`.
    struct HalfJump {
        dim: usize,
        max_harmonic: usize,
        piecewise_constant: bool,
        coefficients: fn(f64, bool, &mut DMatrix<f64>, &mut DVector<f64>),
    }

    impl PeriodicSystem for HalfJump {
        fn dim(&self) -> usize {
            self.dim
        }
        fn period_s(&self) -> f64 {
            1.0
        }
        fn eval(&self, t: f64, side: Side, p: &mut DMatrix<f64>, f: &mut DVector<f64>) {
            (self.coefficients)(t, first_half(t, side), p, f);
        }
        fn breakpoints(&self) -> Vec<f64> {
            vec![0.5]
        }
        fn piecewise_constant(&self) -> bool {
            self.piecewise_constant
        }
        fn max_harmonic(&self) -> usize {
            self.max_harmonic
        }
    }

    /// x' = -x + f with f = 1 on [0, T/2), 0 after: piecewise constant, one state.
    const SQUARE: HalfJump = HalfJump {
        dim: 1,
        max_harmonic: 0,
        piecewise_constant: true,
        coefficients: |_, first, p, f| {
            p[(0, 0)] = -1.0;
            f[0] = if first { 1.0 } else { 0.0 };
        },
    };

    /// x'' + 0.3 x' + k(t) x = cos(2 pi t) + 0.2 with k = 50 on [0, 1/2), 40 after: several oscillations per
    /// period, so the probe has interior extremes on many steps.
    const OSCILLATOR: HalfJump = HalfJump {
        dim: 2,
        max_harmonic: 1,
        piecewise_constant: false,
        coefficients: |t, first, p, f| {
            p[(0, 0)] = 0.0;
            p[(0, 1)] = 1.0;
            p[(1, 0)] = if first { -50.0 } else { -40.0 };
            p[(1, 1)] = -0.3;
            f[0] = 0.0;
            f[1] = (2.0 * std::f64::consts::PI * t).cos() + 0.2;
        },
    };

    /// The exact periodic solution: x = 1 - A e^-t on the first half, B e^-(t - 1/2) on the second, with
    /// B = 1 - A e^-1/2 and A = 1 - B e^-1/2 (continuity at both ends).
    fn exact(t: f64) -> f64 {
        let e = (-0.5f64).exp();
        let a = (1.0 - e) / (1.0 - e * e);
        let b = 1.0 - a * e;
        if t < 0.5 { 1.0 - a * (-t).exp() } else { b * (-(t - 0.5)).exp() }
    }

    /// The closed forms on the cubic Hermite dense output (moments per run, z^2 per step, roots of z') against
    /// fine 4-point Gauss quadrature and the golden-section extreme search on the same dense output, on a
    /// grid of two runs of different step (41 steps, a jump at 0.5) with a probe mixing the state and a constant.
    #[test]
    fn hermite_closed_forms_match_quadrature_of_the_same_dense_output() {
        let sys = OSCILLATOR;
        let grid = rk4::Grid::new(1.0, &[0.5], 41);
        let x0 = DVector::from_vec(vec![0.02, -0.1]);
        let states = rk4::trajectory(&sys, &grid, &x0);
        let probe = Probe { weights: vec![-2.5, 0.3], derivative: false };
        let closed = hermite_response(&sys, &grid, &states, &probe, 12, 1.0, &[1.0, 1.0]).expect("two runs");
        // theta clamps to 0.05 at 1e-15: the quadrature's own error is near 2.9e-7 (0.025)^8 ~ 5e-20
        let quad = gauss_response(&sys, &grid, &states, rk4::Scheme::Rk4, &probe, 12, 1.0, &[1.0, 1.0], 1e-15);
        let scale = closed.max.abs().max(closed.min.abs());
        for (k, (a, b)) in closed.lines.iter().zip(&quad.lines).enumerate() {
            // sums of ~1e3 terms of size 1: rounding far below 1e-13
            assert!((a - b).norm() < 1e-13 * scale, "line {k}: {a} against {b}");
        }
        assert!((closed.rms - quad.rms).abs() < 1e-13 * scale, "{} against {}", closed.rms, quad.rms);
        // golden section ends within 2e-17 (b - a)^2 |z''| of an interior extreme
        assert!((closed.max - quad.max).abs() < 1e-13 * scale, "{} against {}", closed.max, quad.max);
        assert!((closed.min - quad.min).abs() < 1e-13 * scale, "{} against {}", closed.min, quad.min);
    }

    #[test]
    fn piecewise_lines_and_rms_match_the_closed_form() {
        let sys = SQUARE;
        let grid = rk4::Grid::new(1.0, &[0.5], 2);
        let states = vec![exact(0.0), exact(0.5), exact(0.0)];
        let traj = Trajectory::Grid { grid, states, scheme: rk4::Scheme::Magnus4 };
        let probe = Probe { weights: vec![1.0], derivative: false };
        let r = response(&sys, &traj, 1.0, &probe, 5, &[1.0], 1e-10);
        // mean of x = mean of f (integrate x' = -x + f over a period) = 1/2, exactly
        assert!((r.lines[0].re - 0.5).abs() < 1e-15, "{}", r.lines[0]);
        // Z_1 and the rms by Simpson on 2 x 20000 points of the closed form (error ~1e-17)
        let m = 20000;
        let (mut z1, mut sq) = (C64::new(0.0, 0.0), 0.0);
        for half in 0..2 {
            let h = 0.5 / m as f64;
            for j in 0..=m {
                let t = 0.5 * half as f64 + j as f64 * h;
                let x = if half == 0 && j == m { exact(0.5 - 1e-300) } else { exact(t) };
                let w = if j == 0 || j == m {
                    1.0
                } else if j % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                z1 += C64::from_polar(x, -2.0 * std::f64::consts::PI * t) * (w * h / 3.0);
                sq += x * x * w * h / 3.0;
            }
        }
        assert!((r.lines[1] - z1).norm() < 1e-14, "{} vs {z1}", r.lines[1]);
        assert!((r.rms - sq.sqrt()).abs() < 1e-14, "{} vs {}", r.rms, sq.sqrt());
    }
}
