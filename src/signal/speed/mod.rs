//! Shaft speed: from tachometer pulses, or estimated from the signal's repetition period.

use super::spectrum::{Fft, autocorrelation};
use super::{Sample, SignalError};

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

/// The normalised autocorrelation of the first `n` samples of each channel up to `lag_max`, averaged over
/// the channels.
fn summed_autocorrelation<T: Sample>(fft: &mut Fft, channels: &[&[T]], n: usize, lag_max: usize) -> Vec<f64> {
    let mut sum = vec![0.0; lag_max + 1];
    for c in channels {
        for (s, r) in sum.iter_mut().zip(autocorrelation(fft, &c[..n], lag_max)) {
            *s += r / channels.len() as f64;
        }
    }
    sum
}

/// Whether lag `i` holds the largest value of `sum` within +-10 % of itself (at least 2 lags each side).
fn dominates(sum: &[f64], i: usize) -> bool {
    let w = (i / 10).max(2);
    let (lo, hi) = (i.saturating_sub(w).max(1), (i + w).min(sum.len() - 1));
    sum[lo..=hi].iter().all(|&v| v <= sum[i])
}

/// A repetition period estimated from the signal.
#[derive(Clone, Debug, PartialEq)]
pub struct PeriodEstimate {
    /// Period in samples (fractional).
    pub period_samples: f64,
    /// Normalised autocorrelation at that lag (0..1): how strongly the signal repeats.
    pub confidence: f64,
    /// The shorter lag that repeats strongly within the period (the tooth-mesh period, fractional samples),
    /// when the period was found as a multiple of it: period / mesh lag is then the mesh order.
    pub mesh_lag: Option<f64>,
}

/// Repetition period of the summed normalised autocorrelation of `channels`, between `min_lag` and
/// `max_lag` samples: the shortest strong peak (at least 75 % of the highest, and the largest value within
/// +-10 % of its own lag); a strong peak at 8 times that lag or more replaces it when it stands clearly above
/// the neighbouring multiples (the short lag was then the tooth-mesh period); refined to a fraction of a
/// sample from the peak near the largest multiple of it that fits in half the record.
///
/// # Errors
/// No peak in the range (signal not periodic there).
pub fn estimate_period<T: Sample>(
    fft: &mut Fft,
    channels: &[&[T]],
    min_lag: usize,
    max_lag: usize,
) -> Result<PeriodEstimate, SignalError> {
    let n = channels.iter().map(|c| c.len()).min().unwrap_or(0);
    let lag_max = (n / 2).max(max_lag.min(n.saturating_sub(2)));
    let sum = summed_autocorrelation(fft, channels, n, lag_max);
    // a candidate must dominate +-10 % of its lag: ripple from the mesh on a shaft-period lobe is not a period
    let dominant = |i: usize| dominates(&sum, i);
    let peaks: Vec<usize> = (min_lag.max(2)..max_lag.min(lag_max - 1))
        .filter(|&i| sum[i] > sum[i - 1] && sum[i] >= sum[i + 1] && sum[i] > 0.0 && dominant(i))
        .collect();
    let strong_from = |from: usize| -> Option<usize> {
        let best = peaks.iter().filter(|&&i| i >= from).map(|&i| sum[i]).fold(0.0, f64::max);
        peaks.iter().copied().find(|&i| i >= from && sum[i] >= 0.75 * best)
    };
    let Some(shortest) = strong_from(0) else {
        return Err(SignalError::Invalid(format!(
            "no repetition period found between {min_lag} and {max_lag} samples: give the shaft speed"
        )));
    };
    // The shortest strong lag may be the tooth-mesh period. A shaft carries at least 8 teeth, so a strong
    // peak at 8 times that lag or beyond is the shaft period when it stands 25 % above the neighbouring
    // multiples of the short lag (a truly periodic signal has equal peaks at all multiples instead).
    let local_max = |centre: usize| {
        let w = (shortest / 4).max(2);
        sum[centre.saturating_sub(w).max(1)..=(centre + w).min(lag_max)].iter().copied().fold(f64::MIN, f64::max)
    };
    let stands_out = |p: usize| sum[p] >= 1.25 * local_max(p - shortest).max(local_max(p + shortest));
    let p0 = match strong_from(8 * shortest) {
        Some(p) if stands_out(p) => {
            // a whole fraction p / k that still repeats strongly and stands out is the shaft itself
            (2..=6)
                .rev()
                .filter_map(|k| {
                    let q = (p as f64 / k as f64).round() as usize;
                    let w = (q / 50).max(2);
                    let q = (q.saturating_sub(w)..=q + w).max_by(|a, b| sum[*a].total_cmp(&sum[*b]))?;
                    (q >= 8 * shortest && sum[q] >= 0.6 * sum[p] && stands_out(q)).then_some(q)
                })
                .next()
                .unwrap_or(p)
        }
        // a short lag cannot be a shaft period (fewer than 64 samples per revolution): look for the shaft
        // among its multiples
        _ if shortest < 64 => comb_outlier(&sum, shortest, lag_max).unwrap_or(shortest),
        _ => whole_fraction(&sum, shortest, &dominant).unwrap_or(shortest),
    };
    let mesh_lag = (p0 > shortest).then(|| refine(&sum, shortest as f64));
    // a whole fraction of the shortest strong period rests on that period's repetition
    let confidence = if p0 < shortest { sum[shortest] } else { sum[p0] };
    Ok(PeriodEstimate { period_samples: refine(&sum, p0 as f64), confidence, mesh_lag })
}

