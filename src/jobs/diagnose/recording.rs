//! Reading one recording for the diagnosis: the channels to decode, units, and the checks on the data,
//! the sample rate and a given speed, before anything is sized from them.

use super::*;

/// Diagnoses one recording.
///
/// # Errors
/// Unreadable file, bad channel or sample rate, constant or non-finite data, too short for the TSA.
pub fn diagnose(path: &Path, o: &Options, geometry: Option<&Geometry>) -> Result<Diagnosis, Error> {
    if let Some(m) = &o.machine {
        return super::machine::diagnose(path, o, m.machine(), geometry);
    }
    let (rec, o) = read(path, o)?;
    analyse(path, rec, &o, geometry)
}

/// Reads the channels of `path` that the diagnosis uses (units applied), and the options with the
/// tachometer in use (given, or the sidecar's).
///
/// # Errors
/// Unreadable file.
pub(super) fn read(path: &Path, o: &Options) -> Result<(Recording<'static>, Options), Error> {
    // with one channel asked for, only it and the tachometer are decoded (a long multi-channel WAV then
    // needs the memory of those channels alone); without, the sidecar's pulse channels that are not the
    // tachometer in use are not decoded either (they are never analysed as vibration)
    let sidecar = io::sidecar::read(path)?.sidecar();
    // the sidecar's pinion tachometer gives the speed when no tachometer channel is named, also beside a
    // given speed: that is then the nominal one, cross-checked against the tachometer's
    let sidecar_tacho = o
        .tacho_channel
        .is_none()
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
    if let (Some(t), Some(_)) = (sidecar_tacho, o.shaft_hz) {
        rec.warnings.push(format!(
            "the sidecar's pinion tachometer (channel {t}) gives the speed and the teeth's origin: the given speed is taken as the nominal one and checked against it"
        ));
    }
    apply_units(&mut rec, o, tacho);
    Ok((rec, Options { tacho_channel: tacho, ..o.clone() }))
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
    if let Some(m) = &o.machine {
        return super::machine::diagnose_in_memory(name, rec, o, m.machine(), geometry);
    }
    apply_units(&mut rec, o, o.tacho_channel);
    analyse(name, rec, o, geometry)
}

/// `--sensitivity` (samples divided by it) and `--unit` applied to every channel but the tachometer whose
/// file names no physical unit (none, or volts: a sensitivity turns volts into the physical unit). A
/// channel whose file already names its physical unit (a sidecar, a CSV header) is left as it is, so that
/// a baseline read with its sidecar and a recording without one are both in the same unit.
pub(super) fn apply_units(rec: &mut Recording, o: &Options, tacho: Option<usize>) {
    for (i, (x, unit)) in rec.channels.iter_mut().zip(rec.units.iter_mut()).enumerate() {
        if Some(i + 1) == tacho || unit == "pulse" {
            continue;
        }
        let raw = unit.is_empty() || unit.eq_ignore_ascii_case("v") || unit.eq_ignore_ascii_case("mv");
        if !raw {
            continue;
        }
        if let Some(s) = o.sensitivity {
            let k = (1.0 / s) as f32;
            x.to_mut().iter_mut().for_each(|v| *v *= k);
        }
        if let Some(u) = &o.unit {
            unit.clone_from(u);
        }
    }
}

/// Name of the pinion's tachometer channel in gearvib's sidecar: used for the speed when no speed and no
/// tachometer channel are given.
pub const PINION_TACHO: &str = "tacho pinion";

/// True when a channel is a tachometer pulse train, never a vibration signal, judged on its first
/// [`PULSE_SCAN`] samples: exactly two distinct levels, or (a pulse train recorded through an ADC, with
/// noise and finite edges) at least [`PULSE_SHARE`] of the samples within [`PULSE_BAND`] of the range
/// from its least or its largest value, each level held for [`PULSE_HELD`] samples on average and the
/// levels changing at least [`PULSE_EDGES`] times. A vibration signal spends most of its time around its middle: on the
/// hold-out recordings' vibration channels the share was 0.000-0.002, on their tachometer channels
/// (filtered edges, noise) 0.996-0.997.
pub(super) fn looks_like_pulses(x: &[f32]) -> bool {
    let x = &x[..x.len().min(PULSE_SCAN)];
    two_levels(x) || mostly_at_two_levels(x)
}

/// Samples from a channel's start read to tell a pulse train.
const PULSE_SCAN: usize = 200_000;
/// Share of samples near one of the two extreme levels from which a channel is a pulse train.
const PULSE_SHARE: f64 = 0.95;
/// Distance from an extreme, as a share of the range, within which a sample sits at that level.
const PULSE_BAND: f32 = 0.15;
/// Changes of level a pulse train shows at least (two pulses).
const PULSE_EDGES: usize = 4;
/// Samples a pulse train holds each level for on average, at least.
const PULSE_HELD: f64 = 3.0;

