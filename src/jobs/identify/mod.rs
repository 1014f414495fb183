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
pub mod measure;
pub mod transfer;

use super::JobError;
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

fn value(what: &str, msg: impl std::fmt::Display) -> Error {
    JobError::Value { what: what.into(), message: msg.to_string() }.into()
}

/// The scene's gear pair, without its errors, faults and crack (what the fit estimates).
fn gear_params(job: &IdentifyJob, warnings: &mut Vec<String>) -> Result<GearPairParams, Error> {
    let scene = Scene::load(&job.scene.display().to_string())?;
    let Model::GearPair(pair) = &scene.model else {
        return Err(bad(
            &job.scene,
            "the scene is not a gear pair (model gear_pair): identify fits a gear pair's tooth errors",
        ));
    };
    let params = pair.params().clone();
    if !matches!(params.mesh, MeshStiffness::Fourier(_)) {
        return Err(bad(
            &job.scene,
            "mesh_stiffness must be a Fourier series for identify (its transfers are solved by harmonic balance)",
        ));
    }
    if !params.pinion_errors.is_constant() || !params.wheel_errors.is_constant() || params.crack.is_some() {
        warnings.push("the scene's own tooth errors, faults and crack are ignored: they are what is fitted".into());
    }
    Ok(params)
}

/// Channel roles of a recording: the vibration channel and the tachometers (0-based).
struct Channels {
    vibration: usize,
    pinion_tacho: Option<usize>,
    wheel_tacho: Option<usize>,
}

fn channels(job: &IdentifyJob, rec: &Recording) -> Result<Channels, Error> {
    let n = rec.channels.len();
    let check = |role: super::ChannelRole, c: usize| -> Result<usize, Error> {
        if c == 0 || c > n {
            Err(JobError::Channel { file: job.recording.display().to_string(), role, index: c, count: n }.into())
        } else {
            Ok(c - 1)
        }
    };
    let named = |name: &str| rec.names.iter().position(|c| c == name);
    let pinion_tacho = match job.tacho_channel {
        Some(c) => Some(check(super::ChannelRole::Tachometer, c)?),
        None => named(super::diagnose::PINION_TACHO),
    };
    let wheel_tacho = named("tacho wheel");
    let vibration = match job.channel {
        Some(c) => check(super::ChannelRole::Vibration, c)?,
        None => (0..n)
            .find(|&c| Some(c) != pinion_tacho && !rec.names[c].starts_with("tacho") && rec.units[c] != "pulse")
            .ok_or_else(|| bad(&job.recording, "no vibration channel besides the tachometers"))?,
    };
    if Some(vibration) == pinion_tacho {
        return Err(bad(
            &job.recording,
            format!("channel {} is the tachometer: it cannot also be the vibration", vibration + 1),
        ));
    }
    Ok(Channels { vibration, pinion_tacho, wheel_tacho })
}

fn sample_rate(job: &IdentifyJob, rec: &Recording) -> Result<f64, Error> {
    let fs = job.fs_hz.or(rec.sample_rate_hz).ok_or_else(|| {
        Error::from(JobError::NoSampleRate { file: job.recording.display().to_string(), for_speed: false })
    })?;
    let (lo, hi) = super::diagnose::SAMPLE_RATE_RANGE_HZ;
    if !(fs.is_finite() && (lo..=hi).contains(&fs)) {
        return Err(value("sample rate", format!("must be between {lo} Hz and {hi:e} Hz, got {fs:e} Hz")));
    }
    Ok(fs)
}

fn quantity(job: &IdentifyJob, rec: &Recording, c: usize, warnings: &mut Vec<String>) -> Quantity {
    if let Some(q) = job.quantity {
        return q;
    }
    match Quantity::from_unit(&rec.units[c]) {
        Some(q) => q,
        None => {
            warnings.push(format!(
                "channel {} names no unit: taken as velocity (dq/dt); give --quantity if it is not",
                c + 1
            ));
            Quantity::Velocity
        }
    }
}

/// The tracked angle; checks the speed against the scene's.
fn track(job: &IdentifyJob, rec: &Recording, ch: &Channels, fs: f64, p: &GearPairParams) -> Result<Angle, Error> {
    let scene_hz = p.speed_rpm / 60.0;
    let teeth = (p.pinion_teeth, p.wheel_teeth);
    let x = &rec.channels[ch.vibration];
    let angle = match ch.pinion_tacho {
        Some(t) => measure::angle_from_tacho(&rec.channels[t], ch.wheel_tacho.map(|w| &*rec.channels[w]), teeth)
            .map_err(|e| bad(&job.recording, format!("tachometer channel {}: {e}", t + 1)))?,
        None => measure::angle_from_mesh(x, fs / scene_hz, p.pinion_teeth).map_err(|e| {
            bad(
                &job.recording,
                format!("no tachometer, and the mesh line (order {}) cannot be tracked: {e}", p.pinion_teeth),
            )
        })?,
    };
    let mean_hz = angle.speed.mean * fs;
    let off = mean_hz / scene_hz - 1.0;
    if off.abs() > MAX_SPEED_OFFSET {
        return Err(bad(
            &job.recording,
            format!(
                "runs at {mean_hz:.3} Hz ({:.1} rpm), {:+.1} % from the scene's {:.1} rpm: the scene does not model this operating point (more than {:.0} % apart)",
                mean_hz * 60.0,
                100.0 * off,
                p.speed_rpm,
                100.0 * MAX_SPEED_OFFSET
            ),
        ));
    }
    Ok(angle)
}

