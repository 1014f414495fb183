//! Beyond the TSA in a diagnosis: the envelope analysis (band from the kurtogram, the baseline or the
//! user), the cepstrum's rahmonics and the rpm-order map of a recording whose speed changes.

use super::*;
use crate::signal::Spectrum;
use crate::signal::envelope::BandOverlapAdd;
use crate::signal::spectrum::AmplitudeOptions;

/// Speed range (slowest to fastest revolution, over the mean) above which the rpm-order map is drawn.
pub(super) const ORDER_MAP_SPEED_CHANGE: f64 = 0.02;

/// Mesh harmonics (with the sidebands of the last) drawn in the rpm-order map when the sample rate keeps
/// them: a gear's mesh harmonics beyond the fifth seldom carry what the first five do not.
const ORDER_MAP_MESH_HARMONICS: f64 = 5.5;

/// The rpm-order map of a recording whose speed changes: segments of 8 revolutions advancing by 4 (order
/// resolution 1/8), orders up to [`ORDER_MAP_MESH_HARMONICS`] mesh orders, or as far as the sample rate
/// reaches at the fastest revolution (0.45 of its samples per revolution, under the anti-alias filter's
/// edge), and at least 1.5 mesh orders. `None` when the recording holds too few revolutions.
pub(super) fn order_map(fft: &mut Fft, x: &[f32], map: &AngleMap, mesh_order: usize) -> Option<OrderMap> {
    let mesh = mesh_order.max(1) as f64;
    let fastest = angle::SpeedProfile::of(map).max;
    let nyquist_order = if fastest > 0.0 { 0.45 / fastest } else { f64::INFINITY };
    let max_order = (ORDER_MAP_MESH_HARMONICS * mesh).min(nyquist_order).max(1.5 * mesh);
    let points = ((3.0 * max_order) as usize).next_power_of_two().max(64);
    crate::signal::order_map::order_map(fft, x, map, points, 8, 4, max_order).ok()
}

/// How the envelope band is chosen: kurtogram depth, and a band (given, or the baseline's) that overrides
/// the kurtogram's choice.
#[derive(Clone, Copy, Debug)]
pub(super) struct BandChoice {
    pub(super) levels: Option<usize>,
    pub(super) band: Option<(f64, f64)>,
}

/// Kurtogram levels searched (band widths down to fs / 64).
const KURTOGRAM_LEVELS: usize = 5;

/// The envelope band of one channel: the fast kurtogram of its first 2^18 samples and the band of largest
/// spectral kurtosis from 1.5 mesh frequencies up (at most from fs / 4), unless `choice` gives one.
pub(super) struct EnvelopeBand {
    kurtogram: crate::signal::envelope::Kurtogram,
    level: usize,
    pub(super) band_hz: (f64, f64),
    given: bool,
}

/// Chooses the envelope band of `x` (see [`EnvelopeBand`]).
pub(super) fn envelope_band<T: crate::signal::Sample>(
    fft: &mut Fft,
    x: &[T],
    fs: f64,
    map: &AngleMap,
    mesh_order: usize,
    choice: BandChoice,
) -> Result<EnvelopeBand, crate::signal::SignalError> {
    let BandChoice { levels, band } = choice;
    let n = x.len().min(1 << 18);
    let deepest = ((n.next_power_of_two() / 4 / 64) as f64).log2().floor().max(1.0) as usize;
    // bands from 1.5 mesh frequencies up: below, the shafts' and mesh's own lines beat into a peaky envelope
    let mesh_hz = mesh_order as f64 * fs / map.mean_period_samples();
    let levels = levels.unwrap_or(KURTOGRAM_LEVELS.min(deepest));
    let kurtogram = crate::signal::envelope::kurtogram(fft, x, fs, levels, (1.5 * mesh_hz).min(fs / 4.0))?;
    // a given band first, then the baseline's (so the lines compare with it), else the kurtogram's choice
    let (level, lo, hi) = match band {
        Some((lo, hi)) => (0, lo, hi),
        None => (kurtogram.best.0, kurtogram.best.2, kurtogram.best.3),
    };
    Ok(EnvelopeBand { kurtogram, level, band_hz: (lo, hi), given: band.is_some() })
}

