//! Shaft speed: from tachometer pulses, or estimated from the signal's repetition period.

use super::spectrum::Fft;
use super::{Sample, SignalError};

mod period;
pub use period::{
    PeriodEstimate, estimate_period, period_near, refine, refine_near, revolution_within, whole_cycle_period,
};

/// Rising crossings of the mid level (min + max) / 2, as fractional sample indices (linear
/// interpolation between the two samples around each crossing).
///
/// # Errors
/// A constant channel or fewer than two pulses.
pub fn tacho_pulses<T: Sample>(x: &[T]) -> Result<Vec<f64>, SignalError> {
    let (lo, hi) = x.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v.f()), b.max(v.f())));
    if hi.is_nan() || hi <= lo {
        return Err(SignalError::Invalid("tachometer channel is constant: no pulses".into()));
    }
    let mid = 0.5 * (lo + hi);
    let pulses: Vec<f64> = x
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[0].f() < mid && w[1].f() >= mid)
        .map(|(i, w)| i as f64 + (mid - w[0].f()) / (w[1].f() - w[0].f()))
        .collect();
    if pulses.len() < 2 {
        return Err(SignalError::Invalid(format!(
            "tachometer channel has {} pulse(s); at least 2 are needed",
            pulses.len()
        )));
    }
    Ok(pulses)
}

/// Mesh harmonics the nominal-speed comb and the choice of the tracked harmonic look at: the first 16
/// (below 0.45 cycles per sample). A housing or mesh resonance lifts a few harmonics of the mesh 10-15 dB
/// over their band while the first four lie under the sensor noise (hold-out machines of
/// `tests/holdout`: harmonics 5-10 stand, 1-4 do not), so a comb of the first four alone locked onto a
/// sideband family there.
pub const COMB_HARMONICS: usize = 16;

/// Cap on one harmonic's height over its floor (amplitude ratio, 60 dB) in the comb's score: one strong
/// line of something else (hum, a fan, another pair) that happens to fall on one harmonic of a wrong speed
/// must not outweigh several harmonics of the true mesh standing 10-20 dB. A lower cap (20 dB) let an
/// impulsive fault's sidebands tie with the mesh: on a clean recording of a cracked pinion every shaft
/// order stands over 20 dB, so the comb of speed f (z - 1) / z, whose harmonic k is the -k sideband of
/// mesh harmonic k, scored as the true one.
const COMB_CAP: f64 = 1000.0;

/// An averaged amplitude spectrum read for lines against its local floor (the median of 128-bin blocks).
pub struct LineSpectrum {
    amp: Vec<f64>,
    floor: Vec<f64>,
    n: usize,
}

impl LineSpectrum {
    /// The averaged spectrum of `x` over half-overlapping Hann segments of `segment` samples.
    ///
    /// # Errors
    /// Fewer than `segment` samples.
    pub fn new<T: Sample>(fft: &mut Fft, x: &[T], segment: usize, what: &str) -> Result<Self, SignalError> {
        if x.len() < segment {
            return Err(SignalError::TooShort { what: what.into(), needed: segment, got: x.len() });
        }
        let (power, n) = super::spectrum::averaged_power(fft, x, segment, 0.5, what)?;
        let floor = super::mesh_comb::local_floor(&power).iter().map(|p| p.sqrt()).collect();
        Ok(Self { amp: power.iter().map(|p| p.max(0.0).sqrt()).collect(), floor, n })
    }

    /// Segment length (samples): bins are 1 / n cycles per sample apart.
    pub fn segment(&self) -> usize {
        self.n
    }

    /// Amplitude over the local floor of the strongest bin within half a bin of frequency `f` (cycles per
    /// sample); 0 outside the spectrum.
    pub fn height(&self, f: f64) -> f64 {
        let b = f * self.n as f64;
        if !(b.is_finite() && b >= 1.0) {
            return 0.0;
        }
        let (lo, hi) = ((b - 0.5).floor() as usize, ((b + 0.5).ceil() as usize).min(self.amp.len() - 1));
        (lo..=hi).map(|i| self.amp[i] / self.floor[i].max(f64::MIN_POSITIVE)).fold(0.0, f64::max)
    }

    /// The amplitude-weighted centre of the three bins around frequency `f` (cycles per sample): a line's
    /// frequency to a fraction of a bin. `None` at the spectrum's ends.
    pub fn centroid(&self, f: f64) -> Option<f64> {
        let b = f * self.n as f64;
        let i = if b.is_finite() && b >= 1.0 { b.round() as usize } else { return None };
        if i + 1 >= self.amp.len() {
            return None;
        }
        let w = [self.amp[i - 1], self.amp[i], self.amp[i + 1]];
        let total = w.iter().sum::<f64>();
        (total > 0.0).then(|| ((i - 1) as f64 * w[0] + i as f64 * w[1] + (i + 1) as f64 * w[2]) / total / self.n as f64)
    }

