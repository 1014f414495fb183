//! One check for every periodic solver on every reference case (RustFFT's `check_fft_algorithm`, diffsol's
//! `test_ode_solver`): solve, compute what `simulate` prints (lines, rms, peak-to-peak, multipliers, the
//! periodic state) with its error estimates, and hold each against a reference computed here, independently
//! of the solver: exact matrix exponentials (this file's own Taylor scaling-and-squaring, `expm`) on each
//! piece of piecewise-constant coefficients, else classical RK4 with tiny steps aligned on every jump;
//! composite Simpson per piece for the integrals; every node of the tiny-step grid (millions per second of
//! simulated time, far above 400 kHz) for the extremes, refined by a parabola through the best node and its
//! neighbours. The periodic state is compared over the whole period, at about [`DENSE_POINTS`] times
//! spread over the pieces (the reference there by one exact exponential, or one RK4 step, from its node
//! before; the solver's by its own dense output, `SteadyState::states_at`). The reference runs at two
//! resolutions; their difference (times 4) is its own accuracy (`floor`), below which a true error cannot
//! be told.
//!
//! For each printed quantity: true error <= estimate and estimate <= 30 x true error (both above the floor),
//! or the result is not trusted (then only the first: the estimate stays an upper bound).

use super::expm;
use gearvib::model::SecondOrderSystem;
use gearvib::scene::Scene;
use gearvib::solver::response::{Estimates, Probe, Response, solve_response};
use gearvib::solver::steady::state_scales;
use gearvib::solver::{Method, SolverOptions, SteadyState};
use gearvib::system::{PeriodicSystem, Side};
use nalgebra::{Complex, DMatrix, DVector};

type C64 = Complex<f64>;

/// Where a case's system comes from.
pub enum Source {
    /// A scene (its system and output quantity).
    Scene(Box<Scene>),
    /// A catalog system, probed by `probe`.
    System(SecondOrderSystem, Probe),
}

/// A reference case: a system, what is probed, how many lines.
pub struct Case {
    pub name: String,
    pub source: Source,
    /// Highest line compared (0: lines not compared, as over a hunting period's thousands).
    pub lines: usize,
    /// Steps per period of the finer reference run.
    pub reference_steps: usize,
}

impl Case {
    pub fn system(&self) -> &dyn PeriodicSystem {
        match &self.source {
            Source::Scene(s) => s.system(),
            Source::System(s, _) => s,
        }
    }
    pub fn probe(&self) -> Probe {
        match &self.source {
            Source::Scene(s) => gearvib::jobs::simulate::probe(&s.output.quantity, s.system().dim()),
            Source::System(_, p) => p.clone(),
        }
    }
    /// Lines the solver prints: the scene's `max_order`, else `lines`.
    pub fn printed_lines(&self, period_s: f64) -> usize {
        match &self.source {
            Source::Scene(s) => (s.output.max_order * period_s * s.output.base_hz + 1e-9).floor() as usize,
            Source::System(..) => self.lines,
        }
    }
}

/// Reference values of one case.
#[derive(Clone, Debug)]
pub struct Reference {
    /// One-sided amplitudes |Z_0|, 2 |Z_k|, k <= `Case::lines`.
    pub amplitudes: Vec<f64>,
    pub rms: f64,
    pub max: f64,
    pub min: f64,
    pub multipliers: Vec<C64>,
    /// Periodic initial state.
    pub x0: Vec<f64>,
    /// The times (s) where the state is compared over the period ([`dense_times`]).
    pub dense_times: Vec<f64>,
    /// The periodic state at `dense_times`, n per time.
    pub dense_states: Vec<f64>,
    /// Largest balanced state over the period (the scale of state errors).
    pub state_scale: f64,
    /// The reference's own accuracy per quantity (relative, same measures as the estimates).
    pub floor: Estimates,
}

