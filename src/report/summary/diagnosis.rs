//! The diagnosis of one recording (`diagnose --json`, one object per recording).

use crate::signal::Spectrum;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

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

/// How the spectrum image shows its levels (`diagnose --spectrum`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SpectrumScale {
    /// Amplitude of each line (Hann window, amplitude-corrected, averaged) on a log axis, signal unit.
    #[default]
    Amplitude,
    /// The same amplitude as 20 log10(A / 1 unit), dB re 1 unit, on a linear axis.
    Db,
    /// Power spectral density, unit^2/Hz (one-sided, Welch): the amplitude times the Hann window's factor
    /// [`crate::signal::spectrum::hann_psd_per_amplitude2`], so that its integral is the signal's variance.
    Psd,
}

impl SpectrumScale {
    /// The scale named `amplitude`, `db` or `psd`.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "amplitude" => Some(Self::Amplitude),
            "db" => Some(Self::Db),
            "psd" => Some(Self::Psd),
            _ => None,
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

/// Condition of a recording.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum VerdictState {
    /// The recording could not be scored (no comparable block, an indicator that is not a number, a gear
    /// the baseline does not hold): never taken for healthy. Lowest in the order, so that any gear that
    /// could be judged and shows a fault decides.
    NotJudged,
    /// No indicator beyond its limit.
    Healthy,
    /// One indicator beyond its first limit.
    Suspect,
    /// An indicator beyond its second limit, or several beyond their first.
    Faulty,
}

impl VerdictState {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::NotJudged => "not judged",
            Self::Healthy => "healthy",
            Self::Suspect => "suspect",
            Self::Faulty => "faulty",
        }
    }
}

/// The gear a verdict concerns.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum VerdictGear {
    /// The pinion.
    #[serde(rename = "pinion")]
    Pinion,
    /// The wheel.
    #[serde(rename = "wheel")]
    Wheel,
    /// The teeth were not given, so the gear cannot be named.
    #[serde(rename = "unknown (teeth not given)")]
    Unknown,
    /// No gear (healthy).
    #[serde(rename = "none")]
    None,
    /// The sun of a planetary stage (`diagnose --machine`).
    #[serde(rename = "sun")]
    Sun,
    /// A planet of a planetary stage (which one: `Verdict::planet`).
    #[serde(rename = "planet")]
    Planet,
    /// The ring of a planetary stage.
    #[serde(rename = "ring")]
    Ring,
}

impl VerdictGear {
    /// Name shown to people and in the JSON.
    pub fn name(self) -> &'static str {
        match self {
            Self::Pinion => "pinion",
            Self::Wheel => "wheel",
            Self::Unknown => "unknown (teeth not given)",
            Self::None => "none",
            Self::Sun => "sun",
            Self::Planet => "planet",
            Self::Ring => "ring",
        }
    }
}

impl From<Shaft> for VerdictGear {
    fn from(s: Shaft) -> Self {
        match s {
            Shaft::Pinion => Self::Pinion,
            Shaft::Wheel => Self::Wheel,
            Shaft::Estimated | Shaft::Named(_) => Self::Unknown,
        }
    }
}

/// A sideband line.
#[derive(Clone, Debug, Serialize)]
pub struct Sideband {
    /// Offset in shaft orders (negative below the mesh line).
    pub offset: i32,
    /// Shaft whose sideband this is.
    pub shaft: Shaft,
    /// Frequency in Hz (`null` when the sample rate is unknown).
    pub frequency_hz: Option<f64>,
    /// Order of the reference shaft.
    pub order: f64,
    /// Peak amplitude.
    pub amplitude: f64,
    /// False when a line of the other shaft (or the mesh line) lies within three spectral bins: the Hann
    /// main lobe then mixes them and the amplitude cannot be attributed to this shaft.
    pub resolved: bool,
}

/// A mesh harmonic with its sidebands.
#[derive(Clone, Debug, Serialize)]
pub struct MeshHarmonic {
    /// Harmonic number.
    pub k: usize,
    /// Frequency in Hz (`null` when unknown).
    pub frequency_hz: Option<f64>,
    /// Order of the reference shaft.
    pub order: f64,
    /// Peak amplitude.
    pub amplitude: f64,
    /// Sidebands labelled by shaft.
    pub sidebands: Vec<Sideband>,
}

