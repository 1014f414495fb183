//! Speed and mesh order of a recording: the nominal speed (given, tachometer or repetition period), the
//! mesh order when the teeth are not given, and order tracking on the phase of a mesh harmonic (the
//! teeth themselves: `teeth.rs`).

use super::*;

mod estimate;
use estimate::*;
mod fundamental;
use fundamental::*;
mod mesh_shaft;
use mesh_shaft::*;
mod turns;
use turns::*;
mod ramp;
mod repetition;
mod ridges;
mod starts;
pub(super) use ramp::passes_through;
use ramp::ramp_through;
use repetition::*;
pub(super) use ridges::strongest_low_harmonic;
use ridges::*;
use starts::*;

/// The speed before tracking: revolution starts from the tachometer, or a constant nominal speed (given,
/// or estimated from the repetition period).
pub(super) struct Nominal {
    /// Revolution starts at the nominal speed.
    pub(super) map: AngleMap,
    /// Where the speed came from.
    pub(super) source: SpeedSource,
    /// Confidence of an estimated speed (1 when given).
    pub(super) confidence: f64,
    /// Mesh order from the ratio of the repetition period to the mesh lag (estimated speed only).
    pub(super) mesh_order: Option<usize>,
    /// Why an estimated speed is too doubtful for a verdict of health to rest on it.
    pub(super) doubt: Option<String>,
    /// A given speed whose mesh comb was sought and not found (its height over the spectrum, dB): unless the
    /// tracking then follows the mesh line, the averages rest on the nameplate speed as it is.
    pub(super) unconfirmed_comb_db: Option<f64>,
    /// A second start for the tracking and what it is ([`SecondStart`]); kept when the line followed from
    /// it stands clearly higher than the one followed from `map` (the analysis stage decides).
    pub(super) alternative: Option<(AngleMap, SecondStart)>,
}

impl Nominal {
    /// An angle at a constant speed or from pulses with nothing more to say (no mesh order, no doubt, no
    /// comb to weigh, no second start).
    fn plain(map: AngleMap, source: SpeedSource, confidence: f64) -> Self {
        Nominal { map, source, confidence, mesh_order: None, doubt: None, unconfirmed_comb_db: None, alternative: None }
    }
}

