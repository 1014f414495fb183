//! The analysis of one recording: speed and tracking, the TSA of each gear, condition indicators over the
//! whole record and its blocks, spectra, mesh harmonics with their sidebands, envelope and cepstrum.

use super::*;

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
    let Checked { tacho, channels, moments, samples: n, fs } = check_recording(path, &rec, o, &mut warnings)?;
    let mut fft = Fft::new();
    let nominal = nominal_speed(path, &rec, &channels, o, fs, geometry, &mut fft, &mut warnings)?;
    let (source, confidence, speed_doubt) = (nominal.source, nominal.confidence, nominal.doubt.clone());
    let nominal_mesh_from_lag = nominal.mesh_order.is_some();
    let known_z = o.teeth.map(|t| t.0).or_else(|| geometry.and_then(|g| g.mesh_order)).or(nominal.mesh_order);
    let (map, tracking, line_snr_db, tracked_z) = track(path, &rec, &channels, o, known_z, nominal.map, &mut warnings)?;
    // the tachometer's pulses are in the angle map now and are never analysed: free them
    if let Some(t) = tacho {
        rec.channels[t - 1] = std::borrow::Cow::Borrowed(&[]);
    }
    let profile = angle::SpeedProfile::of(&map);
    // a given speed is a nominal one: what was measured (mesh comb and tracking, or the tachometer) is used,
    // and its deviation from the given speed reported
    let speed_given = o.shaft_hz.zip(fs).map(|(hz, fs)| (hz, 100.0 * (profile.mean * fs / hz - 1.0)));
    if let Some((hz, off)) = speed_given {
        if off.abs() > 100.0 * o.speed_tolerance {
            warnings.push(format!(
                "the given speed {hz:.4} Hz is {off:+.2} % from the measured {:.4} Hz ({}), beyond the +-{:.1} % tolerance: check the given speed",
                profile.mean * fs.unwrap_or(0.0),
                tracking,
                100.0 * o.speed_tolerance
            ));
        } else if off.abs() > 0.5 {
            warnings.push(format!(
                "the given speed {hz:.4} Hz is {off:+.2} % from the measured {:.4} Hz ({}): the measured speed is used (a nameplate speed is off by the motor's slip)",
                profile.mean * fs.unwrap_or(0.0),
                tracking
            ));
        }
    }
    let speed_profile = SpeedProfile {
        tracking,
        mean_hz: fs.map(|f| f * profile.mean),
        min_hz: fs.map(|f| f * profile.min),
        max_hz: fs.map(|f| f * profile.max),
        change_percent: 100.0 * profile.change,
        fluctuation_percent: 100.0 * profile.wander,
        line_snr_db,
    };
    let period = map.mean_period_samples();
    // the baseline's averaging length when there is one: the recording under test is averaged exactly as
    // the baseline was (a revolution of 1023.9 and one of 1024.1 samples would otherwise round to averages
    // of 1024 and 2048 points, whose blocks cannot be compared)
    let points = geometry.and_then(|g| g.tsa_points).unwrap_or_else(|| tsa_points(period));
    // ---- TSA of the reference shaft first (needed to find the mesh when teeth are unknown); a given or
    // measured speed is the pinion's, an estimated period belongs to a shaft nobody named
    let reference = if source == SpeedSource::Estimated { Shaft::Estimated } else { Shaft::Pinion };
    // with a machine: every shaft with a gear whose mesh is a whole order of it, the tracked shaft first,
    // each with the mesh orders of its other gears (removed from its regular signal too)
    let machine_shafts = o.machine.as_ref().map(|m| super::machine::averaged_shafts(m.machine(), o));
    let gears: Vec<(Shaft, f64, Option<usize>)> = match (&machine_shafts, o.teeth) {
        (Some(ms), _) => ms.iter().map(|s| (s.shaft, s.ratio, Some(s.mesh_orders[0]))).collect(),
        (None, Some((zp, zw))) => {
            vec![(Shaft::Pinion, 1.0, Some(zp)), (Shaft::Wheel, zp as f64 / zw as f64, Some(zw))]
        }
        (None, None) => vec![(reference, 1.0, geometry.and_then(|g| g.mesh_order).or(tracked_z))],
    };
    let none = OtherLines::default();
    let others = |gi: usize| machine_shafts.as_ref().map_or(&none, |ms| &ms[gi].others);
    // a mesh order known now must fit the averages' resolution before their blocks are scored
    for &(name, _, z) in &gears {
        if let Some(z) = z {
            check_mesh_order(path, z, points, name, source)?;
        }
    }
    // the TSAs of every channel, gear by gear (each in parallel runs of blocks, the channels sharing the
    // angle's interpolation); each block's indicators as the block completes when the gear's mesh order
    // is known (else the block is kept until the TSAs give it)
    let views: Vec<&[f32]> = channels.iter().map(|&c| &*rec.channels[c - 1]).collect();
    // the given wheel teeth checked, or the meshing gear's estimated, from the sidebands on the tracked
    // angle of the first channel: at the same time as the TSAs when the mesh order is known already
    let first = channels[0];
    let teeth_scan = |z: usize| match o.teeth {
        // a machine's stages are given whole: no pair's wheel to check
        Some(_) if o.machine.is_some() => (None, None),
        Some((_, zw)) => (wheel_teeth(&rec.channels[first - 1], &map, z, zw), None),
        None => {
            let other = other_gear_teeth(&rec.channels[first - 1], &map, z);
            (Some(other_gear_note(z, other.as_ref())), other.filter(|g| g.confidence >= MIN_OTHER_GEAR_CONFIDENCE))
        }
    };
    // the first blocks keep their residual's order spectrum when a baseline's change will be measured
    let keep = |i: usize| o.residual_spectra && i < SPECTRUM_BLOCKS;
    let (tsas, early_scan) = rayon::join(
        || {
            let mut out = Vec::new();
            for (gi, &(_, ratio, z)) in gears.iter().enumerate() {
                let on_block = |fft: &mut Fft, _: usize, i: usize, b: &[f64]| match z {
                    Some(z) => PendingBlock::Done(block_indicators(fft, b, z, others(gi), o.shaft_orders, keep(i))),
                    None => PendingBlock::Raw(b.to_vec()),
                };
                let per_channel =
                    tsa::tsa_with_blocks(&views, &map, ratio, points, o.min_revolutions, o.block_revs(), on_block)
                        .map_err(|e| bad(path, e))?;
                out.extend(channels.iter().zip(per_channel).map(|(&c, (t, blocks))| (c, gi, t, blocks)));
            }
            Ok::<_, Error>(out)
        },
        || gears[0].2.map(teeth_scan),
    );
    let tsas = tsas?;
    let (tsas, mut block_lists): (Vec<_>, Vec<_>) = tsas.into_iter().map(|(c, gi, t, b)| ((c, gi, t), b)).unzip();
    let mut teeth_source = match (o.teeth, geometry.and_then(|g| g.mesh_order)) {
        (Some(_), _) => TeethSource::Given,
        (None, Some(_)) => TeethSource::Baseline,
        (None, None) => TeethSource::Estimated,
    };
    if teeth_source == TeethSource::Estimated && tracked_z.is_some() {
        warnings.push(format!(
            "mesh order {} estimated ({}); give the teeth when known",
            tracked_z.unwrap_or(0),
            if nominal_mesh_from_lag {
                "repetition period over the mesh period"
            } else {
                "strongest harmonic family of the TSA spectrum"
            }
        ));
    }
    let mut pending = Vec::new();
    let mut mesh_orders = Vec::new();
    for (gi, (name, _, known)) in gears.iter().enumerate() {
        let z = match known {
            Some(z) => *z,
            None => {
                let z = mesh_family(&mut fft, tsas.iter().filter(|t| t.1 == gi).map(|t| t.2.samples.as_slice()));
                teeth_source = TeethSource::Estimated;
                warnings.push(format!(
                    "mesh order {z} estimated from the strongest harmonic family of the TSA spectrum; give the teeth when known"
                ));
                z
            }
        };
        check_mesh_order(path, z, points, *name, source)?;
        if let (Some(t), Some(_), Shaft::Pinion) = (tacho, o.teeth, *name) {
            let pinion = tsas.iter().filter(|t| t.1 == gi).map(|t| t.2.samples.as_slice());
            if let Some(found) = teeth::pulses_misfit(pinion, z) {
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
            if let Some(w) = teeth_misfit(tsas.iter().filter(|t| t.1 == gi).map(|t| t.2.samples.as_slice()), z, *name) {
                warnings.push(w);
            }
        }
        if let (Some((zp, zw)), Shaft::Wheel) = (o.teeth, *name) {
            if zp == zw {
                warnings.push(format!(
                    "teeth {zp},{zw}: with equal teeth the gears turn together, so their averages are the same signal and a fault cannot be told to be on the pinion or the wheel; check the teeth"
                ));
            }
        }
        mesh_orders.push(z);
        for (i, (c, _, t)) in tsas.iter().enumerate().filter(|(_, t)| t.1 == gi) {
            pending.push((*name, *c, z, others(gi), t, std::mem::take(&mut block_lists[i])));
        }
    }
    // ---- the gears' indicators, and at the same time the teeth scan when it waited for the mesh order;
    // then the spectra and mesh harmonics (deciding channel chosen later:
    // the first for now; its envelope band is chosen first, so that the amplitude spectrum's segments also
    // give its envelope)
    let shaft_hz = fs.map(|fs| fs / period);
    let ratios: Vec<(Shaft, f64)> = gears.iter().map(|g| (g.0, g.1)).collect();
    let choice =
        BandChoice { levels: o.kurtogram_levels, band: o.envelope_band.or(geometry.and_then(|g| g.envelope_band)) };
    let (gear_results, (wheel_warning, other_gear)) = rayon::join(
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
                            PendingBlock::Raw(b) => block_indicators(&mut fft, &b, z, others, o.shaft_orders, keep(i)),
                        })
                        .collect();
                    g
                })
                .collect::<Vec<GearIndicators>>()
        },
        || early_scan.unwrap_or_else(|| teeth_scan(mesh_orders[0])),
    );
    warnings.extend(wheel_warning);
    // the TSAs and the teeth scan are done: unless their spectra are asked for, the other channels'
    // samples are freed before the spectra's and the envelope's record-long buffers are allocated
    if !o.all_spectra {
        free_other_channels(&mut rec, &channels, first);
    }
    // the averages are in the indicators now: free them before the spectra's record-long buffers
    drop(tsas);
    let mut plan = match (fs, o.lifter) {
        (Some(fs), None) => Some(envelope_plan(&mut fft, &rec.channels[first - 1], fs, &map, mesh_orders[0], choice)),
        _ => None,
    };
    let ola = std::sync::Mutex::new(match &mut plan {
        Some(Ok((_, ola))) => ola.take(),
        _ => None,
    });
    // the deciding channel's spectra (its mesh harmonics, envelope and cepstrum); the others' only on request
    let spectrum_channels: Vec<usize> = channels.iter().copied().filter(|&c| c == first || o.all_spectra).collect();
    let spectra = match fs {
        Some(fs) => spectrum_channels
            .par_iter()
            .map(|&c| {
                let ola = if c == first { ola.lock().map(|mut o| o.take()).unwrap_or(None) } else { None };
                channel_spectra(&mut Fft::new(), &rec.channels[c - 1], fs, ola)
                    .map(|s| (c, s))
                    .map_err(|e| bad(path, e))
            })
            .collect::<Result<Vec<_>, Error>>()?,
        None => Vec::new(),
    };
    let raw = moments
        .iter()
        .map(|m| Indicators::from([(Indicator::Rms, m.rms), (Indicator::Kurtosis, m.kurtosis)]))
        .collect();
    // only the deciding channel is read from here on (envelope, cepstrum, rpm-order map)
    free_other_channels(&mut rec, &channels, first);
    let shafts = match (&machine_shafts, o.teeth) {
        (Some(_), _) => super::machine::shaft_hz(o, shaft_hz),
        (None, Some((zp, zw))) => {
            ShaftHz::Pair { pinion: shaft_hz, wheel: shaft_hz.map(|f| f * zp as f64 / zw as f64) }
        }
        (None, None) if reference == Shaft::Pinion => ShaftHz::Pinion { pinion: shaft_hz },
        (None, None) => ShaftHz::Estimated { estimated_shaft: shaft_hz },
    };
    let mut deciding = None;
    let spectra = spectra
        .into_iter()
        .map(|(c, s)| {
            if c == first {
                deciding = Some((s.power, s.segment, s.envelope));
            }
            (c, s.amplitude)
        })
        .collect();
    let mut d = Diagnosis {
        file: path.display().to_string(),
        sample_rate_hz: fs,
        samples: n,
        channels: channels.clone(),
        shaft_hz: shafts,
        shaft_period_samples: period,
        speed_source: source,
        speed_confidence: confidence,
        speed_doubt,
        spectrum_scale: Default::default(),
        speed_given_hz: speed_given.map(|g| g.0),
        speed_deviation_percent: speed_given.map(|g| g.1),
        speed_profile,
        mesh_hz: shaft_hz.map(|f| f * mesh_orders[0] as f64),
        mesh_order: mesh_orders[0],
        teeth_source,
        other_gear,
        mesh_harmonics: Vec::new(),
        indicators: BTreeMap::new(),
        gears: gear_results,
        raw,
        verdict: Verdict::new(VerdictState::Healthy, VerdictGear::None, Vec::new()),
        comparison: None,
        envelope: None,
        cepstrum: None,
        scores: Vec::new(),
        local_change: Vec::new(),
        unit: rec.units.get(channels[0] - 1).cloned().unwrap_or_default(),
        warnings,
        spectra,
        baseline_spectra: Vec::new(),
        baseline_tsas: Vec::new(),
        order_map: None,
        machine: None,
    };
    d.mesh_harmonics = mesh_harmonics(&d, channels[0], &ratios);
    if let Some(g) = d.gears.first() {
        d.indicators = g.indicators.clone();
    }
    if let Some(fs) = fs {
        let x = &rec.channels[first - 1];
        let result = match (o.lifter, plan) {
            (Some(shaft), _) => {
                let ratio = ratios.iter().find(|r| r.0 == shaft).map(|r| r.1).ok_or_else(|| {
                    bad(path, format!("cannot lifter the {shaft} family: give the teeth so that its speed is known"))
                })?;
                let y =
                    crate::signal::envelope::lifter_comb(&mut fft, x, period / ratio, 1).map_err(|e| bad(path, e))?;
                // the plan's overlap-add is for a spectrum pass over the recording, which the liftered
                // signal never gets: its envelope takes a pass of its own
                envelope_plan(&mut fft, &y, fs, &map, d.mesh_order, choice).and_then(|(band, _)| {
                    let (e, r) = envelope_of(&mut fft, &y, fs, &band, None)?;
                    Ok(envelope(&mut fft, band, &e, r, fs, &map, &ratios))
                })
            }
            (None, Some(Ok((band, _)))) => match deciding.as_ref().and_then(|s| s.2.as_ref()) {
                Some((e, r)) => Ok(envelope(&mut fft, band, e, *r, fs, &map, &ratios)),
                None => envelope_of(&mut fft, x, fs, &band, None)
                    .map(|(e, r)| envelope(&mut fft, band, &e, r, fs, &map, &ratios)),
            },
            (None, Some(Err(e))) => Err(e),
            (None, None) => unreachable!("a sample rate without a lifter always plans the envelope"),
        };
        match result.map(|mut e| {
            e.liftered = o.lifter;
            e
        }) {
            Ok(e) => d.envelope = Some(e),
            // a band or level the user asked for that does not fit is an error; the automatic choice
            // failing on a short recording is a warning
            Err(e) if o.envelope_band.is_some() || o.kurtogram_levels.is_some() => return Err(bad(path, e)),
            Err(e) => d.warnings.push(format!("no envelope analysis: {e}")),
        }
        let power = deciding.as_ref().map(|s| (s.0.as_slice(), s.1));
        d.cepstrum = cepstrum(&mut fft, x, power, fs, period, &ratios);
    }
    if (profile.max - profile.min) > ORDER_MAP_SPEED_CHANGE * profile.mean {
        d.order_map = order_map(&mut fft, &rec.channels[channels[0] - 1], &map, d.mesh_order);
    }
    let deciding = std::mem::take(&mut rec.channels[first - 1]);
    Ok(Analysed { diagnosis: d, map, deciding })
}

