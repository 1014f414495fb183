//! Track stage: the shaft's angle from one source (tachometer, mesh-phase tracking, nominal speed), the
//! speed it implies, and the doubts that keep a verdict of health from resting on it.

use super::super::*;
use super::sync::{CheckedSpeed, SyncSpectrum, mesh_not_sideband, no_mesh_lines, no_shaft_lines, speed_multiple};

/// Track stage: the shaft's angle from one source, where it came from, and the speed it implies.
pub(in crate::jobs::diagnose) struct ShaftAngle {
    /// Revolution starts of the reference shaft.
    pub map: AngleMap,
    /// Where the speed came from.
    pub source: SpeedSource,
    /// Confidence of an estimated speed (1 when given or measured).
    pub confidence: f64,
    /// Why an estimated speed is too doubtful for a verdict of health.
    pub doubt: Option<String>,
    /// Mesh order from the ratio of the repetition period to the mesh lag (estimated speed only).
    pub mesh_from_lag: bool,
    /// Mesh order the tracking found, when it had to.
    pub tracked_z: Option<usize>,
    /// Speed over the recording as reported.
    pub profile: SpeedProfile,
    /// Mean, least and largest revolution length, and their change (samples, fractions).
    pub speeds: angle::SpeedProfile,
    /// A given speed (Hz) and the measured speed's deviation from it (percent).
    pub given: Option<(f64, f64)>,
    /// Mean revolution, samples.
    pub period: f64,
}

impl ShaftAngle {
    /// The shaft that a measured or given speed belongs to: the pinion's, or a shaft nobody named when the
    /// period was estimated.
    pub(super) fn reference(&self) -> Shaft {
        if self.source == SpeedSource::Estimated { Shaft::Estimated } else { Shaft::Pinion }
    }
}

