//! The diagnosis of one recording (`diagnose --json`, one object per recording).

use super::{
    Cepstrum, Comparison, Envelope, GearIndicators, LocalChange, LongScore, MachineDiagnosis, MeshHarmonic, OtherGear,
    Score, Shaft, ShaftHz, SpeedProfile, SpeedSource, TeethSource, Tracking, Verdict, VerdictGear, VerdictState,
};
use crate::signal::Spectrum;
use serde::Serialize;

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
    pub indicators: super::Indicators,
    /// Indicators per gear and channel.
    pub gears: Vec<GearIndicators>,
    /// Raw-signal RMS and kurtosis per channel (for reference only).
    pub raw: Vec<super::Indicators>,
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
    /// The whole record's impulse measures against the baseline files' (empty without a baseline, or when
    /// the averages' lengths differ).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub long_scores: Vec<LongScore>,
    /// The baseline was stated to be recorded at this recording's load and speed (`diagnose --same-load`):
    /// a single file's limits are its own blocks'; absent otherwise.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub baseline_same_load: bool,
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
    pub machine: Option<MachineDiagnosis>,
    /// The gears whose averages hold a stronger mesh family than the given teeth's (the warning says at
    /// which order); absent when the teeth fit every gear.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub teeth_misfit: Vec<Shaft>,
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
    /// Samples per revolution of `shaft` (for a recording without a sample rate): the tracked shaft's
    /// period, a pair's wheel's that times its mesh order over the pinion's (the mesh is one line on both);
    /// `None` for a machine's other shafts, whose ratios the machine file holds.
    pub fn revolution_samples(&self, shaft: Shaft) -> Option<f64> {
        let reference = *self.shaft_hz.shafts().first()?;
        if shaft == reference {
            return Some(self.shaft_period_samples);
        }
        let order = |g: Shaft| self.gears.iter().find(|x| x.gear == g).map(|x| x.mesh_order as f64);
        match self.shaft_hz {
            ShaftHz::Pair { .. } => Some(self.shaft_period_samples * order(shaft)? / order(reference)?),
            _ => None,
        }
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
