//! Diagnosis of recorded signals: speed and teeth (given, tachometer, or estimated), spectra, TSA per
//! gear, condition indicators, sidebands labelled by shaft, a verdict, and comparison with a model.
//!
//! Which signal each indicator uses (see `reference/diagnostics.md`): RMS, kurtosis and crest factor on
//! the TSA of the gear's shaft; FM0 on the TSA and its mesh-harmonic amplitudes; FM4, M6A, M8A on the
//! difference signal; NA4 on the residual (ensemble of the recordings in command-line order; NA4* against
//! a baseline's residual variance); ER = RMS(difference) / RMS(regular); SI, SLF and SER on the TSA
//! amplitude spectrum around the first mesh harmonic. Raw-signal RMS and kurtosis are reported but never
//! decide the verdict.

mod analysis;
pub mod baseline;
mod beyond;
mod compare;
mod compat;
mod evidence;
mod files;
mod load_doubt;
mod machine;
mod options;
pub mod profile;
mod recording;
mod shared_period;
mod teeth;
mod tooth;
mod tracking;
pub mod trend;
mod verdict;

use analysis::*;
use beyond::{
    BandChoice, ORDER_MAP_SPEED_CHANGE, cepstrum, channel_spectra, envelope, envelope_of, envelope_plan, order_map,
};
pub use compat::{
    BaselineFacts, Compatibility, MAX_SPEED_DIFFERENCE, OPERATING_POINT_SPEED_DIFFERENCE, WARN_SPEED_DIFFERENCE,
    compatibility,
};
pub(crate) use files::{baseline_files, expand_dirs};
use recording::*;
pub use recording::{MIN_SAMPLES_PER_REV, PINION_TACHO, SAMPLE_RATE_RANGE_HZ, diagnose, diagnose_in_memory};
use teeth::{
    MIN_OTHER_GEAR_CONFIDENCE, WHEEL_DOUBT_RATIO, WheelCheck, doubled_family, mesh_family, other_gear_teeth,
    teeth_misfit, wheel_teeth,
};
use tracking::{Tracked, nominal_speed, strongest_low_harmonic, track};

pub use baseline::BaselineLoad;
pub use compare::compare;
pub use options::{DEFAULT_SPEED_TOLERANCE, Geometry, Options};
pub use verdict::{Thresholds, ensemble_na4, judge};

use super::{ChannelRole, Given, JobError};
use crate::Error;
use crate::io::{self, Recording};
use crate::model::Quantity;
use crate::report::summary::{
    Diagnosis, GearIndicators, Indicator, Indicators, MeshHarmonic, OtherGear, Shaft, ShaftHz, Sideband, SpeedProfile,
    SpeedSource, TeethSource, Tracking, Verdict, VerdictGear, VerdictState,
};
use crate::signal::indicators as ind;
use crate::signal::order_map::OrderMap;
use crate::signal::spectrum::Fft;
use crate::signal::tsa::{self, AngleMap, Decomposition};
use crate::signal::{angle, mesh_comb, speed};
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
    /// A healthy profile written by `learn` ([`profile::Profile`]): its processing settings replace
    /// `options` (all but `all_spectra`) and its reference replaces `baselines`.
    pub profile: Option<PathBuf>,
    /// Scene simulated at each recording's speed and compared with it.
    pub scene: Option<PathBuf>,
    /// Directory for the PNG images and the JSON of each recording.
    pub report: Option<PathBuf>,
    /// Recordings already in memory (from the Python bindings), each with the name it is reported under;
    /// diagnosed after the files, as if they were files (`--unit`, `--sensitivity` and the channel choice
    /// apply alike). Their samples may be lent (`Cow::Borrowed`): they are read in place, never copied
    /// unless `--sensitivity` must scale them.
    pub in_memory: Vec<(PathBuf, Recording<'a>)>,
    /// Machine class whose ISO 10816-3 velocity zones the report states (none: the velocity alone).
    pub iso_class: Option<crate::signal::velocity::MachineClass>,
    /// How the report's spectrum images show their levels.
    pub spectrum_scale: crate::report::summary::SpectrumScale,
    /// Whether the baseline (files or profile) was recorded at the recordings' load and speed.
    pub baseline_load: baseline::BaselineLoad,
}

