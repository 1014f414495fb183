//! The tooth mesh of a recording whose speed is unknown: the harmonic series of lines (a comb) that stands
//! highest over the spectrum's local floor, each candidate spacing scored by the lines it predicts.

use super::spectrum::{Fft, averaged_power_each};
use super::{Sample, SignalError};

/// One candidate fundamental of [`comb_candidates`].
#[derive(Clone, Debug, PartialEq)]
pub struct CombCandidate {
    /// The comb's spacing (its fundamental), cycles per sample.
    pub frequency: f64,
    /// Evidence, nats: over the predicted lines, the log of each line's height over the local floor less
    /// the log of [`LINE_RATIO`], clamped to [-[`ABSENT_COST`], [`LINE_CAP`]], averaged over the channels.
    pub score: f64,
    /// Predicted lines (harmonics below the top of the band) that stand [`LINE_RATIO`] over the floor on
    /// some channel.
    pub standing: usize,
    /// Predicted lines.
    pub predicted: usize,
    /// The harmonic among the first four with the most height over the floor (the one to follow: a
    /// higher harmonic smears more under a wandering speed and may sit in a resonance's hump).
    pub strongest: usize,
}

/// The comb evidence of every spacing of a geometric grid, and its best local maxima.
#[derive(Clone, Debug)]
pub struct CombEvidence {
    /// Spacings, cycles per sample (relative steps of [`GRID_STEP`]).
    grid: Vec<f64>,
    /// Evidence per spacing (nats per segment and channel), each segment free to wander.
    total: Vec<f64>,
    /// The best local maxima, best first (at most 8, none within 3 % of a better one).
    pub peaks: Vec<CombCandidate>,
    /// Each channel's averaged spectrum.
    spectra: Vec<Lines>,
}

impl CombEvidence {
    /// The evidence of the comb of spacing `f` (cycles per sample): the grid's nearest point, 0 outside it
    /// (no evidence either way).
    pub fn at(&self, f: f64) -> f64 {
        let (Some(&lo), Some(&hi)) = (self.grid.first(), self.grid.last()) else { return 0.0 };
        if !(f >= lo && f <= hi) {
            return 0.0;
        }
        let i = ((f / lo).ln() / (1.0 + GRID_STEP).ln()).round() as usize;
        self.total[i.min(self.total.len() - 1)]
    }

    /// How far (nats of power) the harmonics of `f` (cycles per sample) that are multiples of `m` stand
    /// over their two neighbouring harmonics on the averaged spectrum (height over the local floor, best
    /// channel per line): the least margin over the first [`STANDING_MULTIPLES`] multiples below 0.45
    /// cycles per sample, the margin that half of them reach (every one of two or three). A comb of a divisor of the mesh in
    /// a rich spectrum (every shaft harmonic a line) holds the mesh lines as its multiples of m, each a local
    /// peak among the shaft lines around it; the mesh comb's own harmonics do not alternate like that. A
    /// mesh whose first harmonics lie under the noise while a resonance lifts others (hold-out machines:
    /// harmonics 5-10 stand, or 1-5 and not 6-8) leaves some multiples level with their neighbours, so
    /// half of them, not every one, must stand. `None` with fewer than two such multiples.
    pub fn multiples_stand_out(&self, f: f64, m: usize) -> Option<f64> {
        let height = |fk: f64| self.log_height(fk, f);
        let margins: Vec<f64> = (1..=STANDING_MULTIPLES)
            .map(|j| j * m)
            .take_while(|&k| (k + 1) as f64 * f < 0.45)
            .map_while(|k| {
                let on = height(k as f64 * f)?;
                let beside = height((k - 1) as f64 * f)?.max(height((k + 1) as f64 * f)?);
                Some(on - beside)
            })
            .collect();
        let mut margins = margins;
        margins.sort_by(|a, b| b.total_cmp(a));
        // half of them (every one of two or three)
        let n = margins.len();
        (n >= 2).then(|| margins[if n <= 3 { n - 1 } else { (n - 1) / 2 }])
    }
}