/// The nominal speed of a recording: from the tachometer channel, the given speed (checked on the mesh
/// comb when the teeth are given), or estimated from the signal (the mesh comb with the teeth, the mesh
/// line's angle, the repetition period).
#[allow(clippy::too_many_arguments)]
pub(super) fn nominal_speed(
    path: &Path,
    rec: &Recording,
    channels: &[usize],
    o: &Options,
    fs: Option<f64>,
    geometry: Option<&Geometry>,
    fft: &mut Fft,
    warnings: &mut Vec<String>,
) -> Result<Nominal, Error> {
    let n = rec.channels.iter().map(|c| c.len()).max().unwrap_or(0);
    // a given speed is checked against the record whatever gives the speed (beside a tachometer it is the
    // nominal speed the tachometer's is compared with); without a sample rate `given_speed` refuses it
    if let (Some(hz), Some(fs)) = (o.shaft_hz, fs) {
        check_given_speed(path, hz, fs, n, o.min_revolutions)?;
    }
    if let Some(t) = o.tacho_channel {
        let pulses = speed::tacho_pulses(&rec.channels[t - 1])
            .and_then(|p| angle::from_pulses(&p, o.pulses_per_rev.max(1)))
            .map_err(|e| bad(path, format!("tachometer channel {t}: {e}")))?;
        return Ok(Nominal::plain(pulses, SpeedSource::Tachometer, 1.0));
    }
    if let Some(hz) = o.shaft_hz {
        return given_speed(path, rec, channels, o, (hz, fs), fft, warnings);
    }
    let views: Vec<&[f32]> = channels.iter().map(|&c| &rec.channels[c - 1][..n.min(1 << 20)]).collect();
    let full: Vec<&[f32]> = channels.iter().map(|&c| &rec.channels[c - 1][..n.min(1 << 21)]).collect();
    let est = match estimated_on_lines(path, (&views, &full, n), o, fs, geometry, fft, warnings)? {
        Ok(found) => return Ok(with_baseline_start(found.nominal(n, warnings), o, geometry, n)),
        Err(est) => est,
    };
    // a mesh-dominated signal (its shortest strong repetition is a tooth mesh): the shaft is sought on the
    // mesh line's own angle, which holds under speed fluctuation where the raw autocorrelation smears
    let mesh_lag = est.mesh_lag.or((est.period_samples < MIN_SAMPLES_PER_REV).then_some(est.period_samples));
    if let (Some(lag), None) = (mesh_lag, geometry.and_then(|g| g.period_samples)) {
        let pinion = o.teeth.map(|t| (t.0, "the given teeth"));
        match shaft_through_mesh(fft, &full, lag, o.min_revolutions, pinion, o.teeth.map(|t| t.1)) {
            Ok(Some(found)) => return Ok(found.nominal(n, warnings)),
            Ok(None) => {
                return Err(missing_speed(
                    path,
                    format!(
                        "no plausible shaft speed: the signal follows a tooth mesh (a cycle every {}) but no longer period (a shaft) stands out on its angle; give the shaft speed (or the teeth) or a tachometer channel",
                        fs.map_or(format!("{lag:.2} samples"), |f| format!("{lag:.2} samples, {:.1} Hz", f / lag))
                    ),
                ));
            }
            // the line cannot be followed: the short lag may be no mesh but a few revolutions (then the
            // revolution inside it is the period); otherwise the raw repetition period below is all there is
            Err(_) => {
                if let Some(inner) = est.mesh_lag.and_then(|m| speed::revolution_within(fft, &views, m)) {
                    warnings.push(format!(
                        "the signal's short repetition ({lag:.1} samples) is no tooth mesh (no line follows it): it holds {:.0} revolutions of {:.3} samples, taken as the shaft's",
                        lag / inner.period_samples,
                        inner.period_samples
                    ));
                    return Ok(from_repetition(&inner, &views, o, geometry, n, warnings));
                }
            }
        }
    }
    if est.mesh_lag.is_none() && est.period_samples < MIN_SAMPLES_PER_REV {
        return Err(missing_speed(
            path,
            format!(
                "no plausible shaft speed: the signal repeats every {:.2} samples, too short for a shaft (likely the tooth mesh), and no longer period stands out (the speed may vary too much to estimate); give the shaft speed or a tachometer channel",
                est.period_samples
            ),
        ));
    }
    warnings.push(format!(
        "shaft speed estimated from the signal's repetition period ({:.3} samples, autocorrelation {:.2}); give the speed or a tachometer channel when known",
        est.period_samples, est.confidence
    ));
    Ok(with_baseline_start(from_repetition(&est, &views, o, geometry, n, warnings), o, geometry, n))
}

/// A given speed `hz` (with the sample rate `fs`; checked against the record by [`nominal_speed`]), sought
/// on the mesh comb when the teeth are given (the comb's speed, or a second start for the tracking).
fn given_speed(
    path: &Path,
    rec: &Recording,
    channels: &[usize],
    o: &Options,
    (hz, fs): (f64, Option<f64>),
    fft: &mut Fft,
    warnings: &mut Vec<String>,
) -> Result<Nominal, Error> {
    let n = rec.channels.iter().map(|c| c.len()).max().unwrap_or(0);
    let fs =
        fs.ok_or_else(|| Error::from(JobError::NoSampleRate { file: path.display().to_string(), for_speed: true }))?;
    let (period, unconfirmed_comb_db, alternative) = match o.teeth {
        Some((zp, _)) => given_on_mesh_comb(rec, channels, fs / hz, zp, o, fft, warnings),
        None => (fs / hz, None, None),
    };
    Ok(Nominal {
        unconfirmed_comb_db,
        alternative: alternative.map(|p| (AngleMap::constant(p, 0.0, n), SecondStart::WeakComb)),
        ..Nominal::plain(AngleMap::constant(period, 0.0, n), SpeedSource::Given, 1.0)
    })
}

