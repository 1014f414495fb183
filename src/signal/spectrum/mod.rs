//! Discrete Fourier transforms of real data (realfft / rustfft live only here) and the spectra built on
//! them.
//!
//! Conventions: one-sided spectra have N/2 + 1 bins at k fs / N. "Amplitude" means the peak amplitude of
//! a sinusoid: |X_0| / N for k = 0, 2 |X_k| / N otherwise (|X_{N/2}| / N at Nyquist for even N), divided by
//! the window's coherent gain (its mean) when a window is applied. A PSD is one-sided, in unit^2/Hz,
//! normalised by fs * sum(w^2) (scipy's `welch(..., scaling="density")`), so its integral is the variance.

use super::{Sample, SignalError, Spectrum};
use realfft::RealFftPlanner;
use realfft::num_complex::Complex;

/// |c| of a complex value (re, im): sqrt(re^2 + im^2), without `hypot`'s guard against overflow (several
/// times slower; a spectrum of f32 samples stays below 1e60).
#[inline]
pub fn magnitude(c: (f64, f64)) -> f64 {
    (c.0 * c.0 + c.1 * c.1).sqrt()
}

/// Plans shared by every [`Fft`] of the process: each length is planned once (a 60 s recording's
/// diagnosis runs a dozen contexts in parallel, which used to plan the same lengths each).
struct Plans {
    real: RealFftPlanner<f64>,
    complex: rustfft::FftPlanner<f64>,
}

fn plans() -> std::sync::MutexGuard<'static, Plans> {
    static PLANS: std::sync::OnceLock<std::sync::Mutex<Plans>> = std::sync::OnceLock::new();
    PLANS
        .get_or_init(|| {
            std::sync::Mutex::new(Plans { real: RealFftPlanner::new(), complex: rustfft::FftPlanner::new() })
        })
        .lock()
        // a planner holds only finished plans: one left by a panicking thread is still sound
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Longest transform (entries) whose plan the process keeps: a teeth scan's baseband of up to 2^18 entries
/// (4 MB of twiddles) is planned once for its two harmonics and the next recordings of a batch; a longer
/// plan's twiddles (15 MB for the order spectrum of a 60 s recording) are freed after use.
const KEPT_PLAN: usize = 1 << 18;

fn real_forward(n: usize) -> std::sync::Arc<dyn realfft::RealToComplex<f64>> {
    if n <= KEPT_PLAN { plans().real.plan_fft_forward(n) } else { RealFftPlanner::new().plan_fft_forward(n) }
}

fn real_inverse(n: usize) -> std::sync::Arc<dyn realfft::ComplexToReal<f64>> {
    if n <= KEPT_PLAN { plans().real.plan_fft_inverse(n) } else { RealFftPlanner::new().plan_fft_inverse(n) }
}

fn complex_inverse(n: usize) -> std::sync::Arc<dyn rustfft::Fft<f64>> {
    if n <= KEPT_PLAN { plans().complex.plan_fft_inverse(n) } else { rustfft::FftPlanner::new().plan_fft_inverse(n) }
}

/// Reusable FFT context: plans come from the process-wide cache, the spectrum and scratch buffers are
/// kept between calls up to 2^17 complex entries (a record-long transform's are freed at once).
#[derive(Default)]
pub struct Fft {
    spec: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
}

/// Longest spectrum or scratch buffer (complex entries, 2 MiB) an [`Fft`] keeps for its next call.
const KEPT_BUFFER: usize = 1 << 17;

impl Fft {
    /// A fresh context.
    pub fn new() -> Self {
        Self::default()
    }

    fn scratch(&mut self, len: usize) -> &mut [Complex<f64>] {
        if self.scratch.len() < len {
            self.scratch.resize(len, Complex::new(0.0, 0.0));
        }
        &mut self.scratch[..len]
    }

    /// Takes the spectrum buffer back after a call, and frees both buffers when they are record-long.
    fn keep(&mut self, buf: Vec<Complex<f64>>) {
        if buf.len() <= KEPT_BUFFER {
            self.spec = buf;
        }
        if self.scratch.len() > KEPT_BUFFER {
            self.scratch = Vec::new();
        }
    }

