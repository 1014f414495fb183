//! Beyond the TSA: the envelope of a band (where a local fault's impacts excite a resonance), the band
//! chosen by the fast kurtogram, the envelope's order spectrum on the tracked shaft angle, and the real
//! power cepstrum.
//!
//! ```text
//! band envelope   c(t) = analytic signal of x band-passed to [f1, f2], shifted to 0 Hz (FFT bins of the band)
//! squared env.    e(t) = |c(t)|^2
//! spectral kurt.  SK = <|c|^4> / <|c|^2>^2 - 2          (0 for Gaussian noise, Antoni 2006; > 0 impulsive)
//! kurtogram       SK of the 2^l bands of width fs / 2^(l+1), levels l = 1..L (Antoni 2007, dyadic tree)
//! cepstrum        C(q) = IFFT(ln |X(f)|^2)             (real power cepstrum, segment-averaged power)
//! ```

use super::spectrum::{Fft, magnitude};
use super::tsa::AngleMap;
use super::{Sample, SignalError};

/// Complex envelope of the band [`lo`, `hi`) bins of a one-sided spectrum of an N-point real signal: the
/// band's bins moved to 0 Hz and inverse transformed at the smallest power-of-two length holding them (a
/// decimated envelope, one sample every N / len input samples). |c|^2 is the squared envelope up to a
/// constant factor.
fn band_envelope(fft: &mut Fft, spec: &[(f64, f64)], lo: usize, hi: usize) -> Vec<(f64, f64)> {
    let width = hi.saturating_sub(lo).max(1);
    let len = width.next_power_of_two().max(8);
    let mut buf = vec![(0.0, 0.0); len];
    for (k, b) in buf.iter_mut().enumerate().take(width) {
        *b = spec.get(lo + k).copied().unwrap_or((0.0, 0.0));
    }
    fft.inverse_complex(&mut buf);
    buf
}

/// Spectral kurtosis of a complex envelope: <|c|^4> / <|c|^2>^2 - 2.
fn spectral_kurtosis(c: &[(f64, f64)]) -> f64 {
    let (mut m2, mut m4) = (0.0, 0.0);
    for &(r, i) in c {
        let p = r * r + i * i;
        m2 += p;
        m4 += p * p;
    }
    let n = c.len() as f64;
    if m2 <= 0.0 { 0.0 } else { (m4 / n) / (m2 / n).powi(2) - 2.0 }
}

/// The fast kurtogram of a signal.
#[derive(Clone, Debug)]
pub struct Kurtogram {
    /// Spectral kurtosis per level (level l has 2^l bands of width fs / 2^(l+1)), levels 1..=L.
    pub levels: Vec<Vec<f64>>,
    /// The band with the largest spectral kurtosis: (level, band index, lower and upper edge in Hz).
    pub best: (usize, usize, f64, f64),
    /// Its spectral kurtosis.
    pub best_kurtosis: f64,
}

/// Fewest envelope samples a band needs for its kurtosis to mean anything.
const MIN_BAND_SAMPLES: usize = 64;

/// Fast kurtogram over levels 1..=`levels` of the first 2^18 samples of `x` (sample rate `fs_hz`); the best
/// band is sought among bands starting at `min_hz` or above (below it, a machine's own deterministic lines
/// beat into a peaky but fault-free envelope). Bands holding fewer than 64 envelope samples cannot be
/// estimated: asking for such a level is an error.
///
/// # Errors
/// Fewer than 256 samples, no level, or a level deeper than the recording allows.
pub fn kurtogram<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    fs_hz: f64,
    levels: usize,
    min_hz: f64,
) -> Result<Kurtogram, SignalError> {
    // 2^18 samples (5 s at 51.2 kHz) choose the band as well as the whole record: the deepest default level
    // still leaves each band 4096 envelope samples
    let n = x.len().min(1 << 18);
    if n < 256 {
        return Err(SignalError::TooShort { what: "kurtogram".into(), needed: 256, got: x.len() });
    }
    let n = 1usize << (usize::BITS - 1 - n.leading_zeros()); // largest power of two that fits
    let deepest = ((n / 2 / MIN_BAND_SAMPLES) as f64).log2().floor() as usize;
    if levels == 0 || levels > deepest {
        return Err(SignalError::Invalid(format!(
            "kurtogram level {levels} is not possible: {n} samples allow levels 1 to {deepest} (each band needs {MIN_BAND_SAMPLES} envelope samples)"
        )));
    }
    let mean = x[..n].iter().map(|v| v.f()).sum::<f64>() / n as f64;
    let mut buf: Vec<f64> = x[..n].iter().map(|v| v.f() - mean).collect();
    let mut spec = Vec::new();
    fft.forward(&mut buf, &mut spec);
    let half = n / 2;
    let mut out = Vec::with_capacity(levels);
    let mut best = (1, 1, fs_hz / 4.0, fs_hz / 2.0);
    let mut best_k = f64::NEG_INFINITY;
    for l in 1..=levels {
        let bands = 1usize << l;
        let width = half / bands;
        let row: Vec<f64> = (0..bands)
            .map(|b| {
                // the DC bin is left out of the lowest band
                let lo = (b * width).max(1);
                spectral_kurtosis(&band_envelope(fft, &spec, lo, (b + 1) * width))
            })
            .collect();
        let bw = fs_hz / 2.0 / bands as f64;
        for (b, &k) in row.iter().enumerate() {
            if k > best_k && b as f64 * bw >= min_hz {
                best_k = k;
                best = (l, b, b as f64 * bw, (b + 1) as f64 * bw);
            }
        }
        out.push(row);
    }
    Ok(Kurtogram { levels: out, best, best_kurtosis: best_k })
}

