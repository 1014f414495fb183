//! Diagnosis of recorded signals: speed and teeth (given, tachometer, or estimated), spectra, TSA per
//! gear, condition indicators, sidebands labelled by shaft, a verdict, and comparison with a model.
//!
//! Which signal each indicator uses (see `reference/diagnostics.md`): RMS, kurtosis and crest factor on
//! the TSA of the gear's shaft; FM0 on the TSA and its mesh-harmonic amplitudes; FM4, M6A, M8A on the
//! difference signal; NA4 on the residual (ensemble of the recordings in command-line order; NA4* against
//! a baseline's residual variance); ER = RMS(difference) / RMS(regular); SI, SLF and SER on the TSA
//! amplitude spectrum around the first mesh harmonic. Raw-signal RMS and kurtosis are reported but never
//! decide the verdict.

pub mod baseline;
mod beyond;
mod compare;
mod compat;
mod tracking;
pub mod trend;
mod verdict;

use beyond::{
    BandChoice, ORDER_MAP_SPEED_CHANGE, cepstrum, channel_spectra, envelope, envelope_of, envelope_plan, order_map,
};
pub use compat::{
    Compatibility, MAX_SPEED_DIFFERENCE, OPERATING_POINT_SPEED_DIFFERENCE, WARN_SPEED_DIFFERENCE, compatibility,
};
use tracking::{mesh_family, nominal_speed, teeth_misfit, track, wheel_teeth};

pub use compare::compare;
pub use verdict::{Thresholds, ensemble_na4, judge};

use super::{ChannelRole, JobError};
use crate::Error;
use crate::io::{self, Recording};
use crate::model::Quantity;
use crate::report::summary::{
    Diagnosis, GearIndicators, MeshHarmonic, Shaft, ShaftHz, Sideband, SpeedProfile, SpeedSource, TeethSource,
    Tracking, Verdict, VerdictGear, VerdictState,
};
use crate::signal::indicators as ind;
use crate::signal::order_map::OrderMap;
use crate::signal::spectrum::Fft;
use crate::signal::tsa::{self, AngleMap, Decomposition};
use crate::signal::{angle, speed};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One `diagnose` call: recordings in time order, the shared options, an optional healthy baseline, an
/// optional comparison scene and an optional report directory.
#[derive(Clone, Debug, Default)]
pub struct DiagnoseJob<'a> {
    /// Recordings (.wav or .csv), in time order (NA4 uses that order).
    pub recordings: Vec<PathBuf>,
    /// Analysis options shared by all recordings and the baseline.
    pub options: Options,
    /// Healthy recordings of the same machine (files, or directories whose .wav and .csv files are taken in
    /// name order): the statistical baseline.
    pub baselines: Vec<PathBuf>,
    /// Scene simulated at each recording's speed and compared with it.
    pub scene: Option<PathBuf>,
    /// Directory for the PNG images and the JSON of each recording.
    pub report: Option<PathBuf>,
    /// Recordings already in memory (from the Python bindings), each with the name it is reported under;
    /// diagnosed after the files, as if they were files (`--unit`, `--sensitivity` and the channel choice
    /// apply alike). Their samples may be lent (`Cow::Borrowed`): they are read in place, never copied
    /// unless `--sensitivity` must scale them.
    pub in_memory: Vec<(PathBuf, Recording<'a>)>,
}

/// What [`run`] produced: one diagnosis per recording, in the order given, and the report files written.
#[derive(Clone, Debug)]
pub struct DiagnoseOutcome {
    /// Diagnoses in the order of the recordings.
    pub diagnoses: Vec<Diagnosis>,
    /// Report files written (empty without a report directory).
    pub report_files: Vec<PathBuf>,
}

/// Diagnoses every recording of `job`: the baseline first (its speed and mesh order are shared with the
/// recordings when they were estimated), the recordings in parallel, NA4 over the ensemble in time order,
/// the verdict of each against the baseline, the model comparison (the scene loaded once), and the report.
///
/// # Errors
/// Any recording, the baseline or the scene cannot be read or analysed; the report cannot be written.
pub fn run(job: &DiagnoseJob) -> Result<DiagnoseOutcome, Error> {
    let mut done = Vec::new();
    let reference = run_streaming(job, &mut |d| {
        done.push(d);
        Ok(())
    })?;
    let mut report_files = Vec::new();
    if let Some(dir) = &job.report {
        let mut sections = Vec::new();
        for d in &done {
            let files = write_report(d, dir)?;
            let images: Vec<PathBuf> =
                files.iter().filter(|f| f.extension().is_some_and(|e| e == "png")).cloned().collect();
            sections.push(crate::report::html::diagnosis_section(d, &images));
            report_files.extend(files);
        }
        if done.len() >= 2 && reference {
            let files = trend::write(dir, &done)?;
            sections.insert(
                0,
                crate::report::html::Section {
                    heading: format!("Trend over {} recordings (time order as given)", done.len()),
                    facts: vec!["Every scored indicator in spreads from the baseline's centre; the table is in trend.csv and trend.jsonl.".into()],
                    images: files.iter().filter(|f| f.extension().is_some_and(|e| e == "png")).cloned().collect(),
                    ..Default::default()
                },
            );
            report_files.extend(files);
        }
        report_files.push(crate::report::html::write(dir, "gearvib diagnosis", &sections)?);
    }
    Ok(DiagnoseOutcome { diagnoses: done, report_files })
}