/// Highest harmonic of the averaged period the fit may use (the harmonic-balance and averaging work grows
/// with it; the bundled 14/39 pair with wheel orders needs about 4000).
pub const MAX_PERIOD_ORDER: usize = 1 << 18;

/// Largest relative difference between the recording's speed and the scene's that the model is re-solved
/// for (beyond it the scene is another operating point).
pub const MAX_SPEED_OFFSET: f64 = 0.10;

/// Mesh harmonics the sample rate resolves with every sideband of the fit below [`MAX_LINE_FRACTION`].
fn resolvable_harmonics(job: &IdentifyJob, p: &GearPairParams, per_rev: f64) -> Result<usize, Error> {
    let (z1, z2) = (p.pinion_teeth, p.wheel_teeth);
    let side = (job.pinion_orders as f64).max(job.wheel_orders as f64 * z1 as f64 / z2 as f64);
    let top = MAX_LINE_FRACTION * per_rev;
    let h = ((top - side) / z1 as f64).floor();
    if h < 1.0 {
        return Err(bad(
            &job.recording,
            format!(
                "{per_rev:.1} samples per pinion revolution resolve orders up to {top:.1}: the first mesh harmonic (order {z1}) and its sidebands up to order {:.1} are beyond it; the sample rate is too low for this gear pair",
                z1 as f64 + side
            ),
        ));
    }
    Ok((h as usize).min(job.mesh_harmonics.unwrap_or(MAX_HARMONICS)))
}

