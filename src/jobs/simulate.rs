//! The simulate and stability jobs: a scene's periodic steady state, its output over one period and order
//! spectrum, its Floquet multipliers; optionally the signal file and the report images.

use super::JobError;
use super::synth::{self, SignalInfo};
use crate::Error;
use crate::model::OutputQuantity;
use crate::report::summary::{
    Multiplier, OrderLine, PressCoordinate, QuantityErrors, SimulateSummary, SimulationSeries, StabilitySummary,
    to_json_line,
};
use crate::scene::{Model, Scene};
use crate::signal::spectrum::Fft;
use crate::solver::hill::HillSolution;
use crate::solver::response::{self, Probe};
use crate::solver::{self, SteadyState, Trajectory};
use nalgebra::Complex;
use std::path::PathBuf;

/// Result of simulating a scene.
#[derive(Clone, Debug)]
pub struct Simulation {
    /// Steady state and Floquet analysis.
    pub steady: SteadyState,
    /// Output quantity over one period at `period_samples.len()` equally spaced times from 0.
    pub period_samples: Vec<f64>,
    /// Lines up to the scene's `max_order`, every harmonic of 1/T.
    pub orders: Vec<OrderLine>,
    /// RMS over one period (includes the mean), output unit.
    pub rms: f64,
    /// Peak-to-peak over one period, output unit.
    pub peak_to_peak: f64,
    /// Estimated error of each printed quantity.
    pub errors: response::Estimates,
}

/// One `simulate` call.
#[derive(Clone, Debug)]
pub struct SimulateJob {
    /// Scene file.
    pub scene: PathBuf,
    /// Signal file to write (.wav or .csv) with its sidecar.
    pub output: Option<PathBuf>,
    /// Write even when the sample rate is below twice the highest line requested (then warns).
    pub allow_aliasing: bool,
    /// Directory for the images and `simulate.json`.
    pub report: Option<PathBuf>,
}

/// What [`run`] produced.
#[derive(Clone, Debug)]
pub struct SimulateOutcome {
    /// The JSON summary (`simulate --json`).
    pub summary: SimulateSummary,
    /// What the signal file holds, when one was written.
    pub signal: Option<SignalInfo>,
    /// Report files written.
    pub report_files: Vec<PathBuf>,
}

/// One `stability` call.
#[derive(Clone, Debug)]
pub struct StabilityJob {
    /// Scene file.
    pub scene: PathBuf,
    /// Directory for the multiplier image and `stability.json`.
    pub report: Option<PathBuf>,
}

/// What [`stability`] produced.
#[derive(Clone, Debug)]
pub struct StabilityOutcome {
    /// The JSON summary (`stability --json`).
    pub summary: StabilitySummary,
    /// Report files written.
    pub report_files: Vec<PathBuf>,
}

/// The warning that explains a refusal best (stability limit, then conditioning).
fn main_reason(warnings: &[String]) -> String {
    ["stability limit", "ill-conditioned", "near +1", "extreme search"]
        .iter()
        .find_map(|k| warnings.iter().find(|w| w.contains(k)))
        .map_or(String::new(), |w| format!("; {w}"))
}

fn scene_error(scene: &Scene, e: impl std::fmt::Display) -> Error {
    JobError::Input { file: scene.file.clone(), message: e.to_string() }.into()
}

/// Simulates a scene: refuses a bad signal request before computing, solves, refuses a periodic solution
/// that cannot meet the scene's tolerance, writes the signal and the report.
///
/// # Errors
/// Unreadable or invalid scene, a solver failure, an untrusted result, unwritable outputs.
pub fn run(job: &SimulateJob) -> Result<SimulateOutcome, Error> {
    crate::io::begin_run();
    let scene = Scene::load(&job.scene.display().to_string())?;
    if let Some(out) = &job.output {
        synth::check_request(&scene, out, job.allow_aliasing, &mut Vec::new())?;
    }
    let (sim, mut summary) = summarize(&scene)?;
    let signal = match &job.output {
        Some(out) => {
            let info = synth::write_signal(&scene, &sim, out, job.allow_aliasing)?;
            summary.signal_file = Some(info.file.clone());
            Some(info)
        }
        None => None,
    };
    let mut report_files = Vec::new();
    if let Some(dir) = &job.report {
        crate::io::create_dir(dir)?;
        crate::io::check_output(&dir.join("simulate.json"))?;
        report_files = crate::report::figures::simulation(&summary, &series(&scene, &sim), dir)?;
        crate::io::write_atomic(&dir.join("simulate.json"), to_json_line(&summary).as_bytes())?;
        let section = crate::report::html::simulation_section(&summary, &report_files);
        report_files.push(crate::report::html::write(dir, &format!("gearvib simulation: {}", scene.name), &[section])?);
    }
    Ok(SimulateOutcome { summary, signal, report_files })
}

