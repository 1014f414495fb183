//! Refinement of a tracked angle by the synchronous average itself (after the mesh-phase tracking of the
//! parent module).
//!
//! A mesh line followed in noise gives an angle whose error is small in cycles of that line but grows with
//! the harmonic: at 6-18 dB over its band, the phase noise of the fundamental is a few hundredths of a mesh
//! cycle, and a gearbox whose vibration lies at mesh harmonics 10-40 (a housing resonance far above the
//! mesh) loses most of its synchronous average to it (the average of the 18/31 generated machine at 15 Hz
//! held a quarter of the RMS its tachometer's angle gives). Every harmonic carries the same angle, so the
//! whole revolution can: each revolution, resampled on the current angle, is compared with the average of
//! all of them, and the shift that lines it up best is the angle's error there (least squares over every
//! order: the maximum of the cross-correlation, searched within a third of a mesh cycle so that it cannot
//! jump a tooth, and refined by Newton's method on the cross-spectrum). The shifts are moved onto the
//! revolution starts, which are smoothed as a tachometer's are, and the average is formed again; three
//! rounds, the one whose average holds the most energy is kept. The mean shift is taken out, so the angle's
//! origin stays where the tracking put it.

use super::super::Sample;
use super::super::spectrum::Fft;
use super::super::tsa::AngleMap;
use super::super::tsa_change::{OrderSpectrum, advanced, align_within, mean, order_spectrum};
use super::smooth_starts;
use rayon::prelude::*;

/// Rounds of refinement (each one resampling of the record).
const ROUNDS: usize = 3;
/// Highest frequency used, cycles per sample of the record: where the resampling is still flat.
const HIGHEST: f64 = 0.35;
/// Least gain in the average's RMS for which a refined angle is given: on a right angle the shifts line up
/// noise alone, which gains well under 1 % (0.1 % on the tests' signals).
pub const MIN_GAIN: f64 = 1.02;

/// A refined angle and what it gained.
#[derive(Clone, Debug)]
pub struct Refined {
    /// The angle.
    pub map: AngleMap,
    /// RMS of the synchronous average (orders 1 and up) on the refined angle over the RMS on the angle
    /// given: at least [`MIN_GAIN`].
    pub gain: f64,
}

/// The angle `map` of a shaft with `teeth` teeth (the mesh order it was tracked on) refined by lining every
/// revolution of `x` up with their average; `None` when that gains less than [`MIN_GAIN`] (predicted from
/// the first round's shifts applied to each revolution's spectrum before the record is resampled again;
/// first on 256 revolutions spread over a longer record) or for fewer than 8 revolutions.
pub fn refine<T: Sample>(x: &[T], map: &AngleMap, teeth: usize) -> Option<Refined> {
    let revs = map.revolutions();
    let period = map.mean_period_samples();
    if revs < 8 || teeth == 0 || !(period.is_finite() && period > 8.0) {
        return None;
    }
    let points = (period as usize).next_power_of_two().clamp(256, 8192);
    let highest = ((HIGHEST * period) as usize).min(points / 2);
    // a third of a mesh cycle: a revolution is never moved onto the next tooth
    let reach = 1.0 / (3 * teeth) as f64;
    if revs > CHECK_REVS && predicted_gain(&spectra_of(x, map, points, highest, spread(revs)), reach) < MIN_GAIN {
        return None;
    }
    let mut spectra_now = spectra(x, map, points, highest);
    let energy0 = energy(&average(&spectra_now));
    let (mut best, mut best_energy) = (None, energy0);
    let mut current = map.clone();
    for round in 0..ROUNDS {
        let template = average(&spectra_now);
        // the lag of each revolution behind the average, revolutions in (-reach, reach)
        let shifts = lags(&spectra_now, &template, reach);
        if round == 0 && lined_up_gain(&spectra_now, &template, &shifts) < MIN_GAIN {
            return None;
        }
        let Some(next) = moved(&current, &shifts) else { break };
        current = next;
        spectra_now = spectra(x, &current, points, highest);
        let e = energy(&average(&spectra_now));
        if e > best_energy {
            (best, best_energy) = (Some(current.clone()), e);
        }
    }
    let gain = (best_energy / energy0).sqrt();
    best.filter(|_| gain >= MIN_GAIN).map(|map| Refined { map, gain })
}

