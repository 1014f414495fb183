//! Where a gear's average changed against a healthy average of the same gear: the phase-aligned difference of
//! two residual signals and how much of its energy one tooth holds.
//!
//! A gear's residual (its TSA less the mean, the low shaft orders and the mesh harmonics) keeps the pattern of
//! its manufacturing errors, the same on every healthy recording of that gear. A crack, a spall or a broken
//! tooth adds a change at one tooth; subtracting the healthy average (shifted to the same angle origin, and
//! scaled by least squares for a change of load) leaves that change and the noise. The concentration is the
//! largest tooth pitch's share of the difference's energy over the median pitch's: about 1.5-3 for noise
//! alone over z pitches, several times that for a local fault even where it is too weak to make the average
//! itself impulsive.

use super::spectrum::Fft;

/// A one-sided complex order spectrum X_k = (re, im), k = 0..=K, of a signal over one revolution, normalised
/// by the number of points (X_k = (1/L) sum_n x_n exp(-2 pi i k n / L)).
pub type OrderSpectrum = Vec<(f64, f64)>;

/// The complex order spectrum of `x` (one revolution, any length) up to order `max_order` (or the record's
/// Nyquist order), DC set to zero.
pub fn order_spectrum(fft: &mut Fft, x: &[f64], max_order: usize) -> OrderSpectrum {
    let n = x.len().max(1) as f64;
    let mut input = x.to_vec();
    let mut out = Vec::new();
    fft.forward(&mut input, &mut out);
    out.truncate(max_order + 1);
    // kept spectra (one per revolution in the angle's refinement) hold only the orders asked for
    out.shrink_to_fit();
    for c in out.iter_mut() {
        *c = (c.0 / n, c.1 / n);
    }
    if let Some(c) = out.first_mut() {
        *c = (0.0, 0.0);
    }
    out
}

/// The mean of several order spectra (over their common length).
pub fn mean(spectra: &[&[(f64, f64)]]) -> OrderSpectrum {
    let len = spectra.iter().map(|s| s.len()).min().unwrap_or(0);
    let m = spectra.len().max(1) as f64;
    (0..len)
        .map(|k| {
            let (re, im) = spectra.iter().fold((0.0, 0.0), |a, s| (a.0 + s[k].0, a.1 + s[k].1));
            (re / m, im / m)
        })
        .collect()
}

/// How one average lines up with a reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alignment {
    /// Angle (revolutions, in [0, 1)) by which the signal lags the reference: x(theta) = r(theta - shift).
    pub shift: f64,
    /// Normalised correlation at that shift, Re sum X'_k conj(R_k) / sqrt(sum |X_k|^2 sum |R_k|^2), in [-1, 1].
    pub correlation: f64,
}

/// exp(2 pi i k s) for k = 0, 1, 2, ... by a turning phasor (one sin_cos, then a complex product per order;
/// re-anchored on a direct value every 256 orders, so the rounding stays near 1e-11 at order 4096).
fn phasors(s: f64) -> impl Iterator<Item = (f64, f64)> {
    let (sn, cs) = (2.0 * std::f64::consts::PI * s).sin_cos();
    let mut p = (1.0, 0.0);
    (0usize..).map(move |k| {
        if k % 256 == 0 {
            let (a, b) = (2.0 * std::f64::consts::PI * s * k as f64).sin_cos();
            p = (b, a);
        }
        let out = p;
        p = (p.0 * cs - p.1 * sn, p.0 * sn + p.1 * cs);
        out
    })
}

/// c(s) = Re sum_k C_k exp(2 pi i k s) and its first two derivatives in s.
fn correlation_at(c: &[(f64, f64)], s: f64) -> (f64, f64, f64) {
    let (mut v, mut d1, mut d2) = (0.0, 0.0, 0.0);
    for (k, (&(re, im), (cs, sn))) in c.iter().zip(phasors(s)).enumerate() {
        let w = 2.0 * std::f64::consts::PI * k as f64;
        let real = re * cs - im * sn;
        let imag = re * sn + im * cs;
        v += real;
        d1 -= w * imag;
        d2 -= w * w * real;
    }
    (v, d1, d2)
}