/// A mesh order `z` that the TSA of `points` samples per revolution of `gear` resolves with room for its
/// sidebands (and is not zero).
///
/// # Errors
/// [`JobError::Input`] naming the file, the order and the speed's source.
fn check_mesh_order(path: &Path, z: usize, points: usize, gear: Shaft, source: SpeedSource) -> Result<(), Error> {
    if z == 0 {
        return Err(bad(path, format!("mesh order 0 of the {gear}: a gear has at least one tooth")));
    }
    if z.saturating_mul(2).saturating_add(8) <= points / 2 {
        return Ok(());
    }
    Err(bad(
        path,
        format!(
            "mesh order {z} needs more than {points} samples per revolution of the {gear}: the shaft speed ({}) is too high for the sample rate, or the teeth are wrong",
            match source {
                SpeedSource::Estimated => "estimated; give the shaft speed",
                SpeedSource::Given => "given",
                SpeedSource::Tachometer => "from the tachometer",
            }
        ),
    ))
}

/// Frees the samples of every channel of `channels` but `keep` (the recording's raw statistics were taken
/// by the checks).
fn free_other_channels(rec: &mut Recording, channels: &[usize], keep: usize) {
    for &c in channels.iter().filter(|&&c| c != keep) {
        rec.channels[c - 1] = std::borrow::Cow::Borrowed(&[]);
    }
}

