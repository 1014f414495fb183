//! Simulation of a `gear_train` scene: when the stages' own periods share a short common period (their
//! frequency ratio a fraction of small numerator and denominator) the whole train is one periodic system over
//! it, solved with the ordinary solvers (Floquet multipliers included); when not, its quasi-periodic steady
//! state comes from the two-frequency harmonic balance (`solver::quasi`), without integrating thousands of
//! mesh cycles. The summary says which was done and why; the recording holds the machine's sensors.
//!
//! ```text
//! sensor signal (every sensor, in its unit, times its sensitivity): s(t) = sum_k dq_k/dt, q_k = delta_k,
//!     the line-of-action velocity of every mesh summed (a housing that sees all meshes with unit gain);
//!     m/s^2 and g sensors get its time derivative, m and um sensors its integral (no mean)
//! ```

use super::JobError;
use super::simulate::SimulateJob;
use crate::Error;
use crate::model::SecondOrderSystem;
use crate::model::gear_train::{GearTrain, rational_gcd};
use crate::model::kinematics::{Ratio, SensorUnit};
use crate::scene::train::TrainScene;
use crate::solver::quasi::{self, TwoToneSolution};
use crate::solver::{self, SteadyState, Trajectory};
use crate::system::PeriodicSystem;
use nalgebra::Complex;
use std::f64::consts::PI;

/// Largest numerator or denominator of the stages' frequency ratio (nu_k / nu0) for which the common period
/// is called short and the train solved over it.
pub const SHORT_PERIOD_RATIO: i128 = 16;
/// Most harmonics per base frequency the two-frequency balance may grow to.
const MAX_QUASI_HARMONICS: usize = 1 << 17;
/// Lines listed in the summary.
const SUMMARY_LINES: usize = 40;

/// One spectral line of the sensor quantity.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TrainLine {
    /// Frequency, Hz.
    pub frequency_hz: f64,
    /// One-sided amplitude of sum_k dq_k/dt, m/s.
    pub amplitude: f64,
    /// Which combination: "k nu1 + l nu2" of the stage base frequencies, or "h nu0" of the common base.
    pub label: String,
}

/// A Floquet multiplier.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TrainMultiplier {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
    /// Modulus.
    pub abs: f64,
}

/// The `simulate --json` summary of a gear train.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TrainSummary {
    /// Scene name.
    pub scene: String,
    /// Always "gear_train".
    pub model: String,
    /// "hill", "rk4", "magnus4" (over the common period) or "quasi-hb" (two-frequency harmonic balance).
    pub method: String,
    /// Why that method.
    pub method_reason: String,
    /// Every shaft's rotation frequency, Hz, in the machine file's order.
    pub shaft_hz: Vec<f64>,
    /// Shaft names.
    pub shafts: Vec<String>,
    /// Every stage's mesh frequency, Hz.
    pub mesh_hz: Vec<f64>,
    /// Every stage's own base frequency (its coefficients' period is 1 / this), Hz.
    pub stage_base_hz: Vec<f64>,
    /// The exact common period, s (however long).
    pub common_period_s: f64,
    /// The period solved over, s (`null` for the quasi-periodic balance).
    pub period_s: Option<f64>,
    /// Floquet multipliers over `period_s` (`null` when no short common period exists).
    pub multipliers: Option<Vec<TrainMultiplier>>,
    /// |rho|max.
    pub rho_max: Option<f64>,
    /// |rho|max < 1.
    pub stable: Option<bool>,
    /// What the stability fields mean or why they are missing.
    pub stability_note: String,
    /// Estimated relative error of the steady state.
    pub error_estimate: f64,
    /// Truncation: harmonics of nu0, or K and L of nu1 and nu2; or steps.
    pub resolution: Vec<usize>,
    /// Strongest lines of the sensor quantity (sum of the meshes' dq/dt).
    pub lines: Vec<TrainLine>,
    /// RMS of the sensor quantity, m/s.
    pub rms: f64,
    /// Written recording.
    pub signal_file: Option<String>,
    /// What was modelled.
    pub notes: Vec<String>,
}