/// Revolutions beyond which the first round's prediction is made on [`CHECK_REVS`] of them spread over the
/// record before the whole record is resampled (a minute at 30 Hz is 1800 revolutions, 0.2 s of resampling
/// and alignment for an angle that usually needs nothing). Fewer revolutions hold more noise in their
/// average, which the shifts partly line up too: the prediction from a sample errs towards a gain, so an
/// angle that would gain is not skipped for it.
const CHECK_REVS: usize = 256;

/// [`CHECK_REVS`] revolution numbers spread evenly over `revs`.
fn spread(revs: usize) -> Vec<usize> {
    (0..CHECK_REVS).map(|i| i * revs / CHECK_REVS).collect()
}

/// The lag of each revolution's spectrum behind `template`, revolutions in (-reach, reach).
fn lags(spectra: &[OrderSpectrum], template: &[(f64, f64)], reach: f64) -> Vec<f64> {
    spectra
        .par_iter()
        .map_init(Fft::new, |fft, r| {
            let s = align_within(fft, r, template, reach).shift;
            if s > 0.5 { s - 1.0 } else { s }
        })
        .collect()
}

/// RMS of the average of `spectra` each advanced by its shift over the RMS of their average `template`.
fn lined_up_gain(spectra: &[OrderSpectrum], template: &[(f64, f64)], shifts: &[f64]) -> f64 {
    let lined_up: Vec<OrderSpectrum> = spectra.iter().zip(shifts).map(|(r, &d)| advanced(r, d)).collect();
    (energy(&average(&lined_up)) / energy(template)).sqrt()
}

/// The gain in RMS that one round of lining `spectra` up with their average would give.
fn predicted_gain(spectra: &[OrderSpectrum], reach: f64) -> f64 {
    let template = average(spectra);
    lined_up_gain(spectra, &template, &lags(spectra, &template, reach))
}

/// `map` with revolution k's shift `shifts[k]` (revolutions) moved onto the revolution starts (start k
/// between the centres of revolutions k - 1 and k, the mean shift taken out) and smoothed; `None` when the
/// starts would not increase or fewer than 8 revolutions remain.
fn moved(map: &AngleMap, shifts: &[f64]) -> Option<AngleMap> {
    let revs = shifts.len();
    let centre = shifts.iter().sum::<f64>() / revs as f64;
    let at = |k: usize| 0.5 * (shifts[k.saturating_sub(1).min(revs - 1)] + shifts[k.min(revs - 1)]) - centre;
    let starts: Vec<f64> = (0..=revs).map(|k| map.sample_at(k as f64 + at(k))).collect();
    if starts.windows(2).any(|w| w[1] <= w[0]) {
        return None;
    }
    let next = AngleMap::from_pulses(&smooth_starts(&starts), 1);
    (next.revolutions() >= 8).then_some(next)
}

/// Each revolution's order spectrum on `map` (orders 0..=`highest`, DC zero), resampled at `points` per
/// revolution.
fn spectra<T: Sample>(x: &[T], map: &AngleMap, points: usize, highest: usize) -> Vec<OrderSpectrum> {
    let mut y = vec![0.0; map.revolutions() * points];
    map.resample(x, 0.0, 1.0 / points as f64, &mut y);
    y.par_chunks_exact(points).map_init(Fft::new, |fft, r| order_spectrum(fft, r, highest)).collect()
}

/// The order spectra of the revolutions `revs` of `x` on `map`, as [`spectra`] gives them.
fn spectra_of<T: Sample>(
    x: &[T],
    map: &AngleMap,
    points: usize,
    highest: usize,
    revs: Vec<usize>,
) -> Vec<OrderSpectrum> {
    revs.into_par_iter()
        .map_init(
            || (Fft::new(), vec![0.0; points]),
            |(fft, y), k| {
                map.resample(x, k as f64, 1.0 / points as f64, y);
                order_spectrum(fft, y, highest)
            },
        )
        .collect()
}

/// The mean of the revolutions' spectra.
fn average(spectra: &[OrderSpectrum]) -> OrderSpectrum {
    mean(&spectra.iter().map(|s| s.as_slice()).collect::<Vec<_>>())
}