/// Without a speed: the shaft found on lines (the mesh comb of the given teeth; near a baseline's period, the
/// mesh line's angle), or else the signal's repetition period (near the baseline's, or anywhere, of at most
/// `n` samples over the least revolutions).
fn estimated_on_lines(
    path: &Path,
    (views, full, n): (&[&[f32]], &[&[f32]], usize),
    o: &Options,
    fs: Option<f64>,
    geometry: Option<&Geometry>,
    fft: &mut Fft,
    warnings: &mut Vec<String>,
) -> Result<Result<MeshShaft, speed::PeriodEstimate>, Error> {
    let comb = |fft: &mut Fft| o.teeth.and_then(|t| shaft_from_comb(fft, views, full, t, o.min_revolutions, fs));
    let est = match geometry.and_then(|g| g.period_samples) {
        Some(p) => {
            // the baseline's period: with the teeth, the mesh comb as the baseline's own speed was found (one
            // pipeline), kept when it is the baseline's within the accepted speed change; then a
            // mesh-dominated recording is followed on its mesh line as the baseline was (a 1 % speed
            // fluctuation smears the raw repetition of a whole revolution), the shaft found there kept on the
            // same condition
            if let Some(found) = comb(fft).filter(|f| (f.period_samples / p - 1.0).abs() <= MAX_SPEED_DIFFERENCE) {
                return Ok(Ok(found));
            }
            let mesh_order = geometry.and_then(|g| g.mesh_order).or(o.teeth.map(|t| t.0));
            if let Some(found) = mesh_order.and_then(|z| shaft_near(fft, views, full, p, z, o.min_revolutions)) {
                return Ok(Ok(found));
            }
            match (speed::period_near(fft, views, p, 0.03), mesh_order) {
                (Err(_), Some(_)) => {
                    return Ok(Ok(from_the_baseline(p, fs)));
                }
                (near, _) => near,
            }
        }
        None => {
            if let Some(found) = comb(fft) {
                return Ok(Ok(over_unsure_comb(found, fft, (views, full, n), o, fs, warnings)));
            }
            speed::estimate_period(fft, views, 16, n / o.min_revolutions.max(2))
        }
    };
    est.map(Err).map_err(|e| bad(path, e))
}

/// The nominal angle on a repetition period `est`: with the teeth and no baseline, the pinion revolution
/// is the fraction of a repetition over several revolutions (a hunting period) where the given mesh order
/// has its line; a period found near the baseline's is the baseline's shaft revolution (whose own estimate
/// already told a revolution from a hunting period), never a multiple of it (a cracked pinion's strong fourth
/// mesh harmonic would otherwise cut the baseline's revolution into four).
fn from_repetition(
    est: &speed::PeriodEstimate,
    views: &[&[f32]],
    o: &Options,
    geometry: Option<&Geometry>,
    n: usize,
    warnings: &mut Vec<String>,
) -> Nominal {
    if let (Some((zp, _)), None) = (o.teeth, geometry.and_then(|g| g.period_samples)) {
        let line = |k: usize| -> f64 {
            let f = zp as f64 * k as f64 / est.period_samples;
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
            return Nominal::plain(
                AngleMap::constant(est.period_samples / k as f64, 0.0, n),
                SpeedSource::Estimated,
                est.confidence,
            );
        }
    }
    Nominal {
        mesh_order: est
            .mesh_lag
            .map(|m| (est.period_samples / m).round() as usize)
            .map(|z| fundamental_mesh(views, est.period_samples, z))
            .filter(|&z| z >= 8),
        doubt: (est.confidence < UNSURE_REPETITION).then(|| {
            format!(
                "the shaft speed was estimated from a repetition of autocorrelation {:.2} (under {UNSURE_REPETITION}): the signal hardly repeats there, so averages on that period cannot clear the machine; give the shaft speed or a tachometer channel",
                est.confidence
            )
        }),
        ..Nominal::plain(AngleMap::constant(est.period_samples, 0.0, n), SpeedSource::Estimated, est.confidence)
    }
}

