//! The scene file as serde reads it: every field, `deny_unknown_fields`, tagged enums for the choices.
//! Validation into typed model objects is in `validate`.

use super::WavFormat;
use crate::model::gear::Gear;
use crate::solver::Method;
use serde::Deserialize;

/// Which model a scene builds; its object of the same name holds the parameters.
#[derive(Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub(super) enum ModelKind {
    /// `gear_pair`.
    GearPair,
    /// `press`.
    Press,
    /// `ltp`.
    Ltp,
}

impl ModelKind {
    pub(super) fn key(self) -> &'static str {
        match self {
            Self::GearPair => "gear_pair",
            Self::Press => "press",
            Self::Ltp => "ltp",
        }
    }
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScene {
    #[serde(default)]
    pub(super) name: Option<String>,
    /// Free text for people reading the scene; accepted, not used by the program.
    #[serde(default)]
    #[allow(dead_code)]
    pub(super) description: Option<String>,
    pub(super) model: ModelKind,
    #[serde(default)]
    pub(super) gear_pair: Option<RawGearPair>,
    #[serde(default)]
    pub(super) press: Option<RawPress>,
    #[serde(default)]
    pub(super) ltp: Option<RawLtp>,
    #[serde(default)]
    pub(super) solver: RawSolver,
    #[serde(default)]
    pub(super) output: RawOutput,
}

#[derive(Deserialize, Debug, Clone, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSolver {
    #[serde(default)]
    pub(super) method: Option<Method>,
    #[serde(default)]
    pub(super) tolerance: Option<f64>,
    #[serde(default)]
    pub(super) steps: Option<u64>,
    #[serde(default)]
    pub(super) harmonics: Option<u64>,
}

#[derive(Deserialize, Debug, Clone, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawOutput {
    #[serde(default)]
    pub(super) quantity: Option<String>,
    #[serde(default)]
    pub(super) sample_rate_hz: Option<f64>,
    #[serde(default)]
    pub(super) duration_s: Option<f64>,
    #[serde(default)]
    pub(super) max_order: Option<f64>,
    #[serde(default)]
    pub(super) noise_rms: Option<f64>,
    #[serde(default)]
    pub(super) seed: Option<u64>,
    #[serde(default)]
    pub(super) speed_modulation: Option<RawSpeedModulation>,
    #[serde(default)]
    pub(super) speed_drift: Option<RawSpeedDrift>,
    #[serde(default)]
    pub(super) speed_ramp: Option<RawSpeedRamp>,
    #[serde(default)]
    pub(super) tacho: Option<bool>,
    #[serde(default)]
    pub(super) wav_format: Option<WavFormat>,
    #[serde(default)]
    pub(super) full_scale: Option<f64>,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSpeedModulation {
    pub(super) depth: f64,
    pub(super) frequency_hz: f64,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSpeedDrift {
    pub(super) ppm: f64,
    pub(super) time_scale_s: f64,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSpeedRamp {
    pub(super) from: f64,
    pub(super) to: f64,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawHarmonic {
    pub(super) order: u32,
    pub(super) amplitude_m: f64,
    #[serde(default)]
    pub(super) phase_rad: f64,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawToothFault {
    pub(super) tooth: u32,
    pub(super) depth_m: f64,
    #[serde(default = "one")]
    pub(super) width_teeth: f64,
}

pub(super) fn one() -> f64 {
    1.0
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawGear {
    pub(super) teeth: u32,
    pub(super) inertia_kg_m2: f64,
    pub(super) base_radius_m: f64,
    #[serde(default)]
    pub(super) errors: Vec<RawHarmonic>,
    #[serde(default)]
    pub(super) tooth_faults: Vec<RawToothFault>,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawStiffnessHarmonic {
    pub(super) amplitude_n_per_m: f64,
    #[serde(default)]
    pub(super) phase_rad: f64,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub(super) enum RawMesh {
    Fourier {
        mean_n_per_m: f64,
        #[serde(default)]
        harmonics: Vec<RawStiffnessHarmonic>,
    },
    Rectangular {
        contact_ratio: f64,
        pair_stiffness_n_per_m: f64,
    },
    Samples {
        values_n_per_m: Vec<f64>,
    },
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCrack {
    pub(super) gear: Gear,
    pub(super) tooth: u32,
    pub(super) stiffness_loss: f64,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawGearPair {
    pub(super) speed_rpm: f64,
    pub(super) damping_ratio: f64,
    pub(super) static_deflection_m: f64,
    pub(super) pinion: RawGear,
    pub(super) wheel: RawGear,
    pub(super) mesh_stiffness: RawMesh,
    #[serde(default)]
    pub(super) crack: Option<RawCrack>,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPress {
    pub(super) speed_rpm: f64,
    pub(super) torsional_stiffness_n_m_per_rad: f64,
    pub(super) follower_stiffness_n_per_m: f64,
    pub(super) torsional_damping_n_m_s_per_rad: f64,
    pub(super) follower_damping_n_s_per_m: f64,
    pub(super) cam_inertia_kg_m2: f64,
    pub(super) follower_mass_kg: f64,
    pub(super) load_n: f64,
    pub(super) cam_cos_m_per_rad: Vec<f64>,
    #[serde(default)]
    pub(super) cam_sin_m_per_rad: Vec<f64>,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawEntry {
    #[serde(default)]
    pub(super) mean: Option<f64>,
    #[serde(default)]
    pub(super) cos: Vec<f64>,
    #[serde(default)]
    pub(super) sin: Vec<f64>,
    #[serde(default)]
    pub(super) steps: Option<RawSteps>,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSteps {
    pub(super) starts_s: Vec<f64>,
    pub(super) values: Vec<f64>,
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawLtp {
    pub(super) period_s: f64,
    pub(super) mass: Vec<Vec<RawEntry>>,
    pub(super) damping: Vec<Vec<RawEntry>>,
    pub(super) stiffness: Vec<Vec<RawEntry>>,
    pub(super) forcing: Vec<RawEntry>,
}
