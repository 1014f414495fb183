//! Tests of the transforms and spectra (the FFT and a line's amplitude against a naive O(n^2) DFT).

use super::*;
use crate::signal::test_noise::uniform_noise;

/// The PSD read off an amplitude spectrum is Welch's PSD of the same segments (to rounding), and its
/// integral is the variance of white noise (Parseval; the average of 37 segments leaves a few percent
/// of scatter in the sum, far less: 1 %).
#[test]
fn psd_from_the_amplitude_is_welch_and_integrates_to_the_variance() {
    let mut noise = uniform_noise(11);
    let x: Vec<f64> = (0..(1 << 16)).map(|_| noise()).collect();
    let fs = 2000.0;
    let mut fft = Fft::new();
    let amp = amplitude_spectrum(&mut fft, &x, fs, AmplitudeOptions { segment: 4096, overlap: 0.5 }).unwrap();
    let psd = psd_from_amplitude(&amp);
    let welch = welch_psd(&mut fft, &x, fs, 4096).unwrap();
    for (a, b) in psd.values.iter().zip(&welch.values) {
        assert!((a - b).abs() <= 1e-12 * b.abs().max(1e-30), "{a} {b}");
    }
    let df = psd.freqs_hz[1];
    let integral: f64 = psd.values.iter().sum::<f64>() * df;
    let var = 1.0 / 12.0;
    assert!((integral / var - 1.0).abs() < 0.01, "{integral} against {var}");
}
use std::f64::consts::PI;

#[test]
fn line_amplitude_matches_a_naive_windowed_dft() {
    // a line between the probe frequencies, on a DC offset: the largest of the nine Hann-windowed DFT
    // values, each summed directly with cos and sin (the reference), within rounding of 65536 terms
    let n = 70_000;
    let m = 1 << 16;
    // probes a bin apart; the line 1.3 bins above the centre, 0.3 bins from a probe
    let (f, search) = (0.01234, 4.0 / m as f64);
    let line = f + 1.3 / m as f64;
    let x: Vec<f32> = (0..n).map(|i| (3.0 + 0.7 * (2.0 * PI * line * i as f64 + 0.4).sin()) as f32).collect();
    let w = hann(m);
    let mean = x[..m].iter().map(|v| f64::from(*v)).sum::<f64>() / m as f64;
    let gain: f64 = w.iter().sum();
    let naive = (-4..=4)
        .map(|j| {
            let fj = f + search * j as f64 / 4.0;
            let (mut re, mut im) = (0.0, 0.0);
            for i in 0..m {
                let y = (f64::from(x[i]) - mean) * w[i];
                re += y * (2.0 * PI * fj * i as f64).cos();
                im += y * (2.0 * PI * fj * i as f64).sin();
            }
            2.0 * re.hypot(im) / gain
        })
        .fold(0.0, f64::max);
    let fast = line_amplitude(&x, f, search);
    assert!((fast - naive).abs() < 1e-9 * naive, "{fast} {naive}");
    // and with probes a bin apart the amplitude is read within the Hann scalloping (15 % at most)
    assert!(fast > 0.85 * 0.7 && fast < 0.7 * 1.001, "{fast}");
}

/// O(N^2) DFT oracle.
fn naive_dft(x: &[f64]) -> Vec<(f64, f64)> {
    let n = x.len();
    (0..=n / 2)
        .map(|k| {
            x.iter().enumerate().fold((0.0, 0.0), |(re, im), (j, v)| {
                let a = -2.0 * PI * (k * j % n) as f64 / n as f64;
                (re + v * a.cos(), im + v * a.sin())
            })
        })
        .collect()
}