    /// Heights (as [`Self::height`]) of the mesh harmonics k z f, k = 1..=[`COMB_HARMONICS`], below `limit`
    /// cycles per sample, of a pinion turning at `f` cycles per sample: (k, height).
    pub fn harmonics(&self, f: f64, z: usize, limit: f64) -> Vec<(usize, f64)> {
        (1..=COMB_HARMONICS)
            .map(|k| (k, (k * z) as f64 * f))
            .take_while(|&(_, m)| m < limit)
            .map(|(k, m)| (k, self.height(m)))
            .collect()
    }
}

/// Segment length (samples) of a spectrum read for mesh lines on a shaft of `period` samples: about 8
/// revolutions (bins of an eighth of the shaft frequency resolve the sidebands; longer segments smear
/// under a fluctuating speed), a power of two of at least 256.
fn line_segment(period: f64) -> usize {
    ((8.0 * period).ceil().min((1u64 << 24) as f64) as usize).next_power_of_two().max(256)
}

/// A nominal shaft period checked on the mesh comb: the shaft period (samples) within +-`tolerance`
/// (relative) of `nominal` at which the mesh harmonics k z f (k = 1..=[`COMB_HARMONICS`], below 0.45 cycles
/// per sample) of a gear of `z` teeth stand highest over their local floor, and that comb's height: the
/// geometric mean of its three highest harmonics' amplitude over their floor, dB. The score of a candidate
/// speed is sum_k ln(clamp(h_k, 1, 1000)) (60 dB, the cap) with h_k harmonic k's height: noise adds about the same to every
/// candidate, the mesh's harmonics only where they line up. A nameplate speed off by the motor's slip puts
/// the comb 1-4 % away; a sideband family kz + j (j shaft orders) lines up with the comb of speed
/// f (1 + j / (k z)) for one harmonic k only, so the sum over many harmonics peaks at the true speed.
///
/// # Errors
/// Too short a record for a spectrum resolving the shaft (fewer than 8 revolutions).
pub fn mesh_comb_period<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    nominal: f64,
    z: usize,
    tolerance: f64,
) -> Result<(f64, f64), SignalError> {
    let s = LineSpectrum::new(fft, x, line_segment(nominal), "mesh comb spectrum")?;
    let n = s.segment();
    // the uncapped heights break ties among candidates whose harmonics all reach the cap (a clean recording)
    let score = |f: f64| -> f64 {
        s.harmonics(f, z, 0.45).iter().map(|&(_, h)| h.clamp(1.0, COMB_CAP).ln() + 1e-3 * h.max(1.0).ln()).sum()
    };
    let f0 = 1.0 / nominal;
    // steps of a quarter bin at the highest harmonic used
    let top = s.harmonics(f0 * (1.0 - tolerance), z, 0.45).len().max(1);
    let step = 0.25 / (n as f64 * (top * z) as f64);
    let count = ((2.0 * tolerance * f0 / step).ceil() as usize).clamp(1, 1 << 18);
    let (best_f, _) = (0..=count)
        .map(|i| f0 * (1.0 - tolerance) + i as f64 * (2.0 * tolerance * f0) / count as f64)
        .map(|f| (f, score(f)))
        .fold((f0, f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
    // refined on the strongest harmonic's own peak (the grid's maximum sits anywhere on the plateau where
    // every line is within half a bin of its harmonic): the centre of mass of its three bins
    let refined = s
        .harmonics(best_f, z, 0.45)
        .into_iter()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .and_then(|(k, _)| s.centroid((k * z) as f64 * best_f).map(|f| f / (k * z) as f64))
        .filter(|f| ((f - best_f) * n as f64 * z as f64).abs() < 1.0)
        .unwrap_or(best_f);
    let best_f = refined;
    let mut heights: Vec<f64> = s.harmonics(best_f, z, 0.45).iter().map(|&(_, h)| h).collect();
    heights.sort_by(|a, b| b.total_cmp(a));
    heights.truncate(3);
    let mean_db =
        heights.iter().map(|h| 20.0 * h.max(f64::MIN_POSITIVE).log10()).sum::<f64>() / heights.len().max(1) as f64;
    Ok((1.0 / best_f, mean_db))
}

/// The mesh harmonic of a gear of `z` teeth that stands highest over its local floor, of the first
/// [`COMB_HARMONICS`] below `limit` cycles per sample, on a shaft of period `period` samples: (its shaft
/// order k z, its height in dB). The spectrum is averaged over segments of about 8 revolutions of the
/// first 2^21 samples. `None` when the record is too short.
pub fn strongest_mesh_harmonic<T: Sample>(x: &[T], period: f64, z: usize, limit: f64) -> Option<(f64, f64)> {
    let s =
        LineSpectrum::new(&mut Fft::new(), &x[..x.len().min(1 << 21)], line_segment(period), "mesh harmonics").ok()?;
    s.harmonics(1.0 / period, z, limit)
        .into_iter()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .filter(|&(_, h)| h > 0.0)
        .map(|(k, h)| ((k * z) as f64, 20.0 * h.log10()))
}

/// One candidate shaft of [`teeth_candidates`].
#[derive(Clone, Debug, PartialEq)]
pub struct ShaftCandidate {
    /// The pinion's period, samples.
    pub period_samples: f64,
    /// Which harmonic of the pinion's mesh the strongest line would be (1: the mesh itself).
    pub harmonic: usize,
    /// Lines the candidate predicts (mesh harmonics, the pinion's +-1 and +-2 sidebands, the wheel's +-1)
    /// that stand out of the spectrum.
    pub standing: usize,
    /// Lines it predicts within the band.
    pub predicted: usize,
    /// Evidence: standing lines less half the predicted ones that do not stand.
    pub score: f64,
}

/// Height over the local median of the averaged amplitude spectrum from which a line stands out: the
/// power averaged over 16 or more half-overlapping segments is a chi-square of about 24 degrees of freedom
/// or more around its mean, exceeding 4 times its median (twice the amplitude) with a probability below 1e-6
/// per bin.
const LINE_OVER_FLOOR: f64 = 2.0;

/// The lines (cycles per sample) a pinion turning at `f` with `zp` and `zw` teeth predicts: its mesh
/// harmonics 1..=4 below 0.45, each with the pinion's +-1 and +-2 sidebands and the wheel's +-1.
fn predicted_lines(f: f64, zp: usize, zw: usize) -> Vec<f64> {
    let fw = f * zp as f64 / zw as f64;
    (1..=4)
        .map(|k| (k * zp) as f64 * f)
        .filter(|m| m + 2.0 * f < 0.45)
        .flat_map(|m| [0.0, f, -f, 2.0 * f, -2.0 * f, fw, -fw].map(|d| m + d))
        .collect()
}

/// Without a speed, with the teeth known: the line `seed` (cycles per sample) is a harmonic h of the mesh
/// of `zp` teeth, so the pinion turns at seed / (h zp) for some h = 1..=8. Each candidate is scored by the
/// lines it predicts (mesh harmonics 1..=4 with the pinion's +-1, +-2 and the wheel's +-1 sidebands) that stand twice over the spectrum's local median as local
/// maxima; a finer candidate is preferred when the lines only it predicts stand far more often than
/// chance. Best first. On a record resampled on the angle of a tracked mesh harmonic that harmonic is a
/// sharp line at a known place (the seed) whatever the speed did.
///
/// # Errors
/// Too short a record for a resolving spectrum.
pub fn teeth_candidates<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    zp: usize,
    zw: usize,
    seed: f64,
) -> Result<Vec<ShaftCandidate>, SignalError> {
    // 16 segments or more: a speed that wanders by a percent smears a line over many bins of a long
    // segment, and the averaging steadies the floor
    let segment = (x.len() / 16).next_power_of_two().clamp(1024, 1 << 15);
    let (power, n) = super::spectrum::averaged_power(fft, x, segment.min(x.len()), 0.5, "teeth comb spectrum")?;
    let amp: Vec<f64> = power.iter().map(|p| p.max(0.0).sqrt()).collect();
    // the local floor: the median of blocks of 128 bins (the median commutes with the square root)
    let floors: Vec<f64> = super::mesh_comb::local_floor(&power).iter().map(|p| p.sqrt()).collect();
    let floor = |bin: usize| floors[bin.min(floors.len() - 1)];
    // a line stands when a local maximum of the spectrum within a bin of it is that far over the floor (the
    // slope of a hump smeared by the speed's wander is not a line of its own)
    let stands = |f: f64| -> bool {
        let b = f * n as f64;
        if !(b.is_finite() && b >= 3.0) {
            return false;
        }
        let i = b.round() as usize;
        if i.saturating_add(3) >= amp.len() {
            return false;
        }
        (i - 1..=i + 1).any(|j| {
            amp[j] >= LINE_OVER_FLOOR * floor(j)
                && amp[j] >= amp[j - 1]
                && amp[j] >= amp[j + 1]
                && amp[j] >= amp[j - 2]
                && amp[j] >= amp[j + 2]
        })
    };
    let mut out: Vec<ShaftCandidate> = Vec::new();
    for h in 1..=8 {
        let f = seed / (h * zp) as f64;
        // the wheel's sidebands must be resolved from the mesh line: two bins at least
        if f * zp as f64 / zw as f64 * (n as f64) < 2.0 {
            continue;
        }
        let lines = predicted_lines(f, zp, zw);
        let standing = lines.iter().filter(|&&l| stands(l)).count();
        if !lines.is_empty() {
            out.push(ShaftCandidate {
                period_samples: 1.0 / f,
                harmonic: h,
                standing,
                predicted: lines.len(),
                score: standing as f64 - 0.5 * (lines.len() - standing) as f64,
            });
        }
    }
    out.sort_by(|a, b| b.score.total_cmp(&a.score));
    // a candidate h predicts a subset of the lines of a finer one m h (every m-th mesh line, wider
    // sidebands), so the best score can go to a coarse one when the fine lines are weak: a finer candidate
    // wins when the lines only it predicts stand far more often than chance (a third of
    // them, against well under one in ten on noise)
    if let Some(first) = out.first().cloned() {
        let lines = |c: &ShaftCandidate| predicted_lines(1.0 / c.period_samples, zp, zw);
        let mut chosen = first;
        loop {
            let coarse = lines(&chosen);
            let finer = out.iter().find(|c| {
                c.harmonic > chosen.harmonic && c.harmonic % chosen.harmonic == 0 && {
                    let extra: Vec<f64> = lines(c)
                        .into_iter()
                        .filter(|l| coarse.iter().all(|m| ((l - m) * n as f64).abs() > 1.5))
                        .collect();
                    !extra.is_empty() && 3 * extra.iter().filter(|&&l| stands(l)).count() >= extra.len()
                }
            });
            match finer {
                Some(c) => chosen = c.clone(),
                None => break,
            }
        }
        out.retain(|c| *c != chosen);
        out.insert(0, chosen);
    }
    Ok(out)
}

/// The order spectra of the averages of the two halves of a record resampled at `period` points per
/// (supposed) revolution, over their whole revolutions, compared order by order ([`Halves::coherence`])
/// over several sets of orders at the cost of one pair of transforms. Content synchronous with the
/// revolution reads near 1 (the same line in both halves), noise near 0: when the revolution holds d turns
/// of the shaft, the orders not divisible by d hold no synchronous content while the others do.
pub struct Halves {
    a: Vec<(f64, f64)>,
    b: Vec<(f64, f64)>,
    period: usize,
}

impl Halves {
    /// The halves of `y`; `None` with fewer than 8 revolutions.
    pub fn of(fft: &mut Fft, y: &[f64], period: usize) -> Option<Self> {
        let revs = y.len() / period.max(1);
        if revs < 8 || period < 8 {
            return None;
        }
        let half = revs / 2;
        let mut average = |from: usize| {
            let mut a = vec![0.0; period];
            for r in y[from * period..(from + half) * period].chunks_exact(period) {
                a.iter_mut().zip(r).for_each(|(s, v)| *s += v / half as f64);
            }
            let mut out = Vec::new();
            fft.forward(&mut a, &mut out);
            out
        };
        Some(Self { a: average(0), b: average(half), period })
    }

    /// sum Re(A_k conj(B_k)) / sqrt(sum |A_k|^2 sum |B_k|^2) over the orders k below a quarter of the period
    /// that `keep` keeps (0 when they hold nothing).
    pub fn coherence(&self, keep: &dyn Fn(usize) -> bool) -> f64 {
        let (a, b) = (&self.a, &self.b);
        let (mut cross, mut ea, mut eb) = (0.0, 0.0, 0.0);
        for k in (1..self.period / 4).filter(|&k| keep(k)) {
            cross += a[k].0 * b[k].0 + a[k].1 * b[k].1;
            ea += a[k].0 * a[k].0 + a[k].1 * a[k].1;
            eb += b[k].0 * b[k].0 + b[k].1 * b[k].1;
        }
        if ea > 0.0 && eb > 0.0 { cross / (ea * eb).sqrt() } else { 0.0 }
    }
}

#[cfg(test)]
mod tests;