/// Energy of a spectrum whose DC is zero.
fn energy(s: &[(f64, f64)]) -> f64 {
    s.iter().map(|c| c.0 * c.0 + c.1 * c.1).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A revolution of many mesh harmonics (a housing resonance far above the mesh), its angle known in
    /// closed form (a 1 % speed fluctuation), and revolution starts jittered by 0.03 mesh cycles rms, as a
    /// mesh line followed in noise gives them: the refinement brings the starts back to within a twentieth of
    /// that error over what smoothing the true starts leaves, and the average's RMS up to what the true angle
    /// gives.
    #[test]
    fn a_jittered_angle_is_lined_up_by_the_average() {
        jittered_angle_lined_up(60);
    }

    /// The same over more than [`CHECK_REVS`] revolutions, where the first round is predicted on a sample
    /// of them: the sample must not refuse an angle that gains.
    #[test]
    fn a_long_jittered_angle_passes_the_sampled_check() {
        jittered_angle_lined_up(3 * CHECK_REVS / 2);
    }

    fn jittered_angle_lined_up(revs: usize) {
        let (z, period) = (18usize, 1500.0f64);
        let n = (period * revs as f64) as usize + 10;
        // theta(t) = t / period + a sin(2 pi f t): a 1 % fluctuation of a cycle per 7 revolutions
        let f = 1.0 / (7.0 * period);
        let a = 0.01 / (2.0 * std::f64::consts::PI * f * period);
        let theta = |t: f64| t / period + a * (2.0 * std::f64::consts::PI * f * t).sin();
        let wave = |th: f64| -> f64 {
            (8..=20).map(|h| (2.0 * std::f64::consts::PI * (h * z) as f64 * th + h as f64).cos()).sum::<f64>()
                + 0.5 * (2.0 * std::f64::consts::PI * (z as f64) * th).sin()
        };
        let x: Vec<f64> = (0..n).map(|i| wave(theta(i as f64))).collect();
        // true starts: theta(t) = k, solved by Newton
        let true_start = |k: usize| {
            let mut t = k as f64 * period;
            for _ in 0..30 {
                let d = 1.0 / period + a * 2.0 * std::f64::consts::PI * f * (2.0 * std::f64::consts::PI * f * t).cos();
                t -= (theta(t) - k as f64) / d;
            }
            t
        };
        let truth: Vec<f64> = (0..revs).map(true_start).collect();
        // jitter of 0.03 mesh cycles rms (a fixed pseudo-random sequence)
        let mut s = 12345u64;
        let mut noise = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 12f64.sqrt()
        };
        let jitter = 0.03 * period / z as f64;
        let jittered: Vec<f64> = truth.iter().map(|t| t + jitter * noise()).collect();
        let rms_err = |starts: &[f64]| {
            let m = starts.len().min(truth.len());
            let e: Vec<f64> = (2..m - 2).map(|k| starts[k] - truth[k]).collect();
            let mean = e.iter().sum::<f64>() / e.len() as f64;
            (e.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / e.len() as f64).sqrt()
        };
        let before = rms_err(&jittered);
        let r = refine(&x, &AngleMap::from_pulses(&jittered, 1), z).unwrap();
        let after = rms_err(r.map.starts());
        // the jitter is 0.9 samples at 1500 samples per revolution; lined up on 17 harmonics of a noise-free
        // signal the starts are good to the smoothing's own error
        // the smoothing's own error on the true starts (a quadratic over a few revolutions of a fluctuation
        // of 7) is the floor: the refined starts come within a twentieth of the jitter of it
        let floor = rms_err(&super::smooth_starts(&truth));
        assert!(after < floor + 0.05 * before, "start error {before:.3} -> {after:.3} samples (floor {floor:.3})");
        // a jitter of 0.03 mesh cycles is 0.24-0.6 cycles at mesh harmonics 8-20: the jittered average keeps
        // under half of the harmonics' RMS (sinc-like loss of a uniform phase spread), the lined-up one all
        assert!(r.gain > 2.0, "gain {}", r.gain);
    }

    /// On the true angle there is nothing to gain: no refined angle is given, whether the first round is
    /// predicted on every revolution or on a sample of them.
    #[test]
    fn a_right_angle_stays() {
        right_angle_stays(40);
        right_angle_stays(2 * CHECK_REVS);
    }

    fn right_angle_stays(revs: usize) {
        let (z, period) = (13usize, 1024.0f64);
        let x: Vec<f64> = (0..(period as usize * revs + 5))
            .map(|i| {
                let th = i as f64 / period;
                (2.0 * std::f64::consts::PI * (3 * z) as f64 * th).cos() + 0.3 * (2.0 * std::f64::consts::PI * th).sin()
            })
            .collect();
        let starts: Vec<f64> = (0..revs).map(|k| k as f64 * period).collect();
        assert!(refine(&x, &AngleMap::from_pulses(&starts, 1), z).is_none());
    }
}
