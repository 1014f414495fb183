//! Recording-like signals from a solved scene: the output quantity at the true sample instants, with
//! optional slow speed fluctuation, white measurement noise and once-per-revolution tachometer channels.
//!
//! ```text
//! speed(t) = nominal s(t)                                       (s: relative speed, 1 when constant)
//! phase(t) = integral of the relative speed from 0 to t        (s of nominal-speed time; angle / w_nominal;
//!            see `scene::SpeedChange`: sinusoidal, random drift or ramp)
//! y(t_n)   = steady-state output at phase(t_n) mod T              (quasi-static in the speed fluctuation)
//! ```
//! For smooth systems with a linear output the periodic output is tabulated once (values and exact time
//! derivatives, a power-of-two number of points per period fine enough for the tolerance) and evaluated by
//! cubic Hermite interpolation; otherwise every sample is one partial RK4 step from the nearest grid node.

use super::JobError;
use super::simulate::Simulation;
use crate::Error;
use crate::io::sidecar::{ChannelInfo, Sidecar};
use crate::io::{SignalOut, wav::WavSampleFormat};
use crate::model::OutputQuantity;
use crate::scene::{Model, Scene, WavFormat};
use crate::solver::Trajectory;
use crate::system::Side;
use std::path::Path;

/// What a written signal file holds (the sidecar).
pub type SignalInfo = Sidecar;

/// Refuses requests that would need more samples than this (about 8 GiB as f64).
pub const MAX_TOTAL_SAMPLES: f64 = 1.0e9;

struct Noise {
    state: u64,
    spare: Option<f64>,
}

impl Noise {
    fn new(seed: u64) -> Self {
        Self { state: seed ^ 0x9E37_79B9_7F4A_7C15, spare: None }
    }
    fn next_u64(&mut self) -> u64 {
        // SplitMix64
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    /// Standard normal (Marsaglia's polar method: one logarithm per pair, no trigonometry).
    fn gauss(&mut self) -> f64 {
        if let Some(s) = self.spare.take() {
            return s;
        }
        loop {
            let (u, v) = (2.0 * self.uniform() - 1.0, 2.0 * self.uniform() - 1.0);
            let s = u * u + v * v;
            if s > 0.0 && s < 1.0 {
                let f = (-2.0 * s.ln() / s).sqrt();
                self.spare = Some(v * f);
                return u * f;
            }
        }
    }
}

/// Periodic output tabulated with exact derivatives, evaluated by cubic Hermite interpolation.
struct Table {
    period_s: f64,
    values: Vec<f64>,
    slopes: Vec<f64>,
}

impl Table {
    fn eval(&self, tau: f64) -> f64 {
        let m = self.values.len();
        let h = self.period_s / m as f64;
        let x = tau / h;
        let i = (x.floor() as usize).min(m - 1);
        let s = x - i as f64;
        let j = (i + 1) % m;
        let (y0, y1, d0, d1) = (self.values[i], self.values[j], self.slopes[i] * h, self.slopes[j] * h);
        let s2 = s * s;
        let s3 = s2 * s;
        (2.0 * s3 - 3.0 * s2 + 1.0) * y0 + (s3 - 2.0 * s2 + s) * d0 + (-2.0 * s3 + 3.0 * s2) * y1 + (s3 - s2) * d1
    }
}

/// Output evaluator: a Hermite table for smooth systems with a linear output, else direct partial steps.
enum Evaluator<'a> {
    Table(Table),
    Direct(&'a Scene, &'a Simulation),
}

impl Evaluator<'_> {
    fn describe(&self) -> String {
        match self {
            Self::Table(t) => {
                format!("cubic Hermite table of {} points per period with exact derivatives", t.values.len())
            }
            Self::Direct(..) => "one partial RK4 step per sample from the nearest grid node".into(),
        }
    }
}

