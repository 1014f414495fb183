//! `identify`: the gear-pair model of a scene fitted to a recording. The recording is tracked (tachometer,
//! else the mesh phase) and averaged over whole model periods; the transmission-error harmonics of each
//! gear and one complex transfer-path gain per mesh harmonic are fitted to the mesh lines and their
//! sidebands ([`fit`]); optionally a local fault (pit or crack) on one tooth is searched for
//! ([`faults`]). See [`transfer`] for the model side and [`measure`] for the measured side.
//!
//! The path gain of mesh harmonic h multiplies the mesh line and all its sidebands alike, so what the fit
//! really uses is the sideband-to-mesh ratios, which the unknown path from the mesh to the sensor leaves
//! alone. The mesh line itself carries no error harmonic (order i < z1 / 2 cannot reach it): it sets the
//! gain, the sidebands set the errors.

pub mod faults;
pub mod fit;
mod input;
pub mod measure;
mod results;
pub mod transfer;

use input::*;
pub use input::{MAX_PERIOD_ORDER, MAX_SPEED_OFFSET};
pub use results::POOR_FIT_CHI2;
use results::*;

use super::{Given, JobError};
use crate::Error;
use crate::io::{self, Recording};
use crate::model::Quantity;
use crate::model::gear::{Gear, GearPairParams, MeshStiffness};
pub use crate::report::summary::{
    ErrorHarmonic, FaultKind, FitLine, Identification, LocalFault, Origins, PathGain, PerTooth, PhaseOrigin, Speed,
};
use crate::scene::{Model, Scene};
use measure::{Angle, Coefficients};
use nalgebra::Complex;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use transfer::{LineKind, Setup, Transfers};

type C64 = Complex<f64>;

/// One `identify` call.
#[derive(Clone, Debug)]
pub struct IdentifyJob {
    /// The recording (WAV or CSV).
    pub recording: PathBuf,
    /// The scene giving the gear pair.
    pub scene: PathBuf,
    /// Pinion error orders 1..=N to fit (N < z1 / 2).
    pub pinion_orders: usize,
    /// Wheel error orders 1..=M to fit (M < z2 / 2; above 0 the period is the hunting period).
    pub wheel_orders: usize,
    /// Mesh harmonics to use (`None`: all the sample rate resolves, at most [`MAX_HARMONICS`]).
    pub mesh_harmonics: Option<usize>,
    /// Local faults to search for.
    pub faults: Vec<FaultKind>,
    /// Width of a pit in tooth pitches (6 sigma of the Gaussian).
    pub pit_width_teeth: f64,
    /// 1-based vibration channel (`None`: the first that is not a tachometer).
    pub channel: Option<usize>,
    /// 1-based pinion tachometer channel (`None`: the sidecar's "tacho pinion", else none).
    pub tacho_channel: Option<usize>,
    /// Sample rate override in Hz.
    pub fs_hz: Option<f64>,
    /// What the recording measures (`None`: from its unit, else the scene's output quantity).
    pub quantity: Option<Quantity>,
    /// Directory for images, JSON and `index.html`.
    pub report: Option<PathBuf>,
}

/// Mesh harmonics used at most by default (the stiffness series of the paper's gear has ten).
pub const MAX_HARMONICS: usize = 10;

/// Fewest whole model periods the average needs (the noise of each line is estimated from their scatter).
pub const MIN_PERIODS: usize = 4;

/// Highest line frequency used, as a fraction of the sample rate (the resampling filter is flat to 0.35
/// cycles per sample; above it amplitudes drop).
pub const MAX_LINE_FRACTION: f64 = 0.35;

fn bad(path: &Path, msg: impl std::fmt::Display) -> Error {
    JobError::Input { file: path.display().to_string(), message: msg.to_string() }.into()
}

fn value(what: Given, msg: impl std::fmt::Display) -> Error {
    JobError::Value { what, message: msg.to_string() }.into()
}

