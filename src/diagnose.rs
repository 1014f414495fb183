//! Diagnosis of recorded signals: speed and teeth (given, tachometer, or estimated), spectra, TSA per
//! gear, condition indicators, sidebands labelled by shaft, a verdict, and comparison with a model.
//!
//! Which signal each indicator uses (see `reference/diagnostics.md`): RMS, kurtosis and crest factor on
//! the TSA of the gear's shaft; FM0 on the TSA and its mesh-harmonic amplitudes; FM4, M6A, M8A on the
//! difference signal; NA4 on the residual (ensemble of the recordings in command-line order; NA4* against
//! a baseline's residual variance); ER = RMS(difference) / RMS(regular); SI, SLF and SER on the TSA
//! amplitude spectrum around the first mesh harmonic. Raw-signal RMS and kurtosis are reported but never
//! decide the verdict.

use crate::Error;
use crate::io::{self, Recording};
use crate::signal::indicators as ind;
use crate::signal::spectrum::{AmplitudeOptions, Fft, amplitude_spectrum, welch_psd};
use crate::signal::tsa::{self, AngleMap, Decomposition};
use crate::signal::{Spectrum, speed};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// What the recording measures (for comparison with a model's dq/dt).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Quantity {
    /// Acceleration.
    Acceleration,
    /// Velocity (what `gearvib simulate` writes for the gear pair).
    Velocity,
    /// Displacement.
    Displacement,
}

/// Options of [`diagnose`]. Defaults: all channels but the tachometer, sample rate from the file, speed
/// estimated, teeth estimated, velocity, 8 revolutions at least, shaft orders 1..=2 in the regular signal.
#[derive(Clone, Debug)]
pub struct Options {
    /// 1-based channel to analyse (all but the tachometer when `None`).
    pub channel: Option<usize>,
    /// Sample rate override in Hz.
    pub fs_hz: Option<f64>,
    /// Analyse in orders only when no sample rate is known.
    pub fs_unknown: bool,
    /// Pinion (input) shaft speed in Hz.
    pub shaft_hz: Option<f64>,
    /// Teeth of pinion and wheel.
    pub teeth: Option<(usize, usize)>,
    /// 1-based tachometer channel (pinion shaft).
    pub tacho_channel: Option<usize>,
    /// Tachometer pulses per revolution.
    pub pulses_per_rev: usize,
    /// What the recording measures.
    pub quantity: Quantity,
    /// Fewest whole revolutions a TSA needs.
    pub min_revolutions: usize,
    /// Shaft orders 1..=n counted as regular.
    pub shaft_orders: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            channel: None,
            fs_hz: None,
            fs_unknown: false,
            shaft_hz: None,
            teeth: None,
            tacho_channel: None,
            pulses_per_rev: 1,
            quantity: Quantity::Velocity,
            min_revolutions: 8,
            shaft_orders: 2,
        }
    }
}

/// A sideband line.
#[derive(Clone, Debug, Serialize)]
pub struct Sideband {
    /// Offset in shaft orders (negative below the mesh line).
    pub offset: i32,
    /// "pinion" or "wheel".
    pub shaft: String,
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
    /// "pinion", "wheel" or "shaft of the estimated period".
    pub gear: String,
    /// 1-based channel.
    pub channel: usize,
    /// Mesh order of this gear's shaft (its teeth).
    pub mesh_order: usize,
    /// Revolutions averaged in the TSA.
    pub revolutions: usize,
    /// Indicators keyed by lower-case name.
    pub indicators: BTreeMap<String, f64>,
    #[serde(skip)]
    residual: Vec<f64>,
    #[serde(skip)]
    tsa_amplitudes: Vec<f64>,
    #[serde(skip)]
    tsa: Vec<f64>,
}

