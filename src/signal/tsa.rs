//! Time-synchronous averaging in the shaft-angle domain, and the regular / residual / difference signals
//! by exact FFT bin masking.
//!
//! The record is resampled to shaft angle over whole revolutions with L points per revolution (L a power
//! of two), so order k of that shaft falls exactly on bin k of the averaged revolution. Resampling uses a
//! Kaiser-windowed sinc (band-limited, flat to ~1e-3 up to 0.35 cycles/sample); the angle comes from
//! revolution start times (a tachometer) or a constant period, linearly in between.

use super::interpolate::HALF;
pub use super::interpolate::Interpolator;
use super::spectrum::Fft;
use super::{Sample, SignalError};

/// Where each revolution of the reference shaft starts, as fractional sample indices.
#[derive(Clone, Debug, PartialEq)]
pub struct AngleMap {
    starts: Vec<f64>,
    /// (offset, period) in samples when the speed is constant.
    constant: Option<(f64, f64)>,
}

impl AngleMap {
    /// Constant speed: a revolution every `period_samples`, the first starting at `offset`.
    pub fn constant(period_samples: f64, offset: f64, samples: usize) -> Self {
        let revs = ((samples as f64 - 1.0 - offset) / period_samples).floor().max(0.0) as usize;
        Self {
            starts: (0..=revs).map(|k| offset + k as f64 * period_samples).collect(),
            constant: Some((offset, period_samples)),
        }
    }

    /// Revolution starts from tachometer pulses (every `per_rev`-th pulse starts a revolution).
    pub fn from_pulses(pulses: &[f64], per_rev: usize) -> Self {
        Self { starts: pulses.iter().step_by(per_rev.max(1)).copied().collect(), constant: None }
    }

    /// Revolution starts, fractional sample indices.
    pub fn starts(&self) -> &[f64] {
        &self.starts
    }

    /// Whole revolutions covered.
    pub fn revolutions(&self) -> usize {
        self.starts.len().saturating_sub(1)
    }

    /// Mean revolution length in samples.
    pub fn mean_period_samples(&self) -> f64 {
        let k = self.revolutions().max(1);
        (self.starts[self.starts.len() - 1] - self.starts[0]) / k as f64
    }

    /// Fractional sample index at reference-shaft angle `rev` (in revolutions from the first start): a
    /// Catmull-Rom cubic through the revolution starts, so a smoothly varying speed keeps the angle exact
    /// to third order within each revolution (linear at the two end revolutions).
    #[inline]
    pub fn sample_at(&self, rev: f64) -> f64 {
        let k = self.segment(rev);
        let c = self.cubic(k);
        let t = rev - k as f64;
        c[0] + t * (c[1] + t * (c[2] + t * c[3]))
    }

    /// Sample indices at the angles `rev0 + i step` (revolutions, `step` > 0) for every entry of `out`:
    /// [`sample_at`](Self::sample_at) with each revolution's cubic built once.
    pub fn fill_positions(&self, rev0: f64, step: f64, out: &mut [f64]) {
        self.fill_positions_from(rev0, step, 0, out);
    }

    /// [`fill_positions`](Self::fill_positions) for the entries `first ..` of a longer array.
    /// Runs of entries within one revolution are evaluated with that revolution's cubic in a loop of their
    /// own (no search per entry); an entry on the boundary may take either neighbour's cubic, which agree
    /// there.
    fn fill_positions_from(&self, rev0: f64, step: f64, first: usize, out: &mut [f64]) {
        let last = self.revolutions().saturating_sub(1);
        let mut i = 0;
        while i < out.len() {
            let k = self.segment(rev0 + (first + i) as f64 * step);
            let c = self.cubic(k);
            // entries before the next revolution's start (all the rest in the last revolution)
            let end = if k >= last {
                out.len()
            } else {
                let next = ((k + 1) as f64 - rev0) / step - first as f64;
                (next.ceil().max(0.0) as usize).clamp(i + 1, out.len())
            };
            for (j, o) in out[i..end].iter_mut().enumerate() {
                let t = rev0 + (first + i + j) as f64 * step - k as f64;
                *o = c[0] + t * (c[1] + t * (c[2] + t * c[3]));
            }
            i = end;
        }
    }

