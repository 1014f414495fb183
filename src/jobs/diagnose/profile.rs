//! The stored healthy profile: what `learn` taught from healthy recordings of one machine (the machine's
//! speed, teeth, channels and units, the processing settings, the baseline's per-indicator distributions
//! with their block counts), written as versioned JSON that people can read, and applied by `diagnose
//! --profile` with exactly those settings.

use super::{BaselineFacts, DiagnoseJob, Geometry, Options, baseline::Reference};
use crate::Error;
use crate::jobs::{Given, JobError};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What the file says it is.
pub const FORMAT: &str = "gearvib healthy profile";
/// Version of the profile layout; a profile of another version is refused.
pub const VERSION: u32 = 1;
/// Largest profile file read, bytes: a profile of a few gears and channels is tens of kilobytes.
pub const MAX_PROFILE_BYTES: u64 = 64 << 20;

/// A healthy profile.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Profile {
    /// Always [`FORMAT`].
    pub format: String,
    /// Always [`VERSION`].
    pub version: u32,
    /// The healthy recordings learned from, in the order given.
    pub learned_from: Vec<String>,
    /// The processing settings (teeth, given speed and its tolerance, channels, tachometer, units, block
    /// length, envelope band...): every recording is diagnosed with exactly these.
    pub processing: Options,
    /// What the first healthy recording fixed for the others: its period and mesh order when estimated,
    /// its envelope band and its averaging length.
    pub geometry: Geometry,
    /// The facts a recording is checked against (unit, channels, speed, sample rate, level).
    pub baseline: BaselineFacts,
    /// Per gear and channel, each deciding indicator's distribution over the healthy blocks.
    pub reference: Reference,
    /// With a machine that has a planetary stage: the healthy planet-fault energies of each planet (absent
    /// from profiles without one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub planets: Option<Vec<crate::report::summary::PlanetBaseline>>,
    /// How `planets` was measured: [`PLANET_MEASURE`] (absent from older profiles, whose planet energies were
    /// taken on the squared signal and do not compare with a recording's now).
    #[serde(default)]
    pub planet_measure: u32,
}

/// The planets' fault energy on the squared tooth-to-tooth difference (see
/// `report::summary::MachineDiagnosis::planet_fault_energy`); 0, the squared signal, before.
pub const PLANET_MEASURE: u32 = 1;

/// A `learn` call: healthy recordings (files or directories), the options they are analysed with, and
/// the profile to write.
#[derive(Clone, Debug)]
pub struct LearnJob {
    /// Healthy recordings of one machine.
    pub healthy: Vec<PathBuf>,
    /// Analysis options.
    pub options: Options,
    /// Where the profile goes (written atomically).
    pub output: PathBuf,
}

/// Learns the profile of `job`'s healthy recordings and writes it.
///
/// # Errors
/// A recording cannot be read or analysed, the recordings do not fit each other, too few blocks, the
/// profile cannot be written.
pub fn learn(job: &LearnJob) -> Result<Profile, Error> {
    crate::io::begin_run();
    for h in &job.healthy {
        crate::io::register_input(h);
    }
    let diagnose_job =
        DiagnoseJob { baselines: job.healthy.clone(), options: job.options.clone(), ..Default::default() };
    // a file given twice would count twice among the healthy recordings the limits rest on
    if let Some(f) = super::baseline_files(&diagnose_job)?.twice.first() {
        return Err(bad(f, "given twice to learn from: give each healthy recording once"));
    }
    let p = super::prepare(&diagnose_job)?;
    let (Some(facts), Some(geometry), Some(reference)) = (p.facts, p.geometry, p.reference) else {
        return Err(JobError::Value { what: Given::Baseline, message: "no healthy recordings given".into() }.into());
    };
    let profile = Profile {
        format: FORMAT.into(),
        version: VERSION,
        planet_measure: PLANET_MEASURE,
        learned_from: super::expand_dirs(&job.healthy)?.iter().map(|f| f.display().to_string()).collect(),
        processing: p.opts,
        geometry,
        baseline: facts,
        reference,
        planets: p.planets,
    };
    let text = serde_json::to_string_pretty(&profile).map_err(|e| bad(&job.output, e))?;
    crate::io::write_atomic(&job.output, text.as_bytes())?;
    Ok(profile)
}

/// Reads a profile, refusing one that is too large, not a regular file, of another format or version.
///
/// # Errors
/// [`JobError::Input`] naming the file and what is wrong (the field path for a malformed profile).
pub fn load(path: &Path) -> Result<Profile, Error> {
    crate::io::register_input(path);
    let meta = std::fs::metadata(path).map_err(|e| bad(path, format!("cannot read the profile: {e}")))?;
    if !meta.is_file() {
        return Err(bad(path, "the profile is not a regular file"));
    }
    if meta.len() > MAX_PROFILE_BYTES {
        return Err(bad(
            path,
            format!("{} bytes: larger than any profile ({} MiB at most)", meta.len(), MAX_PROFILE_BYTES >> 20),
        ));
    }
    let text = std::fs::read_to_string(path).map_err(|e| bad(path, format!("cannot read the profile: {e}")))?;
    let head: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(path, format!("not a JSON profile: {e}")))?;
    if head.get("format").and_then(|f| f.as_str()) != Some(FORMAT) {
        return Err(bad(
            path,
            format!("not a gearvib profile (its `format` is not \"{FORMAT}\"; write one with learn)"),
        ));
    }
    if head.get("version").and_then(|v| v.as_u64()) != Some(u64::from(VERSION)) {
        return Err(bad(
            path,
            format!("profile version {} is not {VERSION}: learn it again with this gearvib", head["version"]),
        ));
    }
    let p: Profile = crate::scene::parse_json(&text, &path.display().to_string())
        .map_err(|e| bad(path, e.to_string().trim_start_matches(&format!("{}: ", path.display())).to_string()))?;
    check(&p).map_err(|m| bad(path, m))?;
    Ok(p)
}

