//! Every JSON contract of DESIGN.md section 5 (stable keys): the results jobs hand to the printer and to
//! the figures.

mod diagnosis;
mod identify;
mod machine;

pub use diagnosis::*;
pub use identify::*;
pub use machine::*;

use crate::scene::Scene;
use crate::solver::SteadyState;
use serde::Serialize;

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
    /// Estimated error of each printed quantity.
    pub errors: QuantityErrors,
}

/// Estimated relative error of each printed quantity of `simulate`.
pub use crate::solver::response::Estimates as QuantityErrors;

/// One point of a parameter sweep, for the stability map.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SweepPoint {
    /// Parameter value.
    pub value: f64,
    /// |rho|max (`null` when the point failed).
    pub rho_max: Option<f64>,
    /// Asymptotically stable.
    pub stable: Option<bool>,
    /// Result within tolerance.
    pub trusted: bool,
    /// Amplitudes of the first mesh harmonics (or strongest orders) of the output quantity.
    pub lines: Vec<(String, f64)>,
    /// Why the point failed, if it did.
    pub error: Option<String>,
}

/// `gearvib sweep --json`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SweepSummary {
    /// Dotted JSON path of the parameter swept.
    pub param: String,
    /// One entry per value.
    pub points: Vec<SweepPoint>,
    /// Scene name.
    pub scene: String,
    /// Runs of consecutive unstable points, in sweep order.
    pub unstable_ranges: Vec<UnstableRange>,
}

/// A run of consecutive unstable points of a sweep: the parameter from `from` to `to` (both unstable;
/// the boundary lies within one step outside them).
#[derive(Clone, Debug, serde::Serialize)]
pub struct UnstableRange {
    /// First unstable value.
    pub from: f64,
    /// Last unstable value.
    pub to: f64,
    /// Unstable points in the run.
    pub points: usize,
    /// Largest |rho|max in the run.
    pub rho_max: f64,
}

/// The runs of consecutive unstable points of `points` (in their order).
pub fn unstable_ranges(points: &[SweepPoint]) -> Vec<UnstableRange> {
    let mut out: Vec<UnstableRange> = Vec::new();
    let mut open = false;
    for p in points {
        match (p.stable, p.rho_max) {
            (Some(false), Some(r)) => match out.last_mut() {
                Some(last) if open => {
                    last.to = p.value;
                    last.points += 1;
                    last.rho_max = last.rho_max.max(r);
                }
                _ => {
                    out.push(UnstableRange { from: p.value, to: p.value, points: 1, rho_max: r });
                    open = true;
                }
            },
            _ => open = false,
        }
    }
    out
}

/// One measured point.
#[derive(Clone, Debug, Serialize)]
pub struct BenchResult {
    /// Scene name.
    pub scene: String,
    /// "rk4", "hill" or "auto@tol".
    pub method: String,
    /// Steps (rk4) or harmonics (hill).
    pub resolution: usize,
    /// Median wall time of one solve, s.
    pub time_s: f64,
    /// Relative error of the periodic solution against the reference.
    pub error: f64,
}

/// What the errors of one scene are measured against.
#[derive(Clone, Debug, Serialize)]
pub struct Reference {
    /// Scene name.
    pub scene: String,
    /// Reference for rk4 points.
    pub for_rk4: String,
    /// Reference for hill points.
    pub for_hill: String,
}

/// A whole benchmark run.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// Measured points.
    pub results: Vec<BenchResult>,
    /// References used.
    pub references: Vec<Reference>,
}

/// A Floquet multiplier as JSON.
#[derive(Serialize, Debug, Clone, Copy)]
pub struct Multiplier {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
    /// Modulus.
    pub abs: f64,
}