/// The verdict.
#[derive(Clone, Debug, Serialize)]
pub struct Verdict {
    /// "healthy", "suspect" or "faulty".
    pub state: String,
    /// Gear concerned ("pinion", "wheel", "unknown", or "none").
    pub gear: String,
    /// Reasons in plain words.
    pub reasons: Vec<String>,
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
    pub shaft_hz: BTreeMap<String, Option<f64>>,
    /// Shaft period in samples.
    pub shaft_period_samples: f64,
    /// "given", "tachometer" or "estimated".
    pub speed_source: String,
    /// Confidence of an estimated speed (autocorrelation at the period, 0..1); 1 when given.
    pub speed_confidence: f64,
    /// Mesh frequency in Hz (`null` when unknown).
    pub mesh_hz: Option<f64>,
    /// Mesh order of the pinion (or of the estimated shaft).
    pub mesh_order: usize,
    /// "given", "scene" or "estimated".
    pub teeth_source: String,
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
    /// Model comparison, with `--scene`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub comparison: Option<Comparison>,
    /// Warnings (clipping, estimated quantities).
    pub warnings: Vec<String>,
    #[serde(skip)]
    spectra: Vec<(usize, Spectrum, Spectrum)>,
}

impl Diagnosis {
    /// Amplitude spectrum and Welch PSD per analysed channel (when the sample rate is known).
    pub fn spectra(&self) -> &[(usize, Spectrum, Spectrum)] {
        &self.spectra
    }
    /// TSA, its order amplitudes and the gear label of each gear and channel.
    pub fn tsas(&self) -> impl Iterator<Item = (&GearIndicators, &[f64], &[f64])> {
        self.gears.iter().map(|g| (g, g.tsa.as_slice(), g.tsa_amplitudes.as_slice()))
    }
}

fn bad(path: &Path, msg: impl std::fmt::Display) -> Error {
    Error::Other(format!("{}: {msg}", path.display()))
}

/// Speed and gear geometry shared by all recordings of one call (from the options, the baseline or the
/// first recording).
#[derive(Clone, Debug)]
pub struct Geometry {
    /// Shaft period in samples, when known from the baseline.
    pub period_samples: Option<f64>,
    /// Mesh order, when known.
    pub mesh_order: Option<usize>,
}

/// Diagnoses one recording.
///
/// # Errors
/// Unreadable file, bad channel or sample rate, constant or non-finite data, too short for the TSA.
pub fn diagnose(path: &Path, o: &Options, geometry: Option<&Geometry>) -> Result<Diagnosis, Error> {
    let rec = io::read_recording(path)?;
    analyse(path, rec, o, geometry)
}

fn check_channel(path: &Path, idx: usize, x: &[f32], warnings: &mut Vec<String>) -> Result<(), Error> {
    if let Some(i) = x.iter().position(|v| !v.is_finite()) {
        return Err(bad(path, format!("channel {idx} has a non-finite sample at index {i}")));
    }
    let (lo, hi) = x.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    if lo == hi {
        return Err(bad(path, format!("channel {idx} is constant ({lo}): nothing to analyse")));
    }
    // clipping: runs of 3+ samples stuck at the extreme value
    let level = lo.abs().max(hi.abs()) * 0.9999;
    let peak = lo.abs().max(hi.abs());
    let (mut run, mut stuck) = (0usize, 0usize);
    for v in x {
        run = if v.abs() >= level { run + 1 } else { 0 };
        stuck += usize::from(run >= 3);
    }
    if stuck as f64 > 1e-4 * x.len() as f64 {
        warnings.push(format!("channel {idx} looks clipped: {stuck} runs of samples stuck at +-{peak}; amplitudes and indicators are unreliable"));
    }
    Ok(())
}

fn sample_rate(path: &Path, rec: &Recording, o: &Options) -> Result<Option<f64>, Error> {
    if let Some(fs) = o.fs_hz {
        if !(fs.is_finite() && fs > 0.0) {
            return Err(Error::Other(format!("--fs: must be a positive number of Hz, got {fs}")));
        }
        return Ok(Some(fs));
    }
    match rec.sample_rate_hz {
        Some(fs) if fs > 0.0 => Ok(Some(fs)),
        Some(fs) => Err(bad(path, format!("sample rate {fs} Hz is not positive; pass --fs HZ"))),
        None if o.fs_unknown => Ok(None),
        None => Err(bad(
            path,
            "no sample rate: the file has no time column; pass --fs HZ, or --fs-unknown to analyse in shaft orders only",
        )),
    }
}

