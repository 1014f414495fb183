//! The simulate and stability jobs: a scene's periodic steady state, its output over one period and order
//! spectrum, its Floquet multipliers; optionally the signal file and the report images.

use super::JobError;
use super::synth::{self, SignalInfo};
use crate::Error;
use crate::report::summary::{OrderLine, SimulateSummary, Simulation, StabilitySummary, to_json_line};
use crate::scene::Scene;
use crate::signal::spectrum::periodic_amplitudes;
use crate::solver::{self, SteadyState};
use std::path::PathBuf;

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
    ["stability limit", "ill-conditioned", "near +1"]
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
    let scene = Scene::load(&job.scene.display().to_string())?;
    if let Some(out) = &job.output {
        synth::check_request(&scene, out, job.allow_aliasing, &mut Vec::new())?;
    }
    let sim = simulate(&scene).map_err(|e| scene_error(&scene, e))?;
    let mut summary = SimulateSummary::new(&scene, &sim);
    if !sim.steady.trusted {
        return Err(JobError::Untrusted {
            file: scene.file.clone(),
            message: format!(
                "periodic solution not printed: it cannot meet solver.tolerance {:.1e} (estimated error {:.2e}, cond(I - Phi) {:.2e}){}",
                scene.solver.tolerance,
                sim.steady.error_estimate,
                sim.steady.cond_i_minus_phi,
                main_reason(&summary.stability.warnings)
            ),
        }
        .into());
    }
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
        report_files = crate::report::figures::simulation(&scene, &sim, dir)?;
        crate::io::write_atomic(&dir.join("simulate.json"), to_json_line(&summary).as_bytes())?;
    }
    Ok(SimulateOutcome { summary, signal, report_files })
}

/// Floquet analysis of a scene: refuses multipliers that cannot meet the scene's tolerance, writes the
/// report.
///
/// # Errors
/// Unreadable or invalid scene, a solver failure, an untrusted result, unwritable outputs.
pub fn stability(job: &StabilityJob) -> Result<StabilityOutcome, Error> {
    let scene = Scene::load(&job.scene.display().to_string())?;
    let steady = solver::solve(scene.system(), &scene.solver).map_err(|e| scene_error(&scene, e))?;
    let summary = StabilitySummary::new(&scene, &steady);
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
    let mut report_files = Vec::new();
    if let Some(dir) = &job.report {
        crate::io::create_dir(dir)?;
        report_files.push(crate::report::figures::multipliers(&scene, &steady, dir)?);
        crate::io::write_atomic(&dir.join("stability.json"), to_json_line(&summary).as_bytes())?;
    }
    Ok(StabilityOutcome { summary, report_files })
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

/// Solves the scene and computes its output over one period and its order spectrum.
///
/// # Errors
/// Solver failures.
pub fn simulate(scene: &Scene) -> Result<Simulation, Error> {
    let sys = scene.system();
    let steady = solver::solve(sys, &scene.solver)?;
    let period = steady.period_s;
    let revs = period * scene.output.base_hz;
    let kmax = (scene.output.max_order * revs + 1e-9).floor() as usize;
    let m = samples_per_period(kmax.max(sys.max_harmonic()));
    let times: Vec<f64> = (0..m).map(|i| period * i as f64 / m as f64).collect();
    let period_samples = output_at(scene, &steady, &times);
    let amps = periodic_amplitudes(&period_samples);
    let orders = (0..=kmax.min(m / 2))
        .map(|k| OrderLine { order: k as f64 / revs, frequency_hz: k as f64 / period, amplitude: amps[k] })
        .collect();
    let rms = (period_samples.iter().map(|v| v * v).sum::<f64>() / m as f64).sqrt();
    let (lo, hi) = period_samples.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    Ok(Simulation { steady, period_samples, orders, rms, peak_to_peak: hi - lo })
}