/// Track stage: the nominal speed (given, tachometer, or estimated), then the angle followed on the mesh
/// line; a given speed's deviation from the measured one is warned about.
#[allow(clippy::too_many_arguments)]
pub(super) fn follow_shaft(
    path: &Path,
    rec: &mut Recording,
    checked: &Checked,
    o: &Options,
    geometry: Option<&Geometry>,
    fft: &mut Fft,
    warnings: &mut Vec<String>,
) -> Result<ShaftAngle, Error> {
    let Checked { tacho, ref channels, fs, .. } = *checked;
    let nominal = nominal_speed(path, rec, channels, o, fs, geometry, fft, warnings)?;
    let known_z = o.teeth.map(|t| t.0).or_else(|| geometry.and_then(|g| g.mesh_order)).or(nominal.mesh_order);
    let given = o.shaft_hz.zip(fs).map(|(hz, fs)| fs / hz);
    let mesh_from_lag = nominal.mesh_order.is_some();
    let (map, tracking, line_snr_db, tracked_z) = match nominal.alternative {
        None => track(path, rec, channels, o, known_z, nominal.map, given, warnings)?,
        Some((alt, what)) => {
            // two starts (the given speed and its weak comb's best, or the recording's own estimate and the
            // baseline's speed): the second when its followed line stands clearly higher
            let mut given_warnings = Vec::new();
            let first = track(path, rec, channels, o, known_z, nominal.map, given, &mut given_warnings)?;
            let mut alt_warnings = Vec::new();
            let second = track(path, rec, channels, o, known_z, alt, given, &mut alt_warnings)?;
            let line = |t: &Tracked| t.2.filter(|_| t.1 == Tracking::MeshPhase).unwrap_or(f64::NEG_INFINITY);
            // without a speed, the same line followed from both starts (means within SAME_LINE) keeps the
            // first start: the second is there for a line the first missed
            let same_line = o.shaft_hz.is_none()
                && line(&first).is_finite()
                && (first.0.mean_period_samples() / second.0.mean_period_samples() - 1.0).abs() <= SAME_LINE;
            // when neither start followed a line (-inf stands as high as -inf plus any margin) the second
            // is kept only beside an estimate of the recording's own (`kept_without_lines`): beside a given
            // speed the weak comb's best is not (a 25/50 machine's broken wheel, given its nameplate, was
            // averaged on the comb's best 4.7 % from it, under a reason saying the given speed was used as
            // it is)
            if !same_line && second_start_kept(line(&first), line(&second), what.kept_without_lines()) {
                warnings.extend(alt_warnings);
                let (second_start, first_start) = what.names();
                // (a second start kept on no line is one where neither start followed a line)
                warnings.push(if !line(&second).is_finite() {
                    format!(
                        "the tracking followed no line from {second_start} nor from {first_start}: the start from {second_start} is kept"
                    )
                } else {
                    format!(
                        "the tracking from {second_start} followed a line {:.1} dB over its band, the one from {first_start} {}: the start from {second_start} is kept",
                        line(&second),
                        if line(&first).is_finite() { format!("{:.1} dB", line(&first)) } else { "none".into() }
                    )
                });
                second
            } else {
                warnings.extend(given_warnings);
                first
            }
        }
    };
    // the first channel's synchronous spectrum on an angle, up to 4.5 mesh orders (the mesh's first four
    // harmonics with their sidebands): what the checks of the angle read
    let x = &rec.channels[channels[0] - 1];
    let sync_of = |map: &AngleMap, z: usize| SyncSpectrum::new(x, map, 4.5 * z as f64);
    let (map, rests_on_nothing) = match (o.shaft_hz, known_z, tacho, tracking) {
        (Some(_), Some(z), None, Tracking::MeshPhase) => {
            let zw = o.teeth.filter(|t| t.0 == z).map(|t| t.1);
            let unconfirmed = nominal.unconfirmed_comb_db.is_some();
            let spectrum = sync_of(&map, z);
            let (map, spectrum) = match spectrum
                .as_ref()
                .and_then(|s| mesh_not_sideband(x, &map, s, (z, zw), o, (fs, unconfirmed), warnings))
            {
                Some(scaled) => {
                    let spectrum = sync_of(&scaled, z);
                    (scaled, spectrum)
                }
                None => (map, spectrum),
            };
            let q = zw.map(|w| z as f64 / w as f64);
            let misfit =
                spectrum.as_ref().zip(o.shaft_hz).and_then(|(s, hz)| speed_multiple(s, q, hz, CheckedSpeed::Given));
            (map, misfit)
        }
        (_, _, Some(_), Tracking::Tachometer) => {
            // the mesh must stand on the tachometer's angle, and a single pair's lines not on every d-th
            // order alone: too many pulses per revolution given put the averages on d turns of the shaft
            // (a machine's other shafts put lines of their own between the tachometer shaft's orders)
            let z = tracked_z.or(known_z);
            let spectrum = z.and_then(|z| sync_of(&map, z));
            let no_mesh = spectrum.as_ref().zip(z).and_then(|(s, z)| no_mesh_lines(s, z));
            let q = z.and_then(|z| o.teeth.filter(|t| t.0 == z)).map(|t| t.0 as f64 / t.1 as f64);
            let hz = fs.filter(|_| o.machine.is_none()).map(|fs| fs / map.mean_period_samples());
            let misfit =
                || spectrum.as_ref().zip(hz).and_then(|(s, hz)| speed_multiple(s, q, hz, CheckedSpeed::Tachometer));
            (map, no_mesh.or_else(misfit))
        }
        (None, Some(z), None, Tracking::MeshPhase) if nominal.source == SpeedSource::Estimated => {
            let zw = o.teeth.filter(|t| t.0 == z).map(|t| t.1);
            let bare = sync_of(&map, z).and_then(|s| no_shaft_lines(&s, (z, zw)));
            (map, bare)
        }
        _ => (map, None),
    };
    let (map, refined_gain) = match (tracking, tracked_z) {
        (Tracking::MeshPhase | Tracking::MeshPhaseTachometerOrigin, Some(z)) => refine_by_average(x, map, z),
        _ => (map, None),
    };
    // the tachometer's pulses are in the angle map now and are never analysed: free them
    if let Some(t) = tacho {
        rec.channels[t - 1] = std::borrow::Cow::Borrowed(&[]);
    }
    let speeds = angle::SpeedProfile::of(&map);
    // a given speed is a nominal one: what was measured (mesh comb and tracking, or the tachometer) is used,
    // and its deviation from the given speed reported
    let given = o.shaft_hz.zip(fs).map(|(hz, fs)| (hz, 100.0 * (speeds.mean * fs / hz - 1.0)));
    let mut ramp_off = false;
    let mut beyond = None;
    if let Some((hz, off)) = given {
        // (`given` is there only with a sample rate)
        let f = fs.unwrap_or(0.0);
        let measured = speeds.mean * f;
        let beyond_tolerance = off.abs() > 100.0 * o.speed_tolerance;
        ramp_off = beyond_tolerance && tracking::passes_through(&speeds, f / hz, o.speed_tolerance);
        if ramp_off {
            warnings.push(format!(
                "the speed changed by {:+.1} % over the recording ({:.3} to {:.3} Hz, {tracking}) and passed through the given {hz:.4} Hz: a run-up or coast-down, whose mean lies {off:+.2} % from the given speed; the averages follow the measured angle",
                100.0 * speeds.change,
                f * speeds.min,
                f * speeds.max
            ));
        } else if beyond_tolerance {
            warnings.push(format!(
                "the given speed {hz:.4} Hz is {off:+.2} % from the measured {measured:.4} Hz ({tracking}), beyond the +-{:.1} % tolerance: check the given speed",
                100.0 * o.speed_tolerance
            ));
            // (a tachometer's speed stands on its pulses: the given one is then the one in doubt)
            beyond = (tracking == Tracking::MeshPhase).then(|| format!(
                "the measured speed {measured:.4} Hz lies {:+.2} % from the given {hz:.4} Hz, beyond the +-{:.1} % tolerance: either the given speed is wrong or the line followed is not the mesh, so the averages cannot clear the machine; check the given speed (or widen --speed-tolerance) or give a tachometer channel",
                off,
                100.0 * o.speed_tolerance
            ));
        } else if off.abs() > 0.5 {
            warnings.push(format!(
                "the given speed {hz:.4} Hz is {off:+.2} % from the measured {measured:.4} Hz ({tracking}): the measured speed is used (a nameplate speed is off by the motor's slip)"
            ));
        }
    }
    let profile = SpeedProfile {
        tracking,
        mean_hz: fs.map(|f| f * speeds.mean),
        min_hz: fs.map(|f| f * speeds.min),
        max_hz: fs.map(|f| f * speeds.max),
        change_percent: 100.0 * speeds.change,
        fluctuation_percent: 100.0 * speeds.wander,
        line_snr_db,
        refined_gain,
    };
    let doubt = nominal
        .doubt
        .or(rests_on_nothing)
        .or_else(|| unconfirmed_speed(nominal.unconfirmed_comb_db, &profile, o, ramp_off))
        .or(beyond)
        .or_else(|| no_mesh_found(known_z, tracked_z, &profile, o))
        .or_else(|| unfollowed_estimate(nominal.source, &profile))
        .or_else(|| {
            let zp = o.teeth.map(|t| t.0).filter(|_| nominal.source == SpeedSource::Estimated)?;
            on_mains(zp, profile.mean_hz?, &speeds)
        });
    Ok(ShaftAngle {
        period: map.mean_period_samples(),
        map,
        source: nominal.source,
        confidence: nominal.confidence,
        doubt,
        mesh_from_lag,
        tracked_z,
        profile,
        speeds,
        given,
    })
}