    /// The forward transform of `input` (overwritten), each bin X_k handed to `read`, k = 0..=N/2.
    fn forward_with<R>(&mut self, input: &mut [f64], read: impl FnOnce(&[Complex<f64>]) -> R) -> R {
        let plan = real_forward(input.len());
        let mut spec = std::mem::take(&mut self.spec);
        spec.resize(plan.complex_len(), Complex::new(0.0, 0.0));
        plan.process_with_scratch(input, &mut spec, self.scratch(plan.get_scratch_len())).expect("sizes from the plan");
        let r = read(&spec);
        self.keep(spec);
        r
    }

    /// Unnormalised forward transform of `input` (overwritten) into `out` (len N/2 + 1).
    pub fn forward(&mut self, input: &mut [f64], out: &mut Vec<(f64, f64)>) {
        self.forward_with(input, |spec| {
            out.clear();
            out.extend(spec.iter().map(|c| (c.re, c.im)));
        });
    }

    /// |X_k| for k in `bins` (within 0..=N/2) of the unnormalised forward transform of `input`
    /// (overwritten), as sqrt(re^2 + im^2): a band of [`forward`](Self::forward)'s spectrum, without copying
    /// the rest of it (a short-time spectrum that reads a few hundred bins of 8193).
    pub fn forward_band_magnitudes(&mut self, input: &mut [f64], bins: std::ops::RangeInclusive<usize>) -> Vec<f64> {
        self.forward_with(input, |spec| spec[bins].iter().map(|c| (c.re * c.re + c.im * c.im).sqrt()).collect())
    }

    /// |X_k| for k = 0..=N/2 of the unnormalised forward transform of `input` (overwritten): what
    /// [`forward`](Self::forward) gives, without a second record-long copy of the spectrum.
    pub fn forward_magnitudes(&mut self, input: &mut [f64]) -> Vec<f64> {
        self.forward_with(input, |spec| spec.iter().map(|c| magnitude((c.re, c.im))).collect())
    }

    /// Unnormalised complex inverse transform in place: x_n = sum_k X_k exp(+2 pi i k n / N).
    pub fn inverse_complex(&mut self, data: &mut [(f64, f64)]) {
        let plan = complex_inverse(data.len());
        let mut buf = std::mem::take(&mut self.spec);
        buf.clear();
        buf.extend(data.iter().map(|&(r, i)| Complex::new(r, i)));
        plan.process_with_scratch(&mut buf, self.scratch(plan.get_inplace_scratch_len()));
        for (d, c) in data.iter_mut().zip(&buf) {
            *d = (c.re, c.im);
        }
        self.keep(buf);
    }

    /// |x_n| for n = 0..len of the unnormalised complex inverse transform of `data` padded with zeros to
    /// `len` entries (`data.len()` <= `len`): x_n = sum_k X_k exp(+2 pi i k n / len). The padding is
    /// written once, into the transform's own buffer, never read before it is written (a record-long
    /// zero-padded buffer that is read first costs the kernel a copy-on-write of every page).
    pub fn inverse_complex_magnitudes(&mut self, data: &[(f64, f64)], len: usize) -> Vec<f64> {
        let plan = complex_inverse(len);
        let mut buf = std::mem::take(&mut self.spec);
        buf.clear();
        buf.reserve(len);
        buf.extend(data.iter().take(len).map(|&(r, i)| Complex::new(r, i)));
        buf.resize(len, Complex::new(0.0, 0.0));
        plan.process_with_scratch(&mut buf, self.scratch(plan.get_inplace_scratch_len()));
        let out = buf.iter().map(|c| (c.re * c.re + c.im * c.im).sqrt()).collect();
        self.keep(buf);
        out
    }

    /// Inverse of [`forward`](Self::forward) including the 1/N factor: `spec` (len N/2 + 1) -> N samples.
    pub fn inverse(&mut self, spec: &[(f64, f64)], n: usize) -> Vec<f64> {
        let plan = real_inverse(n);
        let mut input = std::mem::take(&mut self.spec);
        input.clear();
        input.extend(spec.iter().map(|&(r, i)| Complex::new(r, i)));
        // a real signal's DC and Nyquist bins are real
        input[0].im = 0.0;
        if n.is_multiple_of(2) {
            input[n / 2].im = 0.0;
        }
        let mut out = plan.make_output_vec();
        plan.process_with_scratch(&mut input, &mut out, self.scratch(plan.get_scratch_len()))
            .expect("sizes from the plan");
        self.keep(input);
        let scale = 1.0 / n as f64;
        out.iter_mut().for_each(|v| *v *= scale);
        out
    }
}