/// The augmented [P f; 0 0] at (t, side).
fn augmented(sys: &dyn PeriodicSystem, t: f64, side: Side) -> DMatrix<f64> {
    let n = sys.dim();
    let (mut p, mut f) = (DMatrix::zeros(n, n), DVector::zeros(n));
    sys.eval(t, side, &mut p, &mut f);
    let mut a = DMatrix::zeros(n + 1, n + 1);
    a.view_mut((0, 0), (n, n)).copy_from(&p);
    a.view_mut((0, n), (n, 1)).copy_from(&f);
    a
}

fn to_rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows()).map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect()).collect()
}

fn from_rows(r: &[Vec<f64>]) -> DMatrix<f64> {
    DMatrix::from_fn(r.len(), r[0].len(), |i, j| r[i][j])
}

/// Node times of one period, piece by piece (each piece's first and last node on its ends).
struct Grid {
    pieces: Vec<Vec<f64>>,
}

fn grid(sys: &dyn PeriodicSystem, steps: usize) -> Grid {
    let t_end = sys.period_s();
    let mut edges = vec![0.0];
    edges.extend(sys.breakpoints());
    edges.push(t_end);
    let pieces = edges
        .windows(2)
        .map(|w| {
            // an even count per piece (Simpson), at least 2
            let k = (((w[1] - w[0]) / t_end * steps as f64 / 2.0).ceil() as usize).max(1) * 2;
            (0..=k).map(|j| if j == k { w[1] } else { w[0] + (w[1] - w[0]) * j as f64 / k as f64 }).collect()
        })
        .collect();
    Grid { pieces }
}

/// About this many times per period where the periodic state is compared (each piece gets its share by
/// length, and at least its two ends).
pub const DENSE_POINTS: usize = 4096;

/// The comparison times of each piece of `sys`'s period: equally spaced, both ends included.
fn dense_times(sys: &dyn PeriodicSystem) -> Vec<Vec<f64>> {
    let t_end = sys.period_s();
    let mut edges = vec![0.0];
    edges.extend(sys.breakpoints());
    edges.push(t_end);
    edges
        .windows(2)
        .map(|w| {
            let m = ((w[1] - w[0]) / t_end * DENSE_POINTS as f64).ceil().max(1.0) as usize;
            (0..=m).map(|i| if i == m { w[1] } else { w[0] + (w[1] - w[0]) * i as f64 / m as f64 }).collect()
        })
        .collect()
}

/// One classical RK4 step of W' = A(t) W from ta to tb (W is (n+1) x cols), A at the step ends taken inside
/// the piece.
fn step(sys: &dyn PeriodicSystem, ta: f64, tb: f64, w: &DMatrix<f64>) -> DMatrix<f64> {
    let h = tb - ta;
    let a0 = augmented(sys, ta, Side::Right);
    let am = augmented(sys, ta + 0.5 * h, Side::Right);
    let a1 = augmented(sys, tb, Side::Left);
    let k1 = &a0 * w * h;
    let k2 = &am * (w + &k1 * 0.5) * h;
    let k3 = &am * (w + &k2 * 0.5) * h;
    let k4 = &a1 * (w + &k3) * h;
    w + (k1 + k2 * 2.0 + k3 * 2.0 + k4) / 6.0
}

/// For piecewise-constant coefficients, the augmented matrix A of a piece: then the state at any node is
/// exp(A (t - t_start)) applied to the piece's start state (one exponential per node, no accumulated
/// products).
fn piece_matrix(sys: &dyn PeriodicSystem, nodes: &[f64]) -> Option<DMatrix<f64>> {
    sys.piecewise_constant().then(|| augmented(sys, 0.5 * (nodes[0] + nodes[1]), Side::Right))
}