/// Comb height (the geometric mean of its three highest harmonics over their local floor, dB) from which the
/// comb's speed replaces a given one: over a +-5 % window the three highest of 16 noise-only harmonics,
/// each the largest of 2-3 bins of a spectrum averaged over 20 or more segments, reach about 3 dB; the
/// hold-out machines' meshes stand 8-15 dB at their resonance-lifted harmonics.
pub(super) const MIN_COMB_DB: f64 = 8.0;

/// Comb height (as [`MIN_COMB_DB`]) from which the comb's best speed, though not a confirmation, is a second
/// start for the tracking beside the given speed: 2 dB over what noise alone reaches. A high harmonic's
/// ridge is sought within +-0.45 orders of its start, which a given speed 1.5 % off misses at order 78
/// (a 13-tooth pinion's sixth mesh harmonic, where the hold-out's m2 has its strongest lines; the tracking
/// then followed the wheel's sideband, 2.6 % off).
const START_COMB_DB: f64 = 5.0;

/// Mesh comb height over the spectrum's median from which the first channel's comb is taken without
/// looking at the others, dB: the period the comb gives is only the tracking's start (the tracking follows
/// the mesh line's phase from there), and a comb 20 dB over the floor puts it within a fraction of a bin.
const CLEAR_COMB_DB: f64 = 20.0;

/// The pinion period (samples) of a given nominal speed (period `nominal`), searched on the mesh comb of
/// `zp` teeth within the tolerance on the analysed channels (the one where the comb stands highest); the
/// nominal period when no comb stands [`MIN_COMB_DB`] over the floor, with a warning and the comb's height
/// (dB; `None` when the comb confirmed the speed), and the comb's best period as a second start for the
/// tracking when the comb stands between [`START_COMB_DB`] and [`MIN_COMB_DB`].
fn given_on_mesh_comb(
    rec: &Recording,
    channels: &[usize],
    nominal: f64,
    zp: usize,
    o: &Options,
    fft: &mut Fft,
    warnings: &mut Vec<String>,
) -> (f64, Option<f64>, Option<f64>) {
    let comb = |fft: &mut Fft, c: usize| {
        let x = &rec.channels[c - 1];
        speed::mesh_comb_period(fft, &x[..x.len().min(1 << 21)], nominal, zp, o.speed_tolerance).ok()
    };
    // the first channel's comb when it stands clear; else every channel's (in parallel, each with its own
    // transforms), the highest taken
    let first = comb(fft, channels[0]);
    let best = match first {
        Some((_, db)) if db >= CLEAR_COMB_DB => first,
        _ => {
            let rest: Vec<(f64, f64)> = channels[1..].par_iter().filter_map(|&c| comb(&mut Fft::new(), c)).collect();
            first.into_iter().chain(rest).max_by(|a, b| a.1.total_cmp(&b.1))
        }
    };
    match best {
        Some((p, db)) if db >= MIN_COMB_DB => (p, None, None),
        Some((p, db)) if db >= START_COMB_DB => {
            warnings.push(format!(
                "the mesh comb of {zp} teeth stands only {db:.1} dB over the spectrum within +-{:.1} % of the given speed: not a confirmation; the tracking is started from the given speed and from the comb's best ({:+.2} % from it), and the comb's start is kept only when its line stands clearly higher",
                100.0 * o.speed_tolerance,
                100.0 * (nominal / p - 1.0)
            ));
            (nominal, Some(db), Some(p))
        }
        Some((_, db)) => {
            warnings.push(format!(
                "the mesh comb of {zp} teeth stands only {db:.1} dB over the spectrum within +-{:.1} % of the given speed: the given speed is used as it is",
                100.0 * o.speed_tolerance
            ));
            (nominal, Some(db), None)
        }
        None => (nominal, Some(f64::NEG_INFINITY), None),
    }
}