/// The shaft revolution inside a repetition `lag` (samples) that [`estimate_period`] took for a tooth-mesh
/// period and whose line could then not be followed (a lag that is no mesh: two revolutions of a pair
/// whose short repetitions are all shaft periods, the real rig's healthy 80 % load file repeating at 864
/// samples, its revolution 432): the whole fraction of the summed autocorrelation's peak near `lag` by the
/// rule of the hunting period (each multiple of the fraction a dominant peak keeping a quarter of the
/// lag's autocorrelation; at least 64 samples), refined. `None` when no fraction repeats so.
pub fn revolution_within<T: Sample>(fft: &mut Fft, channels: &[&[T]], lag: f64) -> Option<PeriodEstimate> {
    let n = channels.iter().map(|c| c.len()).min().unwrap_or(0);
    let lag_max = n / 2;
    let p = lag.round() as usize;
    if channels.is_empty() || p < 128 || 2 * p + 4 > lag_max {
        return None;
    }
    let sum = summed_autocorrelation(fft, channels, n, lag_max);
    let dominant = |i: usize| dominates(&sum, i);
    let w = (p / 50).max(2);
    let p = (p - w..=p + w).max_by(|a, b| sum[*a].total_cmp(&sum[*b]))?;
    if !dominant(p) || sum[p] <= 0.0 {
        return None;
    }
    let q = whole_fraction(&sum, p, &dominant)?;
    Some(PeriodEstimate { period_samples: refine(&sum, q as f64), confidence: sum[q], mesh_lag: None })
}

/// Lowest share of the period's autocorrelation that each multiple of a whole fraction of it must keep
/// for the fraction to be the shaft: a pair whose teeth share a factor repeats wholly only after a few
/// revolutions (the hunting period, on a real rig 0.44 against 0.14-0.21 at each revolution), while a
/// lag that is no revolution holds no dominant peak at all.
const FRACTION_SHARE: f64 = 0.25;

/// The shaft period inside a period `p` that is a few revolutions of it (the hunting period of a pair,
/// or the slower shaft): the smallest whole fraction p / k (k = 6 down to 2, at least 64 samples) whose
/// every multiple j p / k (j < k) is a peak dominating +-10 % of its lag (`dominant`) and keeps
/// [`FRACTION_SHARE`] of the autocorrelation at p. `None` when no fraction repeats so.
fn whole_fraction(sum: &[f64], p: usize, dominant: &dyn Fn(usize) -> bool) -> Option<usize> {
    let peak_near = |centre: usize| -> usize {
        let w = (centre / 50).max(2);
        (centre.saturating_sub(w).max(1)..=(centre + w).min(sum.len() - 1))
            .max_by(|a, b| sum[*a].total_cmp(&sum[*b]))
            .unwrap_or(centre)
    };
    (2..=6usize).rev().find_map(|k| {
        let q = peak_near((p as f64 / k as f64).round() as usize);
        let repeats = (1..k).all(|j| {
            let i = peak_near(j * q);
            dominant(i) && sum[i] >= FRACTION_SHARE * sum[p]
        });
        (q >= 64 && repeats).then_some(q)
    })
}