/// Largest relative difference of two followed angles' mean speeds for them to be the same line (a
/// tracked mean is good to about 1e-4; lines of another source stand a percent or more away).
const SAME_LINE: f64 = 1e-3;

/// How much higher (dB) the line followed from a weak comb's best speed must stand than the one followed
/// from the given speed for the comb's start to be kept: lines of 6-7 dB differ by a dB between two
/// starts on the same line (a 31/47 pinion spall's 6.1 and 6.8 dB, where the comb's start smeared the
/// pinion's FM4 from 22.8 to 3.7), while a line and its neighbour differ by several.
const CLEARER_START_DB: f64 = 3.0;

/// Whether the second tracking start is kept: its followed line (dB over its band, -inf for none) stands
/// [`CLEARER_START_DB`] over the first's, or neither start followed a line and `without_lines` (the start's
/// `SecondStart::kept_without_lines` rule) keeps it.
fn second_start_kept(first: f64, second: f64, without_lines: bool) -> bool {
    if !first.is_finite() && !second.is_finite() {
        return without_lines;
    }
    second >= first + CLEARER_START_DB
}

/// Why averages on an estimated speed that could not be followed cannot clear the machine: the estimate is
/// the mean speed of a shaft that may wander by 0.5-2 %, and a constant-speed average on it smears a fault
/// over the revolution (hold-out machines, teeth only: a spall and worn pinion averaged on a constant speed
/// 0.95-1.34 % off the true mean were called healthy).
fn unfollowed_estimate(source: SpeedSource, profile: &SpeedProfile) -> Option<String> {
    (source == SpeedSource::Estimated && profile.tracking == Tracking::Constant).then(|| {
        "the estimated speed could not be followed, so the averages assume a constant speed on a shaft that may wander by a percent or two, which smears a fault over the revolution: they cannot clear the machine; give the shaft speed or a tachometer channel".to_string()
    })
}

/// Height over its band (dB) of a tracked mesh line under which it does not confirm a given speed that the
/// mesh comb did not confirm: the phase-locked tracking held the true line on every generated recording
/// whose line stood 10.6 dB or more, and on the hold-out machines lines of 6.1-7.7 dB were a neighbouring
/// line 1-1.8 % off the true speed.
const FOLLOWED_LINE_DB: f64 = 10.0;