/// The FFT bins lo..=hi of an N-point record inside the band [`lo_hz`, `hi_hz`].
fn band_bins(n: usize, fs_hz: f64, lo_hz: f64, hi_hz: f64) -> Result<(usize, usize), SignalError> {
    if !(lo_hz >= 0.0 && hi_hz > lo_hz && hi_hz <= fs_hz / 2.0) {
        return Err(SignalError::Invalid(format!(
            "envelope band {lo_hz} .. {hi_hz} Hz is empty or outside 0 .. {} Hz",
            fs_hz / 2.0
        )));
    }
    let (lo, hi) = ((lo_hz * n as f64 / fs_hz).ceil() as usize, (hi_hz * n as f64 / fs_hz).floor() as usize);
    if hi <= lo {
        return Err(SignalError::Invalid(format!("envelope band {lo_hz} .. {hi_hz} Hz holds no frequency bin")));
    }
    Ok((lo, hi))
}

/// Squared envelope of `x` in the band [`lo_hz`, `hi_hz`] at the full sample rate: the band's bins of the
/// whole record kept, the analytic signal by inverse transform, |.|^2.
///
/// # Errors
/// An empty band, or one outside 0 .. fs / 2.
pub fn squared_envelope<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    fs_hz: f64,
    lo_hz: f64,
    hi_hz: f64,
) -> Result<Vec<f64>, SignalError> {
    let n = x.len();
    let (lo, hi) = band_bins(n, fs_hz, lo_hz, hi_hz)?;
    let mut buf: Vec<f64> = x.iter().map(|v| v.f()).collect();
    let mut spec = Vec::new();
    fft.forward(&mut buf, &mut spec);
    // analytic signal: positive frequencies doubled, the rest zero
    let mut full = vec![(0.0, 0.0); n];
    for k in lo.max(1)..=hi.min(n / 2) {
        full[k] = (2.0 * spec[k].0 / n as f64, 2.0 * spec[k].1 / n as f64);
    }
    fft.inverse_complex(&mut full);
    Ok(full.iter().map(|(r, i)| r * r + i * i).collect())
}

/// Squared envelope of `x` in the band [`lo_hz`, `hi_hz`] at a reduced rate: the band's bins of the whole
/// record moved to 0 Hz and inverse transformed at the smallest power of two holding twice the band (|c|^2
/// has twice the band's width, so nothing aliases). Returns the envelope and its sample rate relative to
/// the input's (len / N). Memory: the record's spectrum and the short envelope, not record-length complex
/// buffers. The squared envelope is scaled as [`squared_envelope`]'s.
///
/// # Errors
/// As [`squared_envelope`].
pub fn squared_envelope_decimated<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    fs_hz: f64,
    lo_hz: f64,
    hi_hz: f64,
) -> Result<(Vec<f64>, f64), SignalError> {
    let n = x.len();
    let (lo, hi) = band_bins(n, fs_hz, lo_hz, hi_hz)?;
    let mut buf: Vec<f64> = x.iter().map(|v| v.f()).collect();
    let mut spec = Vec::new();
    fft.forward(&mut buf, &mut spec);
    drop(buf);
    let len = (2 * (hi - lo + 1)).next_power_of_two().max(16);
    let mut c = vec![(0.0, 0.0); len];
    for (k, b) in c.iter_mut().enumerate().take(hi - lo + 1) {
        let i = lo.max(1) + k;
        if i <= hi.min(n / 2) {
            *b = (2.0 * spec[i].0 / n as f64, 2.0 * spec[i].1 / n as f64);
        }
    }
    fft.inverse_complex(&mut c);
    Ok((c.iter().map(|(r, i)| r * r + i * i).collect(), len as f64 / n as f64))
}

