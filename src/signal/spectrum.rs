//! Discrete Fourier transforms of real data (realfft / rustfft live only here).
//!
//! Conventions: one-sided spectra have N/2 + 1 bins at k fs / N. "Amplitude" means the peak amplitude of
//! the sinusoid at that bin: |X_0| / N for k = 0, 2 |X_k| / N otherwise (|X_{N/2}| / N at Nyquist for even
//! N), divided by the window's coherent gain (mean of the window) when a window is applied.

use realfft::RealFftPlanner;

/// Amplitudes of harmonics 0..=N/2 of one period sampled at N equally spaced points (no window: the
/// record is exactly one period, so every harmonic falls on a bin).
pub fn periodic_amplitudes(samples: &[f64]) -> Vec<f64> {
    let n = samples.len();
    if n == 0 {
        return Vec::new();
    }
    let mut planner = RealFftPlanner::<f64>::new();
    let r2c = planner.plan_fft_forward(n);
    let mut input = samples.to_vec();
    let mut out = r2c.make_output_vec();
    r2c.process(&mut input, &mut out).expect("buffer sizes come from the plan");
    out.iter()
        .enumerate()
        .map(|(k, c)| {
            let scale = if k == 0 || (n % 2 == 0 && k == n / 2) { 1.0 } else { 2.0 };
            scale * c.norm() / n as f64
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn periodic_amplitudes_works() {
        let n = 64;
        let x: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 / n as f64 * 2.0 * std::f64::consts::PI;
                0.5 + 2.0 * (3.0 * t + 0.3).cos() + 0.25 * (7.0 * t).sin()
            })
            .collect();
        let a = periodic_amplitudes(&x);
        assert_eq!(a.len(), 33);
        assert!((a[0] - 0.5).abs() < 1e-13);
        assert!((a[3] - 2.0).abs() < 1e-13);
        assert!((a[7] - 0.25).abs() < 1e-13);
        assert!(a[5] < 1e-13);
    }
}