/// exp(A t) by the test's own scaling and squaring, on A balanced by powers of two (Osborne): a gear's
/// matrix mixes metres and metres per second, and squaring an unbalanced exponential loses digits.
fn exp_at(a: &DMatrix<f64>, t: f64) -> DMatrix<f64> {
    let n = a.nrows();
    let mut m = a * t;
    let mut d = vec![1.0; n];
    for _ in 0..50 {
        for i in 0..n {
            let c: f64 = (0..n).filter(|&j| j != i).map(|j| m[(j, i)].abs()).sum();
            let r: f64 = (0..n).filter(|&j| j != i).map(|j| m[(i, j)].abs()).sum();
            if c > 0.0 && r > 0.0 {
                let f = 2f64.powi(((r / c).log2() / 2.0).round() as i32);
                d[i] *= f;
                for j in 0..n {
                    m[(i, j)] /= f;
                    m[(j, i)] *= f;
                }
            }
        }
    }
    let e = from_rows(&expm(&to_rows(&m)));
    DMatrix::from_fn(n, n, |i, j| e[(i, j)] * d[i] / d[j])
}

/// Eigenvalues of a real matrix by nalgebra's Schur decomposition (backward stable: the 2 x 2 closed form
/// loses half the digits of a pair near a double eigenvalue, even of a normal matrix).
fn eigenvalues(m: &DMatrix<f64>) -> Vec<C64> {
    m.complex_eigenvalues().iter().copied().collect()
}

fn probe_value(sys: &dyn PeriodicSystem, probe: &Probe, t: f64, side: Side, x: &[f64]) -> f64 {
    if probe.derivative {
        let a = augmented(sys, t, side);
        let n = x.len();
        (0..n).map(|r| probe.weights[r] * ((0..n).map(|c| a[(r, c)] * x[c]).sum::<f64>() + a[(r, n)])).sum()
    } else {
        probe.weights.iter().zip(x).map(|(w, v)| w * v).sum()
    }
}

