//! Band-limited interpolation of a sampled record at fractional sample indices, for resampling on a
//! shaft's angle (the TSA, the order spectra, the rpm-order map).

use super::Sample;

/// Band-limited interpolation: a Kaiser-windowed sinc of 8 taps each side (beta = 8), tabulated at 1024
/// fractional phases and normalised to unit DC gain. Flat to about 1e-3 up to 0.35 cycles per sample, so a
/// mesh with only 3 samples per cycle keeps its amplitude.
pub struct Interpolator {
    table: Vec<Row>,
}

/// One phase's 16 taps, aligned to a 64-byte cache line: a row read at a random phase touches one line,
/// not two (unaligned rows straddled a line boundary on three phases in four).
#[derive(Clone, Copy)]
#[repr(align(64))]
struct Row([f32; 2 * HALF]);

/// Taps on each side of the interpolated point.
pub(super) const HALF: usize = 8;
const PHASES: usize = 1024;

fn bessel_i0(x: f64) -> f64 {
    let (mut sum, mut term) = (1.0, 1.0);
    for k in 1..50 {
        term *= (x / (2.0 * k as f64)).powi(2);
        sum += term;
    }
    sum
}

impl Default for Interpolator {
    fn default() -> Self {
        Self::new()
    }
}

impl Interpolator {
    /// Builds the table.
    pub fn new() -> Self {
        let beta = 8.0;
        let i0b = bessel_i0(beta);
        let table = (0..=PHASES)
            .map(|p| {
                let frac = p as f64 / PHASES as f64;
                let mut taps = [0.0; 2 * HALF];
                for (j, t) in taps.iter_mut().enumerate() {
                    let x = j as f64 - (HALF as f64 - 1.0) - frac; // distance from the sample to the point
                    let sinc = if x.abs() < 1e-12 {
                        1.0
                    } else {
                        (std::f64::consts::PI * x).sin() / (std::f64::consts::PI * x)
                    };
                    let r = x / HALF as f64;
                    let win = if r.abs() < 1.0 { bessel_i0(beta * (1.0 - r * r).sqrt()) / i0b } else { 0.0 };
                    *t = sinc * win;
                }
                let sum: f64 = taps.iter().sum();
                Row(taps.map(|t| (t / sum) as f32))
            })
            .collect();
        Self { table }
    }

