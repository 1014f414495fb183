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
//! 2. *Lock*: the line's phase around theta0, in blocks of a sixteenth of a revolution, is followed by a
//!    second-order phase-locked loop (natural frequency 0.4 orders) run forward and backward and
//!    averaged, then smoothed by the moving averages of stage 3 (applied twice), which take out the shaft
//!    sidebands the loop follows. At a high mesh harmonic a 1 % fluctuation of a cycle per 8 revolutions
//!    swings the line by more than +-1 order around theta0, past what stage 3 can hold: without the loop,
//!    the tracked angle slipped whole cycles of the harmonic (0.3-2 mesh cycles rms on the generated
//!    gearboxes of tests/unseen_machines.rs; with it 0.004-0.012, as their tachometer's angle). When the
//!    two directions disagree (a line too weak against its sidebands and noise), the ridge's angle goes on.
//! 3. *Demodulation*: x(t) exp(-i 2 pi m theta(t)) brings the line to 0 Hz and its sidebands to multiples
//!    of the shaft frequency f1; a cascade of two moving averages over two revolutions (zeros at every
//!    multiple of f1 / 2) keeps the line alone, and its phase psi(t) corrects the angle:
//!    theta(t) += (psi(t) - psi0) / (2 pi m). Once after the lock (twice from the ridge alone, the
//!    second time around the first result), so the angle follows speed changes slower than f1 / 2.
//!
//! Revolutions start where theta crosses an integer; [`AngleMap`] interpolates between the starts.

use super::spectrum::{Fft, hann, phasor_sum};
use super::tsa::AngleMap;
use super::{Sample, SignalError};
use rayon::prelude::*;

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
    let (mut theta, passes) = match lock(x, &knots, period, order) {
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
    Ok(Tracked { map: AngleMap::from_pulses(&starts, 1), line_snr_db })
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
    let mut y = vec![(0.0, 0.0); m];
    // the blocks are independent: summed in parallel; each gives its entry and its window weight
    let w: Vec<f64> = y[..nb]
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
    fft.inverse_complex(&mut y);
    y.iter().map(|c| 2.0 * (c.0 * c.0 + c.1 * c.1).sqrt() / wsum).collect()
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
            || (Fft::new(), vec![0.0; nw], Vec::new()),
            |(fft, buf, spec), &s| {
                for (b, (v, w)) in buf.iter_mut().zip(x[s..s + nw].iter().zip(&win)) {
                    *b = v.f() * w;
                }
                fft.forward(buf, spec);
                spec[keep.0..=keep.1].iter().map(|c| (c.0 * c.0 + c.1 * c.1).sqrt()).collect()
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
    let mut knots = vec![(0.0, 0.0), (speed[0].0, speed[0].1 * speed[0].0)];
    for w in speed.windows(2) {
        let th = knots[knots.len() - 1].1 + 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0);
        knots.push((w[1].0, th));
    }
    let (t_last, v_last) = speed[speed.len() - 1];
    let th = knots[knots.len() - 1].1 + v_last * (n as f64 - t_last);
    knots.push((n as f64, th));
    knots.dedup_by(|b, a| b.0 <= a.0);
    Ok((knots, snr))
}

/// Sums of x exp(-i 2 pi m theta) over blocks of a sixteenth of the nominal revolution `period`, theta from
/// knots (linear in between, the last segment extended beyond the last knot) and linear within a block.
struct Blocks {
    /// Samples per block.
    len: usize,
    /// The block sums.
    sums: Vec<(f64, f64)>,
    /// theta at each block's centre, revolutions.
    mid: Vec<f64>,
}