/// What [`run`] produced: one diagnosis per recording that could be diagnosed, in the order given, the
/// recordings that could not, and the report files written.
#[derive(Debug)]
pub struct DiagnoseOutcome {
    /// Diagnoses in the order of the recordings.
    pub diagnoses: Vec<Diagnosis>,
    /// Recordings of a batch that failed, each with its error (the others are diagnosed all the same).
    pub failures: Vec<Failure>,
    /// Report files written (empty without a report directory).
    pub report_files: Vec<PathBuf>,
}

/// A recording of a batch that could not be diagnosed: its file and the error (which names it).
#[derive(Debug)]
pub struct Failure {
    /// The recording as given.
    pub file: String,
    /// What went wrong.
    pub error: Error,
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.error.fmt(f)
    }
}

impl Failure {
    fn of(file: &Path, error: Error) -> Self {
        Self { file: file.display().to_string(), error }
    }
}

/// Diagnoses every recording of `job`: the baseline first (its speed and mesh order are shared with the
/// recordings when they were estimated), the recordings in parallel, NA4 over the ensemble in time order,
/// the verdict of each against the baseline, the model comparison (the scene loaded once), and the report.
///
/// # Errors
/// Any recording, the baseline or the scene cannot be read or analysed; the report cannot be written.
pub fn run(job: &DiagnoseJob) -> Result<DiagnoseOutcome, Error> {
    let (mut done, mut failures) = (Vec::new(), Vec::new());
    let reference = run_streaming(job, &mut |d| {
        match d {
            Ok(d) => done.push(d),
            Err(f) => failures.push(f),
        }
        Ok(())
    })?;
    let mut report_files = Vec::new();
    if let (Some(dir), false) = (&job.report, done.is_empty() && failures.is_empty()) {
        // every output checked before the first is written: a refusal leaves no half report set
        check_report_outputs(dir, &done, done.len() >= 2 && reference)?;
        io::create_dir(dir)?;
        let mut sections = Vec::new();
        if !failures.is_empty() {
            // a page that lists only what could be judged would pass an unread recording for a good one
            let failed: Vec<(String, String)> =
                failures.iter().map(|f| (f.file.clone(), f.error.to_string())).collect();
            sections.push(crate::report::html::failures_section(&failed));
        }
        for d in done.iter_mut() {
            d.spectrum_scale = job.spectrum_scale;
            let files = write_report(d, dir)?;
            let images: Vec<PathBuf> =
                files.iter().filter(|f| f.extension().is_some_and(|e| e == "png")).cloned().collect();
            sections.push(crate::report::html::diagnosis_section(d, &images, job.iso_class));
            report_files.extend(files);
        }
        if done.len() >= 2 && reference {
            let files = trend::write(dir, &done)?;
            let images: Vec<PathBuf> =
                files.iter().filter(|f| f.extension().is_some_and(|e| e == "png")).cloned().collect();
            sections.insert(usize::from(!failures.is_empty()), crate::report::html::trend_section(&done, &images));
            report_files.extend(files);
        }
        report_files.push(crate::report::html::write(dir, "gearvib diagnosis", &sections)?);
    }
    Ok(DiagnoseOutcome { diagnoses: done, failures, report_files })
}

/// Suffixes of the report files of one recording `STEM` (`STEM-diagnosis.json` and its images).
const REPORT_SUFFIXES: [&str; 9] = [
    "-diagnosis.json",
    "-tsa.png",
    "-spectrum.png",
    "-zoom.png",
    "-envelope.png",
    "-kurtogram.png",
    "-cepstrum.png",
    "-order-map.png",
    "-vs-model.png",
];

/// The report's files that [`run`] may write into `dir` for `done` (with the trend files when `trend`):
/// none may be an input of this run, and no two recordings may share a stem (the second's report would
/// replace the first's).
///
/// # Errors
/// [`JobError::Input`] naming the output and the input, or the two recordings.
fn check_report_outputs(dir: &Path, done: &[Diagnosis], trend: bool) -> Result<(), Error> {
    let mut stems: BTreeMap<String, &str> = BTreeMap::new();
    let mut names = vec!["index.html".to_string()];
    if trend {
        names.extend(["trend.csv", "trend.jsonl", "trend.png"].map(String::from));
    }
    for d in done {
        let stem = report_stem(d);
        if let Some(first) = stems.insert(stem.clone(), &d.file) {
            return Err(bad(
                Path::new(&d.file),
                format!(
                    "its report files ({stem}-...) would replace those of {first} in {}: give the recordings different names or one report directory each",
                    dir.display()
                ),
            ));
        }
        names.extend(REPORT_SUFFIXES.iter().map(|s| format!("{stem}{s}")));
    }
    for n in names {
        io::check_output(&dir.join(n))?;
    }
    Ok(())
}