/// A line of the sensor quantity: angular frequency (rad/s), complex coefficient (m/s), label.
type Line = (f64, Complex<f64>, String);

/// The solved train: the sensor quantity as lines (angular frequency rad/s, complex amplitude Z with
/// s(t) = Re Z_0 + 2 Re sum Z e^{i w t}) plus the summary.
pub struct TrainSolution {
    /// Lines (w >= 0, rad/s; complex coefficient of sum_k dq_k/dt, m/s) with labels.
    pub lines: Vec<(f64, Complex<f64>, String)>,
    /// The summary.
    pub summary: TrainSummary,
}

fn input_error(scene: &TrainScene, e: impl std::fmt::Display) -> Error {
    JobError::Input { file: scene.file.clone(), message: e.to_string() }.into()
}

/// Runs `simulate` on a `gear_train` scene: solve, refuse an untrusted result, write the recording.
///
/// # Errors
/// Invalid scene or machine file, solver failure, an untrusted result, unwritable output.
pub fn run(job: &SimulateJob) -> Result<TrainSummary, Error> {
    crate::io::begin_run();
    let scene = TrainScene::load(&job.scene.display().to_string())?;
    if job.report.is_some() {
        return Err(JobError::Input {
            file: scene.file.clone(),
            message: "report images are not drawn for gear_train scenes yet (the JSON summary and the recording are)"
                .into(),
        }
        .into());
    }
    if let Some(out) = &job.output {
        crate::io::check_output(out)?;
    }
    let mut sol = solve(&scene)?;
    if sol.summary.error_estimate > scene.solver.tolerance {
        return Err(JobError::Untrusted {
            file: scene.file.clone(),
            message: format!(
                "steady state not printed: estimated error {:.2e} is above solver.tolerance {:.1e}",
                sol.summary.error_estimate, scene.solver.tolerance
            ),
        }
        .into());
    }
    if let Some(out) = &job.output {
        write_recording(&scene, &sol, out)?;
        sol.summary.signal_file = Some(out.display().to_string());
    }
    Ok(sol.summary)
}

/// Stage base orders, their common base, and whether the common period is short.
fn periods(train: &GearTrain) -> Result<(Vec<Ratio>, Ratio, bool), String> {
    let orders: Vec<Ratio> = train.stages.iter().map(|s| s.series().base_order).collect();
    let base = rational_gcd(&orders).ok_or("the stages' exact period overflows 128-bit integers")?;
    let short =
        orders.iter().all(|o| o.checked_div(base).is_some_and(|m| m.den() == 1 && m.num() <= SHORT_PERIOD_RATIO));
    Ok((orders, base, short))
}