/// The squared envelope of a band built segment by segment: each Hann segment's band bins (an
/// [`averaged_power_each`](super::spectrum::averaged_power_each) pass with 50 % overlap and padding) are
/// moved to 0 Hz, inverse transformed at the smallest power of two M holding twice the band, and added at
/// their place in a record-long decimated envelope. Hann windows at 50 % overlap sum to one, so the sum is
/// the band's analytic signal (the band's edges blurred by the window's main lobe, 2 bins of the segment).
/// This shares the transforms of the amplitude spectrum instead of transforming the whole record. The
/// segments come in order, so a position is complete once the next segment starts after it: only the
/// squared envelope is kept record-long, the complex sums of one segment's span at a time.
pub struct BandOverlapAdd {
    lo: usize,
    width: usize,
    segment: usize,
    len: usize,
    /// Squared envelope of the complete positions (record-long, at the decimated rate).
    e: Vec<f64>,
    /// Sums of the positions still open, `base ..`.
    open: Vec<(f64, f64)>,
    base: isize,
    buf: Vec<(f64, f64)>,
}

impl BandOverlapAdd {
    /// For a record of `n` samples at `fs_hz` cut into `segment`-sample segments (the record's length when
    /// shorter), the band [`lo_hz`, `hi_hz`].
    ///
    /// # Errors
    /// An empty band, or one outside 0 .. fs / 2.
    pub fn new(n: usize, segment: usize, fs_hz: f64, lo_hz: f64, hi_hz: f64) -> Result<Self, SignalError> {
        let segment = segment.min(n).max(8) & !1;
        let (lo, hi) = band_bins(segment, fs_hz, lo_hz, hi_hz)?;
        let lo = lo.max(1);
        let width = hi.min(segment / 2) + 1 - lo.min(hi + 1);
        let len = (2 * width).next_power_of_two().clamp(16, segment);
        let total = (n * len).div_ceil(segment);
        Ok(Self {
            lo,
            width,
            segment,
            len,
            e: vec![0.0; total],
            open: Vec::with_capacity(2 * len),
            base: 0,
            buf: vec![(0.0, 0.0); len],
        })
    }

    /// Adds the segment starting at sample `start` (a multiple of half a segment) with one-sided spectrum
    /// `spec` of its windowed samples. Segments come in increasing order of `start` (as
    /// [`averaged_power_each`](super::spectrum::averaged_power_each) gives them): the positions before
    /// this segment's are complete.
    pub fn add(&mut self, fft: &mut Fft, start: isize, spec: &[(f64, f64)]) {
        let half = (self.segment / 2) as isize;
        // the band moved to 0 Hz carries exp(-2 pi i lo start / N) = (-1)^(lo start / (N/2)) into the sum
        let sign = if ((start.div_euclid(half)) * self.lo as isize).rem_euclid(2) == 0 { 1.0 } else { -1.0 };
        let scale = 2.0 * sign / self.segment as f64;
        self.buf.iter_mut().for_each(|b| *b = (0.0, 0.0));
        for (b, c) in self.buf.iter_mut().zip(&spec[self.lo..self.lo + self.width]) {
            *b = (scale * c.0, scale * c.1);
        }
        fft.inverse_complex(&mut self.buf);
        let at = start.div_euclid(half) * (self.len / 2) as isize;
        self.close_before(at);
        let end = at + self.len as isize;
        while self.base + (self.open.len() as isize) < end {
            self.open.push((0.0, 0.0));
        }
        for (j, b) in self.buf.iter().enumerate() {
            // a position before the record, or one already complete (a segment out of order), takes nothing
            let Ok(k) = usize::try_from(at + j as isize - self.base) else { continue };
            let c = &mut self.open[k];
            *c = (c.0 + b.0, c.1 + b.1);
        }
    }

    /// Moves the open positions before `at` into the squared envelope.
    fn close_before(&mut self, at: isize) {
        if self.open.is_empty() {
            self.base = self.base.max(at);
            return;
        }
        let done = (at.saturating_sub(self.base)).clamp(0, self.open.len() as isize) as usize;
        for (k, c) in self.open.drain(..done).enumerate() {
            if let Some(e) = usize::try_from(self.base + k as isize).ok().and_then(|i| self.e.get_mut(i)) {
                *e = c.0 * c.0 + c.1 * c.1;
            }
        }
        self.base += done as isize;
        if self.open.is_empty() {
            self.base = self.base.max(at);
        }
    }