/// The shift that best lines `x` up with `reference`: the peak of their circular cross-correlation on a grid of
/// at least four points per period of the highest order, refined by Newton steps on its derivative.
pub fn align(fft: &mut Fft, x: &[(f64, f64)], reference: &[(f64, f64)]) -> Alignment {
    align_within(fft, x, reference, 0.5)
}

/// [`align`] with the shift sought within +-`reach` revolutions of 0 only (the peak of the cross-correlation
/// there; `shift` still in [0, 1)): a revolution lined up with an average of revolutions of the same gear
/// must not jump a tooth to a stronger peak one mesh cycle away.
pub fn align_within(fft: &mut Fft, x: &[(f64, f64)], reference: &[(f64, f64)], reach: f64) -> Alignment {
    let len = x.len().min(reference.len());
    // C_k = X_k conj(R_k) = |R_k|^2 exp(-2 pi i k shift) when x is the reference delayed by `shift`
    let c: Vec<(f64, f64)> = (0..len)
        .map(|k| (x[k].0 * reference[k].0 + x[k].1 * reference[k].1, x[k].1 * reference[k].0 - x[k].0 * reference[k].1))
        .collect();
    let energy = |s: &[(f64, f64)]| s[..len].iter().map(|c| c.0 * c.0 + c.1 * c.1).sum::<f64>();
    let norm = (energy(x) * energy(reference)).sqrt();
    if len < 2 || norm <= 0.0 || !norm.is_finite() {
        return Alignment { shift: 0.0, correlation: 0.0 };
    }
    let grid = (4 * len).next_power_of_two();
    let mut buf = vec![(0.0, 0.0); grid];
    buf[..len].copy_from_slice(&c);
    fft.inverse_complex(&mut buf);
    // grid points within the reach, as signed offsets (all of them at a reach of half a revolution)
    let half = ((reach * grid as f64) as usize).min(grid / 2);
    // offsets -half ..= -1 (the buffer's end), then 0 ..= min(half, grid / 2 - 1): the last maximum wins
    let negative = (grid - half..grid).map(|i| (i as isize - grid as isize, buf[i].0));
    let positive = (0..=half.min(grid / 2 - 1)).map(|i| (i as isize, buf[i].0));
    let best = negative.chain(positive).max_by(|a, b| a.1.total_cmp(&b.1)).map_or(0, |p| p.0);
    let mut s = best as f64 / grid as f64;
    for _ in 0..4 {
        let (_, d1, d2) = correlation_at(&c, s);
        if d2 >= 0.0 {
            break;
        }
        let step = (-d1 / d2).clamp(-0.5 / grid as f64, 0.5 / grid as f64);
        s += step;
        if step.abs() < 1e-12 {
            break;
        }
    }
    // (Newton may step past the reach by a grid point or two; at half a revolution there is no edge)
    let s = if reach < 0.5 { s.clamp(-reach, reach) } else { s };
    let (v, _, _) = correlation_at(&c, s);
    Alignment { shift: s.rem_euclid(1.0), correlation: v / norm }
}

/// `x` advanced by `shift` revolutions (its X_k times exp(2 pi i k shift)): undoes a lag found by [`align`].
pub fn advanced(x: &[(f64, f64)], shift: f64) -> OrderSpectrum {
    x.iter().zip(phasors(shift)).map(|(&(re, im), (cs, sn))| (re * cs - im * sn, re * sn + im * cs)).collect()
}

/// How much of the difference's energy one tooth holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Concentration {
    /// Energy of the largest tooth pitch over the median pitch's.
    pub ratio: f64,
    /// That pitch, 1-based: tooth n spans the angles [(n - 1) / z, n / z) of a revolution from the signal's
    /// origin.
    pub tooth: usize,
}