fn evaluator<'a>(scene: &'a Scene, sim: &'a Simulation) -> Evaluator<'a> {
    let sys = scene.system();
    let OutputQuantity::Linear { weights, .. } = &scene.output.quantity else { return Evaluator::Direct(scene, sim) };
    if !sys.breakpoints().is_empty() {
        return Evaluator::Direct(scene, sim);
    }
    // Hermite error ~ (h w)^4 / 384 relative to a harmonic of angular frequency w: make it below tolerance
    let period = sim.steady.period_s;
    let kmax = sys.max_harmonic().max((scene.output.max_order * period * scene.output.base_hz) as usize).max(1);
    let per_harmonic = 2.0 * std::f64::consts::PI * (384.0 * scene.solver.tolerance).powf(-0.25);
    let m = ((kmax as f64 * per_harmonic).ceil() as usize).max(1024).next_power_of_two().min(1 << 22);
    if let Trajectory::Fourier(sol) = &sim.steady.trajectory {
        let (values, slopes) = super::simulate::fourier_table(&scene.output.quantity, sol, m);
        return Evaluator::Table(Table { period_s: period, values, slopes });
    }
    let times: Vec<f64> = (0..m).map(|i| period * i as f64 / m as f64).collect();
    let n = sys.dim();
    let mut states = Vec::new();
    sim.steady.states_at(sys, &times, &mut states);
    let (mut p, mut f) = (nalgebra::DMatrix::zeros(n, n), nalgebra::DVector::zeros(n));
    let mut values = Vec::with_capacity(m);
    let mut slopes = Vec::with_capacity(m);
    let mut xdot = vec![0.0; n];
    for (i, &t) in times.iter().enumerate() {
        let x = &states[i * n..(i + 1) * n];
        sys.eval(t, Side::Right, &mut p, &mut f);
        crate::system::state_derivative(&p, &f, x, &mut xdot);
        values.push(weights.iter().zip(x).map(|(w, v)| w * v).sum());
        slopes.push(weights.iter().zip(&xdot).map(|(w, v)| w * v).sum());
    }
    Evaluator::Table(Table { period_s: period, values, slopes })
}

/// Relative speeds apart on the quasi-static grid of a ramp (one steady state per 5 % of speed).
const RAMP_GRID_STEP: f64 = 0.05;

/// Steady states on a grid of speeds for a gear pair whose speed ramps: the response is quasi-static, the
/// steady state at the instantaneous speed, linearly interpolated between the two nearest grid speeds (the
/// paper's model has no speed-dependent transient). Each grid solution is evaluated at its own time
/// tau / s_j for the angle reached (tau: the nominal-speed time equivalent of the angle).
struct SpeedGrid {
    /// Relative speeds s_j, ascending, evenly spaced.
    speeds: Vec<f64>,
    /// The scene at each speed and its simulation.
    solved: Vec<(Scene, Simulation)>,
}

impl SpeedGrid {
    /// The grid for `scene` when its output ramps the speed of a gear pair; `None` otherwise.
    fn of(scene: &Scene) -> Result<Option<Self>, Error> {
        let Some(crate::scene::SpeedChange::Ramp { from, to, .. }) = scene.output.speed_change else {
            return Ok(None);
        };
        let Some(rpm) = scene.json.get("gear_pair").and_then(|g| g.get("speed_rpm")).and_then(|v| v.as_f64()) else {
            return Ok(None);
        };
        let (lo, hi) = (from.min(to), from.max(to));
        let k = (((hi - lo) / RAMP_GRID_STEP).ceil() as usize).max(1) + 1;
        let speeds: Vec<f64> = (0..k).map(|j| lo + (hi - lo) * j as f64 / (k - 1) as f64).collect();
        let solved = speeds
            .iter()
            .map(|s| {
                let mut json = scene.json.clone();
                json["gear_pair"]["speed_rpm"] = (rpm * s).into();
                let at = Scene::from_value(json, &scene.file)?;
                let sim = super::simulate::simulate(&at)?;
                Ok((at, sim))
            })
            .collect::<Result<Vec<_>, Error>>()?;
        Ok(Some(Self { speeds, solved }))
    }

    /// Grid cell j (s_j <= s <= s_(j+1)) and the weight of s_(j+1).
    fn bracket(&self, s: f64) -> (usize, f64) {
        let (lo, hi) = (self.speeds[0], self.speeds[self.speeds.len() - 1]);
        if self.speeds.len() < 2 || hi <= lo {
            return (0, 0.0);
        }
        let x = ((s - lo) / (hi - lo) * (self.speeds.len() - 1) as f64).clamp(0.0, (self.speeds.len() - 1) as f64);
        let j = (x.floor() as usize).min(self.speeds.len() - 2);
        (j, x - j as f64)
    }