/// Points per revolution of a TSA: the revolution's samples rounded up to a power of two (64 ..= 65536).
pub(super) fn tsa_points(period: f64) -> usize {
    (period.ceil() as usize).next_power_of_two().clamp(64, 1 << 16)
}

pub(super) fn gear_indicators(
    fft: &mut Fft,
    gear: Shaft,
    channel: usize,
    z: usize,
    others: &OtherLines,
    t: &tsa::Tsa,
    shaft_orders: usize,
) -> GearIndicators {
    let (indicators, d) = tsa_indicators(fft, &t.samples, z, others, shaft_orders);
    GearIndicators {
        gear,
        channel,
        mesh_order: z,
        revolutions: t.revolutions,
        indicators,
        residual: d.residual,
        difference: d.difference,
        tsa_amplitudes: d.amplitudes,
        tsa: t.samples.clone(),
        blocks: Vec::new(),
    }
}

/// With a machine, the lines of an averaged shaft besides its gear's mesh: its other gears' mesh orders, and
/// the other stages' mesh harmonics in its orders, both counted as regular.
#[derive(Clone, Debug, Default)]
pub(super) struct OtherLines {
    pub mesh: Vec<usize>,
    pub foreign: Vec<f64>,
}

/// The condition indicators of one TSA of a gear with mesh order `z` (its shaft's other lines `others`),
/// and its decomposition.
pub(super) fn tsa_indicators(
    fft: &mut Fft,
    x: &[f64],
    z: usize,
    others: &OtherLines,
    shaft_orders: usize,
) -> (Indicators, Decomposition) {
    let d = if others.mesh.is_empty() && others.foreign.is_empty() {
        tsa::decompose(fft, x, z, shaft_orders)
    } else {
        tsa::decompose_many(fft, x, &[&[z][..], &others.mesh].concat(), &others.foreign, shaft_orders)
    };
    let Decomposition { amplitudes, regular, residual, difference } = &d;
    let mesh_amps: Vec<f64> =
        (1..).map(|h| h * z).take_while(|&k| k < amplitudes.len()).map(|k| amplitudes[k]).collect();
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let centred: Vec<f64> = x.iter().map(|v| v - mean).collect();
    // indices checked here: a mesh order beyond the average's resolution (refused by the caller) reads NaN
    let side = match (z.checked_sub(1).and_then(|i| amplitudes.get(i)), amplitudes.get(z + 1)) {
        (Some(a), Some(b)) => a + b,
        _ => f64::NAN,
    };
    let rms = ind::rms(&centred);
    let [fm4, m6a, m8a] = ind::normalized_moments_4_6_8(difference);
    let mut m = BTreeMap::new();
    m.insert(Indicator::Rms, rms);
    m.insert(Indicator::Kurtosis, ind::kurtosis(x));
    m.insert(Indicator::CrestFactor, ind::crest_factor(&centred));
    m.insert(Indicator::Fm0, ind::fm0(x, &mesh_amps));
    m.insert(Indicator::Fm4, fm4);
    m.insert(Indicator::M6a, m6a);
    m.insert(Indicator::M8a, m8a);
    m.insert(Indicator::Na4, ind::kurtosis(residual));
    m.insert(Indicator::Er, ind::energy_ratio(difference, regular));
    m.insert(Indicator::Si, side / 2.0);
    m.insert(Indicator::Slf, side / rms);
    m.insert(
        Indicator::Ser,
        if z < amplitudes.len() { ind::sideband_energy_ratio(amplitudes, z, 1) } else { f64::NAN },
    );
    (m, d)
}