/// Most revolutions the envelope's order spectrum transforms at once: a longer record's is the power
/// average of parts of at most this many (resolution 1/4096 of an order; a one-hour record's whole would
/// take 300 MB at once and print 7 million lines).
const ENVELOPE_REVS: usize = 4096;

/// Envelope analysis of one channel from its band and the band's squared envelope `e` at the rate `r`
/// relative to the record's (from [`BandOverlapAdd`](crate::signal::envelope::BandOverlapAdd)): the
/// envelope's order spectrum on the tracked angle (a long record's averaged over parts of [`ENVELOPE_REVS`]) and its lines at orders 1..=3 of each shaft.
pub(super) fn envelope(
    fft: &mut Fft,
    band: EnvelopeBand,
    e: &[f64],
    r: f64,
    fs: f64,
    map: &AngleMap,
    shafts: &[(Shaft, f64)],
) -> crate::report::summary::Envelope {
    use crate::signal::envelope as env;
    let (lo, hi) = band.band_hz;
    let period = map.mean_period_samples();
    let scaled = AngleMap::from_pulses(&map.starts().iter().map(|s| s * r).collect::<Vec<_>>(), 1);
    // the envelope holds 0 .. (hi - lo) Hz: 2.5 points per cycle of that per revolution suffice
    let needed = 2.5 * (hi - lo) * period / fs;
    let points = (needed.ceil() as usize)
        .next_power_of_two()
        .clamp(32, ((period * r).ceil() as usize).next_power_of_two().clamp(32, 4096));
    let (orders, amplitudes, revs) = env::order_spectrum_parts(fft, e, &scaled, points, ENVELOPE_REVS);
    let revs = revs.max(1) as f64;
    let at = |o: f64| -> (f64, f64) {
        let i = (o * revs).round() as usize;
        let a = (i.saturating_sub(2)..=i + 2).filter_map(|j| amplitudes.get(j)).copied().fold(0.0, f64::max);
        let w = (2.0 * revs) as usize;
        let mut near: Vec<f64> = (i.saturating_sub(w)..=i + w).filter_map(|j| amplitudes.get(j)).copied().collect();
        near.sort_by(f64::total_cmp);
        let floor = near.get(near.len() / 2).copied().unwrap_or(0.0).max(f64::MIN_POSITIVE);
        (a, 20.0 * (a / floor).max(f64::MIN_POSITIVE).log10())
    };
    let lines = shafts
        .iter()
        .flat_map(|&(shaft, ratio)| (1..=3).map(move |k| (shaft, k, k as f64 * ratio)))
        .map(|(shaft, order, o)| {
            let (amplitude, over_floor_db) = at(o);
            crate::report::summary::EnvelopeLine { shaft, order, reference_order: o, amplitude, over_floor_db }
        })
        .collect();
    // a given band's spectral kurtosis from its squared envelope e = |c|^2: <e^2> / <e>^2 - 2 (the same
    // moments at the lower rate)
    let m1 = e.iter().sum::<f64>() / e.len().max(1) as f64;
    let m2 = e.iter().map(|v| v * v).sum::<f64>() / e.len().max(1) as f64;
    let spectral_kurtosis =
        if band.given { m2 / (m1 * m1).max(f64::MIN_POSITIVE) - 2.0 } else { band.kurtogram.best_kurtosis };
    crate::report::summary::Envelope {
        band_hz: [lo, hi],
        level: band.level,
        spectral_kurtosis,
        lines,
        orders,
        amplitudes,
        kurtogram: band.kurtogram.levels,
        liftered: None,
    }
}

/// The deciding channel's envelope band and the overlap-add its spectrum pass feeds (`None` in the pair
/// once the pass has taken it).
pub(super) fn envelope_plan<T: crate::signal::Sample>(
    fft: &mut Fft,
    x: &[T],
    fs: f64,
    map: &AngleMap,
    mesh_order: usize,
    choice: BandChoice,
) -> Result<(EnvelopeBand, Option<BandOverlapAdd>), crate::signal::SignalError> {
    let band = envelope_band(fft, x, fs, map, mesh_order, choice)?;
    let (lo, hi) = band.band_hz;
    let ola = BandOverlapAdd::new(x.len(), AmplitudeOptions::default().segment, fs, lo, hi)?;
    Ok((band, Some(ola)))
}

