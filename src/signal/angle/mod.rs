//! Order tracking: the reference shaft's angle as a function of time, from tachometer pulses or from the
//! phase of a mesh harmonic, and the speed profile it implies.
//!
//! Mesh-phase tracking (no tachometer). A gear mesh puts a strong line at order m = k z of the shaft
//! (k-th mesh harmonic, z teeth). Its phase is 2 pi m theta(t) + phi, with theta the shaft angle in
//! revolutions, so the angle follows from the unwrapped phase divided by m. Three stages:
//! 1. *Ridge*: a short-time spectrum (Hann frames of about 8 revolutions) follows the line from the frame
//!    where it is strongest, frame to frame within +-0.35 shaft orders (half the sideband spacing less a
//!    margin), so a run-up or coast-down is followed; integrating the ridge frequency gives a first angle
//!    theta0(t). Its frames (8-16 revolutions) average a speed fluctuation of a few revolutions away.
//!    When one line is too weak or too smeared for that, the whole mesh comb votes in frames of 1-8
//!    revolutions ([`comb_ridges`]) and the ridge is the best path through the votes.
//! 2. *Lock*: the line's phase around theta0, in blocks of a sixteenth of a revolution, is followed by a
//!    second-order phase-locked loop (natural frequency 0.4 orders) run forward and backward and
//!    averaged, then smoothed by the moving averages of stage 3 (applied twice), which take out the shaft
//!    sidebands the loop follows. At a high mesh harmonic a 1 % fluctuation of a cycle per 8 revolutions
//!    swings the line by more than +-1 order around theta0, past what stage 3 can hold: without the loop,
//!    the tracked angle slipped whole cycles of the harmonic (0.3-2 mesh cycles rms on the generated
//!    gearboxes of tests/unseen_machines.rs; with it 0.004-0.012, as their tachometer's angle). When the
//!    two directions disagree, a wider loop (0.7 orders) tries again (a speed that wanders within a few
//!    revolutions); when that one disagrees too (a line too weak against its sidebands and noise), the
//!    ridge's angle goes on.
//! 3. *Demodulation*: x(t) exp(-i 2 pi m theta(t)) brings the line to 0 Hz and its sidebands to multiples
//!    of the shaft frequency f1; a cascade of two moving averages over two revolutions (zeros at every
//!    multiple of f1 / 2) keeps the line alone, and its phase psi(t) corrects the angle:
//!    theta(t) += (psi(t) - psi0) / (2 pi m). Once after the lock (twice from the ridge alone, the
//!    second time around the first result), so the angle follows speed changes slower than f1 / 2.
//!
//! Revolutions start where theta crosses an integer; [`AngleMap`] interpolates between the starts. The
//! angle can then be refined by the synchronous average itself ([`refine`]): every revolution lined up with
//! the average of all, which carries the angle at every mesh harmonic, where the followed line carries it
//! at one.

use super::spectrum::{Fft, hann, phasor_sum};
use super::tsa::AngleMap;
use super::{Sample, SignalError};
use rayon::prelude::*;

mod comb;
pub use comb::comb_ridges;
mod lock;
use lock::*;
mod refine;
pub use refine::*;

/// Speed of the reference shaft over a recording, from its revolution starts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedProfile {
    /// Mean speed, revolutions per sample (multiply by the sample rate for Hz).
    pub mean: f64,
    /// Slowest single revolution, revolutions per sample.
    pub min: f64,
    /// Fastest single revolution, revolutions per sample.
    pub max: f64,
    /// Relative change from the first tenth of the revolutions to the last tenth (0.2 = +20 %).
    pub change: f64,
    /// How far the speed wanders: half the range between the 10th and 90th percentiles of the
    /// revolutions' speeds, relative to the mean (0.01 = +-1 %); percentiles, so that a few revolutions
    /// misread on a weak line do not count.
    pub wander: f64,
}