/// The name a recording's report files start with: its file stem.
fn report_stem(d: &Diagnosis) -> String {
    Path::new(&d.file).file_stem().and_then(|s| s.to_str()).unwrap_or("recording").to_string()
}

/// The baseline side of a call, prepared once: options as fixed by the first baseline (or a profile), the
/// facts of the first healthy recording, what they fix for the recordings, the statistical reference and
/// the comparison scene. A caller that diagnoses recordings one call at a time against the same baseline
/// (a Dask worker) prepares it once with [`prepare`] and passes it to [`run_streaming_prepared`].
pub struct Prepared {
    opts: Options,
    facts: Option<BaselineFacts>,
    /// The first healthy recording's spectra and averages, drawn behind the recording's in the report
    /// (none from a profile).
    plots: Option<BaselinePlots>,
    geometry: Option<Geometry>,
    reference: Option<baseline::Reference>,
    scene: Option<compare::ModelScene>,
    /// With a machine: the healthy recordings' planet-fault energies of each planetary stage.
    planets: Option<Vec<crate::report::summary::PlanetBaseline>>,
    /// What was done to the baseline files given (one given twice, one also under test), said with
    /// every verdict.
    notes: Vec<String>,
}

/// The first healthy recording's amplitude spectra per channel and its averages per channel and gear.
type BaselinePlots = (Vec<(usize, crate::signal::Spectrum)>, Vec<(usize, Shaft, Vec<f64>)>);

/// Prepares the baseline side of `job` (its recordings are not read): from its profile when it names one,
/// else by learning its baseline recordings.
///
/// # Errors
/// A baseline cannot be read or analysed, baselines that do not fit each other, too short a baseline, an
/// unreadable profile or comparison scene.
pub fn prepare(job: &DiagnoseJob) -> Result<Prepared, Error> {
    let mut p = prepare_sides(job)?;
    p.reference = p.reference.map(|r| r.with_load(job.baseline_load));
    Ok(p)
}

/// What a verdict scored against a reference stated to be at the recording's load rests on ([`BaselineLoad::Same`]):
/// the statement, and whether the measured speed contradicts it (`operating_point`: the speed differs from
/// the baseline's beyond drift). Nothing for a reference without the statement.
fn same_load_words(r: &baseline::Reference, operating_point: bool) -> Vec<String> {
    if !r.same_load() {
        return Vec::new();
    }
    let mut words = vec![if r.files == 1 {
        "the baseline file is taken as recorded at this recording's load and speed, as stated: its limits are its own blocks', with no allowance for another operating point (which one file cannot show)".to_string()
    } else {
        format!(
            "the baseline's {} files were stated to be recorded at this recording's load and speed: with two files or more that changes no limit (how far the files differ sets their spread)",
            r.files
        )
    }];
    if operating_point {
        words.push("the baseline was stated to be recorded at this recording's load and speed, but the shaft's speed differs from the baseline's beyond drift (a reason of the verdict): the statement and the measured speed disagree; the limits are kept as stated, and the verdict is held at suspect".to_string());
    }
    words
}

