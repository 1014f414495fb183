//! Condition indicators with the definitions of `reference/diagnostics.md` (N samples, overbar = mean):
//!
//! ```text
//! RMS      = sqrt(1/N sum x_i^2)                                   (on the TSA)
//! kurtosis = N sum (x_i - xbar)^4 / (sum (x_i - xbar)^2)^2           (non-excess; 3 for Gaussian)
//! crest    = max |x_i| / RMS
//! FM0      = (max x - min x) of the TSA / sum_n P_n,  P_n = amplitude of mesh harmonic n
//! FM4      = N   sum (d_i - dbar)^4 / (sum (d_i - dbar)^2)^2         (difference signal d)
//! M6A      = N^2 sum (d_i - dbar)^6 / (sum (d_i - dbar)^2)^3
//! M8A      = N^3 sum (d_i - dbar)^8 / (sum (d_i - dbar)^2)^4
//! NA4(M)   = N sum_i (r_iM - rbar_M)^4 / [ (1/M) sum_{j=1..M} sum_i (r_ij - rbar_j)^2 ]^2  (residual r)
//! NA4*     = the same with the denominator taken from a healthy baseline only
//! ER       = RMS(d) / RMS(y_r)                                        (regular signal y_r)
//! SI       = (A(f_m - f_r) + A(f_m + f_r)) / 2
//! SLF      = (A(f_m - f_r) + A(f_m + f_r)) / RMS(TSA)
//! SER      = sum_{i=1..6} (A(f_m + i f_r) + A(f_m - i f_r)) / A(f_m)
//! ```

use super::Sample;

/// Root mean square (about zero, not the mean).
pub fn rms<T: Sample>(x: &[T]) -> f64 {
    (x.iter().map(|v| v.f() * v.f()).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// Lanes of the sums below: four independent partial sums, which the compiler can keep in one vector
/// register (a single running sum waits for every addition in turn).
const LANES: usize = 4;

/// Sum of `x` in [`LANES`] partial sums.
fn lane_sum(x: &[f64]) -> f64 {
    let mut acc = [0.0; LANES];
    let chunks = x.chunks_exact(LANES);
    let rest: f64 = chunks.remainder().iter().sum();
    for c in chunks {
        for k in 0..LANES {
            acc[k] += c[k];
        }
    }
    acc.iter().sum::<f64>() + rest
}

/// Sums of (x - m)^2, ^4, ^6 and ^8, in [`LANES`] partial sums each.
fn central_sums(x: &[f64], m: f64) -> [f64; 4] {
    let mut acc = [[0.0; LANES]; 4];
    let chunks = x.chunks_exact(LANES);
    let rest = chunks.remainder();
    for c in chunks {
        for k in 0..LANES {
            let d2 = (c[k] - m) * (c[k] - m);
            let d4 = d2 * d2;
            acc[0][k] += d2;
            acc[1][k] += d4;
            acc[2][k] += d4 * d2;
            acc[3][k] += d4 * d4;
        }
    }
    let mut out = acc.map(|a| a.iter().sum::<f64>());
    for v in rest {
        let d2 = (v - m) * (v - m);
        let d4 = d2 * d2;
        out[0] += d2;
        out[1] += d4;
        out[2] += d4 * d2;
        out[3] += d4 * d4;
    }
    out
}

/// Sum of (x - mean)^2.
pub fn sum_sq_dev(x: &[f64]) -> f64 {
    let m = lane_sum(x) / x.len().max(1) as f64;
    let mut acc = [0.0; LANES];
    let chunks = x.chunks_exact(LANES);
    let rest: f64 = chunks.remainder().iter().map(|v| (v - m) * (v - m)).sum();
    for c in chunks {
        for k in 0..LANES {
            acc[k] += (c[k] - m) * (c[k] - m);
        }
    }
    acc.iter().sum::<f64>() + rest
}

/// Normalised central moment N^(k/2 - 1) sum (x - xbar)^k / (sum (x - xbar)^2)^(k/2), k even:
/// k = 4 is kurtosis / FM4, k = 6 is M6A, k = 8 is M8A.
pub fn normalized_moment<T: Sample>(x: &[T], k: i32) -> f64 {
    let n = x.len() as f64;
    let m = x.iter().map(|v| v.f()).sum::<f64>() / n;
    let (mut s2, mut sk) = (0.0, 0.0);
    for v in x {
        let d = v.f() - m;
        s2 += d * d;
        sk += d.powi(k);
    }
    n.powi(k / 2 - 1) * sk / s2.powi(k / 2)
}

/// [`normalized_moment`] for k = 4, 6 and 8 (FM4, M6A, M8A) in one pass.
pub fn normalized_moments_4_6_8(x: &[f64]) -> [f64; 3] {
    let n = x.len() as f64;
    let [s2, s4, s6, s8] = central_sums(x, lane_sum(x) / n);
    [n * s4 / (s2 * s2), n * n * s6 / (s2 * s2 * s2), n * n * n * s8 / (s2 * s2 * s2 * s2)]
}

/// Range and moments of a raw channel, from [`channel_moments`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChannelMoments {
    /// Smallest and largest sample.
    pub min: f32,
    /// Largest sample.
    pub max: f32,
    /// [`rms`] of the samples.
    pub rms: f64,
    /// [`kurtosis`] of the samples.
    pub kurtosis: f64,
}

/// Range, RMS and kurtosis of a channel in one pass: the first, second, third and fourth powers of the
/// samples less a shift (the mean of the first 4096 samples, near the mean, so that the central moments
/// taken from them lose no digits), summed in eight lanes so that it vectorises, in 256-bit vectors where
/// the processor has AVX2 and FMA; `Err(i)` with the index of the first sample that is not finite.
///
/// With d = x - c and S_k = sum d^k: mu = S_1 / n, C_2 = S_2 - n mu^2,
/// C_4 = S_4 - 4 mu S_3 + 6 mu^2 S_2 - 3 n mu^4; kurtosis = n C_4 / C_2^2, RMS = sqrt(sum x^2 / n).
/// A channel whose mean lies k standard deviations from its first 4096 samples' loses about 4 log10(k)
/// of the kurtosis's 16 digits to the cancellation in C_4 (a drift of 100 sigma: 8 left).
///
/// # Errors
/// The index of the first NaN or infinite sample.
pub fn channel_moments(x: &[f32]) -> Result<ChannelMoments, usize> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: `moments_avx2` only differs from `moments_of` in the instructions the compiler may use,
        // and both features were detected on this processor just above.
        return unsafe { moments_avx2(x) };
    }
    moments_of(x)
}

