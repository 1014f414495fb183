//! Shafts and speed: which shaft, its frequency, where the speed and the teeth came from, how the angle
//! was tracked.

use serde::{Deserialize, Serialize};

/// A shaft of the gear pair, or the shaft of an estimated period when the teeth are not known, or a shaft
/// of a machine file named by its name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Shaft {
    /// The input (pinion) shaft.
    Pinion,
    /// The output (wheel) shaft.
    Wheel,
    /// The shaft whose period was estimated from the signal (teeth unknown).
    Estimated,
    /// A shaft of a machine file (`diagnose --machine`), by its name (interned: see [`Shaft::named`]).
    Named(&'static str),
}

impl Shaft {
    /// The shaft of a machine file called `name`. Names are interned once per process (a machine has a few
    /// shafts, so the table stays small whatever the number of recordings), which keeps `Shaft` a `Copy` key.
    pub fn named(name: &str) -> Self {
        static NAMES: std::sync::Mutex<Vec<&'static str>> = std::sync::Mutex::new(Vec::new());
        let mut names = NAMES.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(n) = names.iter().find(|n| **n == name) {
            return Self::Named(n);
        }
        let n: &'static str = Box::leak(name.to_string().into_boxed_str());
        names.push(n);
        Self::Named(n)
    }

    /// The shaft as a baseline knows it: the shaft of an estimated period is the reference shaft, as the
    /// pinion is when its speed was given or measured (a baseline and a recording whose speeds came
    /// different ways still compare their reference shafts).
    pub fn baseline_key(self) -> Self {
        match self {
            Self::Estimated => Self::Pinion,
            s => s,
        }
    }

    /// The other shaft of the pair: the wheel's for the pinion and the pinion's for the wheel (`None` for
    /// an estimated or a machine's shaft).
    pub fn partner(self) -> Option<Self> {
        match self {
            Self::Pinion => Some(Self::Wheel),
            Self::Wheel => Some(Self::Pinion),
            Self::Estimated | Self::Named(_) => None,
        }
    }

    /// Name shown to people and in the JSON.
    pub fn name(self) -> &'static str {
        match self {
            Self::Pinion => "pinion",
            Self::Wheel => "wheel",
            Self::Estimated => "shaft of the estimated period",
            Self::Named(n) => n,
        }
    }
}

impl Serialize for Shaft {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for Shaft {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        Ok(match name.as_str() {
            "pinion" => Self::Pinion,
            "wheel" => Self::Wheel,
            "shaft of the estimated period" => Self::Estimated,
            other => Self::named(other),
        })
    }
}

impl std::fmt::Display for Shaft {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Shaft frequencies in Hz (`null` when the sample rate is unknown): pinion and wheel when the teeth are
/// known, the pinion alone when its speed was given or measured without the teeth, else the one shaft
/// of the estimated period.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum ShaftHz {
    /// Both shafts of a pair with known teeth.
    Pair {
        /// Pinion (input) shaft, Hz.
        pinion: Option<f64>,
        /// Wheel (output) shaft, Hz.
        wheel: Option<f64>,
    },
    /// The pinion shaft alone: its speed given or from its tachometer, the teeth unknown (so the wheel's
    /// speed is too), Hz.
    Pinion {
        /// Pinion (input) shaft, Hz.
        pinion: Option<f64>,
    },
    /// The shaft of the estimated period, Hz.
    Estimated {
        /// Its frequency, Hz.
        estimated_shaft: Option<f64>,
    },
    /// Every shaft of a machine file, by name, the tracked shaft first, Hz.
    Machine(NamedHz),
}

/// Frequencies of a machine's shafts, in the machine file's order with the tracked shaft first; written as
/// a JSON object keyed by the shafts' names.
#[derive(Clone, Debug, PartialEq)]
pub struct NamedHz(pub Vec<(Shaft, Option<f64>)>);

impl Serialize for NamedHz {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            m.serialize_entry(k.name(), v)?;
        }
        m.end()
    }
}