/// Indicators of one gear on one channel.
#[derive(Clone, Debug, Serialize)]
pub struct GearIndicators {
    /// The gear's shaft.
    pub gear: Shaft,
    /// 1-based channel.
    pub channel: usize,
    /// Mesh order of this gear's shaft (its teeth).
    pub mesh_order: usize,
    /// Revolutions averaged in the TSA.
    pub revolutions: usize,
    /// Indicators keyed by lower-case name.
    pub indicators: BTreeMap<String, f64>,
    /// Residual signal (TSA without shaft and mesh lines) over one revolution.
    #[serde(skip)]
    pub residual: Vec<f64>,
    /// Difference signal (the residual without the first-order sidebands) over one revolution.
    #[serde(skip)]
    pub difference: Vec<f64>,
    /// One-sided amplitude spectrum of the TSA, by order of this shaft.
    #[serde(skip)]
    pub tsa_amplitudes: Vec<f64>,
    /// TSA over one revolution, resampled to a power of two.
    #[serde(skip)]
    pub tsa: Vec<f64>,
    /// The same indicators on consecutive blocks of whole revolutions (for the statistical baseline).
    #[serde(skip)]
    pub blocks: Vec<Block>,
}

/// Indicators of one block of whole revolutions of one gear on one channel.
#[derive(Clone, Debug, Default)]
pub struct Block {
    /// Indicators keyed by lower-case name, plus `residual_m2` and `residual_m4` (second and fourth
    /// central moments of the residual signal, for NA4*).
    pub indicators: BTreeMap<String, f64>,
    /// TSA amplitude by order 0..=K (K about 3.5 mesh harmonics), for the spectral-change indicator.
    pub amplitudes: Vec<f64>,
    /// Complex order spectrum (re, im) of the block's residual signal, orders 0..=K (K at most 4096; DC
    /// zero), for the local-change indicator; empty on the blocks past the first few hundred of a long
    /// recording.
    pub residual_spectrum: Vec<(f64, f64)>,
}

/// Where an indicator is scored: ratios of moments and energies vary by factors between blocks (their
/// block-to-block spread is skewed, M6A from 11 to 25 around 13 on a real healthy gearbox), so they are
/// scored on their logarithm; the spectral change is already a distance in dB.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Scale {
    /// The value itself.
    Linear,
    /// Its natural logarithm.
    Log,
}

/// A line of the envelope's order spectrum at a shaft order.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EnvelopeLine {
    /// The shaft.
    pub shaft: Shaft,
    /// Order of that shaft (1, 2, 3).
    pub order: usize,
    /// Order of the reference shaft where it lies.
    pub reference_order: f64,
    /// Amplitude of the squared envelope (unit^2).
    pub amplitude: f64,
    /// Height over the median of the envelope spectrum within +-2 orders, dB.
    pub over_floor_db: f64,
}

/// The envelope analysis of the deciding channel: band from the fast kurtogram, the squared envelope's
/// order spectrum on the tracked angle, the lines at the shafts' first orders.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Envelope {
    /// Band, Hz.
    pub band_hz: [f64; 2],
    /// Kurtogram level of the band (band width fs / 2^(level + 1)); 0 when the band was given.
    pub level: usize,
    /// Spectral kurtosis of the band (0 for Gaussian noise).
    pub spectral_kurtosis: f64,
    /// Lines at orders 1..=3 of each shaft.
    pub lines: Vec<EnvelopeLine>,
    /// The shaft whose family was removed by comb liftering before demodulation (`--lifter`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub liftered: Option<Shaft>,
    /// Order axis of the envelope spectrum (reference shaft orders).
    #[serde(skip)]
    pub orders: Vec<f64>,
    /// Envelope spectrum amplitudes.
    #[serde(skip)]
    pub amplitudes: Vec<f64>,
    /// Kurtogram: spectral kurtosis per level and band.
    #[serde(skip)]
    pub kurtogram: Vec<Vec<f64>>,
}

/// A rahmonic of a shaft in the real cepstrum.
#[derive(Clone, Debug, Serialize)]
pub struct Rahmonic {
    /// The shaft.
    pub shaft: Shaft,
    /// Rahmonic number (1 at the shaft period).
    pub k: usize,
    /// Quefrency, s.
    pub quefrency_s: f64,
    /// Cepstrum value there (largest within +-1 % of the quefrency).
    pub value: f64,
}

