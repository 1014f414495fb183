//! The sidecar `FILE.json` next to a signal gearvib wrote: one typed struct, written and read by serde.
//! Reading restores physical units of integer WAV files (`full_scale`) and the channel names (tachometer
//! channels are named "tacho ...").
//!
//! A sidecar is read with a size limit ([`MAX_SIDECAR_BYTES`]): a device (`/dev/zero`), a pipe or a file
//! larger than that is refused at once, before anything is read. A sidecar that cannot be read, is not
//! valid JSON (truncated, damaged) or is a damaged gearvib sidecar is an error naming it; a JSON file of
//! the same name that another program wrote (none of gearvib's keys) is ignored with a warning that says
//! what is then not applied.

use super::{AtomicFile, DataError, write_uncommitted};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What a written signal file holds (also written as the sidecar `OUT.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
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
#[serde(deny_unknown_fields)]
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

/// Largest sidecar read, bytes: gearvib writes a few kilobytes (a channel list and a few warnings).
pub const MAX_SIDECAR_BYTES: u64 = 1 << 20;

/// What [`read`] found next to a signal.
#[derive(Clone, Debug, PartialEq)]
pub enum Found {
    /// No file of the sidecar's name.
    None,
    /// gearvib's sidecar.
    Sidecar(Box<Sidecar>),
    /// A JSON file of that name written by another program (none of gearvib's keys): ignored, with the
    /// warning to report.
    Foreign(String),
}

impl Found {
    /// The sidecar, when it is gearvib's.
    pub fn sidecar(self) -> Option<Sidecar> {
        match self {
            Self::Sidecar(s) => Some(*s),
            _ => None,
        }
    }
}

/// Keys of a gearvib sidecar: a JSON object holding any of them is a sidecar, damaged if it does not parse.
const OWN_KEYS: [&str; 6] = ["sample_rate_hz", "frames", "full_scale", "channels", "format", "clipped_samples"];

/// Reads the sidecar of `signal` with a size limit (see the module doc).
///
/// # Errors
/// [`DataError`] naming the sidecar: not a regular file, larger than [`MAX_SIDECAR_BYTES`], unreadable,
/// not UTF-8, not valid JSON, or a gearvib sidecar with a missing, unknown or mistyped field.
pub fn read(signal: &Path) -> Result<Found, DataError> {
    use std::io::Read;
    let side = path_of(signal);
    let meta = match std::fs::metadata(&side) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Found::None),
        Err(e) => return Err(DataError::io(&side, format!("sidecar cannot be read: {e}"))),
    };
    if !meta.is_file() {
        return Err(DataError::format(
            &side,
            "sidecar is not a regular file (a device, pipe or directory): move it away to read the signal without it",
        ));
    }
    let too_big = |len: u64| {
        DataError::format(
            &side,
            format!(
                "sidecar of {len} bytes, over the {MAX_SIDECAR_BYTES} bytes a sidecar may hold: not gearvib's; move it away"
            ),
        )
    };
    if meta.len() > MAX_SIDECAR_BYTES {
        return Err(too_big(meta.len()));
    }
    let file = std::fs::File::open(&side).map_err(|e| DataError::io(&side, format!("sidecar cannot be read: {e}")))?;
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(MAX_SIDECAR_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| DataError::io(&side, format!("sidecar cannot be read: {e}")))?;
    if bytes.len() as u64 > MAX_SIDECAR_BYTES {
        return Err(too_big(bytes.len() as u64));
    }
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        DataError::format(&side, format!("sidecar is not UTF-8 text (byte {}): damaged; move it away", e.valid_up_to()))
    })?;
    // a byte-order mark (an editor's) is no part of the JSON
    let text = text.trim_start_matches('\u{feff}');
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| {
        DataError::format(
            &side,
            format!(
                "sidecar is not valid JSON (truncated or damaged: {e}); move it away to read the signal without it"
            ),
        )
    })?;
    let ours = value.as_object().is_some_and(|o| OWN_KEYS.iter().any(|k| o.contains_key(*k)));
    if !ours {
        return Ok(Found::Foreign(format!(
            "{}: not a gearvib sidecar (none of its keys): ignored, so no channel names, units, tachometer channels or integer full scale come from it",
            side.display()
        )));
    }
    serde_json::from_value(value).map(Found::Sidecar).map_err(|e| {
        DataError::format(&side, format!("damaged sidecar: {e}; move it away to read the signal without it"))
    })
}