fn analyse(path: &Path, rec: Recording, o: &Options, geometry: Option<&Geometry>) -> Result<Diagnosis, Error> {
    let nch = rec.channels.len();
    let n = rec.channels.first().map_or(0, Vec::len);
    if nch == 0 || n < 2 {
        return Err(bad(path, format!("{n} sample(s): far too short to analyse")));
    }
    let fs = sample_rate(path, &rec, o)?;
    let check_index = |flag: &str, c: usize| {
        if c == 0 || c > nch {
            Err(Error::Other(format!("{flag} {c}: {} has {nch} channel(s), numbered from 1", path.display())))
        } else {
            Ok(c)
        }
    };
    let tacho = o.tacho_channel.map(|c| check_index("--tacho-channel", c)).transpose()?;
    let channels: Vec<usize> = match o.channel {
        Some(c) => vec![check_index("--channel", c)?],
        // channels named as tachometers (gearvib's sidecar) are never vibration channels
        None => (1..=nch).filter(|c| Some(*c) != tacho && !rec.names[c - 1].starts_with("tacho")).collect(),
    };
    if channels.is_empty() {
        return Err(bad(path, "no channel left to analyse besides the tachometer"));
    }
    let mut warnings = Vec::new();
    let checks: Vec<Result<Vec<String>, Error>> = channels
        .par_iter()
        .map(|&c| {
            let mut w = Vec::new();
            check_channel(path, c, &rec.channels[c - 1], &mut w).map(|_| w)
        })
        .collect();
    for c in checks {
        warnings.extend(c?);
    }
    let mut fft = Fft::new();
    // ---- speed
    let (map, source, confidence) = if let Some(t) = tacho {
        let pulses =
            speed::tacho_pulses(&rec.channels[t - 1]).map_err(|e| bad(path, format!("--tacho-channel {t}: {e}")))?;
        (AngleMap::from_pulses(&pulses, o.pulses_per_rev.max(1)), "tachometer", 1.0)
    } else if let Some(hz) = o.shaft_hz {
        let fs = fs.ok_or_else(|| bad(path, "--rpm/--shaft-hz need the sample rate (--fs)"))?;
        (AngleMap::constant(fs / hz, 0.0, n), "given", 1.0)
    } else {
        let views: Vec<&[f32]> = channels.iter().map(|&c| &rec.channels[c - 1][..n.min(1 << 20)]).collect();
        let est = match geometry.and_then(|g| g.period_samples) {
            Some(p) => speed::refine_near(&mut fft, &views, p, 0.03),
            None => speed::estimate_period(&mut fft, &views, 16, n / o.min_revolutions.max(2)),
        }
        .map_err(|e| bad(path, e))?;
        warnings.push(format!(
            "shaft speed estimated from the signal's repetition period ({:.3} samples, autocorrelation {:.2}); give --rpm, --shaft-hz or --tacho-channel when known",
            est.period_samples, est.confidence
        ));
        (AngleMap::constant(est.period_samples, 0.0, n), "estimated", est.confidence)
    };
    let period = map.mean_period_samples();
    let points = (period.ceil() as usize).next_power_of_two().clamp(64, 1 << 16);
    // ---- TSA of the reference shaft first (needed to find the mesh when teeth are unknown)
    let gears: Vec<(String, f64, Option<usize>)> = match o.teeth {
        Some((zp, zw)) => vec![("pinion".into(), 1.0, Some(zp)), ("wheel".into(), zp as f64 / zw as f64, Some(zw))],
        None => vec![("shaft of the estimated period".into(), 1.0, geometry.and_then(|g| g.mesh_order))],
    };
    // one TSA per channel and gear, in parallel
    let jobs: Vec<(usize, usize)> = channels.iter().flat_map(|&c| (0..gears.len()).map(move |gi| (c, gi))).collect();
    let tsas = jobs
        .par_iter()
        .map(|&(c, gi)| {
            tsa::tsa(&rec.channels[c - 1], &map, gears[gi].1, points, o.min_revolutions)
                .map(|t| (c, gi, t))
                .map_err(|e| bad(path, e))
        })
        .collect::<Result<Vec<_>, Error>>()?;
    let mut teeth_source = if o.teeth.is_some() { "given" } else { "baseline" }.to_string();
    let mut gear_results = Vec::new();
    let mut mesh_orders = Vec::new();
    for (gi, (name, _, known)) in gears.iter().enumerate() {
        let z = match known {
            Some(z) => *z,
            None => {
                let z = mesh_family(&mut fft, tsas.iter().filter(|t| t.1 == gi).map(|t| t.2.samples.as_slice()));
                teeth_source = "estimated".into();
                warnings.push(format!(
                    "mesh order {z} estimated from the strongest harmonic family of the TSA spectrum; give --teeth when known"
                ));
                z
            }
        };
        if z * 2 + 8 > points / 2 {
            return Err(bad(path, format!("mesh order {z} needs more than {points} samples per revolution")));
        }
        mesh_orders.push(z);
        for (c, _, t) in tsas.iter().filter(|t| t.1 == gi) {
            gear_results.push(gear_indicators(&mut fft, name, *c, z, t, o.shaft_orders));
        }
    }
    // ---- spectra and mesh harmonics (deciding channel chosen later: use the first for now)
    let shaft_hz = fs.map(|fs| fs / period);
    let spectra = match fs {
        Some(fs) => channels
            .par_iter()
            .map(|&c| {
                let mut fft = Fft::new();
                let x = &rec.channels[c - 1];
                let amp = amplitude_spectrum(&mut fft, x, fs, AmplitudeOptions::default()).map_err(|e| bad(path, e))?;
                let psd = welch_psd(&mut fft, x, fs, 4096).map_err(|e| bad(path, e))?;
                Ok((c, amp, psd))
            })
            .collect::<Result<Vec<_>, Error>>()?,
        None => Vec::new(),
    };
    let raw = channels
        .par_iter()
        .map(|&c| {
            let x = &rec.channels[c - 1];
            BTreeMap::from([("rms".to_string(), ind::rms(x)), ("kurtosis".to_string(), ind::kurtosis(x))])
        })
        .collect();
    let mut shafts = BTreeMap::new();
    match o.teeth {
        Some((zp, zw)) => {
            shafts.insert("pinion".to_string(), shaft_hz);
            shafts.insert("wheel".to_string(), shaft_hz.map(|f| f * zp as f64 / zw as f64));
        }
        None => {
            shafts.insert("estimated_shaft".to_string(), shaft_hz);
        }
    }
    let ratios: Vec<(String, f64)> = gears.iter().map(|g| (g.0.clone(), g.1)).collect();
    let mut d = Diagnosis {
        file: path.display().to_string(),
        sample_rate_hz: fs,
        samples: n,
        channels: channels.clone(),
        shaft_hz: shafts,
        shaft_period_samples: period,
        speed_source: source.into(),
        speed_confidence: confidence,
        mesh_hz: shaft_hz.map(|f| f * mesh_orders[0] as f64),
        mesh_order: mesh_orders[0],
        teeth_source,
        mesh_harmonics: Vec::new(),
        indicators: BTreeMap::new(),
        gears: gear_results,
        raw,
        verdict: Verdict { state: "healthy".into(), gear: "none".into(), reasons: Vec::new() },
        comparison: None,
        warnings,
        spectra,
    };
    d.mesh_harmonics = mesh_harmonics(&d, channels[0], &ratios);
    if let Some(g) = d.gears.first() {
        d.indicators = g.indicators.clone();
    }
    Ok(d)
}

