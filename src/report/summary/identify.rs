//! The result of `identify` (its `--json` object): fitted tooth errors, path gains, per-tooth deviations,
//! the fit's lines and the local fault found.

use crate::model::Quantity;
use crate::model::gear::Gear;
use serde::Serialize;

/// A kind of local tooth fault the search may try.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FaultKind {
    /// A stiffness loss over one tooth's mesh cycle (depth: the fraction lost).
    Crack,
    /// A local profile deviation: a Gaussian bump on one tooth (depth in m).
    Pit,
}

impl FaultKind {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Crack => "crack",
            Self::Pit => "pit",
        }
    }
}

impl std::str::FromStr for FaultKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "crack" => Ok(Self::Crack),
            "pit" => Ok(Self::Pit),
            other => Err(format!("expected crack or pit, got \"{other}\"")),
        }
    }
}

/// Where the angle origin of the measured coefficients comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PhaseOrigin {
    /// A tachometer pulse (rising edge at angle 0): phases and tooth numbers are absolute.
    Tachometer,
    /// The mesh phase alone: phases are relative to an arbitrary origin and tooth numbers to an arbitrary
    /// first tooth.
    Arbitrary,
}

/// A local-fault candidate.
#[derive(Clone, Debug, Serialize)]
pub struct LocalFault {
    /// Pit or crack.
    pub kind: FaultKind,
    /// The gear.
    pub gear: Gear,
    /// Tooth number, 1-based (tooth 1 meshes first after the angle origin).
    pub tooth: usize,
    /// Pit: depth of the profile deviation in m; crack: fraction of mesh stiffness lost.
    pub depth: f64,
    /// Unit of `depth`: "m" or "fraction".
    pub depth_unit: &'static str,
    /// 1 - S_fault / S_healthy: the share of the healthy fit's weighted residual this fault removes.
    pub improvement: f64,
    /// (S_healthy - S_fault) / (S_fault / dof): how far beyond the noise the improvement is.
    pub significance: f64,
    /// True when `significance` is above the significance threshold of `identify` (25).
    pub significant: bool,
}

/// One fitted error harmonic, e(t) contribution = amplitude cos(order w t + phase).
#[derive(Clone, Debug, Serialize)]
pub struct ErrorHarmonic {
    /// Order of the gear's rotation.
    pub order: usize,
    /// Amplitude in m.
    pub amplitude_m: f64,
    /// Phase in rad (absolute with a tachometer, else relative to an arbitrary origin).
    pub phase_rad: f64,
    /// Standard error of the amplitude in m.
    pub amplitude_std_m: f64,
    /// Standard error of the phase in rad.
    pub phase_std_rad: f64,
    /// True when the amplitude stands above three standard errors (else it is not distinguished from 0).
    pub resolved: bool,
}

/// Per-tooth values of each gear, tooth 1 first.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PerTooth {
    /// Pinion teeth.
    pub pinion: Vec<f64>,
    /// Wheel teeth (empty when no wheel order was fitted).
    pub wheel: Vec<f64>,
}

/// A fitted transfer-path gain of one mesh harmonic (measured / model).
#[derive(Clone, Debug, Serialize)]
pub struct PathGain {
    /// Mesh harmonic h.
    pub harmonic: usize,
    /// |G|.
    pub magnitude: f64,
    /// arg G in rad.
    pub phase_rad: f64,
}

/// A line of the fit: measured, model, residual.
#[derive(Clone, Debug, Serialize)]
pub struct FitLine {
    /// Pinion order.
    pub order: f64,
    /// Frequency in Hz at the mean speed.
    pub frequency_hz: f64,
    /// What the line is ("mesh 2", "mesh 1 - pinion 3", "mesh 1 + wheel 1").
    pub label: String,
    /// Measured amplitude, recording unit.
    pub measured: f64,
    /// Fitted model amplitude.
    pub model: f64,
    /// |measured - model|.
    pub residual: f64,
    /// Noise standard error of the measured line.
    pub noise: f64,
}

/// Which gear the angle origin of each is known for.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Origins {
    /// Pinion phases and tooth numbers.
    pub pinion: PhaseOrigin,
    /// Wheel phases and tooth numbers.
    pub wheel: PhaseOrigin,
}

/// The speed the recording ran at.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Speed {
    /// Mean pinion speed, Hz.
    pub mean_hz: f64,
    /// Slowest revolution, Hz.
    pub min_hz: f64,
    /// Fastest revolution, Hz.
    pub max_hz: f64,
    /// The scene's pinion speed, Hz.
    pub scene_hz: f64,
}

/// What `identify` found.
#[derive(Clone, Debug, Serialize)]
pub struct Identification {
    /// Recording file.
    pub recording: String,
    /// Scene file.
    pub scene: String,
    /// Sample rate in Hz.
    pub sample_rate_hz: f64,
    /// What the recording measures, and its unit.
    pub quantity: Quantity,
    /// Unit of the measured amplitudes.
    pub unit: String,
    /// Pinion teeth z1.
    pub pinion_teeth: usize,
    /// Wheel teeth z2.
    pub wheel_teeth: usize,
    /// Speed (the model is solved at the mean).
    pub speed: Speed,
    /// Pinion revolutions per averaged period.
    pub period_revolutions: usize,
    /// Periods averaged.
    pub periods: usize,
    /// Angle origins.
    pub phase_origin: Origins,
    /// Mesh harmonics used.
    pub mesh_harmonics: usize,
    /// Pinion error harmonics.
    pub pinion_errors: Vec<ErrorHarmonic>,
    /// Wheel error harmonics.
    pub wheel_errors: Vec<ErrorHarmonic>,
    /// Profile deviation at each tooth's mesh position (the fitted e of that gear at its centre, plus a
    /// found pit), m.
    pub tooth_deviation_m: PerTooth,
    /// Standard error of each tooth deviation, m.
    pub tooth_deviation_std_m: PerTooth,
    /// Path gains.
    pub path_gains: Vec<PathGain>,
    /// Fraction of the sideband energy the fitted model explains, 1 - sum |Y - Yhat|^2 / sum |Y|^2.
    pub explained_fraction: f64,
    /// Weighted residual over its degrees of freedom: about 1 when the model explains the lines to the noise.
    pub chi2_per_dof: f64,
    /// Condition number of the column-scaled Jacobian.
    pub condition: f64,
    /// False when the parameters are not identifiable (condition above 1e10).
    pub identifiable: bool,
    /// Sideband lines below three noise standard errors.
    pub lines_under_noise: usize,
    /// Lines the fitted model misses by more than three noise standard errors, largest first (at most 12).
    pub residual_lines: Vec<FitLine>,
    /// Every fitted line (for the report).
    #[serde(skip)]
    pub lines: Vec<FitLine>,
    /// The best local fault when it fits better than none beyond the noise, else `None`.
    pub local_fault: Option<LocalFault>,
    /// The best candidate of each kind searched, significant or not.
    pub fault_candidates: Vec<LocalFault>,
    /// Notes and warnings in plain words.
    pub warnings: Vec<String>,
}
