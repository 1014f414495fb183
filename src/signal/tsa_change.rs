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
pub(crate) mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// A revolution of `l` points holding a few sidebands of a 17-tooth gear's manufacturing pattern.
    fn pattern(l: usize, lag: f64) -> Vec<f64> {
        (0..l)
            .map(|i| {
                let t = i as f64 / l as f64 - lag;
                (2.0 * PI * 16.0 * t).sin()
                    + 0.7 * (2.0 * PI * 18.0 * t + 1.0).cos()
                    + 0.4 * (2.0 * PI * 35.0 * t).sin()
                    + 0.3 * (2.0 * PI * 5.0 * t + 0.4).cos()
            })
            .collect()
    }

    #[test]
    fn a_lag_is_found_to_a_small_fraction_of_a_point() {
        // the same band-limited pattern delayed by 0.3137 rev (not on any grid point): the lag is recovered
        // to 1e-9 rev (Newton on the exact correlation of a band-limited signal; rounding limits it)
        let mut fft = Fft::new();
        let r = order_spectrum(&mut fft, &pattern(512, 0.0), 64);
        let x = order_spectrum(&mut fft, &pattern(512, 0.3137), 64);
        let a = align(&mut fft, &x, &r);
        assert!((a.shift - 0.3137).abs() < 1e-9, "{a:?}");
        assert!((a.correlation - 1.0).abs() < 1e-9, "{a:?}");
        // advanced by the lag, the difference to the reference vanishes
        let back = advanced(&x, a.shift);
        let err: f64 = back.iter().zip(&r).map(|(p, q)| (p.0 - q.0).hypot(p.1 - q.1)).fold(0.0, f64::max);
        assert!(err < 1e-9, "{err}");
    }

    #[test]
    fn a_local_change_is_found_on_its_tooth() {
        // the pattern plus a short burst over tooth 7 of 17 (angles 6/17..7/17) against the pattern scaled by
        // 1.1 (a change of load): the burst's pitch holds several times the median's energy, found on tooth 7
        let mut fft = Fft::new();
        let l = 1024;
        let r = order_spectrum(&mut fft, &pattern(l, 0.0), 200);
        // broadband noise over every order to 200 (fixed pseudo-random phases), 0.2 % of the pattern's lines each
        let noise = |i: usize| -> f64 {
            (1..200).map(|k| 0.002 * (2.0 * PI * k as f64 * i as f64 / l as f64 + (k * k % 97) as f64).cos()).sum()
        };
        let mut y: Vec<f64> = pattern(l, 0.0).iter().enumerate().map(|(i, v)| 1.1 * v + noise(i)).collect();
        let (a, b) = (6 * l / 17, 7 * l / 17);
        for (i, v) in y.iter_mut().enumerate().take(b).skip(a) {
            let t = (i - a) as f64 / (b - a) as f64;
            *v += 0.2 * (PI * t).sin().powi(2) * (2.0 * PI * 120.0 * i as f64 / l as f64).sin();
        }
        let x = order_spectrum(&mut fft, &y, 200);
        let c = concentration(&mut fft, &x, &r, 17).expect("a reference");
        assert_eq!(c.tooth, 7, "{c:?}");
        // the burst's mean power (0.2^2 x 3/16) against the noise's (199 x 0.002^2 / 2) per point: about 19x
        assert!(c.ratio > 10.0, "{c:?}");
        // the scaled pattern and the noise alone: least squares takes the load change out and no pitch stands
        // out (broadband noise over 17 pitches of about 23 degrees of freedom each: the largest holds under
        // twice the median's energy; 3 leaves a margin)
        let plain: Vec<f64> = pattern(l, 0.0).iter().enumerate().map(|(i, v)| 1.1 * v + noise(i)).collect();
        let x = order_spectrum(&mut fft, &plain, 200);
        let c = concentration(&mut fft, &x, &r, 17).expect("a reference");
        assert!(c.ratio < 3.0, "{c:?}");
    }

    #[test]
    fn a_once_per_revolution_change_grows_the_first_sidebands() {
        // the pattern's sidebands of a 17-tooth gear's mesh harmonics (orders 16, 18, 35) against the same
        // pattern plus a mesh carrier (order 17) modulated once per revolution, which adds 0.5 cos at orders
        // 16 and 18: growth 0.5 / 1.65 = 0.30 before the least-squares scale (1.1087) takes part of the
        // order-18 change; numpy's rfft of the same two signals, by the same formula, gives 0.23587
        let mut fft = Fft::new();
        let l = 512;
        let base = pattern(l, 0.0);
        let r = order_spectrum(&mut fft, &base, 60);
        let modulated: Vec<f64> = base
            .iter()
            .enumerate()
            .map(|(i, v)| v + (2.0 * PI * 17.0 * i as f64 / l as f64).cos() * (2.0 * PI * i as f64 / l as f64).cos())
            .collect();
        let x = order_spectrum(&mut fft, &modulated, 60);
        let g = sideband_growth(&x, &r, 17).expect("a reference");
        // rounding only separates the two computations
        assert!((g - 0.235_873_79).abs() < 1e-6, "{g}");
        // the same pattern scaled (a load change) does not grow them
        let scaled: Vec<f64> = base.iter().map(|v| 1.2 * v).collect();
        let x = order_spectrum(&mut fft, &scaled, 60);
        assert!(sideband_growth(&x, &r, 17).expect("a reference") < 1e-20);
    }

    /// The order spectrum of a 17-tooth gear's average: mesh harmonics 1..=3 (orders 17, 34, 51), each
    /// multiplied by the complex carrier `carrier[k]`, with the sidebands of `pattern` (a per-order modulation,
    /// orders 1..=8 each side) around each, as an amplitude- and phase-modulated mesh puts them.
    fn modulated(carrier: [(f64, f64); 3], pattern: &[(f64, f64)]) -> OrderSpectrum {
        let z = 17;
        let mut x = vec![(0.0, 0.0); 4 * z];
        for (k, c) in carrier.iter().enumerate() {
            let h = (k + 1) * z;
            x[h] = *c;
            // the modulation a(theta) = sum_j A_j exp(i j theta) times the carrier C exp(i h theta): order
            // h + j holds C A_j (here A_j = pattern[j - 1] above the harmonic, its re and im swapped below)
            for (j, m) in pattern.iter().enumerate() {
                let times = |a: (f64, f64)| (c.0 * a.0 - c.1 * a.1, c.0 * a.1 + c.1 * a.0);
                x[h + j + 1] = times(*m);
                x[h - j - 1] = times((m.1, m.0));
            }
        }
        x
    }

    #[test]
    fn a_carrier_change_is_not_a_pattern_change() {
        // the same gear's pattern under other carriers (another mesh: each harmonic's amplitude and phase
        // changed differently) leaves nothing; a pattern changed at one order by a known amount leaves that
        // amount's energy share, to rounding
        let pattern: Vec<(f64, f64)> = (1..=8).map(|j| (0.3 / j as f64, 0.1 * (j as f64).sin())).collect();
        let r = modulated([(1.0, 0.0), (0.5, 0.2), (0.2, -0.1)], &pattern);
        let x = modulated([(0.4, 0.9), (-0.7, 0.1), (0.05, 0.3)], &pattern);
        let g = pattern_change(&x, &r, 17).expect("a reference");
        assert!(g < 1e-24, "{g}");
        // the global scale of [`sideband_growth`] does not take the per-harmonic change out
        assert!(sideband_growth(&x, &r, 17).expect("a reference") > 0.1);
        // a pattern change at the second sideband, 0.05 added to its modulation, with the carriers unchanged:
        // the band's least-squares scale absorbs a little of it, so the share lies just under the plain one
        let mut changed = pattern.clone();
        changed[1].0 += 0.05;
        let x = modulated([(1.0, 0.0), (0.5, 0.2), (0.2, -0.1)], &changed);
        let g = pattern_change(&x, &r, 17).expect("a reference");
        let plain = 2.0 * 0.05f64.powi(2) / (2.0 * pattern.iter().map(|m| m.0 * m.0 + m.1 * m.1).sum::<f64>());
        assert!(g < plain && g > 0.8 * plain, "{g} against {plain}");
    }

    #[test]
    fn turning_phasors_match_direct_evaluation() {
        // against sin_cos of each order's own angle, whose argument 2 pi s k is itself rounded by up to
        // 2 pi k eps (6e-12 at order 4096): re-anchoring every 256 orders keeps the recurrence's own drift
        // (about eps per step) well under that, so 2e-11 holds both
        for s in [0.3137, 1e-6, 0.999_999, 0.5] {
            for (k, (c, sn)) in phasors(s).take(4097).enumerate() {
                let (b, a) = (2.0 * PI * s * k as f64).sin_cos();
                assert!((c - a).abs() < 2e-11 && (sn - b).abs() < 2e-11, "s {s} order {k}");
            }
        }
    }

    #[test]
    fn nothing_to_compare_is_none() {
        let mut fft = Fft::new();
        let x = order_spectrum(&mut fft, &pattern(256, 0.0), 40);
        assert!(concentration(&mut fft, &x, &vec![(0.0, 0.0); 41], 17).is_none());
        assert!(concentration(&mut fft, &x, &x, 1).is_none());
        let a = align(&mut fft, &x, &[]);
        assert_eq!(a.correlation, 0.0);
    }

    /// A fixed pattern of `len` orders plus, per block, complex noise uniform in +-a/2 in each part (variance
    /// a^2 / 12 per part, a^2 / 6 per complex order).
    pub(crate) fn noisy_blocks(n: usize, len: usize, a: f64, seed: u64) -> Vec<OrderSpectrum> {
        let mut u = crate::signal::test_noise::uniform_noise(seed);
        let pattern = |k: usize| ((k as f64 * 0.37).sin(), (k as f64 * 1.3).cos());
        (0..n).map(|_| (0..len).map(|k| (pattern(k).0 + a * u(), pattern(k).1 + a * u())).collect()).collect()
    }

    #[test]
    fn block_scatter_is_the_noise_at_the_sidebands() {
        // z = 10 below order 60: the 12 orders 1, 9, 11, ..., 59 carry sidebands; the expected scatter is
        // 12 a^2 / 6. From 40 blocks the estimate of a sum of 24 equal variances with 39 degrees of freedom
        // each has a relative standard deviation of sqrt(2 / (24 x 39)) = 4.6 %: 15 % is over 3 of them
        let a = 0.2;
        let s = sideband_scatter(&noisy_blocks(40, 60, a, 7), 10).expect("blocks");
        let expected = 12.0 * a * a / 6.0;
        assert_eq!(s.blocks, 40);
        assert!((s.energy / expected - 1.0).abs() < 0.15, "{} against {expected}", s.energy);
        // too few blocks or teeth: nothing to say
        assert!(sideband_scatter(&noisy_blocks(1, 60, a, 7), 10).is_none());
        assert!(sideband_scatter(&noisy_blocks(5, 60, a, 7), 2).is_none());
    }

    #[test]
    fn pattern_scatter_is_the_noise_and_not_the_carrier_wander() {
        // z = 10 below order 60: 54 orders are not mesh harmonics (60 less 0, 10, ..., 50). Each block is
        // the pattern scaled by its own complex factor in every band (a carrier wandering 20 % in amplitude
        // and 0.3 rad in phase from block to block) plus uniform noise of a^2 / 6 per complex order. The
        // band's scale taken out (two real parameters of 2 x 9 or more per band: about 11 % fewer degrees
        // of freedom than the plain sum), the scatter is the noise's 54 a^2 / 6 to within 20 % (a sum of
        // 54 variances over 39 degrees of freedom each: 3 % standard deviation; 11 % for the fit), while
        // the plain scatter of the same blocks holds the carrier's wander many times over.
        let a = 0.05;
        let mut blocks = noisy_blocks(40, 60, a, 11);
        for (b, block) in blocks.iter_mut().enumerate() {
            for (o, v) in block.iter_mut().enumerate() {
                let band = (o + 4) / 10; // the bands of `pattern_parts`: (k - 1/2) z < o <= (k + 1/2) z
                let (g, ph) = (1.0 + 0.2 * ((b * 7 + band * 3) as f64).sin(), 0.3 * ((b * 5 + band) as f64).cos());
                let (c, s) = (g * ph.cos(), g * ph.sin());
                *v = (c * v.0 - s * v.1, c * v.1 + s * v.0);
            }
        }
        let expected = 54.0 * a * a / 6.0;
        let s = pattern_scatter(&blocks, 10).expect("blocks");
        assert!((s.energy / expected - 1.0).abs() < 0.2, "{} against {expected}", s.energy);
        let plain = scatter_at(&blocks, (1..60).filter(|o| o % 10 != 0)).expect("blocks");
        assert!(plain.energy > 10.0 * expected, "{} against {expected}", plain.energy);
        assert!(pattern_scatter(&blocks[..1], 10).is_none());
        assert!(pattern_scatter(&blocks, 2).is_none());
    }

    #[test]
    fn own_share_tells_a_change_of_the_gear_from_one_repeating_n_times() {
        // the same healthy pattern on both sides; an impulse added once per revolution (its orders all
        // equal) or three times per revolution (only every third order): shares of 1 and 0 by construction
        let orders = 300usize;
        let pattern: OrderSpectrum = (0..=orders)
            .map(|k| if k == 0 { (0.0, 0.0) } else { ((k as f64).sin(), (k as f64 * 0.7).cos()) })
            .collect();
        let with = |every: usize| -> OrderSpectrum {
            pattern
                .iter()
                .enumerate()
                .map(|(k, c)| if k > 0 && k % every == 0 { (c.0 + 0.5, c.1) } else { *c })
                .collect()
        };
        let once = own_share(&with(1), &pattern, 3).unwrap();
        let thrice = own_share(&with(3), &pattern, 3).unwrap();
        // the least-squares scale takes a little of the added change into the pattern: within 5 %
        assert!((once - 1.0).abs() < 0.05, "own change read as {once}");
        assert!(thrice < 0.05, "a change every third order read as {thrice}");
        assert!(own_share(&with(1), &pattern, 1).is_none());
    }
}