/// [`moments_of`] in 256-bit vectors: eight samples at a time, their range in f32 and their powers in two
/// f64 vectors of four (lanes 0-3 and 4-7, as in `moments_of`), the tail by `moments_of`'s own loop.
///
/// # Safety
/// The processor must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn moments_avx2(x: &[f32]) -> Result<ChannelMoments, usize> {
    use std::arch::x86_64::{
        __m256d, _mm256_add_pd, _mm256_castps256_ps128, _mm256_cvtps_pd, _mm256_extractf128_ps, _mm256_fmadd_pd,
        _mm256_loadu_ps, _mm256_max_ps, _mm256_min_ps, _mm256_mul_pd, _mm256_set1_pd, _mm256_set1_ps,
        _mm256_setzero_pd, _mm256_storeu_pd, _mm256_storeu_ps, _mm256_sub_pd,
    };
    const L: usize = 8;
    let shift = head_mean(x);
    let c = _mm256_set1_pd(shift);
    let (mut lo, mut hi) = (_mm256_set1_ps(f32::INFINITY), _mm256_set1_ps(f32::NEG_INFINITY));
    let mut s: [[__m256d; 2]; 4] = [[_mm256_setzero_pd(); 2]; 4];
    let chunks = x.chunks_exact(L);
    let rest = chunks.remainder();
    for ch in chunks {
        // SAFETY: `ch` holds 8 f32
        let v = unsafe { _mm256_loadu_ps(ch.as_ptr()) };
        lo = _mm256_min_ps(lo, v);
        hi = _mm256_max_ps(hi, v);
        let halves = [_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v)];
        for (h, half) in halves.into_iter().enumerate() {
            let d = _mm256_sub_pd(_mm256_cvtps_pd(half), c);
            let d2 = _mm256_mul_pd(d, d);
            s[0][h] = _mm256_add_pd(s[0][h], d);
            s[1][h] = _mm256_add_pd(s[1][h], d2);
            s[2][h] = _mm256_fmadd_pd(d2, d, s[2][h]);
            s[3][h] = _mm256_fmadd_pd(d2, d2, s[3][h]);
        }
    }
    let (mut lo_l, mut hi_l) = ([0.0f32; L], [0.0f32; L]);
    let mut sums = [[0.0f64; L]; 4];
    // SAFETY: each array holds 8 values of the vector type's lane width
    unsafe {
        _mm256_storeu_ps(lo_l.as_mut_ptr(), lo);
        _mm256_storeu_ps(hi_l.as_mut_ptr(), hi);
        for (k, lanes) in sums.iter_mut().enumerate() {
            _mm256_storeu_pd(lanes.as_mut_ptr(), s[k][0]);
            _mm256_storeu_pd(lanes.as_mut_ptr().add(4), s[k][1]);
        }
    }
    let mut acc = Lanes { lo: lo_l, hi: hi_l, sums };
    for (k, v) in rest.iter().enumerate() {
        acc.add(k, *v, shift);
    }
    acc.finish(x, shift)
}