/// Values a profile must hold to be applied.
fn check(p: &Profile) -> Result<(), String> {
    let o = &p.processing;
    if o.block_revs.is_none_or(|r| r < 2) {
        return Err("field `processing.block_revs`: must be 2 or more".into());
    }
    if !(o.speed_tolerance.is_finite() && (0.0..=0.2).contains(&o.speed_tolerance)) {
        return Err(format!("field `processing.speed_tolerance`: {} is not within 0..0.2", o.speed_tolerance));
    }
    if o.shaft_hz.is_some_and(|f| !(f.is_finite() && f > 0.0)) {
        return Err("field `processing.shaft_hz`: must be positive".into());
    }
    if o.teeth.is_some_and(|(a, b)| a < 3 || b < 3 || a > 10_000 || b > 10_000) {
        return Err("field `processing.teeth`: each gear needs 3 to 10000 teeth".into());
    }
    if p.geometry.tsa_points.is_some_and(|n| !(64..=1 << 16).contains(&n)) {
        return Err("field `geometry.tsa_points`: must be within 64..=65536".into());
    }
    if p.planets.is_some() && p.planet_measure != PLANET_MEASURE {
        return Err(format!(
            "field `planet_measure`: {} is not {PLANET_MEASURE}: its planets' healthy energies were measured on the squared signal, which no longer compares with a recording's; learn the profile again",
            p.planet_measure
        ));
    }
    if p.baseline.channels.is_empty() {
        return Err("field `baseline.channels`: empty".into());
    }
    check_bounds(p)
}

/// The bounds the command line puts on the same settings, said with the profile's field (an edited profile
/// once ran with `block_revs` 1e12 and scored no block, or named `--fs` for its `fs_hz`).
fn check_bounds(p: &Profile) -> Result<(), String> {
    let o = &p.processing;
    let positive = |v: f64| v.is_finite() && v > 0.0;
    let (lo, hi) = super::recording::SAMPLE_RATE_RANGE_HZ;
    let field = |name: &str, why: String| Err(format!("field `{name}`: {why}"));
    if o.block_revs.is_some_and(|r| r > 10_000) {
        return field("processing.block_revs", "must be 2 to 10000".into());
    }
    if !(2..=10_000).contains(&o.min_revolutions) {
        return field("processing.min_revolutions", format!("{} is not within 2 to 10000", o.min_revolutions));
    }
    if let Some(fs) = o.fs_hz.filter(|f| !(f.is_finite() && (lo..=hi).contains(f))) {
        return field("processing.fs_hz", format!("{fs:e} Hz is not within {lo} Hz .. {hi:e} Hz"));
    }
    if let Some(f) = o.shaft_hz.filter(|&f| f > hi) {
        return field("processing.shaft_hz", format!("{f:e} Hz is beyond any sample rate"));
    }
    if o.tacho_channel.is_some_and(|c| c == 0) || o.channel.is_some_and(|c| c == 0) {
        return field("processing.channel / tacho_channel", "channels count from 1".into());
    }
    if o.pulses_per_rev == 0 || o.shaft_orders > 10_000 || o.kurtogram_levels.is_some_and(|l| !(1..=30).contains(&l)) {
        return field(
            "processing.pulses_per_rev / shaft_orders / kurtogram_levels",
            "pulses per revolution from 1, shaft orders up to 10000, kurtogram levels 1 to 30".into(),
        );
    }
    let band_ok = |(a, b): (f64, f64)| a.is_finite() && b.is_finite() && a >= 0.0 && b > a;
    if o.envelope_band.is_some_and(|b| !band_ok(b)) || p.geometry.envelope_band.is_some_and(|b| !band_ok(b)) {
        return field("geometry.envelope_band / processing.envelope_band", "need 0 <= LO < HI in Hz".into());
    }
    if p.geometry.period_samples.is_some_and(|v| !positive(v)) {
        return field("geometry.period_samples", "must be positive".into());
    }
    let b = &p.baseline;
    if !positive(b.shaft_period_samples) {
        return field("baseline.shaft_period_samples", "must be positive".into());
    }
    if b.speed_hz.is_some_and(|v| !positive(v)) {
        return field("baseline.speed_hz", "must be positive".into());
    }
    if b.sample_rate_hz.is_some_and(|f| !(f.is_finite() && (lo..=hi).contains(&f))) {
        return field("baseline.sample_rate_hz", format!("must be within {lo} Hz .. {hi:e} Hz"));
    }
    let nyquist = p.baseline.sample_rate_hz.map_or(f64::INFINITY, |f| f / 2.0);
    if p.geometry.envelope_band.is_some_and(|(_, b)| b > nyquist * 1.001) {
        return field(
            "geometry.envelope_band",
            format!("reaches beyond half the baseline's sample rate ({nyquist} Hz)"),
        );
    }
    Ok(())
}

fn bad(path: &Path, msg: impl std::fmt::Display) -> Error {
    JobError::Input { file: path.display().to_string(), message: msg.to_string() }.into()
}