    /// `out[i]` = `x` at the angle `rev0 + i step` revolutions ([`Interpolator`]): blocks of `out` in
    /// parallel, each filled with its positions and then replaced by the values, so a record-long
    /// resampling holds no second array of its length.
    pub fn resample<T: Sample>(&self, x: &[T], rev0: f64, step: f64, out: &mut [f64]) {
        use rayon::prelude::*;
        const BLOCK: usize = 1 << 16;
        out.par_chunks_mut(BLOCK).enumerate().for_each_init(
            || vec![0.0; BLOCK],
            |at, (b, block)| {
                let at = &mut at[..block.len()];
                self.fill_positions_from(rev0, step, b * BLOCK, at);
                Interpolator::shared().fill(x, at, block);
            },
        );
    }

    /// The revolution whose cubic covers angle `rev` (the first or last outside the covered range).
    #[inline]
    fn segment(&self, rev: f64) -> usize {
        (rev.max(0.0) as usize).min(self.revolutions().saturating_sub(1))
    }

    /// Coefficients c of revolution k's Catmull-Rom cubic, sample = c0 + t (c1 + t (c2 + t c3)) for t in
    /// [0, 1]; the end revolutions take a mirrored neighbour (linear there).
    #[inline]
    fn cubic(&self, k: usize) -> [f64; 4] {
        let last = self.revolutions();
        let s = &self.starts;
        let (p1, p2) = (s[k], s[k + 1]);
        let p0 = if k > 0 { s[k - 1] } else { 2.0 * p1 - p2 };
        let p3 = if k + 2 <= last { s[k + 2] } else { 2.0 * p2 - p1 };
        [p1, 0.5 * (p2 - p0), 0.5 * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3), 0.5 * (3.0 * (p1 - p2) + p3 - p0)]
    }
}

/// An averaged revolution.
#[derive(Clone, Debug)]
pub struct Tsa {
    /// L samples over one revolution of the averaged shaft.
    pub samples: Vec<f64>,
    /// Revolutions averaged.
    pub revolutions: usize,
}

/// TSA of the shaft that turns `ratio` times per reference revolution, with `points` samples per
/// revolution; needs at least `min_revs` whole revolutions.
///
/// # Errors
/// [`SignalError::TooShort`] naming the revolutions needed.
pub fn tsa<T: Sample>(x: &[T], map: &AngleMap, ratio: f64, points: usize, min_revs: usize) -> Result<Tsa, SignalError> {
    let revs = revolutions_of(map, ratio);
    if revs < min_revs {
        let per_rev = map.mean_period_samples() / ratio;
        let needed = (min_revs as f64 * per_rev).ceil() as usize + 2;
        if needed <= x.len() {
            // the record is long enough but the angle does not cover it (a tracked angle ends where the
            // line could be followed, a pulse train at its first and last pulse): say so, not "too short"
            let (a, b) = (map.sample_at(0.0), map.sample_at(map.revolutions() as f64));
            return Err(SignalError::Invalid(format!(
                "time-synchronous average: {revs} whole revolutions of {per_rev:.1} samples lie within the followed angle (samples {a:.0} to {b:.0} of {}), {min_revs} are needed",
                x.len()
            )));
        }
        return Err(SignalError::TooShort {
            what: format!("time-synchronous average ({min_revs} revolutions of {per_rev:.1} samples)"),
            needed,
            got: x.len(),
        });
    }
    let interp = Interpolator::shared();
    if let Some((offset, period)) = map.constant {
        return Ok(Tsa { samples: tsa_constant(x, interp, offset, period / ratio, revs, points), revolutions: revs });
    }
    Ok(Tsa { samples: tsa_of_revolutions(x, map, ratio, points, 0..revs), revolutions: revs })
}

