//! Truncated real Fourier series with value and first three time derivatives.
//!
//! ```text
//! s(t) = mean + sum_{k=1..H} ( cos[k-1] cos(k w t) + sin[k-1] sin(k w t) ),   w = omega_rad_s
//! ```
//! Evaluation uses one `sin_cos` and the angle-addition recurrence for the higher harmonics, so a series
//! with H harmonics costs one transcendental call and O(H) multiply-adds.

/// A real Fourier series of base angular frequency `omega_rad_s` (rad/s).
#[derive(Clone, Debug, PartialEq)]
pub struct FourierSeries {
    /// Base angular frequency w in rad/s (the k-th harmonic oscillates at k w).
    pub omega_rad_s: f64,
    /// Constant term.
    pub mean: f64,
    /// `cos[k-1]` multiplies cos(k w t).
    pub cos: Vec<f64>,
    /// `sin[k-1]` multiplies sin(k w t).
    pub sin: Vec<f64>,
}

impl FourierSeries {
    /// A constant `value` (no harmonics).
    pub fn constant(value: f64) -> Self {
        Self { omega_rad_s: 1.0, mean: value, cos: Vec::new(), sin: Vec::new() }
    }

    /// Series from its cosine and sine coefficient lists; the shorter list is padded with zeros.
    pub fn new(omega_rad_s: f64, mean: f64, cos: Vec<f64>, sin: Vec<f64>) -> Self {
        let mut s = Self { omega_rad_s, mean, cos, sin };
        s.pad();
        s
    }

    /// Series from amplitude/phase pairs: `mean + sum a_k cos(n_k w t + phi_k)` with orders `n_k >= 1`.
    pub fn from_amplitude_phase(omega_rad_s: f64, mean: f64, terms: &[(usize, f64, f64)]) -> Self {
        let h = terms.iter().map(|t| t.0).max().unwrap_or(0);
        let (mut c, mut s) = (vec![0.0; h], vec![0.0; h]);
        for &(n, a, phi) in terms {
            // a cos(x + phi) = a cos(phi) cos x - a sin(phi) sin x
            c[n - 1] += a * phi.cos();
            s[n - 1] -= a * phi.sin();
        }
        Self { omega_rad_s, mean, cos: c, sin: s }
    }

    fn pad(&mut self) {
        let h = self.cos.len().max(self.sin.len());
        self.cos.resize(h, 0.0);
        self.sin.resize(h, 0.0);
    }

    /// Number of harmonics H (highest k kept).
    pub fn harmonics(&self) -> usize {
        self.cos.len()
    }

    /// True when the series has no non-zero harmonic.
    pub fn is_constant(&self) -> bool {
        self.cos.iter().chain(&self.sin).all(|&v| v == 0.0)
    }

    /// Amplitude sqrt(cos^2 + sin^2) of harmonic k (k >= 1), zero beyond H.
    pub fn amplitude(&self, k: usize) -> f64 {
        if k == 0 {
            return self.mean.abs();
        }
        match (self.cos.get(k - 1), self.sin.get(k - 1)) {
            (Some(c), Some(s)) => c.hypot(*s),
            _ => 0.0,
        }
    }

    /// Value s(t).
    pub fn eval(&self, t: f64) -> f64 {
        if self.cos.is_empty() {
            return self.mean;
        }
        let (s1, c1) = (self.omega_rad_s * t).sin_cos();
        let (mut ck, mut sk) = (1.0, 0.0);
        let mut v = self.mean;
        for (a, b) in self.cos.iter().zip(&self.sin) {
            let c = ck * c1 - sk * s1;
            sk = sk * c1 + ck * s1;
            ck = c;
            v += a * ck + b * sk;
        }
        v
    }