/// The least-squares scale s of `reference` to `x` (Re sum x_k conj(r_k) / sum |r_k|^2, over their common
/// orders); `None` when the reference is all zero or not finite.
fn scale(x: &[(f64, f64)], reference: &[(f64, f64)]) -> Option<f64> {
    let rr: f64 = reference.iter().map(|c| c.0 * c.0 + c.1 * c.1).sum();
    let xr: f64 = x.iter().zip(reference).map(|(a, b)| a.0 * b.0 + a.1 * b.1).sum();
    (rr > 0.0 && rr.is_finite()).then(|| xr / rr)
}

/// The change `x_k - s r_k` at order `k` once the reference is scaled by `s`.
fn change_at(x: &[(f64, f64)], reference: &[(f64, f64)], s: f64, k: usize) -> (f64, f64) {
    (x[k].0 - s * reference[k].0, x[k].1 - s * reference[k].1)
}

/// Energy |x_k - s r_k|^2 of [`change_at`].
fn change_energy(x: &[(f64, f64)], reference: &[(f64, f64)], s: f64, k: usize) -> f64 {
    let (re, im) = change_at(x, reference, s, k);
    re.powi(2) + im.powi(2)
}

/// The difference `x - s reference` over one revolution at `n` points (`n` a power of two of at least twice
/// the orders held), s the least-squares scale (so a change of load alone leaves little). `None` when the
/// reference is empty or all zero.
pub fn difference(fft: &mut Fft, x: &[(f64, f64)], reference: &[(f64, f64)], n: usize) -> Option<Vec<f64>> {
    let len = x.len().min(reference.len()).min(n / 2);
    let s = scale(&x[..len], &reference[..len]).filter(|_| len >= 2)?;
    let mut spec = vec![(0.0, 0.0); n / 2 + 1];
    for (k, c) in spec.iter_mut().enumerate().take(len).skip(1) {
        *c = change_at(x, reference, s, k);
    }
    Some(fft.inverse(&spec, n))
}

/// Points of the revolution [`concentration`] works on: twice the orders held, at least 8 per tooth.
pub fn points(orders: usize, z: usize) -> usize {
    (2 * orders).max(8 * z).next_power_of_two()
}

/// The [`difference`] of `x` and `reference` and its energy per tooth pitch of a gear with `z` teeth. `None`
/// when there is nothing to compare (an empty or all-zero reference, fewer than 2 teeth).
pub fn concentration(fft: &mut Fft, x: &[(f64, f64)], reference: &[(f64, f64)], z: usize) -> Option<Concentration> {
    if z < 2 {
        return None;
    }
    let n = points(x.len().min(reference.len()), z);
    let d = difference(fft, x, reference, n)?;
    let mut pitch: Vec<f64> = (0..z)
        .map(|i| {
            let (a, b) = (i * n / z, (i + 1) * n / z);
            d[a..b].iter().map(|v| v * v).sum::<f64>() / (b - a) as f64
        })
        .collect();
    let (tooth, top) = pitch.iter().copied().enumerate().max_by(|a, b| a.1.total_cmp(&b.1))?;
    pitch.sort_by(f64::total_cmp);
    let median = if z % 2 == 1 { pitch[z / 2] } else { 0.5 * (pitch[z / 2 - 1] + pitch[z / 2]) };
    (median > 0.0 && top.is_finite()).then_some(Concentration { ratio: top / median, tooth: tooth + 1 })
}

/// Where the change `x - s reference` (s the least-squares scale) lies between the orders that are not
/// multiples of `n` and those that are: the first's share of its energy over the share (n - 1) / n that
/// they hold of a change spread evenly over the orders (a local fault's, or noise). About 1 for a change
/// of the gear's own; near 0 for a change that repeats n times per revolution, which on a pair whose
/// teeth share a factor is the other gear's (`signal::tsa::split_period`). `None` for `n` under 2 or
/// nothing to compare.
pub fn own_share(x: &[(f64, f64)], reference: &[(f64, f64)], n: usize) -> Option<f64> {
    let len = x.len().min(reference.len());
    if n < 2 || len < 2 * n {
        return None;
    }
    let s = scale(&x[..len], &reference[..len])?;
    let (mut own, mut all) = (0.0, 0.0);
    for k in 1..len {
        let e = change_energy(x, reference, s, k);
        all += e;
        if !k.is_multiple_of(n) {
            own += e;
        }
    }
    (all > 0.0 && all.is_finite()).then(|| own / all * n as f64 / (n - 1) as f64)
}