impl CombEvidence {
    /// Log height over the local floor (nats of power, at least ln 1e-3) of the line nearest `fk` (cycles
    /// per sample) on the averaged spectrum, best channel, sought within the line window but under 0.4 of
    /// the comb's spacing `f`; `None` outside the spectrum.
    fn log_height(&self, fk: f64, f: f64) -> Option<f64> {
        self.spectra
            .iter()
            .filter_map(|s| s.height(fk, search_half(fk * s.n as f64).min(0.4 * f * s.n as f64)))
            .fold(None, |a: Option<f64>, h| Some(a.map_or(h, |a| a.max(h))))
            .map(|h| h.max(1e-3).ln())
    }

    /// How far (nats of power) the second line of the comb of spacing `f` (cycles per sample) stands over its
    /// first on the averaged spectrum: a comb of half the mesh frequency holds the mesh as its second line
    /// and nothing of the gear at its first, while a mesh's own fundamental is a line of the mesh itself.
    /// `None` outside the spectrum.
    pub fn second_over_first(&self, f: f64) -> Option<f64> {
        Some(self.log_height(2.0 * f, f)? - self.log_height(f, f)?)
    }
}

/// Multiples of a comb's m-th harmonic checked by [`CombEvidence::multiples_stand_out`]: the mesh's first
/// four harmonics stand over the shaft lines beside them on a meshing gear with a flat path to the sensor,
/// the fifth and higher may sink among its sidebands; a housing resonance may lift harmonics 5-10 instead.
pub const STANDING_MULTIPLES: usize = 8;

/// Power over the local floor from which a predicted line counts for a candidate: the power averaged over
/// 16 or more half-overlapping Hann segments is a chi-square of about 40 degrees of freedom around its mean
/// (standard deviation about 0.22 of it), so the largest of a few bins of noise exceeds 2.5 times the
/// median with a probability well below 1e-4, while any mesh harmonic of a meshing gear stands far higher.
pub const LINE_RATIO: f64 = 2.5;
/// Cost of a predicted line that is absent (nats): bounded, so one missing harmonic (a zero of the tooth
/// impulse's spectrum, an anti-resonance of the housing) does not outweigh several clear ones.
pub const ABSENT_COST: f64 = 1.0;
/// Cap of one line's evidence (nats, e^5 = 150 times the floor): one huge line (mains hum, a fan) must not
/// make every divisor of its frequency a comb.
pub const LINE_CAP: f64 = 5.0;
/// Power over a single segment's local floor (its lower quartile, [`FLOOR_QUANTILE`]) from which a bin
/// counts as a line: one segment's noise power is exponential about its mean (lower quartile 0.29 of it),
/// exceeding 10 times the quartile (2.9 times the mean) with probability 6 %, and the sum over a hundred
/// or more segments averages that chance away while a line stands in every one.
pub const SEGMENT_RATIO: f64 = 10.0;
/// Quantile of a block of bins taken as its floor: the lower quartile stays between the lines where a
/// broken tooth's dense comb of shaft harmonics fills half of the bins (a median would sit on them).
pub const FLOOR_QUANTILE: f64 = 0.25;

/// The local floor of a power spectrum: the median of each block of 128 bins (a line or a smeared hump
/// occupies a few of them), one value per bin.
pub(crate) fn local_floor(power: &[f64]) -> Vec<f64> {
    let block = 128;
    let medians: Vec<f64> = power
        .chunks(block)
        .map(|c| {
            let mut v = c.to_vec();
            v.sort_by(f64::total_cmp);
            v[v.len() / 2].max(f64::MIN_POSITIVE)
        })
        .collect();
    (0..power.len()).map(|i| medians[i / block]).collect()
}

/// A channel's spectrum read for lines: power and floor per bin, `n` the segment length.
#[derive(Clone, Debug)]
struct Lines {
    power: Vec<f64>,
    floor: Vec<f64>,
    n: usize,
}

impl Lines {
    /// The height over the floor (power ratio) of the strongest bin within `half` bins of frequency `f`
    /// (cycles per sample); `None` outside the spectrum.
    fn height(&self, f: f64, half: f64) -> Option<f64> {
        let b = f * self.n as f64;
        let lo = (b - half).ceil().max(1.0) as usize;
        let hi = (b + half).floor() as usize;
        if hi + 1 >= self.power.len() || lo > hi {
            return None;
        }
        Some((lo..=hi).map(|i| self.power[i] / self.floor[i]).fold(0.0, f64::max))
    }
}

