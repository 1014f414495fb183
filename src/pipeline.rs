//! Whole jobs built from the layers: simulate a scene (steady state, output over one period, orders).

use crate::Error;
use crate::scene::Scene;
use crate::signal::spectrum::periodic_amplitudes;
use crate::solver::{self, SteadyState};

/// One spectral line of the output quantity.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct OrderLine {
    /// Order: multiple of the scene's base frequency (pinion rotation for the gear pair).
    pub order: f64,
    /// Frequency in Hz.
    pub frequency_hz: f64,
    /// One-sided peak amplitude in the output unit.
    pub amplitude: f64,
}

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
            sys.eval(t.rem_euclid(steady.period_s), crate::model::Side::Right, &mut p, &mut f);
            crate::model::state_derivative(&p, &f, x, &mut xdot);
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
