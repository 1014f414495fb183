//! Evidence stage: the deciding channel's spectra, mesh harmonics with their sidebands, envelope, cepstrum
//! and rpm-order map.

use super::super::*;

/// Mesh harmonics and sidebands (3 per shaft on each side) from the raw amplitude spectrum when the
/// sample rate is known, else from the reference TSA's order spectrum.
pub(in crate::jobs::diagnose) fn mesh_harmonics(
    d: &Diagnosis,
    channel: usize,
    shafts: &[(Shaft, f64)],
) -> Vec<MeshHarmonic> {
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

/// Evidence stage, its spectra: every spectrum channel's amplitude spectrum, the deciding channel's
/// averaged power and its band's squared envelope (the same transforms give both), and that band.
pub(in crate::jobs::diagnose) struct Spectra {
    /// Amplitude spectrum per channel: the deciding one, the others on request.
    pub amplitude: Vec<(usize, crate::signal::Spectrum)>,
    /// The deciding channel's averaged power and what the same pass gave.
    deciding: Option<Deciding>,
    /// The envelope's band, chosen before the spectra (none with a lifter or without a sample rate).
    band: Option<Result<super::super::beyond::EnvelopeBand, crate::signal::SignalError>>,
    /// How the band is chosen.
    choice: BandChoice,
}

/// The deciding channel's averaged power, its segment length (samples), and its band's squared envelope
/// with the envelope's rate (Hz) when the spectrum pass gave it.
struct Deciding {
    power: Vec<f64>,
    segment: usize,
    envelope: Option<(Vec<f64>, f64)>,
}

/// Evidence stage: the spectra of the deciding channel (and of the others on request). Its envelope band
/// is chosen first, so that the amplitude spectrum's segments also give its envelope.
#[allow(clippy::too_many_arguments)]
pub(in crate::jobs::diagnose) fn spectra(
    path: &Path,
    rec: &Recording,
    checked: &Checked,
    o: &Options,
    geometry: Option<&Geometry>,
    shaft: &super::ShaftAngle,
    mesh_order: usize,
    fft: &mut Fft,
) -> Result<Spectra, Error> {
    let first = checked.channels[0];
    let choice =
        BandChoice { levels: o.kurtogram_levels, band: o.envelope_band.or(geometry.and_then(|g| g.envelope_band)) };
    let mut plan = match (checked.fs, o.lifter) {
        (Some(fs), None) => Some(envelope_plan(fft, &rec.channels[first - 1], fs, &shaft.map, mesh_order, choice)),
        _ => None,
    };
    let ola = std::sync::Mutex::new(match &mut plan {
        Some(Ok((_, ola))) => ola.take(),
        _ => None,
    });
    let channels: Vec<usize> = checked.channels.iter().copied().filter(|&c| c == first || o.all_spectra).collect();
    let spectra = match checked.fs {
        Some(fs) => channels
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
    let mut deciding = None;
    let amplitude = spectra
        .into_iter()
        .map(|(c, s)| {
            if c == first {
                deciding = Some(Deciding { power: s.power, segment: s.segment, envelope: s.envelope });
            }
            (c, s.amplitude)
        })
        .collect();
    Ok(Spectra { amplitude, deciding, band: plan.map(|p| p.map(|(band, _)| band)), choice })
}

/// Evidence stage beyond the averages, on the deciding channel `x`: the envelope (of the planned band, or
/// of the liftered signal), the cepstrum, and the rpm-order map when the speed changes.
///
/// # Errors
/// A lifter of a shaft whose speed is not known, or an envelope band or level asked for that does not fit.
#[allow(clippy::too_many_arguments)]
pub(in crate::jobs::diagnose) fn beyond_averages(
    path: &Path,
    d: &mut Diagnosis,
    x: &[f32],
    o: &Options,
    shaft: &super::ShaftAngle,
    plan: &super::GearPlan,
    spectra: Spectra,
    fft: &mut Fft,
) -> Result<(), Error> {
    let ratios = plan.ratios();
    let Spectra { deciding, band, choice, .. } = spectra;
    let (map, period) = (&shaft.map, shaft.period);
    if let Some(fs) = d.sample_rate_hz {
        let result = match (o.lifter, band) {
            (Some(lifter), _) => {
                let ratio = ratios.iter().find(|r| r.0 == lifter).map(|r| r.1).ok_or_else(|| {
                    bad(path, format!("cannot lifter the {lifter} family: give the teeth so that its speed is known"))
                })?;
                let y = crate::signal::envelope::lifter_comb(fft, x, period / ratio, 1).map_err(|e| bad(path, e))?;
                // the planned overlap-add is for a spectrum pass over the recording, which the liftered
                // signal never gets: its envelope takes a pass of its own
                envelope_plan(fft, &y, fs, map, d.mesh_order, choice).and_then(|(band, _)| {
                    let (e, r) = envelope_of(fft, &y, fs, &band, None)?;
                    Ok(envelope(fft, band, &e, r, fs, map, &ratios))
                })
            }
            (None, Some(Ok(band))) => match deciding.as_ref().and_then(|s| s.envelope.as_ref()) {
                Some((e, r)) => Ok(envelope(fft, band, e, *r, fs, map, &ratios)),
                None => envelope_of(fft, x, fs, &band, None).map(|(e, r)| envelope(fft, band, &e, r, fs, map, &ratios)),
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
        let power = deciding.as_ref().map(|s| (s.power.as_slice(), s.segment));
        d.cepstrum = cepstrum(fft, x, power, fs, period, &ratios);
    }
    let speeds = &shaft.speeds;
    if (speeds.max - speeds.min) > ORDER_MAP_SPEED_CHANGE * speeds.mean {
        d.order_map = order_map(fft, x, map, d.mesh_order);
    }
    Ok(())
}
