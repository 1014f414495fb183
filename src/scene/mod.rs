//! Scenes: one JSON file states one simulation (model, solver, output). Parsed with serde
//! (`deny_unknown_fields`), then validated into typed model objects; every error names the file and the
//! field. Units are in the field names (SI unless the name says otherwise).

pub mod machine;
mod output;
mod raw;
pub mod train;
mod validate;

use crate::model::{GearPair, OutputQuantity, PressParams, SecondOrderSystem};
use crate::solver::SolverOptions;
use crate::system::PeriodicSystem;
use raw::{ModelKind, RawScene};
use serde::Deserialize;
use validate::Validator;

/// Errors reading or validating a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{file}: cannot read scene: {message}")]
    Io {
        /// Scene path.
        file: String,
        /// OS message.
        message: String,
    },
    /// JSON syntax, unknown or missing field, wrong type.
    #[error("{file}: {message}")]
    Json {
        /// Scene path.
        file: String,
        /// serde_json's message with line and column.
        message: String,
    },
    /// A value that is well-formed but physically meaningless.
    #[error("{file}: field `{field}`: {message}")]
    Invalid {
        /// Scene path.
        file: String,
        /// Dotted path of the field.
        field: String,
        /// What is wrong.
        message: String,
    },
}

// ---------- validated scene ----------

/// The model a scene builds.
#[derive(Clone, Debug)]
pub enum Model {
    /// Gear pair (Eqs 36-46).
    GearPair(GearPair),
    /// Forging-press cam mechanism (Eqs 32-35).
    Press(PressParams, SecondOrderSystem),
    /// Generic LTP system.
    Ltp(SecondOrderSystem),
}

/// A slow speed change over a written recording. Quasi-static: the waveform is the steady state at the
/// nominal speed, and its shaft angle follows the speed, theta(t) = f0 tau(t) with tau(t) = integral of the
/// relative speed s(u) from 0 to t (the "nominal-speed time equivalent").
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpeedChange {
    /// s(t) = 1 + depth sin(2 pi f t).
    Sinusoidal {
        /// Relative depth (0.01 = 1 %).
        depth: f64,
        /// Modulation frequency, Hz.
        frequency_hz: f64,
    },
    /// Smooth random drift: s(t) = 1 + sum over k = 1..=8 of a_k sin(2 pi k t / (8 T) + phi_k), amplitudes
    /// and phases from `seed`, scaled so the largest |s - 1| over the recording is `ppm` 1e-6.
    Drift {
        /// Largest relative deviation, parts per million.
        ppm: f64,
        /// Slowest time scale T, s (the fastest component has period T).
        time_scale_s: f64,
        /// Seed of the amplitudes and phases.
        seed: u64,
    },
    /// Linear change from `from` to `to` times the nominal speed over `duration_s` (a run-up or coast-down).
    Ramp {
        /// Relative speed at t = 0.
        from: f64,
        /// Relative speed at t = duration.
        to: f64,
        /// Duration of the recording, s.
        duration_s: f64,
    },
}

/// Components of [`SpeedChange::Drift`].
const DRIFT_TERMS: usize = 8;

