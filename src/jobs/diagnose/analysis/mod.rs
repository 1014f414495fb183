//! The analysis of one recording, in named stages, each returning what the next needs:
//! 1. *read*: the channel roles and the checks of the data ([`check_recording`]);
//! 2. *track*: the shaft's angle from one source and the speed it implies ([`follow_shaft`]);
//! 3. *average*: the gears to average and their time-synchronous averages, whole and in blocks ([`plan_gears`],
//!    [`average`]);
//! 4. *indicators*: each gear's mesh order, teeth checks and condition indicators ([`gear_results`]);
//! 5. *evidence*: the deciding channel's spectra, mesh harmonics, envelope, cepstrum and order map
//!    ([`evidence::spectra`], [`evidence::beyond_averages`]).
//!
//! The verdict is the caller's (`finish` in the module above), once a baseline or limits are at hand.

use super::*;

mod evidence;
mod indicators;

pub(super) use evidence::mesh_harmonics;
pub(super) use indicators::*;

/// Diagnosis of a recording already read (channels checked here): the whole pipeline for one file.
pub(super) fn analyse(
    path: &Path,
    rec: Recording,
    o: &Options,
    geometry: Option<&Geometry>,
) -> Result<Diagnosis, Error> {
    analyse_parts(path, rec, o, geometry).map(|a| a.diagnosis)
}

/// What [`analyse_parts`] leaves besides the diagnosis, for a machine's further stages: the tracked angle
/// and the deciding channel's samples.
pub(super) struct Analysed<'a> {
    pub diagnosis: Diagnosis,
    pub map: AngleMap,
    pub deciding: std::borrow::Cow<'a, [f32]>,
}

/// [`analyse`], keeping the tracked angle and the deciding channel.
pub(super) fn analyse_parts<'a>(
    path: &Path,
    mut rec: Recording<'a>,
    o: &Options,
    geometry: Option<&Geometry>,
) -> Result<Analysed<'a>, Error> {
    let mut warnings = std::mem::take(&mut rec.warnings);
    let checked = check_recording(path, &rec, o, &mut warnings)?;
    // an undeclared tachometer the checks took (a pulse train whose rate is the pinion's) gives the speed
    let adopted;
    let o = if checked.tacho == o.tacho_channel {
        o
    } else {
        adopted = Options { tacho_channel: checked.tacho, ..o.clone() };
        &adopted
    };
    let mut fft = Fft::new();
    let shaft = follow_shaft(path, &mut rec, &checked, o, geometry, &mut fft, &mut warnings)?;
    let plan = plan_gears(path, o, geometry, &shaft)?;
    // the deciding channel's spectra beside the averages when its mesh order is known and the recording is
    // short enough for both to hold their buffers at once
    let early =
        plan.gears[0].2.filter(|_| checked.samples.saturating_mul(checked.channels.len()) <= CONCURRENT_SAMPLES);
    let (averages, early_spectra) = match early {
        Some(z) => {
            let (a, s) = rayon::join(
                || average(path, &rec, &checked.channels, o, &plan, &shaft.map),
                || evidence::spectra(path, &rec, &checked, o, geometry, &shaft, z, &mut Fft::new()),
            );
            (a?, Some(s))
        }
        None => (average(path, &rec, &checked.channels, o, &plan, &shaft.map)?, None),
    };
    let results = gear_results(path, &rec, &checked, o, geometry, &plan, &shaft, averages, &mut fft, &mut warnings)?;
    let first = checked.channels[0];
    // the TSAs and the teeth scan are done: unless their spectra are asked for, the other channels'
    // samples are freed before the spectra's and the envelope's record-long buffers are allocated
    if !o.all_spectra {
        free_other_channels(&mut rec, &checked.channels, first);
    }
    let spectra = match early_spectra {
        Some(s) => s?,
        None => evidence::spectra(path, &rec, &checked, o, geometry, &shaft, results.mesh_orders[0], &mut fft)?,
    };
    // only the deciding channel is read from here on (envelope, cepstrum, rpm-order map)
    free_other_channels(&mut rec, &checked.channels, first);
    let mut spectra = spectra;
    let amplitude = std::mem::take(&mut spectra.amplitude);
    let mut d = diagnosis(path, &rec, checked, o, &plan, &shaft, results, amplitude, warnings);
    d.mesh_harmonics = mesh_harmonics(&d, first, &plan.ratios());
    evidence::beyond_averages(path, &mut d, &rec.channels[first - 1], o, &shaft, &plan, spectra, &mut fft)?;
    let deciding = std::mem::take(&mut rec.channels[first - 1]);
    Ok(Analysed { diagnosis: d, map: shaft.map, deciding })
}