    /// Values at the equally spaced times t0 + j dt (s), j = 0..out.len(): the sums of [`FourierSeries::eval`]
    /// with each harmonic's phasor turned by exp(i k w dt) from one time to the next instead of a sine and
    /// cosine per time, re-anchored on exact values every 64 times (the turning's rounding stays below
    /// about 64 k eps).
    /// Samples that span exactly one period (the last one repeating the first, or not) come from one
    /// inverse FFT instead, from 64 of them on.
    pub fn sample_uniform(&self, t0: f64, dt: f64, out: &mut [f64]) {
        if self.cos.is_empty() {
            out.fill(self.mean);
            return;
        }
        if self.sample_period(t0, dt, out) {
            return;
        }
        let phasors = |theta: f64, z: &mut Vec<(f64, f64)>| {
            z.clear();
            let (s1, c1) = theta.sin_cos();
            let (mut ck, mut sk) = (1.0, 0.0);
            for _ in 0..self.cos.len() {
                let c = ck * c1 - sk * s1;
                sk = sk * c1 + ck * s1;
                ck = c;
                z.push((ck, sk));
            }
        };
        let w = self.omega_rad_s;
        let (mut turn, mut z) = (Vec::new(), Vec::new());
        phasors(w * dt, &mut turn);
        for (j, v) in out.iter_mut().enumerate() {
            if j % 64 == 0 {
                phasors(w * (t0 + j as f64 * dt), &mut z);
            }
            let mut acc = self.mean;
            for (((c, s), (a, b)), (tc, ts)) in z.iter_mut().zip(self.cos.iter().zip(&self.sin)).zip(&turn) {
                acc += a * *c + b * *s;
                let next = *c * tc - *s * ts;
                *s = *s * tc + *c * ts;
                *c = next;
            }
            *v = acc;
        }
    }

    /// [`FourierSeries::sample_uniform`] by an inverse real FFT when N samples spaced `dt` span one period
    /// (N = `out.len()`, or one less with the last sample the period's end) and N is at least 64 and above
    /// twice the highest harmonic: x_j = Re sum_k (a_k - i b_k) e^{i k w t0} e^{2 pi i k j / N}, exact
    /// (rounding of about eps log N). The turned phasors cost a complex product per harmonic and sample,
    /// most of the multiplier companion's time on a gear mesh (640 samples of 10 harmonics). Returns false
    /// (nothing written) otherwise.
    fn sample_period(&self, t0: f64, dt: f64, out: &mut [f64]) -> bool {
        let w = self.omega_rad_s;
        let spans_period = |n: usize| (n as f64 * dt * w / std::f64::consts::TAU - 1.0).abs() < 1e-12;
        let count = out.len();
        let n = if spans_period(count) {
            count
        } else if count > 1 && spans_period(count - 1) {
            count - 1
        } else {
            return false;
        };
        let harmonics = self.cos.len().max(self.sin.len());
        if n < 64 || n <= 2 * harmonics {
            return false;
        }
        let half = n as f64 / 2.0;
        let mut spec = vec![(0.0, 0.0); n / 2 + 1];
        spec[0] = (self.mean * n as f64, 0.0);
        for (k, bin) in spec.iter_mut().enumerate().skip(1).take(harmonics) {
            let (a, b) = (self.cos.get(k - 1).copied().unwrap_or(0.0), self.sin.get(k - 1).copied().unwrap_or(0.0));
            let (s, c) = (k as f64 * w * t0).sin_cos();
            // (a - i b) (c + i s) N / 2
            *bin = ((a * c + b * s) * half, (a * s - b * c) * half);
        }
        let values = crate::signal::spectrum::Fft::new().inverse(&spec, n);
        out[..n].copy_from_slice(&values);
        if count > n {
            out[n] = values[0];
        }
        true
    }