    /// The squared envelope |c|^2 (scaled as [`squared_envelope`]'s) and its sample rate relative to the
    /// record's.
    pub fn finish(mut self) -> (Vec<f64>, f64) {
        self.close_before(isize::MAX);
        (self.e, self.len as f64 / self.segment as f64)
    }

    /// Segment length used.
    pub fn segment(&self) -> usize {
        self.segment
    }
}

/// Squared envelope of `x` in the band [`lo_hz`, `hi_hz`] by [`BandOverlapAdd`] over Hann segments of
/// `segment` samples; returns the envelope and its rate relative to the record's.
///
/// # Errors
/// As [`squared_envelope`], and fewer than 8 samples.
pub fn squared_envelope_segments<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    fs_hz: f64,
    lo_hz: f64,
    hi_hz: f64,
    segment: usize,
) -> Result<(Vec<f64>, f64), SignalError> {
    let mut ola = BandOverlapAdd::new(x.len(), segment, fs_hz, lo_hz, hi_hz)?;
    let n = ola.segment();
    super::spectrum::averaged_power_each(fft, x, n, 0.5, "envelope", true, |f, start, spec| ola.add(f, start, spec))?;
    Ok(ola.finish())
}

/// Amplitude spectrum in orders of the reference shaft: `x` resampled at `points` equal angles per
/// revolution over the whole revolutions of `map`, mean removed, Hann window, amplitude-corrected. Entry k
/// is order k / revolutions.
pub fn order_spectrum<T: Sample>(fft: &mut Fft, x: &[T], map: &AngleMap, points: usize) -> (Vec<f64>, Vec<f64>) {
    order_spectrum_over(fft, x, map, points, 0, map.revolutions())
}

/// [`order_spectrum`] of a long record as the power average of equal parts of at most `max_revs`
/// revolutions (Welch without overlap): entry k is order k / (revolutions of a part), a steady line reads
/// its amplitude, and the memory is a part's. Returns the orders, the amplitudes and the revolutions of a
/// part. A record of up to `max_revs` revolutions is read whole, exactly as [`order_spectrum`] reads it.
pub fn order_spectrum_parts<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    map: &AngleMap,
    points: usize,
    max_revs: usize,
) -> (Vec<f64>, Vec<f64>, usize) {
    let parts = map.revolutions().div_ceil(max_revs.max(1)).max(1);
    if parts == 1 {
        let (orders, amplitudes) = order_spectrum(fft, x, map, points);
        return (orders, amplitudes, map.revolutions());
    }
    let part = map.revolutions() / parts;
    let mut power: Vec<f64> = Vec::new();
    let mut orders = Vec::new();
    for p in 0..parts {
        let (o, a) = order_spectrum_over(fft, x, map, points, p * part, part);
        power.resize(a.len(), 0.0);
        power.iter_mut().zip(&a).for_each(|(s, v)| *s += v * v / parts as f64);
        orders = o;
    }
    (orders, power.iter().map(|p| p.sqrt()).collect(), part)
}

/// [`order_spectrum`] of the `revs` revolutions of `map` from revolution `first`.
fn order_spectrum_over<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    map: &AngleMap,
    points: usize,
    first: usize,
    revs: usize,
) -> (Vec<f64>, Vec<f64>) {
    let n = revs * points;
    // the Hann window (periodic, as `spectrum::hann`) applied as it is computed: a 60 s record's order
    // spectrum holds no array of its length besides the samples and their spectrum
    let mut y = vec![0.0; n];
    map.resample(x, first as f64, 1.0 / points as f64, &mut y);
    let mean = y.iter().sum::<f64>() / n.max(1) as f64;
    let step = 2.0 * std::f64::consts::PI / n as f64;
    let mut gain = 0.0;
    // cos(step i) by a rotating phasor, started exactly every 4096 samples (drift below 1e-12)
    let rotation = (step.cos(), step.sin());
    for (c, chunk) in y.chunks_mut(4096).enumerate() {
        let a = step * (c * 4096) as f64;
        let (mut cr, mut ci) = (a.cos(), a.sin());
        for v in chunk {
            let w = 0.5 * (1.0 - cr);
            gain += w;
            *v = (*v - mean) * w;
            (cr, ci) = (cr * rotation.0 - ci * rotation.1, cr * rotation.1 + ci * rotation.0);
        }
    }
    let mut amps = fft.forward_magnitudes(&mut y);
    drop(y);
    amps.iter_mut().for_each(|a| *a *= 2.0 / gain);
    let orders = (0..amps.len()).map(|k| k as f64 / revs.max(1) as f64).collect();
    (orders, amps)
}

