//! Stages 2 and 3 of the mesh-phase tracking (see the parent module): the phase-locked loop that holds the
//! line's phase around the ridge's angle, and the demodulation that corrects the angle by the line's own
//! phase.

use super::super::Sample;
use super::super::spectrum::phasor_sum;
use rayon::prelude::*;

/// Sums of x exp(-i 2 pi m theta) over blocks of a sixteenth of the nominal revolution `period`, theta from
/// knots (linear in between, the last segment extended beyond the last knot) and linear within a block.
pub(super) struct Blocks {
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
pub(super) const LOCK_NATURAL_ORDER: f64 = 0.4;
/// Natural frequency of the second try of [`lock`] when the first loop lost the line, orders: a speed that
/// wanders by 1.7 % within a few revolutions (the hold-out's 27/35 machine, followed at order 243 from
/// the mesh comb's ridge) swings the line faster than a loop of 0.4 orders holds (its two directions over
/// half a cycle apart on 44-99 % of the blocks); at 0.6-0.8 orders both directions agree and the angle
/// is within 0.01 mesh cycles rms of the tachometer's, and at 1.2 the wider noise bandwidth (4 orders)
/// loses a line 20 dB over its band. Tried only after the first, so a line held at 0.4 keeps its lower
/// noise.
pub(super) const LOCK_WIDE_NATURAL_ORDER: f64 = 0.7;
/// Damping ratio of the loop (the usual 1/sqrt 2: the fastest response without overshoot to speak of).
pub(super) const LOCK_DAMPING: f64 = std::f64::consts::FRAC_1_SQRT_2;
/// Revolutions over which the forward and the backward loop hand over at the ends of the record (a loop
/// settles in about 1 / (zeta f_n) = 3.5 revolutions from the state it starts with).
pub(super) const LOCK_SETTLE_REVS: f64 = 4.0;
/// Largest share of the blocks where the forward and the backward loop may be over half a cycle apart.
/// On the generated gearboxes of another physics (tests/unseen_machines.rs) a loop that holds the line
/// is apart on at most 3 % (both directions starting their lock), one that lost it on 35-99 %.
pub(super) const LOCK_MAX_APART: f64 = 0.1;

/// The phase-locked stage between the ridge and the demodulation passes: the mesh line's phase around the
/// ridge's angle `theta`, followed block by block (a sixteenth of a revolution) by a second-order
/// phase-locked loop run forward and backward and averaged (the lags of the two directions cancel),
/// then smoothed by the two moving averages of two revolutions (which take out the shaft's sidebands
/// that the loop follows). The ridge's frames span 8-16 revolutions and do not follow a speed
/// fluctuation of a few revolutions; around its angle the line then swings by more than the
/// demodulation's +-0.5 orders, which slips cycles; the loop re-centres itself on the line as it goes.
/// Returns knots at the block centres; `None` when the two directions do not agree (the line is too
/// weak against its sidebands and noise to be locked on).
pub(super) fn lock<T: Sample>(
    x: &[T],
    theta: &[(f64, f64)],
    period: f64,
    order: f64,
    natural_order: f64,
) -> Option<Vec<(f64, f64)>> {
    use std::f64::consts::TAU;
    let blocks = Blocks::of(x, theta, period, order);
    let nb = blocks.sums.len();
    let per_rev = period / blocks.len as f64;
    if nb < (4.0 * per_rev) as usize {
        return None;
    }
    let wn = TAU * natural_order / per_rev;
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
pub(super) fn phase_lock(z: &[(f64, f64)], a: f64, gains: (f64, f64), per_rev: f64) -> Vec<f64> {
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
pub(super) fn demodulate<T: Sample>(x: &[T], theta: &[(f64, f64)], period: f64, order: f64) -> Vec<(f64, f64)> {
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
pub(super) fn moving_average(v: &[(f64, f64)], w: usize) -> Vec<(f64, f64)> {
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