/// Mesh order: the family z (z >= 8) whose first harmonics hold the most TSA energy per harmonic, summed
/// over channels.
fn mesh_family<'a>(fft: &mut Fft, tsas: impl Iterator<Item = &'a [f64]>) -> usize {
    let mut power: Vec<f64> = Vec::new();
    for t in tsas {
        let a = crate::signal::spectrum::periodic_amplitudes_with(fft, t);
        let total: f64 = a.iter().skip(1).map(|v| v * v).sum::<f64>().max(f64::MIN_POSITIVE);
        power.resize(a.len(), 0.0);
        for (p, v) in power.iter_mut().zip(&a) {
            *p += v * v / total;
        }
    }
    let half = power.len().saturating_sub(1);
    (8..=(half / 2).max(8))
        .max_by(|&a, &b| {
            let score = |z: usize| {
                let h = (half / z).clamp(1, 4);
                (1..=h).map(|k| power.get(k * z).copied().unwrap_or(0.0)).sum::<f64>() / h as f64
            };
            score(a).total_cmp(&score(b))
        })
        .unwrap_or(8)
}

fn gear_indicators(
    fft: &mut Fft,
    gear: &str,
    channel: usize,
    z: usize,
    t: &tsa::Tsa,
    shaft_orders: usize,
) -> GearIndicators {
    let x = &t.samples;
    let Decomposition { amplitudes, regular, residual, difference } = tsa::decompose(fft, x, z, shaft_orders);
    let mesh_amps: Vec<f64> =
        (1..).map(|h| h * z).take_while(|&k| k < amplitudes.len()).map(|k| amplitudes[k]).collect();
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let centred: Vec<f64> = x.iter().map(|v| v - mean).collect();
    let side = amplitudes[z - 1] + amplitudes[z + 1];
    let mut m = BTreeMap::new();
    m.insert("rms".into(), ind::rms(&centred));
    m.insert("kurtosis".into(), ind::kurtosis(x));
    m.insert("crest_factor".into(), ind::crest_factor(&centred));
    m.insert("fm0".into(), ind::fm0(x, &mesh_amps));
    m.insert("fm4".into(), ind::normalized_moment(&difference, 4));
    m.insert("m6a".into(), ind::normalized_moment(&difference, 6));
    m.insert("m8a".into(), ind::normalized_moment(&difference, 8));
    m.insert("na4".into(), ind::kurtosis(&residual));
    m.insert("er".into(), ind::energy_ratio(&difference, &regular));
    m.insert("si".into(), side / 2.0);
    m.insert("slf".into(), side / ind::rms(&centred));
    m.insert("ser".into(), ind::sideband_energy_ratio(&amplitudes, z, 1));
    GearIndicators {
        gear: gear.into(),
        channel,
        mesh_order: z,
        revolutions: t.revolutions,
        indicators: m,
        residual,
        tsa_amplitudes: amplitudes,
        tsa: x.clone(),
    }
}