impl SpeedChange {
    /// Amplitudes (relative) and phases of the drift's sinusoids, and the slowest frequency, Hz.
    fn drift_terms(ppm: f64, time_scale_s: f64, seed: u64, duration_s: f64) -> ([(f64, f64); DRIFT_TERMS], f64) {
        // splitmix64: a fixed, documented generator (the recording must be reproducible from the seed)
        let mut state = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut next = || {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut terms = [(0.0, 0.0); DRIFT_TERMS];
        for (k, t) in terms.iter_mut().enumerate() {
            *t = ((next() - 0.5) / (k + 1) as f64, std::f64::consts::TAU * next());
        }
        let f1 = 1.0 / (DRIFT_TERMS as f64 * time_scale_s);
        // scale to the largest deviation over the recording (sampled at 4096 points, enough for 8 slow terms)
        let peak = (0..=4096)
            .map(|i| {
                let t = duration_s * i as f64 / 4096.0;
                terms
                    .iter()
                    .enumerate()
                    .map(|(k, (a, p))| a * (std::f64::consts::TAU * (k + 1) as f64 * f1 * t + p).sin())
                    .sum::<f64>()
                    .abs()
            })
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        let scale = ppm * 1e-6 / peak;
        terms.iter_mut().for_each(|t| t.0 *= scale);
        (terms, f1)
    }

    /// The nominal-speed time equivalent tau(t) of a recording `duration_s` long, as a function of the time t
    /// in s (the drift's terms computed once).
    pub fn angle_time(&self, duration_s: f64) -> Box<dyn Fn(f64) -> f64 + Send + Sync> {
        use std::f64::consts::TAU;
        match *self {
            Self::Sinusoidal { depth, frequency_hz } => {
                let w = TAU * frequency_hz;
                Box::new(move |t| t + depth * (1.0 - (w * t).cos()) / w)
            }
            Self::Drift { ppm, time_scale_s, seed } => {
                let (terms, f1) = Self::drift_terms(ppm, time_scale_s, seed, duration_s);
                Box::new(move |t| {
                    t + terms
                        .iter()
                        .enumerate()
                        .map(|(k, (a, p))| {
                            let w = TAU * (k + 1) as f64 * f1;
                            a * (p.cos() - (w * t + p).cos()) / w
                        })
                        .sum::<f64>()
                })
            }
            Self::Ramp { from, to, duration_s: d } => Box::new(move |t| from * t + (to - from) * t * t / (2.0 * d)),
        }
    }

    /// Largest relative speed reached (1.01 for +1 %).
    pub fn max_relative_speed(&self) -> f64 {
        match *self {
            Self::Sinusoidal { depth, .. } => 1.0 + depth,
            Self::Drift { ppm, .. } => 1.0 + ppm * 1e-6,
            Self::Ramp { from, to, .. } => from.max(to),
        }
    }

    /// One line for the sidecar.
    pub fn describe(&self) -> String {
        match *self {
            Self::Sinusoidal { depth, frequency_hz } => {
                format!("sinusoidal: speed x (1 + {depth} sin(2 pi {frequency_hz} Hz t))")
            }
            Self::Drift { ppm, time_scale_s, seed } => {
                format!("random drift: at most {ppm} ppm, slowest time scale {time_scale_s} s, seed {seed}")
            }
            Self::Ramp { from, to, .. } => format!("linear ramp from {from} to {to} times the nominal speed"),
        }
    }
}

/// Sample format of a written WAV file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WavFormat {
    /// 32-bit IEEE float, values in the physical unit.
    F32,
    /// 16-bit integer, full scale = `full_scale` physical units.
    I16,
    /// 24-bit integer, full scale = `full_scale` physical units.
    I24,
}

/// What `simulate` reports and writes.
#[derive(Clone, Debug)]
pub struct OutputOptions {
    /// Output quantity.
    pub quantity: OutputQuantity,
    /// Frequency whose multiples are the orders (pinion rotation, press input shaft, 1/T), Hz.
    pub base_hz: f64,
    /// Name of the base ("pinion rotation").
    pub base_name: String,
    /// Highest order listed in `orders`.
    pub max_order: f64,
    /// Sample rate of a written signal, Hz.
    pub sample_rate_hz: f64,
    /// Duration of a written signal, s.
    pub duration_s: f64,
    /// RMS of white measurement noise added to the written signal (physical unit).
    pub noise_rms: f64,
    /// Seed of the noise generator.
    pub seed: u64,
    /// Optional speed change over the written recording.
    pub speed_change: Option<SpeedChange>,
    /// Add once-per-revolution tachometer channels.
    pub tacho: bool,
    /// WAV sample format.
    pub wav_format: WavFormat,
    /// Physical value mapped to integer full scale (integer WAV only).
    pub full_scale: Option<f64>,
    /// True when `sample_rate_hz` came from the scene rather than a default.
    pub sample_rate_given: bool,
}

/// A validated scene.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Scene name (file stem when not given).
    pub name: String,
    /// Path it was read from.
    pub file: String,
    /// Model.
    pub model: Model,
    /// Solver options.
    pub solver: SolverOptions,
    /// Output options.
    pub output: OutputOptions,
    /// What was modelled and what was dropped, in plain words.
    pub notes: Vec<String>,
    /// The raw JSON, for parameter sweeps.
    pub json: serde_json::Value,
}

impl Scene {
    /// The model as a periodic system.
    pub fn system(&self) -> &dyn PeriodicSystem {
        match &self.model {
            Model::GearPair(g) => g,
            Model::Press(_, s) | Model::Ltp(s) => s,
        }
    }