    /// Output at nominal-time equivalents `taus` with relative speeds `speeds` (same length).
    fn values(&self, evals: &[Evaluator<'_>], taus: &[f64], speeds: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; taus.len()];
        let mut i = 0;
        while i < taus.len() {
            // a run of samples in the same grid cell: each neighbour evaluated once for the run
            let (j, _) = self.bracket(speeds[i]);
            let end = (i..taus.len()).find(|&m| self.bracket(speeds[m]).0 != j).unwrap_or(taus.len());
            let at = |g: usize| -> Vec<f64> {
                let sj = self.speeds[g];
                let local: Vec<f64> = taus[i..end].iter().map(|t| t / sj).collect();
                evaluate(&evals[g], &local)
            };
            let (a, b) = (at(j), at((j + 1).min(self.speeds.len() - 1)));
            for (m, o) in out[i..end].iter_mut().enumerate() {
                let (_, w) = self.bracket(speeds[i + m]);
                *o = (1.0 - w) * a[m] + w * b[m];
            }
            i = end;
        }
        out
    }
}

/// The output of one evaluator at times `taus` (s, reduced modulo its period).
fn evaluate(e: &Evaluator<'_>, taus: &[f64]) -> Vec<f64> {
    match e {
        Evaluator::Table(tab) => taus.iter().map(|&tau| tab.eval(wrap(tau, tab.period_s))).collect(),
        Evaluator::Direct(sc, si) => super::simulate::output_at(sc, &si.steady, taus),
    }
}

/// Tachometer shafts of a scene: (name, revolutions of that shaft per base revolution).
fn tacho_shafts(scene: &Scene) -> Vec<(String, f64)> {
    match &scene.model {
        Model::GearPair(g) => vec![
            ("tacho pinion".into(), 1.0),
            ("tacho wheel".into(), g.params().pinion_teeth as f64 / g.params().wheel_teeth as f64),
        ],
        Model::Press(..) => vec![("tacho input shaft".into(), 1.0)],
        Model::Ltp(_) => vec![("tacho period".into(), 1.0)],
    }
}

/// Checks a write request before anything is computed or allocated.
///
/// # Errors
/// Unknown extension, aliasing (unless allowed), absurd size.
pub fn check_request(scene: &Scene, out: &Path, allow_aliasing: bool, warnings: &mut Vec<String>) -> Result<(), Error> {
    let ext = crate::io::extension(out);
    if !matches!(ext.as_deref(), Some("wav") | Some("csv")) {
        return Err(JobError::Input {
            file: out.display().to_string(),
            message: "unknown extension for the signal file: expected .wav or .csv".into(),
        }
        .into());
    }
    crate::io::check_output(out)?;
    crate::io::check_output(&crate::io::sidecar::path_of(out))?;
    let o = &scene.output;
    let highest = o.max_order * o.base_hz * o.speed_change.map_or(1.0, |m| m.max_relative_speed());
    if o.sample_rate_hz < 2.0 * highest {
        let msg = format!(
            "field `output.sample_rate_hz`: {} Hz is below twice the highest line requested ({:.1} Hz = order {} of {:.3} Hz): the signal would alias",
            o.sample_rate_hz, highest, o.max_order, o.base_hz
        );
        if !allow_aliasing {
            return Err(JobError::Aliasing {
                file: scene.file.clone(),
                message: format!("{msg}; lower output.max_order"),
            }
            .into());
        }
        warnings.push(format!("{}: {msg}", scene.file));
    }
    let channels = 1 + if o.tacho { tacho_shafts(scene).len() } else { 0 };
    let total = o.sample_rate_hz * o.duration_s * channels as f64;
    if total > MAX_TOTAL_SAMPLES {
        return Err(JobError::Input {
            file: scene.file.clone(),
            message: format!(
                "field `output.duration_s`: {total:.3e} samples ({channels} channels) exceed the limit of {MAX_TOTAL_SAMPLES:.0e}; shorten the duration or lower the sample rate"
            ),
        }
        .into());
    }
    let frames = (o.sample_rate_hz * o.duration_s).round();
    if frames < 2.0 {
        return Err(JobError::Input {
            file: scene.file.clone(),
            message: format!(
                "field `output.duration_s`: {} s at {} Hz gives {frames} samples; a signal needs at least 2",
                o.duration_s, o.sample_rate_hz
            ),
        }
        .into());
    }
    if o.sample_rate_hz.round() != o.sample_rate_hz && ext.as_deref() == Some("wav") {
        return Err(JobError::Input {
            file: scene.file.clone(),
            message: format!("field `output.sample_rate_hz`: WAV needs a whole number of Hz, got {}", o.sample_rate_hz),
        }
        .into());
    }
    Ok(())
}

/// Writes the scene's output signal to `out` (.wav or .csv) and a sidecar `out.json`; returns what was written.
///
/// # Errors
/// See [`check_request`]; I/O failures. No partial file is left behind.
pub fn write_signal(scene: &Scene, sim: &Simulation, out: &Path, allow_aliasing: bool) -> Result<SignalInfo, Error> {
    let mut warnings = Vec::new();
    check_request(scene, out, allow_aliasing, &mut warnings)?;
    let o = &scene.output;
    let fs = o.sample_rate_hz;
    let frames = (fs * o.duration_s).round() as u64;
    let eval = evaluator(scene, sim);
    let grid = SpeedGrid::of(scene)?;
    let grid_evals: Vec<Evaluator<'_>> =
        grid.as_ref().map(|g| g.solved.iter().map(|(sc, si)| evaluator(sc, si)).collect()).unwrap_or_default();
    // the largest steady-state value over every speed the recording reaches (integer full scale)
    let steady_peak = grid
        .iter()
        .flat_map(|g| g.solved.iter().map(|(_, si)| si))
        .chain(std::iter::once(sim))
        .flat_map(|si| si.period_samples.iter())
        .fold(0.0f64, |a, v| a.max(v.abs()));
    let shafts = if o.tacho { tacho_shafts(scene) } else { Vec::new() };
    let q = &o.quantity;
    let mut channels = vec![ChannelInfo {
        name: q.name().into(),
        unit: q.unit().into(),
        description: format!("{} of scene {}", q.name(), scene.name),
    }];
    let is_wav = crate::io::extension(out).as_deref() == Some("wav");
    let (format, full_scale) = match (is_wav, o.wav_format) {
        (false, _) => ("csv".to_string(), None),
        (true, WavFormat::F32) => ("f32".to_string(), None),
        (true, f) => {
            let peak = steady_peak + 4.0 * o.noise_rms;
            let fsc = o.full_scale.unwrap_or_else(|| nice_ceiling(1.25 * peak));
            // a full scale so large that the whole signal rounds to 0 would write an all-zero channel
            let step = fsc / if f == WavFormat::I16 { 32768.0 } else { 8_388_608.0 };
            if peak > 0.0 && peak < 0.5 * step {
                return Err(JobError::Input {
                    file: scene.file.clone(),
                    message: format!(
                        "field `output.full_scale`: {fsc:e} makes one integer step {step:.3e}, above twice the signal's peak {peak:.3e}: every sample would be written as 0; lower output.full_scale (or leave it out for {:e})",
                        nice_ceiling(1.25 * peak)
                    ),
                }
                .into());
            }
            (if f == WavFormat::I16 { "i16" } else { "i24" }.to_string(), Some(fsc))
        }
    };
    let pulse = full_scale.map_or(1.0, |f| 0.5 * f);
    for (name, _) in &shafts {
        channels.push(ChannelInfo {
            name: name.clone(),
            unit: "pulse".into(),
            description: format!(
                "once per revolution: {pulse} for the first 5 % of each revolution, else 0; rising edge at angle 0"
            ),
        });
    }
    let nch = channels.len();
    let fmt = match full_scale {
        None => WavSampleFormat::Float32,
        Some(fsc) => WavSampleFormat::Int { bits: if format == "i16" { 16 } else { 24 }, full_scale: fsc },
    };
    let mut sink = SignalOut::create(out, &channels, fs, fmt)?;
    let period = sim.steady.period_s;
    let mut noise = Noise::new(o.seed);
    const CHUNK: usize = 8192;
    let mut buf = Vec::with_capacity(CHUNK * nch);
    let mut times = Vec::with_capacity(CHUNK);
    let angle_time = o
        .speed_change
        .map_or_else(|| Box::new(|t: f64| t) as Box<dyn Fn(f64) -> f64 + Send + Sync>, |c| c.angle_time(o.duration_s));
    // relative speed at time t (used by the ramp's speed grid): the derivative of tau(t)
    let speed_of = |t: f64| {
        let h = 1e-4 * o.duration_s.max(1e-3);
        (angle_time(t + h) - angle_time((t - h).max(0.0))) / (t + h - (t - h).max(0.0))
    };
    let mut start = 0u64;
    while start < frames {
        let len = CHUNK.min((frames - start) as usize);
        times.clear();
        for i in 0..len {
            let t = (start + i as u64) as f64 / fs;
            times.push(angle_time(t));
        }
        let values = match &grid {
            Some(g) => {
                let speeds: Vec<f64> = (0..len).map(|i| speed_of((start + i as u64) as f64 / fs)).collect::<Vec<f64>>();
                g.values(&grid_evals, &times, &speeds)
            }
            None => evaluate(&eval, &times),
        };
        buf.clear();
        for (i, v) in values.iter().enumerate() {
            let noisy = if o.noise_rms > 0.0 { v + o.noise_rms * noise.gauss() } else { *v };
            if noisy.is_nan() || noisy.abs() > f64::from(f32::MAX) {
                return Err(JobError::Input {
                    file: scene.file.clone(),
                    message: format!(
                        "the signal reaches {noisy:e} at sample {}, beyond 32-bit float range: check output.noise_rms ({}) and the model",
                        start + i as u64,
                        o.noise_rms
                    ),
                }
                .into());
            }
            buf.push(noisy);
            for (_, ratio) in &shafts {
                let rev = times[i] * o.base_hz * ratio;
                buf.push(if wrap(rev, 1.0) < 0.05 { pulse } else { 0.0 });
            }
        }
        sink.write(&buf)?;
        start += len as u64;
    }
    let (signal_guard, clipped) = sink.finish()?;
    if clipped > 0 {
        warnings.push(format!(
            "{clipped} samples clipped at integer full scale {}; raise output.full_scale",
            full_scale.unwrap_or(1.0)
        ));
    }
    let info = SignalInfo {
        file: out.display().to_string(),
        scene: scene.name.clone(),
        scene_file: scene.file.clone(),
        sample_rate_hz: fs,
        frames,
        duration_s: frames as f64 / fs,
        channels,
        format,
        full_scale,
        clipped_samples: clipped,
        noise_rms: o.noise_rms,
        seed: o.seed,
        speed_change: o.speed_change.map(|c| c.describe()),
        base_hz: o.base_hz,
        period_s: period,
        evaluation: match &grid {
            Some(g) => format!(
                "quasi-static: steady states at {} speeds from {} to {} times the nominal, linearly interpolated at the instantaneous speed; each by {}",
                g.speeds.len(),
                g.speeds[0],
                g.speeds[g.speeds.len() - 1],
                eval.describe()
            ),
            None => eval.describe(),
        },
        warnings,
    };
    crate::io::commit_with_sidecar(out, signal_guard, &info)?;
    Ok(info)
}

/// `x` modulo `period` for x >= 0 by a cast (`rem_euclid` and `floor` are library calls on baseline x86-64,
/// and this runs once per sample and channel).
#[inline]
fn wrap(x: f64, period: f64) -> f64 {
    let r = x - (x / period) as i64 as f64 * period;
    if r < 0.0 { r + period } else { r }
}

fn nice_ceiling(x: f64) -> f64 {
    if x.is_nan() || x <= 0.0 {
        return 1.0;
    }
    let p = 10f64.powf(x.log10().floor());
    let m = x / p;
    let step = [1.0, 2.0, 2.5, 5.0, 10.0].into_iter().find(|s| *s >= m).unwrap_or(10.0);
    step * p
}