/// Amplitudes of harmonics 0..=N/2 of one period sampled at N equally spaced points (no window: the
/// record is exactly one period, so every harmonic falls on a bin).
pub fn periodic_amplitudes(samples: &[f64]) -> Vec<f64> {
    let mut fft = Fft::new();
    periodic_amplitudes_with(&mut fft, samples)
}

/// [`periodic_amplitudes`] with a reusable FFT context.
pub fn periodic_amplitudes_with(fft: &mut Fft, samples: &[f64]) -> Vec<f64> {
    let n = samples.len();
    if n == 0 {
        return Vec::new();
    }
    let mut input = samples.to_vec();
    let mut out = Vec::new();
    fft.forward(&mut input, &mut out);
    out.iter().enumerate().map(|(k, c)| bin_scale(k, n) * magnitude(*c) / n as f64).collect()
}

fn bin_scale(k: usize, n: usize) -> f64 {
    if k == 0 || (n.is_multiple_of(2) && k == n / 2) { 1.0 } else { 2.0 }
}

/// Peak amplitude of the strongest sinusoid within +-`search` cycles per sample of `f` (cycles per
/// sample) in the first N = 65536 samples of `x`: Hann-windowed DFT evaluated at 9 frequencies across the
/// search range (the main lobe is 4 / N wide, so a line anywhere in a range up to 8 / N is caught within
/// its lobe; with probes at most a bin apart, search <= 4 / N, the amplitude reads low by up to the Hann
/// scalloping, 15 %; wider probes read a line between them lower still). For deciding which of a few
/// candidate lines is present, not for measuring them.
pub fn line_amplitude<T: Sample>(x: &[T], f: f64, search: f64) -> f64 {
    let n = x.len().min(1 << 16);
    if n < 8 {
        return 0.0;
    }
    // the window of the usual length is built once per process (the tracking asks for a dozen lines)
    static HANN_64K: std::sync::OnceLock<Vec<f64>> = std::sync::OnceLock::new();
    let own;
    let w: &[f64] = if n == 1 << 16 {
        HANN_64K.get_or_init(|| hann(1 << 16))
    } else {
        own = hann(n);
        &own
    };
    let mean = x[..n].iter().map(|v| v.f()).sum::<f64>() / n as f64;
    let gain = w.iter().sum::<f64>();
    let y: Vec<f64> = x[..n].iter().zip(w).map(|(v, wi)| (v.f() - mean) * wi).collect();
    // sum y_i exp(+i 2 pi f_j i): the phasor sum at angle i f_j of order -1
    (-4..=4).map(|j| 2.0 * magnitude(phasor_sum(&y, 0.0, f + search * j as f64 / 4.0, -1.0)) / gain).fold(0.0, f64::max)
}

/// sum over the samples v_i of `x` of v_i exp(-i 2 pi order theta_i), with the angle theta_i = th0 + i slope
/// (revolutions) linear over the block: a rotating phasor, one complex multiplication per sample, in four
/// interleaved lanes (each rotating by four steps) so that the products do not wait on each other.
pub(super) fn phasor_sum<T: Sample>(x: &[T], th0: f64, slope: f64, order: f64) -> (f64, f64) {
    use std::f64::consts::TAU;
    const LANES: usize = 4;
    let mul = |a: (f64, f64), b: (f64, f64)| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
    let step = ((-TAU * order * slope).cos(), (-TAU * order * slope).sin());
    let step2 = mul(step, step);
    let step4 = mul(step2, step2);
    let first = ((-TAU * order * th0).cos(), (-TAU * order * th0).sin());
    let (mut re, mut im) = ([0.0; LANES], [0.0; LANES]);
    let mut p = first;
    for l in 0..LANES {
        (re[l], im[l]) = p;
        p = mul(p, step);
    }
    let (mut sr, mut si) = ([0.0; LANES], [0.0; LANES]);
    let chunks = x.chunks_exact(LANES);
    let rest = chunks.remainder();
    for c in chunks {
        for l in 0..LANES {
            let v = c[l].f();
            sr[l] += v * re[l];
            si[l] += v * im[l];
            (re[l], im[l]) = (re[l] * step4.0 - im[l] * step4.1, re[l] * step4.1 + im[l] * step4.0);
        }
    }
    for (l, v) in rest.iter().enumerate() {
        sr[l] += v.f() * re[l];
        si[l] += v.f() * im[l];
    }
    (sr.iter().sum(), si.iter().sum())
}