/// Largest relative difference between the tracked mean speed and the nominal one that is accepted: the
/// nominal speed is the mean (estimated) or what the user gave; further away the ridge followed another line.
const MAX_TRACKING_SHIFT: f64 = 0.05;

pub(super) fn ind_line(x: &[f32], f: f64, search: f64) -> f64 {
    crate::signal::spectrum::line_amplitude(x, f, search)
}

/// [`MAX_TRACKING_SHIFT`] when the nominal speed was estimated from the repetition period (the mean speed
/// itself, good to about 1e-4): 0.5 % leaves room for a drift that is not symmetric in time.
const MAX_TRACKING_SHIFT_ESTIMATED: f64 = 0.005;

/// How far a followed angle's mean speed may lie from an estimated one: [`MAX_TRACKING_SHIFT_ESTIMATED`],
/// or as far as the followed speed itself wanders (half its 10-90 % range, [`angle::SpeedProfile`]), up
/// to [`MAX_TRACKING_SHIFT`]. An estimate from the teeth is the peak of a mesh comb summed over the record,
/// and on a shaft that wanders by a percent or two that peak lies anywhere the speed spent its time, not
/// at its mean: the hold-out's healthy 13/37 pinion, wandering +-1.2 %, was estimated 0.54 % under the
/// mean its mesh line was followed at, and that angle was dropped for a constant speed that smeared the
/// averages. A line of another source stands apart by more than the wander of the one followed.
fn estimated_shift(map: &AngleMap) -> f64 {
    angle::SpeedProfile::of(map).wander.clamp(MAX_TRACKING_SHIFT_ESTIMATED, MAX_TRACKING_SHIFT)
}

/// Line-to-band ratio from which the best channel's mesh line is followed without looking at the second
/// channel's, dB (14 dB over the weakest line trusted; a 60 s recording's short-time spectra of a channel
/// cost 20 ms).
const CLEAR_LINE_DB: f64 = 20.0;

/// Line-to-band ratio below which a tracked mesh line is too weak to trust, dB.
const MIN_TRACKING_SNR_DB: f64 = 6.0;

/// `map` with its origin moved to the tachometer's: the circular mean, over the pulses of `tacho`, of
/// the angle `map` gives each pulse (revolutions, fraction of one) is taken as `map`'s angle 0.
fn align_origin(map: &AngleMap, tacho: &AngleMap) -> AngleMap {
    let starts = map.starts();
    let (mut c, mut s) = (0.0, 0.0);
    for &p in tacho.starts() {
        let k = starts.partition_point(|&x| x <= p);
        if k == 0 || k >= starts.len() {
            continue;
        }
        let frac = (p - starts[k - 1]) / (starts[k] - starts[k - 1]);
        let phi = std::f64::consts::TAU * frac;
        c += phi.cos();
        s += phi.sin();
    }
    let delta = s.atan2(c).rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU;
    let aligned: Vec<f64> = (0..map.revolutions()).map(|k| map.sample_at(delta + k as f64)).collect();
    AngleMap::from_pulses(&aligned, 1)
}

/// Follows the shaft angle through the recording. With a tachometer its pulses are the angle. Otherwise the
/// phase of the first mesh harmonic is tracked on each analysed channel (the mesh order from the teeth, the
/// baseline, or the harmonic family of a constant-speed TSA) and the channel where the line stands out
/// most is used; when no channel allows it, the constant nominal speed stays, with a warning. With a given
/// speed (`given`: its revolution, samples) the followed angle's mean must lie within the speed tolerance
/// of it as well as near the nominal start: the start may be a comb's speed a few percent from the given
/// one, and a line followed a few percent further is another machine line (a 10-blade fan's third
/// harmonic at order 30 beside a 31-tooth mesh, 5.2 % from the given speed, was followed and used).
#[allow(clippy::too_many_arguments)]
pub(super) fn track(
    path: &Path,
    rec: &Recording,
    channels: &[usize],
    o: &Options,
    known_z: Option<usize>,
    nominal: AngleMap,
    given: Option<f64>,
    warnings: &mut Vec<String>,
) -> Result<Tracked, Error> {
    if o.tacho_channel.is_some() {
        return track_with_tachometer(path, rec, channels, o, known_z, nominal, warnings);
    }
    let (tracked, unfollowed) = follow_mesh(path, rec, channels, o, known_z, nominal, given)?;
    if let Some(why) = unfollowed {
        warnings.push(format!("{why}; the TSA assumes a constant speed"));
    }
    Ok(tracked)
}