/// The reference at `steps` steps per period (see the module docs).
fn reference_at(case: &Case, steps: usize) -> Reference {
    let sys = case.system();
    let probe = case.probe();
    let n = sys.dim();
    let g = grid(sys, steps);
    let exact: Vec<Option<DMatrix<f64>>> = g.pieces.iter().map(|p| piece_matrix(sys, p)).collect();
    // the state at every node of a piece from its start state
    let sweep = |nodes: &[f64], a: Option<&DMatrix<f64>>, start: &DMatrix<f64>| -> Vec<DMatrix<f64>> {
        let mut out = vec![start.clone()];
        for (j, s) in nodes.windows(2).enumerate() {
            out.push(match a {
                Some(a) => exp_at(a, s[1] - nodes[0]) * start,
                None => step(sys, s[0], s[1], &out[j]),
            });
        }
        out
    };
    // monodromy and forcing: W = [Phi c; 0 1]
    let mut w = DMatrix::identity(n + 1, n + 1);
    for (nodes, a) in g.pieces.iter().zip(&exact) {
        w = match a {
            Some(a) => exp_at(a, nodes[nodes.len() - 1] - nodes[0]) * &w,
            None => sweep(nodes, None, &w).pop().unwrap(),
        };
    }
    let phi = w.view((0, 0), (n, n)).clone_owned();
    let c = w.view((0, n), (n, 1)).clone_owned();
    let x0 = (DMatrix::identity(n, n) - &phi).lu().solve(&c).expect("a unique periodic solution");
    let multipliers = eigenvalues(&phi);
    // the periodic solution at every node, piece by piece: (times, z values) per piece
    let d = state_scales(sys);
    let mut xh = DMatrix::from_fn(n + 1, 1, |i, _| if i < n { x0[i] } else { 1.0 });
    let mut state_scale: f64 = 0.0;
    let mut samples: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    // the augmented state [x; 1] at every node, per piece (the starts of the extremes' local refinement)
    let mut node_states: Vec<Vec<DMatrix<f64>>> = Vec::new();
    for (nodes, a) in g.pieces.iter().zip(&exact) {
        let states = sweep(nodes, a.as_ref(), &xh);
        let mut zs = Vec::with_capacity(nodes.len());
        for (j, (&t, st)) in nodes.iter().zip(&states).enumerate() {
            let x: Vec<f64> = (0..n).map(|i| st[(i, 0)]).collect();
            state_scale = x.iter().zip(&d).fold(state_scale, |a, (v, s)| a.max((v / s).abs()));
            let side = if j == 0 { Side::Right } else { Side::Left };
            zs.push(probe_value(sys, &probe, t, side, &x));
        }
        xh = states[states.len() - 1].clone();
        samples.push((nodes.clone(), zs));
        node_states.push(states);
    }
    // the state at the comparison times: from the node at or before each, one exact exponential from the
    // piece's start (constant coefficients) or one RK4 step shorter than the grid's
    let pieces_times = dense_times(sys);
    let mut dense_states = Vec::new();
    for (p, times) in pieces_times.iter().enumerate() {
        let nodes = &g.pieces[p];
        let m = nodes.len() - 1;
        let h = (nodes[m] - nodes[0]) / m as f64;
        for &t in times {
            let j = (((t - nodes[0]) / h).floor().max(0.0) as usize).min(m);
            let start = &node_states[p][j];
            let x = if t <= nodes[j] {
                start.clone()
            } else {
                match &exact[p] {
                    Some(a) => exp_at(a, t - nodes[0]) * &node_states[p][0],
                    None => step(sys, nodes[j], t, start),
                }
            };
            dense_states.extend((0..n).map(|i| x[(i, 0)]));
        }
    }
    let period = sys.period_s();
    let omega = 2.0 * std::f64::consts::PI / period;
    // composite Simpson per piece
    let simpson = |f: &dyn Fn(usize, usize) -> C64| -> C64 {
        let mut total = C64::new(0.0, 0.0);
        for (p, (ts, _)) in samples.iter().enumerate() {
            // the spacing from the piece's length (ts[1] - ts[0] would carry the rounding of ts[0])
            let m = ts.len() - 1;
            let h = (ts[m] - ts[0]) / m as f64;
            for j in 0..=m {
                let wgt = if j == 0 || j == m {
                    1.0
                } else if j % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                total += f(p, j) * (wgt * h / 3.0);
            }
        }
        total / period
    };
    let amplitudes = (0..=case.lines)
        .map(|k| {
            let z = simpson(&|p, j| {
                let (ts, zs) = &samples[p];
                C64::from_polar(zs[j], -(k as f64) * omega * ts[j])
            });
            if k == 0 { z.norm() } else { 2.0 * z.norm() }
        })
        .collect();
    let rms = simpson(&|p, j| C64::new(samples[p].1[j].powi(2), 0.0)).re.sqrt();
    // extremes: the largest nodes (local maxima of sign z, their parabolas' vertices), the best 16 of them
    // re-integrated from the node before to the node after in 64 tiny RK4 steps each, the parabola through
    // the best sub-node and its neighbours (its error, h^3 |z'''| / 64^3, far below the node grid's)
    let extreme = |sign: f64| {
        let vertex = |zs: &[f64], j: usize| {
            let v = sign * zs[j];
            if j == 0 || j + 1 == zs.len() || v < sign * zs[j - 1] || v < sign * zs[j + 1] {
                return v;
            }
            let (a, b, c) = (sign * zs[j - 1], v, sign * zs[j + 1]);
            let curv = a - 2.0 * b + c;
            if curv < 0.0 { b - (c - a).powi(2) / (8.0 * curv) } else { b }
        };
        let mut peaks: Vec<(f64, usize, usize)> = Vec::new();
        for (p, (_, zs)) in samples.iter().enumerate() {
            for j in 0..zs.len() {
                let v = vertex(zs, j);
                let local = (j == 0 || sign * zs[j] >= sign * zs[j - 1])
                    && (j + 1 == zs.len() || sign * zs[j] >= sign * zs[j + 1]);
                if local {
                    peaks.push((v, p, j));
                }
            }
        }
        peaks.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut best = peaks.first().map_or(f64::NEG_INFINITY, |q| q.0);
        for &(_, p, j) in peaks.iter().take(16) {
            let (ts, _) = &samples[p];
            let (lo, hi) = (j.saturating_sub(1), (j + 1).min(ts.len() - 1));
            let sub = 64 * (hi - lo);
            let h = (ts[hi] - ts[lo]) / sub as f64;
            let mut w = node_states[p][lo].clone();
            let mut zsub = Vec::with_capacity(sub + 1);
            for i in 0..=sub {
                let t = ts[lo] + i as f64 * h;
                let side = if i == 0 { Side::Right } else { Side::Left };
                let x: Vec<f64> = (0..n).map(|r| w[(r, 0)]).collect();
                zsub.push(probe_value(sys, &probe, t, side, &x));
                if i < sub {
                    w = step(sys, t, t + h, &w);
                }
            }
            for i in 0..zsub.len() {
                best = best.max(vertex(&zsub, i));
            }
        }
        sign * best
    };
    Reference {
        amplitudes,
        rms,
        max: extreme(1.0),
        min: extreme(-1.0),
        multipliers,
        x0: x0.iter().copied().collect(),
        dense_times: pieces_times.into_iter().flatten().collect(),
        dense_states,
        state_scale,
        floor: Estimates { state: 0.0, monodromy: 0.0, multipliers: 0.0, orders: 0.0, rms: 0.0, peak_to_peak: 0.0 },
    }
}