/// Half-width (bins) of the window in which a predicted line at bin `b` is sought: a bin and a half (the
/// Hann main lobe and a candidate step), widened to 0.4 % of the frequency (a speed wandering by a percent
/// keeps the averaged line's peak within a fraction of that).
fn search_half(b: f64) -> f64 {
    (0.004 * b).max(1.5)
}

/// Relative speed change within which each segment's comb may sit around a candidate: a machine's speed
/// wanders by 0.5-2 % (a motor under a fluctuating load), so a comb fixed over ten seconds smears its
/// harmonics into the floor while each short segment keeps them sharp near its own speed.
pub const SEGMENT_WANDER: f64 = 0.025;
/// Relative step of the grid of candidate spacings (a tenth of [`SEGMENT_WANDER`]'s half-window per step).
pub const GRID_STEP: f64 = 0.0025;
/// Harmonics scored per candidate: enough that the true spacing beats its half (every other line absent)
/// and its double (the odd harmonics lost), few enough that a housing resonance far up does not dominate.
pub const MAX_HARMONICS: usize = 16;

/// Harmonic series of lines in `channels` with fundamental between `lowest` and `highest` (cycles per
/// sample), best first. Each half-overlapping Hann segment (short: a few bins per lowest spacing) scores
/// every spacing of a geometric grid over its first [`MAX_HARMONICS`] harmonics below 0.45 cycles per
/// sample; a candidate's evidence is the sum over segments of the best segment score within
/// +-[`SEGMENT_WANDER`] of it (the speed may wander between segments). Segments resolve `finest` (cycles
/// per sample) with four bins; a coarser spacing of the grid has no evidence. The local maxima not within
/// 3 % of a better one are the peaks (at most 8), each refined on the averaged spectrum. A spacing half the true
/// one predicts every other line where there is none; twice the true one loses the odd harmonics: both
/// score lower than the true spacing when its lines stand.
///
/// # Errors
/// Too short a record for a spectrum of 1024-sample segments.
pub fn comb_candidates<T: Sample>(
    fft: &mut Fft,
    channels: &[&[T]],
    lowest: f64,
    highest: f64,
    finest: f64,
) -> Result<CombEvidence, SignalError> {
    let len = channels.iter().map(|c| c.len()).min().unwrap_or(0);
    let segment = ((4.0 / finest.max(1e-9)).min((1 << 15) as f64) as usize).next_power_of_two().clamp(1024, 1 << 15);
    let n = segment.min(len).max(8);
    let lowest = lowest.max(3.0 / n as f64);
    let highest = highest.min(0.45);
    if lowest.is_nan() || highest.is_nan() || lowest >= highest {
        return Ok(CombEvidence { grid: Vec::new(), total: Vec::new(), peaks: Vec::new(), spectra: Vec::new() });
    }
    let grid: Vec<f64> = (0..).map(|i| lowest * (1.0 + GRID_STEP).powi(i)).take_while(|&f| f <= highest).collect();
    let reach = (SEGMENT_WANDER / GRID_STEP).round() as usize;
    let mut total = vec![0.0; grid.len()];
    let mut plain = vec![0.0; grid.len()];
    let mut spectra = Vec::with_capacity(channels.len());
    for x in channels {
        let mut segment_score = vec![0.0; grid.len()];
        let mut evidence = Vec::new();
        let (power, n) = averaged_power_each(fft, &x[..len], n, 0.5, "mesh comb spectrum", false, |_, start, out| {
            if start < 0 || start as usize + n > len {
                return;
            }
            segment_evidence(out, &mut evidence);
            for (s, &f) in segment_score.iter_mut().zip(&grid) {
                *s = comb_evidence(&evidence, f * n as f64);
            }
            let wandered = sliding_max(&segment_score, reach);
            total.iter_mut().zip(&wandered).for_each(|(t, w)| *t += w);
            plain.iter_mut().zip(&segment_score).for_each(|(t, w)| *t += w);
        })?;
        let floor = local_floor(&power);
        spectra.push(Lines { power, floor, n });
    }
    let segments = ((len - n) / (n / 2) + 1) as f64 * channels.len() as f64;
    let mut peaks: Vec<usize> = (0..grid.len())
        .filter(|&i| (i == 0 || total[i - 1] <= total[i]) && (i + 1 == grid.len() || total[i + 1] < total[i]))
        .collect();
    peaks.sort_by(|&a, &b| total[b].total_cmp(&total[a]));
    let mut out: Vec<CombCandidate> = Vec::new();
    for i in peaks {
        if out.iter().any(|o| (grid[i] / o.frequency - 1.0).abs() <= 0.03) {
            continue;
        }
        // the wandered evidence is flat over +-SEGMENT_WANDER around the mean speed: the centre is where
        // the segments' own combs sum highest
        let lo = i.saturating_sub(reach);
        let hi = (i + reach).min(grid.len() - 1);
        let centre = (lo..=hi).max_by(|&a, &b| plain[a].total_cmp(&plain[b])).unwrap_or(i);
        let c = score(&spectra, grid[centre], 0.45);
        let frequency = refine(&spectra, &c);
        out.push(CombCandidate { frequency, score: total[i] / segments, ..c });
        if out.len() == 8 {
            break;
        }
    }
    total.iter_mut().for_each(|t| *t /= segments);
    Ok(CombEvidence { grid, total, peaks: out, spectra })
}