/// Exactly two distinct values (a synthetic or digital tachometer), changing [`PULSE_EDGES`] times or
/// more: a step, or a record of two or three samples, also holds two values but no pulse.
fn two_levels(x: &[f32]) -> bool {
    let mut levels: Vec<u32> = Vec::with_capacity(3);
    for v in x {
        let b = v.to_bits();
        if !levels.contains(&b) {
            levels.push(b);
            if levels.len() > 2 {
                return false;
            }
        }
    }
    let changes = x.windows(2).filter(|w| w[0].to_bits() != w[1].to_bits()).count();
    levels.len() == 2 && changes >= PULSE_EDGES
}

/// Nearly every sample near the least or the largest value, both levels held for [`PULSE_HELD`] samples
/// or more on average and left [`PULSE_EDGES`] times or more. (A shock on quiet noise also sits at two
/// levels, but for a sample or two, and rings through the middle.)
fn mostly_at_two_levels(x: &[f32]) -> bool {
    let (lo, hi) = x.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), &v| (l.min(v), h.max(v)));
    let band = PULSE_BAND * (hi - lo);
    if !(band > 0.0 && band.is_finite()) {
        return false;
    }
    // samples at each level, and the runs at it (a run is counted when the level is entered)
    let (mut at, mut runs, mut last) = ([0usize; 2], [0usize; 2], None);
    for &v in x {
        let level = if v - lo <= band {
            Some(0)
        } else if hi - v <= band {
            Some(1)
        } else {
            None
        };
        if let Some(l) = level {
            at[l] += 1;
            if last != Some(l) {
                runs[l] += 1;
                last = Some(l);
            }
        }
    }
    let held = |l: usize| runs[l] > 0 && at[l] as f64 >= PULSE_HELD * runs[l] as f64;
    held(0) && held(1) && runs[0] + runs[1] > PULSE_EDGES && (at[0] + at[1]) as f64 >= PULSE_SHARE * x.len() as f64
}

/// Checks one channel (finite, not constant, clipping warned about) and returns its raw RMS and kurtosis
/// from the same passes.
pub(super) fn check_channel(
    path: &Path,
    idx: usize,
    x: &[f32],
    warnings: &mut Vec<String>,
) -> Result<ind::ChannelMoments, Error> {
    let m = ind::channel_moments(x)
        .map_err(|i| bad(path, format!("channel {idx} has a non-finite sample at index {i}")))?;
    let (lo, hi) = (m.min, m.max);
    if lo == hi {
        return Err(bad(path, format!("channel {idx} is constant ({lo}): nothing to analyse")));
    }
    // clipping: runs of 3+ samples stuck at the extreme value
    let level = lo.abs().max(hi.abs()) * 0.9999;
    let peak = lo.abs().max(hi.abs());
    if let Some(stuck) = clipped_samples(x, level) {
        warnings.push(format!("channel {idx} looks clipped: {stuck} runs of samples stuck at +-{peak}; amplitudes and indicators are unreliable"));
    }
    Ok(m)
}

/// Share of a channel's samples stuck at its extreme from which it is called clipped.
const CLIPPED_SHARE: f64 = 1e-4;

/// The samples of `x` that are the third or later of a run at or beyond `level` in magnitude (a clipped
/// channel's runs stuck at its extreme), when they are over [`CLIPPED_SHARE`] of the channel. Counted run
/// by run only when the samples reaching the level at all (a vectorised count, and a bound on the stuck
/// ones) are over that share.
fn clipped_samples(x: &[f32], level: f32) -> Option<usize> {
    let over_share = |count: usize| count as f64 > CLIPPED_SHARE * x.len() as f64;
    if !over_share(x.iter().map(|v| usize::from(v.abs() >= level)).sum::<usize>()) {
        return None;
    }
    let (mut run, mut stuck) = (0usize, 0usize);
    for v in x {
        run = if v.abs() >= level { run + 1 } else { 0 };
        stuck += usize::from(run >= 3);
    }
    over_share(stuck).then_some(stuck)
}

/// Fewest samples per shaft revolution a TSA can use (the resampling keeps at least 64 points).
pub const MIN_SAMPLES_PER_REV: f64 = 64.0;