/// Mesh harmonics and sidebands (3 per shaft on each side) from the raw amplitude spectrum when the
/// sample rate is known, else from the reference TSA's order spectrum.
fn mesh_harmonics(d: &Diagnosis, channel: usize, shafts: &[(String, f64)]) -> Vec<MeshHarmonic> {
    let z = d.mesh_order as f64;
    let spectrum = d.spectra.iter().find(|s| s.0 == channel).map(|s| &s.1);
    let tsa_amps = d.gears.iter().find(|g| g.channel == channel).map(|g| &g.tsa_amplitudes);
    let shaft_hz = d.shaft_hz.values().next().copied().flatten();
    let mut out = Vec::new();
    for k in 1..=3usize {
        let order = k as f64 * z;
        let read = |o: f64| -> Option<(Option<f64>, f64)> {
            match (spectrum, shaft_hz) {
                (Some(s), Some(f1)) => {
                    let f = o * f1;
                    // within 1.5 bins only: a line of the other shaft can sit a few Hz away (3 f2 = 32.3 Hz
                    // against f1 = 30 Hz for 14/39 teeth) and must not be taken for this one
                    let df = s.freqs_hz.get(1).copied().unwrap_or(1.0);
                    let (ff, a) = s.peak_near(f, 1.5 * df)?;
                    Some((Some(ff), a))
                }
                _ => {
                    let a = tsa_amps?;
                    let i = o.round() as usize;
                    ((o - o.round()).abs() < 1e-9 && i < a.len()).then(|| (None, a[i]))
                }
            }
        };
        let Some((f, a)) = read(order) else { break };
        let mut sidebands = Vec::new();
        for (name, ratio) in shafts {
            for i in 1..=3i32 {
                for sign in [-1, 1] {
                    let o = order + f64::from(sign * i) * ratio;
                    if let Some((ff, aa)) = read(o) {
                        sidebands.push(Sideband {
                            offset: sign * i,
                            shaft: name.clone(),
                            frequency_hz: ff,
                            order: o,
                            amplitude: aa,
                            resolved: true,
                        });
                    }
                }
            }
        }
        // lines of different shafts closer than the resolution (3 bins, in orders) cannot be told apart
        let resolution = match (spectrum, shaft_hz) {
            (Some(s), Some(f1)) => 3.0 * s.freqs_hz.get(1).copied().unwrap_or(1.0) / f1,
            _ => 0.0,
        };
        let nominal: Vec<(String, f64)> = shafts
            .iter()
            .flat_map(|(name, ratio)| {
                (1..=3).flat_map(move |i| [-1.0, 1.0].map(|sg| (name.clone(), order + sg * f64::from(i) * ratio)))
            })
            .chain(std::iter::once(("mesh".to_string(), order)))
            .collect();
        for sb in &mut sidebands {
            sb.resolved = !nominal.iter().any(|(name, o)| *name != sb.shaft && (o - sb.order).abs() < resolution);
        }
        out.push(MeshHarmonic { k, frequency_hz: f, order, amplitude: a, sidebands });
    }
    out
}