/// `gearvib stability --json`.
#[derive(Serialize, Debug, Clone)]
pub struct StabilitySummary {
    /// Scene name.
    pub scene: String,
    /// Period T in s.
    pub period_s: f64,
    /// Floquet multipliers by decreasing modulus.
    pub multipliers: Vec<Multiplier>,
    /// Floquet exponents ln(rho)/T in 1/s (`null` for rho = 0).
    pub exponents: Vec<Option<[f64; 2]>>,
    /// |rho|max.
    pub rho_max: f64,
    /// |rho|max < 1.
    pub stable: bool,
    /// Method used.
    pub method: String,
    /// Why it was chosen.
    pub method_reason: String,
    /// Resolution used: steps of a step-based method, harmonics for hill (key kept as `steps`).
    pub steps: usize,
    /// "steps" or "harmonics".
    pub resolution_unit: String,
    /// Estimated relative error of what is printed: the larger of the two below.
    pub error_estimate: f64,
    /// Estimated relative error of the periodic solution (balanced state, over the period).
    pub state_error: f64,
    /// Estimated error of the balanced monodromy (2-norm bound relative to max(|Phi|, 1)): bounds the
    /// multipliers' error away from repeated multipliers.
    pub multiplier_error: f64,
    /// Requested tolerance.
    pub tolerance: f64,
    /// Condition number of the periodic problem (I - Phi) x0 = c against errors in Phi, balanced state:
    /// ||(I - Phi)^-1|| max(||Phi||, 1).
    pub cond_i_minus_phi: f64,
    /// Fewest steps above the explicit RK4 stability limit.
    pub stability_limit_steps: usize,
    /// Error estimate within tolerance and I - Phi well conditioned.
    pub trusted: bool,
    /// Warnings in plain words.
    pub warnings: Vec<String>,
    /// What the scene modelled.
    pub notes: Vec<String>,
}

impl StabilitySummary {
    /// Summary of a solved scene.
    pub fn new(scene: &Scene, s: &SteadyState) -> Self {
        Self {
            scene: scene.name.clone(),
            period_s: s.period_s,
            multipliers: s
                .floquet
                .multipliers
                .iter()
                .map(|r| Multiplier { re: r.re, im: r.im, abs: r.norm() })
                .collect(),
            exponents: s.floquet.exponents.iter().map(|e| e.map(|c| [c.re, c.im])).collect(),
            rho_max: s.floquet.rho_max,
            stable: s.floquet.stable,
            method: s.method.name().to_string(),
            method_reason: s.reason.clone(),
            steps: s.resolution,
            resolution_unit: if s.method == crate::solver::Method::Hill { "harmonics" } else { "steps" }.into(),
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
}

/// `gearvib simulate --json`: the stability keys plus the output quantity.
#[derive(Serialize, Debug, Clone)]
pub struct SimulateSummary {
    /// Stability part.
    #[serde(flatten)]
    pub stability: StabilitySummary,
    /// Output quantity name.
    pub quantity: String,
    /// Its unit.
    pub unit: String,
    /// Base frequency of the orders in Hz.
    pub base_hz: f64,
    /// What the base frequency is.
    pub base: String,
    /// One-sided amplitude spectrum over one period, by order.
    pub orders: Vec<OrderLine>,
    /// RMS over one period.
    pub rms: f64,
    /// Peak-to-peak over one period.
    pub peak_to_peak: f64,
    /// Estimated relative error of each printed quantity.
    pub errors: QuantityErrors,
    /// Written signal file, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub signal_file: Option<String>,
}

impl SimulateSummary {
    /// Summary of a simulation.
    pub fn new(scene: &Scene, sim: &Simulation) -> Self {
        Self {
            stability: StabilitySummary::new(scene, &sim.steady),
            quantity: scene.output.quantity.name().to_string(),
            unit: scene.output.quantity.unit().to_string(),
            base_hz: scene.output.base_hz,
            base: scene.output.base_name.clone(),
            orders: sim.orders.clone(),
            rms: sim.rms,
            peak_to_peak: sim.peak_to_peak,
            errors: sim.errors,
            signal_file: None,
        }
    }
}

/// Serialises any summary as one line of JSON.
pub fn to_json_line<T: Serialize>(value: &T) -> String {
    // f64 NaN/inf serialise as null in serde_json; our summaries hold finite numbers.
    serde_json::to_string(value).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
}