impl Blocks {
    fn of<T: Sample>(x: &[T], theta: &[(f64, f64)], period: f64, order: f64) -> Self {
        let n = x.len();
        let len = ((period / 16.0) as usize).max(1);
        let nb = n / len;
        let at = |i: f64| -> f64 {
            let seg = theta.partition_point(|k| k.0 <= i).saturating_sub(1).min(theta.len().saturating_sub(2));
            let (a, c) = (theta[seg], theta[seg + 1]);
            a.1 + (c.1 - a.1) * (i - a.0) / (c.0 - a.0)
        };
        // the blocks are independent: summed in parallel
        let (sums, mid) = (0..nb)
            .into_par_iter()
            .with_min_len(256)
            .map(|b| {
                let (i0, i1) = (b * len, (b + 1) * len);
                let (th0, th1) = (at(i0 as f64), at(i1 as f64));
                // the angle is linear within the block to the accuracy that matters
                (
                    phasor_sum(&x[i0..i1], th0, (th1 - th0) / len as f64, order),
                    0.5 * (th0 + th1 - (th1 - th0) / len as f64),
                )
            })
            .unzip();
        Self { len, sums, mid }
    }

    /// Knots (sample, revolutions) at the centres of the blocks `range`: theta plus `phase(b)` (cycles of
    /// `order`) over `order`, with the end speeds held out to sample 0 and `n` (used by a next pass only:
    /// revolution starts come from the interior knots). `None` with fewer than two blocks.
    fn knots(
        &self,
        range: std::ops::Range<usize>,
        phase: impl Fn(usize) -> f64,
        order: f64,
        n: usize,
    ) -> Option<Vec<(f64, f64)>> {
        let mut out: Vec<(f64, f64)> = range
            .map(|b| ((b * self.len) as f64 + 0.5 * (self.len as f64 - 1.0), self.mid[b] + phase(b) / order))
            .collect();
        if out.len() < 2 {
            return None;
        }
        let (a, b) = (out[0], out[1]);
        let (c, d) = (out[out.len() - 2], out[out.len() - 1]);
        out.insert(0, (0.0, a.1 - a.0 * (b.1 - a.1) / (b.0 - a.0)));
        out.push((n as f64, d.1 + (n as f64 - d.0) * (d.1 - c.1) / (d.0 - c.0)));
        Some(out)
    }
}

/// Natural frequency of the phase-locked loop of [`lock`], orders of the shaft (cycles per revolution).
/// A speed fluctuation of a cycle per 8 revolutions (1.5 Hz at 12 Hz) at a mesh harmonic of order 124
/// swings the line by +-1.2 orders at 1 % and its phase by +-1.6 cycles around the ridge's angle; a
/// second-order loop leaves (f / f_n)^2 of that, 0.16 cycles at 0.4 orders: inside what the
/// demodulation passes then take in. Its noise bandwidth is 3.3 f_n (1.3 orders).
const LOCK_NATURAL_ORDER: f64 = 0.4;
/// Damping ratio of the loop (the usual 1/sqrt 2: the fastest response without overshoot to speak of).
const LOCK_DAMPING: f64 = std::f64::consts::FRAC_1_SQRT_2;
/// Revolutions over which the forward and the backward loop hand over at the ends of the record (a loop
/// settles in about 1 / (zeta f_n) = 3.5 revolutions from the state it starts with).
const LOCK_SETTLE_REVS: f64 = 4.0;
/// Largest share of the blocks where the forward and the backward loop may be over half a cycle apart.
/// On the generated gearboxes of another physics (tests/unseen_machines.rs) a loop that holds the line
/// is apart on at most 3 % (both directions starting their lock), one that lost it on 35-99 %.
const LOCK_MAX_APART: f64 = 0.1;