/// [`tsa`] of several channels sampled alike and, in the same pass, the averages of consecutive blocks of
/// `block_revs` revolutions (the revolutions after the last whole block count in the full average only),
/// each handed to `on_block` as it completes (with an `Fft` of its thread, the channel's index in `xs` and the
/// block's index from the recording's start):
/// what it returns is kept, the block's average is not (a 60 s recording's blocks of four channels would
/// hold 20 MB). Each revolution's sample positions and interpolation taps are found once for all
/// channels, and runs of whole blocks are averaged in parallel; the full averages sum the runs' partial
/// sums in order, so the result does not depend on the threads.
///
/// # Errors
/// As [`tsa`].
pub fn tsa_with_blocks<T: Sample, B: Send>(
    xs: &[&[T]],
    map: &AngleMap,
    ratio: f64,
    points: usize,
    min_revs: usize,
    block_revs: usize,
    on_block: impl Fn(&mut Fft, usize, usize, &[f64]) -> B + Sync,
) -> Result<Vec<(Tsa, Vec<B>)>, SignalError> {
    use rayon::prelude::*;
    let per = block_revs.max(1);
    let revs = revolutions_of(map, ratio);
    if map.constant.is_some() || revs < min_revs {
        // constant speed (class sums, see `tsa_constant`), or too few revolutions (the error)
        let mut fft = Fft::new();
        return xs
            .iter()
            .enumerate()
            .map(|(k, x)| {
                let full = tsa(x, map, ratio, points, min_revs)?;
                let blocks = (0..full.revolutions / per)
                    .map(|b| {
                        on_block(&mut fft, k, b, &tsa_of_revolutions(x, map, ratio, points, b * per..(b + 1) * per))
                    })
                    .collect();
                Ok((full, blocks))
            })
            .collect();
    }
    // runs of whole blocks (about 16 per call, so two cores share them evenly); the revolutions after the
    // last whole block join the last run and count in the full averages only
    let blocks = revs / per;
    let run_blocks = blocks.div_ceil(16).max(1);
    let runs: Vec<std::ops::Range<usize>> = (0..blocks.div_ceil(run_blocks).max(1))
        .map(|r| r * run_blocks * per..((r + 1) * run_blocks * per).min(blocks * per))
        .collect();
    let last = runs.len() - 1;
    // per run: each channel's partial sum of revolutions and its finished blocks
    type Run<B> = (Vec<Vec<f64>>, Vec<Vec<B>>);
    let parts: Vec<Run<B>> = runs
        .into_par_iter()
        .enumerate()
        .map(|(r, range)| {
            let range = if r == last { range.start..revs } else { range };
            let interp = Interpolator::shared();
            let mut fft = Fft::new();
            let mut full = vec![vec![0.0; points]; xs.len()];
            let mut block = vec![vec![0.0; points]; xs.len()];
            let mut values = vec![vec![0.0; points]; xs.len()];
            let mut done: Vec<Vec<B>> = (0..xs.len()).map(|_| Vec::new()).collect();
            let mut at = vec![0.0; points];
            for j in range {
                map.fill_positions(j as f64 / ratio, 1.0 / (points as f64 * ratio), &mut at);
                interp.fill_many(xs, &at, &mut values);
                for k in 0..xs.len() {
                    for ((f, b), v) in full[k].iter_mut().zip(block[k].iter_mut()).zip(&values[k]) {
                        *f += v;
                        *b += v;
                    }
                    if (j + 1) % per == 0 && j < blocks * per {
                        block[k].iter_mut().for_each(|v| *v /= per as f64);
                        done[k].push(on_block(&mut fft, k, j / per, &block[k]));
                        block[k].iter_mut().for_each(|v| *v = 0.0);
                    }
                }
            }
            (full, done)
        })
        .collect();
    let mut out: Vec<(Tsa, Vec<B>)> =
        (0..xs.len()).map(|_| (Tsa { samples: vec![0.0; points], revolutions: revs }, Vec::new())).collect();
    for (full, done) in parts {
        for (k, (f, d)) in full.into_iter().zip(done).enumerate() {
            out[k].0.samples.iter_mut().zip(&f).for_each(|(a, v)| *a += v);
            out[k].1.extend(d);
        }
    }
    for (t, _) in &mut out {
        t.samples.iter_mut().for_each(|v| *v /= revs as f64);
    }
    Ok(out)
}