/// How much the first-order sidebands (orders k z +- 1, every mesh harmonic k) changed: the energy of the
/// difference `x - s reference` (s the least-squares scale) at those orders over the energy of `s reference`
/// there. A change once per revolution of the gear (an eccentric gear, wear that differs from tooth to tooth)
/// modulates every mesh harmonic and lands on those orders. `None` when there is nothing to compare.
pub fn sideband_growth(x: &[(f64, f64)], reference: &[(f64, f64)], z: usize) -> Option<f64> {
    sideband_change(x, reference, z).map(|c| c.change / c.own)
}

/// The parts of [`sideband_growth`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SidebandChange {
    /// Energy of `x - s reference` at the first-order sidebands.
    pub change: f64,
    /// Energy of `s reference` there.
    pub own: f64,
    /// The least-squares scale s.
    pub scale: f64,
}

/// The first-order sideband orders k z +- 1 (k >= 1) of a gear of `z` teeth below `len`.
fn sideband_orders(len: usize, z: usize) -> impl Iterator<Item = usize> {
    (1..len).filter(move |k| k % z == 1 || k % z == z - 1)
}

/// [`sideband_growth`]'s energies and scale. `None` when there is nothing to compare.
pub fn sideband_change(x: &[(f64, f64)], reference: &[(f64, f64)], z: usize) -> Option<SidebandChange> {
    let len = x.len().min(reference.len());
    if z < 3 || len <= z + 1 {
        return None;
    }
    let s = scale(&x[..len], &reference[..len])?;
    let (mut change, mut own) = (0.0, 0.0);
    for k in sideband_orders(len, z) {
        change += change_energy(x, reference, s, k);
        own += s * s * (reference[k].0.powi(2) + reference[k].1.powi(2));
    }
    (own > 0.0).then_some(SidebandChange { change, own, scale: s })
}

/// How much noise one block puts at the first-order sidebands: the blocks' scatter about their mean there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scatter {
    /// Sum over the sideband orders of the blocks' variance about their mean (|X_b,k - mean_k|^2 summed over
    /// the blocks, over n - 1): the expected energy one block's noise puts there; a mean of n blocks holds
    /// 1/n of it.
    pub energy: f64,
    /// Blocks.
    pub blocks: usize,
}

impl Scatter {
    /// The noise energy the mean of the blocks holds at the sidebands: one block's over the block count.
    pub fn of_mean(self) -> f64 {
        self.energy / self.blocks as f64
    }
}

/// The [`Scatter`] of `blocks` (order spectra of one gear, on one angle origin) at the first-order sidebands
/// of a gear of `z` teeth. `None` from fewer than 2 blocks or z < 3.
pub fn sideband_scatter(blocks: &[OrderSpectrum], z: usize) -> Option<Scatter> {
    let len = blocks.iter().map(|b| b.len()).min().unwrap_or(0);
    if z < 3 || len <= z + 1 {
        return None;
    }
    scatter_at(blocks, sideband_orders(len, z))
}

/// The [`Scatter`] of `blocks` at the orders [`pattern_change`] reads (every order from 1 that is not a
/// multiple of `z`), each block's band around a mesh harmonic first scaled onto the mean's by its own
/// complex factor: the noise the figure carries. A carrier whose amplitude and phase wander from block to
/// block (the load's fluctuation) scales the gear's whole pattern in each band, which [`pattern_change`]
/// takes out of the mean as well, so it is no noise of that figure. `None` from fewer than 2 blocks or
/// z < 3.
pub fn pattern_scatter(blocks: &[OrderSpectrum], z: usize) -> Option<Scatter> {
    let n = blocks.len();
    let len = blocks.iter().map(|b| b.len()).min().unwrap_or(0);
    if n < 2 || z < 3 || len < 2 {
        return None;
    }
    let slices: Vec<&[(f64, f64)]> = blocks.iter().map(|b| &b[..len]).collect();
    let m = mean(&slices);
    let energy: f64 =
        blocks.iter().map(|b| pattern_parts(&b[..len], &m, z).map_or(0.0, |p| p.change)).sum::<f64>() / (n - 1) as f64;
    energy.is_finite().then_some(Scatter { energy, blocks: n })
}