/// Fills NA4 over the ensemble (recordings in time order): NA4 of record M uses the mean residual sum of
/// squares of records 1..=M of the same gear and channel.
pub fn ensemble_na4(results: &mut [Diagnosis]) {
    let mut history: BTreeMap<(String, usize), Vec<f64>> = BTreeMap::new();
    for d in results.iter_mut() {
        for g in &mut d.gears {
            let h = history.entry((g.gear.clone(), g.channel)).or_default();
            h.push(ind::sum_sq_dev(&g.residual));
            g.indicators.insert("na4".into(), ind::na4(&g.residual, h));
        }
        if let Some(g) = d.gears.first() {
            d.indicators = g.indicators.clone();
        }
    }
}

struct Trigger {
    level: u8,
    ratio: f64,
    text: String,
}

/// Verdict relative to a baseline diagnosis of the same machine, or on absolute thresholds without one.
pub fn judge(d: &mut Diagnosis, baseline: Option<&Diagnosis>) {
    let mut per_gear: Vec<(String, usize, Vec<Trigger>)> = Vec::new();
    for g in &mut d.gears {
        let mut trig = Vec::new();
        let get = |m: &BTreeMap<String, f64>, k: &str| m.get(k).copied().unwrap_or(f64::NAN);
        match baseline.and_then(|b| b.gears.iter().find(|x| x.gear == g.gear && x.channel == g.channel)) {
            Some(b) => {
                // NA4*: residual fourth moment over the baseline's residual variance
                let n = g.residual.len() as f64;
                let ss_b = ind::sum_sq_dev(&b.residual);
                let mean = g.residual.iter().sum::<f64>() / n;
                let s4: f64 = g.residual.iter().map(|v| (v - mean).powi(4)).sum();
                let na4_star = n * s4 / (ss_b * ss_b);
                g.indicators.insert("na4_star".into(), na4_star);
                let base_k = ind::kurtosis(&b.residual);
                let checks = [
                    (
                        "NA4*",
                        na4_star,
                        base_k,
                        1.5,
                        2.0,
                        "the residual signal (TSA without shaft and mesh lines) has grown and become impulsive",
                    ),
                    (
                        "M6A",
                        get(&g.indicators, "m6a"),
                        get(&b.indicators, "m6a"),
                        1.5,
                        2.0,
                        "the difference signal has sharper peaks",
                    ),
                    (
                        "FM4",
                        get(&g.indicators, "fm4"),
                        get(&b.indicators, "fm4"),
                        1.25,
                        1.5,
                        "the difference signal is more impulsive",
                    ),
                    (
                        "SER",
                        get(&g.indicators, "ser"),
                        get(&b.indicators, "ser"),
                        2.0,
                        3.0,
                        "the sidebands around the mesh line have grown",
                    ),
                    (
                        "SI",
                        get(&g.indicators, "si"),
                        get(&b.indicators, "si"),
                        2.0,
                        3.0,
                        "the first sidebands of the mesh line have grown",
                    ),
                ];
                for (name, now, then, s, f, why) in checks {
                    let r = now / then;
                    if r.is_finite() && r >= s {
                        trig.push(Trigger {
                            level: if r >= f { 2 } else { 1 },
                            ratio: r,
                            text: format!(
                                "{} (channel {}): {name} {now:.3} against {then:.3} in the baseline (x{r:.2}): {why}",
                                g.gear, g.channel
                            ),
                        });
                    }
                }
            }
            None => {
                let checks = [
                    (
                        "FM4",
                        get(&g.indicators, "fm4"),
                        4.5,
                        6.0,
                        3.0,
                        "difference signal impulsive (3 for a healthy mesh)",
                    ),
                    (
                        "M6A",
                        get(&g.indicators, "m6a"),
                        40.0,
                        80.0,
                        15.0,
                        "difference signal has sharp peaks (15 for a healthy mesh)",
                    ),
                    ("NA4", get(&g.indicators, "na4"), 4.5, 6.0, 3.0, "residual signal impulsive (3 nominal)"),
                ];
                for (name, now, s, f, nominal, why) in checks {
                    if now.is_finite() && now >= s {
                        trig.push(Trigger {
                            level: if now >= f { 2 } else { 1 },
                            ratio: now / nominal,
                            text: format!("{} (channel {}): {name} = {now:.3}: {why}", g.gear, g.channel),
                        });
                    }
                }
            }
        }
        per_gear.push((g.gear.clone(), g.channel, trig));
    }
    let level = |t: &[Trigger]| -> u8 {
        let top = t.iter().map(|x| x.level).max().unwrap_or(0);
        if t.len() >= 2 { 2 } else { top }
    };
    let worst = per_gear.iter().max_by(|a, b| {
        (level(&a.2), a.2.iter().map(|t| t.ratio).fold(0.0, f64::max))
            .partial_cmp(&(level(&b.2), b.2.iter().map(|t| t.ratio).fold(0.0, f64::max)))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let mut reasons = Vec::new();
    let (state, gear) = match worst {
        Some((gear, channel, t)) if level(t) > 0 => {
            let mut all: Vec<&Trigger> = per_gear.iter().flat_map(|g| &g.2).collect();
            all.sort_by(|a, b| b.ratio.total_cmp(&a.ratio));
            reasons.extend(all.iter().take(6).map(|t| t.text.clone()));
            if let Some(g) = d.gears.iter().find(|g| &g.gear == gear && g.channel == *channel) {
                d.indicators = g.indicators.clone();
            }
            let gear = if gear.starts_with("shaft") { "unknown (teeth not given)".to_string() } else { gear.clone() };
            (if level(t) == 2 { "faulty" } else { "suspect" }, gear)
        }
        _ => {
            reasons.push(match baseline {
                Some(_) => "no condition indicator rose above its threshold relative to the baseline".into(),
                None => {
                    "FM4, M6A and NA4 are within their healthy ranges (no baseline given: absolute thresholds)".into()
                }
            });
            ("healthy", "none".to_string())
        }
    };
    if baseline.is_none() {
        reasons.push("without --baseline only absolute thresholds apply; a healthy recording of the same machine makes the verdict much stronger".into());
    }
    d.verdict = Verdict { state: state.into(), gear, reasons };
}

/// Compares the recording's pinion TSA orders with a scene simulated at the measured speed.
///
/// # Errors
/// The scene cannot be loaded or solved; the recording has no pinion TSA or sample rate.
pub fn compare(d: &mut Diagnosis, scene_path: &str, quantity: Quantity) -> Result<(), Error> {
    let mut scene_json: serde_json::Value = {
        let s = crate::scene::Scene::load(scene_path)?;
        s.json
    };
    let shaft_hz = d.shaft_hz.get("pinion").copied().flatten().ok_or_else(|| {
        Error::Other(format!("{}: --scene needs the pinion speed in Hz (give --teeth and a sample rate)", d.file))
    })?;
    let rpm = shaft_hz * 60.0;
    if let Some(g) = scene_json.get_mut("gear_pair") {
        g["speed_rpm"] = rpm.into();
    } else {
        return Err(Error::Other(format!("{scene_path}: --scene needs a gear_pair scene")));
    }
    let scene = crate::scene::Scene::from_value(scene_json, scene_path)?;
    let sim = crate::pipeline::simulate(&scene)?;
    let gear = d.gears.iter().find(|g| g.gear == "pinion").ok_or_else(|| Error::Other("no pinion TSA".into()))?;
    let z = gear.mesh_order;
    let model: BTreeMap<usize, f64> = sim
        .orders
        .iter()
        .filter(|l| (l.order - l.order.round()).abs() < 1e-9)
        .map(|l| (l.order.round() as usize, l.amplitude))
        .collect();
    let to_velocity = |order: usize, a: f64| {
        let w = 2.0 * std::f64::consts::PI * order as f64 * shaft_hz;
        match quantity {
            Quantity::Velocity => a,
            Quantity::Acceleration => a / w,
            Quantity::Displacement => a * w,
        }
    };
    let meas = |o: usize| gear.tsa_amplitudes.get(o).map(|a| to_velocity(o, *a));
    let (Some(m0), Some(&s0)) = (meas(z), model.get(&z)) else {
        return Err(Error::Other(format!(
            "{scene_path}: mesh order {z} not available in both the recording and the model"
        )));
    };
    let db = |a: f64, r: f64| 20.0 * (a.max(r * 1e-4) / r).log10();
    let mut lines = Vec::new();
    for k in 1..=3 {
        for i in -3i64..=3 {
            let o = (k * z) as i64 + i;
            let (Some(a), Some(&b)) = (meas(o as usize), model.get(&(o as usize))) else { continue };
            let label = if i == 0 { format!("{k}x mesh") } else { format!("{k}x mesh {i:+} pinion") };
            let (md, sd) = (db(a, m0), db(b, s0));
            lines.push(ComparedLine {
                order: o as usize,
                label,
                measured_db: md,
                model_db: sd,
                difference_db: md - sd,
            });
        }
    }
    let distance = (lines.iter().map(|l| l.difference_db.powi(2)).sum::<f64>() / lines.len().max(1) as f64).sqrt();
    d.comparison = Some(Comparison {
        scene: scene_path.into(),
        model_speed_rpm: rpm,
        scale_at_mesh: m0 / s0,
        distance_db: distance,
        model_misses: lines
            .iter()
            .filter(|l| l.difference_db > 6.0)
            .map(|l| format!("order {} ({}): +{:.1} dB", l.order, l.label, l.difference_db))
            .collect(),
        model_overpredicts: lines
            .iter()
            .filter(|l| l.difference_db < -6.0)
            .map(|l| format!("order {} ({}): {:.1} dB", l.order, l.label, l.difference_db))
            .collect(),
        lines,
    });
    Ok(())
}