    /// The table shared by every caller (1025 x 16 Bessel-windowed taps, built once per process).
    pub fn shared() -> &'static Self {
        static TABLE: std::sync::OnceLock<Interpolator> = std::sync::OnceLock::new();
        TABLE.get_or_init(Self::new)
    }

    /// Value of `x` at fractional index `s` (samples beyond the ends repeat the end values).
    #[inline(always)]
    pub fn at<T: Sample>(&self, x: &[T], s: f64) -> f64 {
        let (first, taps) = self.taps_at(s);
        Self::tap_sum(x, first, taps)
    }

    /// The 16-tap sum from sample `first` on ([`Sample::dot16`] inside the record, the end samples
    /// repeated beyond it).
    #[inline(always)]
    fn tap_sum<T: Sample>(x: &[T], first: isize, taps: &[f32; 2 * HALF]) -> f64 {
        if first >= 0 && first + 2 * HALF as isize <= x.len() as isize {
            T::dot16(&x[first as usize..first as usize + 2 * HALF], taps)
        } else {
            Self::at_edge(x, first, taps)
        }
    }

    /// The first of the 16 samples around fractional index `s` (clamped at 0) and their taps.
    #[inline(always)]
    fn taps_at(&self, s: f64) -> (isize, &[f32; 2 * HALF]) {
        // casts instead of floor/round: those are library calls on baseline x86-64
        let s = s.max(0.0);
        let i = s as isize;
        (i - (HALF as isize - 1), &self.table[((s - i as f64) * PHASES as f64 + 0.5) as usize].0)
    }

    /// The 16-tap sum from sample `first` on when it runs past an end (the end samples repeat).
    fn at_edge<T: Sample>(x: &[T], first: isize, taps: &[f32; 2 * HALF]) -> f64 {
        let n = x.len() as isize;
        taps.iter().enumerate().map(|(j, t)| f64::from(*t) * x[(first + j as isize).clamp(0, n - 1) as usize].f()).sum()
    }

    /// `out[i]` = `x` at fractional index `positions[i]` ([`at`](Self::at) for each), with the 16-tap
    /// products in 256-bit vectors where the processor has AVX2 and FMA.
    pub fn fill<T: Sample>(&self, x: &[T], positions: &[f64], out: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: `fill_avx2` only differs from `fill_portable` in the instructions the compiler may use,
            // and both features were detected on this processor just above.
            unsafe { self.fill_avx2(x, positions, out) };
            return;
        }
        self.fill_portable(x, positions, out);
    }

    /// `outs[k][i]` = `xs[k]` at fractional index `positions[i]` for every channel k ([`fill`](Self::fill)
    /// of each), each position's taps looked up once for all channels.
    pub fn fill_many<T: Sample>(&self, xs: &[&[T]], positions: &[f64], outs: &mut [Vec<f64>]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: as in `fill`: the same code, compiled for the features detected just above.
            unsafe { self.fill_many_avx2(xs, positions, outs) };
            return;
        }
        self.fill_many_portable(xs, positions, outs);
    }

    #[inline(always)]
    fn fill_many_portable<T: Sample>(&self, xs: &[&[T]], positions: &[f64], outs: &mut [Vec<f64>]) {
        for (i, &s) in positions.iter().enumerate() {
            let (first, taps) = self.taps_at(s);
            for (x, out) in xs.iter().zip(outs.iter_mut()) {
                out[i] = Self::tap_sum(x, first, taps);
            }
        }
    }

    /// # Safety
    /// The processor must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn fill_many_avx2<T: Sample>(&self, xs: &[&[T]], positions: &[f64], outs: &mut [Vec<f64>]) {
        match xs.iter().map(|x| T::as_f32(x)).collect::<Option<Vec<&[f32]>>>() {
            Some(f32s) => {
                let mut outs: Vec<&mut [f64]> = outs.iter_mut().map(|o| o.as_mut_slice()).collect();
                self.fill_f32_avx2(&f32s, positions, &mut outs);
            }
            None => self.fill_many_portable(xs, positions, outs),
        }
    }

    /// The f32 kernel of [`fill_many`](Self::fill_many) in 256-bit vectors: the same products and the same
    /// order of sums as [`Sample::dot16`] (so the same values), which the compiler left in 64-bit pieces.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn fill_f32_avx2(&self, xs: &[&[f32]], positions: &[f64], outs: &mut [&mut [f64]]) {
        use std::arch::x86_64::{
            _mm_add_ps, _mm_add_ss, _mm_cvtss_f32, _mm_movehl_ps, _mm_shuffle_ps, _mm256_add_ps,
            _mm256_castps256_ps128, _mm256_extractf128_ps, _mm256_loadu_ps, _mm256_mul_ps,
        };
        for (i, &s) in positions.iter().enumerate() {
            let (first, taps) = self.taps_at(s);
            // SAFETY: a row of the table holds 16 f32, read as two vectors of 8
            let (t0, t1) = unsafe { (_mm256_loadu_ps(taps.as_ptr()), _mm256_loadu_ps(taps.as_ptr().add(8))) };
            for (x, out) in xs.iter().zip(outs.iter_mut()) {
                out[i] = if first >= 0 && first + 2 * HALF as isize <= x.len() as isize {
                    let p = &x[first as usize..first as usize + 2 * HALF];
                    // SAFETY: `p` holds 16 f32, read as two vectors of 8
                    let (a0, a1) = unsafe { (_mm256_loadu_ps(p.as_ptr()), _mm256_loadu_ps(p.as_ptr().add(8))) };
                    // a_k = x_k t_k + x_(k+8) t_(k+8); b_k = a_k + a_(k+4); (b0 + b2) + (b1 + b3)
                    let a = _mm256_add_ps(_mm256_mul_ps(a0, t0), _mm256_mul_ps(a1, t1));
                    let b = _mm_add_ps(_mm256_castps256_ps128(a), _mm256_extractf128_ps::<1>(a));
                    let c = _mm_add_ps(b, _mm_movehl_ps(b, b));
                    f64::from(_mm_cvtss_f32(_mm_add_ss(c, _mm_shuffle_ps::<1>(c, c))))
                } else {
                    Self::at_edge(x, first, taps)
                };
            }
        }
    }

    #[inline(always)]
    fn fill_portable<T: Sample>(&self, x: &[T], positions: &[f64], out: &mut [f64]) {
        for (o, &s) in out.iter_mut().zip(positions) {
            *o = self.at(x, s);
        }
    }

    /// # Safety
    /// The processor must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn fill_avx2<T: Sample>(&self, x: &[T], positions: &[f64], out: &mut [f64]) {
        match T::as_f32(x) {
            Some(x) => self.fill_f32_avx2(&[x], positions, &mut [out]),
            None => self.fill_portable(x, positions, out),
        }
    }
}