/// Per-bin evidence of one segment's spectrum `out` (complex bins): ln(power / (floor x [`SEGMENT_RATIO`]))
/// clamped to [-[`ABSENT_COST`], [`LINE_CAP`]], the floor the lower quartile of 64-bin blocks, then the largest
/// over each bin and its two neighbours (a line between two bins, the Hann main lobe).
fn segment_evidence(out: &[(f64, f64)], evidence: &mut Vec<f64>) {
    let power: Vec<f64> = out.iter().map(|c| c.0 * c.0 + c.1 * c.1).collect();
    let block = 64;
    let mut raw = Vec::with_capacity(power.len());
    for c in power.chunks(block) {
        let mut v = c.to_vec();
        v.sort_by(f64::total_cmp);
        let floor = v[(v.len() as f64 * FLOOR_QUANTILE) as usize].max(f64::MIN_POSITIVE) * SEGMENT_RATIO;
        raw.extend(c.iter().map(|p| (p / floor).max(f64::MIN_POSITIVE).ln().clamp(-ABSENT_COST, LINE_CAP)));
    }
    evidence.clear();
    evidence.extend((0..raw.len()).map(|i| {
        let lo = i.saturating_sub(1);
        let hi = (i + 1).min(raw.len() - 1);
        raw[lo..=hi].iter().copied().fold(f64::NEG_INFINITY, f64::max)
    }));
}

/// One segment's evidence for the comb of spacing `b` bins: the sum over its first [`MAX_HARMONICS`]
/// harmonics inside the spectrum (linear interpolation between bins).
fn comb_evidence(evidence: &[f64], b: f64) -> f64 {
    let top = 0.9 * (evidence.len() - 1) as f64;
    (1..=MAX_HARMONICS)
        .map(|k| k as f64 * b)
        .take_while(|&bk| bk < top)
        .map(|bk| {
            let i = bk as usize;
            let t = bk - i as f64;
            evidence[i] * (1.0 - t) + evidence[i + 1] * t
        })
        .sum()
}

/// The largest value within `reach` places of each place.
fn sliding_max(v: &[f64], reach: usize) -> Vec<f64> {
    (0..v.len())
        .map(|i| {
            let lo = i.saturating_sub(reach);
            let hi = (i + reach).min(v.len() - 1);
            v[lo..=hi].iter().copied().fold(f64::NEG_INFINITY, f64::max)
        })
        .collect()
}

/// The spacing of candidate `c` refined on its strongest harmonic: the peak bin of the channel where that
/// line stands highest, interpolated by a parabola through the log power of the bins around it (a
/// fraction of a bin for a Hann window), divided by the harmonic. The score's plateau is as wide as the
/// search window, so the grid point alone is off by up to the window.
fn refine(spectra: &[Lines], c: &CombCandidate) -> f64 {
    let k = c.strongest as f64;
    let fk = k * c.frequency;
    let best = spectra
        .iter()
        .filter_map(|s| {
            let b = fk * s.n as f64;
            let half = search_half(b);
            let lo = (b - half).ceil().max(2.0) as usize;
            let hi = ((b + half).floor() as usize).min(s.power.len().saturating_sub(3));
            (lo..=hi).max_by(|&i, &j| s.power[i].total_cmp(&s.power[j])).map(|i| (s, i))
        })
        .max_by(|a, b| (a.0.power[a.1] / a.0.floor[a.1]).total_cmp(&(b.0.power[b.1] / b.0.floor[b.1])));
    let Some((s, i)) = best else { return c.frequency };
    let l = |j: usize| s.power[j].max(f64::MIN_POSITIVE).ln();
    let (a, b0, d) = (l(i - 1), l(i), l(i + 1));
    let den = a - 2.0 * b0 + d;
    let shift = if den < 0.0 { (0.5 * (a - d) / den).clamp(-0.5, 0.5) } else { 0.0 };
    (i as f64 + shift) / s.n as f64 / k
}

