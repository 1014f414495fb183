//! The repetition period of a signal from its autocorrelation: the shortest strong repetition, a shaft
//! period among the multiples of a mesh lag, the revolution inside a hunting period, a period near a known
//! one, and the repetition in whole cycles of a signal resampled on a line's angle.

use super::super::spectrum::{Fft, autocorrelation};
use super::super::{Sample, SignalError};

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