/// The mean of a channel's first 4096 samples: the shift of [`channel_moments`]' powers.
#[inline(always)]
fn head_mean(x: &[f32]) -> f64 {
    let head = &x[..x.len().min(4096)];
    head.iter().map(|&v| f64::from(v)).sum::<f64>() / head.len().max(1) as f64
}

/// Eight lanes of [`channel_moments`]' running range and power sums.
struct Lanes {
    lo: [f32; 8],
    hi: [f32; 8],
    /// Sums of d, d^2, d^3, d^4 (d = x - shift) per lane.
    sums: [[f64; 8]; 4],
}

impl Lanes {
    #[inline(always)]
    fn add(&mut self, k: usize, v: f32, shift: f64) {
        self.lo[k] = self.lo[k].min(v);
        self.hi[k] = self.hi[k].max(v);
        let d = f64::from(v) - shift;
        let d2 = d * d;
        self.sums[0][k] += d;
        self.sums[1][k] += d2;
        self.sums[2][k] += d2 * d;
        self.sums[3][k] += d2 * d2;
    }

    /// The moments from the lanes (or the first non-finite sample of `x`).
    fn finish(&self, x: &[f32], shift: f64) -> Result<ChannelMoments, usize> {
        let min = self.lo.iter().copied().fold(f32::INFINITY, f32::min);
        let max = self.hi.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        let [s1, s2, s3, s4] = self.sums.map(|lanes| lanes.iter().sum::<f64>());
        // a NaN or an infinity makes the fourth-power sum NaN or infinite (min / max may skip a NaN)
        if !(min.is_finite() && max.is_finite() && s4.is_finite()) {
            return Err(x.iter().position(|v| !v.is_finite()).unwrap_or(0));
        }
        let n = x.len().max(1) as f64;
        let mu = s1 / n;
        let c2 = s2 - n * mu * mu;
        let c4 = s4 - 4.0 * mu * s3 + 6.0 * mu * mu * s2 - 3.0 * n * mu.powi(4);
        let mean = shift + mu;
        // sum x^2 = sum (x - mean)^2 + n mean^2
        Ok(ChannelMoments { min, max, rms: ((c2 + n * mean * mean) / n).sqrt(), kurtosis: n * c4 / (c2 * c2) })
    }
}

/// [`channel_moments`] without vector instructions.
fn moments_of(x: &[f32]) -> Result<ChannelMoments, usize> {
    let shift = head_mean(x);
    let mut acc = Lanes { lo: [f32::INFINITY; 8], hi: [f32::NEG_INFINITY; 8], sums: [[0.0; 8]; 4] };
    for c in x.chunks(8) {
        for (k, v) in c.iter().enumerate() {
            acc.add(k, *v, shift);
        }
    }
    acc.finish(x, shift)
}

/// Non-excess kurtosis (3 for Gaussian).
pub fn kurtosis<T: Sample>(x: &[T]) -> f64 {
    normalized_moment(x, 4)
}

/// max |x| / RMS.
pub fn crest_factor(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |a, v| a.max(v.abs())) / rms(x)
}