/// The phase-locked stage between the ridge and the demodulation passes: the mesh line's phase around the
/// ridge's angle `theta`, followed block by block (a sixteenth of a revolution) by a second-order
/// phase-locked loop run forward and backward and averaged (the lags of the two directions cancel),
/// then smoothed by the two moving averages of two revolutions (which take out the shaft's sidebands
/// that the loop follows). The ridge's frames span 8-16 revolutions and do not follow a speed
/// fluctuation of a few revolutions; around its angle the line then swings by more than the
/// demodulation's +-0.5 orders, which slips cycles; the loop re-centres itself on the line as it goes.
/// Returns knots at the block centres; `None` when the two directions do not agree (the line is too
/// weak against its sidebands and noise to be locked on).
fn lock<T: Sample>(x: &[T], theta: &[(f64, f64)], period: f64, order: f64) -> Option<Vec<(f64, f64)>> {
    use std::f64::consts::TAU;
    let blocks = Blocks::of(x, theta, period, order);
    let nb = blocks.sums.len();
    let per_rev = period / blocks.len as f64;
    if nb < (4.0 * per_rev) as usize {
        return None;
    }
    let wn = TAU * LOCK_NATURAL_ORDER / per_rev;
    let gains = (2.0 * LOCK_DAMPING * wn, wn * wn);
    let reversed: Vec<(f64, f64)> = blocks.sums.iter().rev().copied().collect();
    let both = |a: f64| -> (Vec<f64>, Vec<f64>) {
        let mut back = phase_lock(&reversed, a, gains, per_rev);
        back.reverse();
        (phase_lock(&blocks.sums, a, gains, per_rev), back)
    };
    // the line's amplitude per block: first the blocks' rms (line and noise), then the coherent mean of
    // the blocks turned back by the phase the loops found (the noise averages out)
    let rms = (blocks.sums.iter().map(|z| z.0 * z.0 + z.1 * z.1).sum::<f64>() / nb as f64).sqrt();
    let (fwd, back) = both(rms.max(f64::MIN_POSITIVE));
    let coherent = |phase: &[f64]| {
        let (re, im) = blocks.sums.iter().zip(phase).fold((0.0, 0.0), |(re, im), (z, p)| {
            let (s, c) = (TAU * p).sin_cos();
            (re + z.0 * c + z.1 * s, im + z.1 * c - z.0 * s)
        });
        (re * re + im * im).sqrt() / nb as f64
    };
    let amplitude = coherent(&fwd).max(coherent(&back));
    let (fwd, back) = if amplitude > 0.0 { both(amplitude) } else { (fwd, back) };
    // the two directions lock on the same line: whole cycles apart at most (their starting phases)
    let mut offsets: Vec<f64> = fwd.iter().zip(&back).map(|(f, b)| (f - b).round()).collect();
    offsets.sort_by(f64::total_cmp);
    let offset = offsets[nb / 2];
    // a loop that lost the line drifts off it, each direction its own way: over half a cycle apart on
    // more than a tenth of the record, neither is trusted
    let apart = fwd.iter().zip(&back).filter(|(f, b)| (*f - *b - offset).abs() > 0.5).count();
    if apart as f64 > LOCK_MAX_APART * nb as f64 {
        return None;
    }
    let settle = LOCK_SETTLE_REVS * per_rev;
    let phase: Vec<(f64, f64)> = (0..nb)
        .map(|b| {
            let (wf, wb) = (((b + 1) as f64 / settle).min(1.0), ((nb - b) as f64 / settle).min(1.0));
            ((wf * fwd[b] + wb * (back[b] + offset)) / (wf + wb), 0.0)
        })
        .collect();
    // the two moving averages of two revolutions, applied twice (to the phase, then to what they left of
    // it: 2H - H^2): the loop's shaft sidebands out (H = 0 at every half order), a swing over 8
    // revolutions kept to 96 % (H alone keeps 81 %, and the 0.2 cycles it would leave at order 124 turn
    // into harmonics of the swing in the demodulation's phasor averages, which no pass takes out)
    let width = ((2.0 * per_rev).round() as usize).max(1) | 1;
    let once = moving_average(&moving_average(&phase, width), width);
    let rest: Vec<(f64, f64)> = phase.iter().zip(&once).map(|(p, s)| (p.0 - s.0, 0.0)).collect();
    let again = moving_average(&moving_average(&rest, width), width);
    blocks.knots(0..nb, |b| once[b].0 + again[b].0, order, x.len())
}

