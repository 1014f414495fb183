//! Stage 1 of the mesh-phase tracking on a weak or smeared mesh line: the ridge of the whole mesh comb.
//!
//! A shaft speed that wanders by 1-2 % within a few revolutions smears a high mesh harmonic over many bins
//! of a frame of 8 revolutions (at order 243 a 1 % change is 2.4 orders), and a weak first harmonic lies
//! under the noise; the single line then stands no higher over its band than noise does. Here every mesh
//! harmonic k z below 0.45 cycles per sample (up to [`MAX_HARMONIC`]) votes for the speed in each frame:
//!
//!   S(u) = sum over k of ( |X(u k z f0)| / floor_k )^2,
//!
//! u the speed relative to the nominal f0 within +-`tolerance`, |X| the frame's Hann magnitude read by
//! linear interpolation between bins, floor_k the median magnitude of harmonic k's search band. The mesh
//! lines of all harmonics line up at one u while a shaft sideband of harmonic k sits at u = 1 +- 1/(k z),
//! different for every k. Frames of about 1, 2, 4 and 8 revolutions each give a ridge, the one whose
//! followed harmonic stands highest over its band first: short frames hold a fast-wandering high harmonic
//! in a few bins, long ones lift a steady line out of the noise.

use super::super::spectrum::{Fft, hann};
use super::super::{Sample, SignalError};
use super::MeshRidge;
use rayon::prelude::*;

/// Highest mesh harmonic that votes (a housing resonance lifts harmonics up to the 16th over the noise on
/// the generated gearboxes; higher ones add noise bins more than lines).
pub const MAX_HARMONIC: usize = 16;

/// Highest frequency of a voting harmonic, cycles per sample (an anti-alias filter's roll-off above).
const TOP: f64 = 0.45;

/// Frame lengths tried, revolutions (each rounded up to a power of two samples).
const FRAME_REVS: [f64; 4] = [1.0, 2.0, 4.0, 8.0];

/// How far the speed may wander from its mean within the recording, relative: the grid of u spans the
/// tolerance on the mean and this (the hold-out machines wander by up to +-1 %, a run-up more).
const WANDER: f64 = 0.03;

/// Fewest frames a frame length must give to be tried.
const MIN_FRAMES: usize = 6;

/// One frame's votes: S(u) on the grid, and each harmonic's search band (its first bin, its magnitudes)
/// with its floor.
struct FrameVotes {
    sum: Vec<f64>,
    bands: Vec<Band>,
}

/// A harmonic's search band in one frame.
struct Band {
    /// Centre bin at the nominal speed.
    centre: f64,
    /// First bin of `mag`.
    lo: usize,
    mag: Vec<f64>,
    floor: f64,
}

impl Band {
    /// The magnitude over the floor at relative speed `u`.
    fn height(&self, u: f64) -> f64 {
        read(&self.mag, u * self.centre - self.lo as f64) / self.floor
    }

    /// The line's height over the median of +-2 orders around it (`bpo` bins per order) at relative speed
    /// `u`, the line being the largest bin within one bin of u: as the single line's ridge measures it.
    fn line_over_band(&self, u: f64, bpo: f64) -> f64 {
        let last = self.mag.len() - 1;
        let p = (u * self.centre - self.lo as f64).clamp(0.0, last as f64);
        let k = argmax(&self.mag, (p.round() as usize).saturating_sub(1), (p.round() as usize + 1).min(last));
        let (a, b) = ((p - 2.0 * bpo).floor().max(0.0) as usize, ((p + 2.0 * bpo).ceil() as usize).min(last));
        self.mag[k] / median(self.mag[a..=b].to_vec()).max(1e-300)
    }
}

/// The ridges of the mesh comb of `z` teeth on a shaft of nominal revolution `period` samples, within
/// +-`tolerance` (relative) of it, one per frame length, the highest line first: the knots of the angle
/// each ridge's speed gives and, as the line to demodulate, the harmonic that stands highest along it
/// (with its median height over its band, dB). A ridge may wander 3 % beyond the tolerance; the
/// caller checks the mean speed it gives. The highest line is not always the one a phase-locked loop
/// holds: frames of 4 revolutions can lift a line higher than frames of 2 and still lag a speed that
/// wanders within a few revolutions, so the caller follows them in turn.
///
/// # Errors
/// No harmonic below 0.45 cycles per sample, or a recording shorter than six frames of one revolution.
pub fn comb_ridges<T: Sample>(x: &[T], period: f64, z: usize, tolerance: f64) -> Result<Vec<MeshRidge>, SignalError> {
    let tol = tolerance.clamp(1e-3, 0.3) + WANDER;
    let harmonics: Vec<usize> =
        (1..=MAX_HARMONIC).filter(|k| (k * z) as f64 * (1.0 + tol) / period < TOP && z > 0).collect();
    if harmonics.is_empty() || !(period.is_finite() && period >= 4.0) {
        return Err(SignalError::Invalid(format!(
            "no mesh harmonic of {z} teeth lies below the Nyquist frequency at {period:.1} samples per revolution"
        )));
    }
    let mut ridges: Vec<MeshRidge> = FRAME_REVS
        .iter()
        .map(|revs| ((revs * period).ceil() as usize).next_power_of_two())
        .filter(|nw| nw * (MIN_FRAMES + 3) / 4 <= x.len())
        .map(|nw| frames_ridge(x, period, z, tol, &harmonics, nw))
        .collect();
    if ridges.is_empty() {
        return Err(SignalError::TooShort {
            what: "mesh-comb tracking (six frames of a revolution)".into(),
            needed: (2.25 * period).ceil() as usize,
            got: x.len(),
        });
    }
    ridges.sort_by(|a, b| b.line_snr_db.total_cmp(&a.line_snr_db));
    Ok(ridges)
}