/// The baseline side of a call, prepared once: options as fixed by the first baseline, the baselines'
/// diagnoses, what they fix for the recordings, the statistical reference and the comparison scene. A
/// caller that diagnoses recordings one call at a time against the same baseline (a Dask worker) prepares
/// it once with [`prepare`] and passes it to [`run_streaming_prepared`].
pub struct Prepared {
    opts: Options,
    baselines: Vec<Diagnosis>,
    geometry: Option<Geometry>,
    reference: Option<baseline::Reference>,
    scene: Option<compare::ModelScene>,
}

/// Prepares the baseline side of `job` (its recordings are not read).
///
/// # Errors
/// A baseline cannot be read or analysed, baselines that do not fit each other, too short a baseline, an
/// unreadable comparison scene.
pub fn prepare(job: &DiagnoseJob) -> Result<Prepared, Error> {
    let mut opts = job.options.clone();
    let baseline_files = expand_dirs(&job.baselines)?;
    // the first baseline fixes what was estimated (speed, mesh order) and the block length; the others
    // follow it
    let mut first = baseline_files.first().map(|b| diagnose(b, &opts, None)).transpose()?;
    if let (Some(b), None) = (&first, opts.block_revs) {
        let revs = b.gears.iter().map(|g| g.revolutions).min().unwrap_or(0) * baseline_files.len();
        let fit = auto_block_revs(revs);
        opts.block_revs = Some(fit);
        if fit != DEFAULT_BLOCK_REVS {
            first = Some(diagnose(&baseline_files[0], &opts, None)?);
        }
    }
    let geometry = first.as_ref().map(|b| Geometry {
        period_samples: (b.speed_source == SpeedSource::Estimated).then_some(b.shaft_period_samples),
        mesh_order: (b.teeth_source == TeethSource::Estimated).then_some(b.mesh_order),
        envelope_band: b.envelope.as_ref().map(|e| (e.band_hz[0], e.band_hz[1])),
    });
    let mut baselines: Vec<Diagnosis> = first.into_iter().collect();
    let rest: Vec<Result<Diagnosis, Error>> = baseline_files
        .iter()
        .skip(1)
        .collect::<Vec<_>>()
        .par_iter()
        .map(|b| diagnose(b, &opts, geometry.as_ref()))
        .collect();
    for b in rest {
        baselines.push(b?);
    }
    for b in baselines.iter().skip(1) {
        compatibility(b, &baselines[0])?;
    }
    let reference = (!baselines.is_empty()).then(|| baseline::build(&baselines, opts.block_revs())).transpose()?;
    let scene = job.scene.as_deref().map(compare::ModelScene::load).transpose()?;
    Ok(Prepared { opts, baselines, geometry, reference, scene })
}

/// Recordings diagnosed at once by [`run_streaming`]: enough to keep every core busy, few enough that a
/// directory of any size needs the memory of this many diagnoses.
fn chunk_size() -> usize {
    2 * rayon::current_num_threads().max(1)
}

/// [`run`] without the report: each diagnosis is handed to `emit` as soon as it and every recording before
/// it are judged (time order kept; NA4 over the ensemble carried from one to the next), so a directory of
/// any size runs in bounded memory. Returns whether a statistical baseline was used.
///
/// # Errors
/// As [`run`], or what `emit` returns.
pub fn run_streaming(job: &DiagnoseJob, emit: &mut dyn FnMut(Diagnosis) -> Result<(), Error>) -> Result<bool, Error> {
    crate::io::begin_run();
    let p = prepare(job)?;
    run_streaming_prepared(job, &p, emit)
}

/// [`run_streaming`] with the baseline side already prepared (by [`prepare`] of a job with the same
/// options, baselines and scene; `job`'s own are not read again).
///
/// # Errors
/// As [`run_streaming`].
pub fn run_streaming_prepared(
    job: &DiagnoseJob,
    p: &Prepared,
    emit: &mut dyn FnMut(Diagnosis) -> Result<(), Error>,
) -> Result<bool, Error> {
    let recordings = expand_dirs(&job.recordings)?;
    let mut history = verdict::Na4History::default();
    for chunk in recordings.chunks(chunk_size()) {
        let results: Vec<Result<Diagnosis, Error>> =
            chunk.par_iter().map(|r| diagnose(r, &p.opts, p.geometry.as_ref())).collect();
        for d in results {
            emit(finish(d?, p, &mut history, job.report.is_some())?)?;
        }
    }
    for (name, rec) in &job.in_memory {
        let d = diagnose_in_memory(name, rec.lent(), &p.opts, p.geometry.as_ref())?;
        emit(finish(d, p, &mut history, job.report.is_some())?)?;
    }
    Ok(p.reference.is_some())
}

