//! Command line: clap arguments -> validated jobs -> library calls -> printing.
//! The only module that prints and the only one that knows the flags: library errors that came from a
//! flag are restated here in terms of that flag.

pub mod args;
pub mod print;
pub mod progress;
mod restate;

pub use args::{Cli, Command, DiagnoseArgs, FailOn, IdentifyArgs, LearnArgs, one_line, parse_args, parse_from};

use crate::Error;
use crate::jobs::{self, JobError};
use crate::report::summary::{VerdictState, to_json_line};
use crate::scene::Scene;
use restate::{restate_for_flags, restate_for_profile};
use std::io::Write;
use std::path::PathBuf;

/// Errors of the command line: a flag's value, or the standard output closing under us.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// A flag's value is wrong in itself or does not fit the input.
    #[error("{flag}: {message}")]
    Flag {
        /// The flag, e.g. `--rpm`.
        flag: String,
        /// What is wrong.
        message: String,
    },
    /// Writing to standard output failed (a closed pipe is reported as such and ends quietly).
    #[error("cannot write to standard output: {0}")]
    Stdout(#[from] std::io::Error),
}

impl CliError {
    fn flag(flag: &str, message: impl Into<String>) -> Error {
        Self::Flag { flag: flag.into(), message: message.into() }.into()
    }
}

impl Error {
    /// True when the error is a closed standard output (`gearvib ... | head`): not a failure of ours.
    pub fn is_broken_pipe(&self) -> bool {
        matches!(self, Self::Cli(CliError::Stdout(e)) if e.kind() == std::io::ErrorKind::BrokenPipe)
    }
}

/// Makes every panic of this process record where it happened ([`jobs::note_panic`]) and print nothing: a
/// panic is a bug, reported on one line by [`guarded`] (or, in a batch, for the recording that caused it),
/// never with a backtrace.
pub fn quiet_panics() {
    std::panic::set_hook(Box::new(|info| {
        if let Some(l) = info.location() {
            jobs::note_panic(l.to_string());
        }
    }));
}

/// Runs a whole command `f` and returns the process exit code with the one line for standard error, if
/// any: `f`'s own code and no line; 0 and no line for a closed standard output (`gearvib ... | head`); 2
/// and `gearvib: error: ...` for an error; 2 and `gearvib: error: internal error at FILE:LINE:COL: WHAT (a
/// bug ...)` for a panic anywhere in `f`, worker threads included (rayon hands their panics to the
/// caller), with the location [`quiet_panics`] recorded. Never a success code after a panic.
pub fn guarded(f: impl FnOnce() -> Result<u8, Error>) -> (u8, Option<String>) {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(Ok(code)) => (code, None),
        Ok(Err(e)) if e.is_broken_pipe() => (0, None),
        Ok(Err(e)) => (2, Some(format!("gearvib: error: {e}"))),
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "a panic".into());
            let at = jobs::last_panic_location().map(|l| format!(" at {l}")).unwrap_or_default();
            // one line, whatever the panic's message holds
            let what = what.replace(['\n', '\r'], " ");
            (2, Some(format!("gearvib: error: internal error{at}: {what} (a bug in gearvib: please report it)")))
        }
    }
}

/// Runs a parsed command; returns the process exit code (0 ok, 1 fault found with `--fail-on`).
///
/// # Errors
/// Any layer's error; the caller prints it on one line and exits with code 2.
pub fn run(cli: Cli) -> Result<u8, Error> {
    let mut out = std::io::stdout().lock();
    let result = match cli.command {
        Command::Simulate { scene, output, allow_aliasing, report, json } => {
            let job = jobs::simulate::SimulateJob {
                scene: scene.into(),
                output: output.map(PathBuf::from),
                allow_aliasing,
                report: report.map(PathBuf::from),
            };
            simulate(&mut out, &job, json)
        }
        Command::Stability { scene, report, json } => stability(
            &mut out,
            &jobs::simulate::StabilityJob { scene: scene.into(), report: report.map(PathBuf::from) },
            json,
        ),
        Command::Sweep { scene, param, from, to, steps, output, report, json } => {
            let job = jobs::sweep::SweepJob {
                scene: scene.into(),
                param,
                from,
                to,
                steps,
                images: output.map(PathBuf::from).into_iter().collect(),
                report: report.map(PathBuf::from),
            };
            sweep(&mut out, &job, json)
        }
        Command::Diagnose(args) => diagnose(&mut out, &args),
        Command::Learn(args) => learn(&mut out, &args),
        Command::Identify(args) => identify(&mut out, &args),
        Command::Bench { scenes, report, json } => {
            let job = jobs::bench::BenchJob {
                scenes: scenes.into_iter().map(PathBuf::from).collect(),
                report: report.map(PathBuf::from),
            };
            bench(&mut out, &job, json)
        }
    };
    result.map_err(restate_for_flags)
}