/// Periodic Hann window of length n: w_i = 0.5 (1 - cos(2 pi i / n)).
pub fn hann(n: usize) -> Vec<f64> {
    (0..n).map(|i| 0.5 * (1.0 - (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos())).collect()
}

/// Options of [`amplitude_spectrum`]. Defaults: `segment = 65536` (or the whole record when shorter),
/// `overlap = 0.5`.
#[derive(Clone, Copy, Debug)]
pub struct AmplitudeOptions {
    /// Segment length (samples).
    pub segment: usize,
    /// Fractional overlap of segments in [0, 1).
    pub overlap: f64,
}

impl Default for AmplitudeOptions {
    fn default() -> Self {
        Self { segment: 65536, overlap: 0.5 }
    }
}

/// One-sided amplitude spectrum: Hann window, amplitude-corrected (a sine on a bin reads its peak
/// amplitude), averaged in power over overlapping segments (mean removed per segment).
///
/// # Errors
/// Fewer than 8 samples.
pub fn amplitude_spectrum<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    fs: f64,
    o: AmplitudeOptions,
) -> Result<Spectrum, SignalError> {
    let (power, n) = averaged_power(fft, x, o.segment, o.overlap, "amplitude spectrum")?;
    Ok(amplitude_from_power(&power, n, fs))
}

/// Welch PSD: Hann segments of `nperseg` (or the record length when shorter), 50 % overlap, mean removed
/// per segment, one-sided density in unit^2/Hz.
///
/// # Errors
/// Fewer than 8 samples.
pub fn welch_psd<T: Sample>(fft: &mut Fft, x: &[T], fs: f64, nperseg: usize) -> Result<Spectrum, SignalError> {
    let (power, n) = averaged_power(fft, x, nperseg, 0.5, "Welch PSD")?;
    let w2: f64 = hann(n).iter().map(|v| v * v).sum();
    let values = power
        .iter()
        .enumerate()
        .map(|(k, p)| if k == 0 || (n % 2 == 0 && k == n / 2) { *p } else { 2.0 * p } / (fs * w2))
        .collect();
    Ok(Spectrum { freqs_hz: (0..=n / 2).map(|k| k as f64 * fs / n as f64).collect(), values })
}

/// Mean power |X_k|^2 of Hann-windowed, mean-removed segments of `segment` samples (or the record when
/// shorter) stepping by (1 - `overlap`) segments, and the segment length used.
///
/// # Errors
/// Fewer than 8 samples.
pub fn averaged_power<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    segment: usize,
    overlap: f64,
    what: &str,
) -> Result<(Vec<f64>, usize), SignalError> {
    use rayon::prelude::*;
    let (n, step) = segments(x.len(), segment, overlap, what)?;
    let count = (x.len() - n) / step + 1;
    // the segments in at most POWER_PARTS runs of consecutive ones, each summed in order on its own and the
    // runs' sums added in order: the same sums whatever the number of threads
    let parts = (count / MIN_SEGMENTS_PER_PART).clamp(1, POWER_PARTS);
    let w = hann(n);
    let run = |fft: &mut Fft, part: usize| {
        let mut acc = vec![0.0; n / 2 + 1];
        let (mut buf, mut out) = (vec![0.0; n], Vec::new());
        for i in part * count / parts..(part + 1) * count / parts {
            windowed(&mut buf, &x[i * step..i * step + n], &w);
            fft.forward(&mut buf, &mut out);
            add_power(&mut acc, &out);
        }
        acc
    };
    let mut acc = if parts == 1 {
        run(fft, 0)
    } else {
        let sums: Vec<Vec<f64>> = (0..parts).into_par_iter().map(|part| run(&mut Fft::new(), part)).collect();
        sums.into_iter()
            .reduce(|mut a, b| {
                a.iter_mut().zip(&b).for_each(|(s, v)| *s += v);
                a
            })
            .expect("at least one part")
    };
    acc.iter_mut().for_each(|a| *a /= count as f64);
    Ok((acc, n))
}