/// Solves the train over its common period or by the two-frequency balance, as the module doc says.
///
/// # Errors
/// Solver failure, a train of more than two stages without a short common period.
pub fn solve(scene: &TrainScene) -> Result<TrainSolution, Error> {
    let train = &scene.train;
    let (orders, base, short) = periods(train).map_err(|e| input_error(scene, e))?;
    let f_ref = train.speed_hz;
    let multiples: Vec<String> =
        orders.iter().map(|o| o.checked_div(base).map_or_else(|| "?".into(), |m| m.to_string())).collect();
    let common_period_s = 1.0 / (base.to_f64() * f_ref);
    let mesh_hz = scene.machine.mesh_hz(f_ref);
    let cycles = common_period_s * mesh_hz.iter().fold(0.0, |a: f64, b| a.max(*b));
    let ratio = multiples.join(" : ");
    let m = train.matrices();
    let u: Vec<f64> = (0..train.stages.len()).fold(vec![0.0; train.dof()], |mut acc, k| {
        acc.iter_mut().zip(train.mesh_weights(k)).for_each(|(a, w)| *a += w);
        acc
    });
    let mut summary = TrainSummary {
        scene: scene.name.clone(),
        model: "gear_train".into(),
        method: String::new(),
        method_reason: String::new(),
        shaft_hz: scene.machine.speeds_hz(scene.machine.reference(), f_ref),
        shafts: scene.machine.shafts.clone(),
        mesh_hz,
        stage_base_hz: orders.iter().map(|o| o.to_f64() * f_ref).collect(),
        common_period_s,
        period_s: None,
        multipliers: None,
        rho_max: None,
        stable: None,
        stability_note: String::new(),
        error_estimate: f64::NAN,
        resolution: Vec::new(),
        lines: Vec::new(),
        rms: 0.0,
        signal_file: None,
        notes: scene.notes.clone(),
    };
    let lines = if short {
        let (mass, damping, stiffness, forcing) = m.common_period(base, f_ref);
        let sys = SecondOrderSystem::new(common_period_s, mass, damping, stiffness, forcing)
            .map_err(|e| input_error(scene, format!("{e:?}")))?;
        let steady = solver::solve(&sys, &scene.solver)?;
        summary.method = steady.method.name().into();
        summary.method_reason = format!(
            "the stages' base frequencies stand as {ratio} (each at most {SHORT_PERIOD_RATIO}), so they share a short common period of {common_period_s:.6} s ({cycles:.0} mesh cycles): the train is one periodic system over it; {}",
            steady.reason
        );
        summary.period_s = Some(common_period_s);
        summary.multipliers = Some(
            steady.floquet.multipliers.iter().map(|r| TrainMultiplier { re: r.re, im: r.im, abs: r.norm() }).collect(),
        );
        summary.rho_max = Some(steady.floquet.rho_max);
        summary.stable = Some(steady.floquet.stable);
        summary.stability_note = "Floquet multipliers of the monodromy over the common period".into();
        summary.error_estimate = steady.error_estimate;
        summary.resolution = vec![steady.resolution];
        common_lines(&sys, &steady, &u)
    } else {
        if train.stages.len() != 2 {
            return Err(input_error(
                scene,
                format!(
                    "the stages' base frequencies stand as {ratio}: no short common period ({common_period_s:.3e} s), and the two-frequency harmonic balance takes two stages, not {}",
                    train.stages.len()
                ),
            ));
        }
        let form = m.two_tone(f_ref);
        let (sol, report) = quasi::solve(&form, scene.solver.tolerance, MAX_QUASI_HARMONICS)?;
        summary.method = "quasi-hb".into();
        summary.method_reason = format!(
            "the stages' base frequencies stand as {ratio}: their common period is {common_period_s:.3e} s ({cycles:.0} mesh cycles), too long to solve over, so the quasi-periodic steady state comes from harmonic balance on the lines k nu1 + l nu2 ({} lines in {} classes, stiffness strides {:?}, {} GMRES iterations)",
            sol.lines_held().len(),
            report.classes,
            report.strides,
            report.iterations
        );
        summary.stability_note = format!(
            "not computed: the coefficients are quasi-periodic; Floquet multipliers exist only over the exact common period of {common_period_s:.3e} s, which was not integrated"
        );
        summary.error_estimate = report.error_estimate;
        summary.resolution = sol.harmonics.to_vec();
        quasi_lines(&sol, &u)
    };
    let lines = merge_equal_frequencies(lines);
    // the strongest lines: each modulus once, the top SUMMARY_LINES picked before sorting
    let mut listed: Vec<(f64, &Line)> = lines.iter().map(|l| (l.1.norm(), l)).collect();
    let top = listed.iter().map(|l| l.0).fold(0.0, f64::max);
    // largest first, equal ones by frequency
    let order = |a: &(f64, &Line), b: &(f64, &Line)| b.0.total_cmp(&a.0).then(a.1.0.total_cmp(&b.1.0));
    if listed.len() > SUMMARY_LINES {
        listed.select_nth_unstable_by(SUMMARY_LINES, order);
        listed.truncate(SUMMARY_LINES);
    }
    listed.sort_by(order);
    summary.lines = listed
        .iter()
        .map(|(_, (w, z, label))| TrainLine {
            frequency_hz: w / (2.0 * PI),
            amplitude: if *w == 0.0 { z.norm() } else { 2.0 * z.norm() },
            label: label.clone(),
        })
        .collect();
    summary.rms =
        lines.iter().map(|(w, z, _)| if *w == 0.0 { z.norm_sqr() } else { 2.0 * z.norm_sqr() }).sum::<f64>().sqrt();
    // lines far below the tolerance are left out of the recording
    let floor = 1e-3 * scene.solver.tolerance * top;
    let lines = lines.into_iter().filter(|l| l.1.norm() > floor).collect();
    Ok(TrainSolution { lines, summary })
}