impl ShaftHz {
    /// The reference shaft's frequency (the pinion, or the estimated shaft), Hz.
    pub fn reference(&self) -> Option<f64> {
        match self {
            Self::Pair { pinion, .. } | Self::Pinion { pinion } => *pinion,
            Self::Estimated { estimated_shaft } => *estimated_shaft,
            Self::Machine(m) => m.0.first().and_then(|s| s.1),
        }
    }
    /// The pinion's frequency when its shaft is known to be the reference, Hz.
    pub fn pinion(&self) -> Option<f64> {
        match self {
            Self::Pair { pinion, .. } | Self::Pinion { pinion } => *pinion,
            Self::Estimated { .. } => None,
            Self::Machine(m) => m.0.first().and_then(|s| s.1),
        }
    }
    /// (shaft, frequency) pairs in display order.
    pub fn entries(&self) -> Vec<(&'static str, Option<f64>)> {
        match self {
            Self::Pair { pinion, wheel } => vec![("pinion", *pinion), ("wheel", *wheel)],
            Self::Pinion { pinion } => vec![("pinion", *pinion)],
            Self::Estimated { estimated_shaft } => vec![("estimated_shaft", *estimated_shaft)],
            Self::Machine(m) => m.0.iter().map(|(s, f)| (s.name(), *f)).collect(),
        }
    }
    /// The shafts in display order.
    pub fn shafts(&self) -> Vec<Shaft> {
        match self {
            Self::Pair { .. } => vec![Shaft::Pinion, Shaft::Wheel],
            Self::Pinion { .. } => vec![Shaft::Pinion],
            Self::Estimated { .. } => vec![Shaft::Estimated],
            Self::Machine(m) => m.0.iter().map(|s| s.0).collect(),
        }
    }
}

/// Where the shaft speed came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SpeedSource {
    /// Given by the user (rpm or Hz).
    Given,
    /// From tachometer pulses.
    Tachometer,
    /// Estimated from the signal's repetition period.
    Estimated,
}

impl SpeedSource {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Given => "given",
            Self::Tachometer => "tachometer",
            Self::Estimated => "estimated",
        }
    }
}

/// How the shaft angle was followed through the recording.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Tracking {
    /// Revolution starts from tachometer pulses, interpolated in between.
    #[serde(rename = "tachometer")]
    Tachometer,
    /// Angle from the unwrapped phase of a mesh harmonic.
    #[serde(rename = "mesh phase")]
    MeshPhase,
    /// Constant speed assumed (tracking was not possible; see the warnings).
    #[serde(rename = "constant speed")]
    Constant,
    /// Angle from the mesh harmonic's phase, its origin (angle 0) at the tachometer's pulses.
    #[serde(rename = "mesh phase, tachometer origin")]
    MeshPhaseTachometerOrigin,
}

impl Tracking {
    /// Whether angle 0 is at the tachometer's pulse (else the origin is arbitrary).
    pub fn tachometer_origin(self) -> bool {
        matches!(self, Self::Tachometer | Self::MeshPhaseTachometerOrigin)
    }

    /// Name shown to people and in the JSON.
    pub fn name(self) -> &'static str {
        match self {
            Self::Tachometer => "tachometer",
            Self::MeshPhase => "mesh phase",
            Self::Constant => "constant speed",
            Self::MeshPhaseTachometerOrigin => "mesh phase, tachometer origin",
        }
    }
}

/// The reference shaft's speed over the recording (per revolution), in Hz (`null` without a sample rate).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SpeedProfile {
    /// How the angle was tracked.
    pub tracking: Tracking,
    /// Mean speed, Hz.
    pub mean_hz: Option<f64>,
    /// Slowest revolution, Hz.
    pub min_hz: Option<f64>,
    /// Fastest revolution, Hz.
    pub max_hz: Option<f64>,
    /// Change from the first tenth of the recording to the last tenth, percent of the mean.
    pub change_percent: f64,
    /// How far the speed wanders within the recording: half the range between the 10th and 90th
    /// percentiles of the revolutions' speeds, percent of the mean.
    pub fluctuation_percent: f64,
    /// With mesh-phase tracking: how far the tracked line stands above its band, dB.
    pub line_snr_db: Option<f64>,
    /// With mesh-phase tracking, when the angle was refined by lining every revolution up with the average
    /// of all of them: the RMS of that average on the refined angle over its RMS on the tracked one (above
    /// 1.02; `null` when the tracked angle was kept).
    pub refined_gain: Option<f64>,
}

/// The gear meshing with the tracked shaft, estimated from its sidebands when the teeth are not given.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OtherGear {
    /// Its teeth.
    pub teeth: usize,
    /// Confidence of the estimate, 0..1 (reported as an estimate from 0.5).
    pub confidence: f64,
    /// Where its +-1 sidebands stand around the mesh harmonics, orders of the tracked shaft (z / teeth).
    pub sideband_orders: f64,
    /// Mean height of those sidebands over their local floor, dB.
    pub line_over_floor_db: f64,
}

/// Where the teeth (mesh order) came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TeethSource {
    /// Given by the user or by the comparison scene.
    Given,
    /// Taken from the baseline recording's estimate.
    Baseline,
    /// Estimated from the TSA spectrum.
    Estimated,
}

impl TeethSource {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Given => "given",
            Self::Baseline => "baseline",
            Self::Estimated => "estimated",
        }
    }
}