fn warn_all(warnings: &[String]) {
    for w in warnings {
        eprintln!("gearvib: warning: {w}");
    }
}

fn json_line(out: &mut dyn Write, value: &impl serde::Serialize) -> Result<(), Error> {
    writeln!(out, "{}", to_json_line(value)).map_err(CliError::from)?;
    Ok(())
}

fn list(files: &[PathBuf]) -> String {
    files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>().join(", ")
}

/// Runs `work` under a spinner on a terminal (cleared when done): a long solve is never silent.
fn with_spinner<T>(message: &str, work: impl FnOnce() -> T) -> T {
    let pb = progress::spinner();
    if let Some(pb) = &pb {
        pb.set_message(message.to_string());
    }
    let out = work();
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    out
}

fn stability(out: &mut dyn Write, job: &jobs::simulate::StabilityJob, json: bool) -> Result<u8, Error> {
    let done = with_spinner("solving", || jobs::simulate::stability(job))?;
    warn_all(&done.summary.warnings);
    if json {
        json_line(out, &done.summary)?;
    } else {
        if !done.report_files.is_empty() {
            writeln!(out, "report: {}", list(&done.report_files)).map_err(CliError::from)?;
        }
        print::stability(out, &done.summary).map_err(CliError::from)?;
    }
    Ok(0)
}

fn simulate(out: &mut dyn Write, job: &jobs::simulate::SimulateJob, json: bool) -> Result<u8, Error> {
    if crate::scene::train::is_gear_train(&job.scene.display().to_string()) {
        let done = with_spinner("solving and writing", || jobs::train::run(job))?;
        if json {
            return json_line(out, &done).map(|_| 0);
        }
        return print::train(out, &done).map(|_| 0).map_err(|e| CliError::from(e).into());
    }
    let done = with_spinner("solving and writing", || jobs::simulate::run(job))?;
    warn_all(&done.summary.stability.warnings);
    if let Some(info) = &done.signal {
        warn_all(&info.warnings);
    }
    if json {
        return json_line(out, &done.summary).map(|_| 0);
    }
    if let Some(info) = &done.signal {
        writeln!(
            out,
            "wrote {} ({} channels, {} frames at {} Hz, {}) and {}.json",
            info.file,
            info.channels.len(),
            info.frames,
            info.sample_rate_hz,
            info.format,
            info.file
        )
        .map_err(CliError::from)?;
    }
    if !done.report_files.is_empty() {
        writeln!(out, "report: {}", list(&done.report_files)).map_err(CliError::from)?;
    }
    print::simulate(out, &done.summary).map_err(CliError::from)?;
    Ok(0)
}

fn parse_teeth(s: &str) -> Result<(usize, usize), Error> {
    let bad = || CliError::flag(&format!("--teeth {s}"), "expected two whole numbers of teeth >= 3, like 14,39");
    let (a, b) = s.split_once(',').ok_or_else(bad)?;
    let (a, b): (usize, usize) = (a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?);
    if a < 3 || b < 3 {
        return Err(bad());
    }
    Ok((a, b))
}

fn scene_teeth(path: &str) -> Result<Option<(usize, usize)>, Error> {
    let scene = Scene::load(path)?;
    Ok(match &scene.model {
        crate::scene::Model::GearPair(g) => Some((g.params().pinion_teeth, g.params().wheel_teeth)),
        _ => None,
    })
}

fn positive(flag: &str, v: f64) -> Result<f64, Error> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(CliError::flag(flag, format!("must be a finite positive number, got {v}")))
    }
}