/// Judges one diagnosis (the next in time order): against the baseline when there is one, NA4 over the
/// ensemble so far, the envelope's evidence, the operating-point cap, the model comparison.
fn finish(mut d: Diagnosis, p: &Prepared, history: &mut verdict::Na4History, report: bool) -> Result<Diagnosis, Error> {
    let mut cap = None;
    if let Some(b) = p.baselines.first() {
        let c = compatibility(&d, b)?;
        d.warnings.extend(c.warnings);
        cap = c.operating_point;
        if report {
            d.baseline_spectra = b.spectra.clone();
            d.baseline_tsas = b.gears.iter().map(|g| (g.channel, g.gear, g.tsa.clone())).collect();
        }
    }
    history.apply(&mut d);
    judge(&mut d, p.reference.as_ref(), &Thresholds::default());
    if let Some(e) = p.baselines.first().and_then(|b| b.envelope.as_ref()) {
        verdict::envelope_evidence(&mut d, e);
    }
    if let Some(why) = cap {
        verdict::cap_at_suspect(&mut d, why);
    }
    if let Some(s) = &p.scene {
        let quantity = match p.opts.quantity.or_else(|| Quantity::from_unit(&d.unit)) {
            Some(q) => q,
            None => {
                d.warnings.push(format!(
                    "the recording's unit ({}) does not say what it measures: taken as velocity for the model comparison; give --quantity",
                    if d.unit.is_empty() { "none" } else { &d.unit }
                ));
                Quantity::Velocity
            }
        };
        compare(&mut d, s, quantity)?;
    }
    Ok(d)
}

/// Revolutions per baseline block unless given: 8, or fewer (down to 2) when the baseline would otherwise
/// give fewer than [`baseline::MIN_BASELINE_BLOCKS`] blocks. Fewer revolutions per block make noisier
/// indicators on both sides alike (the recording is scored on blocks of the same length).
pub const DEFAULT_BLOCK_REVS: usize = 8;

fn auto_block_revs(baseline_revs: usize) -> usize {
    (2..=DEFAULT_BLOCK_REVS)
        .rev()
        .find(|r| baseline_revs / r >= 2 * baseline::MIN_BASELINE_BLOCKS)
        .or_else(|| (2..=DEFAULT_BLOCK_REVS).rev().find(|r| baseline_revs / r >= baseline::MIN_BASELINE_BLOCKS))
        .unwrap_or(2)
}

/// Files of `paths`, directories replaced by their .wav and .csv files in name order.
///
/// # Errors
/// A directory that cannot be read or holds no recording.
fn expand_dirs(paths: &[PathBuf]) -> Result<Vec<PathBuf>, Error> {
    let mut out = Vec::new();
    for p in paths {
        if !p.is_dir() {
            out.push(p.clone());
            continue;
        }
        let mut files: Vec<PathBuf> = std::fs::read_dir(p)
            .map_err(|e| bad(p, format!("cannot read the directory: {e}")))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|f| {
                f.extension()
                    .and_then(|x| x.to_str())
                    .is_some_and(|x| x.eq_ignore_ascii_case("wav") || x.eq_ignore_ascii_case("csv"))
            })
            .collect();
        files.sort();
        if files.is_empty() {
            return Err(bad(p, "the directory holds no .wav or .csv recording"));
        }
        out.extend(files);
    }
    Ok(out)
}

/// Writes `DIR/<stem>-diagnosis.json` and the diagnosis images of `d`.
///
/// # Errors
/// The directory cannot be created or a file cannot be written.
pub fn write_report(d: &Diagnosis, dir: &Path) -> Result<Vec<PathBuf>, Error> {
    io::create_dir(dir)?;
    let stem = Path::new(&d.file).file_stem().and_then(|s| s.to_str()).unwrap_or("recording").to_string();
    io::write_atomic(&dir.join(format!("{stem}-diagnosis.json")), crate::report::summary::to_json_line(d).as_bytes())?;
    Ok(crate::report::figures::diagnosis(d, dir)?)
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
            fs_unknown: false,
            shaft_hz: None,
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
        }
    }
}

fn bad(path: &Path, msg: impl std::fmt::Display) -> Error {
    JobError::Input { file: path.display().to_string(), message: msg.to_string() }.into()
}

