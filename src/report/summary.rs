//! JSON summaries with the stable keys of DESIGN.md section 5.

use crate::pipeline::{OrderLine, Simulation};
use crate::scene::Scene;
use crate::solver::SteadyState;
use serde::Serialize;

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
#[derive(Serialize, Debug)]
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
    /// Estimated relative error.
    pub error_estimate: f64,
    /// Requested tolerance.
    pub tolerance: f64,
    /// Condition number of I - Phi.
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
            method: s.method.to_string(),
            method_reason: s.reason.clone(),
            steps: s.resolution,
            resolution_unit: if s.method == "hill" { "harmonics" } else { "steps" }.into(),
            error_estimate: s.error_estimate,
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
#[derive(Serialize, Debug)]
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
            signal_file: None,
        }
    }
}

/// Serialises any summary as one line of JSON.
pub fn to_json_line<T: Serialize>(value: &T) -> String {
    // f64 NaN/inf serialise as null in serde_json; our summaries hold finite numbers.
    serde_json::to_string(value).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
}