#[test]
fn forward_and_inverse_work() {
    let x: Vec<f64> = (0..48).map(|i| ((i * 7 % 11) as f64 - 5.0) * 0.3 + (i as f64 * 0.4).sin()).collect();
    let mut fft = Fft::new();
    let mut out = Vec::new();
    fft.forward(&mut x.clone(), &mut out);
    for (a, b) in out.iter().zip(naive_dft(&x)) {
        assert!((a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12);
    }
    let back = fft.inverse(&out, x.len());
    for (a, b) in back.iter().zip(&x) {
        assert!((a - b).abs() < 1e-13);
    }
}

#[test]
fn scalloping_is_corrected_for_a_line_anywhere_between_bins() {
    // a 1.0-amplitude sine at seeded random frequencies: the Hann peak bin alone reads as low as 0.85;
    // the interpolated line reads 1.000 +- 0.001 (the noise-free Hann main lobe makes the formula exact
    // up to the leakage of the negative-frequency image, below 1e-4 away from 0 and Nyquist)
    let (fs, n) = (10_000.0, 1usize << 17);
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let mut fft = Fft::new();
    for _ in 0..20 {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        let f = 200.0 + (seed % 1_000_000) as f64 / 1_000_000.0 * 4000.0;
        let x: Vec<f64> = (0..n).map(|i| (2.0 * PI * f * i as f64 / fs + 0.3).sin()).collect();
        let s = amplitude_spectrum(&mut fft, &x, fs, AmplitudeOptions::default()).unwrap();
        let (ff, a) = s.hann_line_near(f, 2.0).unwrap();
        assert!((a - 1.0).abs() < 1e-3, "f = {f}: amplitude {a}");
        let df = fs / 65536.0;
        assert!((ff - f).abs() < 0.02 * df, "f = {f}: {ff}");
    }
}

#[test]
fn periodic_amplitudes_works() {
    let n = 64;
    let x: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 / n as f64 * 2.0 * PI;
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

#[test]
fn amplitude_spectrum_recovers_sines_on_bins() {
    // 1024-sample segments at 1024 Hz: 1 Hz bins; sines on bins 50 and 200 with amplitudes 1.5, 0.01
    let fs = 1024.0;
    let x: Vec<f64> = (0..8192)
        .map(|i| 1.5 * (2.0 * PI * 50.0 * i as f64 / fs + 0.4).sin() + 0.01 * (2.0 * PI * 200.0 * i as f64 / fs).cos())
        .collect();
    let s = amplitude_spectrum(&mut Fft::new(), &x, fs, AmplitudeOptions { segment: 1024, overlap: 0.5 }).unwrap();
    assert!((s.freqs_hz[50] - 50.0).abs() < 1e-12);
    assert!((s.values[50] - 1.5).abs() < 1.5e-6, "{}", s.values[50]);
    assert!((s.values[200] - 0.01).abs() < 1e-8, "{}", s.values[200]);
}

#[test]
fn welch_psd_integrates_to_variance() {
    // white-ish deterministic sequence: the PSD integral equals the variance (Parseval, Hann-normalised)
    let mut state = 12345u64;
    let x: Vec<f64> = (0..65536)
        .map(|_| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect();
    let fs = 1000.0;
    let s = welch_psd(&mut Fft::new(), &x, fs, 1024).unwrap();
    let df = s.freqs_hz[1];
    let integral: f64 = s.values.iter().sum::<f64>() * df;
    let var = 1.0 / 12.0; // uniform on [-0.5, 0.5)
    assert!((integral / var - 1.0).abs() < 0.02, "{integral}");
}

#[test]
fn autocorrelation_finds_period() {
    let x: Vec<f64> =
        (0..4000).map(|i| (2.0 * PI * i as f64 / 37.0).sin() + 0.3 * (2.0 * PI * i as f64 / 18.5).cos()).collect();
    let r = autocorrelation(&mut Fft::new(), &x, 100);
    let peak = (20..60).max_by(|a, b| r[*a].total_cmp(&r[*b])).unwrap();
    assert_eq!(peak, 37);
    assert!((r[0] - 1.0).abs() < 1e-12);
}

/// The averaged power of a record of many segments (summed in parallel runs) is the mean over its
/// segments of the naive DFT's |X_k|^2 of each mean-removed, Hann-windowed segment (to rounding: 1e-9 of
/// the largest bin, sums of a few hundred terms of order 1).
#[test]
fn averaged_power_of_many_segments_is_the_mean_of_naive_dfts() {
    let mut noise = uniform_noise(5);
    // 203 segments of 64 at a step of 32: 16 runs of unequal length
    let x: Vec<f64> = (0..32 * 203 + 32 + 7).map(|i| noise() + (0.3 * i as f64).sin()).collect();
    let (power, n) = averaged_power(&mut Fft::new(), &x, 64, 0.5, "test").unwrap();
    assert_eq!(n, 64);
    let w = hann(64);
    let starts: Vec<usize> = (0..).map(|i| 32 * i).take_while(|s| s + 64 <= x.len()).collect();
    assert_eq!(starts.len(), 203);
    let mut mean = vec![0.0; 33];
    for &s in &starts {
        let seg = &x[s..s + 64];
        let m = seg.iter().sum::<f64>() / 64.0;
        let y: Vec<f64> = seg.iter().zip(&w).map(|(v, wi)| (v - m) * wi).collect();
        for (acc, c) in mean.iter_mut().zip(naive_dft(&y)) {
            *acc += (c.0 * c.0 + c.1 * c.1) / starts.len() as f64;
        }
    }
    let top = mean.iter().copied().fold(0.0, f64::max);
    for (k, (a, b)) in power.iter().zip(&mean).enumerate() {
        assert!((a - b).abs() <= 1e-9 * top, "bin {k}: {a} against {b}");
    }
}

/// The zero-padded inverse magnitudes against the inverse DFT summed directly: five complex values padded
/// to 16, and three unpadded, |sum_k X_k exp(+2 pi i k n / N)|. Tolerance 1e-12:
/// a 16-point transform of values near 1 rounds to a few 1e-16.
#[test]
fn zero_padded_inverse_magnitudes_match_a_direct_sum() {
    let data = [(1.0, 0.5), (-0.25, 2.0), (0.75, -1.0), (0.0, 0.3), (-1.5, 0.1)];
    let direct = |x: &[(f64, f64)], n: usize| -> Vec<f64> {
        (0..n)
            .map(|j| {
                let (mut re, mut im) = (0.0, 0.0);
                for (k, &(a, b)) in x.iter().enumerate() {
                    let (s, c) = (std::f64::consts::TAU * (k * j) as f64 / n as f64).sin_cos();
                    re += a * c - b * s;
                    im += a * s + b * c;
                }
                (re * re + im * im).sqrt()
            })
            .collect()
    };
    let mut fft = Fft::new();
    for (x, n) in [(&data[..], 16), (&data[..3], 3)] {
        let got = fft.inverse_complex_magnitudes(x, n);
        let want = direct(x, n);
        assert_eq!(got.len(), n);
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() < 1e-12, "{got:?} against {want:?}");
        }
    }
}