/// A mesh-phase angle `map` (mesh order `z`) refined by lining the revolutions of `x` up with their average
/// ([`angle::refine`]) when that averages more of the signal coherently (by [`angle::MIN_GAIN`] or more in
/// RMS), and the gain; `map` itself and `None` otherwise. The followed line's phase noise grows with the mesh harmonic, and a
/// housing resonance far above the mesh puts the vibration at harmonics 10-40: on the 18/31 generated
/// machine at 15 Hz (tests/unseen_machines.rs) the averages on the tracked angle held a quarter of the RMS
/// the tachometer's give, and a 25 % pinion crack's M6A fell from 1336 to 7.5; refined, 1305.
fn refine_by_average(x: &[f32], map: AngleMap, z: usize) -> (AngleMap, Option<f64>) {
    match angle::refine(x, &map, z) {
        Some(r) => (r.map, Some(r.gain)),
        None => (map, None),
    }
}

/// Why the averages on a given speed cannot clear the machine: the given speed's mesh comb was not found
/// (its height over the spectrum `comb_db`, dB, when it was sought and not found) and the tracking did not follow the mesh line, so the averages run on the
/// nameplate speed as given, which a motor's slip puts up to the speed tolerance off, on a shaft that may
/// wander: a fault is smeared over the revolution there (on generated machines of another physics, 20 of the
/// 38 faults called healthy this way ran on a speed over 0.5 % off). Likewise a followed line that runs
/// through the given speed with its mean beyond the tolerance (`ramp_off`: a run-up or coast-down,
/// [`tracking::passes_through`]) without the comb's confirmation: a cracked pinion coasting from 30 to
/// 26.4 Hz, given 2000 rpm, had its mesh's fifth harmonic followed for the fourth (the speed 5/4 of the
/// true one) and was called healthy.
fn unconfirmed_speed(comb_db: Option<f64>, profile: &SpeedProfile, o: &Options, ramp_off: bool) -> Option<String> {
    let db = comb_db?;
    match (profile.tracking, profile.line_snr_db) {
        (Tracking::Constant, _) => {}
        (Tracking::MeshPhase, _) if ramp_off => {
            return Some(format!(
                "the given speed was not confirmed: its mesh comb stands only {db:.1} dB over the spectrum, and the line followed runs through the given speed with a mean beyond the +-{:.1} % tolerance, as a run-up or coast-down does, and as a mesh harmonic followed for another does; give a tachometer channel or the measured speed",
                100.0 * o.speed_tolerance
            ));
        }
        (Tracking::MeshPhase, Some(line)) if line < FOLLOWED_LINE_DB => {
            return Some(format!(
                "the given speed was not confirmed: its mesh comb stands only {db:.1} dB over the spectrum and the line followed stands only {line:.1} dB over its band (under {FOLLOWED_LINE_DB} dB), where the tracking can follow a neighbouring line; give a tachometer channel or the measured speed"
            ));
        }
        _ => return None,
    }
    let comb = if db.is_finite() {
        format!("its mesh comb stands only {db:.1} dB over the spectrum")
    } else {
        "its mesh comb could not be measured".to_string()
    };
    Some(format!(
        "the given speed was not confirmed: {comb} and the mesh line could not be followed, so the averages run on the given speed as it is, which a motor's slip can put up to {:.1} % off; give a tachometer channel or the measured speed",
        100.0 * o.speed_tolerance
    ))
}

/// Why averages on a given speed without the teeth cannot clear the machine: the mesh order (`tracked_z`)
/// was only the strongest harmonic family of the average (no teeth given, none from a baseline: `known_z`
/// is `None`) and its line could not be followed, so nothing shows that the averages hold a gear at all.
/// Pure noise at 10 kHz with `--rpm 1800` took a family of order 49 standing 5.5 dB over its band and was
/// called healthy.
fn no_mesh_found(
    known_z: Option<usize>,
    tracked_z: Option<usize>,
    profile: &SpeedProfile,
    o: &Options,
) -> Option<String> {
    let z = tracked_z?;
    (o.shaft_hz.is_some() && o.tacho_channel.is_none() && known_z.is_none() && profile.tracking == Tracking::Constant)
        .then(|| {
            format!(
                "no tooth mesh stands out at the given speed: the mesh order {z} is only the strongest harmonic family of the average and its line could not be followed, so the averages may hold no gear and cannot clear the machine; give the teeth (or a tachometer channel)"
            )
        })
}