/// A block average of a gear's TSA: its indicators, or the average itself until the gear's mesh order
/// is known.
pub(super) enum PendingBlock {
    Done(crate::report::summary::Block),
    Raw(Vec<f64>),
}

/// Blocks from a recording's start whose residual order spectrum is kept for the local-change indicator
/// (256 blocks of 16 revolutions: 4096 revolutions, 16 MB at most per gear and channel).
const SPECTRUM_BLOCKS: usize = 256;
/// Highest order of a block's residual spectrum kept (a crack's change lives up to the housing's
/// resonances, far above the mesh harmonics: 4096 orders of a 12 Hz shaft reach 49 kHz).
const SPECTRUM_ORDERS: usize = 4096;

/// Indicators of one block average of a gear (consecutive blocks of whole revolutions; the statistical
/// baseline's samples; a recording under test is scored by the median of its own blocks, so both sides
/// average the same number of revolutions); with `spectrum` the block keeps its residual's order spectrum.
pub(super) fn block_indicators(
    fft: &mut Fft,
    block: &[f64],
    z: usize,
    others: &OtherLines,
    shaft_orders: usize,
    spectrum: bool,
) -> crate::report::summary::Block {
    let (mut indicators, d) = tsa_indicators(fft, block, z, others, shaft_orders);
    let n = d.residual.len() as f64;
    let mean = d.residual.iter().sum::<f64>() / n;
    indicators.insert(Indicator::ResidualM2, d.residual.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n);
    indicators.insert(Indicator::ResidualM4, d.residual.iter().map(|v| (v - mean).powi(4)).sum::<f64>() / n);
    let residual_spectrum = if spectrum {
        crate::signal::tsa_change::order_spectrum(fft, &d.residual, SPECTRUM_ORDERS)
    } else {
        Vec::new()
    };
    crate::report::summary::Block { indicators, amplitudes: d.amplitudes, residual_spectrum }
}

