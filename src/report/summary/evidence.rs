//! The evidence of a diagnosis: mesh harmonics and sidebands, gear indicators and their blocks, the
//! envelope, the cepstrum, the comparison with a model.

use super::{Indicators, Shaft};
use serde::{Deserialize, Serialize};

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
    /// Indicators of the gear's average.
    pub indicators: Indicators,
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
    /// Indicators of the block's average, with the residual's second and fourth central moments (for NA4*).
    pub indicators: Indicators,
    /// TSA amplitude by order 0..=K (K about 3.5 mesh harmonics), for the spectral-change indicator.
    pub amplitudes: Vec<f64>,
    /// Complex order spectrum (re, im) of the block's residual signal, orders 0..=K (K at most 4096; DC
    /// zero), for the change against a baseline; empty unless a baseline of two files or a profile asks for
    /// it, and on the blocks past the first 256 of a long recording.
    pub residual_spectrum: Vec<(f64, f64)>,
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