/// The diagnose job the flags describe.
/// The diagnosis job that `diagnose` runs for these arguments (flags checked and turned into the job's
/// types), for callers that run it through the library (the report tests).
///
/// # Errors
/// A flag's value is invalid (the message names the flag).
pub fn diagnose_job(a: &DiagnoseArgs) -> Result<jobs::diagnose::DiagnoseJob<'static>, Error> {
    if a.fs.is_some() && a.fs_unknown {
        return Err(CliError::flag("--fs", "conflicts with --fs-unknown: give the sample rate or say it is unknown"));
    }
    if a.channel.is_some() && a.channel == a.tacho_channel {
        return Err(CliError::flag(
            &format!("--channel {}", a.channel.unwrap_or(0)),
            "is also the --tacho-channel: tachometer pulses are not a vibration signal",
        ));
    }
    if a.same_load && a.baseline.is_empty() && a.profile.is_none() {
        return Err(CliError::flag(
            "--same-load",
            "needs --baseline or --profile: it says where the baseline was recorded",
        ));
    }
    if a.pulses_per_rev == 0 {
        return Err(CliError::flag("--pulses-per-rev", "0: a tachometer gives at least 1 pulse per revolution"));
    }
    let shaft_hz = match (a.rpm, a.shaft_hz) {
        (Some(r), _) => Some(positive("--rpm", r)? / 60.0),
        (_, Some(h)) => Some(positive("--shaft-hz", h)?),
        _ => None,
    };
    if let Some(fs) = a.fs {
        positive("--fs", fs)?;
    } else if a.fs_override {
        return Err(CliError::flag("--fs-override", "needs --fs: the sample rate that overrides the file's"));
    }
    if !(a.speed_tolerance.is_finite() && (0.0..=0.2).contains(&a.speed_tolerance)) {
        return Err(CliError::flag(
            "--speed-tolerance",
            format!("must be between 0 and 0.2 (relative), got {}", a.speed_tolerance),
        ));
    }
    let mut teeth = a.teeth.as_deref().map(parse_teeth).transpose()?;
    let machine = match &a.machine {
        Some(m) => {
            if a.teeth.is_some() {
                return Err(CliError::flag(
                    "--teeth",
                    "cannot be given with --machine: the machine file states every stage's teeth (--teeth ZP,ZW is the one-stage shorthand)",
                ));
            }
            if a.lifter.is_some() {
                return Err(CliError::flag("--lifter", "takes pinion or wheel of a pair: not with --machine"));
            }
            Some(crate::scene::machine::load_machine_file(m)?)
        }
        None => None,
    };
    if teeth.is_none() && machine.is_none() {
        if let Some(sc) = &a.scene {
            teeth = scene_teeth(sc)?;
        }
    }
    let options = jobs::diagnose::Options {
        channel: a.channel,
        fs_hz: a.fs,
        fs_override: a.fs_override,
        fs_unknown: a.fs_unknown,
        shaft_hz,
        speed_tolerance: a.speed_tolerance,
        teeth,
        tacho_channel: a.tacho_channel,
        pulses_per_rev: a.pulses_per_rev,
        quantity: a.quantity,
        unit: a.unit.clone(),
        sensitivity: a.sensitivity,
        envelope_band: a.envelope_band.as_deref().map(parse_band).transpose()?,
        kurtogram_levels: a.kurtogram_levels.map(|l| l as usize),
        lifter: match a.lifter.as_deref() {
            Some("pinion") => Some(crate::report::summary::Shaft::Pinion),
            Some(_) => Some(crate::report::summary::Shaft::Wheel),
            None => None,
        },
        block_revs: a.block_revs.map(|r| r as usize),
        machine,
        ..Default::default()
    };
    Ok(jobs::diagnose::DiagnoseJob {
        recordings: a.recordings.iter().map(PathBuf::from).collect(),
        options,
        baselines: a.baseline.iter().map(PathBuf::from).collect(),
        profile: a.profile.as_ref().map(PathBuf::from),
        scene: a.scene.as_ref().map(PathBuf::from),
        report: a.report.as_ref().map(PathBuf::from),
        in_memory: Vec::new(),
        iso_class: a.iso_class.as_deref().and_then(crate::signal::velocity::MachineClass::from_name),
        spectrum_scale: a
            .spectrum
            .as_deref()
            .and_then(crate::report::summary::SpectrumScale::from_name)
            .unwrap_or_default(),
        baseline_load: if a.same_load {
            jobs::diagnose::BaselineLoad::Same
        } else {
            jobs::diagnose::BaselineLoad::Unknown
        },
    })
}

/// Flags that fix the machine or its processing: a profile holds them, so they cannot be given with it.
fn profile_conflicts(a: &DiagnoseArgs) -> Option<&'static str> {
    [
        (a.teeth.is_some(), "--teeth"),
        (a.machine.is_some(), "--machine"),
        (a.rpm.is_some(), "--rpm"),
        (a.shaft_hz.is_some(), "--shaft-hz"),
        (a.tacho_channel.is_some(), "--tacho-channel"),
        (a.channel.is_some(), "--channel"),
        (a.block_revs.is_some(), "--block-revs"),
        (a.envelope_band.is_some(), "--envelope-band"),
    ]
    .into_iter()
    .find(|c| c.0)
    .map(|c| c.1)
}