    /// Value and first three time derivatives `[s, s', s'', s''']` at t.
    pub fn eval_derivatives(&self, t: f64) -> [f64; 4] {
        if self.cos.is_empty() {
            return [self.mean, 0.0, 0.0, 0.0];
        }
        let w = self.omega_rad_s;
        let (s1, c1) = (w * t).sin_cos();
        let (mut ck, mut sk) = (1.0, 0.0);
        let mut out = [self.mean, 0.0, 0.0, 0.0];
        for (k, (a, b)) in self.cos.iter().zip(&self.sin).enumerate() {
            let c = ck * c1 - sk * s1;
            sk = sk * c1 + ck * s1;
            ck = c;
            let kw = (k + 1) as f64 * w;
            let even = a * ck + b * sk; // d0
            let odd = b * ck - a * sk; // d1 / (kw)
            out[0] += even;
            out[1] += kw * odd;
            out[2] -= kw * kw * even;
            out[3] -= kw * kw * kw * odd;
        }
        out
    }

    /// The time derivative as a series of the same base frequency.
    pub fn derivative(&self) -> Self {
        let w = self.omega_rad_s;
        let c = self.sin.iter().enumerate().map(|(k, b)| (k + 1) as f64 * w * b).collect();
        let s = self.cos.iter().enumerate().map(|(k, a)| -((k + 1) as f64) * w * a).collect();
        Self { omega_rad_s: w, mean: 0.0, cos: c, sin: s }
    }

    /// `self * factor`.
    pub fn scaled(&self, factor: f64) -> Self {
        Self {
            omega_rad_s: self.omega_rad_s,
            mean: self.mean * factor,
            cos: self.cos.iter().map(|v| v * factor).collect(),
            sin: self.sin.iter().map(|v| v * factor).collect(),
        }
    }

    /// `self + other`; both must share the base frequency (a constant series adopts the other's).
    pub fn plus(&self, other: &Self) -> Self {
        let h = self.harmonics().max(other.harmonics());
        let get = |v: &Vec<f64>, k: usize| v.get(k).copied().unwrap_or(0.0);
        Self {
            omega_rad_s: self.common_omega(other),
            mean: self.mean + other.mean,
            cos: (0..h).map(|k| get(&self.cos, k) + get(&other.cos, k)).collect(),
            sin: (0..h).map(|k| get(&self.sin, k) + get(&other.sin, k)).collect(),
        }
    }

    /// Exact product of two series of the same base frequency (harmonics add up). Only the non-zero
    /// coefficients are multiplied: a series stretched over a long period (a mesh over the hunting period)
    /// holds one harmonic in hundreds.
    pub fn times(&self, other: &Self) -> Self {
        let (a, b) = (self.complex_coefficients(), other.complex_coefficients());
        let (ha, hb) = (self.harmonics() as isize, other.harmonics() as isize);
        let h = ha + hb;
        let mut c = vec![(0.0, 0.0); (2 * h + 1) as usize];
        let nonzero = |v: &[(f64, f64)], off: isize| -> Vec<isize> {
            (0..v.len()).filter(|&k| v[k] != (0.0, 0.0)).map(|k| k as isize - off).collect()
        };
        let nb = nonzero(&b, hb);
        for i in nonzero(&a, ha) {
            let (ar, ai) = a[(i + ha) as usize];
            for &j in &nb {
                let (br, bi) = b[(j + hb) as usize];
                let slot = &mut c[(i + j + h) as usize];
                slot.0 += ar * br - ai * bi;
                slot.1 += ar * bi + ai * br;
            }
        }
        Self::from_complex_coefficients(self.common_omega(other), &c)
    }

    fn common_omega(&self, other: &Self) -> f64 {
        if self.is_constant() { other.omega_rad_s } else { self.omega_rad_s }
    }

    /// Complex coefficients c_k, k = -H..=H (index k + H), with s(t) = sum c_k exp(i k w t).
    pub fn complex_coefficients(&self) -> Vec<(f64, f64)> {
        let h = self.harmonics();
        let mut out = vec![(0.0, 0.0); 2 * h + 1];
        out[h] = (self.mean, 0.0);
        for k in 1..=h {
            let (a, b) = (self.cos[k - 1], self.sin[k - 1]);
            // a cos + b sin = (a - i b)/2 e^{i..} + (a + i b)/2 e^{-i..}
            out[h + k] = (a / 2.0, -b / 2.0);
            out[h - k] = (a / 2.0, b / 2.0);
        }
        out
    }