/// Speed and gear geometry shared by all recordings of one call (from the options, the baseline or the
/// first recording).
#[derive(Clone, Debug)]
pub struct Geometry {
    /// Shaft period in samples, when known from the baseline.
    pub period_samples: Option<f64>,
    /// Mesh order, when known.
    pub mesh_order: Option<usize>,
    /// The baseline's envelope band in Hz: recordings are demodulated in the same band, so their envelope
    /// lines compare with the baseline's.
    pub envelope_band: Option<(f64, f64)>,
}

/// Diagnoses one recording.
///
/// # Errors
/// Unreadable file, bad channel or sample rate, constant or non-finite data, too short for the TSA.
pub fn diagnose(path: &Path, o: &Options, geometry: Option<&Geometry>) -> Result<Diagnosis, Error> {
    // with one channel asked for, only it and the tachometer are decoded (a long multi-channel WAV then
    // needs the memory of those channels alone); without, the sidecar's pulse channels that are not the
    // tachometer in use are not decoded either (they are never analysed as vibration)
    let sidecar = io::sidecar::read(path);
    let sidecar_tacho = (o.tacho_channel.is_none() && o.shaft_hz.is_none())
        .then_some(sidecar.as_ref())
        .flatten()
        .and_then(|side| side.channels.iter().position(|c| c.name == PINION_TACHO).map(|i| i + 1));
    let tacho = o.tacho_channel.or(sidecar_tacho);
    let keep: Option<Vec<usize>> = match (o.channel, &sidecar) {
        (Some(c), _) => Some(std::iter::once(c).chain(tacho).map(|c| c.saturating_sub(1)).collect()),
        (None, Some(side)) if side.channels.iter().any(|c| c.name.starts_with("tacho")) => Some(
            (0..side.channels.len())
                .filter(|&i| Some(i + 1) == tacho || !side.channels[i].name.starts_with("tacho"))
                .collect(),
        ),
        (None, _) => None,
    };
    let mut rec = io::read_recording_channels(path, keep.as_deref())?;
    apply_units(&mut rec, o, tacho);
    analyse(path, rec, &Options { tacho_channel: tacho, ..o.clone() }, geometry)
}

/// Diagnoses a recording held in memory under `name` (no sidecar: a tachometer channel must be named by
/// `tacho_channel`).
///
/// # Errors
/// As [`diagnose`], without the reading.
pub fn diagnose_in_memory(
    name: &Path,
    mut rec: Recording,
    o: &Options,
    geometry: Option<&Geometry>,
) -> Result<Diagnosis, Error> {
    apply_units(&mut rec, o, o.tacho_channel);
    analyse(name, rec, o, geometry)
}

/// `--sensitivity` (samples divided by it) and `--unit` (for channels whose file names no unit, or for all
/// with a sensitivity) applied to every channel but the tachometer.
fn apply_units(rec: &mut Recording, o: &Options, tacho: Option<usize>) {
    for (i, (x, unit)) in rec.channels.iter_mut().zip(rec.units.iter_mut()).enumerate() {
        if Some(i + 1) == tacho || unit == "pulse" {
            continue;
        }
        if let Some(s) = o.sensitivity {
            let k = (1.0 / s) as f32;
            x.to_mut().iter_mut().for_each(|v| *v *= k);
        }
        // a sensitivity turns the recorded unit (volts) into the physical one: --unit then names it
        if unit.is_empty() || o.sensitivity.is_some() {
            if let Some(u) = &o.unit {
                unit.clone_from(u);
            }
        }
    }
}

/// Name of the pinion's tachometer channel in gearvib's sidecar: used for the speed when no speed and no
/// tachometer channel are given.
pub const PINION_TACHO: &str = "tacho pinion";