impl SpeedProfile {
    /// The profile of the revolutions of `map`.
    pub fn of(map: &AngleMap) -> Self {
        let starts = map.starts();
        let speeds: Vec<f64> = starts.windows(2).map(|w| 1.0 / (w[1] - w[0])).collect();
        let tenth = (speeds.len() / 10).max(1);
        let mean_of = |s: &[f64]| s.iter().sum::<f64>() / s.len().max(1) as f64;
        let mean = 1.0 / map.mean_period_samples();
        let (first, last) =
            (mean_of(&speeds[..tenth.min(speeds.len())]), mean_of(&speeds[speeds.len() - tenth.min(speeds.len())..]));
        Self {
            mean,
            min: speeds.iter().copied().fold(f64::INFINITY, f64::min),
            max: speeds.iter().copied().fold(0.0, f64::max),
            change: (last - first) / mean,
            wander: wander(&speeds) / mean,
        }
    }
}

/// Half the range between the 10th and 90th percentiles of `speeds` (0 when empty).
fn wander(speeds: &[f64]) -> f64 {
    if speeds.is_empty() {
        return 0.0;
    }
    let mut sorted = speeds.to_vec();
    sorted.sort_by(f64::total_cmp);
    let at = |q: f64| sorted[((sorted.len() - 1) as f64 * q).round() as usize];
    0.5 * (at(0.9) - at(0.1))
}

/// A tracked shaft angle.
#[derive(Clone, Debug)]
pub struct Tracked {
    /// Revolution starts.
    pub map: AngleMap,
    /// Median over the short-time frames of the line's height over the median of its search band, dB: how
    /// clearly the tracked line stands out (below about 10 dB the angle is noisy).
    pub line_snr_db: f64,
    /// Whether the phase-locked loop held the line (forward and backward agreeing); without it the angle
    /// is the ridge's, corrected by two demodulation passes, and can slip cycles of the line.
    pub locked: bool,
}

/// Revolution starts from tachometer pulses, `per_rev` pulses per revolution, after checking the pulse
/// train: an interval more than 1.6 times the median of its neighbours is a missing pulse.
///
/// # Errors
/// Too few pulses for one revolution, or pulses missing.
pub fn from_pulses(pulses: &[f64], per_rev: usize) -> Result<AngleMap, SignalError> {
    let per_rev = per_rev.max(1);
    if pulses.len() < 2 * per_rev + 1 {
        return Err(SignalError::Invalid(format!(
            "tachometer channel has {} pulse(s); two revolutions of {per_rev} pulse(s) are needed",
            pulses.len()
        )));
    }
    let gaps: Vec<f64> = pulses.windows(2).map(|w| w[1] - w[0]).collect();
    for (i, g) in gaps.iter().enumerate() {
        let lo = i.saturating_sub(4);
        let hi = (i + 5).min(gaps.len());
        let mut near: Vec<f64> = gaps[lo..hi].to_vec();
        near.sort_by(f64::total_cmp);
        // the lower quartile of the neighbours: with every third pulse missing the median is itself a
        // doubled gap, the lower quartile still a whole revolution
        let median = near[near.len() / 4];
        if *g > 1.6 * median {
            return Err(SignalError::Invalid(format!(
                "tachometer pulses missing: the gap after pulse {} at sample {:.0} is {:.2} times its neighbours'",
                i + 1,
                pulses[i],
                g / median
            )));
        }
    }
    let starts: Vec<f64> = pulses.iter().step_by(per_rev).copied().collect();
    Ok(AngleMap::from_pulses(&smooth_starts(&starts), 1))
}

/// Windows (revolutions) of the revolution-start smoothing, widest first.
const SMOOTHING_WINDOWS: [usize; 4] = [17, 11, 7, 5];