/// One ridge of [`comb_ridges`], with frames of `nw` samples.
fn frames_ridge<T: Sample>(x: &[T], period: f64, z: usize, tol: f64, harmonics: &[usize], nw: usize) -> MeshRidge {
    let n = x.len();
    // a quarter of a frame (with half a frame, one of the hold-out's m3 ridges was lost by the loop and
    // its speed ran 0.8 % off)
    let hop = nw / 4;
    let starts: Vec<usize> = (0..=(n - nw) / hop).map(|k| k * hop).collect();
    let bins_per_order = nw as f64 / period;
    let top = *harmonics.last().unwrap_or(&1) as f64 * z as f64 * bins_per_order;
    // half a bin at the highest harmonic (the peak is refined by a parabola)
    let du = 0.5 / top;
    let grid: Vec<f64> = (0..=(2.0 * tol / du).ceil() as usize).map(|j| 1.0 - tol + j as f64 * du).collect();
    let win = hann(nw);
    let votes: Vec<FrameVotes> = starts
        .par_iter()
        .map_init(
            || (Fft::new(), vec![0.0; nw]),
            |(fft, buf), &s| {
                for (b, (v, w)) in buf.iter_mut().zip(x[s..s + nw].iter().zip(&win)) {
                    *b = v.f() * w;
                }
                let mag = fft.forward_magnitudes(buf);
                frame_votes(&mag, &grid, harmonics, z, bins_per_order, tol)
            },
        )
        .collect();
    // the ridge: from the frame where the comb stands highest, followed frame to frame within a third of
    // the sideband spacing of the strongest harmonic
    let strongest = strongest_harmonic(&votes, &grid, harmonics.len());
    let reach = ((0.35 / (harmonics[strongest] * z) as f64 / du).floor() as usize).max(1);
    let u = follow(&votes, reach, &grid, du);
    let snr =
        median(votes.iter().zip(&u).map(|(v, &u)| v.bands[strongest].line_over_band(u, bins_per_order)).collect());
    let speeds: Vec<(f64, f64)> =
        starts.iter().zip(&u).map(|(&s, &u)| (s as f64 + nw as f64 / 2.0, u / period)).collect();
    MeshRidge {
        knots: integrate(&speeds, n),
        period,
        order: (harmonics[strongest] * z) as f64,
        line_snr_db: 20.0 * snr.max(1e-300).log10(),
    }
}

/// S(u) on `grid` for one frame's magnitudes `mag`, and each harmonic's height over its floor.
fn frame_votes(mag: &[f64], grid: &[f64], harmonics: &[usize], z: usize, bpo: f64, tol: f64) -> FrameVotes {
    let last = mag.len().saturating_sub(2) as f64;
    let bands: Vec<Band> = harmonics
        .iter()
        .map(|&k| {
            let centre = (k * z) as f64 * bpo;
            // the search band and two orders each side; its median is the floor
            let lo = (centre * (1.0 - tol) - 2.0 * bpo).floor().max(1.0) as usize;
            let hi = ((centre * (1.0 + tol) + 2.0 * bpo).ceil().min(last) as usize).max(lo + 1);
            let mag = mag[lo..=hi].to_vec();
            let floor = median(mag.clone()).max(1e-300);
            Band { centre, lo, mag, floor }
        })
        .collect();
    // band by band over the grid (u_j = u_0 + j du: the read position moves by du c per point)
    let mut sum = vec![0.0; grid.len()];
    let du = if grid.len() > 1 { grid[1] - grid[0] } else { 0.0 };
    for b in &bands {
        let (start, step) = (grid[0] * b.centre - b.lo as f64, du * b.centre);
        for (j, s) in sum.iter_mut().enumerate() {
            *s += (read(&b.mag, start + j as f64 * step) / b.floor).powi(2);
        }
    }
    FrameVotes { sum, bands }
}