/// Simulates a loaded scene and builds its `simulate --json` summary; refuses a periodic solution that
/// cannot meet the scene's tolerance.
///
/// # Errors
/// A solver failure or an untrusted result.
pub fn summarize(scene: &Scene) -> Result<(Simulation, SimulateSummary), Error> {
    let sim = simulate(scene).map_err(|e| scene_error(scene, e))?;
    let summary = simulate_summary(scene, &sim);
    if !sim.steady.trusted {
        return Err(JobError::Untrusted {
            file: scene.file.clone(),
            message: format!(
                "periodic solution not printed: it cannot meet solver.tolerance {:.1e} (estimated error {:.2e}, conditioning {:.2e}){}",
                scene.solver.tolerance,
                sim.steady.error_estimate,
                sim.steady.cond_i_minus_phi,
                main_reason(&summary.stability.warnings)
            ),
        }
        .into());
    }
    Ok((sim, summary))
}

/// Floquet analysis of a loaded scene and its `stability --json` summary; refuses multipliers that cannot
/// meet the scene's tolerance.
///
/// # Errors
/// A solver failure or untrusted multipliers.
pub fn stability_of(scene: &Scene) -> Result<(SteadyState, StabilitySummary), Error> {
    let steady = solver::solve(scene.system(), &scene.solver).map_err(|e| scene_error(scene, e))?;
    let summary = stability_summary(scene, &steady);
    if steady.error_estimate > scene.solver.tolerance {
        return Err(JobError::Untrusted {
            file: scene.file.clone(),
            message: format!(
                "multipliers not trusted: estimated error {:.2e} is above solver.tolerance {:.1e}{}",
                steady.error_estimate,
                scene.solver.tolerance,
                main_reason(&summary.warnings)
            ),
        }
        .into());
    }
    Ok((steady, summary))
}

/// Floquet analysis of a scene: refuses multipliers that cannot meet the scene's tolerance, writes the
/// report.
///
/// # Errors
/// Unreadable or invalid scene, a solver failure, an untrusted result, unwritable outputs.
pub fn stability(job: &StabilityJob) -> Result<StabilityOutcome, Error> {
    crate::io::begin_run();
    let scene = Scene::load(&job.scene.display().to_string())?;
    let (_, summary) = stability_of(&scene)?;
    let mut report_files = Vec::new();
    if let Some(dir) = &job.report {
        crate::io::create_dir(dir)?;
        crate::io::check_output(&dir.join("stability.json"))?;
        report_files.push(crate::report::figures::multipliers(&summary, dir)?);
        crate::io::write_atomic(&dir.join("stability.json"), to_json_line(&summary).as_bytes())?;
        let section = crate::report::html::stability_section(&summary, &report_files);
        report_files.push(crate::report::html::write(dir, &format!("gearvib stability: {}", scene.name), &[section])?);
    }
    Ok(StabilityOutcome { summary, report_files })
}