    /// Inverse of [`complex_coefficients`](Self::complex_coefficients) (imaginary parts of a real series'
    /// mean are ignored).
    pub fn from_complex_coefficients(omega_rad_s: f64, c: &[(f64, f64)]) -> Self {
        let h = (c.len() - 1) / 2;
        let cos = (1..=h).map(|k| c[h + k].0 + c[h - k].0).collect();
        let sin = (1..=h).map(|k| c[h - k].1 - c[h + k].1).collect();
        Self { omega_rad_s, mean: c[h].0, cos, sin }
    }

    /// Drops trailing harmonics whose amplitude is below `abs_tol`; returns how many were dropped.
    pub fn truncate_below(&mut self, abs_tol: f64) -> usize {
        let before = self.harmonics();
        while let Some(k) = self.harmonics().checked_sub(1) {
            if self.cos[k].hypot(self.sin[k]) > abs_tol {
                break;
            }
            self.cos.pop();
            self.sin.pop();
        }
        before - self.harmonics()
    }

    /// Largest harmonic amplitude (0 for a constant).
    pub fn max_amplitude(&self) -> f64 {
        (1..=self.harmonics()).map(|k| self.amplitude(k)).fold(0.0, f64::max)
    }

    /// Series of a periodic function given by `n` equally spaced samples over one period (trigonometric
    /// interpolation; exact for band-limited data with H < n/2), keeping `max_harmonics` harmonics.
    pub fn from_samples(omega_rad_s: f64, samples: &[f64], max_harmonics: usize) -> Self {
        let n = samples.len();
        let h = max_harmonics.min((n - 1) / 2);
        let mean = samples.iter().sum::<f64>() / n as f64;
        let mut cos = vec![0.0; h];
        let mut sin = vec![0.0; h];
        for k in 1..=h {
            let (mut a, mut b) = (0.0, 0.0);
            for (j, &v) in samples.iter().enumerate() {
                let (s, c) = (2.0 * std::f64::consts::PI * (k * j % n) as f64 / n as f64).sin_cos();
                a += v * c;
                b += v * s;
            }
            cos[k - 1] = 2.0 * a / n as f64;
            sin[k - 1] = 2.0 * b / n as f64;
        }
        Self { omega_rad_s, mean, cos, sin }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naive(s: &FourierSeries, t: f64) -> [f64; 4] {
        let mut out = [s.mean, 0.0, 0.0, 0.0];
        for k in 1..=s.harmonics() {
            let kw = k as f64 * s.omega_rad_s;
            let (a, b) = (s.cos[k - 1], s.sin[k - 1]);
            let (sn, cs) = (kw * t).sin_cos();
            out[0] += a * cs + b * sn;
            out[1] += kw * (b * cs - a * sn);
            out[2] += -kw * kw * (a * cs + b * sn);
            out[3] += -kw.powi(3) * (b * cs - a * sn);
        }
        out
    }

    fn sample() -> FourierSeries {
        FourierSeries::new(2.5, 0.3, vec![1.0, -0.5, 0.25, 0.0, 0.1], vec![0.2, 0.0, -0.7])
    }

    #[test]
    fn sample_uniform_works() {
        // against eval at each time (a sine and cosine per time): the turned phasors drift by rounding only
        let s = FourierSeries::new(7.3, 0.4, vec![1.0, -0.5, 0.25, 0.0, 0.1], vec![0.3, 0.2, -0.7, 0.05, 0.0]);
        let (t0, dt) = (0.013, 0.0021);
        let mut out = vec![0.0; 300];
        s.sample_uniform(t0, dt, &mut out);
        for (j, v) in out.iter().enumerate() {
            let want = s.eval(t0 + j as f64 * dt);
            // 64 turns of unit phasors summed over coefficients of size ~3: a few hundred eps at most
            assert!((v - want).abs() < 1e-13, "sample {j}: {v} against {want}");
        }
    }

    #[test]
    fn sample_uniform_over_a_period_works() {
        // the inverse-FFT path (N samples spanning one period, with and without the period's end) against
        // eval at each time
        let s = FourierSeries::new(7.3, 0.4, vec![1.0, -0.5, 0.25, 0.0, 0.1], vec![0.3, 0.2, -0.7, 0.05, 0.0]);
        let period = std::f64::consts::TAU / 7.3;
        for (n, extra, t0) in [(64, 0, 0.013), (80, 1, 0.0), (160, 0, -0.4), (100, 1, 0.37)] {
            let dt = period / n as f64;
            let mut out = vec![f64::NAN; n + extra];
            assert!(s.sample_period(t0, dt, &mut out), "{n} samples span the period");
            for (j, v) in out.iter().enumerate() {
                let want = s.eval(t0 + j as f64 * dt);
                // an FFT of 64-160 points on coefficients of size ~3: rounding of a few tens of eps
                assert!((v - want).abs() < 1e-13, "{n}: sample {j}: {v} against {want}");
            }
        }
        // not a period, or too few samples: the turned phasors
        let mut out = vec![0.0; 100];
        assert!(!s.sample_period(0.0, period / 101.0, &mut out));
        let mut out = vec![0.0; 32];
        assert!(!s.sample_period(0.0, period / 32.0, &mut out));
    }

    #[test]
    fn eval_derivatives_works() {
        let s = sample();
        for i in 0..50 {
            let t = i as f64 * 0.137 - 2.0;
            let (got, want) = (s.eval_derivatives(t), naive(&s, t));
            for d in 0..4 {
                // recurrence vs direct cos/sin: agree to rounding times the scale k^d w^d
                let scale = (5.0 * 2.5f64).powi(d as i32) * 3.0;
                assert!((got[d] - want[d]).abs() < 1e-13 * scale, "d={d} t={t} {} {}", got[d], want[d]);
            }
            assert!((s.eval(t) - want[0]).abs() < 1e-13);
        }
    }

    #[test]
    fn times_works() {
        let (a, b) = (sample(), FourierSeries::new(2.5, -1.0, vec![0.0, 0.3], vec![0.4]));
        let p = a.times(&b);
        assert_eq!(p.harmonics(), 7);
        for i in 0..30 {
            let t = i as f64 * 0.31;
            assert!((p.eval(t) - a.eval(t) * b.eval(t)).abs() < 1e-13);
        }
    }

    #[test]
    fn derivative_and_amplitude_phase_work() {
        let s = FourierSeries::from_amplitude_phase(3.0, 1.0, &[(2, 0.5, 0.7), (3, 0.2, -1.1)]);
        for i in 0..20 {
            let t = i as f64 * 0.21;
            let want = 1.0 + 0.5 * (6.0 * t + 0.7).cos() + 0.2 * (9.0 * t - 1.1).cos();
            assert!((s.eval(t) - want).abs() < 1e-14);
            assert!((s.derivative().eval(t) - s.eval_derivatives(t)[1]).abs() < 1e-12);
        }
        assert!((s.amplitude(2) - 0.5).abs() < 1e-15);
    }

    #[test]
    fn from_samples_works() {
        let s = sample();
        let w = 2.5;
        let period = 2.0 * std::f64::consts::PI / w;
        let data: Vec<f64> = (0..32).map(|j| s.eval(period * j as f64 / 32.0)).collect();
        let back = FourierSeries::from_samples(w, &data, 10);
        for k in 0..=5 {
            assert!((back.amplitude(k) - s.amplitude(k)).abs() < 1e-13);
        }
        assert!(back.amplitude(6) < 1e-13);
    }
}