/// Lines at one frequency (within 1e-12 relative: the same physical line reached by two combinations, such
/// as the intermediate shaft's rate from both stages) summed into one, labels joined.
fn merge_equal_frequencies(mut lines: Vec<(f64, Complex<f64>, String)>) -> Vec<(f64, Complex<f64>, String)> {
    lines.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out: Vec<(f64, Complex<f64>, String)> = Vec::with_capacity(lines.len());
    for (w, z, label) in lines {
        match out.last_mut() {
            Some(last) if (last.0 - w).abs() <= 1e-12 * w.abs().max(1.0) => {
                last.1 += z;
                last.2 = format!("{} = {label}", last.2);
            }
            _ => out.push((w, z, label)),
        }
    }
    out
}

/// Lines of u . y' from a common-period steady state: exact coefficients of harmonic balance, or
/// quadrature on the step grid.
fn common_lines(sys: &SecondOrderSystem, steady: &SteadyState, u: &[f64]) -> Vec<(f64, Complex<f64>, String)> {
    let n = u.len();
    let w0 = 2.0 * PI / steady.period_s;
    let z: Vec<Complex<f64>> = match &steady.trajectory {
        Trajectory::Fourier(sol) => (0..=sol.harmonics)
            .map(|k| u.iter().enumerate().map(|(i, w)| sol.coefficient(n + i, k) * *w).sum())
            .collect(),
        Trajectory::Grid { .. } => {
            let kmax = (4 * sys.max_harmonic()).clamp(64, 20_000);
            let comps: Vec<usize> = (n..2 * n).collect();
            let per = super::simulate::grid_coefficients(sys, steady, kmax, &comps).unwrap_or_default();
            (0..=kmax).map(|k| per.iter().zip(u).map(|(c, w)| c[k] * *w).sum()).collect()
        }
    };
    z.into_iter().enumerate().map(|(k, c)| (k as f64 * w0, c, format!("{k} nu0"))).collect()
}

/// Lines of u . y' from the two-frequency balance (w >= 0, each frequency once).
fn quasi_lines(sol: &TwoToneSolution, u: &[f64]) -> Vec<(f64, Complex<f64>, String)> {
    sol.lines_held()
        .iter()
        .enumerate()
        .filter_map(|(j, &(k, l))| {
            let w = sol.frequency_rad_s(k, l);
            // each real line once: w > 0, or w = 0 only for (0, 0)
            if w < 0.0 || (w == 0.0 && (k, l) != (0, 0)) {
                return None;
            }
            let z: Complex<f64> =
                sol.line_coefficients(j).iter().zip(u).map(|(y, wt)| y * Complex::new(0.0, w * wt)).sum();
            Some((w, z, format!("{k} nu1 + {l} nu2")))
        })
        .collect()
}

/// Factor from the velocity lines to a sensor's recorded value at angular frequency w (physical unit times
/// sensitivity): i w for accelerations, 1 / (i w) for displacements.
fn sensor_factor(unit: SensorUnit, sensitivity: f64, w: f64) -> Complex<f64> {
    let (deriv, scale) = match unit {
        SensorUnit::MetrePerSecondSquared => (1, 1.0),
        SensorUnit::G => (1, 1.0 / 9.80665),
        SensorUnit::MetrePerSecond | SensorUnit::Volt => (0, 1.0),
        SensorUnit::MillimetrePerSecond => (0, 1e3),
        SensorUnit::Metre => (-1, 1.0),
        SensorUnit::Micrometre => (-1, 1e6),
    };
    let f = match deriv {
        1 => Complex::new(0.0, w),
        -1 if w > 0.0 => Complex::new(0.0, -1.0 / w),
        -1 => Complex::new(0.0, 0.0),
        _ => Complex::new(1.0, 0.0),
    };
    f * (scale * sensitivity)
}