/// Runs the identification.
///
/// # Errors
/// A scene that is not a Fourier-stiffness gear pair; a recording that cannot be read, tracked or
/// averaged over enough periods, of another speed than the scene, or whose sample rate does not resolve
/// the first mesh harmonic's sidebands; orders that are not identifiable; writing the report.
pub fn run(job: &IdentifyJob) -> Result<Identification, Error> {
    let mut warnings = Vec::new();
    let mut params = gear_params(job, &mut warnings)?;
    check_orders(job, &params)?;
    let rec = io::read_recording(&job.recording)?;
    let ch = channels(job, &rec)?;
    let fs = sample_rate(job, &rec)?;
    check_samples(job, &rec.channels[ch.vibration])?;
    let quantity = quantity(job, &rec, ch.vibration, &mut warnings);
    let angle = track(job, &rec, &ch, fs, &params)?;
    let scene_hz = params.speed_rpm / 60.0;
    let mean_hz = angle.speed.mean * fs;
    if (mean_hz / scene_hz - 1.0).abs() > 0.002 {
        warnings.push(format!(
            "the recording runs at {:.1} rpm, the scene at {:.1} rpm: the model is solved at the recording's speed",
            mean_hz * 60.0,
            params.speed_rpm
        ));
    }
    params.speed_rpm = mean_hz * 60.0;
    let per_rev = fs / mean_hz;
    let harmonics = resolvable_harmonics(job, &params, per_rev)?;
    let setup = Setup::new(params, job.pinion_orders, job.wheel_orders, harmonics, quantity);
    if setup.max_m() > MAX_PERIOD_ORDER {
        return Err(value(
            Given::WheelOrders,
            format!(
                "the hunting period of {} pinion revolutions puts the lines up to harmonic {} of it (at most {MAX_PERIOD_ORDER}): fit no wheel orders, or fewer mesh harmonics",
                setup.period_revs,
                setup.max_m()
            ),
        ));
    }
    let measured = average(job, &rec.channels[ch.vibration], &angle, &setup, per_rev, &mut warnings)?;
    let origins = origins(&angle, &setup, &mut warnings);
    let transfers = transfer::healthy(&setup)?;
    let mut out = identify(job, &setup, &measured, &transfers, &mut warnings)?;
    out.sample_rate_hz = fs;
    out.unit =
        rec.units.get(ch.vibration).cloned().filter(|u| !u.is_empty()).unwrap_or_else(|| "recording unit".into());
    out.speed = Speed { mean_hz, min_hz: angle.speed.min * fs, max_hz: angle.speed.max * fs, scene_hz };
    out.phase_origin = origins;
    out.warnings.extend(warnings);
    if let Some(dir) = &job.report {
        write_report(&out, dir)?;
    }
    Ok(out)
}

fn check_samples(job: &IdentifyJob, x: &[f32]) -> Result<(), Error> {
    if x.len() < 2 {
        return Err(bad(&job.recording, format!("{} sample(s): far too short to analyse", x.len())));
    }
    if let Some(i) = x.iter().position(|v| !v.is_finite()) {
        return Err(bad(&job.recording, format!("non-finite sample at index {i}")));
    }
    Ok(())
}

/// The measured coefficients over whole periods, starting where both gears are at angle 0 when a wheel
/// tachometer says where that is.
fn average(
    job: &IdentifyJob,
    x: &[f32],
    angle: &Angle,
    setup: &Setup,
    per_rev: f64,
    warnings: &mut Vec<String>,
) -> Result<Coefficients, Error> {
    let p = setup.period_revs;
    let first = if p > 1 { angle.wheel_start.unwrap_or(0) } else { 0 };
    let revs = angle.map.revolutions().saturating_sub(first);
    let periods = revs / p;
    if periods < MIN_PERIODS {
        return Err(bad(
            &job.recording,
            format!(
                "{revs} whole pinion revolutions give {periods} period(s) of {p} revolution(s); the fit needs at least {MIN_PERIODS} (the noise of each line comes from their scatter): record longer{}",
                if p > 1 { " or fit no wheel orders" } else { "" }
            ),
        ));
    }
    if periods < 16 {
        warnings.push(format!(
            "only {periods} periods averaged: the noise estimates of the lines are rough (standard errors within about {:.0} %)",
            100.0 / (2.0 * (periods - 1) as f64).sqrt()
        ));
    }
    let map = if first > 0 {
        crate::signal::tsa::AngleMap::from_pulses(&angle.map.starts()[first..], 1)
    } else {
        angle.map.clone()
    };
    let points = (per_rev.ceil() as usize).next_power_of_two().max(64);
    Ok(measure::coefficients(x, &map, p, periods, points, setup.max_m()))
}

