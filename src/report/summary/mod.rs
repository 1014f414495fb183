//! Every JSON contract of DESIGN.md section 5 (stable keys): the results jobs hand to the printer and to
//! the figures.

mod diagnosis;
mod evidence;
mod identify;
mod indicator;
mod machine;
mod speed;
mod verdict;

pub use diagnosis::*;
pub use evidence::*;
pub use identify::*;
pub use indicator::*;
pub use machine::*;
pub use speed::*;
pub use verdict::*;

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

/// Estimated relative error of each printed quantity of `simulate` (the solver's estimates, copied by
/// the simulate job).
#[derive(Serialize, Debug, Clone, Copy, PartialEq)]
pub struct QuantityErrors {
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

/// The curves of a simulation that the images draw and the JSON summary leaves out; the simulate job
/// builds it from the solved scene.
#[derive(Clone, Debug, Default)]
pub struct SimulationSeries {
    /// Output quantity over one period at `period_samples.len()` equally spaced times from 0, output unit.
    pub period_samples: Vec<f64>,
    /// Pinion and wheel teeth when the scene is a gear pair (mesh harmonics and sidebands are then
    /// marked and the spectrum drawn in Hz).
    pub teeth: Option<(usize, usize)>,
    /// The cam press's coordinates over one input revolution (empty for other models).
    pub press: Vec<PressCoordinate>,
}

/// One coordinate of the cam press over one input revolution, with its spectrum by order.
#[derive(Clone, Debug)]
pub struct PressCoordinate {
    /// Name ("q1", "q2").
    pub name: String,
    /// Unit of the values ("rad", "mm").
    pub unit: String,
    /// (time s, value) over one period.
    pub points: Vec<(f64, f64)>,
    /// (order of the input speed, one-sided amplitude) of orders 1, 2, ...
    pub lines: Vec<(f64, f64)>,
}

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

/// Serialises any summary as one line of JSON.
pub fn to_json_line<T: Serialize>(value: &T) -> String {
    // f64 NaN/inf serialise as null in serde_json; our summaries hold finite numbers.
    serde_json::to_string(value).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
}