/// The mesh-phase part of [`track`]: the followed angle, or the constant nominal one with why the line
/// could not be followed (what the caller then averages on is its own to say).
fn follow_mesh(
    path: &Path,
    rec: &Recording,
    channels: &[usize],
    o: &Options,
    known_z: Option<usize>,
    nominal: AngleMap,
    given: Option<f64>,
) -> Result<(Tracked, Option<String>), Error> {
    let period = nominal.mean_period_samples();
    let z = match known_z {
        Some(z) => z,
        None => mesh_order_on(path, rec, channels, o, &nominal)?,
    };
    let ridges = ridges_to_follow(rec, channels, period, z);
    let mut best = None;
    for (c, r) in ridges {
        let t = r.and_then(|r| angle::follow_ridge(&rec.channels[c - 1], r));
        let done = t.is_ok();
        best = Some(t);
        if done {
            break;
        }
    }
    // a given speed may be off by a few percent; an estimated one by the speed's own wander
    let within = |t: &angle::Tracked| {
        let mean = t.map.mean_period_samples();
        let max_shift = if o.shaft_hz.is_some() { MAX_TRACKING_SHIFT } else { estimated_shift(&t.map) };
        (mean / period - 1.0).abs() <= max_shift && given.is_none_or(|g| (g / mean - 1.0).abs() <= o.speed_tolerance)
    };
    // a weak line, or one the phase-locked loop lost: the whole comb is followed too, and its angle kept
    // when the loop holds it and the single line was lost or stands lower
    let weak = !matches!(&best, Some(Ok(t)) if within(t) && t.locked && t.line_snr_db >= COMB_FALLBACK_DB);
    if weak {
        let tolerance = if o.shaft_hz.is_some() { o.speed_tolerance } else { MAX_TRACKING_SHIFT_ESTIMATED };
        if let Some(comb) = comb_tracked(rec, channels, period, z, tolerance).filter(within) {
            let better = match &best {
                Some(Ok(t)) => !within(t) || !t.locked || comb.line_snr_db > t.line_snr_db,
                _ => true,
            };
            if better {
                best = Some(Ok(comb));
            }
        }
    }
    // when neither the line nor the comb ends near the speeds, two lines are still the machine's mesh
    // (the caller checks that the line is no sideband and says how the given speed is off): one the loop
    // holds running up or coasting down through the given speed (a line near the speeds, the comb's above,
    // is preferred: a sideband of a ramp runs through it too), and a clear one the loop holds near the
    // nominal speed with only the given speed beyond the tolerance
    let mesh_after_all = |t: &angle::Tracked| {
        let ramp = ramp_through(t, period, given, o.speed_tolerance) && t.line_snr_db >= MIN_TRACKING_SNR_DB;
        let clear_beyond_given = t.locked
            && t.line_snr_db >= CLEAR_LINE_DB
            && (t.map.mean_period_samples() / period - 1.0).abs() <= MAX_TRACKING_SHIFT;
        o.shaft_hz.is_some() && (ramp || clear_beyond_given)
    };
    let constant = (nominal, Tracking::Constant, None, Some(z));
    Ok(match best {
        Some(Ok(t)) if !within(&t) && mesh_after_all(&t) => {
            ((t.map, Tracking::MeshPhase, Some(t.line_snr_db), Some(z)), None)
        }
        Some(Ok(t)) if !within(&t) => {
            let mean = t.map.mean_period_samples();
            let why = format!(
                "mesh-phase tracking of order {z} ended {:+.1} % away from the nominal speed{}: it followed another line",
                100.0 * (period / mean - 1.0),
                given.map_or(String::new(), |g| format!(
                    " ({:+.1} % from the given one, tolerance +-{:.1} %)",
                    100.0 * (g / mean - 1.0),
                    100.0 * o.speed_tolerance
                ))
            );
            (constant, Some(why))
        }
        Some(Ok(t)) if t.line_snr_db >= MIN_TRACKING_SNR_DB => {
            ((t.map, Tracking::MeshPhase, Some(t.line_snr_db), Some(z)), None)
        }
        Some(Ok(t)) => {
            let why = format!(
                "the mesh line (order {z}) stands only {:.1} dB above its band: too weak to track the speed",
                t.line_snr_db
            );
            (constant, Some(why))
        }
        Some(Err(e)) => (constant, Some(format!("mesh-phase tracking not possible ({e})"))),
        None => (constant, None),
    })
}