/// RMS, kurtosis, crest factor and peak-to-peak of an average, in two passes over it (its mean, then the
/// rest); the same values as [`rms`] and [`crest_factor`] of the centred signal, [`kurtosis`] and the range
/// [`fm0`] divides.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AverageMoments {
    /// Root mean square about the mean (unit of the signal).
    pub rms: f64,
    /// Normalised fourth central moment.
    pub kurtosis: f64,
    /// Largest |x - mean| over the RMS.
    pub crest_factor: f64,
    /// Largest minus least value (unit of the signal).
    pub peak_to_peak: f64,
}

impl AverageMoments {
    /// The moments of `x` (not empty).
    pub fn of(x: &[f64]) -> Self {
        let n = x.len() as f64;
        let mean = lane_sum(x) / n;
        let [s2, s4, _, _] = central_sums(x, mean);
        let (lo, hi) = lane_range(x);
        let rms = (s2 / n).sqrt();
        let peak = (hi - mean).max(mean - lo);
        Self { rms, kurtosis: n * s4 / (s2 * s2), crest_factor: peak / rms, peak_to_peak: hi - lo }
    }
}

/// Least and largest value of `x`, in [`LANES`] partial ranges.
fn lane_range(x: &[f64]) -> (f64, f64) {
    let (mut lo, mut hi) = ([f64::INFINITY; LANES], [f64::NEG_INFINITY; LANES]);
    let chunks = x.chunks_exact(LANES);
    let rest = chunks.remainder();
    for c in chunks {
        for k in 0..LANES {
            lo[k] = lo[k].min(c[k]);
            hi[k] = hi[k].max(c[k]);
        }
    }
    let lo = lo.iter().chain(rest).copied().fold(f64::INFINITY, f64::min);
    let hi = hi.iter().chain(rest).copied().fold(f64::NEG_INFINITY, f64::max);
    (lo, hi)
}

/// FM0 = peak-to-peak of the TSA / sum of the mesh-harmonic amplitudes.
pub fn fm0(tsa: &[f64], mesh_amplitudes: &[f64]) -> f64 {
    let (lo, hi) = tsa.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    (hi - lo) / mesh_amplitudes.iter().sum::<f64>()
}

/// NA4 of the last record: `current` residual and the sums of squared deviations of all records so far
/// (including the current one), in time order.
pub fn na4(current: &[f64], sums_sq_so_far: &[f64]) -> f64 {
    let n = current.len() as f64;
    let m = current.iter().sum::<f64>() / n;
    let s4: f64 = current.iter().map(|v| (v - m).powi(4)).sum();
    let mean_ss = sums_sq_so_far.iter().sum::<f64>() / sums_sq_so_far.len() as f64;
    n * s4 / (mean_ss * mean_ss)
}

/// ER = RMS(difference) / RMS(regular), both about their means, from the difference signal and the regular
/// signal's energy (sum of squares over as many samples; it has no mean, its DC bin being left out).
pub fn energy_ratio(difference: &[f64], regular_energy: f64) -> f64 {
    (sum_sq_dev(difference) / regular_energy).sqrt()
}

/// SBR: the first-order sidebands' energy over the other orders of their band, against the mesh lines'
/// energy, summed over every mesh harmonic that the amplitude spectrum holds with both its sidebands:
/// SBR = sum_k max(A(k z - 1)^2 + A(k z + 1)^2 - 2 F_k, 0) / sum_k A(k z)^2, k = 1, 2, ... while
/// k z + 1 < len, with F_k the median of A(j)^2 over the other orders j of the band |j - k z| <= z / 2
/// (orders 3 and up). A change once per revolution of the gear (an eccentric gear, wear that differs from
/// tooth to tooth) modulates every mesh harmonic and raises its first sidebands over the rest of the
/// gear's pattern; broadband energy (noise, a shock in the block) raises the whole band and is taken out
/// with F_k. The sum weighs each harmonic by its own energy, so the harmonics a housing resonance lifts out
/// of the noise carry it where the first one is buried (SER and SI read the first harmonic only). A
/// harmonic whose mesh or sideband bin `other(bin)` claims (a line of another shaft or another mesh of the
/// same shaft, which is not this gear's modulation) is left out, and so are such bins from F_k. NaN when
/// no harmonic fits or the mesh lines hold no energy.
pub fn first_sideband_ratio(amplitudes: &[f64], z: usize, other: impl Fn(usize) -> bool) -> f64 {
    let (mut side, mut mesh) = (0.0, 0.0);
    let mut band = Vec::with_capacity(z + 1);
    for k in (1..).map(|h| h * z).take_while(|&k| z > 1 && k + 1 < amplitudes.len()) {
        if other(k - 1) || other(k) || other(k + 1) {
            continue;
        }
        band.clear();
        band.extend(
            (k.saturating_sub(z / 2).max(3)..=(k + z / 2).min(amplitudes.len() - 1))
                .filter(|&j| (j + 1 < k || j > k + 1) && !other(j))
                .map(|j| amplitudes[j].powi(2)),
        );
        let floor = band_median(&mut band);
        side += (amplitudes[k - 1].powi(2) + amplitudes[k + 1].powi(2) - 2.0 * floor).max(0.0);
        mesh += amplitudes[k].powi(2);
    }
    if mesh > 0.0 { side / mesh } else { f64::NAN }
}

