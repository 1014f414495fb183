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
mod compare;
pub mod trend;
mod verdict;

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
use crate::signal::spectrum::{AmplitudeOptions, Fft, amplitude_spectrum, welch_psd};
use crate::signal::tsa::{self, AngleMap, Decomposition};
use crate::signal::{angle, speed};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One `diagnose` call: recordings in time order, the shared options, an optional healthy baseline, an
/// optional comparison scene and an optional report directory.
#[derive(Clone, Debug, Default)]
pub struct DiagnoseJob {
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
    /// apply alike).
    pub in_memory: Vec<(PathBuf, Recording)>,
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
/// diagnoses, what they fix for the recordings, the statistical reference and the comparison scene.
struct Prepared {
    opts: Options,
    baselines: Vec<Diagnosis>,
    geometry: Option<Geometry>,
    reference: Option<baseline::Reference>,
    scene: Option<compare::ModelScene>,
}

fn prepare(job: &DiagnoseJob) -> Result<Prepared, Error> {
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
    let recordings = expand_dirs(&job.recordings)?;
    let mut history = verdict::Na4History::default();
    for chunk in recordings.chunks(chunk_size()) {
        let results: Vec<Result<Diagnosis, Error>> =
            chunk.par_iter().map(|r| diagnose(r, &p.opts, p.geometry.as_ref())).collect();
        for d in results {
            emit(finish(d?, &p, &mut history, job.report.is_some())?)?;
        }
    }
    for (name, rec) in &job.in_memory {
        let d = diagnose_in_memory(name, rec.clone(), &p.opts, p.geometry.as_ref())?;
        emit(finish(d, &p, &mut history, job.report.is_some())?)?;
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
            d.baseline_spectra = b.spectra.iter().map(|(ch, amp, _)| (*ch, amp.clone())).collect();
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

/// Relative speed difference from the baseline beyond which a recording is refused: indicators change with
/// speed (resonances move against the mesh orders), so a baseline at another speed is another machine state.
pub const MAX_SPEED_DIFFERENCE: f64 = 0.10;
/// Relative speed difference from the baseline that is warned about.
pub const WARN_SPEED_DIFFERENCE: f64 = 0.03;

/// Relative speed difference from the baseline above which the operating point is taken to differ: 20
/// times the drift of a speed-controlled rig (100 ppm); an induction motor slows by about 0.4 % from no
/// load to 90 % load on the SpectraQuest rig of `data/realdata`, while a broken tooth changes its speed by
/// less than 0.05 %.
pub const OPERATING_POINT_SPEED_DIFFERENCE: f64 = 0.002;

/// What [`compatibility`] found.
#[derive(Clone, Debug, Default)]
pub struct Compatibility {
    /// Warnings for the recording.
    pub warnings: Vec<String>,
    /// Why the operating point differs from the baseline's (the verdict then stays at most suspect).
    pub operating_point: Option<String>,
}

/// Checks that `d` and the baseline `b` come from the same machine and operating point: same unit and
/// channels (refused), speed within [`MAX_SPEED_DIFFERENCE`] (refused beyond, warned beyond
/// [`WARN_SPEED_DIFFERENCE`], operating point taken as different beyond
/// [`OPERATING_POINT_SPEED_DIFFERENCE`]), sample rate and overall level (warned).
///
/// # Errors
/// An incompatible baseline, naming both files and what differs.
pub fn compatibility(d: &Diagnosis, b: &Diagnosis) -> Result<Compatibility, Error> {
    let refuse = |what: String| -> Error {
        JobError::Value {
            what: "baseline".into(),
            message: format!("{} is not comparable with {}: {what}", b.file, d.file),
        }
        .into()
    };
    let mut warnings = Vec::new();
    if !d.unit.is_empty() && !b.unit.is_empty() && d.unit != b.unit {
        return Err(refuse(format!("it is in {} and the recording in {}", b.unit, d.unit)));
    }
    if let Some(c) = d.channels.iter().find(|c| !b.channels.contains(c)) {
        return Err(refuse(format!(
            "the recording's channel {c} is not among the baseline's analysed channels {:?}",
            b.channels
        )));
    }
    let speed = |x: &Diagnosis| x.speed_profile.mean_hz.unwrap_or(1.0 / x.shaft_period_samples);
    let ratio = speed(d) / speed(b) - 1.0;
    if ratio.abs() > MAX_SPEED_DIFFERENCE {
        return Err(refuse(format!(
            "its shaft speed differs by {:+.1} % (at most {} % is accepted: another operating point)",
            -100.0 * ratio / (1.0 + ratio),
            100.0 * MAX_SPEED_DIFFERENCE
        )));
    }
    if ratio.abs() > WARN_SPEED_DIFFERENCE {
        warnings.push(format!(
            "the shaft speed differs from the baseline's by {:+.1} %: indicators that depend on speed may move",
            100.0 * ratio
        ));
    }
    let operating_point = (ratio.abs() > OPERATING_POINT_SPEED_DIFFERENCE).then(|| {
        format!(
            "the shaft runs {:.2} % {} than in the baseline ({} ppm is normal drift): a different load or operating point, which changes the vibration by itself; a fault is judged only against a baseline at the same operating point, so this verdict is at most suspect",
            100.0 * ratio.abs(),
            if ratio > 0.0 { "faster" } else { "slower" },
            (OPERATING_POINT_SPEED_DIFFERENCE * 1e6 / 20.0) as u32
        )
    });
    if let (Some(fd), Some(fb)) = (d.sample_rate_hz, b.sample_rate_hz) {
        if (fd / fb - 1.0).abs() > 1e-3 {
            warnings.push(format!("the baseline was sampled at {fb} Hz and this recording at {fd} Hz: the orders are compared, the raw spectra differ"));
        }
    }
    for (i, c) in d.channels.iter().enumerate() {
        let j = b.channels.iter().position(|x| x == c);
        let level = |x: &Diagnosis, k: usize| x.raw.get(k).and_then(|m| m.get("rms")).copied().unwrap_or(f64::NAN);
        if let Some(j) = j {
            let r = level(d, i) / level(b, j);
            if !(0.5..=2.0).contains(&r) {
                warnings.push(format!(
                    "channel {c}: the overall level is {r:.2} times the baseline's: the operating condition (load) may differ, and the indicators that scale with it move too"
                ));
            }
        }
    }
    Ok(Compatibility { warnings, operating_point })
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
    // needs the memory of those channels alone)
    let sidecar_tacho = (o.tacho_channel.is_none() && o.shaft_hz.is_none())
        .then(|| io::sidecar::read(path))
        .flatten()
        .and_then(|side| side.channels.iter().position(|c| c.name == PINION_TACHO).map(|i| i + 1));
    let tacho = o.tacho_channel.or(sidecar_tacho);
    let keep: Option<Vec<usize>> =
        o.channel.map(|c| std::iter::once(c).chain(tacho).map(|c| c.saturating_sub(1)).collect());
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
            x.iter_mut().for_each(|v| *v *= k);
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

fn analyse(path: &Path, rec: Recording, o: &Options, geometry: Option<&Geometry>) -> Result<Diagnosis, Error> {
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
    let n = rec.channels.iter().map(Vec::len).max().unwrap_or(0);
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
        mesh_orders.push(z);
        for (c, _, t, blocks) in tsas.iter().filter(|t| t.1 == gi) {
            pending.push((*name, *c, z, t, blocks));
        }
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
    let shafts = match o.teeth {
        Some((zp, zw)) => ShaftHz::Pair { pinion: shaft_hz, wheel: shaft_hz.map(|f| f * zp as f64 / zw as f64) },
        None => ShaftHz::Estimated { estimated_shaft: shaft_hz },
    };
    let ratios: Vec<(Shaft, f64)> = gears.iter().map(|g| (g.0, g.1)).collect();
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
        let x = &rec.channels[channels[0] - 1];
        let baseline_band = geometry.and_then(|g| g.envelope_band);
        let band = o.envelope_band.or(baseline_band);
        let choice = BandChoice { levels: o.kurtogram_levels, band };
        let result = match o.lifter {
            Some(shaft) => {
                let ratio = ratios.iter().find(|r| r.0 == shaft).map(|r| r.1).ok_or_else(|| {
                    bad(path, format!("cannot lifter the {shaft} family: give the teeth so that its speed is known"))
                })?;
                let y =
                    crate::signal::envelope::lifter_comb(&mut fft, x, period / ratio, 1).map_err(|e| bad(path, e))?;
                envelope(&mut fft, &y, fs, &map, &ratios, d.mesh_order, choice)
            }
            None => envelope(&mut fft, x, fs, &map, &ratios, d.mesh_order, choice),
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
        d.cepstrum = cepstrum(&mut fft, x, fs, period, &ratios);
    }
    if (profile.max - profile.min) > ORDER_MAP_SPEED_CHANGE * profile.mean {
        d.order_map = order_map(&mut fft, &rec.channels[channels[0] - 1], &map, d.mesh_order);
    }
    Ok(d)
}

/// Speed range (slowest to fastest revolution, over the mean) above which the rpm-order map is drawn.
const ORDER_MAP_SPEED_CHANGE: f64 = 0.02;

/// The rpm-order map of a recording whose speed changes: segments of 8 revolutions advancing by 4 (order
/// resolution 1/8), orders up to 3.5 mesh orders (three mesh harmonics and their sidebands). `None` when
/// the recording holds too few revolutions.
fn order_map(fft: &mut Fft, x: &[f32], map: &AngleMap, mesh_order: usize) -> Option<OrderMap> {
    let max_order = 3.5 * mesh_order.max(1) as f64;
    let points = ((3.0 * max_order) as usize).next_power_of_two().max(64);
    crate::signal::order_map::order_map(fft, x, map, points, 8, 4, max_order).ok()
}

/// How the envelope band is chosen: kurtogram depth, and a band (given, or the baseline's) that overrides
/// the kurtogram's choice.
#[derive(Clone, Copy, Debug)]
struct BandChoice {
    levels: Option<usize>,
    band: Option<(f64, f64)>,
}

/// Kurtogram levels searched (band widths down to fs / 64).
const KURTOGRAM_LEVELS: usize = 5;

/// Envelope analysis of one channel: the band of largest spectral kurtosis (from 1.5 mesh frequencies up,
/// at most from fs / 4), the squared envelope there,
/// its order spectrum on the tracked angle, and its lines at orders 1..=3 of each shaft.
fn envelope<T: crate::signal::Sample>(
    fft: &mut Fft,
    x: &[T],
    fs: f64,
    map: &AngleMap,
    shafts: &[(Shaft, f64)],
    mesh_order: usize,
    choice: BandChoice,
) -> Result<crate::report::summary::Envelope, crate::signal::SignalError> {
    let BandChoice { levels, band } = choice;
    use crate::signal::envelope as env;
    let n = x.len().min(1 << 18);
    let deepest = ((n.next_power_of_two() / 4 / 64) as f64).log2().floor().max(1.0) as usize;
    // bands from 1.5 mesh frequencies up: below, the shafts' and mesh's own lines beat into a peaky envelope
    let period = map.mean_period_samples();
    let mesh_hz = shafts.first().map_or(0.0, |_| mesh_order as f64 * fs / period);
    let levels = levels.unwrap_or(KURTOGRAM_LEVELS.min(deepest));
    let k = env::kurtogram(fft, x, fs, levels, (1.5 * mesh_hz).min(fs / 4.0))?;
    // a given band first, then the baseline's (so the lines compare with it), else the kurtogram's choice
    let (level, _, lo, hi) = match band {
        Some((lo, hi)) => (0, 0, lo, hi),
        None => k.best,
    };
    // the squared envelope at a reduced rate r (it holds twice the band), its revolutions scaled alike
    let (e, r) = env::squared_envelope_decimated(fft, x, fs, lo, hi)?;
    let scaled = AngleMap::from_pulses(&map.starts().iter().map(|s| s * r).collect::<Vec<_>>(), 1);
    // the envelope holds 0 .. (hi - lo) Hz: 2.5 points per cycle of that per revolution suffice
    let needed = 2.5 * (hi - lo) * period / fs;
    let points = (needed.ceil() as usize)
        .next_power_of_two()
        .clamp(32, ((period * r).ceil() as usize).next_power_of_two().clamp(32, 4096));
    let (orders, amplitudes) = env::order_spectrum(fft, &e, &scaled, points);
    let revs = map.revolutions().max(1) as f64;
    let at = |o: f64| -> (f64, f64) {
        let i = (o * revs).round() as usize;
        let a = (i.saturating_sub(2)..=i + 2).filter_map(|j| amplitudes.get(j)).copied().fold(0.0, f64::max);
        let w = (2.0 * revs) as usize;
        let mut near: Vec<f64> = (i.saturating_sub(w)..=i + w).filter_map(|j| amplitudes.get(j)).copied().collect();
        near.sort_by(f64::total_cmp);
        let floor = near.get(near.len() / 2).copied().unwrap_or(0.0).max(f64::MIN_POSITIVE);
        (a, 20.0 * (a / floor).max(f64::MIN_POSITIVE).log10())
    };
    let lines = shafts
        .iter()
        .flat_map(|&(shaft, ratio)| (1..=3).map(move |k| (shaft, k, k as f64 * ratio)))
        .map(|(shaft, order, o)| {
            let (amplitude, over_floor_db) = at(o);
            crate::report::summary::EnvelopeLine { shaft, order, reference_order: o, amplitude, over_floor_db }
        })
        .collect();
    // the band's spectral kurtosis from its squared envelope e = |c|^2: <e^2> / <e>^2 - 2
    let m1 = e.iter().sum::<f64>() / e.len().max(1) as f64;
    // (the band's own kurtosis from the decimated envelope: the same moments at a lower rate)
    let m2 = e.iter().map(|v| v * v).sum::<f64>() / e.len().max(1) as f64;
    let spectral_kurtosis = if band.is_some() { m2 / (m1 * m1).max(f64::MIN_POSITIVE) - 2.0 } else { k.best_kurtosis };
    Ok(crate::report::summary::Envelope {
        band_hz: [lo, hi],
        level,
        spectral_kurtosis,
        lines,
        orders,
        amplitudes,
        kurtogram: k.levels,
        liftered: None,
    })
}

/// Real power cepstrum over segments of about 4 revolutions, with the first 3 rahmonics of each shaft.
fn cepstrum(
    fft: &mut Fft,
    x: &[f32],
    fs: f64,
    period: f64,
    shafts: &[(Shaft, f64)],
) -> Option<crate::report::summary::Cepstrum> {
    let slowest = shafts.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
    let segment = ((8.0 * period / slowest) as usize).next_power_of_two().clamp(256, 1 << 18);
    let values = crate::signal::envelope::cepstrum(fft, x, segment).ok()?;
    let rahmonics = shafts
        .iter()
        .flat_map(|&(shaft, ratio)| (1..=3).map(move |k| (shaft, k, k as f64 * period / ratio)))
        .filter(|(_, _, q)| (*q as usize) + 2 < values.len())
        .map(|(shaft, k, q)| {
            let w = (q * 0.01).ceil() as usize;
            let i = q.round() as usize;
            let value = (i.saturating_sub(w)..=i + w).filter_map(|j| values.get(j)).copied().fold(f64::MIN, f64::max);
            crate::report::summary::Rahmonic { shaft, k, quefrency_s: q / fs, value }
        })
        .collect();
    Some(crate::report::summary::Cepstrum { rahmonics, dq_s: 1.0 / fs, values })
}

/// Points per revolution of a TSA: the revolution's samples rounded up to a power of two (64 ..= 65536).
fn tsa_points(period: f64) -> usize {
    (period.ceil() as usize).next_power_of_two().clamp(64, 1 << 16)
}

/// The speed before tracking: revolution starts from the tachometer, or a constant nominal speed (given,
/// or estimated from the repetition period).
struct Nominal {
    map: AngleMap,
    source: SpeedSource,
    confidence: f64,
    /// Mesh order from the ratio of the repetition period to the mesh lag (estimated speed only).
    mesh_order: Option<usize>,
}

#[allow(clippy::too_many_arguments)]
fn nominal_speed(
    path: &Path,
    rec: &Recording,
    channels: &[usize],
    o: &Options,
    fs: Option<f64>,
    geometry: Option<&Geometry>,
    fft: &mut Fft,
    warnings: &mut Vec<String>,
) -> Result<Nominal, Error> {
    let n = rec.channels.iter().map(Vec::len).max().unwrap_or(0);
    if let Some(t) = o.tacho_channel {
        let pulses = speed::tacho_pulses(&rec.channels[t - 1])
            .and_then(|p| angle::from_pulses(&p, o.pulses_per_rev.max(1)))
            .map_err(|e| bad(path, format!("tachometer channel {t}: {e}")))?;
        return Ok(Nominal { map: pulses, source: SpeedSource::Tachometer, confidence: 1.0, mesh_order: None });
    }
    if let Some(hz) = o.shaft_hz {
        let fs = fs
            .ok_or_else(|| Error::from(JobError::NoSampleRate { file: path.display().to_string(), for_speed: true }))?;
        check_given_speed(path, hz, fs, n, o.min_revolutions)?;
        return Ok(Nominal {
            map: AngleMap::constant(fs / hz, 0.0, n),
            source: SpeedSource::Given,
            confidence: 1.0,
            mesh_order: None,
        });
    }
    let views: Vec<&[f32]> = channels.iter().map(|&c| &rec.channels[c - 1][..n.min(1 << 20)]).collect();
    let est = match geometry.and_then(|g| g.period_samples) {
        Some(p) => speed::refine_near(fft, &views, p, 0.03),
        None => speed::estimate_period(fft, &views, 16, n / o.min_revolutions.max(2)),
    }
    .map_err(|e| bad(path, e))?;
    if est.mesh_lag.is_none() && est.period_samples < MIN_SAMPLES_PER_REV {
        return Err(bad(
            path,
            format!(
                "no plausible shaft speed: the signal repeats every {:.2} samples, too short for a shaft (likely the tooth mesh), and no longer period stands out (the speed may vary too much to estimate); give --rpm or a tachometer channel",
                est.period_samples
            ),
        ));
    }
    warnings.push(format!(
        "shaft speed estimated from the signal's repetition period ({:.3} samples, autocorrelation {:.2}); give the speed or a tachometer channel when known",
        est.period_samples, est.confidence
    ));
    if let Some((zp, _)) = o.teeth {
        // the signal may repeat over several pinion revolutions (a hunting period): the pinion revolution
        // is the fraction of the period where the given mesh order has its strongest line
        let line = |k: usize| -> f64 {
            let f = (zp * k) as f64 / est.period_samples;
            if f >= 0.45 { 0.0 } else { views.iter().map(|c| ind_line(c, f, 0.3 / est.period_samples)).sum() }
        };
        // the smallest k whose line reaches a quarter of the strongest (k = 2 would otherwise take the
        // second mesh harmonic, often stronger than the first, for the mesh of half the shaft period)
        let lines: Vec<f64> = (1..=8).map(line).collect();
        let top = lines.iter().copied().fold(0.0, f64::max);
        let k = lines.iter().position(|&a| a >= 0.25 * top && a > 0.0).map_or(1, |i| i + 1);
        if k > 1 {
            warnings.push(format!(
                "the signal repeats every {k} pinion revolutions (the given mesh order {zp} fits a period of {:.3} samples): the pinion period is taken as that",
                est.period_samples / k as f64
            ));
            return Ok(Nominal {
                map: AngleMap::constant(est.period_samples / k as f64, 0.0, n),
                source: SpeedSource::Estimated,
                confidence: est.confidence,
                mesh_order: None,
            });
        }
    }
    Ok(Nominal {
        map: AngleMap::constant(est.period_samples, 0.0, n),
        source: SpeedSource::Estimated,
        confidence: est.confidence,
        mesh_order: est
            .mesh_lag
            .map(|m| (est.period_samples / m).round() as usize)
            .map(|z| fundamental_mesh(&views, est.period_samples, z))
            .filter(|&z| z >= 8),
    })
}

/// Largest relative difference between the tracked mean speed and the nominal one that is accepted: the
/// nominal speed is the mean (estimated) or what the user gave; further away the ridge followed another line.
const MAX_TRACKING_SHIFT: f64 = 0.05;

/// The mesh order whose fundamental is really there: a repetition lag can hold two or three mesh periods,
/// or only half or a third of one (a strong second harmonic), and a harmonic family can score through its
/// even harmonics; so among z / 3, z / 2, z, 2z and 3z (whole divisors and multiples, at least 8) the
/// smallest whose line reaches [`MESH_FUNDAMENTAL_SHARE`] of its strongest harmonic (orders 1..=4 times
/// it) is taken, summed over channels; a divisor must moreover stand 4 times above the orders around it
/// (a line at half the mesh order from elsewhere in the machine is not a mesh).
/// Smallest amplitude of a mesh fundamental relative to its strongest harmonic: the bundled cracked-tooth
/// scene's first mesh line is 10 % of its second (a resonance near twice the mesh), while on the real
/// SpectraQuest recordings the lines at half and a quarter of the mesh order are 1.6 % and 4.5 % of the
/// mesh: an engineering choice between the two.
const MESH_FUNDAMENTAL_SHARE: f64 = 0.07;

fn fundamental_mesh(channels: &[&[f32]], period: f64, z: usize) -> usize {
    // summed over channels, the strongest line within +-`search` orders of `order`
    let amp = |order: f64, search: f64| -> f64 {
        let f = order / period;
        if f >= 0.5 {
            return 0.0;
        }
        channels.iter().map(|c| ind_line(c, f, search / period)).sum()
    };
    // a divisor of z must also be a line of its own: 4 times the median of orders c +- 1..3
    let clear_line = |c: usize| -> bool {
        let mut near: Vec<f64> = [-3.0, -2.0, -1.0, 1.0, 2.0, 3.0].iter().map(|d| amp(c as f64 + d, 0.2)).collect();
        near.sort_by(f64::total_cmp);
        amp(c as f64, 0.2) >= 4.0 * 0.5 * (near[2] + near[3])
    };
    let mut candidates: Vec<usize> =
        [z / 3, z / 2, z, 2 * z, 3 * z].into_iter().filter(|&c| c >= 8 && (c % z == 0 || z % c == 0)).collect();
    candidates.dedup();
    for c in candidates {
        // +-0.2 orders: a wheel of 2.5 times as many teeth puts lines every 0.4 pinion orders
        let own = amp(c as f64, 0.2);
        let strongest = (1..=4).map(|k| amp((k * c) as f64, 0.2)).fold(0.0, f64::max);
        if own >= MESH_FUNDAMENTAL_SHARE * strongest && own > 0.0 && (c >= z || clear_line(c)) {
            return c;
        }
    }
    z
}

fn ind_line(x: &[f32], f: f64, search: f64) -> f64 {
    crate::signal::spectrum::line_amplitude(x, f, search)
}

/// [`MAX_TRACKING_SHIFT`] when the nominal speed was estimated from the repetition period (the mean speed
/// itself, good to about 1e-4): 0.5 % leaves room for a drift that is not symmetric in time.
const MAX_TRACKING_SHIFT_ESTIMATED: f64 = 0.005;

/// Line-to-band ratio below which a tracked mesh line is too weak to trust, dB.
const MIN_TRACKING_SNR_DB: f64 = 6.0;

/// Follows the shaft angle through the recording. With a tachometer its pulses are the angle. Otherwise the
/// phase of the first mesh harmonic is tracked on each analysed channel (the mesh order from the teeth, the
/// baseline, or the harmonic family of a constant-speed TSA) and the channel where the line stands out
/// most is used; when no channel allows it, the constant nominal speed stays, with a warning.
fn track(
    path: &Path,
    rec: &Recording,
    channels: &[usize],
    o: &Options,
    known_z: Option<usize>,
    nominal: AngleMap,
    warnings: &mut Vec<String>,
) -> Result<(AngleMap, Tracking, Option<f64>, Option<usize>), Error> {
    if o.tacho_channel.is_some() {
        return Ok((nominal, Tracking::Tachometer, None, None));
    }
    let period = nominal.mean_period_samples();
    // an estimated period is the mean to about 1e-4; a given speed may be off by a few percent
    let max_shift = if o.shaft_hz.is_some() { MAX_TRACKING_SHIFT } else { MAX_TRACKING_SHIFT_ESTIMATED };
    let z = match known_z {
        Some(z) => z,
        None => {
            let tsas = channels
                .par_iter()
                .map(|&c| tsa::tsa(&rec.channels[c - 1], &nominal, 1.0, tsa_points(period), o.min_revolutions))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| bad(path, e))?;
            let z = mesh_family(&mut Fft::new(), tsas.iter().map(|t| t.samples.as_slice()));
            let views: Vec<&[f32]> = channels.iter().map(|&c| rec.channels[c - 1].as_slice()).collect();
            fundamental_mesh(&views, period, z)
        }
    };
    // the strongest of the first four mesh harmonics below 0.4 cycles per sample (a resonance can make the
    // second ten times the first) on each channel, relative to the channel's RMS; the two channels where it
    // stands out most are tracked and the one whose tracked line has the better SNR is used
    let mut candidates: Vec<(usize, f64, f64)> = channels
        .par_iter()
        .map(|&c| {
            let x = &rec.channels[c - 1];
            let (order, amp) = (1..=4)
                .map(|k| (k * z) as f64)
                .filter(|o| o / period < 0.4)
                .map(|o| (o, ind_line(x, o / period, 0.2 / period)))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap_or((z as f64, 0.0));
            (c, order, amp / ind::rms(&x[..x.len().min(1 << 16)]).max(f64::MIN_POSITIVE))
        })
        .collect();
    candidates.sort_by(|a, b| b.2.total_cmp(&a.2));
    let tracked: Vec<Result<angle::Tracked, _>> = candidates
        .par_iter()
        .take(2)
        .map(|&(c, order, _)| angle::track_mesh(&mut Fft::new(), &rec.channels[c - 1], period, order))
        .collect();
    let best = tracked.into_iter().reduce(|a, b| match (&a, &b) {
        (Ok(x), Ok(y)) => {
            if y.line_snr_db > x.line_snr_db {
                b
            } else {
                a
            }
        }
        (Err(_), _) => b,
        _ => a,
    });
    match best {
        Some(Ok(t)) if (t.map.mean_period_samples() / period - 1.0).abs() > max_shift => {
            warnings.push(format!(
                "mesh-phase tracking of order {z} ended {:+.1} % away from the nominal speed: it followed another line, so the TSA assumes a constant speed",
                100.0 * (period / t.map.mean_period_samples() - 1.0)
            ));
            Ok((nominal, Tracking::Constant, None, Some(z)))
        }
        Some(Ok(t)) if t.line_snr_db >= MIN_TRACKING_SNR_DB => {
            Ok((t.map, Tracking::MeshPhase, Some(t.line_snr_db), Some(z)))
        }
        Some(Ok(t)) => {
            warnings.push(format!(
                "the mesh line (order {z}) stands only {:.1} dB above its band: too weak to track the speed; the TSA assumes a constant speed",
                t.line_snr_db
            ));
            Ok((nominal, Tracking::Constant, None, Some(z)))
        }
        Some(Err(e)) => {
            warnings.push(format!("mesh-phase tracking not possible ({e}); the TSA assumes a constant speed"));
            Ok((nominal, Tracking::Constant, None, Some(z)))
        }
        None => Ok((nominal, Tracking::Constant, None, Some(z))),
    }
}

/// A warning when the given teeth do not fit: the TSA line at the mesh order z must stand above every line
/// of its +-1..3 sideband family (summed over channels), as a mesh line does; a line of the family that is
/// stronger says the mesh is elsewhere (13 or 15 given for 14 teeth, or the pinion and wheel swapped).
fn teeth_misfit<'a>(tsas: impl Iterator<Item = &'a [f64]>, z: usize, gear: Shaft) -> Option<String> {
    let mut power: Vec<f64> = Vec::new();
    for t in tsas {
        let a = crate::signal::spectrum::periodic_amplitudes(t);
        power.resize(a.len(), 0.0);
        power.iter_mut().zip(&a).for_each(|(p, v)| *p += v * v);
    }
    let at = |k: usize| power.get(k).copied().unwrap_or(0.0).sqrt();
    let (best, a_best) = (z.saturating_sub(3).max(1)..=z + 3).map(|k| (k, at(k))).max_by(|a, b| a.1.total_cmp(&b.1))?;
    (best != z).then(|| {
        format!(
            "the given teeth do not fit the {gear}: its TSA line at order {best} is {:.1} times the line at the given mesh order {z}; check --teeth (a mesh line stands above its sidebands)",
            a_best / at(z).max(f64::MIN_POSITIVE)
        )
    })
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