/// Revolutions of the shaft turning `ratio` times per reference revolution that `map` covers whole.
pub fn revolutions_of(map: &AngleMap, ratio: f64) -> usize {
    (map.revolutions() as f64 * ratio + 1e-9).floor() as usize
}

/// Average of the revolutions `revs` (of the shaft turning `ratio` times per reference revolution), each
/// resampled at `points` angles through `map`; the caller keeps `revs` within [`revolutions_of`].
pub fn tsa_of_revolutions<T: Sample>(
    x: &[T],
    map: &AngleMap,
    ratio: f64,
    points: usize,
    revs: std::ops::Range<usize>,
) -> Vec<f64> {
    let interp = Interpolator::shared();
    let count = revs.len().max(1);
    let mut acc = vec![0.0; points];
    let (mut at, mut values) = (vec![0.0; points], vec![0.0; points]);
    for j in revs {
        map.fill_positions(j as f64 / ratio, 1.0 / (points as f64 * ratio), &mut at);
        interp.fill(x, &at, &mut values);
        acc.iter_mut().zip(&values).for_each(|(a, v)| *a += v);
    }
    acc.iter_mut().for_each(|a| *a /= count as f64);
    acc
}

/// Number of fractional-offset classes of [`tsa_constant`].
const OFFSET_BINS: usize = 128;

/// TSA at constant speed: revolutions are summed sample by sample into classes of equal fractional start
/// offset (to 1/256 sample), and each class is interpolated once. Equivalent to interpolating every
/// revolution up to a phase error of 1/256 sample (amplitude error below 1e-4 at 0.3 cycles per sample).
fn tsa_constant<T: Sample>(
    x: &[T],
    interp: &Interpolator,
    offset: f64,
    period: f64,
    revs: usize,
    points: usize,
) -> Vec<f64> {
    let pad = HALF + 1;
    let seg_len = period.ceil() as usize + 2 * pad + 1;
    let mut sums: Vec<Vec<f64>> = vec![Vec::new(); OFFSET_BINS];
    let n = x.len() as isize;
    for j in 0..revs {
        let start = offset + j as f64 * period;
        let mut i0 = start as isize;
        let mut bin = ((start - i0 as f64) * OFFSET_BINS as f64 + 0.5) as usize;
        if bin == OFFSET_BINS {
            bin = 0;
            i0 += 1;
        }
        let sum = &mut sums[bin];
        if sum.is_empty() {
            sum.resize(seg_len, 0.0);
        }
        let first = i0 - pad as isize;
        for (k, acc) in sum.iter_mut().enumerate() {
            *acc += x[(first + k as isize).clamp(0, n - 1) as usize].f();
        }
    }
    let mut out = vec![0.0; points];
    for (bin, sum) in sums.iter().enumerate() {
        if sum.is_empty() {
            continue;
        }
        let delta = bin as f64 / OFFSET_BINS as f64;
        for (i, o) in out.iter_mut().enumerate() {
            *o += interp.at(sum, pad as f64 + delta + i as f64 * period / points as f64);
        }
    }
    out.iter_mut().for_each(|v| *v /= revs as f64);
    out
}

/// Regular, residual and difference signals of a TSA and its amplitude spectrum by order.
#[derive(Clone, Debug)]
pub struct Decomposition {
    /// Peak amplitude of each order 0..=L/2 in the TSA.
    pub amplitudes: Vec<f64>,
    /// Energy (sum of squares over the L samples) of the regular signal: shaft orders 1..=`shaft_orders`
    /// and mesh harmonics h z, from its bins by Parseval (sum_n r_n^2 = (1/L) sum_k w_k |X_k|^2, w_k = 2
    /// but 1 at the DC and Nyquist bins): only ER needs it, so it is not transformed back.
    pub regular_energy: f64,
    /// TSA - mean - regular.
    pub residual: Vec<f64>,
    /// Residual without the first-order sidebands h z +- 1.
    pub difference: Vec<f64>,
}

