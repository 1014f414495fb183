//! The sidecar `FILE.json` next to a signal gearvib wrote: one typed struct, written and read by serde.
//! Reading restores physical units of integer WAV files (`full_scale`) and the channel names (tachometer
//! channels are named "tacho ...").

use super::{AtomicFile, DataError, write_uncommitted};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What a written signal file holds (also written as the sidecar `OUT.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sidecar {
    /// Written file.
    pub file: String,
    /// Scene name.
    pub scene: String,
    /// Scene file.
    pub scene_file: String,
    /// Sample rate in Hz.
    pub sample_rate_hz: f64,
    /// Frames (samples per channel).
    pub frames: u64,
    /// Duration in s.
    pub duration_s: f64,
    /// Channels in file order.
    pub channels: Vec<ChannelInfo>,
    /// "f32", "i16", "i24" (WAV) or "csv".
    pub format: String,
    /// Physical value of integer full scale (integer WAV only).
    pub full_scale: Option<f64>,
    /// Samples clipped at integer full scale.
    pub clipped_samples: u64,
    /// White measurement noise RMS (output unit).
    pub noise_rms: f64,
    /// Noise seed.
    pub seed: u64,
    /// The speed change the recording follows (`null` at constant speed).
    pub speed_change: Option<String>,
    /// Base frequency of the orders in Hz (pinion rotation for the gear pair).
    pub base_hz: f64,
    /// Period of the steady state in s.
    pub period_s: f64,
    /// How samples were evaluated.
    pub evaluation: String,
    /// Warnings (aliasing allowed, clipping).
    pub warnings: Vec<String>,
}

/// One channel of a written file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChannelInfo {
    /// Name, e.g. "dq/dt" or "tacho pinion".
    pub name: String,
    /// Unit of the stored values (integer WAV: multiply the [-1, 1) value by `full_scale`).
    pub unit: String,
    /// Description.
    pub description: String,
}

/// Path of the sidecar of `signal`: the signal's name plus ".json".
pub fn path_of(signal: &Path) -> PathBuf {
    let mut side = signal.as_os_str().to_os_string();
    side.push(".json");
    PathBuf::from(side)
}

/// Writes the sidecar of `signal` (pretty-printed JSON) under a temporary name: commit the guard to put it
/// in place.
///
/// # Errors
/// The file cannot be written.
pub fn write(signal: &Path, info: &Sidecar) -> Result<AtomicFile, DataError> {
    let side = path_of(signal);
    let text = serde_json::to_string_pretty(info).map_err(|e| DataError::format(&side, e.to_string()))?;
    write_uncommitted(&side, text.as_bytes())
}

/// Reads the sidecar of `signal`: `None` when there is none or it is not a gearvib sidecar (a file of the
/// same name written by another program is ignored, never an error).
pub fn read(signal: &Path) -> Option<Sidecar> {
    let text = std::fs::read_to_string(path_of(signal)).ok()?;
    serde_json::from_str(&text).ok()
}