/// What [`track`] gives: the angle, how it was found, the followed line's height over its band (dB) and
/// the mesh order it was followed for.
pub(super) type Tracked = (AngleMap, Tracking, Option<f64>, Option<usize>);

/// With a tachometer: one angle source for every recording of a machine, the mesh line's phase when the
/// teeth are known and the line can be followed (it follows the speed within a revolution, where a
/// once-per-revolution pulse train only interpolates), the tachometer fixing its origin; the
/// tachometer's own angle `nominal` otherwise.
fn track_with_tachometer(
    path: &Path,
    rec: &Recording,
    channels: &[usize],
    o: &Options,
    known_z: Option<usize>,
    nominal: AngleMap,
    warnings: &mut Vec<String>,
) -> Result<Tracked, Error> {
    let Some(z) = known_z else { return Ok((nominal, Tracking::Tachometer, None, None)) };
    let without = Options { tacho_channel: None, ..o.clone() };
    let (tracked, unfollowed) = follow_mesh(path, rec, channels, &without, Some(z), nominal.clone(), None)?;
    Ok(match tracked {
        // the mesh line must stand clear for its angle to replace a tachometer's (a weaker line can slip a
        // cycle in noise, which a pulse train never does)
        (map, Tracking::MeshPhase, snr @ Some(db), z)
            if db >= CLEAR_LINE_DB && map.revolutions() >= nominal.revolutions().saturating_sub(2) =>
        {
            (align_origin(&map, &nominal), Tracking::MeshPhaseTachometerOrigin, snr, z)
        }
        _ => {
            if let Some(why) = unfollowed {
                warnings.push(format!("the tachometer's angle is used, not the mesh phase: {why}"));
            }
            (nominal, Tracking::Tachometer, None, None)
        }
    })
}

/// The mesh order of a recording whose teeth are not known: the harmonic family of its constant-speed
/// TSA on `nominal`, brought down to the fundamental whose line stands.
fn mesh_order_on(
    path: &Path,
    rec: &Recording,
    channels: &[usize],
    o: &Options,
    nominal: &AngleMap,
) -> Result<usize, Error> {
    let period = nominal.mean_period_samples();
    let tsas = channels
        .par_iter()
        .map(|&c| tsa::tsa(&rec.channels[c - 1], nominal, 1.0, tsa_points(period), o.min_revolutions))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| bad(path, e))?;
    let z = mesh_family(&mut Fft::new(), tsas.iter().map(|t| t.samples.as_slice()));
    let views: Vec<&[f32]> = channels.iter().map(|&c| &*rec.channels[c - 1]).collect();
    Ok(fundamental_mesh(&views, period, z))
}

/// The error of a recording whose shaft speed could not be found: the speed must be given.
fn missing_speed(path: &Path, message: String) -> Error {
    JobError::Missing { file: path.display().to_string(), message, give: Given::ShaftSpeed }.into()
}