/// A given shaft speed must fit the recording: enough samples per revolution, enough revolutions. Checked
/// before anything is sized from it.
pub(super) fn check_given_speed(path: &Path, hz: f64, fs: f64, n: usize, min_revs: usize) -> Result<(), Error> {
    let per_rev = fs / hz;
    if per_rev.is_nan() || per_rev < MIN_SAMPLES_PER_REV {
        return Err(JobError::Value {
            what: Given::ShaftSpeed,
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
            what: Given::ShaftSpeed,
            message: format!(
                "{} Hz gives only {revs:.2} revolutions in the {n} samples of {}; the time-synchronous average needs at least {min_revs}: is the speed too low, or the recording too short?",
                crate::report::format::sig(hz, 6),
                path.display()
            ),
        }
        .into());
    }
    Ok(())
}

/// Accepted sample rates, Hz: from sub-hertz loggers to the fastest vibration front ends.
pub const SAMPLE_RATE_RANGE_HZ: (f64, f64) = (0.1, 100e6);

pub(super) fn sample_rate(path: &Path, rec: &Recording, o: &Options) -> Result<Option<f64>, Error> {
    if let Some(fs) = o.fs_hz {
        let (lo, hi) = SAMPLE_RATE_RANGE_HZ;
        if !(fs.is_finite() && (lo..=hi).contains(&fs)) {
            return Err(JobError::Value {
                what: Given::SampleRate,
                message: format!("must be between {lo} Hz and {hi:e} Hz, got {fs:e} Hz"),
            }
            .into());
        }
        if let Some(file_hz) = rec.sample_rate_hz.filter(|f| (f / fs - 1.0).abs() > 1e-6 && !o.fs_override) {
            return Err(JobError::SampleRateConflict { file: path.display().to_string(), given_hz: fs, file_hz }.into());
        }
        return Ok(Some(fs));
    }
    let (lo, hi) = SAMPLE_RATE_RANGE_HZ;
    match rec.sample_rate_hz {
        Some(fs) if (lo..=hi).contains(&fs) => Ok(Some(fs)),
        Some(fs) if fs > 0.0 && fs.is_finite() => Err(bad(
            path,
            format!(
                "the file's sample rate, {} Hz, is outside {lo} Hz .. {hi:e} Hz: a damaged header or time column; give the true rate with --fs and --fs-override",
                crate::report::format::sig(fs, 6)
            ),
        )),
        Some(fs) => Err(bad(path, format!("sample rate {fs} Hz is not positive; give the sample rate"))),
        None if o.fs_unknown => Ok(None),
        None => Err(JobError::NoSampleRate { file: path.display().to_string(), for_speed: false }.into()),
    }
}

/// What [`check_recording`] established: the tachometer channel, the vibration channels (1-based) with
/// their raw RMS and kurtosis, the longest channel's samples and the sample rate in Hz (`None` when
/// unknown).
pub(super) struct Checked {
    pub tacho: Option<usize>,
    pub channels: Vec<usize>,
    pub moments: Vec<ind::ChannelMoments>,
    pub samples: usize,
    pub fs: Option<f64>,
}

/// Most relative difference between an undeclared tachometer's shaft rate and a given speed's, or between
/// the mesh comb's best period near it and its own, for its pulses to be the pinion's: a given speed is
/// nominal (its tolerance, `--speed-tolerance`), while a comb found within 1 % of the pulses' speed on a
/// spectrum resolving a tenth of a shaft order agrees to a few parts in a thousand.
const UNDECLARED_COMB_AGREEMENT: f64 = 0.005;

/// A pulse train among `pulses` (channels that sit at two levels, none named as the tachometer) whose rate
/// over the pulses per revolution is the pinion's speed: within the tolerance of a given speed, or, with
/// the pinion's teeth and no speed, where the mesh comb of the vibration channel `vib` stands
/// [`super::tracking::MIN_COMB_DB`] over its floor within [`UNDECLARED_COMB_AGREEMENT`] of the teeth times
/// that rate. Nothing is taken without a speed or the teeth to check it on (a wheel's or a motor's
/// tachometer would give a wrong speed silently). The channel and why it was taken.
fn undeclared_tachometer(
    rec: &Recording,
    pulses: &[usize],
    vib: usize,
    o: &Options,
    fs: Option<f64>,
) -> Option<(usize, String)> {
    let ppr = o.pulses_per_rev.max(1) as f64;
    let period_of = |c: usize| {
        let p = speed::tacho_pulses(&rec.channels[c - 1]).ok()?;
        (p.len() >= 3).then(|| ppr * (p[p.len() - 1] - p[0]) / (p.len() - 1) as f64)
    };
    pulses.iter().find_map(|&c| {
        let period = period_of(c)?;
        let per_rev = if ppr > 1.0 { format!("{ppr} pulses") } else { "one pulse".into() };
        match (o.shaft_hz, fs, o.teeth) {
            (Some(hz), Some(fs), _) => {
                let rate = fs / period;
                ((rate / hz - 1.0).abs() <= o.speed_tolerance).then(|| {
                    (c, format!("at {per_rev} per revolution it gives {rate:.4} Hz, the given speed within its tolerance"))
                })
            }
            (None, _, Some((zp, _))) => {
                let x = &rec.channels[vib - 1];
                let (found, db) =
                    speed::mesh_comb_period(&mut Fft::new(), &x[..x.len().min(1 << 21)], period, zp, 0.01).ok()?;
                ((found / period - 1.0).abs() <= UNDECLARED_COMB_AGREEMENT && db >= super::tracking::MIN_COMB_DB).then(
                    || {
                        (c, format!(
                            "at {per_rev} per revolution the mesh comb of {zp} teeth stands {db:.1} dB over its floor at {zp} times its rate"
                        ))
                    },
                )
            }
            _ => None,
        }
    })
}