/// The `stability --json` summary of a solved scene.
pub fn stability_summary(scene: &Scene, s: &SteadyState) -> StabilitySummary {
    StabilitySummary {
        scene: scene.name.clone(),
        period_s: s.period_s,
        multipliers: s.floquet.multipliers.iter().map(|r| Multiplier { re: r.re, im: r.im, abs: r.norm() }).collect(),
        exponents: s.floquet.exponents.iter().map(|e| e.map(|c| [c.re, c.im])).collect(),
        rho_max: s.floquet.rho_max,
        stable: s.floquet.stable,
        method: s.method.name().to_string(),
        method_reason: s.reason.clone(),
        steps: s.resolution,
        resolution_unit: if s.method == solver::Method::Hill { "harmonics" } else { "steps" }.into(),
        error_estimate: s.error_estimate,
        state_error: s.state_error,
        multiplier_error: s.multiplier_error,
        tolerance: scene.solver.tolerance,
        cond_i_minus_phi: s.cond_i_minus_phi,
        stability_limit_steps: s.stability_limit_steps,
        trusted: s.trusted,
        warnings: s.warnings.clone(),
        notes: scene.notes.clone(),
    }
}

/// The `simulate --json` summary of a simulated scene (no signal file yet).
pub fn simulate_summary(scene: &Scene, sim: &Simulation) -> SimulateSummary {
    let e = &sim.errors;
    SimulateSummary {
        stability: stability_summary(scene, &sim.steady),
        quantity: scene.output.quantity.name().to_string(),
        unit: scene.output.quantity.unit().to_string(),
        base_hz: scene.output.base_hz,
        base: scene.output.base_name.clone(),
        orders: sim.orders.clone(),
        rms: sim.rms,
        peak_to_peak: sim.peak_to_peak,
        errors: QuantityErrors {
            state: e.state,
            monodromy: e.monodromy,
            multipliers: e.multipliers,
            orders: e.orders,
            rms: e.rms,
            peak_to_peak: e.peak_to_peak,
        },
        signal_file: None,
    }
}

/// The curves the simulate images draw besides the summary: the output over one period, the teeth of a
/// gear pair, the press's coordinates.
pub fn series(scene: &Scene, sim: &Simulation) -> SimulationSeries {
    let teeth = match &scene.model {
        Model::GearPair(g) => Some((g.params().pinion_teeth, g.params().wheel_teeth)),
        _ => None,
    };
    let press = match &scene.model {
        Model::Press(..) => press_coordinates(scene, &sim.steady),
        _ => Vec::new(),
    };
    SimulationSeries { period_samples: sim.period_samples.clone(), teeth, press }
}

/// The cam press's q1 (rad) and q2 (mm) over one input revolution (721 points) and their first 24 orders
/// (one-sided amplitudes from 1024 samples over the period; floored at 1e-12 for the log axis).
fn press_coordinates(scene: &Scene, steady: &SteadyState) -> Vec<PressCoordinate> {
    let sys = scene.system();
    let period = steady.period_s;
    let m = 720;
    let times: Vec<f64> = (0..=m).map(|i| period * i as f64 / m as f64).collect();
    let mut states = Vec::new();
    steady.states_at(sys, &times, &mut states);
    let samples: Vec<f64> = (0..1024).map(|i| i as f64 * period / 1024.0).collect();
    let mut sampled = Vec::new();
    steady.states_at(sys, &samples, &mut sampled);
    let n = sys.dim();
    [(0usize, "q1", "rad", 1.0), (1, "q2", "mm", 1e3)]
        .into_iter()
        .map(|(idx, name, unit, scale)| {
            let points = times.iter().enumerate().map(|(i, t)| (*t, states[i * n + idx] * scale)).collect();
            let x: Vec<f64> = (0..1024).map(|i| sampled[i * n + idx] * scale).collect();
            let amps = crate::signal::spectrum::periodic_amplitudes(&x);
            let lines = amps.iter().enumerate().skip(1).take(24).map(|(k, a)| (k as f64, a.max(1e-12))).collect();
            PressCoordinate { name: name.into(), unit: unit.into(), points, lines }
        })
        .collect()
}

/// Number of samples per period used for the orders: a power of two with at least 8 samples per period of
/// the highest listed harmonic and of the coefficients' highest harmonic.
pub fn samples_per_period(highest_harmonic: usize) -> usize {
    (8 * highest_harmonic).max(1024).next_power_of_two().min(1 << 22)
}