/// Samples of sum Re(Z) + 2 Re sum Z e^{i w t} at n / fs, by a phasor per line advanced one sample at a time
/// (re-anchored every 4096 samples so rounding cannot accumulate).
fn synthesize(lines: &[(f64, Complex<f64>)], fs: f64, frames: usize) -> Vec<f32> {
    let mut out = vec![0.0f64; frames];
    const BLOCK: usize = 4096;
    for (w, z) in lines {
        let step = Complex::from_polar(1.0, w / fs);
        let mut start = 0;
        while start < frames {
            let mut p = *z * Complex::from_polar(1.0, (w * start as f64 / fs).rem_euclid(2.0 * PI));
            for o in &mut out[start..(start + BLOCK).min(frames)] {
                *o += if *w == 0.0 { p.re } else { 2.0 * p.re };
                p *= step;
            }
            start += BLOCK;
        }
    }
    out.into_iter().map(|v| v as f32).collect()
}

/// Writes the machine's sensors (and its tachometer) as a recording, channels in channel-number order.
fn write_recording(scene: &TrainScene, sol: &TrainSolution, out: &std::path::Path) -> Result<(), Error> {
    let o = &scene.output;
    let frames = (o.duration_s * o.sample_rate_hz).round() as usize;
    let nyquist = 0.5 * o.sample_rate_hz;
    let kept: Vec<(f64, Complex<f64>)> =
        sol.lines.iter().filter(|l| l.0 / (2.0 * PI) < nyquist).map(|l| (l.0, l.1)).collect();
    let mut channels: Vec<(u32, String, String, Vec<f32>)> = Vec::new();
    let sensors = &scene.machine.sensors;
    if sensors.is_empty() {
        channels.push((1, "sum dq/dt".into(), "m/s".into(), synthesize(&kept, o.sample_rate_hz, frames)));
    }
    for s in sensors {
        let lines: Vec<(f64, Complex<f64>)> =
            kept.iter().map(|(w, z)| (*w, z * sensor_factor(s.unit, s.sensitivity, *w))).collect();
        channels.push((
            s.channel,
            format!("ch{}", s.channel),
            s.unit.name().into(),
            synthesize(&lines, o.sample_rate_hz, frames),
        ));
    }
    if let Some(t) = &scene.machine.tachometer {
        let hz = scene.machine.speeds_hz(scene.machine.reference(), scene.train.speed_hz)[t.shaft];
        let pulses: Vec<f32> = (0..frames)
            .map(|i| {
                let turns = hz * i as f64 / o.sample_rate_hz * t.pulses_per_rev as f64;
                if turns.fract() < 0.1 { 1.0 } else { 0.0 }
            })
            .collect();
        channels.push((t.channel, format!("tacho {}", scene.machine.shafts[t.shaft]), "V".into(), pulses));
    }
    channels.sort_by_key(|c| c.0);
    let rec = crate::io::Recording {
        names: channels.iter().map(|c| c.1.clone()).collect(),
        units: channels.iter().map(|c| c.2.clone()).collect(),
        sample_rate_hz: Some(o.sample_rate_hz),
        channels: channels.into_iter().map(|c| std::borrow::Cow::Owned(c.3)).collect(),
        warnings: Vec::new(),
    };
    crate::io::write_recording(out, &rec)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synthesize_works() {
        // 0.5 + 2 Re(0.25 e^{i w t}) = 0.5 + 0.5 cos(w t) at 1 kHz, w = 2 pi 50
        let w = 2.0 * PI * 50.0;
        let s = synthesize(&[(0.0, Complex::new(0.5, 0.0)), (w, Complex::new(0.25, 0.0))], 1000.0, 9000);
        for (i, v) in s.iter().enumerate() {
            let t = i as f64 / 1000.0;
            assert!((*v as f64 - (0.5 + 0.5 * (w * t).cos())).abs() < 1e-6, "sample {i}");
        }
    }
}