/// Largest distance from each of `a` to its nearest in `b`.
fn multiplier_distance(a: &[C64], b: &[C64]) -> f64 {
    a.iter().map(|r| b.iter().map(|s| (r - s).norm()).fold(f64::INFINITY, f64::min)).fold(0.0, f64::max)
}

/// True errors of printed values against a reference, in the measures of [`Estimates`]; `states` is the
/// periodic state at the reference's `dense_times` (n per time).
fn errors(
    amplitudes: &[f64],
    rms: f64,
    p2p: f64,
    multipliers: &[C64],
    states: &[f64],
    d: &[f64],
    r: &Reference,
) -> Estimates {
    let top = r.amplitudes.iter().fold(0.0f64, |a, v| a.max(*v)).max(f64::MIN_POSITIVE);
    let lines = amplitudes.iter().zip(&r.amplitudes).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / top;
    let rho_scale = r.multipliers.iter().map(|m| m.norm()).fold(1.0, f64::max);
    // the balanced state z = x / d over the period, relative to the largest |z|
    let n = d.len();
    let state = states
        .iter()
        .zip(&r.dense_states)
        .enumerate()
        .map(|(i, (a, b))| ((a - b) / d[i % n]).abs())
        .fold(0.0, f64::max)
        / r.state_scale.max(f64::MIN_POSITIVE);
    let r_p2p = r.max - r.min;
    let p2p_scale = r_p2p.max(r.max.abs()).max(r.min.abs());
    Estimates {
        state,
        monodromy: f64::NAN,
        multipliers: multiplier_distance(multipliers, &r.multipliers) / rho_scale,
        orders: lines,
        rms: (rms - r.rms).abs() / r.rms.max(f64::MIN_POSITIVE),
        peak_to_peak: (p2p - r_p2p).abs() / p2p_scale.max(f64::MIN_POSITIVE),
    }
}

/// The reference of a case at its resolution and twice it; the floor of each quantity is four times their
/// difference plus 1e-14 (rounding of the reference's sums).
pub fn reference(case: &Case) -> Reference {
    let coarse = reference_at(case, case.reference_steps / 2);
    let mut fine = reference_at(case, case.reference_steps);
    let d = state_scales(case.system());
    let diff = errors(
        &coarse.amplitudes,
        coarse.rms,
        coarse.max - coarse.min,
        &coarse.multipliers,
        &coarse.dense_states,
        &d,
        &fine,
    );
    let f = |v: f64| 4.0 * v + 1e-14;
    fine.floor = Estimates {
        state: f(diff.state),
        monodromy: f64::NAN,
        multipliers: f(diff.multipliers),
        orders: f(diff.orders),
        rms: f(diff.rms),
        peak_to_peak: f(diff.peak_to_peak),
    };
    fine
}

