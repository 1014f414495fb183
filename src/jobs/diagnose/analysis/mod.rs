//! The analysis of one recording, in named stages, each returning what the next needs:
//! 1. *read*: the channel roles and the checks of the data ([`check_recording`]);
//! 2. *track*: the shaft's angle from one source and the speed it implies ([`shaft::follow_shaft`]);
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
mod shaft;
mod sync;

pub(super) use evidence::mesh_harmonics;
pub(super) use indicators::*;
use shaft::follow_shaft;
pub(super) use shaft::{ShaftAngle, mains_of};

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
                || average(&rec, &checked.channels, o, &plan, &shaft.map).map_err(|e| unaveraged(path, &shaft, e)),
                || evidence::spectra(path, &rec, &checked, o, geometry, &shaft, z, &mut Fft::new()),
            );
            (a?, Some(s))
        }
        None => {
            (average(&rec, &checked.channels, o, &plan, &shaft.map).map_err(|e| unaveraged(path, &shaft, e))?, None)
        }
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

/// What the teeth scan found: the given wheel teeth's check, or a note on the meshing gear's estimated
/// teeth and the estimate when confident.
pub(super) type TeethScan = (Option<WheelCheck>, Option<OtherGear>);

/// The given wheel teeth checked, or the meshing gear's estimated, from the sidebands on the tracked angle
/// of the first channel `x` (`z`: the tracked shaft's mesh order).
fn teeth_scan(x: &[f32], map: &AngleMap, o: &Options, z: usize) -> TeethScan {
    match o.teeth {
        // a machine's stages are given whole: no pair's wheel to check
        Some(_) if o.machine.is_some() => (None, None),
        Some((_, zw)) => (wheel_teeth(x, map, z, zw), None),
        None => {
            let other = other_gear_teeth(x, map, z);
            let note = WheelCheck::Unchecked(other_gear_note(z, other.as_ref()));
            (Some(note), other.filter(|g| g.confidence >= MIN_OTHER_GEAR_CONFIDENCE))
        }
    }
}

/// The warning that an estimated mesh order `z` may be `2z`, its odd harmonics `db` (negative) under its
/// even ones.
fn doubled_note(z: usize, db: f64) -> String {
    format!(
        "the estimated mesh order {z} may be {}: the odd harmonics of {z} stand {:.0} dB under its even ones, which the family {} alone explains; the teeth would decide",
        2 * z,
        -db,
        2 * z
    )
}

/// Average stage: the TSAs of every channel, gear by gear (each in parallel runs of blocks, the channels
/// sharing the angle's interpolation); each block's indicators as the block completes when the gear's mesh
/// order is known (else the block is kept until the TSAs give it); beside them the teeth scan when the
/// first gear's mesh order is known already.
fn average(
    rec: &Recording,
    channels: &[usize],
    o: &Options,
    plan: &GearPlan,
    map: &AngleMap,
) -> Result<Averages, crate::signal::SignalError> {
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
                    tsa::tsa_with_blocks(&views, map, ratio, plan.points, o.min_revolutions, o.block_revs(), on_block)?;
                out.extend(channels.iter().zip(per_channel).map(|(&c, (t, blocks))| (c, gi, t, blocks)));
            }
            Ok::<_, crate::signal::SignalError>(out)
        },
        || plan.gears[0].2.map(|z| teeth_scan(&rec.channels[channels[0] - 1], map, o, z)),
    );
    Ok(Averages { tsas: tsas?, early_scan })
}