fn origins(angle: &Angle, setup: &Setup, warnings: &mut Vec<String>) -> Origins {
    let pinion = angle.origin;
    let wheel = if setup.wheel_orders == 0 {
        pinion
    } else if angle.origin == PhaseOrigin::Tachometer && angle.wheel_start.is_some() {
        PhaseOrigin::Tachometer
    } else {
        PhaseOrigin::Arbitrary
    };
    if pinion == PhaseOrigin::Arbitrary {
        warnings.push("no tachometer: phases and tooth numbers are relative to an arbitrary origin (tooth 1 is not a physical tooth 1)".into());
    } else if wheel == PhaseOrigin::Arbitrary {
        warnings.push("no wheel tachometer where both gears are at angle 0: wheel phases and wheel tooth numbers are relative to an arbitrary origin".into());
    }
    Origins { pinion, wheel }
}

/// Noise of each line: the pooled standard error of its mesh harmonic's sidebands (the additive noise is
/// smooth over a band); the mesh line keeps its own when larger (its scatter between periods also holds
/// the jitter of the tracked angle, which grows with the line). Floored at 1e-9 of the band's mesh line so a
/// noiseless synthetic recording still weighs sensibly.
fn line_noise(setup: &Setup, m: &Coefficients) -> Vec<f64> {
    let mut pooled = vec![(0.0, 0usize, 0.0f64); setup.harmonics];
    for l in &setup.lines {
        let b = &mut pooled[l.harmonic - 1];
        if l.kind == LineKind::Mesh {
            b.2 = m.mean[l.m].norm();
        } else {
            b.0 += m.std_error[l.m].powi(2);
            b.1 += 1;
        }
    }
    setup
        .lines
        .iter()
        .map(|l| {
            let (ss, n, mesh) = pooled[l.harmonic - 1];
            let band = (ss / n.max(1) as f64).sqrt();
            let own = if l.kind == LineKind::Mesh { m.std_error[l.m] } else { 0.0 };
            band.max(own).max(1e-9 * mesh).max(f64::MIN_POSITIVE)
        })
        .collect()
}