/// Splits a TSA by bin masking. `mesh_order` is the mesh order z of the averaged shaft (its teeth).
pub fn decompose(fft: &mut Fft, tsa: &[f64], mesh_order: usize, shaft_orders: usize) -> Decomposition {
    decompose_many(fft, tsa, &[mesh_order], &[], shaft_orders)
}

/// [`decompose`] of the average of a shaft that carries several gears (an intermediate shaft: one gear per
/// stage): the harmonics of every mesh order in `mesh_orders` are regular, and the first-order sidebands of
/// every one are left out of the difference signal. `foreign_orders` are lines of other shafts (the mesh
/// harmonics of stages the shaft does not carry): at an order that is not whole, what an average of a few
/// revolutions leaves of them sits in the bins within one order, which are counted as regular too; a whole
/// order (stages with a short common period) is its own bin.
pub fn decompose_many(
    fft: &mut Fft,
    tsa: &[f64],
    mesh_orders: &[usize],
    foreign_orders: &[f64],
    shaft_orders: usize,
) -> Decomposition {
    let l = tsa.len();
    let mut spec = Vec::new();
    fft.forward(&mut tsa.to_vec(), &mut spec);
    let amplitudes = spec
        .iter()
        .enumerate()
        .map(|(k, c)| if k == 0 || k == l / 2 { 1.0 } else { 2.0 } * super::spectrum::magnitude(*c) / l as f64)
        .collect();
    let nb = spec.len();
    let is_mesh = |k: usize| mesh_orders.iter().any(|&z| z > 0 && k.is_multiple_of(z));
    let is_side = |k: usize| mesh_orders.iter().any(|&z| z > 0 && (k % z == 1 || k % z == z - 1) && k + 1 >= z);
    let mut foreign = vec![false; spec.len()];
    for &f in foreign_orders.iter().filter(|f| f.is_finite() && **f >= 0.0) {
        // a whole order up to rounding in the ratio chain's floating point: its own bin only
        let f = if (f - f.round()).abs() < 1e-9 { f.round() } else { f };
        for k in [f.floor() as usize, f.ceil() as usize] {
            if let Some(b) = foreign.get_mut(k) {
                *b |= (k as f64 - f).abs() < 1.0;
            }
        }
    }
    // each bin's class found once (the modulo tests are the costly part of a block's split)
    let regular: Vec<bool> = (0..nb).map(|k| k > 0 && (k <= shaft_orders || is_mesh(k) || foreign[k])).collect();
    let side: Vec<bool> = (0..nb).map(|k| !regular[k] && is_side(k)).collect();
    let keep = |pred: &dyn Fn(usize) -> bool| -> Vec<(f64, f64)> {
        (0..nb).map(|k| if pred(k) { spec[k] } else { (0.0, 0.0) }).collect()
    };
    let weight = |k: usize| if k == 0 || (l.is_multiple_of(2) && k == l / 2) { 1.0 } else { 2.0 };
    let regular_energy = (0..nb)
        .filter(|&k| regular[k])
        .map(|k| weight(k) * (spec[k].0 * spec[k].0 + spec[k].1 * spec[k].1))
        .sum::<f64>()
        / l as f64;
    let residual = fft.inverse(&keep(&|k| k > 0 && !regular[k]), l);
    let difference = fft.inverse(&keep(&|k| k > 0 && !regular[k] && !side[k]), l);
    Decomposition { amplitudes, regular_energy, residual, difference }
}