/// Output quantity of `scene` at the given times (s) from a solved steady state.
pub fn output_at(scene: &Scene, steady: &SteadyState, times: &[f64]) -> Vec<f64> {
    let sys = scene.system();
    let n = sys.dim();
    let q = &scene.output.quantity;
    let mut states = Vec::new();
    steady.states_at(sys, times, &mut states);
    let mut out = Vec::with_capacity(times.len());
    let (mut p, mut f) = (nalgebra::DMatrix::zeros(n, n), nalgebra::DVector::zeros(n));
    let mut xdot = vec![0.0; n];
    for (i, &t) in times.iter().enumerate() {
        let x = &states[i * n..(i + 1) * n];
        if q.needs_derivative() {
            sys.eval(t.rem_euclid(steady.period_s), crate::system::Side::Right, &mut p, &mut f);
            crate::system::state_derivative(&p, &f, x, &mut xdot);
        }
        out.push(q.value(x, &xdot));
    }
    out
}

/// Complex Fourier coefficients Z_k, k = 0..=kmax, of the output quantity from a harmonic-balance
/// solution: exact (z(t) = Re Z_0 + 2 Re sum Z_k e^{i k w t}); a derivative output is i k w times the
/// coefficient of its state component.
fn fourier_output(q: &OutputQuantity, sol: &HillSolution, kmax: usize) -> Vec<Complex<f64>> {
    (0..=kmax)
        .map(|k| match q {
            OutputQuantity::Linear { weights, .. } => {
                weights.iter().enumerate().map(|(c, w)| sol.coefficient(c, k) * *w).sum()
            }
            OutputQuantity::Derivative { index, .. } => {
                sol.coefficient(*index, k) * Complex::new(0.0, k as f64 * sol.omega)
            }
        })
        .collect()
}

/// Values and time derivatives of the output at `m` equally spaced times of one period of a
/// harmonic-balance solution (m a power of two): two inverse FFTs of its exact coefficients Z_k and
/// i k w Z_k (k <= min(H, m / 2)), O(m log m) where evaluating the series point by point costs O(m H).
pub(super) fn fourier_table(q: &OutputQuantity, sol: &HillSolution, m: usize) -> (Vec<f64>, Vec<f64>) {
    let z = fourier_output(q, sol, sol.harmonics.min(m / 2));
    let dz: Vec<Complex<f64>> =
        z.iter().enumerate().map(|(k, c)| c * Complex::new(0.0, k as f64 * sol.omega)).collect();
    (samples_from(&z, m), samples_from(&dz, m))
}

/// Fourier coefficients Z_c(k), k = 0..=kmax, of the state components c in `components` (in that order) of
/// a time-stepped solution (x_c(t) = Re Z_c(0) + 2 Re sum Z_c(k) e^{i k w t}) by Gauss-Legendre quadrature (4 points) on every step
/// of the solver's own grid, so jumps of the coefficients (and kinks of the state) sit on step ends and the
/// integrals keep the solver's fourth order. `None` for a harmonic-balance solution (its coefficients are
/// exact already).
pub fn grid_coefficients(
    sys: &dyn crate::system::PeriodicSystem,
    steady: &SteadyState,
    kmax: usize,
    components: &[usize],
) -> Option<Vec<Vec<Complex<f64>>>> {
    let Trajectory::Grid { grid, .. } = &steady.trajectory else { return None };
    const NODES: [f64; 4] =
        [-0.861_136_311_594_052_6, -0.339_981_043_584_856_3, 0.339_981_043_584_856_3, 0.861_136_311_594_052_6];
    const WEIGHTS: [f64; 4] =
        [0.347_854_845_137_453_9, 0.652_145_154_862_546_1, 0.652_145_154_862_546_1, 0.347_854_845_137_453_9];
    let mut times = Vec::with_capacity(4 * grid.steps());
    let mut weights = Vec::with_capacity(4 * grid.steps());
    for w in grid.nodes.windows(2) {
        let (mid, half) = (0.5 * (w[0] + w[1]), 0.5 * (w[1] - w[0]));
        for (x, g) in NODES.iter().zip(WEIGHTS) {
            times.push(mid + half * x);
            weights.push(half * g);
        }
    }
    let n = sys.dim();
    let mut states = Vec::new();
    steady.states_at(sys, &times, &mut states);
    let period = steady.period_s;
    let w0 = 2.0 * std::f64::consts::PI / period;
    // harmonic by harmonic over all points (each point's e^{-i k w t} advanced by one multiplication): the
    // points are independent, so the loop runs at the multipliers' throughput, not their latency
    let steps: Vec<Complex<f64>> = times
        .iter()
        .map(|t| {
            let (s, c) = (w0 * t).sin_cos();
            Complex::new(c, -s)
        })
        .collect();
    let mut z = Vec::with_capacity(components.len());
    for &comp in components {
        let mut e: Vec<Complex<f64>> =
            (0..times.len()).map(|i| Complex::new(weights[i] * states[i * n + comp] / period, 0.0)).collect();
        let mut zc = Vec::with_capacity(kmax + 1);
        for _ in 0..=kmax {
            zc.push(e.iter().sum::<Complex<f64>>());
            e.iter_mut().zip(&steps).for_each(|(v, s)| *v *= s);
        }
        z.push(zc);
    }
    Some(z)
}