/// The real power cepstrum of the deciding channel.
#[derive(Clone, Debug, Serialize)]
pub struct Cepstrum {
    /// Rahmonics of each shaft.
    pub rahmonics: Vec<Rahmonic>,
    /// Quefrency step, s.
    pub dq_s: f64,
    /// Cepstrum values from quefrency 0.
    #[serde(skip)]
    pub values: Vec<f64>,
}

/// One indicator of one gear and channel scored against the statistical baseline.
#[derive(Clone, Debug, Serialize)]
pub struct Score {
    /// Gear (shaft).
    pub gear: Shaft,
    /// 1-based channel.
    pub channel: usize,
    /// Indicator name (lower case).
    pub indicator: String,
    /// Median over this recording's blocks.
    pub value: f64,
    /// Blocks of this recording.
    pub blocks: usize,
    /// Median over the baseline's blocks.
    pub baseline_centre: f64,
    /// Spread of the baseline's blocks (1.4826 x median absolute deviation, at least 5 % of the centre), on
    /// `scale`.
    pub baseline_spread: f64,
    /// `log` when the indicator is scored on its natural logarithm (the spread is then of ln value).
    pub scale: Scale,
    /// Smallest and largest baseline block value.
    pub baseline_range: [f64; 2],
    /// Baseline blocks.
    pub baseline_blocks: usize,
    /// (value - centre) / spread: how many spreads above the baseline's centre.
    pub spreads: f64,
    /// Suspect limit in spreads (false-alarm probability 1e-3 per indicator and block, Student-t prediction
    /// limit for the number of baseline blocks).
    pub suspect_at: f64,
    /// Faulty limit in spreads (false-alarm probability 1e-6).
    pub faulty_at: f64,
    /// Whether this indicator takes part in the verdict (a near-zero amplitude does not).
    pub decides: bool,
}

/// Where one gear's average changed against the baseline's: the phase-aligned difference of its residual
/// signal from the baseline's mean residual, and how much of that difference's energy one tooth pitch holds.
#[derive(Clone, Debug, Serialize)]
pub struct LocalChange {
    /// Gear (shaft).
    pub gear: Shaft,
    /// 1-based channel.
    pub channel: usize,
    /// Energy of the difference over the tooth pitch where it is largest, over the median pitch's.
    pub value: f64,
    /// The largest of the same measure between the baseline's own files (each against the others).
    pub healthy: f64,
    /// From here the change counts as evidence of a local fault: 2.5 times `healthy`, at least 3.
    pub limit: f64,
    /// Normalised correlation of the recording's residual with the baseline's at the best shift (1: the same
    /// pattern).
    pub alignment: f64,
    /// The tooth (1-based, from the recording's angle origin) where the change is largest.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tooth: Option<usize>,
    /// Sideband growth: the difference's energy at the first-order sidebands (k z +- 1) over the baseline's
    /// own there; a change once per revolution (an eccentric gear, uneven wear) raises it.
    pub sidebands: f64,
    /// The largest of the same between the baseline's own files.
    pub sidebands_healthy: f64,
    /// From here the growth counts as evidence: 3 times `sidebands_healthy`, at least 8.
    pub sidebands_limit: f64,
}

/// The verdict.
#[derive(Clone, Debug, Serialize)]
pub struct Verdict {
    /// Condition.
    pub state: VerdictState,
    /// Gear concerned.
    pub gear: VerdictGear,
    /// Reasons in plain words.
    pub reasons: Vec<String>,
    /// The tooth of a local fault (1-based), when the gear's difference signal holds one impulse per
    /// revolution that places it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tooth: Option<usize>,
    /// Where tooth 1 is counted from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tooth_origin: Option<ToothOrigin>,
    /// The other gears whose indicators moved with the fault's, said to be its cross-talk (their averages
    /// hold the faulty gear's impulses, smeared), not second faults.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub cross_talk: Vec<String>,
    /// With a machine: the name of the shaft that carries the faulty gear (`gear` is then `pinion` for the
    /// stage's driving gear, `wheel` for its driven gear, or `sun`, `planet`, `ring`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shaft: Option<String>,
    /// With a machine: the stage of the faulty gear, 1-based (machine file order).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stage: Option<usize>,
    /// With a machine and a faulty planet: the planet, 1-based (the order they pass the sensor).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub planet: Option<usize>,
    /// The average (gear or shaft) whose indicators decided a suspect or faulty verdict.
    #[serde(skip)]
    pub deciding: Option<Shaft>,
}