/// True when a channel holds at most two distinct levels over its first 200 000 samples: a tachometer
/// pulse train, never a vibration signal.
fn looks_like_pulses(x: &[f32]) -> bool {
    let mut levels: Vec<u32> = Vec::with_capacity(3);
    for v in x.iter().take(200_000) {
        let b = v.to_bits();
        if !levels.contains(&b) {
            levels.push(b);
            if levels.len() > 2 {
                return false;
            }
        }
    }
    levels.len() == 2
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

/// Fewest samples per shaft revolution a TSA can use (the resampling keeps at least 64 points).
pub const MIN_SAMPLES_PER_REV: f64 = 64.0;

/// A given shaft speed must fit the recording: enough samples per revolution, enough revolutions. Checked
/// before anything is sized from it.
fn check_given_speed(path: &Path, hz: f64, fs: f64, n: usize, min_revs: usize) -> Result<(), Error> {
    let per_rev = fs / hz;
    if per_rev.is_nan() || per_rev < MIN_SAMPLES_PER_REV {
        return Err(JobError::Value {
            what: "shaft speed".into(),
            message: format!(
                "{hz:.6e} Hz gives {per_rev:.3e} samples per revolution at the {fs} Hz sample rate of {}; at least {MIN_SAMPLES_PER_REV} are needed: the speed is far too high for this recording (rpm given as Hz?)",
                path.display()
            ),
        }
        .into());
    }
    let revs = n as f64 / per_rev;
    if revs < min_revs as f64 {
        return Err(JobError::Value {
            what: "shaft speed".into(),
            message: format!(
                "{hz:.6} Hz gives only {revs:.2} revolutions in the {n} samples of {}; the time-synchronous average needs at least {min_revs}: is the speed too low, or the recording too short?",
                path.display()
            ),
        }
        .into());
    }
    Ok(())
}

/// Accepted sample rates, Hz: from sub-hertz loggers to the fastest vibration front ends.
pub const SAMPLE_RATE_RANGE_HZ: (f64, f64) = (0.1, 100e6);

fn sample_rate(path: &Path, rec: &Recording, o: &Options) -> Result<Option<f64>, Error> {
    if let Some(fs) = o.fs_hz {
        let (lo, hi) = SAMPLE_RATE_RANGE_HZ;
        if !(fs.is_finite() && (lo..=hi).contains(&fs)) {
            return Err(JobError::Value {
                what: "sample rate".into(),
                message: format!("must be between {lo} Hz and {hi:e} Hz, got {fs:e} Hz"),
            }
            .into());
        }
        return Ok(Some(fs));
    }
    match rec.sample_rate_hz {
        Some(fs) if fs > 0.0 => Ok(Some(fs)),
        Some(fs) => Err(bad(path, format!("sample rate {fs} Hz is not positive; give the sample rate"))),
        None if o.fs_unknown => Ok(None),
        None => Err(JobError::NoSampleRate { file: path.display().to_string(), for_speed: false }.into()),
    }
}

fn analyse(path: &Path, mut rec: Recording, o: &Options, geometry: Option<&Geometry>) -> Result<Diagnosis, Error> {
    let nch = rec.channels.len();
    let check_index = |role: ChannelRole, c: usize| -> Result<usize, Error> {
        if c == 0 || c > nch {
            Err(JobError::Channel { file: path.display().to_string(), role, index: c, count: nch }.into())
        } else {
            Ok(c)
        }
    };
    let tacho = o.tacho_channel.map(|c| check_index(ChannelRole::Tachometer, c)).transpose()?;
    let mut warnings = Vec::new();
    let channels: Vec<usize> = match o.channel {
        Some(c) => {
            let c = check_index(ChannelRole::Vibration, c)?;
            if Some(c) == tacho {
                return Err(bad(
                    path,
                    format!(
                        "channel {c} is the tachometer channel: it gives the speed and cannot also be analysed as vibration"
                    ),
                ));
            }
            if looks_like_pulses(&rec.channels[c - 1]) {
                return Err(bad(
                    path,
                    format!(
                        "channel {c} holds two levels only, a tachometer pulse train: it is not analysed as vibration"
                    ),
                ));
            }
            vec![c]
        }
        // channels named as tachometers (gearvib's sidecar) or holding two levels are never vibration
        None => (1..=nch)
            .filter(|c| Some(*c) != tacho && !rec.names[c - 1].starts_with("tacho"))
            .filter(|&c| {
                let pulses = looks_like_pulses(&rec.channels[c - 1]);
                if pulses {
                    warnings
                        .push(format!("channel {c} holds two levels only (a pulse train): not analysed as vibration"));
                }
                !pulses
            })
            .collect(),
    };
    let n = rec.channels.iter().map(|c| c.len()).max().unwrap_or(0);
    if nch == 0 || n < 2 {
        return Err(bad(path, format!("{n} sample(s): far too short to analyse")));
    }
    let fs = sample_rate(path, &rec, o)?;
    if channels.is_empty() {
        return Err(bad(path, "no channel left to analyse besides the tachometer"));
    }
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
    let nominal = nominal_speed(path, &rec, &channels, o, fs, geometry, &mut fft, &mut warnings)?;
    let (source, confidence) = (nominal.source, nominal.confidence);
    let nominal_mesh_from_lag = nominal.mesh_order.is_some();
    let known_z = o.teeth.map(|t| t.0).or_else(|| geometry.and_then(|g| g.mesh_order)).or(nominal.mesh_order);
    let (map, tracking, line_snr_db, tracked_z) = track(path, &rec, &channels, o, known_z, nominal.map, &mut warnings)?;
    // the tachometer's pulses are in the angle map now and are never analysed: free them
    if let Some(t) = tacho {
        rec.channels[t - 1] = std::borrow::Cow::Borrowed(&[]);
    }
    let profile = angle::SpeedProfile::of(&map);
    if let (Some(hz), Some(fs), Tracking::MeshPhase) = (o.shaft_hz, fs, tracking) {
        let off = profile.mean * fs / hz - 1.0;
        if off.abs() > 0.01 {
            warnings.push(format!(
                "the given speed {hz:.4} Hz differs by {:+.2} % from the speed tracked on the mesh line ({:.4} Hz): the tracked speed is used; check the given speed",
                100.0 * off,
                profile.mean * fs
            ));
        }
    }
    let speed_profile = SpeedProfile {
        tracking,
        mean_hz: fs.map(|f| f * profile.mean),
        min_hz: fs.map(|f| f * profile.min),
        max_hz: fs.map(|f| f * profile.max),
        change_percent: 100.0 * profile.change,
        line_snr_db,
    };
    let period = map.mean_period_samples();
    let points = tsa_points(period);
    // ---- TSA of the reference shaft first (needed to find the mesh when teeth are unknown)
    let gears: Vec<(Shaft, f64, Option<usize>)> = match o.teeth {
        Some((zp, zw)) => vec![(Shaft::Pinion, 1.0, Some(zp)), (Shaft::Wheel, zp as f64 / zw as f64, Some(zw))],
        None => vec![(Shaft::Estimated, 1.0, geometry.and_then(|g| g.mesh_order).or(tracked_z))],
    };
    // one TSA per channel and gear, in parallel
    let jobs: Vec<(usize, usize)> = channels.iter().flat_map(|&c| (0..gears.len()).map(move |gi| (c, gi))).collect();
    let tsas = jobs
        .par_iter()
        .map(|&(c, gi)| {
            tsa::tsa_with_blocks(&rec.channels[c - 1], &map, gears[gi].1, points, o.min_revolutions, o.block_revs())
                .map(|(t, blocks)| (c, gi, t, blocks))
                .map_err(|e| bad(path, e))
        })
        .collect::<Result<Vec<_>, Error>>()?;
    let mut teeth_source = match (o.teeth, geometry.and_then(|g| g.mesh_order)) {
        (Some(_), _) => TeethSource::Given,
        (None, Some(_)) => TeethSource::Baseline,
        (None, None) => TeethSource::Estimated,
    };
    if teeth_source == TeethSource::Estimated && tracked_z.is_some() {
        warnings.push(format!(
            "mesh order {} estimated ({}); give the teeth when known",
            tracked_z.unwrap_or(0),
            if nominal_mesh_from_lag {
                "repetition period over the mesh period"
            } else {
                "strongest harmonic family of the TSA spectrum"
            }
        ));
    }
    let mut pending = Vec::new();
    let mut mesh_orders = Vec::new();
    for (gi, (name, _, known)) in gears.iter().enumerate() {
        let z = match known {
            Some(z) => *z,
            None => {
                let z = mesh_family(&mut fft, tsas.iter().filter(|t| t.1 == gi).map(|t| t.2.samples.as_slice()));
                teeth_source = TeethSource::Estimated;
                warnings.push(format!(
                    "mesh order {z} estimated from the strongest harmonic family of the TSA spectrum; give the teeth when known"
                ));
                z
            }
        };
        if z * 2 + 8 > points / 2 {
            return Err(bad(
                path,
                format!(
                    "mesh order {z} needs more than {points} samples per revolution of the {name}: the shaft speed ({}) is too high for the sample rate, or the teeth are wrong",
                    match source {
                        SpeedSource::Estimated => "estimated; give --rpm",
                        SpeedSource::Given => "given",
                        SpeedSource::Tachometer => "from the tachometer",
                    }
                ),
            ));
        }
        if o.teeth.is_some() {
            if let Some(w) = teeth_misfit(tsas.iter().filter(|t| t.1 == gi).map(|t| t.2.samples.as_slice()), z, *name) {
                warnings.push(w);
            }
        }
        if let (Some((zp, zw)), Shaft::Wheel) = (o.teeth, *name) {
            if zp == zw {
                warnings.push(format!(
                    "--teeth {zp},{zw}: with equal teeth the gears turn together, so their averages are the same signal and a fault cannot be told to be on the pinion or the wheel; check --teeth"
                ));
            }
        }
        mesh_orders.push(z);
        for (c, _, t, blocks) in tsas.iter().filter(|t| t.1 == gi) {
            pending.push((*name, *c, z, t, blocks));
        }
    }
    // the given wheel teeth checked against its sidebands on the pinion's angle
    if let (Some(&zp), Some((_, zw))) = (mesh_orders.first(), o.teeth) {
        warnings.extend(wheel_teeth(&mut fft, &rec.channels[channels[0] - 1], &map, zp, zw));
    }
    let gear_results: Vec<GearIndicators> = pending
        .par_iter()
        .map(|&(name, c, z, t, blocks)| {
            let mut fft = Fft::new();
            let mut g = gear_indicators(&mut fft, name, c, z, t, o.shaft_orders);
            g.blocks = block_indicators(&mut fft, blocks, z, o.shaft_orders);
            g
        })
        .collect();
    // the averages and their blocks are in the indicators now: free them before the spectra
    drop(pending);
    drop(tsas);
    // ---- spectra and mesh harmonics (deciding channel chosen later: use the first for now). The envelope
    // band of that channel is chosen first, so that the amplitude spectrum's segments also give its envelope.
    let shaft_hz = fs.map(|fs| fs / period);
    let ratios: Vec<(Shaft, f64)> = gears.iter().map(|g| (g.0, g.1)).collect();
    let choice =
        BandChoice { levels: o.kurtogram_levels, band: o.envelope_band.or(geometry.and_then(|g| g.envelope_band)) };
    let first = channels[0];
    let mut plan = match (fs, o.lifter) {
        (Some(fs), None) => Some(envelope_plan(&mut fft, &rec.channels[first - 1], fs, &map, mesh_orders[0], choice)),
        _ => None,
    };
    let ola = std::sync::Mutex::new(match &mut plan {
        Some(Ok((_, ola))) => ola.take(),
        _ => None,
    });
    let spectra = match fs {
        Some(fs) => channels
            .par_iter()
            .map(|&c| {
                let ola = if c == first { ola.lock().map(|mut o| o.take()).unwrap_or(None) } else { None };
                channel_spectra(&mut Fft::new(), &rec.channels[c - 1], fs, ola)
                    .map(|s| (c, s))
                    .map_err(|e| bad(path, e))
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
    let shafts = match o.teeth {
        Some((zp, zw)) => ShaftHz::Pair { pinion: shaft_hz, wheel: shaft_hz.map(|f| f * zp as f64 / zw as f64) },
        None => ShaftHz::Estimated { estimated_shaft: shaft_hz },
    };
    let mut deciding = None;
    let spectra = spectra
        .into_iter()
        .map(|(c, s)| {
            if c == first {
                deciding = Some((s.power, s.segment, s.envelope));
            }
            (c, s.amplitude)
        })
        .collect();
    let mut d = Diagnosis {
        file: path.display().to_string(),
        sample_rate_hz: fs,
        samples: n,
        channels: channels.clone(),
        shaft_hz: shafts,
        shaft_period_samples: period,
        speed_source: source,
        speed_confidence: confidence,
        speed_profile,
        mesh_hz: shaft_hz.map(|f| f * mesh_orders[0] as f64),
        mesh_order: mesh_orders[0],
        teeth_source,
        mesh_harmonics: Vec::new(),
        indicators: BTreeMap::new(),
        gears: gear_results,
        raw,
        verdict: Verdict { state: VerdictState::Healthy, gear: VerdictGear::None, reasons: Vec::new() },
        comparison: None,
        envelope: None,
        cepstrum: None,
        scores: Vec::new(),
        unit: rec.units.get(channels[0] - 1).cloned().unwrap_or_default(),
        warnings,
        spectra,
        baseline_spectra: Vec::new(),
        baseline_tsas: Vec::new(),
        order_map: None,
    };
    d.mesh_harmonics = mesh_harmonics(&d, channels[0], &ratios);
    if let Some(g) = d.gears.first() {
        d.indicators = g.indicators.clone();
    }
    if let Some(fs) = fs {
        let x = &rec.channels[first - 1];
        let result = match (o.lifter, plan) {
            (Some(shaft), _) => {
                let ratio = ratios.iter().find(|r| r.0 == shaft).map(|r| r.1).ok_or_else(|| {
                    bad(path, format!("cannot lifter the {shaft} family: give the teeth so that its speed is known"))
                })?;
                let y =
                    crate::signal::envelope::lifter_comb(&mut fft, x, period / ratio, 1).map_err(|e| bad(path, e))?;
                envelope_plan(&mut fft, &y, fs, &map, d.mesh_order, choice).and_then(|(band, ola)| {
                    let (e, r) = envelope_of(&mut fft, &y, fs, &band, ola)?;
                    Ok(envelope(&mut fft, band, &e, r, fs, &map, &ratios))
                })
            }
            (None, Some(Ok((band, _)))) => match deciding.as_ref().and_then(|s| s.2.as_ref()) {
                Some((e, r)) => Ok(envelope(&mut fft, band, e, *r, fs, &map, &ratios)),
                None => envelope_of(&mut fft, x, fs, &band, None)
                    .map(|(e, r)| envelope(&mut fft, band, &e, r, fs, &map, &ratios)),
            },
            (None, Some(Err(e))) => Err(e),
            (None, None) => unreachable!("a sample rate without a lifter always plans the envelope"),
        };
        match result.map(|mut e| {
            e.liftered = o.lifter;
            e
        }) {
            Ok(e) => d.envelope = Some(e),
            // a band or level the user asked for that does not fit is an error; the automatic choice
            // failing on a short recording is a warning
            Err(e) if o.envelope_band.is_some() || o.kurtogram_levels.is_some() => return Err(bad(path, e)),
            Err(e) => d.warnings.push(format!("no envelope analysis: {e}")),
        }
        let power = deciding.as_ref().map(|s| (s.0.as_slice(), s.1));
        d.cepstrum = cepstrum(&mut fft, x, power, fs, period, &ratios);
    }
    if (profile.max - profile.min) > ORDER_MAP_SPEED_CHANGE * profile.mean {
        d.order_map = order_map(&mut fft, &rec.channels[channels[0] - 1], &map, d.mesh_order);
    }
    Ok(d)
}

/// Points per revolution of a TSA: the revolution's samples rounded up to a power of two (64 ..= 65536).
fn tsa_points(period: f64) -> usize {
    (period.ceil() as usize).next_power_of_two().clamp(64, 1 << 16)
}

fn gear_indicators(
    fft: &mut Fft,
    gear: Shaft,
    channel: usize,
    z: usize,
    t: &tsa::Tsa,
    shaft_orders: usize,
) -> GearIndicators {
    let (indicators, d) = tsa_indicators(fft, &t.samples, z, shaft_orders);
    GearIndicators {
        gear,
        channel,
        mesh_order: z,
        revolutions: t.revolutions,
        indicators,
        residual: d.residual,
        difference: d.difference,
        tsa_amplitudes: d.amplitudes,
        tsa: t.samples.clone(),
        blocks: Vec::new(),
    }
}

/// The condition indicators of one TSA of a gear with mesh order `z`, and its decomposition.
fn tsa_indicators(fft: &mut Fft, x: &[f64], z: usize, shaft_orders: usize) -> (BTreeMap<String, f64>, Decomposition) {
    let d = tsa::decompose(fft, x, z, shaft_orders);
    let Decomposition { amplitudes, regular, residual, difference } = &d;
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
    m.insert("fm4".into(), ind::normalized_moment(difference, 4));
    m.insert("m6a".into(), ind::normalized_moment(difference, 6));
    m.insert("m8a".into(), ind::normalized_moment(difference, 8));
    m.insert("na4".into(), ind::kurtosis(residual));
    m.insert("er".into(), ind::energy_ratio(difference, regular));
    m.insert("si".into(), side / 2.0);
    m.insert("slf".into(), side / ind::rms(&centred));
    m.insert("ser".into(), ind::sideband_energy_ratio(amplitudes, z, 1));
    (m, d)
}

/// Indicators of the block averages of a gear (consecutive blocks of whole revolutions; the statistical
/// baseline's samples; a recording under test is scored by the median of its own blocks, so both sides
/// average the same number of revolutions).
fn block_indicators(
    fft: &mut Fft,
    blocks: &[Vec<f64>],
    z: usize,
    shaft_orders: usize,
) -> Vec<crate::report::summary::Block> {
    blocks
        .iter()
        .map(|t| {
            let (mut indicators, d) = tsa_indicators(fft, t, z, shaft_orders);
            let n = d.residual.len() as f64;
            let mean = d.residual.iter().sum::<f64>() / n;
            indicators.insert("residual_m2".into(), d.residual.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n);
            indicators.insert("residual_m4".into(), d.residual.iter().map(|v| (v - mean).powi(4)).sum::<f64>() / n);
            crate::report::summary::Block { indicators, amplitudes: d.amplitudes }
        })
        .collect()
}

/// Mesh harmonics and sidebands (3 per shaft on each side) from the raw amplitude spectrum when the
/// sample rate is known, else from the reference TSA's order spectrum.
fn mesh_harmonics(d: &Diagnosis, channel: usize, shafts: &[(Shaft, f64)]) -> Vec<MeshHarmonic> {
    let z = d.mesh_order as f64;
    let spectrum = d.spectra.iter().find(|s| s.0 == channel).map(|s| &s.1);
    let tsa_amps = d.gears.iter().find(|g| g.channel == channel).map(|g| &g.tsa_amplitudes);
    let shaft_hz = d.shaft_hz.reference();
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
                    let (ff, a) = s.hann_line_near(f, 1.5 * df)?;
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
        for &(name, ratio) in shafts {
            for i in 1..=3i32 {
                for sign in [-1, 1] {
                    let o = order + f64::from(sign * i) * ratio;
                    if let Some((ff, aa)) = read(o) {
                        sidebands.push(Sideband {
                            offset: sign * i,
                            shaft: name,
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
        // (shaft, order); `None` marks the mesh line itself
        let nominal: Vec<(Option<Shaft>, f64)> = shafts
            .iter()
            .flat_map(|&(name, ratio)| {
                (1..=3).flat_map(move |i| [-1.0, 1.0].map(|sg| (Some(name), order + sg * f64::from(i) * ratio)))
            })
            .chain(std::iter::once((None, order)))
            .collect();
        for sb in &mut sidebands {
            sb.resolved = !nominal.iter().any(|(name, o)| *name != Some(sb.shaft) && (o - sb.order).abs() < resolution);
        }
        out.push(MeshHarmonic { k, frequency_hz: f, order, amplitude: a, sidebands });
    }
    out
}