fn check_orders(job: &IdentifyJob, p: &GearPairParams) -> Result<(), Error> {
    let (z1, z2) = (p.pinion_teeth, p.wheel_teeth);
    if job.pinion_orders == 0 && job.wheel_orders == 0 {
        return Err(value("orders", "--pinion-orders and --wheel-orders are both 0: nothing to fit"));
    }
    if 2 * job.pinion_orders >= z1 {
        return Err(value(
            "pinion orders",
            format!(
                "{} with {z1} pinion teeth: the sidebands of orders {} and {} of neighbouring mesh harmonics fall on the same lines, so orders from z1 / 2 = {} up are not identifiable; use at most {}",
                job.pinion_orders,
                z1 / 2,
                z1 - z1 / 2,
                z1 as f64 / 2.0,
                (z1 - 1) / 2
            ),
        ));
    }
    if 2 * job.wheel_orders >= z2 {
        return Err(value(
            "wheel orders",
            format!("{} with {z2} wheel teeth: use at most {}", job.wheel_orders, (z2 - 1) / 2),
        ));
    }
    if !(job.pit_width_teeth.is_finite() && job.pit_width_teeth > 0.0 && job.pit_width_teeth <= 3.0) {
        return Err(value("pit width", format!("must be in (0, 3] tooth pitches, got {}", job.pit_width_teeth)));
    }
    Ok(())
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
            "wheel orders",
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
            if job.faults.is_empty() { " (a local fault? try --faults crack,pit)" } else { "" }
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

/// chi2/dof above which the fit is said not to explain the recording.
pub const POOR_FIT_CHI2: f64 = 25.0;

/// A warning when the scene's teeth do not fit the recording: the measured line at the first mesh order
/// h z1 must stand above every sideband of its band, as a mesh line does (a wrong z1 puts the "mesh" on a
/// sideband or between lines).
fn teeth_misfit(setup: &Setup, y: &[C64]) -> Option<String> {
    let mesh = setup.lines.iter().zip(y).find(|(l, _)| l.harmonic == 1 && l.kind == LineKind::Mesh)?.1.norm();
    let (line, top) = setup
        .lines
        .iter()
        .zip(y)
        .filter(|(l, _)| l.harmonic == 1 && l.kind != LineKind::Mesh)
        .map(|(l, v)| (l, v.norm()))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    (top > mesh).then(|| {
        format!(
            "the scene's teeth ({}, {}) do not fit this recording: the line at the mesh order {} is {:.2} times weaker than the one at order {} beside it; check the scene",
            setup.params.pinion_teeth,
            setup.params.wheel_teeth,
            setup.params.pinion_teeth,
            top / mesh,
            line.m as f64 / setup.period_revs as f64
        )
    })
}

/// Sideband energy explained: 1 - sum |Y - Yhat|^2 / sum |Y|^2 over the sidebands.
fn explained(setup: &Setup, y: &[C64], model: &[C64]) -> f64 {
    let (mut res, mut tot) = (0.0, 0.0);
    for ((l, v), m) in setup.lines.iter().zip(y).zip(model) {
        if l.kind != LineKind::Mesh {
            res += (v - m).norm_sqr();
            tot += v.norm_sqr();
        }
    }
    if tot > 0.0 { 1.0 - res / tot } else { 0.0 }
}

/// Error harmonics from the parameters (Re E, Im E pairs) and their covariance:
/// amplitude |E|, phase arg E, standard errors by the delta method.
fn harmonics(setup: &Setup, f: &fit::Fit) -> (Vec<ErrorHarmonic>, Vec<ErrorHarmonic>) {
    let one = |k: usize, order: usize| {
        let (re, im) = (f.params[2 * k], f.params[2 * k + 1]);
        let c = &f.covariance;
        let (vrr, vii, vri) = (c[2 * k][2 * k], c[2 * k + 1][2 * k + 1], c[2 * k][2 * k + 1]);
        let a = re.hypot(im);
        let a2 = (a * a).max(f64::MIN_POSITIVE);
        let var_a = (re * re * vrr + im * im * vii + 2.0 * re * im * vri) / a2;
        let var_p = (im * im * vrr + re * re * vii - 2.0 * re * im * vri) / (a2 * a2);
        let amplitude_std_m = var_a.max(0.0).sqrt();
        ErrorHarmonic {
            order,
            amplitude_m: a,
            phase_rad: im.atan2(re),
            amplitude_std_m,
            phase_std_rad: var_p.max(0.0).sqrt().min(PI),
            resolved: a > 3.0 * amplitude_std_m,
        }
    };
    let n = setup.pinion_orders;
    let pinion = (0..n).map(|k| one(k, k + 1)).collect();
    let wheel = (0..setup.wheel_orders).map(|k| one(n + k, k + 1)).collect();
    (pinion, wheel)
}

/// e of each gear at its teeth's centres theta_n = 2 pi (n - 1/2) / z, from the fitted harmonics (plus a
/// found pit on its gear), with standard errors from the covariance (the pit depth's own variance added).
fn tooth_deviations(
    setup: &Setup,
    f: &fit::Fit,
    fault: Option<&LocalFault>,
    pit_width: f64,
    np: usize,
) -> (PerTooth, PerTooth) {
    let gear_dev = |z: usize, first: usize, orders: usize, gear: Gear| -> (Vec<f64>, Vec<f64>) {
        if orders == 0 {
            return (Vec::new(), Vec::new());
        }
        let pit = fault.filter(|l| l.kind == FaultKind::Pit && l.gear == gear).map(|l| {
            let g = crate::model::gear::gaussian_tooth_faults(
                z,
                &[crate::model::gear::ToothFault { tooth: l.tooth, depth_m: 1.0, width_teeth: pit_width }],
                1e-9,
            );
            (g, l.depth)
        });
        (1..=z)
            .map(|n| {
                let theta = 2.0 * PI * (n as f64 - 0.5) / z as f64;
                // d = sum_i Re E_i cos(i theta) - Im E_i sin(i theta): gradient g over (Re, Im) pairs
                let grad: Vec<f64> =
                    (1..=orders).flat_map(|i| [(i as f64 * theta).cos(), -(i as f64 * theta).sin()]).collect();
                let idx = |k: usize| first + k;
                let mut d: f64 = grad.iter().enumerate().map(|(k, g)| g * f.params[idx(k)]).sum();
                let mut var: f64 = (0..grad.len())
                    .flat_map(|a| (0..grad.len()).map(move |b| (a, b)))
                    .map(|(a, b)| grad[a] * grad[b] * f.covariance[idx(a)][idx(b)])
                    .sum();
                if let Some((g, depth)) = &pit {
                    let shape = g.eval(theta / g.omega_rad_s);
                    d += depth * shape;
                    if f.params.len() > np {
                        var += shape * shape * f.covariance[np][np];
                    }
                }
                (d, var.max(0.0).sqrt())
            })
            .unzip()
    };
    let (p, ps) = gear_dev(setup.params.pinion_teeth, 0, setup.pinion_orders, Gear::Pinion);
    let (w, ws) = gear_dev(setup.params.wheel_teeth, 2 * setup.pinion_orders, setup.wheel_orders, Gear::Wheel);
    (PerTooth { pinion: p, wheel: w }, PerTooth { pinion: ps, wheel: ws })
}

fn label(kind: LineKind, h: usize) -> String {
    match kind {
        LineKind::Mesh => format!("mesh {h}"),
        LineKind::Pinion(s) => format!("mesh {h} {} pinion {}", if s < 0 { "-" } else { "+" }, s.abs()),
        LineKind::Wheel(s) => format!("mesh {h} {} wheel {}", if s < 0 { "-" } else { "+" }, s.abs()),
    }
}

fn fit_lines(setup: &Setup, y: &[C64], model: &[C64], noise: &[f64]) -> Vec<FitLine> {
    setup
        .lines
        .iter()
        .enumerate()
        .map(|(k, l)| FitLine {
            order: l.m as f64 / setup.period_revs as f64,
            frequency_hz: setup.frequency_hz(l.m),
            label: label(l.kind, l.harmonic),
            measured: y[k].norm(),
            model: model[k].norm(),
            residual: (y[k] - model[k]).norm(),
            noise: noise[k],
        })
        .collect()
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