/// The evidence of the comb of spacing `f` (cycles per sample) over its harmonics below `top`.
fn score(spectra: &[Lines], f: f64, top: f64) -> CombCandidate {
    let (mut total, mut standing, mut predicted, mut strongest, mut best) = (0.0, 0, 0, 1, 0.0);
    let mut k = 1;
    while (k as f64) * f < top {
        let fk = k as f64 * f;
        let mut sum = 0.0;
        let mut any = false;
        let mut height = 0.0_f64;
        for s in spectra {
            let Some(h) = s.height(fk, search_half(fk * s.n as f64)) else { continue };
            any |= h >= LINE_RATIO;
            height = height.max(h);
            sum += (h / LINE_RATIO).ln().clamp(-ABSENT_COST, LINE_CAP);
        }
        total += sum / spectra.len() as f64;
        predicted += 1;
        standing += usize::from(any);
        if k <= 4 && height > best {
            best = height;
            strongest = k;
        }
        k += 1;
    }
    CombCandidate { frequency: f, score: total, standing, predicted, strongest }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::test_noise::uniform_noise;
    use std::f64::consts::PI;

    /// A comb whose odd harmonics are weak (a strong second mesh harmonic) and whose fundamental sits among
    /// a louder foreign harmonic series (mains hum): the mesh spacing wins, neither its half nor its double.
    #[test]
    fn the_mesh_comb_beats_its_half_its_double_and_a_hum() {
        let n = 1 << 18;
        let mesh = 0.0213; // cycles per sample
        let hum = 0.00491;
        let mut noise = uniform_noise(12345);
        let x: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64;
                let m: f64 = (1..=6)
                    .map(|k| {
                        let a = if k % 2 == 0 { 1.0 } else { 0.15 };
                        a * (2.0 * PI * mesh * k as f64 * t).sin()
                    })
                    .sum();
                let h = 3.0 * (2.0 * PI * hum * t).sin() + 1.0 * (2.0 * PI * 3.0 * hum * t).sin();
                m + h + noise()
            })
            .collect();
        let mut fft = Fft::new();
        let c = comb_candidates(&mut fft, &[&x[..]], 0.002, 0.05, 0.002).unwrap().peaks;
        let best = &c[0];
        // the grid steps are a quarter bin of 1/16384: the spacing within half a bin of the truth
        assert!((best.frequency - mesh).abs() < 0.5 / 16384.0, "{c:?}");
    }

    /// A mesh whose harmonics 1, 3, 4 and 5 stand and 2, 6, 7, 8 lie under the noise (a housing that
    /// lifts some harmonics, the hold-out's 29/71 pinion): the comb of a third of its spacing is promoted
    /// by its multiples of 3 (four of its first eight stand clear over noise beside them; every one of the
    /// first four, the rule before, failed on the second harmonic), while the mesh comb itself is no
    /// divisor of anything (its even harmonics do not stand over the odd ones).
    #[test]
    fn a_divisor_comb_is_promoted_when_half_its_multiples_stand() {
        let n = 1 << 18;
        let mesh = 0.021;
        let mut noise = uniform_noise(99);
        let x: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64;
                [1, 3, 4, 5].iter().map(|&k| 0.5 * (2.0 * PI * mesh * k as f64 * t).sin()).sum::<f64>() + noise()
            })
            .collect();
        let e = comb_candidates(&mut Fft::new(), &[&x[..]], 0.003, 0.2, 0.002).unwrap();
        let divisor = e.multiples_stand_out(mesh / 3.0, 3).unwrap();
        assert!(divisor >= 0.69, "{divisor}");
        let mesh_itself = e.multiples_stand_out(mesh, 2).unwrap();
        assert!(mesh_itself < 0.69, "{mesh_itself}");
    }
}