/// Revolution starts smoothed by a local quadratic least-squares fit (Savitzky-Golay; windows shifted
/// inside at the ends) over the window of [`SMOOTHING_WINDOWS`] with the least leave-one-out prediction
/// error (each start against the fit of its window without it: r_k / (1 - h_kk), h_kk the weight of the
/// start in its own fit); fewer starts than 5 stay raw. Pulse edges sampled without interpolation jitter by
/// up to half a sample, which at 300 samples per revolution is 0.13 rad of phase at mesh order 14; the
/// 17-revolution fit's noise gain at the centre is 0.36 (sqrt of 3 (3m^2 + 3m - 1) / ((2m + 1)(4m^2 +
/// 4m - 3)), m = 8), and every window keeps a constant acceleration exact. A speed fluctuation of a cycle
/// per 16 revolutions (1.5 Hz at 1480 rpm) moves the starts by far more than the jitter (by 50 samples at
/// 2 % and 1000 samples per revolution), and a 17-revolution fit would take it out of the angle (a residual
/// of 4 samples rms): its prediction error rules that window out.
fn smooth_starts(starts: &[f64]) -> Vec<f64> {
    SMOOTHING_WINDOWS
        .iter()
        .filter(|&&w| starts.len() >= w)
        .map(|&w| {
            let (fit, own) = quadratic_fit(starts, w);
            let press: f64 = starts.iter().zip(&fit).zip(&own).map(|((s, f), h)| ((s - f) / (1.0 - h)).powi(2)).sum();
            (press, fit)
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or_else(|| starts.to_vec(), |(_, fit)| fit)
}

/// [`smooth_starts`] with a window of `w` revolutions (`starts` holds at least `w`): the fitted starts, and
/// each start's weight in its own fit.
fn quadratic_fit(starts: &[f64], w: usize) -> (Vec<f64>, Vec<f64>) {
    (0..starts.len())
        .map(|k| {
            let lo = k.saturating_sub(w / 2).min(starts.len() - w);
            // fit t = a + b u + c u^2 with u = j - k over the window, evaluate at u = 0
            let mut m = [[0.0f64; 3]; 3];
            let mut r = [0.0f64; 3];
            for (j, &t) in starts[lo..lo + w].iter().enumerate() {
                let u = (lo + j) as f64 - k as f64;
                let p = [1.0, u, u * u];
                for a in 0..3 {
                    r[a] += p[a] * t;
                    for b in 0..3 {
                        m[a][b] += p[a] * p[b];
                    }
                }
            }
            // the weight of start k (u = 0) in its own fit is (M^-1)_00
            (solve3(m, r)[0], solve3(m, [1.0, 0.0, 0.0])[0])
        })
        .unzip()
}

/// Solves a 3x3 symmetric positive definite system by Gaussian elimination.
fn solve3(mut m: [[f64; 3]; 3], mut r: [f64; 3]) -> [f64; 3] {
    for i in 0..3 {
        for j in i + 1..3 {
            let f = m[j][i] / m[i][i];
            let pivot = m[i];
            for (a, p) in m[j].iter_mut().zip(pivot).skip(i) {
                *a -= f * p;
            }
            r[j] -= f * r[i];
        }
    }
    let mut x = [0.0; 3];
    for i in (0..3).rev() {
        x[i] = (r[i] - (i + 1..3).map(|k| m[i][k] * x[k]).sum::<f64>()) / m[i][i];
    }
    x
}

/// Tracks the shaft angle from the mesh harmonic at `order` (k z, in orders of the shaft) of `x`, starting
/// from a nominal revolution length of `period` samples (within +-20 % of the mean).
///
/// # Errors
/// Recording shorter than 3 nominal frames, no line near the nominal order, or an angle that goes backwards
/// (the speed varies faster than the tracking can follow).
pub fn track_mesh<T: Sample>(x: &[T], period: f64, order: f64) -> Result<Tracked, SignalError> {
    follow_ridge(x, mesh_ridge(x, period, order)?)
}

/// The first stage of [`track_mesh`]: the mesh line's ridge in short-time spectra, its height over its
/// band, and the knots of the angle it gives. Cheaper than the demodulation that follows, and its
/// `line_snr_db` is the tracked line's: a caller choosing among channels follows only the best ridge.
pub struct MeshRidge {
    knots: Vec<(f64, f64)>,
    period: f64,
    order: f64,
    /// Median height of the line over its band along the record, dB.
    pub line_snr_db: f64,
}

/// The ridge of the mesh harmonic at `order` of `x` around a nominal revolution of `period` samples.
///
/// # Errors
/// As [`track_mesh`]: too short a recording, no line near the nominal order.
pub fn mesh_ridge<T: Sample>(x: &[T], period: f64, order: f64) -> Result<MeshRidge, SignalError> {
    if !(period.is_finite() && period >= 4.0 && order >= 1.0) || order / period >= 0.5 {
        return Err(SignalError::Invalid(format!(
            "cannot track order {order} at {period:.1} samples per revolution (above the Nyquist frequency)"
        )));
    }
    let (knots, snr) = ridge(x, period, order)?;
    Ok(MeshRidge { knots, period, order, line_snr_db: 20.0 * snr.log10() })
}

/// The second stage of [`track_mesh`]: two demodulation passes of `x` around the ridge's angle, and the
/// revolution starts where the angle crosses whole revolutions.
///
/// # Errors
/// An angle that goes backwards (the speed varies faster than the tracking can follow), fewer than two
/// revolutions.
pub fn follow_ridge<T: Sample>(x: &[T], r: MeshRidge) -> Result<Tracked, SignalError> {
    let MeshRidge { knots, period, order, line_snr_db } = r;
    // the phase-locked stage, then the demodulation passes; each returns knots at block centres
    // after the lock one demodulation pass takes in what the smoothing left (measured on the generated
    // gearboxes: a second pass changes the error by 2 %); from the ridge alone two are needed
    let locked = lock(x, &knots, period, order, LOCK_NATURAL_ORDER)
        .or_else(|| lock(x, &knots, period, order, LOCK_WIDE_NATURAL_ORDER));
    let (mut theta, passes) = match locked {
        Some(locked) => (locked, 1),
        None => (knots, 2),
    };
    for _ in 0..passes {
        theta = demodulate(x, &theta, period, order);
    }
    if let Some(w) = theta.windows(2).find(|w| w[1].1 <= w[0].1) {
        return Err(SignalError::Invalid(format!(
            "the tracked shaft angle stops or runs backwards near sample {:.0}: the speed varies faster than mesh-phase tracking can follow (give a tachometer channel)",
            w[0].0
        )));
    }
    // the first and last knots are extrapolated: starts come from the measured interior
    let starts = integer_crossings(&theta[1..theta.len().saturating_sub(1).max(1)]);
    if starts.len() < 3 {
        return Err(SignalError::TooShort {
            what: "mesh-phase tracking (2 revolutions)".into(),
            needed: (3.0 * period) as usize,
            got: x.len(),
        });
    }
    Ok(Tracked { map: AngleMap::from_pulses(&starts, 1), line_snr_db, locked: passes == 1 })
}

/// Amplitudes of the lines of `x` near shaft order `order`, over the whole tracked record: the angle-domain
/// baseband y_b = mean of x(n) exp(-i 2 pi order theta(n)) over each 1/`per_rev` of a revolution (theta
/// from `map`, linear within a block), Hann-windowed and transformed with 8 times zero padding. Entry m of
/// the result is the amplitude (peak, unit of x) of the line at `order + offset(m)` orders, with
/// offset(m) = m per_rev / M for m < M/2 and (m - M) per_rev / M above (M = the result's length): a
/// line of amplitude A at order + d reads A at the bin nearest d (within 0.5 % for the zero padding).
pub fn baseband_lines<T: Sample>(fft: &mut Fft, x: &[T], map: &AngleMap, order: f64, per_rev: usize) -> Vec<f64> {
    baseband_lines_over(fft, x, map, order, per_rev, 0..map.revolutions())
}

/// [`baseband_lines`] over the revolutions `revs` of `map` only (a part of a long record: the result's
/// resolution is 1 / `revs.len()` orders and its memory that of the part).
pub fn baseband_lines_over<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    map: &AngleMap,
    order: f64,
    per_rev: usize,
    revs: std::ops::Range<usize>,
) -> Vec<f64> {
    use std::f64::consts::TAU;
    let nb = revs.len() * per_rev;
    if nb < 8 || revs.end > map.revolutions() {
        return Vec::new();
    }
    let first = revs.start * per_rev;
    let mut edges = vec![0.0; nb + 1];
    map.fill_positions(revs.start as f64, 1.0 / per_rev as f64, &mut edges);
    let m = (8 * nb).next_power_of_two();
    let mut y = vec![(0.0, 0.0); nb];
    // the blocks are independent: summed in parallel; each gives its entry and its window weight
    let w: Vec<f64> = y
        .par_iter_mut()
        .with_min_len(256)
        .zip(edges.par_windows(2))
        .enumerate()
        .map(|(b, (y, e))| {
            let (i0, i1) = (e[0].ceil().max(0.0) as usize, (e[1].ceil().max(0.0) as usize).min(x.len()));
            if i1 <= i0 {
                return 0.0;
            }
            // angle (revolutions) at sample i: b / per_rev + (i - e0) / (e1 - e0) / per_rev
            let slope = 1.0 / ((e[1] - e[0]) * per_rev as f64);
            let th0 = (first + b) as f64 / per_rev as f64 + (i0 as f64 - e[0]) * slope;
            let (sr, si) = phasor_sum(&x[i0..i1], th0, slope, order);
            let w = 0.5 - 0.5 * (TAU * (b as f64 + 0.5) / nb as f64).cos();
            let k = (i1 - i0) as f64;
            // conjugated: the inverse transform of the conjugate is the conjugate of the forward transform
            *y = (w * sr / k, -w * si / k);
            w
        })
        .collect();
    let wsum: f64 = w.iter().sum();
    // zero-padded to m in the transform's own buffer
    fft.inverse_complex_magnitudes(&y, m).into_iter().map(|a| 2.0 * a / wsum).collect()
}

/// Knots (sample index, angle in revolutions) of the ridge stage and the median line-to-band ratio.
fn ridge<T: Sample>(x: &[T], period: f64, order: f64) -> Result<(Vec<(f64, f64)>, f64), SignalError> {
    let n = x.len();
    let mut nw = ((8.0 * period).ceil() as usize).next_power_of_two();
    while nw > n && nw as f64 >= 6.0 * period {
        nw /= 2;
    }
    if nw > n || (nw as f64) < 3.0 * period {
        return Err(SignalError::TooShort {
            what: format!("mesh-phase tracking (frames of 3 revolutions of {period:.1} samples)"),
            needed: (3.0 * period).ceil() as usize,
            got: n,
        });
    }
    let hop = nw / 4;
    let mut starts: Vec<usize> = (0..=(n - nw) / hop).map(|k| k * hop).collect();
    if starts.last().is_some_and(|&s| s + nw < n) {
        starts.push(n - nw);
    }
    let win = hann(nw);
    let bins_per_order = nw as f64 / period;
    let centre = order * bins_per_order;
    // only the bins within +-30 % of the nominal line and 2.5 orders more are kept (a run-up of +-20 % stays
    // inside): the rest of each frame's spectrum is never looked at
    let keep = (
        ((0.7 * centre - 2.5 * bins_per_order).floor().max(0.0) as usize).min(nw / 2),
        ((1.3 * centre + 2.5 * bins_per_order).ceil() as usize).min(nw / 2),
    );
    // the frames are independent: transformed in parallel, each thread with its own buffers
    let mags: Vec<Vec<f64>> = starts
        .par_iter()
        .map_init(
            || (Fft::new(), vec![0.0; nw]),
            |(fft, buf), &s| {
                for (b, (v, w)) in buf.iter_mut().zip(x[s..s + nw].iter().zip(&win)) {
                    *b = v.f() * w;
                }
                fft.forward_band_magnitudes(buf, keep.0..=keep.1)
            },
        )
        .collect();
    // bins searched: inside the kept range with a neighbour each side (entry i of a frame is bin keep.0 + i)
    let (bottom, top) = (keep.0 + 1, keep.1.saturating_sub(1));
    let bin = |m: &[f64], k: usize| m[k - keep.0];
    // the line is sought first within +-0.45 orders of the nominal (no neighbouring sideband reaches
    // there), in the frame where it is strongest; from there it is followed frame to frame
    let half = (0.45 * bins_per_order).max(1.0);
    let (lo, hi) = (((centre - half).floor() as usize).max(bottom), ((centre + half).ceil() as usize).min(top));
    if lo >= hi {
        return Err(SignalError::Invalid(format!("order {order} is outside the spectrum")));
    }
    let argmax = |m: &[f64], a: usize, b: usize| (a..=b).max_by(|&i, &j| bin(m, i).total_cmp(&bin(m, j))).unwrap_or(a);
    let first = (0..mags.len())
        .max_by(|&a, &b| bin(&mags[a], argmax(&mags[a], lo, hi)).total_cmp(&bin(&mags[b], argmax(&mags[b], lo, hi))))
        .unwrap_or(0);
    // the line's height is judged against the median of +-2 orders around it
    let (band_lo, band_hi) = (
        ((centre - 2.0 * bins_per_order).floor() as usize).max(bottom),
        ((centre + 2.0 * bins_per_order).ceil() as usize).min(top),
    );
    let reach = (0.35 * bins_per_order).ceil().max(1.0) as usize;
    let mut peak = vec![0.0; mags.len()];
    let mut ratio = vec![0.0; mags.len()];
    let mut follow = |f: usize, guess: usize| -> usize {
        let m = &mags[f];
        let k = argmax(m, guess.saturating_sub(reach).max(bottom), (guess + reach).min(top));
        let (y0, y1, y2) = (bin(m, k - 1).max(1e-300).ln(), bin(m, k).max(1e-300).ln(), bin(m, k + 1).max(1e-300).ln());
        let den = y0 - 2.0 * y1 + y2;
        peak[f] = k as f64 + if den < 0.0 { (0.5 * (y0 - y2) / den).clamp(-0.5, 0.5) } else { 0.0 };
        let (a, b) = (band_lo.min(k.saturating_sub(1)).max(bottom), band_hi.max(k + 1).min(top));
        let mut band: Vec<f64> = (a..=b).map(|i| bin(m, i)).collect();
        band.sort_by(f64::total_cmp);
        ratio[f] = bin(m, k) / band[band.len() / 2].max(1e-300);
        k
    };
    let k0 = follow(first, argmax(&mags[first], lo, hi));
    let mut k = k0;
    for f in first + 1..mags.len() {
        k = follow(f, k);
    }
    k = k0;
    for f in (0..first).rev() {
        k = follow(f, k);
    }
    ratio.sort_by(f64::total_cmp);
    let snr = ratio[ratio.len() / 2];
    // shaft speed in revolutions per sample at each frame centre, integrated (trapezoid) to knots
    let speed: Vec<(f64, f64)> =
        starts.iter().zip(&peak).map(|(&s, &p)| (s as f64 + nw as f64 / 2.0, p / nw as f64 / order)).collect();
    Ok((comb::integrate(&speed, n), snr))
}

/// Fractional sample indices where the piecewise-linear angle crosses whole revolutions.
fn integer_crossings(theta: &[(f64, f64)]) -> Vec<f64> {
    let mut out = Vec::new();
    for w in theta.windows(2) {
        let (a, b) = (w[0], w[1]);
        let mut k = a.1.floor() + 1.0;
        while k <= b.1 {
            out.push(a.0 + (b.0 - a.0) * (k - a.1) / (b.1 - a.1));
            k += 1.0;
        }
    }
    out
}

#[cfg(test)]
mod tests;