/// The blocks' variance about their mean summed over `orders` (each below every block's length).
fn scatter_at(blocks: &[OrderSpectrum], orders: impl Iterator<Item = usize>) -> Option<Scatter> {
    let n = blocks.len();
    if n < 2 {
        return None;
    }
    let slices: Vec<&[(f64, f64)]> = blocks.iter().map(|b| b.as_slice()).collect();
    let m = mean(&slices);
    let energy: f64 = orders
        .map(|k| blocks.iter().map(|b| (b[k].0 - m[k].0).powi(2) + (b[k].1 - m[k].1).powi(2)).sum::<f64>())
        .sum::<f64>()
        / (n - 1) as f64;
    energy.is_finite().then_some(Scatter { energy, blocks: n })
}

/// How much a gear's own modulation pattern changed: the energy of the difference `x - c_k reference` over the
/// energy of `c_k reference`, summed over every order that is not a mesh harmonic (orders k z +- j, j < z / 2,
/// in the band of mesh harmonic k), with c_k the complex least-squares scale of the reference within that band.
///
/// A gear's average holds, around each mesh harmonic, the sidebands its own teeth put there (each tooth's
/// profile and pitch error, its runout): the mesh's carrier times the gear's modulation. A change of the
/// other gear of the pair (its wear, a load change) changes the carrier, the amplitude and phase of each mesh
/// harmonic, and with it every sideband of that band by the same complex factor, which `c_k` takes out; a
/// change of this gear's own teeth (wear that differs from tooth to tooth, a crack, runout) changes the
/// pattern within the band and stays. Both gears' averages see the same mesh harmonics, so the energy
/// indicators and the spectral change move on both for a fault of either; this measure tells which gear's
/// own teeth changed. `None` when there is nothing to compare (z < 3, an empty or all-zero reference).
pub fn pattern_change(x: &[(f64, f64)], reference: &[(f64, f64)], z: usize) -> Option<f64> {
    pattern_parts(x, reference, z).map(|p| p.change / p.own)
}

/// The two energies of [`pattern_change`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatternChange {
    /// Energy of `x - c_k reference` at the pattern's orders.
    pub change: f64,
    /// Energy of `c_k reference` there.
    pub own: f64,
}

/// [`pattern_change`]'s energies. `None` when there is nothing to compare.
pub fn pattern_parts(x: &[(f64, f64)], reference: &[(f64, f64)], z: usize) -> Option<PatternChange> {
    let len = x.len().min(reference.len());
    if z < 3 || len < 2 {
        return None;
    }
    let (mut change, mut own) = (0.0, 0.0);
    // the bands: orders (k - 1/2) z < order <= (k + 1/2) z around harmonic k, the first from order 1
    let mut lo = 1;
    while lo < len {
        let k = (lo + z / 2) / z;
        let hi = (k * z + z / 2 + 1).clamp(lo + 1, len);
        let band = (lo..hi).filter(|o| o % z != 0);
        // c = sum x conj(r) / sum |r|^2
        let (mut re, mut im, mut rr) = (0.0, 0.0, 0.0);
        for o in band.clone() {
            let ((a, b), (c, d)) = (x[o], reference[o]);
            re += a * c + b * d;
            im += b * c - a * d;
            rr += c * c + d * d;
        }
        if rr > 0.0 && rr.is_finite() {
            let (cr, ci) = (re / rr, im / rr);
            for o in band {
                let (c, d) = reference[o];
                let (pr, pi) = (cr * c - ci * d, cr * d + ci * c);
                change += (x[o].0 - pr).powi(2) + (x[o].1 - pi).powi(2);
                own += pr * pr + pi * pi;
            }
        }
        lo = hi;
    }
    (own > 0.0 && change.is_finite()).then_some(PatternChange { change, own })
}

#[cfg(test)]
pub(crate) mod tests;