/// The median of `band` (0 when empty), found by selection: the values are reordered. The same value as a
/// full sort's middle (or the mean of its two middle values).
fn band_median(band: &mut [f64]) -> f64 {
    let n = band.len();
    if n == 0 {
        return 0.0;
    }
    let (below, &mut middle, _) = band.select_nth_unstable_by(n / 2, f64::total_cmp);
    if n % 2 == 1 {
        middle
    } else {
        let lower = below.iter().copied().max_by(f64::total_cmp).unwrap_or(middle);
        0.5 * (lower + middle)
    }
}

/// SER: six sideband pairs at spacing `spacing` bins around `mesh` in an amplitude spectrum (bins beyond
/// the spectrum count as zero), divided by the mesh amplitude.
pub fn sideband_energy_ratio(amplitudes: &[f64], mesh: usize, spacing: usize) -> f64 {
    let get = |i: isize| if i >= 0 { amplitudes.get(i as usize).copied().unwrap_or(0.0) } else { 0.0 };
    let sum: f64 =
        (1..=6).map(|i| get((mesh + i * spacing) as isize) + get(mesh as isize - (i * spacing) as isize)).sum();
    sum / amplitudes[mesh]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SBR of lines placed by hand: harmonics 10 and 20 of amplitude 2 and 1 with sidebands 0.2 and 0.3
    /// over an empty band give (2 * 0.04 + 2 * 0.09) / (4 + 1) = 0.052; a floor of 0.1 under every order
    /// takes 2 * 0.01 out of each harmonic's sidebands, (0.06 + 0.16) / 5 = 0.044; a spectrum too short for
    /// one harmonic's sidebands is NaN.
    #[test]
    fn band_median_is_the_sorted_middle() {
        // against the definition: the middle of the sorted values, or the mean of the two middle ones
        for n in 0..12usize {
            let values: Vec<f64> = (0..n).map(|i| ((i * 7919) % 13) as f64 - 0.5 * i as f64).collect();
            let mut sorted = values.clone();
            sorted.sort_by(f64::total_cmp);
            let expected = match n {
                0 => 0.0,
                n if n % 2 == 1 => sorted[n / 2],
                n => 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]),
            };
            assert_eq!(band_median(&mut values.clone()), expected, "{n} values");
        }
    }

    #[test]
    fn first_sideband_ratio_of_placed_lines() {
        let mut a = vec![0.0; 25];
        a[10] = 2.0;
        a[20] = 1.0;
        for k in [9, 11] {
            a[k] = 0.2;
        }
        for k in [19, 21] {
            a[k] = 0.3;
        }
        a[5] = 7.0; // a shaft order is not a sideband
        let none = |_| false;
        assert!((first_sideband_ratio(&a, 10, none) - 0.052).abs() < 1e-15);
        assert!(first_sideband_ratio(&a[..11], 10, none).is_nan());
        assert!(first_sideband_ratio(&a, 1, none).is_nan());
        // a line of another shaft at order 19.4 claims bin 19: harmonic 20 is left out, 0.08 / 4 = 0.02
        assert!((first_sideband_ratio(&a, 10, |b| b == 19) - 0.02).abs() < 1e-15);
        let floored: Vec<f64> = a.iter().map(|&v| if v == 0.0 { 0.1 } else { v }).collect();
        assert!((first_sideband_ratio(&floored, 10, none) - 0.044).abs() < 1e-15);
    }

    /// The sums in lanes equal one running sum (to rounding), whatever the length's remainder.
    #[test]
    fn lane_sums_equal_the_plain_sums() {
        for n in [1usize, 3, 4, 5, 1027] {
            let x: Vec<f64> = (0..n).map(|i| (1.3 * i as f64).sin().powi(3) + 0.1 * i as f64 / n as f64).collect();
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-11 * b.abs().max(1e-300);
            let m = x.iter().sum::<f64>() / n as f64;
            let ssd: f64 = x.iter().map(|v| (v - m) * (v - m)).sum();
            assert!(close(sum_sq_dev(&x), ssd), "{n}");
            if n > 2 {
                let fused = normalized_moments_4_6_8(&x);
                for (k, f) in [4, 6, 8].into_iter().zip(fused) {
                    assert!(close(f, normalized_moment(&x, k)), "{n} {k}: {f} {}", normalized_moment(&x, k));
                }
                let am = AverageMoments::of(&x);
                let hi = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                let lo = x.iter().copied().fold(f64::INFINITY, f64::min);
                assert_eq!(am.peak_to_peak, hi - lo, "{n}");
            }
        }
    }

    /// The fused moments equal the separate definitions (to rounding: the same sums in another order at most).
    #[test]
    fn average_moments_are_the_separate_indicators() {
        let x: Vec<f64> =
            (0..2048).map(|i| (0.37 * i as f64).sin() + 0.2 * (0.011 * (i * i) as f64).cos() + 0.5).collect();
        let m = AverageMoments::of(&x);
        let mean = x.iter().sum::<f64>() / x.len() as f64;
        let centred: Vec<f64> = x.iter().map(|v| v - mean).collect();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
        assert!(close(m.rms, rms(&centred)), "{} {}", m.rms, rms(&centred));
        assert!(close(m.kurtosis, kurtosis(&x)), "{} {}", m.kurtosis, kurtosis(&x));
        assert!(close(m.crest_factor, crest_factor(&centred)));
        let amps = [2.0];
        assert!(close(m.peak_to_peak / 2.0, fm0(&x, &amps)));
    }

    #[test]
    fn moments_work_on_hand_computed_arrays() {
        // x = [1, 2, 3, 4, 10]: mean 4, deviations -3 -2 -1 0 6
        let x = [1.0, 2.0, 3.0, 4.0, 10.0];
        let (s2, s4, s6, s8) = (
            9.0 + 4.0 + 1.0 + 36.0,
            81.0 + 16.0 + 1.0 + 1296.0,
            729.0 + 64.0 + 1.0 + 46656.0,
            6561.0 + 256.0 + 1.0 + 1679616.0,
        );
        assert!((kurtosis(&x) - 5.0 * s4 / (s2 * s2)).abs() < 1e-12);
        assert!((normalized_moment(&x, 6) - 25.0 * s6 / (s2 * s2 * s2)).abs() < 1e-12);
        assert!((normalized_moment(&x, 8) - 125.0 * s8 / (s2 * s2 * s2 * s2)).abs() < 1e-12);
        // the channel moments of the same samples (f32 exactly), and the first non-finite sample found
        let c = channel_moments(&[1.0f32, 2.0, 3.0, 4.0, 10.0]).unwrap();
        assert!((c.kurtosis - 5.0 * s4 / (s2 * s2)).abs() < 1e-12 && (c.rms - (26.0f64).sqrt()).abs() < 1e-12);
        assert_eq!((c.min, c.max), (1.0, 10.0));
        let mut long: Vec<f32> = (0..37).map(|i| i as f32).collect();
        long[29] = f32::NAN;
        assert_eq!(channel_moments(&long), Err(29));
        long[29] = f32::NEG_INFINITY;
        assert_eq!(channel_moments(&long), Err(29));
        // the one-pass FM4 / M6A / M8A against the same hand sums (rounding of a few operations only)
        let [m4, m6, m8] = normalized_moments_4_6_8(&x);
        assert!((m4 - 5.0 * s4 / (s2 * s2)).abs() < 1e-12);
        assert!((m6 - 25.0 * s6 / (s2 * s2 * s2)).abs() < 1e-12);
        assert!((m8 - 125.0 * s8 / (s2 * s2 * s2 * s2)).abs() < 1e-12);
        assert!((rms(&x) - (130.0f64 / 5.0).sqrt()).abs() < 1e-12);
        assert!((crest_factor(&x) - 10.0 / (26.0f64).sqrt()).abs() < 1e-12);
    }

    /// The one-pass channel moments (vectorised where the processor allows, and without vectors) against a
    /// plain two-pass sum in f64 (mean first, then the central powers): a noisy sine on a DC offset 1000
    /// times its amplitude, whose shifted powers would lose every digit without the shift, and a
    /// length that leaves a tail after the lanes. Tolerance 1e-9 relative: both sum the same f64 values in
    /// different orders (the reference two-pass sum over 100 003 terms rounds to about 1e-12).
    #[test]
    fn channel_moments_match_a_two_pass_sum() {
        let mut noise = crate::signal::test_noise::uniform_noise(3);
        let x: Vec<f32> = (0..100_003)
            .map(|i| (1000.0 + (i as f64 * 0.013).sin() + 0.3 * noise() + 0.05 * (i % 7) as f64) as f32)
            .collect();
        let n = x.len() as f64;
        let mean = x.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
        let (s2, s4) = x.iter().fold((0.0, 0.0), |(a, b), &v| {
            let d = f64::from(v) - mean;
            (a + d * d, b + d.powi(4))
        });
        let rms = (x.iter().map(|&v| f64::from(v).powi(2)).sum::<f64>() / n).sqrt();
        let kurt = n * s4 / (s2 * s2);
        let (lo, hi) = x.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), &v| (l.min(v), h.max(v)));
        for m in [channel_moments(&x).unwrap(), moments_of(&x).unwrap()] {
            assert_eq!((m.min, m.max), (lo, hi));
            assert!((m.rms / rms - 1.0).abs() < 1e-9, "{} {rms}", m.rms);
            assert!((m.kurtosis / kurt - 1.0).abs() < 1e-9, "{} {kurt}", m.kurtosis);
        }
        // a non-finite sample in the lanes and in the tail is found, by both
        for at in [5, 100_001] {
            let mut y = x.clone();
            y[at] = f32::INFINITY;
            assert_eq!(channel_moments(&y), Err(at));
            assert_eq!(moments_of(&y), Err(at));
        }
    }

    #[test]
    fn gaussian_difference_gives_3_15_105() {
        // Box-Muller from a fixed LCG: FM4 ~ 3, M6A ~ 15, M8A ~ 105 (Gaussian moments 3, 15, 105)
        let mut s = 7u64;
        let mut u = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let x: Vec<f64> =
            (0..400_000).map(|_| (-2.0 * u().ln()).sqrt() * (2.0 * std::f64::consts::PI * u()).cos()).collect();
        // sampling error of the k-th moment estimate shrinks as 1/sqrt(N); the 8th moment is the noisiest
        assert!((kurtosis(&x) - 3.0).abs() < 0.05);
        assert!((normalized_moment(&x, 6) - 15.0).abs() < 0.6);
        assert!((normalized_moment(&x, 8) - 105.0).abs() < 8.0);
    }

    #[test]
    fn fm0_na4_er_ser_work() {
        assert!((fm0(&[1.0, -3.0, 2.0], &[1.0, 1.5]) - 5.0 / 2.5).abs() < 1e-15);
        // NA4 with one record is the kurtosis; with a quieter earlier record the denominator shrinks
        let r = [1.0, -1.0, 2.0, -2.0];
        assert!((na4(&r, &[sum_sq_dev(&r)]) - kurtosis(&r)).abs() < 1e-12);
        let ss = sum_sq_dev(&r); // 10
        assert!((na4(&r, &[2.5, ss]) - 4.0 * 34.0 / (6.25 * 6.25)).abs() < 1e-12);
        // a regular signal (2, -2) holds 8 in energy
        assert!((energy_ratio(&[1.0, -1.0], 8.0) - 0.5).abs() < 1e-15);
        let mut a = vec![0.0; 40];
        a[20] = 2.0;
        a[19] = 0.5;
        a[21] = 0.3;
        a[14] = 0.2; // i = 6 below
        a[27] = 0.9; // i = 7 above: outside the six pairs
        assert!((sideband_energy_ratio(&a, 20, 1) - 1.0 / 2.0).abs() < 1e-15);
    }
}