/// Mesh harmonics and sidebands (3 per shaft on each side) from the raw amplitude spectrum when the
/// sample rate is known, else from the reference TSA's order spectrum.
pub(super) fn mesh_harmonics(d: &Diagnosis, channel: usize, shafts: &[(Shaft, f64)]) -> Vec<MeshHarmonic> {
    let z = d.mesh_order as f64;
    let spectrum = d.spectra.iter().find(|s| s.0 == channel).map(|s| &s.1);
    let tsa_amps = d.gears.iter().find(|g| g.channel == channel).map(|g| &g.tsa_amplitudes);
    let shaft_hz = d.shaft_hz.reference();
    let mut out = Vec::new();
    for k in 1..=3usize {
        let order = k as f64 * z;
        let read = |o: f64| -> Option<(Option<f64>, f64)> {
            match (spectrum, shaft_hz) {
                (Some(s), Some(f1)) => {
                    let f = o * f1;
                    // within 1.5 bins only: a line of the other shaft can sit a few Hz away (3 f2 = 32.3 Hz
                    // against f1 = 30 Hz for 14/39 teeth) and must not be taken for this one
                    let df = s.freqs_hz.get(1).copied().unwrap_or(1.0);
                    let (ff, a) = s.hann_line_near(f, 1.5 * df)?;
                    Some((Some(ff), a))
                }
                _ => {
                    let a = tsa_amps?;
                    let i = o.round() as usize;
                    ((o - o.round()).abs() < 1e-9 && i < a.len()).then(|| (None, a[i]))
                }
            }
        };
        let Some((f, a)) = read(order) else { break };
        let mut sidebands = Vec::new();
        for &(name, ratio) in shafts {
            for i in 1..=3i32 {
                for sign in [-1, 1] {
                    let o = order + f64::from(sign * i) * ratio;
                    if let Some((ff, aa)) = read(o) {
                        sidebands.push(Sideband {
                            offset: sign * i,
                            shaft: name,
                            frequency_hz: ff,
                            order: o,
                            amplitude: aa,
                            resolved: true,
                        });
                    }
                }
            }
        }
        // lines of different shafts closer than the resolution (3 bins, in orders) cannot be told apart
        let resolution = match (spectrum, shaft_hz) {
            (Some(s), Some(f1)) => 3.0 * s.freqs_hz.get(1).copied().unwrap_or(1.0) / f1,
            _ => 0.0,
        };
        // (shaft, order); `None` marks the mesh line itself
        let nominal: Vec<(Option<Shaft>, f64)> = shafts
            .iter()
            .flat_map(|&(name, ratio)| {
                (1..=3).flat_map(move |i| [-1.0, 1.0].map(|sg| (Some(name), order + sg * f64::from(i) * ratio)))
            })
            .chain(std::iter::once((None, order)))
            .collect();
        for sb in &mut sidebands {
            sb.resolved = !nominal.iter().any(|(name, o)| *name != Some(sb.shaft) && (o - sb.order).abs() < resolution);
        }
        out.push(MeshHarmonic { k, frequency_hz: f, order, amplitude: a, sidebands });
    }
    out
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