/// The shaft period among the multiples j m of the mesh lag m (j >= 8) when it stands out of the comb of
/// mesh-lag peaks as an outlier rather than by a fixed ratio: with c(j) the autocorrelation peak near j m,
/// the excess e(j) = c(j) - (c(j - 1) + c(j + 1)) / 2 of the best j must exceed 6 times the median
/// absolute excess (a robust noise level of the comb) and 0.005. A local fault adds a small shaft-periodic
/// part to a mesh-dominated signal: its peak at the shaft lag is then only a few percent above its
/// neighbours, but far above the comb's ripple.
fn comb_outlier(sum: &[f64], m: usize, lag_max: usize) -> Option<usize> {
    let peak_near = |centre: usize| -> Option<usize> {
        let w = (m / 4).max(1);
        let (lo, hi) = (centre.saturating_sub(w).max(1), (centre + w).min(lag_max));
        (lo <= hi).then(|| (lo..=hi).max_by(|a, b| sum[*a].total_cmp(&sum[*b])).unwrap_or(centre))
    };
    let jmax = lag_max / m;
    if jmax < 10 {
        return None;
    }
    let c: Vec<(usize, f64)> = (0..=jmax).map(|j| peak_near(j * m).map_or((j * m, 0.0), |i| (i, sum[i]))).collect();
    let excess: Vec<(usize, f64)> = (8..jmax).map(|j| (c[j].0, c[j].1 - 0.5 * (c[j - 1].1 + c[j + 1].1))).collect();
    let mut abs: Vec<f64> = excess.iter().map(|e| e.1.abs()).collect();
    abs.sort_by(f64::total_cmp);
    let mad = abs[abs.len() / 2];
    let (lag, e) = excess.iter().copied().max_by(|a, b| a.1.total_cmp(&b.1))?;
    // the shortest lag whose excess is at least 40 % of the best (the best may be a multiple of the shaft)
    let first = excess.iter().find(|x| x.1 >= 0.4 * e).map_or(lag, |x| x.0);
    (e > 6.0 * mad && e > 0.005).then_some(first)
}

/// The repetition, in whole cycles, of a signal sampled on the angle of one of its lines (a tracked mesh
/// line): `c[j]` is its normalised autocorrelation at j cycles (exact lags on that grid). A shaft of q
/// teeth makes c(q) and its multiples stand above the comb of the mesh. With the excess
/// e(j) = c(j) - max over d = 1..3 of c(j +- d) (three neighbours each side, so a comb that alternates
/// between whole and half mesh cycles does not count), the period q is the smallest j >= `min` whose
/// excess reaches 40 % of the best (the best may be a multiple of the shaft); it stands out when the best
/// excess is over 0.01 and over twice the largest excess at any j that is not a multiple of q (the
/// ripple of the comb), or when those lags hold the other shaft of the pair: a second period q2 found the
/// same way among them (reduced to its smallest divisor whose excess is over 0.01), the best excess among
/// them over 0.01, and the excesses at q and q2 themselves over twice anything at a multiple of neither.
/// None when nothing stands out.
pub fn whole_cycle_period(c: &[f64], min: usize) -> Option<usize> {
    let len = c.len();
    let min = min.max(4);
    if len < 2 * min + 4 {
        return None;
    }
    let excess: Vec<(usize, f64)> = (min..len - 3)
        .map(|j| {
            let near = (1..=3).flat_map(|d| [c[j - d], c[j + d]]).fold(f64::MIN, f64::max);
            (j, c[j] - near)
        })
        .collect();
    let best = excess.iter().map(|e| e.1).fold(f64::MIN, f64::max);
    let q = excess.iter().find(|e| e.1 >= 0.4 * best)?.0;
    let other = excess.iter().filter(|e| e.0 % q != 0).map(|e| e.1).fold(0.0, f64::max);
    if best <= 0.01 {
        return None;
    }
    if best > 2.0 * other {
        return Some(q);
    }
    // both shafts of the pair repeat (a pinion error and an eccentric wheel): the other stands out the same
    // way among the lags that are not multiples of q, and nothing else does
    let rest: Vec<(usize, f64)> = excess.iter().copied().filter(|e| e.0 % q != 0).collect();
    let found = rest.iter().find(|e| e.1 >= 0.4 * other)?.0;
    // its fundamental: the smallest divisor that stands out at all (a neighbouring multiple of q can
    // hide most of its excess, as 42 does for 39)
    let at = |j: usize| excess.get(j.wrapping_sub(min)).map_or(0.0, |e| e.1);
    let q2 = (min..=found).find(|&d| found % d == 0 && d % q != 0 && at(d) > 0.01).unwrap_or(found);
    let beyond = rest.iter().filter(|e| e.0 % q2 != 0).map(|e| e.1).fold(0.0, f64::max);
    (other > 0.01 && [at(q), at(q2)].iter().all(|&e| e > 2.0 * beyond)).then_some(q)
}

/// Refines a period from the autocorrelation peaks near its multiples 2, 4, 8, ... (parabolic vertex).
pub fn refine(r: &[f64], p0: f64) -> f64 {
    let mut p = p0;
    let mut m = 1.0;
    while 2.0 * m * p < (r.len() - 2) as f64 {
        m *= 2.0;
        let centre = (m * p).round() as usize;
        // the previous estimate is good to about a sample over m/2 periods: search a few samples, and never
        // as far as a neighbouring multiple of the period
        let w = (3 + (m * 0.002 * p) as usize).min((p / 4.0) as usize).max(1);
        let lo = centre.saturating_sub(w).max(1);
        let hi = (centre + w).min(r.len() - 2);
        let Some(i) = (lo..=hi).max_by(|a, b| r[*a].total_cmp(&r[*b])) else { break };
        let (y0, y1, y2) = (r[i - 1], r[i], r[i + 1]);
        let den = y0 - 2.0 * y1 + y2;
        let d = if den < 0.0 { 0.5 * (y0 - y2) / den } else { 0.0 };
        p = (i as f64 + d) / m;
    }
    p
}