/// [`prepare`] before the baseline's operating point is applied.
fn prepare_sides(job: &DiagnoseJob) -> Result<Prepared, Error> {
    let scene = job.scene.as_deref().map(compare::ModelScene::load).transpose()?;
    if let Some(path) = &job.profile {
        let p = profile::load(path)?;
        // the profile fixes the machine and its processing; what describes the recording's own file (its
        // sample rate, unit and scale, for a file that names none) may still be given for it
        let o = &job.options;
        let opts = Options {
            all_spectra: o.all_spectra,
            residual_spectra: true,
            fs_hz: o.fs_hz.or(p.processing.fs_hz),
            fs_override: o.fs_override || p.processing.fs_override,
            unit: o.unit.clone().or_else(|| p.processing.unit.clone()),
            sensitivity: o.sensitivity.or(p.processing.sensitivity),
            ..p.processing
        };
        return Ok(Prepared {
            opts,
            facts: Some(p.baseline),
            plots: None,
            geometry: Some(p.geometry),
            reference: Some(p.reference),
            scene,
            planets: p.planets,
            notes: Vec::new(),
        });
    }
    let files = baseline_files(job)?;
    let mut learned = learn_baseline(&files.files, &job.options)?;
    learned.scene = scene;
    learned.notes = files.notes();
    Ok(learned)
}

/// The baseline side learned from healthy recordings (`baseline_files`, directories expanded): the first
/// fixes what was estimated (speed, mesh order), the block length and the averaging length; the others
/// follow it.
fn learn_baseline(baseline_files: &[PathBuf], options: &Options) -> Result<Prepared, Error> {
    let mut opts = options.clone();
    opts.residual_spectra = !baseline_files.is_empty();
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
        tsa_points: b.gears.first().map(|g| g.tsa.len()),
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
    // each further recording is checked against the first; the facts then hold the span of their speeds
    if let Some(f) = baselines.first().map(BaselineFacts::of) {
        for b in baselines.iter().skip(1) {
            compatibility(b, &f)?;
            compat::same_recorder(b, &f)?;
        }
    }
    let facts = BaselineFacts::of_all(&baselines);
    let reference = (!baselines.is_empty()).then(|| baseline::build(&baselines, opts.block_revs())).transpose()?;
    let plots = baselines
        .first()
        .map(|b| (b.spectra.clone(), b.gears.iter().map(|g| (g.channel, g.gear, g.tsa.clone())).collect::<Vec<_>>()));
    let planets = opts
        .machine
        .is_some()
        .then(|| crate::report::summary::PlanetBaseline::of(baselines.iter().filter_map(|b| b.machine.as_ref())))
        .filter(|p| !p.is_empty());
    Ok(Prepared { opts, facts, plots, geometry, reference, scene: None, planets, notes: Vec::new() })
}

/// Recordings diagnosed at once by [`run_streaming`]: enough to keep every core busy, few enough that a
/// directory of any size needs the memory of this many diagnoses.
fn chunk_size() -> usize {
    2 * rayon::current_num_threads().max(1)
}

/// [`run`] without the report: each recording's diagnosis, or its failure, is handed to `emit` as soon as
/// it and every recording before it are judged (time order kept; NA4 over the ensemble carried from one
/// to the next), so a directory of any size runs in bounded memory. A recording that fails (bad data, or
/// a panic caught as an internal error) does not stop the others. Returns whether a statistical baseline
/// was used.
///
/// # Errors
/// The baseline or the scene cannot be used, a directory cannot be listed, or what `emit` returns.
pub fn run_streaming(job: &DiagnoseJob, emit: &mut Emit<'_>) -> Result<bool, Error> {
    crate::io::begin_run();
    let p = prepare(job)?;
    run_streaming_prepared(job, &p, emit)
}

/// [`run_streaming`] with the baseline side already prepared (by [`prepare`] of a job with the same
/// options, baselines and scene; `job`'s own are not read again).
///
/// # Errors
/// As [`run_streaming`].
pub fn run_streaming_prepared(job: &DiagnoseJob, p: &Prepared, emit: &mut Emit<'_>) -> Result<bool, Error> {
    let recordings = expand_dirs(&job.recordings)?;
    let mut history = verdict::Na4History::default();
    let report = job.report.is_some();
    for chunk in recordings.chunks(chunk_size()) {
        let results: Vec<Result<Diagnosis, Error>> =
            chunk.par_iter().map(|r| caught(r, || diagnose(r, &p.opts, p.geometry.as_ref()))).collect();
        for (r, d) in chunk.iter().zip(results) {
            let judged = d.and_then(|d| caught(r, || finish(d, p, &mut history, report)));
            emit(judged.map_err(|e| Failure::of(r, e)))?;
        }
    }
    for (name, rec) in &job.in_memory {
        let d = caught(name, || diagnose_in_memory(name, rec.lent(), &p.opts, p.geometry.as_ref()))
            .and_then(|d| caught(name, || finish(d, p, &mut history, report)));
        emit(d.map_err(|e| Failure::of(name, e)))?;
    }
    Ok(p.reference.is_some())
}