impl Verdict {
    /// The gear and, when placed, the tooth, in words: "pinion, tooth 3 (counted from the tachometer
    /// pulse)".
    pub fn place(&self) -> String {
        let gear = match (&self.shaft, self.stage, self.planet) {
            (_, Some(k), Some(p)) => format!("stage {k} planet {p}"),
            (Some(s), Some(k), None) => format!("stage {k} {} on shaft `{s}`", self.gear.name()),
            _ => self.gear.name().to_string(),
        };
        match (self.tooth, self.tooth_origin) {
            (Some(t), Some(ToothOrigin::Tachometer)) => {
                format!("{gear}, tooth {t} (counted from the tachometer pulse)")
            }
            (Some(t), Some(ToothOrigin::Relative)) => format!(
                "{gear}, tooth {t} (counted from a relative origin: no tachometer on this shaft, so only the distance between teeth is meaningful)"
            ),
            (Some(t), _) => format!(
                "{gear}, tooth {t} (counted from an arbitrary origin: no tachometer, so only the distance between teeth is meaningful)"
            ),
            _ => gear,
        }
    }

    /// A verdict without a tooth or cross-talk.
    pub fn new(state: VerdictState, gear: VerdictGear, reasons: Vec<String>) -> Self {
        Self {
            state,
            gear,
            reasons,
            tooth: None,
            tooth_origin: None,
            cross_talk: Vec::new(),
            shaft: None,
            stage: None,
            planet: None,
            deciding: None,
        }
    }
}

/// Where a placed tooth is counted from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum ToothOrigin {
    /// Tooth 1 is the one meshing at the tachometer's pulse.
    #[serde(rename = "tachometer pulse")]
    Tachometer,
    /// No tachometer: tooth 1 is where the tracked angle happened to start; only the distance between teeth
    /// is meaningful (another recording of the same machine may number them from elsewhere).
    #[serde(rename = "arbitrary (no tachometer)")]
    Arbitrary,
    /// With a machine: a shaft that the tachometer does not watch; tooth 1 is where its angle stood at the
    /// tracked shaft's first pulse (the tracked angle times the exact ratio), which depends on how many
    /// revolutions the machine had turned: only the distance between teeth is meaningful.
    #[serde(rename = "relative (no tachometer on this shaft)")]
    Relative,
}

/// One line of the model comparison.
#[derive(Clone, Debug, Serialize)]
pub struct ComparedLine {
    /// Pinion order.
    pub order: usize,
    /// "14k+-i pinion" style label.
    pub label: String,
    /// Measured level relative to the measured first mesh line, dB.
    pub measured_db: f64,
    /// Model level relative to the model's first mesh line, dB.
    pub model_db: f64,
    /// measured - model, dB.
    pub difference_db: f64,
}

/// Measured against modelled orders.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    /// Scene file.
    pub scene: String,
    /// Speed used for the model, rpm.
    pub model_speed_rpm: f64,
    /// Measured / model amplitude at the first mesh line, after conversion to velocity.
    pub scale_at_mesh: f64,
    /// RMS over the compared lines of the dB difference (0 = the model explains the pattern exactly).
    pub distance_db: f64,
    /// Lines compared.
    pub lines: Vec<ComparedLine>,
    /// Lines the model misses (measured > model + 6 dB).
    pub model_misses: Vec<String>,
    /// Lines the model overpredicts (measured < model - 6 dB).
    pub model_overpredicts: Vec<String>,
}