/// The harmonic (index into the voting ones) whose peak over its floor is largest in most frames' best
/// vote: the median over frames of its height at each frame's comb peak.
fn strongest_harmonic(votes: &[FrameVotes], grid: &[f64], count: usize) -> usize {
    let peaks: Vec<usize> = votes.iter().map(|v| argmax(&v.sum, 0, v.sum.len() - 1)).collect();
    (0..count)
        .map(|h| (h, median(votes.iter().zip(&peaks).map(|(v, &j)| v.bands[h].height(grid[j])).collect())))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(0, |(h, _)| h)
}

/// The relative speed of each frame along the ridge: the path through the frames' votes, moving at most
/// `reach` grid points from frame to frame, whose votes (each over its frame's median) sum highest
/// (dynamic programming, so one frame where a passing tone lines up with the comb cannot pull the ridge
/// away); each frame's point refined by a parabola through it and its neighbours.
fn follow(votes: &[FrameVotes], reach: usize, grid: &[f64], du: f64) -> Vec<f64> {
    let g = grid.len();
    let gain = |f: usize| -> Vec<f64> {
        let m = median(votes[f].sum.clone());
        votes[f].sum.iter().map(|v| v - m).collect()
    };
    // best[j]: the highest sum of a path ending at j; from[f][j]: where that path was in frame f - 1
    let mut best = gain(0);
    let mut from: Vec<Vec<u32>> = Vec::with_capacity(votes.len());
    from.push(vec![0; g]);
    for f in 1..votes.len() {
        let own = gain(f);
        let reached = window_argmax(&best, reach);
        let next = reached.iter().zip(&own).map(|(&k, o)| best[k as usize] + o).collect();
        best = next;
        from.push(reached);
    }
    let mut j = argmax(&best, 0, g - 1);
    let mut path = vec![0; votes.len()];
    for f in (0..votes.len()).rev() {
        path[f] = j;
        j = from[f][j] as usize;
    }
    path.iter()
        .zip(votes)
        .map(|(&j, v)| {
            let s = &v.sum;
            let shift = if j > 0 && j + 1 < g {
                let den = s[j - 1] - 2.0 * s[j] + s[j + 1];
                if den < 0.0 { (0.5 * (s[j - 1] - s[j + 1]) / den).clamp(-0.5, 0.5) } else { 0.0 }
            } else {
                0.0
            };
            grid[j] + shift * du
        })
        .collect()
}

/// For each j, the index of the largest of `v[j - reach ..= j + reach]` (clipped to `v`; the first of
/// equal ones), in one pass with a queue of candidate indices (each enters and leaves once).
fn window_argmax(v: &[f64], reach: usize) -> Vec<u32> {
    let mut queue = std::collections::VecDeque::new();
    let mut out = Vec::with_capacity(v.len());
    let mut next = 0;
    for j in 0..v.len() {
        // bring in everything up to j + reach, dropping the smaller ones behind it
        while next < v.len() && next <= j + reach {
            while queue.back().is_some_and(|&b: &usize| v[b] < v[next]) {
                queue.pop_back();
            }
            queue.push_back(next);
            next += 1;
        }
        while queue.front().is_some_and(|&f| f + reach < j) {
            queue.pop_front();
        }
        out.push(queue.front().copied().unwrap_or(j) as u32);
    }
    out
}

/// Knots (sample, revolutions) of the angle whose speed (revolutions per sample) is `speeds` at the given
/// samples: trapezoids between them, the end speeds held out to samples 0 and `n`.
pub(super) fn integrate(speeds: &[(f64, f64)], n: usize) -> Vec<(f64, f64)> {
    let mut knots = vec![(0.0, 0.0), (speeds[0].0, speeds[0].1 * speeds[0].0)];
    for w in speeds.windows(2) {
        let th = knots[knots.len() - 1].1 + 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0);
        knots.push((w[1].0, th));
    }
    let (t_last, v_last) = speeds[speeds.len() - 1];
    let th = knots[knots.len() - 1].1 + v_last * (n as f64 - t_last);
    knots.push((n as f64, th));
    knots.dedup_by(|b, a| b.0 <= a.0);
    knots
}

/// `v` read at the fractional index `p` by linear interpolation (clamped to its ends).
fn read(v: &[f64], p: f64) -> f64 {
    // a cast, not floor (a library call on baseline x86-64): p is clamped to 0 or above
    let p = p.clamp(0.0, (v.len() - 1) as f64);
    let i = (p as usize).min(v.len().saturating_sub(2));
    if v.len() < 2 { v[0] } else { v[i] + (p - i as f64) * (v[i + 1] - v[i]) }
}

fn argmax(v: &[f64], a: usize, b: usize) -> usize {
    (a..=b).max_by(|&i, &j| v[i].total_cmp(&v[j])).unwrap_or(a)
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let m = v.len() / 2;
    *v.select_nth_unstable_by(m, f64::total_cmp).1
}