/// What [`run_streaming`] hands each recording's outcome to, in time order; an error it returns stops the
/// batch (a closed output, a caller that wants no more).
pub type Emit<'a> = dyn FnMut(Result<Diagnosis, Failure>) -> Result<(), Error> + 'a;

/// `f`, with a panic inside it (a bug, in this thread or a worker's) turned into an error naming `file`:
/// the batch goes on, and the process never ends with a partial result and a success code.
fn caught<T>(file: &Path, f: impl FnOnce() -> Result<T, Error>) -> Result<T, Error> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).unwrap_or_else(|payload| {
        let what = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic".into());
        let at = crate::jobs::last_panic_location().map(|l| format!(" at {l}")).unwrap_or_default();
        Err(bad(file, format!("internal error{at}: {what} (a bug in gearvib: please report it with this file)")))
    })
}

/// Said when every gear's average is the baseline's own data ([`baseline::SameData`]): the verdict then
/// rests on the absolute limits, as without a baseline, so that a fault judged against itself is not
/// called healthy for want of a change.
const OWN_DATA_WARNING: &str = "every gear's average equals the baseline's to within a quarter of its own noise: the recording is one of the baseline's recordings (or overlaps one), so a change against the baseline cannot show; it is judged on the absolute limits, as without a baseline; give another healthy recording of the machine to compare with";

/// Said when a gear's average is the baseline's own data ([`baseline::SameData`]).
const SAME_DATA_WARNING: &str = "a gear's average equals the baseline's to within a quarter of its own noise: the recording is one of the baseline's recordings (or overlaps one), so its change against the baseline is nil and is not measured";

/// Why a verdict without a baseline is at most suspect on a run-up or coast-down: the speed changed by more
/// than `tolerance` (a fraction) over the recording, and the absolute limits hold for a steady speed. A mesh
/// sweeping through the housing's resonances changes its amplitude and phase over the record, which raises
/// the peaks of the difference signal by itself: healthy 19/53 and 16/45 pinions of the hold-out physics
/// coasting down by 12 % read M6A 129-163 on the tachometer's angle (88-107 steady, the limit 90) and were
/// called faulty.
fn ramp_without_baseline(d: &Diagnosis, tolerance: f64) -> Option<String> {
    let change = d.speed_profile.change_percent;
    (change.abs() > 100.0 * tolerance).then(|| {
        format!(
            "the speed changed by {change:+.1} % within the recording (a run-up or coast-down): the absolute limits hold for a steady speed, and a mesh sweeping through the housing's resonances raises the averages' peaks by itself, so without a baseline a fault is judged at most suspect; a healthy recording of the same run makes the verdict firm"
        )
    })
}