/// Refines a known approximate period `near` (for example a baseline's) within +-`tolerance` relative.
///
/// # Errors
/// No peak in the window.
pub fn refine_near<T: Sample>(
    fft: &mut Fft,
    channels: &[&[T]],
    near: f64,
    tolerance: f64,
) -> Result<PeriodEstimate, SignalError> {
    let lo = (near * (1.0 - tolerance)).floor() as usize;
    let hi = (near * (1.0 + tolerance)).ceil() as usize + 1;
    let est = estimate_period(fft, channels, lo, hi)?;
    Ok(est)
}

/// The repetition period within +-`tolerance` (relative) of a period `near` that is known to be a shaft's
/// revolution (a baseline's, found on a healthy recording of the same machine): the highest peak of the
/// summed normalised autocorrelation of `channels` in that window, refined like [`estimate_period`]'s. Unlike
/// [`refine_near`] it never takes a whole fraction or a multiple of the lag for the shaft: the revolution is
/// known, and a faulty gear's strong mesh harmonic or a second impulse per revolution (which make a half or a
/// quarter of it repeat almost as well) must not cut it.
///
/// # Errors
/// Too short a record for two periods, or no peak inside the window (the signal does not repeat there).
pub fn period_near<T: Sample>(
    fft: &mut Fft,
    channels: &[&[T]],
    near: f64,
    tolerance: f64,
) -> Result<PeriodEstimate, SignalError> {
    let n = channels.iter().map(|c| c.len()).min().unwrap_or(0);
    let lo = ((near * (1.0 - tolerance)).floor() as usize).max(2);
    let hi = (near * (1.0 + tolerance)).ceil() as usize;
    if channels.is_empty() || n < 2 * hi + 4 {
        return Err(SignalError::TooShort { what: "repetition period".into(), needed: 2 * hi + 4, got: n });
    }
    let lag_max = n / 2;
    let sum = summed_autocorrelation(fft, channels, n, lag_max);
    let best = (lo..=hi).max_by(|a, b| sum[*a].total_cmp(&sum[*b])).unwrap_or(lo);
    // a maximum on the window's edge is the flank of a peak outside it, not a period inside
    if best == lo || best == hi || sum[best] <= 0.0 {
        return Err(SignalError::Invalid(format!(
            "no repetition period found between {lo} and {hi} samples: give the shaft speed"
        )));
    }
    Ok(PeriodEstimate { period_samples: refine(&sum, best as f64), confidence: sum[best], mesh_lag: None })
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

/// Coherence of the synchronous content between the two halves of `y`, a record resampled on a shaft's
/// angle at `period` points per (supposed) revolution: the halves' averages over their whole revolutions
/// are compared order by order, as sum Re(A_k conj(B_k)) / sqrt(sum |A_k|^2 sum |B_k|^2) over the orders
/// below a quarter of `period`, once over the orders not divisible by `d` and once over those that are
/// (order 0 left out). Content synchronous with the revolution reads near 1 (the same line in both halves),
/// noise near 0. When the revolution holds `d` turns of the shaft, the orders not divisible by `d` hold no
/// synchronous content while the others do. `None` with fewer than 8 revolutions.
pub fn halves_coherence(fft: &mut Fft, y: &[f64], period: usize, d: usize) -> Option<(f64, f64)> {
    let revs = y.len() / period.max(1);
    if revs < 8 || period < 8 || d < 2 {
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
    let (a, b) = (average(0), average(half));
    let coherence = |keep: &dyn Fn(usize) -> bool| {
        let (mut cross, mut ea, mut eb) = (0.0, 0.0, 0.0);
        for k in (1..period / 4).filter(|&k| keep(k)) {
            cross += a[k].0 * b[k].0 + a[k].1 * b[k].1;
            ea += a[k].0 * a[k].0 + a[k].1 * a[k].1;
            eb += b[k].0 * b[k].0 + b[k].1 * b[k].1;
        }
        if ea > 0.0 && eb > 0.0 { cross / (ea * eb).sqrt() } else { 0.0 }
    };
    Some((coherence(&|k| k % d != 0), coherence(&|k| k % d == 0)))
}

#[cfg(test)]
mod tests;