/// An estimated speed whose averages cannot be taken (the angle followed on it covers too few revolutions:
/// a generated 18/31 machine's teeth-only estimate of 0.93 Hz, its true 15 Hz, was followed over 5 of the
/// 8 revolutions needed) is the estimate's failure, not the file's: said as a missing speed, with what
/// would supply it. Other sources' errors are as they were.
fn unaveraged(path: &Path, shaft: &ShaftAngle, e: crate::signal::SignalError) -> Error {
    if shaft.source != SpeedSource::Estimated {
        return bad(path, e);
    }
    let speed = shaft
        .profile
        .mean_hz
        .map_or(format!("a revolution of {:.1} samples", shaft.period), |hz| format!("{hz:.4} Hz"));
    JobError::Missing {
        file: path.display().to_string(),
        message: format!(
            "the shaft speed estimated from the signal ({speed}, confidence {:.2}) gives no averages ({e}): give the shaft speed or a tachometer channel",
            shaft.confidence
        ),
        give: Given::ShaftSpeed,
    }
    .into()
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
    /// Why the given wheel teeth do not fit the wheel's sidebands, when they do not.
    pub wheel_misfit: Option<String>,
    /// The gears whose averages put their mesh family elsewhere than the given teeth ([`teeth_misfit`]).
    pub teeth_misfit: Vec<Shaft>,
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
    let mut teeth_misfit = Vec::new();
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
        if teeth_source == TeethSource::Estimated {
            warnings.extend(doubled_family(fft, averages(), z).map(|db| doubled_note(z, db)));
        }
        check_mesh_order(path, z, plan.points, *name, shaft.source)?;
        if check_teeth(path, checked.tacho, o, *name, z, averages, warnings)? {
            teeth_misfit.push(*name);
        }
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
    warnings.extend(wheel_warning.as_ref().map(|w| w.text().to_string()));
    let wheel_misfit = match wheel_warning {
        Some(WheelCheck::Misfit { text, ratio }) if ratio >= WHEEL_DOUBT_RATIO => Some(text),
        _ => None,
    };
    Ok(GearResults { gears, mesh_orders, teeth_source, other_gear, wheel_misfit, teeth_misfit })
}

/// The checks of a gear's mesh order `z` against the tachometer's pulses per revolution (an error) and
/// against the given teeth (warnings), on the gear's averages: whether the given teeth do not fit them.
fn check_teeth<'t, I: Iterator<Item = &'t [f64]>>(
    path: &Path,
    tacho: Option<usize>,
    o: &Options,
    name: Shaft,
    z: usize,
    averages: impl Fn() -> I,
    warnings: &mut Vec<String>,
) -> Result<bool, Error> {
    if let (Some(t), Some(_), Shaft::Pinion) = (tacho, o.teeth, name) {
        if let Some(found) = teeth::pulses_misfit(averages(), z) {
            return Err(bad(
                path,
                format!(
                    "tachometer channel {t}: with {} pulse(s) per revolution the mesh line of {z} teeth stands at order {found} of the pinion's average, not {z}: check the pulses per revolution, the tachometer's pulses and that the teeth (or a profile's) are this machine's",
                    o.pulses_per_rev
                ),
            ));
        }
    }
    let mut misfit = false;
    if o.teeth.is_some() && o.machine.is_none() {
        if let Some(w) = teeth_misfit(averages(), z, name) {
            warnings.push(w);
            misfit = true;
        }
    }
    if let (Some((zp, zw)), Shaft::Wheel) = (o.teeth, name) {
        if zp == zw {
            warnings.push(format!(
                "teeth {zp},{zw}: with equal teeth the gears turn together, so their averages are the same signal and a fault cannot be told to be on the pinion or the wheel; check the teeth"
            ));
        }
    }
    Ok(misfit)
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
    let GearResults { gears, mesh_orders, teeth_source, other_gear, wheel_misfit, teeth_misfit } = results;
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
        // given wheel teeth the sidebands contradict: the teeth or the speed the averages rest on are wrong
        speed_doubt: shaft.doubt.clone().or_else(|| {
            wheel_misfit.map(|why| {
                format!(
                    "{why}: with wrong teeth or a wrong speed the averages hold no gear, so they cannot clear the machine"
                )
            })
        }),
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
        long_scores: Vec::new(),
        baseline_same_load: false,
        local_change: Vec::new(),
        warnings,
        spectra,
        baseline_spectra: Vec::new(),
        baseline_tsas: Vec::new(),
        order_map: None,
        machine: None,
        teeth_misfit,
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