/// Most runs of segments [`averaged_power`] sums in parallel (their sums held at once: 16 half-spectra).
const POWER_PARTS: usize = 16;

/// Fewest segments a run of [`averaged_power`] holds (fewer segments are summed in one run).
const MIN_SEGMENTS_PER_PART: usize = 4;

/// [`averaged_power`], handing every segment's spectrum to `each(fft, start, spectrum)` (start in samples)
/// as it is made, so one pass of transforms serves several analyses. With `padded`, the segments also run
/// one step before the record and on past its end, zeros outside it, so that with 50 % overlap every
/// sample lies under two windows summing to one; those padded segments go to `each` only, not into the
/// power.
///
/// # Errors
/// Fewer than 8 samples.
pub fn averaged_power_each<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    segment: usize,
    overlap: f64,
    what: &str,
    padded: bool,
    mut each: impl FnMut(&mut Fft, isize, &[(f64, f64)]),
) -> Result<(Vec<f64>, usize), SignalError> {
    let (n, step) = segments(x.len(), segment, overlap, what)?;
    let w = hann(n);
    let mut acc = vec![0.0; n / 2 + 1];
    let mut buf = vec![0.0; n];
    let mut out = Vec::new();
    let mut count = 0usize;
    let len = x.len() as isize;
    let mut start: isize = if padded { -(step as isize) } else { 0 };
    while if padded { start < len } else { start + n as isize <= len } {
        let inside = start >= 0 && start + n as isize <= len;
        let (a, b) = (start.max(0) as usize, (start + n as isize).min(len) as usize);
        let offset = (a as isize - start) as usize;
        if !inside {
            buf.iter_mut().for_each(|v| *v = 0.0);
        }
        windowed(&mut buf[offset..], &x[a..b], &w[offset..]);
        fft.forward(&mut buf, &mut out);
        if inside {
            add_power(&mut acc, &out);
            count += 1;
        }
        each(fft, start, &out);
        start += step as isize;
    }
    acc.iter_mut().for_each(|a| *a /= count.max(1) as f64);
    Ok((acc, n))
}

/// The segment length (`segment`, at most the record's `len` samples, at least 8) and the step between
/// segments (samples) of a Welch average with `overlap`.
///
/// # Errors
/// Fewer than 8 samples.
fn segments(len: usize, segment: usize, overlap: f64, what: &str) -> Result<(usize, usize), SignalError> {
    if len < 8 {
        return Err(SignalError::TooShort { what: what.into(), needed: 8, got: len });
    }
    let n = segment.min(len).max(8);
    Ok((n, ((n as f64 * (1.0 - overlap)).round() as usize).max(1)))
}

/// `buf[i]` = (`seg[i]` - mean of `seg`) `w[i]` for the samples of `seg` (a segment mean-removed and
/// windowed).
fn windowed<T: Sample>(buf: &mut [f64], seg: &[T], w: &[f64]) {
    let mean = seg.iter().map(|v| v.f()).sum::<f64>() / seg.len().max(1) as f64;
    for ((bv, v), wi) in buf.iter_mut().zip(seg).zip(w) {
        *bv = (v.f() - mean) * wi;
    }
}

/// `acc[k]` += |X_k|^2 of a spectrum `out`.
fn add_power(acc: &mut [f64], out: &[(f64, f64)]) {
    for (p, c) in acc.iter_mut().zip(out) {
        *p += c.0 * c.0 + c.1 * c.1;
    }
}

/// One-sided amplitude spectrum from an averaged power of `n`-point Hann segments ([`averaged_power`]):
/// what [`amplitude_spectrum`] returns.
pub fn amplitude_from_power(power: &[f64], n: usize, fs: f64) -> Spectrum {
    let gain = hann(n).iter().sum::<f64>() / n as f64;
    let values = power.iter().enumerate().map(|(k, p)| bin_scale(k, n) * p.sqrt() / (n as f64 * gain)).collect();
    Spectrum { freqs_hz: (0..=n / 2).map(|k| k as f64 * fs / n as f64).collect(), values }
}