/// Samples of z(t) at m equally spaced times of one period from its coefficients (inverse FFT).
fn samples_from(z: &[Complex<f64>], m: usize) -> Vec<f64> {
    let spec: Vec<(f64, f64)> =
        (0..=m / 2).map(|k| z.get(k).map_or((0.0, 0.0), |c| (c.re * m as f64, c.im * m as f64))).collect();
    Fft::new().inverse(&spec, m)
}

/// The output quantity as a solver probe (a linear function of x or of x').
pub fn probe(q: &OutputQuantity, n: usize) -> Probe {
    match q {
        OutputQuantity::Linear { weights, .. } => Probe { weights: weights.clone(), derivative: false },
        OutputQuantity::Derivative { index, .. } => {
            Probe { weights: (0..n).map(|i| if i == *index { 1.0 } else { 0.0 }).collect(), derivative: true }
        }
    }
}

/// Highest line index of a scene over the period `period_s`.
fn highest_line(scene: &Scene, period_s: f64) -> usize {
    (scene.output.max_order * period_s * scene.output.base_hz + 1e-9).floor() as usize
}

/// Output samples over one period at m equally spaced times (for the signal and the figures).
fn period_table(scene: &Scene, steady: &SteadyState, kmax: usize) -> Vec<f64> {
    let sys = scene.system();
    let period = steady.period_s;
    match &steady.trajectory {
        Trajectory::Fourier(sol) => {
            let m = samples_per_period(kmax.max(sys.max_harmonic()).max(sol.harmonics / 4));
            let z = fourier_output(&scene.output.quantity, sol, sol.harmonics.min(m / 2).max(kmax));
            samples_from(&z, m)
        }
        Trajectory::Grid { .. } => {
            let m = samples_per_period(kmax.max(sys.max_harmonic()));
            let times: Vec<f64> = (0..m).map(|i| period * i as f64 / m as f64).collect();
            output_at(scene, steady, &times)
        }
    }
}

/// The steady state and the order spectrum of [`simulate`] (the same lines), without the second solution's
/// estimates or the samples over a period (the middle value is empty): what a sweep needs.
///
/// # Errors
/// Solver failures.
pub fn solve_with_orders(scene: &Scene) -> Result<(SteadyState, Vec<f64>, Vec<OrderLine>), Error> {
    // one response of the printed solution (a sweep prints lines and trust, not their estimates)
    let sys = scene.system();
    let steady = solver::solve(sys, &scene.solver)?;
    let period = steady.period_s;
    let kmax = highest_line(scene, period);
    let d = solver::steady::state_scales(sys);
    let probe = probe(&scene.output.quantity, sys.dim());
    let resp = response::response(sys, &steady.trajectory, period, &probe, kmax, &d, scene.solver.tolerance);
    let revs = period * scene.output.base_hz;
    let amps = resp.amplitudes();
    let orders = (0..=kmax)
        .map(|k| OrderLine { order: k as f64 / revs, frequency_hz: k as f64 / period, amplitude: amps[k] })
        .collect();
    Ok((steady, Vec::new(), orders))
}