/// What one check measured.
#[derive(Debug)]
pub struct Outcome {
    pub trusted: bool,
    pub method: Method,
    pub truth: Estimates,
    pub estimate: Estimates,
    pub floor: Estimates,
}

impl std::fmt::Display for Outcome {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let row = |name: &str, t: f64, e: f64, fl: f64| format!("{name} true {t:.1e} est {e:.1e} (floor {fl:.0e})");
        write!(
            f,
            "{:?} trusted {}: {}; {}; {}; {}; {}",
            self.method,
            self.trusted,
            row("state", self.truth.state, self.estimate.state, self.floor.state),
            row("rho", self.truth.multipliers, self.estimate.multipliers, self.floor.multipliers),
            if self.floor.orders.is_nan() {
                "lines not compared".to_string()
            } else {
                row("lines", self.truth.orders, self.estimate.orders, self.floor.orders)
            },
            row("rms", self.truth.rms, self.estimate.rms, self.floor.rms),
            row("p2p", self.truth.peak_to_peak, self.estimate.peak_to_peak, self.floor.peak_to_peak),
        )
    }
}

/// Solves `case` with `method` at `tolerance` and holds every printed quantity against `reference`: the
/// estimate bounds the true error (above the reference's floor), and overstates it at most 30x. A refusal
/// (an error, or an untrusted result) passes the upper check: the number is not printed as trusted. Returns
/// `None` when the method rightly refuses the system (harmonic balance on jumps).
pub fn check_periodic_solver(case: &Case, reference: &Reference, method: Method, tolerance: f64) -> Option<Outcome> {
    let sys = case.system();
    let opts = SolverOptions { method, tolerance, ..Default::default() };
    let kmax = |t: f64| case.printed_lines(t);
    let (steady, resp, est): (SteadyState, Response, Estimates) = match solve_response(sys, &opts, &case.probe(), &kmax)
    {
        Ok(r) => r,
        Err(e) if method == Method::Hill && sys.fourier_form().is_none() => {
            assert!(e.to_string().contains("jumps"), "{}: {e}", case.name);
            return None;
        }
        Err(e) => {
            eprintln!("{} {method:?} {tolerance:e}: refused: {e}", case.name);
            return None;
        }
    };
    let d = state_scales(sys);
    let amps: Vec<f64> = resp.amplitudes().into_iter().take(case.lines + 1).collect();
    // the solver's own dense output over the period (t = 0 is the printed x0)
    let mut states = Vec::new();
    steady.states_at(sys, &reference.dense_times, &mut states);
    let truth = errors(&amps, resp.rms, resp.max - resp.min, &steady.floquet.multipliers, &states, &d, reference);
    let mut floor = reference.floor;
    if case.lines == 0 {
        floor.orders = f64::NAN;
    }
    let outcome = Outcome { trusted: steady.trusted, method: steady.method, truth, estimate: est, floor };
    let what = format!("{} with {method:?} at {tolerance:e}: {outcome}", case.name);
    let fl = &reference.floor;
    let mut quantities = vec![
        ("state", truth.state, est.state, fl.state),
        ("multipliers", truth.multipliers, est.multipliers, fl.multipliers),
        ("rms", truth.rms, est.rms, fl.rms),
        ("peak-to-peak", truth.peak_to_peak, est.peak_to_peak, fl.peak_to_peak),
    ];
    if case.lines > 0 {
        quantities.push(("lines", truth.orders, est.orders, fl.orders));
    }
    for (name, t, e, floor) in quantities {
        assert!(t <= e.max(floor), "{what}\n{name}: true error {t:e} above its estimate {e:e}");
        if steady.trusted {
            assert!(e <= 30.0 * t.max(floor), "{what}\n{name}: estimate {e:e} over 30x the true error {t:e}");
            assert!(e <= tolerance, "{what}\n{name}: trusted with an estimate {e:e} above the tolerance");
        }
    }
    eprintln!("{what}");
    Some(outcome)
}