/// Fit, per-tooth deviations, lines, local faults.
fn identify(
    job: &IdentifyJob,
    setup: &Setup,
    measured: &Coefficients,
    transfers: &Transfers,
    warnings: &mut Vec<String>,
) -> Result<Identification, Error> {
    let y: Vec<C64> = setup.lines.iter().map(|l| measured.mean[l.m]).collect();
    let noise = line_noise(setup, measured);
    let band: Vec<usize> = setup.lines.iter().map(|l| l.harmonic - 1).collect();
    let cols: Vec<&[C64]> = transfers.columns.iter().map(Vec::as_slice).collect();
    let problem = fit::Problem {
        measured: &y,
        noise: &noise,
        band: &band,
        bands: setup.harmonics,
        base: &transfers.base,
        columns: &cols,
    };
    let healthy = fit::fit(&problem, None).map_err(|e| bad(&job.recording, e))?;
    let search = faults::search(job, setup, &problem, &healthy)?;
    let chosen = search.chosen.as_ref();
    let f = chosen.map_or(&healthy, |c| &c.fit);
    let np = 2 * (setup.pinion_orders + setup.wheel_orders);
    let (pinion_errors, wheel_errors) = harmonics(setup, f);
    let (dev, dev_std) = tooth_deviations(setup, f, chosen.map(|c| &c.fault), job.pit_width_teeth, np);
    let lines = fit_lines(setup, &y, &f.model, &noise);
    let lines_under_noise = setup
        .lines
        .iter()
        .zip(&y)
        .zip(&noise)
        .filter(|((l, v), s)| l.kind != LineKind::Mesh && v.norm() < 3.0 * **s)
        .count();
    warnings.extend(teeth_misfit(setup, &y));
    let chi2_per_dof = f.chi2 / f.dof as f64;
    if chi2_per_dof > POOR_FIT_CHI2 {
        warnings.push(format!(
            "the fitted model leaves {chi2_per_dof:.0} times the noise on the lines (chi2/dof): it does not explain this recording well{}; read the errors as the best fit of a model that misses something (see the missed lines)",
            if job.faults.is_empty() { " (a local fault? search for cracks and pits too)" } else { "" }
        ));
    }
    let identifiable = f.condition < 1e10;
    if !identifiable {
        warnings.push(format!(
            "the fit is not identifiable (condition {:.1e}): the lines do not separate the parameters; the numbers below are not to be trusted",
            f.condition
        ));
    }
    if lines_under_noise > 0 {
        warnings.push(format!(
            "{lines_under_noise} of {} sidebands are under three noise standard errors: the orders that rest on them are marked unresolved",
            setup.lines.iter().filter(|l| l.kind != LineKind::Mesh).count()
        ));
    }
    let mut residual_lines: Vec<FitLine> = lines.iter().filter(|l| l.residual > 3.0 * l.noise).cloned().collect();
    residual_lines.sort_by(|a, b| b.residual.total_cmp(&a.residual));
    residual_lines.truncate(12);
    Ok(Identification {
        recording: job.recording.display().to_string(),
        scene: job.scene.display().to_string(),
        sample_rate_hz: 0.0,
        quantity: setup.quantity,
        unit: String::new(),
        speed: Speed { mean_hz: 0.0, min_hz: 0.0, max_hz: 0.0, scene_hz: 0.0 },
        pinion_teeth: setup.params.pinion_teeth,
        wheel_teeth: setup.params.wheel_teeth,
        period_revolutions: setup.period_revs,
        periods: measured.periods,
        phase_origin: Origins { pinion: PhaseOrigin::Arbitrary, wheel: PhaseOrigin::Arbitrary },
        mesh_harmonics: setup.harmonics,
        pinion_errors,
        wheel_errors,
        tooth_deviation_m: dev,
        tooth_deviation_std_m: dev_std,
        path_gains: f
            .gains
            .iter()
            .enumerate()
            .map(|(b, g)| PathGain { harmonic: b + 1, magnitude: g.norm(), phase_rad: g.arg() })
            .collect(),
        explained_fraction: explained(setup, &y, &f.model),
        chi2_per_dof,
        condition: f.condition,
        identifiable,
        lines_under_noise,
        residual_lines,
        lines,
        local_fault: search.chosen.map(|c| c.fault),
        fault_candidates: search.candidates,
        warnings: Vec::new(),
    })
}

/// Writes `identify.json`, the images and `index.html` into `dir`.
///
/// # Errors
/// Creating the directory or writing a file.
pub fn write_report(out: &Identification, dir: &Path) -> Result<Vec<PathBuf>, Error> {
    io::create_dir(dir)?;
    let json = dir.join("identify.json");
    io::write_atomic(&json, (serde_json::to_string_pretty(out).unwrap_or_default() + "\n").as_bytes())?;
    let images = crate::report::identify::figures(out, dir)?;
    let section = crate::report::identify::section(out, &images);
    let index = crate::report::html::write(dir, "gearvib identify: tooth errors fitted to a recording", &[section])?;
    Ok([vec![json], images, vec![index]].concat())
}