/// Factor from an amplitude squared of [`amplitude_from_power`] (an interior bin) to the one-sided power
/// spectral density of [`welch_psd`] for Hann segments of `n` samples at `fs` Hz:
/// PSD = A^2 (sum w)^2 / (2 fs sum w^2), unit^2/Hz per unit^2 (for the periodic Hann window 1 / (3 df)).
pub fn hann_psd_per_amplitude2(n: usize, fs: f64) -> f64 {
    let w = hann(n);
    let (s1, s2) = (w.iter().sum::<f64>(), w.iter().map(|v| v * v).sum::<f64>());
    s1 * s1 / (2.0 * fs * s2)
}

/// The one-sided power spectral density (unit^2/Hz) of an amplitude spectrum of [`amplitude_spectrum`]
/// (its segment length read from its axis: n = 2 (bins - 1), fs = n df): what [`welch_psd`] gives for the
/// same segments, without the samples. Empty for fewer than two bins.
pub fn psd_from_amplitude(amp: &Spectrum) -> Spectrum {
    let bins = amp.values.len();
    if bins < 2 {
        return Spectrum { freqs_hz: Vec::new(), values: Vec::new() };
    }
    let n = 2 * (bins - 1);
    let fs = amp.freqs_hz[1] * n as f64;
    let factor = hann_psd_per_amplitude2(n, fs);
    let values = amp
        .values
        .iter()
        .enumerate()
        .map(|(k, a)| {
            // the end bins hold their power once (bin_scale 1), not folded twice
            let s = bin_scale(k, n);
            a * a * factor * 4.0 / (s * s) * if s == 2.0 { 1.0 } else { 0.5 }
        })
        .collect();
    Spectrum { freqs_hz: amp.freqs_hz.clone(), values }
}

/// Zoom spectrum: the Hann-windowed amplitude spectrum of the whole record (resolution fs / N), returned
/// only for `f_lo_hz..=f_hi_hz`. Memory: one record-length buffer.
///
/// # Errors
/// Fewer than 8 samples or an empty band.
pub fn zoom_spectrum<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    fs: f64,
    f_lo_hz: f64,
    f_hi_hz: f64,
) -> Result<Spectrum, SignalError> {
    if f_hi_hz <= f_lo_hz {
        return Err(SignalError::Invalid(format!("zoom band {f_lo_hz}..{f_hi_hz} Hz is empty")));
    }
    let full = amplitude_spectrum(fft, x, fs, AmplitudeOptions { segment: x.len(), overlap: 0.0 })?;
    let (freqs_hz, values) = full
        .freqs_hz
        .iter()
        .zip(&full.values)
        .filter(|(f, _)| **f >= f_lo_hz && **f <= f_hi_hz)
        .map(|(f, v)| (*f, *v))
        .unzip();
    Ok(Spectrum { freqs_hz, values })
}

/// Circular-free autocorrelation r_k / r_0 for lags 0..=max_lag (zero-padded FFT, unbiased: divided by
/// the overlap length N - k).
pub fn autocorrelation<T: Sample>(fft: &mut Fft, x: &[T], max_lag: usize) -> Vec<f64> {
    let n = x.len();
    let m = (2 * n).next_power_of_two();
    let mean = x.iter().map(|v| v.f()).sum::<f64>() / n as f64;
    let mut buf = vec![0.0; m];
    for (b, v) in buf.iter_mut().zip(x) {
        *b = v.f() - mean;
    }
    let mut spec = Vec::new();
    fft.forward(&mut buf, &mut spec);
    let power: Vec<(f64, f64)> = spec.iter().map(|c| (c.0 * c.0 + c.1 * c.1, 0.0)).collect();
    let r = fft.inverse(&power, m);
    let r0 = r[0].max(f64::MIN_POSITIVE);
    (0..=max_lag.min(n - 1)).map(|k| r[k] / r0 * n as f64 / (n - k) as f64).collect()
}

#[cfg(test)]
mod tests;