/// Most samples (over the analysed channels) for which the deciding channel's spectra run beside the
/// averages: 2^25 samples are 128 MB of the recording, which the spectra's buffers (about as large as one
/// channel) add to; a longer recording takes the stages one after the other, its other channels freed first.
const CONCURRENT_SAMPLES: usize = 1 << 25;

/// Track stage: the shaft's angle from one source, where it came from, and the speed it implies.
pub(super) struct ShaftAngle {
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
    fn reference(&self) -> Shaft {
        if self.source == SpeedSource::Estimated { Shaft::Estimated } else { Shaft::Pinion }
    }
}

/// Track stage: the nominal speed (given, tachometer, or estimated), then the angle followed on the mesh
/// line; a given speed's deviation from the measured one is warned about.
#[allow(clippy::too_many_arguments)]
fn follow_shaft(
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
    let mesh_from_lag = nominal.mesh_order.is_some();
    let (map, tracking, line_snr_db, tracked_z) = match nominal.alternative {
        None => track(path, rec, channels, o, known_z, nominal.map, warnings)?,
        Some(alt) => {
            // two starts (the given speed, the weak comb's best): the comb's when its followed line stands
            // clearly higher
            let mut given_warnings = Vec::new();
            let first = track(path, rec, channels, o, known_z, nominal.map, &mut given_warnings)?;
            let mut alt_warnings = Vec::new();
            let second = track(path, rec, channels, o, known_z, alt, &mut alt_warnings)?;
            let line = |t: &Tracked| t.2.filter(|_| t.1 == Tracking::MeshPhase).unwrap_or(f64::NEG_INFINITY);
            if line(&second) >= line(&first) + CLEARER_START_DB {
                warnings.extend(alt_warnings);
                warnings.push(format!(
                    "the tracking from the comb's best speed followed a line {:.1} dB over its band, the one from the given speed {}: the comb's start is kept",
                    line(&second),
                    if line(&first).is_finite() { format!("{:.1} dB", line(&first)) } else { "none".into() }
                ));
                second
            } else {
                warnings.extend(given_warnings);
                first
            }
        }
    };
    // the tachometer's pulses are in the angle map now and are never analysed: free them
    if let Some(t) = tacho {
        rec.channels[t - 1] = std::borrow::Cow::Borrowed(&[]);
    }
    let speeds = angle::SpeedProfile::of(&map);
    // a given speed is a nominal one: what was measured (mesh comb and tracking, or the tachometer) is used,
    // and its deviation from the given speed reported
    let given = o.shaft_hz.zip(fs).map(|(hz, fs)| (hz, 100.0 * (speeds.mean * fs / hz - 1.0)));
    if let Some((hz, off)) = given {
        let measured = speeds.mean * fs.unwrap_or(0.0);
        if off.abs() > 100.0 * o.speed_tolerance {
            warnings.push(format!(
                "the given speed {hz:.4} Hz is {off:+.2} % from the measured {measured:.4} Hz ({tracking}), beyond the +-{:.1} % tolerance: check the given speed",
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
    };
    let doubt = nominal
        .doubt
        .or_else(|| unconfirmed_speed(nominal.unconfirmed_comb_db, &profile, o))
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

/// How much higher (dB) the line followed from a weak comb's best speed must stand than the one followed
/// from the given speed for the comb's start to be kept: lines of 6-7 dB differ by a dB between two
/// starts on the same line (a 31/47 pinion spall's 6.1 and 6.8 dB, where the comb's start smeared the
/// pinion's FM4 from 22.8 to 3.7), while a line and its neighbour differ by several.
const CLEARER_START_DB: f64 = 3.0;

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

/// Why the averages on a given speed cannot clear the machine: the given speed's mesh comb was not found
/// (its height over the spectrum `comb_db`, dB, when it was sought and not found) and the tracking did not follow the mesh line, so the averages run on the
/// nameplate speed as given, which a motor's slip puts up to the speed tolerance off, on a shaft that may
/// wander: a fault is smeared over the revolution there (on generated machines of another physics, 20 of the
/// 38 faults called healthy this way ran on a speed over 0.5 % off).
fn unconfirmed_speed(comb_db: Option<f64>, profile: &SpeedProfile, o: &Options) -> Option<String> {
    let db = comb_db?;
    match (profile.tracking, profile.line_snr_db) {
        (Tracking::Constant, _) => {}
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

/// Average stage, its plan: the gears (shafts) to average, with their speed ratios to the tracked shaft and
/// mesh orders where known, and the averages' length.
pub(super) struct GearPlan {
    /// (shaft, speed over the tracked shaft's, mesh order when known).
    pub gears: Vec<(Shaft, f64, Option<usize>)>,
    /// With a machine: each averaged shaft's other lines.
    pub machine_shafts: Option<Vec<super::machine::AveragedShaft>>,
    /// Points per revolution of every average.
    pub points: usize,
}

impl GearPlan {
    /// Each gear's shaft and speed ratio.
    fn ratios(&self) -> Vec<(Shaft, f64)> {
        self.gears.iter().map(|g| (g.0, g.1)).collect()
    }

    /// The lines besides its mesh of the `gi`-th gear's shaft (none on a single pair).
    fn others(&self, gi: usize) -> &OtherLines {
        static NONE: OtherLines = OtherLines { mesh: Vec::new(), foreign: Vec::new() };
        self.machine_shafts.as_ref().map_or(&NONE, |ms| &ms[gi].others)
    }
}

/// Average stage: which gears are averaged, and their length. The baseline's averaging length when there
/// is one: the recording under test is averaged exactly as the baseline was (a revolution of 1023.9 and
/// one of 1024.1 samples would otherwise round to averages of 1024 and 2048 points, whose blocks cannot be
/// compared).
fn plan_gears(path: &Path, o: &Options, geometry: Option<&Geometry>, shaft: &ShaftAngle) -> Result<GearPlan, Error> {
    let points = geometry.and_then(|g| g.tsa_points).unwrap_or_else(|| tsa_points(shaft.period));
    // with a machine: every shaft with a gear whose mesh is a whole order of it, the tracked shaft first,
    // each with the mesh orders of its other gears (removed from its regular signal too)
    let machine_shafts = o.machine.as_ref().map(|m| super::machine::averaged_shafts(m.machine(), o));
    let gears: Vec<(Shaft, f64, Option<usize>)> = match (&machine_shafts, o.teeth) {
        (Some(ms), _) => ms.iter().map(|s| (s.shaft, s.ratio, Some(s.mesh_orders[0]))).collect(),
        (None, Some((zp, zw))) => {
            vec![(Shaft::Pinion, 1.0, Some(zp)), (Shaft::Wheel, zp as f64 / zw as f64, Some(zw))]
        }
        (None, None) => vec![(shaft.reference(), 1.0, geometry.and_then(|g| g.mesh_order).or(shaft.tracked_z))],
    };
    // a mesh order known now must fit the averages' resolution before their blocks are scored
    for &(name, _, z) in &gears {
        if let Some(z) = z {
            check_mesh_order(path, z, points, name, shaft.source)?;
        }
    }
    Ok(GearPlan { gears, machine_shafts, points })
}

/// Average stage, its result: every channel's average of every gear with its blocks, and the teeth scan
/// when it could run beside them.
pub(super) struct Averages {
    /// (channel, gear index in the plan, average, blocks).
    pub tsas: Vec<(usize, usize, tsa::Tsa, Vec<PendingBlock>)>,
    /// The teeth scan of the first gear, when its mesh order was known before averaging.
    pub early_scan: Option<TeethScan>,
}

/// What the teeth scan found: a warning on the given wheel teeth, or a note on the meshing gear's estimated
/// teeth and the estimate when confident.
pub(super) type TeethScan = (Option<String>, Option<OtherGear>);

/// The given wheel teeth checked, or the meshing gear's estimated, from the sidebands on the tracked angle
/// of the first channel `x` (`z`: the tracked shaft's mesh order).
fn teeth_scan(x: &[f32], map: &AngleMap, o: &Options, z: usize) -> TeethScan {
    match o.teeth {
        // a machine's stages are given whole: no pair's wheel to check
        Some(_) if o.machine.is_some() => (None, None),
        Some((_, zw)) => (wheel_teeth(x, map, z, zw), None),
        None => {
            let other = other_gear_teeth(x, map, z);
            (Some(other_gear_note(z, other.as_ref())), other.filter(|g| g.confidence >= MIN_OTHER_GEAR_CONFIDENCE))
        }
    }
}

/// Average stage: the TSAs of every channel, gear by gear (each in parallel runs of blocks, the channels
/// sharing the angle's interpolation); each block's indicators as the block completes when the gear's mesh
/// order is known (else the block is kept until the TSAs give it); beside them the teeth scan when the
/// first gear's mesh order is known already.
fn average(
    path: &Path,
    rec: &Recording,
    channels: &[usize],
    o: &Options,
    plan: &GearPlan,
    map: &AngleMap,
) -> Result<Averages, Error> {
    let views: Vec<&[f32]> = channels.iter().map(|&c| &*rec.channels[c - 1]).collect();
    let (tsas, early_scan) = rayon::join(
        || {
            let mut out = Vec::new();
            for (gi, &(_, ratio, z)) in plan.gears.iter().enumerate() {
                let on_block = |fft: &mut Fft, _: usize, i: usize, b: &[f64]| match z {
                    Some(z) => PendingBlock::Done(block_indicators(
                        fft,
                        b,
                        z,
                        plan.others(gi),
                        o.shaft_orders,
                        keeps_spectrum(o, i),
                    )),
                    None => PendingBlock::Raw(b.to_vec()),
                };
                let per_channel =
                    tsa::tsa_with_blocks(&views, map, ratio, plan.points, o.min_revolutions, o.block_revs(), on_block)
                        .map_err(|e| bad(path, e))?;
                out.extend(channels.iter().zip(per_channel).map(|(&c, (t, blocks))| (c, gi, t, blocks)));
            }
            Ok::<_, Error>(out)
        },
        || plan.gears[0].2.map(|z| teeth_scan(&rec.channels[channels[0] - 1], map, o, z)),
    );
    Ok(Averages { tsas: tsas?, early_scan })
}

/// Indicators stage, its result: each gear's indicators, the mesh orders, where the teeth came from, and
/// what the teeth scan found.
pub(super) struct GearResults {
    /// Indicators per gear and channel (with their blocks).
    pub gears: Vec<GearIndicators>,
    /// Mesh order of each gear of the plan.
    pub mesh_orders: Vec<usize>,
    /// Where the teeth came from.
    pub teeth_source: TeethSource,
    /// The meshing gear's teeth estimated from its sidebands.
    pub other_gear: Option<OtherGear>,
}

/// Indicators stage: each gear's mesh order (given, the baseline's, or from its averages), its checks
/// against the tachometer and the given teeth, and the indicators of its averages and their blocks; the
/// teeth scan beside them when it waited for the mesh order.
#[allow(clippy::too_many_arguments)]
fn gear_results(
    path: &Path,
    rec: &Recording,
    checked: &Checked,
    o: &Options,
    geometry: Option<&Geometry>,
    plan: &GearPlan,
    shaft: &ShaftAngle,
    averages: Averages,
    fft: &mut Fft,
    warnings: &mut Vec<String>,
) -> Result<GearResults, Error> {
    let Averages { tsas, early_scan } = averages;
    let (tsas, mut block_lists): (Vec<_>, Vec<_>) = tsas.into_iter().map(|(c, gi, t, b)| ((c, gi, t), b)).unzip();
    let mut teeth_source = match (o.teeth, geometry.and_then(|g| g.mesh_order)) {
        (Some(_), _) => TeethSource::Given,
        (None, Some(_)) => TeethSource::Baseline,
        (None, None) => TeethSource::Estimated,
    };
    if teeth_source == TeethSource::Estimated && shaft.tracked_z.is_some() {
        warnings.push(format!(
            "mesh order {} estimated ({}); give the teeth when known",
            shaft.tracked_z.unwrap_or(0),
            if shaft.mesh_from_lag {
                "repetition period over the mesh period"
            } else {
                "strongest harmonic family of the TSA spectrum"
            }
        ));
    }
    let mut pending = Vec::new();
    let mut mesh_orders = Vec::new();
    for (gi, (name, _, known)) in plan.gears.iter().enumerate() {
        let averages = || tsas.iter().filter(move |t| t.1 == gi).map(|t| t.2.samples.as_slice());
        let z = match known {
            Some(z) => *z,
            None => {
                let z = mesh_family(fft, averages());
                teeth_source = TeethSource::Estimated;
                warnings.push(format!(
                    "mesh order {z} estimated from the strongest harmonic family of the TSA spectrum; give the teeth when known"
                ));
                z
            }
        };
        check_mesh_order(path, z, plan.points, *name, shaft.source)?;
        check_teeth(path, checked.tacho, o, *name, z, averages, warnings)?;
        mesh_orders.push(z);
        for (i, (c, _, t)) in tsas.iter().enumerate().filter(|(_, t)| t.1 == gi) {
            pending.push((*name, *c, z, plan.others(gi), t, std::mem::take(&mut block_lists[i])));
        }
    }
    let first = checked.channels[0];
    let (gears, (wheel_warning, other_gear)) = rayon::join(
        || {
            pending
                .into_par_iter()
                .map(|(name, c, z, others, t, blocks)| {
                    let mut fft = Fft::new();
                    let mut g = gear_indicators(&mut fft, name, c, z, others, t, o.shaft_orders);
                    g.blocks = blocks
                        .into_iter()
                        .enumerate()
                        .map(|(i, b)| match b {
                            PendingBlock::Done(b) => b,
                            PendingBlock::Raw(b) => {
                                block_indicators(&mut fft, &b, z, others, o.shaft_orders, keeps_spectrum(o, i))
                            }
                        })
                        .collect();
                    g
                })
                .collect::<Vec<GearIndicators>>()
        },
        || early_scan.unwrap_or_else(|| teeth_scan(&rec.channels[first - 1], &shaft.map, o, mesh_orders[0])),
    );
    warnings.extend(wheel_warning);
    Ok(GearResults { gears, mesh_orders, teeth_source, other_gear })
}

/// The checks of a gear's mesh order `z` against the tachometer's pulses per revolution (an error) and
/// against the given teeth (warnings), on the gear's averages.
fn check_teeth<'t, I: Iterator<Item = &'t [f64]>>(
    path: &Path,
    tacho: Option<usize>,
    o: &Options,
    name: Shaft,
    z: usize,
    averages: impl Fn() -> I,
    warnings: &mut Vec<String>,
) -> Result<(), Error> {
    if let (Some(t), Some(_), Shaft::Pinion) = (tacho, o.teeth, name) {
        if let Some(found) = teeth::pulses_misfit(averages(), z) {
            return Err(bad(
                path,
                format!(
                    "tachometer channel {t}: with {} pulse(s) per revolution the mesh line of {z} teeth stands at order {found} of the pinion's average, not {z}: check the pulses per revolution and the tachometer's pulses",
                    o.pulses_per_rev
                ),
            ));
        }
    }
    if o.teeth.is_some() && o.machine.is_none() {
        if let Some(w) = teeth_misfit(averages(), z, name) {
            warnings.push(w);
        }
    }
    if let (Some((zp, zw)), Shaft::Wheel) = (o.teeth, name) {
        if zp == zw {
            warnings.push(format!(
                "teeth {zp},{zw}: with equal teeth the gears turn together, so their averages are the same signal and a fault cannot be told to be on the pinion or the wheel; check the teeth"
            ));
        }
    }
    Ok(())
}

/// The diagnosis of the stages so far (its verdict still to be judged, its envelope and cepstrum still to
/// come), with the amplitude spectra of the evidence stage.
#[allow(clippy::too_many_arguments)]
fn diagnosis(
    path: &Path,
    rec: &Recording,
    checked: Checked,
    o: &Options,
    plan: &GearPlan,
    shaft: &ShaftAngle,
    results: GearResults,
    spectra: Vec<(usize, crate::signal::Spectrum)>,
    warnings: Vec<String>,
) -> Diagnosis {
    let Checked { channels, moments, samples, fs, .. } = checked;
    let GearResults { gears, mesh_orders, teeth_source, other_gear } = results;
    let shaft_hz = fs.map(|fs| fs / shaft.period);
    let shafts = match (&plan.machine_shafts, o.teeth) {
        (Some(_), _) => super::machine::shaft_hz(o, shaft_hz),
        (None, Some((zp, zw))) => {
            ShaftHz::Pair { pinion: shaft_hz, wheel: shaft_hz.map(|f| f * zp as f64 / zw as f64) }
        }
        (None, None) if shaft.reference() == Shaft::Pinion => ShaftHz::Pinion { pinion: shaft_hz },
        (None, None) => ShaftHz::Estimated { estimated_shaft: shaft_hz },
    };
    Diagnosis {
        file: path.display().to_string(),
        sample_rate_hz: fs,
        samples,
        unit: rec.units.get(channels[0] - 1).cloned().unwrap_or_default(),
        channels,
        shaft_hz: shafts,
        shaft_period_samples: shaft.period,
        speed_source: shaft.source,
        speed_confidence: shaft.confidence,
        speed_doubt: shaft.doubt.clone(),
        spectrum_scale: Default::default(),
        speed_given_hz: shaft.given.map(|g| g.0),
        speed_deviation_percent: shaft.given.map(|g| g.1),
        speed_profile: shaft.profile,
        mesh_hz: shaft_hz.map(|f| f * mesh_orders[0] as f64),
        mesh_order: mesh_orders[0],
        teeth_source,
        other_gear,
        mesh_harmonics: Vec::new(),
        indicators: gears.first().map(|g| g.indicators.clone()).unwrap_or_default(),
        gears,
        raw: moments
            .iter()
            .map(|m| Indicators::from([(Indicator::Rms, m.rms), (Indicator::Kurtosis, m.kurtosis)]))
            .collect(),
        verdict: Verdict::new(VerdictState::Healthy, VerdictGear::None, Vec::new()),
        comparison: None,
        envelope: None,
        cepstrum: None,
        scores: Vec::new(),
        local_change: Vec::new(),
        warnings,
        spectra,
        baseline_spectra: Vec::new(),
        baseline_tsas: Vec::new(),
        order_map: None,
        machine: None,
    }
}

/// Frees the samples of every channel of `channels` but `keep` (the recording's raw statistics were taken
/// by the checks).
fn free_other_channels(rec: &mut Recording, channels: &[usize], keep: usize) {
    for &c in channels.iter().filter(|&&c| c != keep) {
        rec.channels[c - 1] = std::borrow::Cow::Borrowed(&[]);
    }
}

/// What the teeth scan said when the teeth were not given (z: the tracked shaft's mesh order).
fn other_gear_note(z: usize, other: Option<&OtherGear>) -> String {
    match other {
        Some(g) if g.confidence >= MIN_OTHER_GEAR_CONFIDENCE => format!(
            "teeth of the meshing gear estimated: {} (its +-1 sidebands at +-{:.4} orders of the tracked shaft stand {:.0} dB over their floor; confidence {:.2}): the tracked shaft carries the {} gear; give the teeth as {z},{} to analyse both gears",
            g.teeth,
            g.sideband_orders,
            g.line_over_floor_db,
            g.confidence,
            if g.teeth > z { "smaller" } else { "larger" },
            g.teeth
        ),
        Some(g) => format!(
            "the meshing gear's teeth were not estimated: the best count, {}, rests on weak or ambiguous sidebands ({:.0} dB over their floor, confidence {:.2} under {MIN_OTHER_GEAR_CONFIDENCE})",
            g.teeth, g.line_over_floor_db, g.confidence
        ),
        None => "the meshing gear's teeth were not estimated: no sidebands of another gear stand 12 dB over their floor (a true-running healthy gear shows none); give the teeth when known".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