/// Real power cepstrum of `x`: the power spectrum averaged over Hann segments of `segment` samples (50 %
/// overlap), then C(q) = IFFT(ln P) for quefrencies 0 .. segment / 2 samples.
///
/// # Errors
/// Fewer samples than one segment.
pub fn cepstrum<T: Sample>(fft: &mut Fft, x: &[T], segment: usize) -> Result<Vec<f64>, SignalError> {
    if x.len() < segment || segment < 16 {
        return Err(SignalError::TooShort { what: "cepstrum".into(), needed: segment.max(16), got: x.len() });
    }
    let (power, _) = super::spectrum::averaged_power(fft, x, segment, 0.5, "cepstrum")?;
    Ok(cepstrum_of_power(fft, &power, segment))
}

/// [`cepstrum`] from an averaged power spectrum of `segment`-sample segments (N/2 + 1 bins).
pub fn cepstrum_of_power(fft: &mut Fft, power: &[f64], segment: usize) -> Vec<f64> {
    let floor = power.iter().copied().fold(0.0, f64::max) * 1e-12 + f64::MIN_POSITIVE;
    let log: Vec<(f64, f64)> = power.iter().map(|p| (p.max(floor).ln(), 0.0)).collect();
    let c = fft.inverse(&log, segment);
    c[..segment / 2].to_vec()
}

/// Comb liftering (Randall): removes the family of lines spaced fs / `period_samples` (a shaft's harmonics
/// and sidebands) from `x`. The real cepstrum of the whole record, c = IFFT(ln |X|), is set to zero within
/// +-`width` samples of every rahmonic k `period_samples` (k >= 1, and their mirrors), ln |X| is rebuilt
/// from it and recombined with the original phase: X' = exp(FFT(c)) e^(i arg X), x' = IFFT(X'). What does
/// not repeat with that period (another shaft's family, a bearing's lines, noise) keeps its spectrum.
///
/// # Errors
/// A period under 4 samples, or fewer than two periods of signal.
pub fn lifter_comb<T: Sample>(
    fft: &mut Fft,
    x: &[T],
    period_samples: f64,
    width: usize,
) -> Result<Vec<f64>, SignalError> {
    if period_samples.is_nan() || period_samples < 4.0 {
        return Err(SignalError::Invalid(format!("comb lifter: period {period_samples} samples is under 4")));
    }
    let n = x.len() & !1; // even length: a real DC and Nyquist bin
    if (n as f64) < 2.0 * period_samples {
        return Err(SignalError::TooShort {
            what: "comb lifter".into(),
            needed: (2.0 * period_samples) as usize,
            got: x.len(),
        });
    }
    let mut buf: Vec<f64> = x[..n].iter().map(|v| v.f()).collect();
    let mut spec = Vec::new();
    fft.forward(&mut buf, &mut spec);
    let floor = spec.iter().map(|c| magnitude(*c)).fold(0.0, f64::max) * 1e-12 + f64::MIN_POSITIVE;
    let log: Vec<(f64, f64)> = spec.iter().map(|c| (magnitude(*c).max(floor).ln(), 0.0)).collect();
    let mut cep = fft.inverse(&log, n);
    let mut k = 1.0;
    while k * period_samples < n as f64 / 2.0 {
        let q = k * period_samples;
        let lo = (q - width as f64).ceil().max(1.0) as usize;
        let hi = ((q + width as f64).floor() as usize).min(n / 2);
        for i in lo..=hi {
            cep[i] = 0.0;
            cep[n - i] = 0.0;
        }
        k += 1.0;
    }
    let mut relog = Vec::new();
    fft.forward(&mut cep, &mut relog);
    // `inverse` carries the 1/n: the forward transform of the cepstrum is the edited log amplitude
    let edited: Vec<(f64, f64)> = spec
        .iter()
        .zip(&relog)
        .map(|(c, l)| {
            let a = magnitude(*c);
            let m = l.0.exp();
            if a > 0.0 { (c.0 / a * m, c.1 / a * m) } else { (0.0, 0.0) }
        })
        .collect();
    Ok(fft.inverse(&edited, n))
}

#[cfg(test)]
mod tests;