/// Solves the scene and computes its output over one period, its order spectrum, RMS and peak-to-peak.
///
/// Every printed number comes from the solution itself, not from samples of it: the exact Fourier
/// coefficients of harmonic balance, exact integrals over the pieces of piecewise-constant coefficients,
/// or quadrature fine enough for the highest line on the dense output of a time-stepping method
/// ([`response::response`]); extremes from a global search refined on the solution. Each has its own
/// error estimate ([`response::Estimates`]), folded into `error_estimate` and the trust.
///
/// # Errors
/// Solver failures.
pub fn simulate(scene: &Scene) -> Result<Simulation, Error> {
    let sys = scene.system();
    let probe = probe(&scene.output.quantity, sys.dim());
    let kmax = |period_s: f64| highest_line(scene, period_s);
    let (steady, resp, errors) = response::solve_response(sys, &scene.solver, &probe, &kmax)?;
    let period = steady.period_s;
    let revs = period * scene.output.base_hz;
    let kmax = highest_line(scene, period);
    let period_samples = period_table(scene, &steady, kmax);
    let amps = resp.amplitudes();
    let orders = (0..=kmax)
        .map(|k| OrderLine { order: k as f64 / revs, frequency_hz: k as f64 / period, amplitude: amps[k] })
        .collect();
    Ok(Simulation { steady, period_samples, orders, rms: resp.rms, peak_to_peak: resp.max - resp.min, errors })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::system::Side;

    /// The inverse-FFT table of a harmonic-balance output against the slow path it replaced: the state
    /// summed harmonic by harmonic at each time, and the slope from the equation of motion x' = P x + f at
    /// that state (not the series' derivative), on the bundled healthy gear pair (dq/dt output).
    #[test]
    fn the_fourier_table_matches_the_solution_evaluated_point_by_point() {
        let scene = Scene::load(concat!(env!("CARGO_MANIFEST_DIR"), "/data/scenes/gear-z14z39-healthy.json")).unwrap();
        let sim = simulate(&scene).unwrap();
        let Trajectory::Fourier(sol) = &sim.steady.trajectory else { panic!("expected harmonic balance") };
        let OutputQuantity::Linear { weights, .. } = &scene.output.quantity else { panic!("linear output") };
        let m = 1024;
        let (values, slopes) = fourier_table(&scene.output.quantity, sol, m);
        let sys = scene.system();
        let n = sys.dim();
        let (mut p, mut f) = (nalgebra::DMatrix::zeros(n, n), nalgebra::DVector::zeros(n));
        let (mut x, mut xdot) = (vec![0.0; n], vec![0.0; n]);
        let (mut dv, mut ds, mut top_v, mut top_s) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for i in 0..m {
            let t = sim.steady.period_s * i as f64 / m as f64;
            sol.state(t, &mut x);
            sys.eval(t, Side::Right, &mut p, &mut f);
            crate::system::state_derivative(&p, &f, &x, &mut xdot);
            let v: f64 = weights.iter().zip(&x).map(|(w, a)| w * a).sum();
            let s: f64 = weights.iter().zip(&xdot).map(|(w, a)| w * a).sum();
            (dv, ds) = (dv.max((v - values[i]).abs()), ds.max((s - slopes[i]).abs()));
            (top_v, top_s) = (top_v.max(v.abs()), top_s.max(s.abs()));
        }
        // the values are one series summed two ways: rounding of 367 terms, far below 1e-12 relative
        assert!(dv <= 1e-12 * top_v, "values {dv:e} of {top_v:e}");
        // the slope of the truncated series against the equation's: the harmonic-balance residual, which
        // the solver's error estimate bounds relative to the solution (a few 1e-11 here); 1e-7 is the scene's
        // tolerance, far above it, and a lost i k w factor or a sign would be of order 1
        assert!(ds <= 1e-7 * top_s, "slopes {ds:e} of {top_s:e}");
    }
}