/// A second-order phase-locked loop over the block sums `z` of a line of amplitude `a` per block: the
/// phase (cycles) after each block. The phase detector is the sine of the error, the block's component
/// across the predicted phasor over `a` (clamped to +-1, so a shock does not throw the loop); `gains`
/// (proportional, integral) per block. It starts on the phase of the first two revolutions' sum
/// (`per_rev` blocks each) with the ridge's speed (no frequency of its own).
fn phase_lock(z: &[(f64, f64)], a: f64, gains: (f64, f64), per_rev: f64) -> Vec<f64> {
    use std::f64::consts::TAU;
    let start = z.iter().take((2.0 * per_rev) as usize).fold((0.0, 0.0), |s, v| (s.0 + v.0, s.1 + v.1));
    let mut phase = start.1.atan2(start.0) / TAU;
    let mut rate = 0.0;
    z.iter()
        .map(|&(re, im)| {
            let p = phase + rate;
            let (s, c) = (TAU * p).sin_cos();
            let error = ((im * c - re * s) / a).clamp(-1.0, 1.0) / TAU;
            phase = p + gains.0 * error;
            rate += gains.1 * error;
            phase
        })
        .collect()
}

/// One demodulation pass around the angle `theta` (knots, linear in between): block sums of
/// x exp(-i 2 pi m theta), two moving averages over two revolutions, phase correction. Returns knots at
/// the centres of the blocks whose averaging window lies inside the record.
fn demodulate<T: Sample>(x: &[T], theta: &[(f64, f64)], period: f64, order: f64) -> Vec<(f64, f64)> {
    use std::f64::consts::{PI, TAU};
    let blocks = Blocks::of(x, theta, period, order);
    let nb = blocks.sums.len();
    // odd, so the averages are centred on their block
    let width = ((2.0 * period / blocks.len as f64).round() as usize).max(1) | 1;
    let smooth = moving_average(&moving_average(&blocks.sums, width), width);
    let skip = width; // two windows of width/2 each side
    let range = skip..nb.saturating_sub(skip);
    let mut unwrapped = vec![0.0; nb];
    for b in range.clone() {
        let psi = smooth[b].1.atan2(smooth[b].0);
        unwrapped[b] = if b == skip {
            psi
        } else {
            let last = smooth[b - 1].1.atan2(smooth[b - 1].0);
            unwrapped[b - 1] + (psi - last + PI).rem_euclid(TAU) - PI
        };
    }
    blocks.knots(range, |b| unwrapped[b] / TAU, order, x.len()).unwrap_or_else(|| theta.to_vec())
}

