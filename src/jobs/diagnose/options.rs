//! What a `diagnose` call is told (its options, stored in a profile) and the geometry its recordings
//! share.

use super::DEFAULT_BLOCK_REVS;
use crate::model::Quantity;
use crate::report::summary::Shaft;

/// Options of [`diagnose`](super::diagnose). Defaults: all channels but the tachometer, sample rate from the file, speed
/// estimated, teeth estimated, velocity, 8 revolutions at least, shaft orders 1..=2 in the regular signal.
/// A profile stores them (`processing` of [`Profile`](super::profile::Profile)).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Options {
    /// 1-based channel to analyse (all but the tachometer when `None`).
    pub channel: Option<usize>,
    /// Sample rate in Hz, for a file without one; one that contradicts the file's is refused unless
    /// `fs_override`.
    pub fs_hz: Option<f64>,
    /// `fs_hz` overrides the file's own rate.
    pub fs_override: bool,
    /// Analyse in orders only when no sample rate is known.
    pub fs_unknown: bool,
    /// Pinion (input) shaft speed in Hz: a nominal speed, searched on the mesh comb within
    /// +-`speed_tolerance` when the teeth are known.
    pub shaft_hz: Option<f64>,
    /// Relative tolerance of a given speed (0.05: the mesh line is sought within +-5 %).
    pub speed_tolerance: f64,
    /// Teeth of pinion and wheel.
    pub teeth: Option<(usize, usize)>,
    /// 1-based tachometer channel (pinion shaft).
    pub tacho_channel: Option<usize>,
    /// Tachometer pulses per revolution.
    pub pulses_per_rev: usize,
    /// What the recording measures (`None`: from the unit, else velocity).
    pub quantity: Option<Quantity>,
    /// Physical unit for channels whose file names none.
    pub unit: Option<String>,
    /// Recorded value per physical unit: samples are divided by it.
    pub sensitivity: Option<f64>,
    /// Envelope band in Hz (`None`: from the kurtogram).
    pub envelope_band: Option<(f64, f64)>,
    /// Deepest kurtogram level (`None`: 5, or what the recording allows).
    pub kurtogram_levels: Option<usize>,
    /// Shaft whose family of lines is removed by comb liftering before the envelope analysis.
    pub lifter: Option<Shaft>,
    /// Fewest whole revolutions a TSA needs.
    pub min_revolutions: usize,
    /// Revolutions per block of the statistical baseline (`None`: [`DEFAULT_BLOCK_REVS`], or fewer when
    /// the baseline is short).
    pub block_revs: Option<usize>,
    /// Shaft orders 1..=n counted as regular.
    pub shaft_orders: usize,
    /// A machine file (`--machine`): every shaft's speed from its ratio chain on the tracked angle, every
    /// stage's lines, a TSA per shaft, the planets of a planetary stage. `shaft_hz` is then the speed of the
    /// machine's `speed.shaft` (else its reference shaft) and `teeth` must not be given; the tachometer, the
    /// nominal speed and the sensors' unit come from the file unless given. A profile stores it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub machine: Option<crate::scene::machine::MachineFile>,
    /// Amplitude spectra of every analysed channel, not only of the deciding one (the first): the text,
    /// the JSON and the images use the deciding channel's alone; a library caller may want them all.
    #[serde(skip)]
    pub all_spectra: bool,
    /// Keep each block's residual order spectrum for the change against a baseline (set when healthy
    /// files or a profile are given: the recordings and the baseline files then need them; otherwise they
    /// would cost 17 MB on a 60 s, 4-channel recording for nothing).
    #[serde(skip)]
    pub residual_spectra: bool,
}

impl Options {
    /// Revolutions per baseline block in use.
    pub fn block_revs(&self) -> usize {
        self.block_revs.unwrap_or(DEFAULT_BLOCK_REVS)
    }
}

impl Default for Options {
    fn default() -> Self {
        Self {
            channel: None,
            fs_hz: None,
            fs_override: false,
            fs_unknown: false,
            shaft_hz: None,
            speed_tolerance: DEFAULT_SPEED_TOLERANCE,
            teeth: None,
            tacho_channel: None,
            pulses_per_rev: 1,
            quantity: None,
            unit: None,
            sensitivity: None,
            envelope_band: None,
            kurtogram_levels: None,
            lifter: None,
            min_revolutions: 8,
            block_revs: None,
            shaft_orders: 2,
            machine: None,
            all_spectra: false,
            residual_spectra: false,
        }
    }
}

/// Default relative tolerance of a given speed: a nameplate speed is off by the motor's slip (1-4 %).
pub const DEFAULT_SPEED_TOLERANCE: f64 = 0.05;

/// Speed and gear geometry shared by all recordings of one call (from the options, the baseline or the
/// first recording).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Geometry {
    /// Shaft period in samples, when known from the baseline.
    pub period_samples: Option<f64>,
    /// Mesh order, when known.
    pub mesh_order: Option<usize>,
    /// The baseline's envelope band in Hz: recordings are demodulated in the same band, so their envelope
    /// lines compare with the baseline's.
    pub envelope_band: Option<(f64, f64)>,
    /// Points per revolution of the baseline's averages: every recording is averaged on as many, so that
    /// its blocks and the baseline's hold the same orders.
    pub tsa_points: Option<usize>,
}