/// The squared envelope of `band` in `x` and its rate, from `ola` when a spectrum pass has filled it,
/// else by a pass of its own.
pub(super) fn envelope_of<T: crate::signal::Sample>(
    fft: &mut Fft,
    x: &[T],
    fs: f64,
    band: &EnvelopeBand,
    ola: Option<BandOverlapAdd>,
) -> Result<(Vec<f64>, f64), crate::signal::SignalError> {
    match ola {
        Some(ola) => Ok(ola.finish()),
        None => {
            let (lo, hi) = band.band_hz;
            crate::signal::envelope::squared_envelope_segments(fft, x, fs, lo, hi, AmplitudeOptions::default().segment)
        }
    }
}

/// What one pass of segment transforms gives for a channel: the amplitude spectrum, the averaged power
/// behind it (with its segment length) and, for the deciding channel, the envelope band's squared
/// envelope and rate.
pub(super) struct ChannelSpectra {
    pub(super) amplitude: Spectrum,
    pub(super) power: Vec<f64>,
    pub(super) segment: usize,
    pub(super) envelope: Option<(Vec<f64>, f64)>,
}

/// Spectra of one channel; `ola` (the deciding channel's envelope band) is filled by the same transforms
/// when its segments are the amplitude spectrum's.
pub(super) fn channel_spectra(
    fft: &mut Fft,
    x: &[f32],
    fs: f64,
    ola: Option<BandOverlapAdd>,
) -> Result<ChannelSpectra, crate::signal::SignalError> {
    use crate::signal::spectrum::{amplitude_from_power, averaged_power, averaged_power_each};
    let o = AmplitudeOptions::default();
    let what = "amplitude spectrum";
    let shared = ola.filter(|b| b.segment() == o.segment.min(x.len()).max(8) && o.overlap == 0.5);
    let ((power, segment), envelope) = match shared {
        Some(mut b) => {
            let p = averaged_power_each(fft, x, o.segment, o.overlap, what, true, |f, s, sp| b.add(f, s, sp))?;
            (p, Some(b.finish()))
        }
        None => (averaged_power(fft, x, o.segment, o.overlap, what)?, None),
    };
    let amplitude = amplitude_from_power(&power, segment, fs);
    Ok(ChannelSpectra { amplitude, power, segment, envelope })
}

/// Real power cepstrum over segments of about 8 revolutions of the slowest shaft, with the first 3
/// rahmonics of each shaft; `power` is an averaged power already at hand (values and segment length).
pub(super) fn cepstrum(
    fft: &mut Fft,
    x: &[f32],
    power: Option<(&[f64], usize)>,
    fs: f64,
    period: f64,
    shafts: &[(Shaft, f64)],
) -> Option<crate::report::summary::Cepstrum> {
    let slowest = shafts.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
    let segment = ((8.0 * period / slowest) as usize).next_power_of_two().clamp(256, 1 << 18);
    let values = match power {
        // the amplitude spectrum's averaged power, when its segments are the cepstrum's
        Some((p, n)) if n == segment => crate::signal::envelope::cepstrum_of_power(fft, p, n),
        _ => crate::signal::envelope::cepstrum(fft, x, segment).ok()?,
    };
    let rahmonics = shafts
        .iter()
        .flat_map(|&(shaft, ratio)| (1..=3).map(move |k| (shaft, k, k as f64 * period / ratio)))
        .filter(|(_, _, q)| (*q as usize) + 2 < values.len())
        .map(|(shaft, k, q)| {
            let w = (q * 0.01).ceil() as usize;
            let i = q.round() as usize;
            let value = (i.saturating_sub(w)..=i + w).filter_map(|j| values.get(j)).copied().fold(f64::MIN, f64::max);
            crate::report::summary::Rahmonic { shaft, k, quefrency_s: q / fs, value }
        })
        .collect();
    Some(crate::report::summary::Cepstrum { rahmonics, dq_s: 1.0 / fs, values })
}