/// The channel roles and the checks before any analysis: the given tachometer and vibration channels exist
/// and differ, pulse trains and the sidecar's tachometers are never vibration, the data is long enough,
/// finite and not constant, and the sample rate is plausible. Warnings go to `warnings`.
///
/// # Errors
/// A channel that does not exist or is the tachometer, no vibration channel left, bad data, a bad rate.
pub(super) fn check_recording(
    path: &Path,
    rec: &Recording,
    o: &Options,
    warnings: &mut Vec<String>,
) -> Result<Checked, Error> {
    let nch = rec.channels.len();
    let check_index = |role: ChannelRole, c: usize| -> Result<usize, Error> {
        if c == 0 || c > nch {
            Err(JobError::Channel { file: path.display().to_string(), role, index: c, count: nch }.into())
        } else {
            Ok(c)
        }
    };
    let tacho = o.tacho_channel.map(|c| check_index(ChannelRole::Tachometer, c)).transpose()?;
    let mut pulse_channels = Vec::new();
    if o.pulses_per_rev == 0 {
        return Err(bad(path, "0 tachometer pulses per revolution: a tachometer gives at least 1"));
    }
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
                        "channel {c} is a pulse train (it sits at two levels), a tachometer: it is not analysed as vibration; give it as the tachometer channel"
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
                    pulse_channels.push(c);
                }
                !pulses
            })
            .collect(),
    };
    let n = rec.channels.iter().map(|c| c.len()).max().unwrap_or(0);
    if nch == 0 || n < 2 {
        return Err(bad(path, format!("{n} sample(s): far too short to analyse")));
    }
    let fs = sample_rate(path, rec, o)?;
    if channels.is_empty() {
        return Err(bad(path, "no channel left to analyse besides the tachometer"));
    }
    let undeclared = match (tacho, &o.machine) {
        (None, None) => undeclared_tachometer(rec, &pulse_channels, channels[0], o, fs),
        _ => None,
    };
    for &c in &pulse_channels {
        warnings.push(match &undeclared {
            Some((t, why)) if *t == c => format!("channel {c} is a pulse train (it sits at two levels), taken as the pinion's tachometer: {why}"),
            _ if tacho.is_none() && undeclared.is_none() => format!(
                "channel {c} is a pulse train (it sits at two levels), a tachometer: not analysed as vibration; give it as the tachometer channel (with its pulses per revolution) to take the speed from it"
            ),
            _ => format!("channel {c} is a pulse train (it sits at two levels), a tachometer: not analysed as vibration"),
        });
    }
    let tacho = tacho.or(undeclared.map(|u| u.0));
    let checks: Vec<Result<(ind::ChannelMoments, Vec<String>), Error>> = channels
        .par_iter()
        .map(|&c| {
            let mut w = Vec::new();
            check_channel(path, c, &rec.channels[c - 1], &mut w).map(|m| (m, w))
        })
        .collect();
    let mut moments = Vec::new();
    for c in checks {
        let (m, w) = c?;
        moments.push(m);
        warnings.extend(w);
    }
    Ok(Checked { tacho, channels, moments, samples: n, fs })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A batch's catch ([`caught`](super::caught)): a panic while one recording is diagnosed, in its
    /// thread or a worker's, becomes that recording's error naming the file (the batch goes on and the
    /// exit code says it failed); a result passes through.
    #[test]
    fn a_panic_in_one_recording_is_its_error() {
        let file = Path::new("hour-long.wav");
        let e =
            caught(file, || -> Result<(), Error> { panic!("index out of bounds: the len is 33 but the index is 38") })
                .unwrap_err()
                .to_string();
        assert!(e.contains("hour-long.wav") && e.contains("internal error") && e.contains("the index is 38"), "{e}");
        let e = caught(file, || {
            let v: Vec<usize> =
                (0..64usize).into_par_iter().map(|i| if i == 9 { panic!("worker {i}") } else { i }).collect();
            Ok(v.len())
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains("hour-long.wav") && e.contains("worker 9"), "{e}");
        assert_eq!(caught(file, || Ok(5)).unwrap(), 5);
    }

    /// The clipping count against a plain run-by-run count: a sine clipped at 0.8 of its peak (runs of
    /// about 40 samples stuck at the level: counted), a channel with a few short runs at its peak (under
    /// the share: none), and one with many isolated peak samples (the count of samples reaching the level
    /// passes the share, the runs of three do not: none).
    #[test]
    fn clipping_is_counted_as_run_by_run() {
        let plain = |x: &[f32], level: f32| {
            let (mut run, mut stuck) = (0usize, 0usize);
            for v in x {
                run = if v.abs() >= level { run + 1 } else { 0 };
                stuck += usize::from(run >= 3);
            }
            stuck
        };
        let n = 100_000;
        let clipped: Vec<f32> = (0..n).map(|i| (i as f32 * 0.01).sin().clamp(-0.8, 0.8)).collect();
        let stuck = plain(&clipped, 0.8 * 0.9999);
        assert!(stuck as f64 > CLIPPED_SHARE * n as f64);
        assert_eq!(clipped_samples(&clipped, 0.8 * 0.9999), Some(stuck));
        let mut few: Vec<f32> = (0..n).map(|i| 0.5 * (i as f32 * 0.01).sin()).collect();
        few[10..14].fill(1.0);
        assert_eq!(clipped_samples(&few, 0.9999), None);
        let isolated: Vec<f32> =
            (0..n).map(|i| if i % 50 == 0 { 1.0 } else { 0.5 * (i as f32 * 0.01).sin() }).collect();
        assert_eq!(plain(&isolated, 0.9999), 0);
        assert_eq!(clipped_samples(&isolated, 0.9999), None);
    }

    /// A tachometer recorded through an ADC (pulses of 8 % duty, edges through a one-pole low-pass of 4
    /// samples, noise at 1 % of the pulse height, a DC offset) is told as pulses; vibration is not: a
    /// noisy sine, an impulsive signal (a one-sample shock every 500 samples on quiet noise: two levels,
    /// neither held), a sine clipped at half its peak (the clipped tops and the band near them hold 77 %
    /// of the samples, short of 95 %), and a constant or NaN channel.
    #[test]
    fn a_recorded_pulse_train_is_told_from_vibration() {
        let mut noise = crate::signal::test_noise::uniform_noise(7);
        let n = 40_000;
        let mut level = 0.0f64;
        let tacho: Vec<f32> = (0..n)
            .map(|i| {
                let target = if i % 1000 < 80 { 5.0 } else { 0.0 };
                level += (target - level) / 4.0;
                (0.3 + level + 0.05 * noise()) as f32
            })
            .collect();
        assert!(looks_like_pulses(&tacho));
        let sine: Vec<f32> = (0..n).map(|i| ((i as f64 * 0.05).sin() + 0.1 * noise()) as f32).collect();
        assert!(!looks_like_pulses(&sine));
        let shocks: Vec<f32> = (0..n).map(|i| (if i % 500 == 0 { 20.0 } else { 0.0 } + 0.2 * noise()) as f32).collect();
        assert!(!looks_like_pulses(&shocks));
        let clipped: Vec<f32> = (0..n).map(|i| (2.0 * (i as f64 * 0.05).sin()).clamp(-1.0, 1.0) as f32).collect();
        assert!(!looks_like_pulses(&clipped));
        assert!(!looks_like_pulses(&vec![1.5f32; n]));
        assert!(!looks_like_pulses(&vec![f32::NAN; n]));
        // the exact two-level form (a synthetic tachometer) still counts
        let square: Vec<f32> = (0..n).map(|i| if i % 1000 < 80 { 1.0 } else { 0.0 }).collect();
        assert!(looks_like_pulses(&square));
        // two values without two pulses: a step, or a record of a few samples (which is then too short,
        // not a tachometer)
        let step: Vec<f32> = (0..n).map(|i| if i < n / 2 { 0.0 } else { 1.0 }).collect();
        assert!(!looks_like_pulses(&step));
        assert!(!looks_like_pulses(&[1.0, 2.0]));
        assert!(!looks_like_pulses(&[1.0, 2.0, 1.0]));
    }
}