fn learn(out: &mut dyn Write, a: &LearnArgs) -> Result<u8, Error> {
    let d = &a.analysis;
    for (given, flag) in [
        (!d.baseline.is_empty(), "--baseline"),
        (d.profile.is_some(), "--profile"),
        (d.scene.is_some(), "--scene"),
        (d.report.is_some(), "--report"),
        (d.fail_on.is_some(), "--fail-on"),
        (d.same_load, "--same-load"),
    ] {
        if given {
            return Err(CliError::flag(flag, "does not apply to learn: it learns a profile from healthy recordings"));
        }
    }
    if a.output == "-" {
        return Err(CliError::flag("-o -", "a profile is written to a file, not to standard output: give its path"));
    }
    let job = diagnose_job(d)?;
    let learn = jobs::diagnose::profile::LearnJob {
        healthy: job.recordings,
        options: job.options,
        output: PathBuf::from(&a.output),
    };
    let p = with_spinner("learning", || jobs::diagnose::profile::learn(&learn))?;
    if d.json {
        writeln!(out, "{}", serde_json::to_string(&p).unwrap_or_default()).map_err(CliError::from)?;
    } else {
        print::profile(out, &p, &a.output).map_err(CliError::from)?;
    }
    Ok(0)
}

fn diagnose(out: &mut dyn Write, a: &DiagnoseArgs) -> Result<u8, Error> {
    if let (Some(_), Some(flag)) = (&a.profile, profile_conflicts(a)) {
        return Err(CliError::flag(
            flag,
            "cannot be given with --profile: the profile fixes the machine and its processing",
        ));
    }
    let for_profile = |e: Error| restate_for_profile(e, a.profile.as_deref(), a.fs.is_some());
    diagnose_with(out, a, &for_profile).map_err(for_profile)
}

/// [`diagnose`] once the flags are checked; `restate` turns a failed recording's error into the user's
/// terms (a profile's field).
fn diagnose_with(out: &mut dyn Write, a: &DiagnoseArgs, restate: &dyn Fn(Error) -> Error) -> Result<u8, Error> {
    let job = diagnose_job(a)?;
    if a.json && job.report.is_none() {
        // JSON Lines as the recordings are judged: a directory of any size in bounded memory
        let (mut worst, mut failed, mut unjudged) = (VerdictState::Healthy, 0, false);
        jobs::diagnose::run_streaming(&job, &mut |d| {
            match d {
                Ok(d) => {
                    worst = worst.max(d.verdict.state);
                    unjudged |= d.verdict.state == VerdictState::NotJudged;
                    json_line(out, &d)?;
                }
                Err(mut f) => {
                    failed += 1;
                    f.error = restate(f.error);
                    failure_line(out, f)?;
                }
            }
            out.flush().map_err(CliError::from)?;
            Ok(())
        })?;
        return Ok(batch_code(a.fail_on, worst, failed, unjudged));
    }
    let done = with_spinner("diagnosing", || jobs::diagnose::run(&job))?;
    if !a.json && !done.report_files.is_empty() {
        writeln!(out, "report: {}", list(&done.report_files)).map_err(CliError::from)?;
    }
    for d in &done.diagnoses {
        if a.json {
            json_line(out, d)?;
        } else {
            print::diagnosis(out, d, job.iso_class).map_err(CliError::from)?;
        }
    }
    let (worst, failed) =
        (done.diagnoses.iter().map(|d| d.verdict.state).max().unwrap_or(VerdictState::Healthy), done.failures.len());
    let unjudged = done.diagnoses.iter().any(|d| d.verdict.state == VerdictState::NotJudged);
    for mut f in done.failures {
        f.error = restate(f.error);
        if a.json {
            failure_line(out, f)?;
        } else {
            eprintln!("gearvib: error: {}", restate_for_flags(f.error));
        }
    }
    Ok(batch_code(a.fail_on, worst, failed, unjudged))
}

/// A recording of a batch that failed, in JSON Lines: `{"file": ..., "error": ...}` on standard output
/// (in its place among the others) and the error on standard error.
fn failure_line(out: &mut dyn Write, f: jobs::diagnose::Failure) -> Result<(), Error> {
    let message = restate_for_flags(f.error).to_string();
    eprintln!("gearvib: error: {message}");
    #[derive(serde::Serialize)]
    struct Line<'a> {
        file: &'a str,
        error: &'a str,
    }
    json_line(out, &Line { file: &f.file, error: &message })
}

/// Exit code of a `diagnose` batch: 2 when any recording failed (the others were reported), else
/// [`fail_code`].
fn batch_code(fail_on: Option<FailOn>, worst: VerdictState, failed: usize, unjudged: bool) -> u8 {
    if failed > 0 { 2 } else { fail_code(fail_on, worst, unjudged) }
}