/// Judges one diagnosis (the next in time order): against the baseline when there is one, NA4 over the
/// ensemble so far, the envelope's evidence, the operating-point cap, the model comparison.
fn finish(mut d: Diagnosis, p: &Prepared, history: &mut verdict::Na4History, report: bool) -> Result<Diagnosis, Error> {
    let mut cap = None;
    let mut levels = true;
    d.warnings.extend(p.notes.iter().cloned());
    if let Some(b) = &p.facts {
        let c = compatibility(&d, b)?;
        d.warnings.extend(c.warnings);
        cap = c.operating_point;
        levels = c.levels_comparable;
        if d.speed_doubt.is_none() {
            d.speed_doubt = b.doubt();
        }
    }
    if p.facts.is_none() {
        cap = cap.or_else(|| ramp_without_baseline(&d, p.opts.speed_tolerance));
    }
    d.baseline_same_load = p.reference.as_ref().is_some_and(|r| r.same_load());
    if let (true, Some((spectra, tsas))) = (report, &p.plots) {
        d.baseline_spectra = spectra.clone();
        d.baseline_tsas = tsas.clone();
    }
    history.apply(&mut d);
    let mut reference = p.reference.as_ref();
    if let Some(r) = reference {
        let gears = &d.gears;
        let compared: Vec<_> = gears.iter().map(|g| r.local_change(g, shared_period::shared_step(gears, g))).collect();
        if !compared.is_empty() && compared.iter().all(|c| matches!(c, Some(Err(_)))) {
            // nothing to compare: the recording is judged as it would be without a baseline, its scores
            // against the baseline (each at the baseline's centre) kept for the trend
            d.warnings.push(OWN_DATA_WARNING.into());
            verdict::judge_levels(&mut d, reference, &Thresholds::default(), levels);
            reference = None;
        } else if compared.iter().any(|c| matches!(c, Some(Err(_)))) {
            d.warnings.push(SAME_DATA_WARNING.into());
        }
        d.local_change = compared.into_iter().flatten().filter_map(Result::ok).collect();
    }
    // said only where the recording is scored against the reference (not its own data's absolute limits)
    d.warnings.extend(reference.map_or_else(Vec::new, |r| same_load_words(r, cap.is_some())));
    let scores = std::mem::take(&mut d.scores);
    verdict::judge_levels(&mut d, reference, &Thresholds::default(), levels);
    if reference.is_none() && p.reference.is_some() {
        d.scores = scores;
    }
    let pattern_decided = evidence::pattern_evidence(&mut d);
    evidence::local_change_evidence(&mut d, pattern_decided);
    // (empty unless a limit was raised for a single baseline file)
    d.warnings.extend(load_doubt::warning(&d.scores, &d.local_change));
    match p.facts.as_ref().filter(|_| reference.is_some() || p.reference.is_none()) {
        Some(b) => {
            if let Some(e) = &b.envelope {
                evidence::envelope_evidence(&mut d, e);
            }
        }
        None => evidence::envelope_absolute(&mut d),
    }
    match &p.opts.machine {
        Some(m) => machine::name_verdict(&mut d, m.machine(), &p.opts, p.plots.as_ref(), p.planets.as_deref()),
        None => {
            evidence::concentration_evidence(&mut d);
            shared_period::shared_period_evidence(&mut d);
        }
    }
    // a healthy verdict only: the energy ratio also falls on the baseline's own machine (a speed a few %
    // off, a far higher load, the rig's broken tooth on one channel), where a flagged verdict must stand;
    // measured on pairs (a planetary carrier's average swings from 0.5 to 1.2 times its baseline's ER
    // between healthy seeds: the planets' passes, not a mesh, dominate it)
    let withdraw = p.opts.machine.is_none() && d.verdict.state == VerdictState::Healthy;
    let misfit = reference.and_then(|r| {
        baseline::mesh_lost(r, &d.gears, &d.teeth_misfit)
            .or_else(|| withdraw.then(|| baseline::synchronous_lost(&d.scores)).flatten())
    });
    if let Some(why) = misfit {
        // the scores stay in the tables, but a baseline of another mesh (or a withdrawn healthy verdict)
        // decides nothing
        d.verdict = crate::report::summary::Verdict::new(VerdictState::NotJudged, VerdictGear::None, vec![why]);
        d.scores.iter_mut().for_each(|s| s.decides = false);
    } else if let Some(why) = cap {
        verdict::cap_at_suspect(&mut d, why);
    }
    if let Some(s) = &p.scene {
        let quantity = match p.opts.quantity.or_else(|| Quantity::from_unit(&d.unit)) {
            Some(q) => q,
            None => {
                d.warnings.push(format!(
                    "the recording's unit ({}) does not say what it measures: taken as velocity for the model comparison; give the quantity it measures",
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

/// Writes `DIR/<stem>-diagnosis.json` and the diagnosis images of `d`.
///
/// # Errors
/// The directory cannot be created or a file cannot be written.
pub fn write_report(d: &Diagnosis, dir: &Path) -> Result<Vec<PathBuf>, Error> {
    io::create_dir(dir)?;
    let stem = report_stem(d);
    io::write_atomic(&dir.join(format!("{stem}-diagnosis.json")), crate::report::summary::to_json_line(d).as_bytes())?;
    Ok(crate::report::figures::diagnosis(d, dir)?)
}

fn bad(path: &Path, msg: impl std::fmt::Display) -> Error {
    JobError::Input { file: path.display().to_string(), message: msg.to_string() }.into()
}