/// Centred moving average of `w` points (shrinking at the ends).
fn moving_average(v: &[(f64, f64)], w: usize) -> Vec<(f64, f64)> {
    let mut prefix = vec![(0.0, 0.0); v.len() + 1];
    for (i, x) in v.iter().enumerate() {
        prefix[i + 1] = (prefix[i].0 + x.0, prefix[i].1 + x.1);
    }
    (0..v.len())
        .map(|i| {
            let lo = i.saturating_sub(w / 2);
            let hi = (lo + w).min(v.len());
            let k = (hi - lo) as f64;
            ((prefix[hi].0 - prefix[lo].0) / k, (prefix[hi].1 - prefix[lo].1) / k)
        })
        .collect()
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
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    /// The wander of speeds spread evenly over 1 +- 1 % is 0.8 % (the 10th and 90th percentiles of a
    /// uniform spread), and two misread revolutions among a hundred do not move it.
    #[test]
    fn wander_is_the_half_range_between_the_speeds_deciles() {
        let even: Vec<f64> = (0..=100).map(|i| 0.99 + 0.02 * i as f64 / 100.0).collect();
        assert!((wander(&even) - 0.008).abs() < 1e-12, "{}", wander(&even));
        let mut misread = even.clone();
        misread[3] = 2.0;
        misread[60] = 0.1;
        assert!((wander(&misread) - 0.008).abs() < 2e-4, "{}", wander(&misread));
        assert_eq!(wander(&[]), 0.0);
    }

    /// A mesh of 14 teeth on a shaft whose speed follows `rate(t)` (revolutions per sample), with
    /// sidebands at +-1 shaft order, noise-free; returns the samples and the true angle at each sample.
    fn mesh_signal(n: usize, rate: impl Fn(f64) -> f64) -> (Vec<f64>, Vec<f64>) {
        let mut th = 0.0;
        let mut angle = Vec::with_capacity(n);
        let x = (0..n)
            .map(|i| {
                angle.push(th);
                let v = (TAU * 14.0 * th).cos() + 0.3 * (TAU * 13.0 * th).cos() + 0.2 * (TAU * th).sin();
                th += rate(i as f64);
                v
            })
            .collect();
        (x, angle)
    }

    /// A line at order 14 + 14/39 (a wheel sideband) of amplitude 0.3 beside a mesh line of amplitude 1, on
    /// a shaft whose speed drifts by 1 %: read at its bin within 1 % (the 8-fold zero padding leaves at
    /// most 1/16 bin, 0.6 % of Hann scalloping), and a bin with no line far below it.
    #[test]
    fn baseband_lines_read_a_sideband_on_a_drifting_shaft() {
        let n = 200_000;
        let rate = |i: f64| (1.0 + 0.01 * (i / n as f64)) / 333.3;
        let mut th = 0.0;
        let mut starts = Vec::new();
        let x: Vec<f64> = (0..n)
            .map(|i| {
                let next = th + rate(i as f64);
                if i == 0 || next.floor() > th.floor() {
                    starts.push(if i == 0 { 0.0 } else { i as f64 + (next.floor() - th) / (next - th) });
                }
                let v = (TAU * 14.0 * th).cos() + 0.3 * (TAU * (14.0 + 14.0 / 39.0) * th + 0.4).cos();
                th = next;
                v
            })
            .collect();
        let map = AngleMap::from_pulses(&starts, 1);
        let a = baseband_lines(&mut Fft::new(), &x, &map, 14.0, 16);
        let bin = |d: f64| ((d * a.len() as f64 / 16.0).round() as isize).rem_euclid(a.len() as isize) as usize;
        assert!((a[bin(0.0)] - 1.0).abs() < 0.01, "{}", a[bin(0.0)]);
        assert!((a[bin(14.0 / 39.0)] - 0.3).abs() < 0.003, "{}", a[bin(14.0 / 39.0)]);
        assert!(a[bin(-14.0 / 39.0)] < 1e-3, "{}", a[bin(-14.0 / 39.0)]);
        // over a part of the record (revolutions 150..450): the same lines at the part's resolution, and
        // the whole range is the whole record's result
        let p = baseband_lines_over(&mut Fft::new(), &x, &map, 14.0, 16, 150..450);
        let pbin = |d: f64| ((d * p.len() as f64 / 16.0).round() as isize).rem_euclid(p.len() as isize) as usize;
        assert!((p[pbin(0.0)] - 1.0).abs() < 0.01, "{}", p[pbin(0.0)]);
        assert!((p[pbin(14.0 / 39.0)] - 0.3).abs() < 0.003, "{}", p[pbin(14.0 / 39.0)]);
        assert!(p[pbin(-14.0 / 39.0)] < 1e-3, "{}", p[pbin(-14.0 / 39.0)]);
        assert_eq!(baseband_lines_over(&mut Fft::new(), &x, &map, 14.0, 16, 0..map.revolutions()), a);
        assert!(baseband_lines_over(&mut Fft::new(), &x, &map, 14.0, 16, 0..map.revolutions() + 1).is_empty());
    }

    /// Largest error of the revolution starts against the true angle, in revolutions.
    fn start_error(map: &AngleMap, angle: &[f64]) -> f64 {
        let starts = map.starts();
        // the tracked origin is the mesh phase: compare angle increments from the first start
        let at = |s: f64| {
            let i = s as usize;
            angle[i] + (angle[i + 1] - angle[i]) * (s - i as f64)
        };
        let a0 = at(starts[0]);
        starts.iter().enumerate().map(|(k, &s)| (at(s) - a0 - k as f64).abs()).fold(0.0, f64::max)
    }

    #[test]
    fn follows_a_twenty_percent_run_up() {
        // 100 samples per revolution at the start, 80 at the end (+25 % speed), over 300 revolutions
        let n = 27_000;
        let rate = |i: f64| 0.01 * (1.0 + 0.25 * i / n as f64);
        let (x, angle) = mesh_signal(n, rate);
        let t = track_mesh(&x, 90.0, 14.0).unwrap();
        // noise-free: measured 2.6e-4 rev, from sideband leakage through the moving averages whose zeros
        // miss the changing shaft frequency. 5e-4 rev is 0.044 rad of mesh phase at order 14: a TSA loses
        // 0.1 % of the mesh amplitude to it (a mesh period is 0.07 rev)
        let e = start_error(&t.map, &angle);
        assert!(e < 5e-4, "start error {e} rev");
        let p = SpeedProfile::of(&t.map);
        assert!((p.change - 0.25 / 1.125).abs() < 0.03, "{p:?}");
    }

    #[test]
    fn follows_slow_random_fluctuation() {
        // 1 % speed fluctuation of a few slow sinusoids
        let n = 60_000;
        let rate = |i: f64| 0.01 * (1.0 + 0.006 * (i / 7000.0).sin() + 0.004 * (i / 2300.0 + 1.0).cos());
        let (x, angle) = mesh_signal(n, rate);
        let t = track_mesh(&x, 100.0, 14.0).unwrap();
        // as above
        let e = start_error(&t.map, &angle);
        assert!(e < 5e-4, "start error {e} rev");
        assert!(t.line_snr_db > 20.0);
    }

    #[test]
    fn pulse_jitter_is_smoothed_and_a_run_up_kept() {
        // revolution k starts at t(k) = 300 k - 0.3 k^2 (a steady run-up), edges rounded to whole samples
        let truth: Vec<f64> = (0..200).map(|k| 300.0 * k as f64 - 0.3 * (k * k) as f64 / 2.0).collect();
        let pulses: Vec<f64> = truth.iter().map(|t| t.round()).collect();
        let map = from_pulses(&pulses, 1).unwrap();
        let err = |s: &[f64]| (s.iter().zip(&truth).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / s.len() as f64).sqrt();
        // rounding jitter is uniform in +-0.5 (rms 0.29 sample); the fit's noise gain is 0.36 in the
        // interior and up to about 0.6 at the ends: the rms error must fall below 0.6 of the raw one
        assert!(err(map.starts()) < 0.6 * err(&pulses), "{} vs {}", err(map.starts()), err(&pulses));
    }

    #[test]
    fn a_fast_speed_fluctuation_is_kept_and_the_jitter_still_smoothed() {
        // 1000 samples per revolution with a 2 % speed fluctuation of one cycle per 16 revolutions (1.5 Hz
        // at 1480 rpm): revolution k starts at t(k) = 1000 (k + a sin(2 pi k / 16)), the closed form of a
        // phase modulation whose speed swings by 2 pi a / 16 = 2 %; edges rounded to whole samples
        let a = 0.02 * 16.0 / std::f64::consts::TAU;
        let truth: Vec<f64> = (0..300).map(|k| 1000.0 * (k as f64 + a * (TAU * k as f64 / 16.0).sin())).collect();
        let pulses: Vec<f64> = truth.iter().map(|t| t.round()).collect();
        let map = from_pulses(&pulses, 1).unwrap();
        let err = |s: &[f64]| (s.iter().zip(&truth).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / s.len() as f64).sqrt();
        // the 17-revolution fit misses the fluctuation by samples (its residual is 4 samples rms on the
        // test generator's gearbox); a window that follows it leaves the rounding jitter (0.29 sample rms)
        // reduced by its noise gain (0.58 for 7 revolutions) plus a bias of a tenth of a sample: below the
        // raw edges' error
        assert!(err(map.starts()) < err(&pulses), "{} vs {}", err(map.starts()), err(&pulses));
        assert!(err(&quadratic_fit(&pulses, 17).0) > 1.0, "the widest window would have smoothed the fluctuation away");
    }

    #[test]
    fn missing_pulses_are_refused() {
        let mut p: Vec<f64> = (0..20).map(|k| k as f64 * 100.0).collect();
        p.remove(7);
        let e = from_pulses(&p, 1).unwrap_err().to_string();
        assert!(e.contains("missing"), "{e}");
        assert!(from_pulses(&[0.0, 100.0], 1).is_err());
    }

    /// The phase-locked loop against its own linear theory: for a small phase modulation theta_b = a sin(w b)
    /// the loop's error e = theta - prediction has the transfer E / Theta = (1 - u)^2 / (1 - (2 - K1 - K2) u +
    /// (1 - K1) u^2), u = exp(-i w) (from its recursion: prediction p_b = phase_(b-1) + rate_(b-1), phase_b =
    /// p_b + K1 e_b, rate_b = rate_(b-1) + K2 e_b), and the phase it returns, theta - (1 - K1) e, lags by
    /// that. A frequency offset (a phase ramp) is followed with no error left (a type-2 loop).
    #[test]
    fn the_phase_lock_follows_its_linear_theory() {
        let per_rev = 16.0;
        let wn = TAU * LOCK_NATURAL_ORDER / per_rev;
        let (k1, k2) = (2.0 * LOCK_DAMPING * wn, wn * wn);
        let n = 4000;
        for w in [0.02, 0.1, 0.4] {
            let a = 0.01;
            let theta: Vec<f64> = (0..n).map(|b| a * (w * b as f64).sin()).collect();
            let z: Vec<(f64, f64)> = theta.iter().map(|t| ((TAU * t).cos(), (TAU * t).sin())).collect();
            let phase = phase_lock(&z, 1.0, (k1, k2), per_rev);
            // the error's amplitude over the settled second half, by projection on sin and cos of w b
            let (mut s, mut c) = (0.0, 0.0);
            for b in n / 2..n {
                let e = theta[b] - phase[b];
                s += e * (w * b as f64).sin();
                c += e * (w * b as f64).cos();
            }
            let measured = 2.0 * (s * s + c * c).sqrt() / (n / 2) as f64 / a;
            // |1 - H| for the returned phase: theta - phase = (1 - K1) e (the correction takes K1 e)
            let u = ((-w).cos(), (-w).sin());
            let mul = |x: (f64, f64), y: (f64, f64)| (x.0 * y.0 - x.1 * y.1, x.0 * y.1 + x.1 * y.0);
            let u2 = mul(u, u);
            let num = (1.0 - 2.0 * u.0 + u2.0, -2.0 * u.1 + u2.1);
            let den = (1.0 - (2.0 - k1 - k2) * u.0 + (1.0 - k1) * u2.0, -(2.0 - k1 - k2) * u.1 + (1.0 - k1) * u2.1);
            let theory = (1.0 - k1) * ((num.0 * num.0 + num.1 * num.1) / (den.0 * den.0 + den.1 * den.1)).sqrt();
            // the projection over 2000 blocks leaves the transient (decayed by exp(-zeta wn 2000)) and a
            // leakage of 1 / (w 2000) at most relative; the detector's sine departs from its argument by
            // (2 pi e)^2 / 6 < 1e-3 relative for e < 0.01 cycles: 2 % covers both
            assert!((measured - theory).abs() < 0.02 * theory.max(1e-3), "w {w}: {measured} against {theory}");
        }
        // a phase ramp of 0.05 cycles per block: followed to rounding once settled
        let z: Vec<(f64, f64)> =
            (0..n).map(|b| ((TAU * 0.05 * b as f64).cos(), (TAU * 0.05 * b as f64).sin())).collect();
        let phase = phase_lock(&z, 1.0, (k1, k2), per_rev);
        let e = (phase[n - 1] - 0.05 * (n - 1) as f64).rem_euclid(1.0);
        assert!(e.min(1.0 - e) < 1e-9, "{e}");
    }

    /// A mesh harmonic at order 60 (15 teeth, fourth harmonic) with sidebands at +-1 order and noise, on a
    /// shaft whose speed swings by 1.5 % once every 8 revolutions (1.5 Hz at 12 Hz): the line's phase swings
    /// by +-1.15 cycles around a steady angle and its frequency by +-0.9 orders, beyond the demodulation's
    /// +-0.5 orders. Returns the samples and the true angle (revolutions) at each sample.
    fn fluctuating_mesh(n: usize, period: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
        let mut th = 0.0;
        let mut angle = Vec::with_capacity(n);
        let mut state = seed;
        let mut noise = move || {
            // a uniform in +-0.5 (xorshift), its rms 0.29
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let x = (0..n)
            .map(|_| {
                angle.push(th);
                let v = (TAU * 60.0 * th).cos()
                    + 0.3 * (TAU * 59.0 * th + 0.5).cos()
                    + 0.3 * (TAU * 61.0 * th + 1.0).cos()
                    + 0.5 * (TAU * th).sin()
                    + 0.35 * noise();
                th += (1.0 + 0.015 * (TAU * th / 8.0).sin()) / period;
                v
            })
            .collect();
        (x, angle)
    }

    /// Rms and largest error of the angle at 16 points per revolution (through [`AngleMap::sample_at`])
    /// against the true angle, in cycles of `order`, the origin removed.
    fn angle_error(map: &AngleMap, angle: &[f64], order: f64) -> (f64, f64) {
        let at = |s: f64| {
            let i = s as usize;
            angle[i] + (angle[i + 1] - angle[i]) * (s - i as f64)
        };
        let e: Vec<f64> =
            (0..map.revolutions() * 16).map(|j| j as f64 / 16.0).map(|r| at(map.sample_at(r)) - r).collect();
        let mean = e.iter().sum::<f64>() / e.len() as f64;
        let rms = (e.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / e.len() as f64).sqrt();
        (rms * order, e.iter().map(|v| (v - mean).abs()).fold(0.0, f64::max) * order)
    }

    #[test]
    fn follows_a_speed_fluctuation_of_a_few_revolutions_at_a_high_mesh_order() {
        let (n, period) = (60_000, 250.0);
        let (x, angle) = fluctuating_mesh(n, period, 7);
        let t = track_mesh(&x, period, 60.0).unwrap();
        let (rms, max) = angle_error(&t.map, &angle, 60.0);
        // measured 0.012 cycles rms and 0.063 at most (in the first revolution, where the averages are
        // one-sided): the loop leaves 0.1 of the +-1.15-cycle swing, the twice-applied averages 0.04 of
        // that and the demodulation passes 0.19^2 of the rest; the sidebands and the noise leak a little
        // through the averages whose zeros sit at whole orders of the mean speed. The ridge and the
        // demodulation alone slip whole cycles (below): 0.02 rms and 0.1 at most tell the two apart
        assert!(rms < 0.02 && max < 0.1, "error {rms} cycles rms, {max} at most (order 60)");
        // the ridge and the demodulation alone slip whole cycles of the line
        let r = mesh_ridge(&x, period, 60.0).unwrap();
        let mut theta = r.knots.clone();
        for _ in 0..2 {
            theta = demodulate(&x, &theta, period, 60.0);
        }
        let old = AngleMap::from_pulses(&integer_crossings(&theta[1..theta.len() - 1]), 1);
        let (old_rms, _) = angle_error(&old, &angle, 60.0);
        assert!(old_rms > 0.3, "{old_rms}");
    }

    /// A line too weak against its noise to be locked on: the two directions drift apart and the lock gives
    /// way (the ridge and the demodulation passes take over).
    #[test]
    fn a_line_lost_in_noise_is_not_locked() {
        let (n, period) = (60_000, 250.0);
        let (clean, _) = fluctuating_mesh(n, period, 9);
        // the line at 0.05 of noise of rms 2.9 (a tenth of the helper's noise, amplified 100 times)
        let mut state = 12345u64;
        let x: Vec<f64> = clean
            .iter()
            .map(|v| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                0.05 * v + 10.0 * ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
            })
            .collect();
        let r = mesh_ridge(&x, period, 60.0).unwrap();
        assert!(lock(&x, &r.knots, period, 60.0).is_none());
    }
}