/// Result of diagnosing one recording (the JSON object of `diagnose --json`).
#[derive(Clone, Debug, Serialize)]
pub struct Diagnosis {
    /// Recording file.
    pub file: String,
    /// Sample rate in Hz (`null` when unknown).
    pub sample_rate_hz: Option<f64>,
    /// Samples per channel.
    pub samples: usize,
    /// Channels analysed (1-based).
    pub channels: Vec<usize>,
    /// Shaft frequencies in Hz (`null` entries when unknown).
    pub shaft_hz: ShaftHz,
    /// Shaft period in samples.
    pub shaft_period_samples: f64,
    /// Where the speed came from.
    pub speed_source: SpeedSource,
    /// Confidence of an estimated speed, 0..1 (autocorrelation at the period; from the teeth, the mesh comb's
    /// margin over the best comb of another line family times its strength); 1 when given or measured.
    pub speed_confidence: f64,
    /// How the spectrum image shows its levels (display only).
    #[serde(skip)]
    pub spectrum_scale: SpectrumScale,
    /// Why the estimated speed is too doubtful for a verdict of health to rest on it (the verdict is then
    /// at best not judged); absent when the speed is trusted.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_doubt: Option<String>,
    /// The pinion speed the user gave (a nominal speed, Hz), when given: the speed used is the one measured
    /// on the mesh line within the given tolerance (`shaft_hz`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_given_hz: Option<f64>,
    /// The measured mean speed against the given one, percent (`(measured / given - 1) x 100`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_deviation_percent: Option<f64>,
    /// The reference shaft's speed over the recording.
    pub speed_profile: SpeedProfile,
    /// Mesh frequency in Hz (`null` when unknown).
    pub mesh_hz: Option<f64>,
    /// Mesh order of the pinion (or of the estimated shaft).
    pub mesh_order: usize,
    /// Where the teeth came from.
    pub teeth_source: TeethSource,
    /// Without given teeth: the teeth of the gear meshing with the tracked shaft, estimated from its
    /// sidebands (`null` when none stand out).
    pub other_gear: Option<OtherGear>,
    /// Mesh harmonics with sidebands on the deciding channel.
    pub mesh_harmonics: Vec<MeshHarmonic>,
    /// Indicators of the deciding gear and channel.
    pub indicators: BTreeMap<String, f64>,
    /// Indicators per gear and channel.
    pub gears: Vec<GearIndicators>,
    /// Raw-signal RMS and kurtosis per channel (for reference only).
    pub raw: Vec<BTreeMap<String, f64>>,
    /// Verdict.
    pub verdict: Verdict,
    /// Envelope analysis of the deciding channel (with a sample rate).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub envelope: Option<Envelope>,
    /// Real power cepstrum of the deciding channel (with a sample rate).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cepstrum: Option<Cepstrum>,
    /// Indicators scored against the statistical baseline (empty without a baseline).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub scores: Vec<Score>,
    /// Each gear's local change against the baseline (with a baseline of two files or more).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub local_change: Vec<LocalChange>,
    /// Model comparison, with `--scene`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub comparison: Option<Comparison>,
    /// Physical unit of the analysed signal (from the sidecar; empty when the file does not say).
    pub unit: String,
    /// Warnings (clipping, estimated quantities).
    pub warnings: Vec<String>,
    /// Amplitude spectrum of the deciding channel, or of every analysed channel with
    /// `Options::all_spectra` (empty when the sample rate is unknown).
    #[serde(skip)]
    pub spectra: Vec<(usize, Spectrum)>,
    /// The first baseline's amplitude spectrum of each channel, for the overlay in the images.
    #[serde(skip)]
    pub baseline_spectra: Vec<(usize, Spectrum)>,
    /// The first baseline's TSA of each channel and gear (channel, gear, TSA over one revolution), for the
    /// overlay in the images.
    #[serde(skip)]
    pub baseline_tsas: Vec<(usize, Shaft, Vec<f64>)>,
    /// Order amplitudes against speed of the deciding channel, when the speed changed by more than 2 %
    /// over the recording (orders of the reference shaft; speeds in rev/sample).
    #[serde(skip)]
    pub order_map: Option<crate::signal::order_map::OrderMap>,
    /// With a machine file (`diagnose --machine`): every stage's lines, the planetary stages' orders and
    /// per-planet averages.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub machine: Option<super::MachineDiagnosis>,
}

impl Diagnosis {
    /// Amplitude spectra (see the field `spectra`).
    pub fn spectra(&self) -> &[(usize, Spectrum)] {
        &self.spectra
    }
    /// TSA, its order amplitudes and the gear label of each gear and channel.
    pub fn tsas(&self) -> impl Iterator<Item = (&GearIndicators, &[f64], &[f64])> {
        self.gears.iter().map(|g| (g, g.tsa.as_slice(), g.tsa_amplitudes.as_slice()))
    }
}

macro_rules! display_by_name {
    ($($t:ty),*) => {$(
        impl std::fmt::Display for $t {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }
    )*};
}
display_by_name!(VerdictState, VerdictGear, SpeedSource, TeethSource, Tracking);

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