    /// Reads and validates a scene file.
    ///
    /// # Errors
    /// [`SceneError`] naming the file and field.
    pub fn load(path: &str) -> Result<Self, SceneError> {
        crate::io::register_input(std::path::Path::new(path));
        let text = read_limited(path)?;
        // typed parse first, for messages with the field path and line/column
        let mut de = serde_json::Deserializer::from_str(&text);
        let raw: RawScene = serde_path_to_error::deserialize(&mut de).map_err(|e| json_error(path, e))?;
        let value: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| SceneError::Json { file: path.to_string(), message: e.to_string() })?;
        Self::from_raw(raw, value, path)
    }

    /// Validates a scene given as JSON (`file` is used in messages).
    ///
    /// # Errors
    /// [`SceneError`] naming the file and field.
    pub fn from_value(value: serde_json::Value, file: &str) -> Result<Self, SceneError> {
        let raw: RawScene = serde_path_to_error::deserialize(value.clone()).map_err(|e| json_error(file, e))?;
        Self::from_raw(raw, value, file)
    }

    fn from_raw(raw: RawScene, value: serde_json::Value, file: &str) -> Result<Self, SceneError> {
        let v = Validator::new(file);
        let solver = v.solver(&raw.solver)?;
        let mut notes = Vec::new();
        let stem = std::path::Path::new(file).file_stem().and_then(|s| s.to_str()).unwrap_or("scene");
        let name = raw.name.clone().unwrap_or_else(|| stem.to_string());
        let present = [
            (ModelKind::GearPair, raw.gear_pair.is_some()),
            (ModelKind::Press, raw.press.is_some()),
            (ModelKind::Ltp, raw.ltp.is_some()),
        ];
        for (kind, is) in present {
            if is && kind != raw.model {
                return Err(v.err(kind.key(), format!("given, but `model` is \"{}\"", raw.model.key())));
            }
        }
        let missing =
            |key: &str| v.err(key, format!("missing: `model` is \"{key}\" so the `{key}` object is required"));
        let (model, output) = match raw.model {
            ModelKind::GearPair => {
                let g = raw.gear_pair.as_ref().ok_or_else(|| missing("gear_pair"))?;
                let gp = v.gear_pair(g, solver.tolerance, &mut notes)?;
                let out = v.gear_output(&raw.output, &gp)?;
                v.gear_work(&gp, out.max_order, solver.tolerance)?;
                (Model::GearPair(gp), out)
            }
            ModelKind::Press => {
                let p = raw.press.as_ref().ok_or_else(|| missing("press"))?;
                let params = v.press(p)?;
                let sys =
                    params.system().map_err(|_| v.err("press.follower_mass_kg", "mass matrix is singular".into()))?;
                let out = v.press_output(&raw.output, &params)?;
                (Model::Press(params, sys), out)
            }
            ModelKind::Ltp => {
                let l = raw.ltp.as_ref().ok_or_else(|| missing("ltp"))?;
                let sys = v.ltp(l)?;
                let out = v.ltp_output(&raw.output, &sys, l.period_s)?;
                (Model::Ltp(sys), out)
            }
        };
        let mut scene = Self { name, file: file.to_string(), model, solver, output, notes, json: value };
        let sys = scene.system();
        let period = sys.period_s();
        let note = format!(
            "period {:.6} s ({:.4} base revolutions), highest coefficient harmonic {}",
            period,
            period * scene.output.base_hz,
            sys.max_harmonic()
        );
        scene.notes.insert(0, note);
        Ok(scene)
    }
}

/// Parses a JSON document of any typed form (a profile, a machine file) with the failing field's path in
/// the message.
///
/// # Errors
/// [`SceneError::Json`] naming `file` and the field.
pub fn parse_json<T: serde::de::DeserializeOwned>(text: &str, file: &str) -> Result<T, SceneError> {
    let mut de = serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize(&mut de).map_err(|e| json_error(file, e))
}

/// Largest scene file read, bytes: a sampled table of the largest accepted size is well under 1 MB.
pub const MAX_SCENE_BYTES: u64 = 64 << 20;

/// The text of a scene file, read with a size limit: a device, a pipe or a file over [`MAX_SCENE_BYTES`]
/// is refused before it is read.
fn read_limited(path: &str) -> Result<String, SceneError> {
    use std::io::Read;
    let io = |message: String| SceneError::Io { file: path.to_string(), message };
    let meta = std::fs::metadata(path).map_err(|e| io(e.to_string()))?;
    if !meta.is_file() {
        return Err(io("not a regular file (a device, pipe or directory)".into()));
    }
    let file = std::fs::File::open(path).map_err(|e| io(e.to_string()))?;
    let mut bytes = Vec::with_capacity(meta.len().min(MAX_SCENE_BYTES) as usize);
    file.take(MAX_SCENE_BYTES + 1).read_to_end(&mut bytes).map_err(|e| io(e.to_string()))?;
    if bytes.len() as u64 > MAX_SCENE_BYTES {
        return Err(io(format!("larger than the {MAX_SCENE_BYTES} bytes a scene may hold")));
    }
    String::from_utf8(bytes).map_err(|e| io(format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to())))
}

fn json_error(file: &str, e: serde_path_to_error::Error<serde_json::Error>) -> SceneError {
    let path = e.path().to_string();
    let inner = e.into_inner();
    let message = if path == "." || path == "?" || path.is_empty() {
        inner.to_string()
    } else {
        format!("field `{path}`: {inner}")
    };
    SceneError::Json { file: file.to_string(), message }
}