/// Largest relative distance of an estimated mesh frequency from a multiple of the mains frequency for it
/// to be taken for hum: grids hold 50 or 60 Hz within about 0.05 Hz (0.1 %).
const MAINS_MATCH: f64 = 1e-3;

/// Largest fluctuation (fraction) of a tracked speed that a mains line shows: hum follows the grid, steady
/// to 1e-4 over seconds, while a machine's shaft wanders by 0.5-2 % (a mesh line taken for the mesh on
/// generated machines of another physics fluctuated 0.01-0.08 %).
const MAINS_STEADY: f64 = 1e-3;

/// The mains frequency (50 or 60 Hz) whose first or second harmonic `mesh_hz` lies on within
/// [`MAINS_MATCH`], the strongest hum lines (see [`on_mains`] for why only those two).
pub(in crate::jobs::diagnose) fn mains_of(mesh_hz: f64) -> Option<f64> {
    [50.0, 60.0].into_iter().find(|&f: &f64| {
        let k = (mesh_hz / f).round();
        (1.0..=2.0).contains(&k) && (mesh_hz / (k * f) - 1.0).abs() <= MAINS_MATCH
    })
}

/// Why a speed estimated from the teeth may be hum: the pinion's mesh (`zp` times the shaft's `shaft_hz`)
/// lies on 50 or 60 Hz or its second harmonic (the strongest hum lines) and is as steady as the grid. Only
/// those two: a machine at a synchronous speed (1500 or 1800 rpm, a drive set to 25 or 30 Hz) puts its mesh
/// on a higher mains harmonic whenever the pinion has an even number of teeth (the bundled 14-tooth pinion
/// at 30 Hz meshes at 420 Hz, 7 x 60), while a mesh at 50-120 Hz needs a pinion under 10 Hz.
fn on_mains(zp: usize, shaft_hz: f64, speeds: &angle::SpeedProfile) -> Option<String> {
    let mesh = zp as f64 * shaft_hz;
    let mains = mains_of(mesh)?;
    (speeds.wander <= MAINS_STEADY).then(|| {
        format!(
            "the mesh found ({mesh:.2} Hz, {zp} x {shaft_hz:.3} Hz) lies on a harmonic of the {mains:.0} Hz mains and is as steady as the grid: it may be hum taken for the mesh, so averages on that speed cannot clear the machine; give the shaft speed or a tachometer channel"
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The second start is kept on a line 3 dB clearer, or on a line where the first followed none; where
    /// neither followed a line, only as its kind says (-inf once compared as high as -inf plus the margin,
    /// so the weak comb's best replaced a given speed on nothing).
    #[test]
    fn a_second_start_on_no_line_is_kept_only_as_its_kind_says() {
        let none = f64::NEG_INFINITY;
        assert!(second_start_kept(12.0, 15.5, false));
        assert!(!second_start_kept(12.0, 14.0, false));
        assert!(second_start_kept(none, 8.0, false));
        assert!(!second_start_kept(8.0, none, true));
        assert!(!second_start_kept(none, none, false));
        assert!(second_start_kept(none, none, true));
    }

    fn steady(wander: f64) -> angle::SpeedProfile {
        angle::SpeedProfile { mean: 1e-3, min: 1e-3, max: 1e-3, change: 0.0, wander }
    }

    /// A mesh on 50 or 60 Hz or its second harmonic within 0.1 % and steadier than 0.1 % is doubted; a
    /// wandering one, one off by more, and a synchronous machine's mesh on a higher harmonic are not.
    #[test]
    fn hum_is_told_by_its_frequency_and_steadiness() {
        // 13 teeth x 4.6154 Hz = 60.0 Hz (the first harmonic of 60 Hz)
        assert!(on_mains(13, 60.0 / 13.0, &steady(2e-4)).is_some());
        // 20 teeth x 5 Hz = 100 Hz (the second harmonic of 50 Hz), 0.05 % off
        assert!(on_mains(20, 5.0025, &steady(0.0)).is_some());
        // 0.2 % off the mains line: the grid does not wander that far
        assert!(on_mains(13, 1.002 * 60.0 / 13.0, &steady(0.0)).is_none());
        // on the line but wandering by 1 %, as a machine's shaft does
        assert!(on_mains(13, 60.0 / 13.0, &steady(0.01)).is_none());
        // a 14-tooth pinion at a synchronous 30 Hz meshes at 420 Hz = 7 x 60 Hz: not hum
        assert!(on_mains(14, 30.0, &steady(0.0)).is_none());
    }
}