/// Exit code of `diagnose`: 1 when `--fail-on` is given and the worst verdict reaches it; else 3 when a
/// recording could not be judged (nothing unscored passes for healthy); else 0.
fn fail_code(fail_on: Option<FailOn>, worst: VerdictState, unjudged: bool) -> u8 {
    match fail_on {
        Some(FailOn::Faulty) if worst >= VerdictState::Faulty => 1,
        Some(FailOn::Suspect) if worst >= VerdictState::Suspect => 1,
        _ if unjudged => 3,
        _ => 0,
    }
}

fn bench(out: &mut dyn Write, job: &jobs::bench::BenchJob, json: bool) -> Result<u8, Error> {
    let pb = progress::spinner();
    let status = |m: &str| {
        if let Some(pb) = &pb {
            pb.set_message(m.to_string());
        }
    };
    let done = jobs::bench::run(job, &status)?;
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    if json {
        return json_line(out, &done.report).map(|_| 0);
    }
    for png in &done.images {
        writeln!(out, "wrote {}", png.display()).map_err(CliError::from)?;
    }
    print::bench(out, &done.report).map_err(CliError::from)?;
    Ok(0)
}

fn sweep(out: &mut dyn Write, job: &jobs::sweep::SweepJob, json: bool) -> Result<u8, Error> {
    let bar = progress::bar(job.steps as u64);
    let tick = || {
        if let Some(b) = &bar {
            b.inc(1);
        }
    };
    let estimate = |secs: f64| {
        if secs > 2.0 || bar.is_some() {
            eprintln!("gearvib: {} points, estimated run time {secs:.1} s", job.steps);
        }
    };
    let done = jobs::sweep::run(job, &jobs::sweep::Progress { estimate: &estimate, tick: &tick })?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let failed = done.summary.points.iter().filter(|p| p.error.is_some()).count();
    if failed > 0 {
        eprintln!("gearvib: warning: {failed} of {} points failed (listed with their error in the JSON)", job.steps);
    }
    if json {
        return json_line(out, &done.summary).map(|_| 0);
    }
    print::sweep(out, &done.summary).map_err(CliError::from)?;
    for img in &done.images {
        writeln!(out, "wrote {}", img.display()).map_err(CliError::from)?;
    }
    Ok(0)
}

/// `--envelope-band LO,HI` in Hz: two finite numbers, LO >= 0 and HI > LO (the sample rate is checked when
/// the recording is read).
fn parse_band(s: &str) -> Result<(f64, f64), Error> {
    let bad = |why: &str| -> Error {
        CliError::Flag { flag: "--envelope-band".into(), message: format!("{s:?}: {why}") }.into()
    };
    let (lo, hi) = s.split_once(',').ok_or_else(|| bad("expected LO,HI in Hz, e.g. 2000,4000"))?;
    let (lo, hi): (f64, f64) = match (lo.trim().parse(), hi.trim().parse()) {
        (Ok(l), Ok(h)) => (l, h),
        _ => return Err(bad("expected two numbers in Hz, e.g. 2000,4000")),
    };
    if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > lo) {
        return Err(bad("the band is empty: need 0 <= LO < HI"));
    }
    Ok((lo, hi))
}

fn identify(out: &mut dyn Write, a: &IdentifyArgs) -> Result<u8, Error> {
    let job = jobs::identify::IdentifyJob {
        recording: a.recording.clone().into(),
        scene: a.scene.clone().into(),
        pinion_orders: a.pinion_orders,
        wheel_orders: a.wheel_orders,
        mesh_harmonics: a.mesh_harmonics.map(|h| h as usize),
        faults: a.faults.clone(),
        pit_width_teeth: a.pit_width,
        channel: a.channel,
        tacho_channel: a.tacho_channel,
        fs_hz: a.fs,
        quantity: a.quantity,
        report: a.report.clone().map(PathBuf::from),
    };
    // identify takes no --fs-unknown: a file without a sample rate needs --fs
    let result = with_spinner("identifying", || jobs::identify::run(&job)).map_err(|e| match e {
        Error::Job(JobError::NoSampleRate { file, .. }) => {
            CliError::flag("--fs", format!("{file} has no sample rate (no time column); give it with --fs HZ"))
        }
        other => other,
    })?;
    if a.json {
        json_line(out, &result)?;
        warn_all(&result.warnings);
    } else {
        print::identification(out, &result).map_err(CliError::from)?;
    }
    if let Some(dir) = &job.report {
        eprintln!("gearvib: report written to {}", dir.join("index.html").display());
    }
    Ok(0)
}

#[cfg(test)]
mod tests;