/// Splits one revolution `x` of a gear's average into the part that repeats `n` times per revolution and
/// the rest: `(own, shared)` with `own + shared = x`, `shared` holding the orders k that are multiples of
/// `n` (the time-domain fold: shared(t) = (1/n) sum_j x(t + j/n rev)), `own` the others. A pair whose teeth
/// share the factor g = gcd(z_p, z_w) meshes the same tooth pairs every z_w / g pinion revolutions: the
/// pinion's lines fall on the wheel's orders that are multiples of z_w / g and nowhere else, so what the
/// other gear puts into an average lies in `shared` (n = z / g of the averaged gear), and only `own` is
/// the gear's alone.
pub fn split_period(fft: &mut Fft, x: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let l = x.len();
    if n <= 1 || l < 2 {
        return (vec![0.0; l], x.to_vec());
    }
    let mut spec = Vec::new();
    fft.forward(&mut x.to_vec(), &mut spec);
    let part = |shared: bool| -> Vec<(f64, f64)> {
        spec.iter().enumerate().map(|(k, &c)| if k.is_multiple_of(n) == shared { c } else { (0.0, 0.0) }).collect()
    };
    let (own, shared) = (part(false), part(true));
    (fft.inverse(&own, l), fft.inverse(&shared, l))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn tsa_works_on_varying_speed() {
        // a signal locked to shaft angle (orders 3 and 20) under a 5 % speed swing, tacho-style starts
        let (n, mean_period) = (40_000usize, 400.0);
        // slow fluctuation (one cycle over the record): speed = (1 + 0.05 sin(2 pi s / 40000)) / mean_period
        let angle = |s: f64| {
            s / mean_period + 0.05 * 40000.0 / (2.0 * PI * mean_period) * (1.0 - (2.0 * PI * s / 40000.0).cos())
        };
        let x: Vec<f64> = (0..n)
            .map(|i| {
                let th = 2.0 * PI * angle(i as f64);
                (3.0 * th).cos() + 0.5 * (20.0 * th + 0.3).sin() + 0.25 * (110.0 * th).cos()
            })
            .collect();
        // revolution starts: solve angle(s) = k by bisection
        let mut starts = Vec::new();
        for k in 0.. {
            let (mut lo, mut hi) = (0.0, n as f64 - 1.0);
            if angle(hi) < k as f64 {
                break;
            }
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if angle(mid) < k as f64 { lo = mid } else { hi = mid }
            }
            starts.push(lo);
        }
        let map = AngleMap::from_pulses(&starts, 1);
        let t = tsa(&x, &map, 1.0, 256, 8).unwrap();
        let mut fft = Fft::new();
        let d = decompose(&mut fft, &t.samples, 20, 3);
        // order 110 has 3.6 samples per cycle: the windowed sinc keeps it within 2e-3 relative
        assert!((d.amplitudes[3] - 1.0).abs() < 2e-3, "{}", d.amplitudes[3]);
        assert!((d.amplitudes[20] - 0.5).abs() < 1e-3, "{}", d.amplitudes[20]);
        assert!((d.amplitudes[110] - 0.25).abs() < 5e-4, "{}", d.amplitudes[110]);
        // orders 3 and 20 are regular; order 110 alone is left in the residual: RMS 0.25 / sqrt 2
        let rms = (d.residual.iter().map(|v| v * v).sum::<f64>() / d.residual.len() as f64).sqrt();
        assert!((rms - 0.25 / 2f64.sqrt()).abs() < 1e-3, "residual rms {rms}");
    }

    #[test]
    fn constant_speed_tsa_matches_per_revolution_interpolation() {
        let period = 333.37;
        let x: Vec<f64> = (0..60_000)
            .map(|i| {
                let th = 2.0 * PI * i as f64 / period;
                (3.0 * th).cos()
                    + 0.5 * (14.0 * th + 0.3).sin()
                    + 0.2 * (97.0 * th).cos()
                    + 0.01 * ((i * 7919 % 1000) as f64 / 1000.0 - 0.5)
            })
            .collect();
        let fast = tsa(&x, &AngleMap::constant(period, 0.0, x.len()), 1.0, 512, 8).unwrap();
        // the same revolutions through the general (tachometer) path
        let starts: Vec<f64> = (0..=fast.revolutions).map(|k| k as f64 * period).collect();
        let exact = tsa(&x, &AngleMap::from_pulses(&starts, 1), 1.0, 512, 8).unwrap();
        // offsets rounded to 1/256 sample: at order 97 (0.29 cycles/sample, amplitude 0.2) one revolution's
        // phase error is at most 2 pi 0.29 / 256 = 7e-3 rad, i.e. 1.4e-3; rounding errors of opposite sign
        // cancel in the average, so 5e-4 (3e-4 of the signal's peak 1.7) is a safe bound
        for (a, b) in fast.samples.iter().zip(&exact.samples) {
            assert!((a - b).abs() < 5e-4, "{a} {b}");
        }
    }

    #[test]
    fn decompose_masks_the_right_bins() {
        // TSA built from known orders: shaft 1, mesh 8 and 16, sidebands 7 and 9, other 5
        let l = 64;
        let x: Vec<f64> = (0..l)
            .map(|i| {
                let th = 2.0 * PI * i as f64 / l as f64;
                2.0 + th.cos()
                    + (8.0 * th).cos()
                    + 0.5 * (16.0 * th).sin()
                    + 0.2 * (7.0 * th).cos()
                    + 0.1 * (9.0 * th).cos()
                    + 0.05 * (5.0 * th).cos()
            })
            .collect();
        let d = decompose(&mut Fft::new(), &x, 8, 1);
        let mut regular_energy = 0.0;
        for i in 0..l {
            let th = 2.0 * PI * i as f64 / l as f64;
            let reg = th.cos() + (8.0 * th).cos() + 0.5 * (16.0 * th).sin();
            let res = 0.2 * (7.0 * th).cos() + 0.1 * (9.0 * th).cos() + 0.05 * (5.0 * th).cos();
            regular_energy += reg * reg;
            assert!((d.residual[i] - res).abs() < 1e-12);
            assert!((d.difference[i] - 0.05 * (5.0 * th).cos()).abs() < 1e-12);
        }
        assert!((d.amplitudes[0] - 2.0).abs() < 1e-12);
        // Parseval's energy of the regular signal against the sum of squares of the signal itself
        assert!((d.regular_energy / regular_energy - 1.0).abs() < 1e-12, "{} {regular_energy}", d.regular_energy);
    }

    #[test]
    fn a_whole_foreign_order_takes_its_own_bin_only() {
        // mesh 8; another stage's mesh line at order 20 given as 20 + 1e-12 (the ratio chain's rounding),
        // and a line at 21 that is nobody's: the first is regular, the second stays in the residual
        let l = 64;
        let x: Vec<f64> = (0..l)
            .map(|i| {
                let th = 2.0 * PI * i as f64 / l as f64;
                (8.0 * th).cos() + 3.0 * (20.0 * th).cos() + 0.1 * (21.0 * th).cos()
            })
            .collect();
        let d = decompose_many(&mut Fft::new(), &x, &[8], &[20.0 + 1e-12], 1);
        for i in 0..l {
            let th = 2.0 * PI * i as f64 / l as f64;
            // exact bins of an exact FFT: round-off only
            assert!((d.residual[i] - 0.1 * (21.0 * th).cos()).abs() < 1e-12, "{i}");
        }
    }

    #[test]
    fn tsa_rejects_short_records() {
        let x = vec![0.0; 1000];
        let e = tsa(&x, &AngleMap::constant(300.0, 0.0, 1000), 1.0, 256, 8).unwrap_err();
        assert!(e.to_string().contains("8 revolutions"), "{e}");
    }

    #[test]
    fn split_period_matches_the_time_domain_fold() {
        // an impulse once per revolution plus a line at order 7 over 3 x 256 points: the part repeating
        // three times per revolution is the mean of the three shifted thirds (the fold), the rest its
        // complement; checked against that direct fold, not the transform
        let (l, n) = (768usize, 3usize);
        let x: Vec<f64> =
            (0..l).map(|i| if i == 100 { 5.0 } else { 0.0 } + (2.0 * PI * 7.0 * i as f64 / l as f64).cos()).collect();
        let (own, shared) = split_period(&mut Fft::new(), &x, n);
        for i in 0..l {
            let fold = (0..n).map(|j| x[(i + j * l / n) % l]).sum::<f64>() / n as f64;
            assert!((shared[i] - fold).abs() < 1e-9, "shared at {i}: {} against the fold {fold}", shared[i]);
            assert!((own[i] + shared[i] - x[i]).abs() < 1e-9);
        }
        // the impulse: 2/3 of it its own at its place, a third at each of the three places in `shared`
        assert!((own[100] - (5.0 * 2.0 / 3.0 + (2.0 * PI * 700.0 / l as f64).cos())).abs() < 1e-9);
    }
}
