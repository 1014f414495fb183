//! Tests of the envelope, the kurtogram, the comb liftering, the cepstrum and the order spectrum.

use super::*;
use crate::signal::test_noise::uniform_noise;
use std::f64::consts::TAU;

#[test]
fn comb_liftering_removes_a_shafts_family_and_keeps_other_lines() {
    // a pulse repeating every 128 samples (its harmonics on bins 64 k of 8192), a 0.5 sine on bin 1013
    // (no harmonic of the pulse), white noise 0.01 (a floor for the log spectrum)
    let n = 8192;
    let mut noise = 12345u64;
    let mut gauss = || {
        let mut u = || {
            noise = noise.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((noise >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (-2.0 * u().ln()).sqrt() * (TAU * u()).cos()
    };
    let x: Vec<f64> = (0..n)
        .map(|i| {
            let p = (i % 128) as f64;
            (-p / 6.0).exp() + 0.5 * (TAU * 1013.0 * i as f64 / n as f64).sin() + 0.01 * gauss()
        })
        .collect();
    let mut fft = Fft::new();
    let y = lifter_comb(&mut fft, &x, 128.0, 1).unwrap();
    let amp = |s: &[f64], fft: &mut Fft| {
        let mut b = s.to_vec();
        let mut sp = Vec::new();
        fft.forward(&mut b, &mut sp);
        sp.iter().map(|c| 2.0 * magnitude(*c) / n as f64).collect::<Vec<f64>>()
    };
    let (a, b) = (amp(&x, &mut fft), amp(&y, &mut fft));
    let family = |s: &[f64]| (1..20).map(|k| s[64 * k].powi(2)).sum::<f64>().sqrt();
    // the family: its 19 first harmonics lose more than 10 dB in all
    assert!(20.0 * (family(&a) / family(&b)).log10() > 10.0, "{} -> {}", family(&a), family(&b));
    // the sine: within 1 dB (liftering 3 of 4096 quefrencies per rahmonic touches it only slightly)
    assert!((20.0 * (b[1013] / a[1013]).log10()).abs() < 1.0, "{} -> {}", a[1013], b[1013]);
    // bad periods are refused
    assert!(lifter_comb(&mut fft, &x, 2.0, 2).is_err());
    assert!(lifter_comb(&mut fft, &x[..100], 128.0, 2).is_err());
}

/// 1 s of (1 + m cos(2 pi fm t)) cos(2 pi 1000 t) at `fs`.
fn am_signal(fs: f64, fm: f64, m: f64) -> Vec<f64> {
    (0..fs as usize)
        .map(|i| {
            let t = i as f64 / fs;
            (1.0 + m * (TAU * fm * t).cos()) * (TAU * 1000.0 * t).cos()
        })
        .collect()
}

#[test]
fn squared_envelope_of_am_signal_is_closed_form() {
    // x = (1 + m cos(2 pi fm t)) cos(2 pi fc t): e = (1 + m cos)^2 = 1 + m^2/2 + 2 m cos + m^2/2 cos(2 .)
    let (fs, fm, m) = (8192.0, 16.0, 0.3);
    let x = am_signal(fs, fm, m);
    let e = squared_envelope(&mut Fft::new(), &x, fs, 900.0, 1100.0).unwrap();
    // every line is on a bin and inside the band: the envelope is exact to rounding
    for (i, v) in e.iter().enumerate().skip(100).take(7000) {
        let t = i as f64 / fs;
        let want = (1.0 + m * (TAU * fm * t).cos()).powi(2);
        assert!((v - want).abs() < 1e-9, "{i}: {v} vs {want}");
    }
    assert!(squared_envelope(&mut Fft::new(), &x, fs, 1100.0, 900.0).is_err());
}

#[test]
fn decimated_envelope_matches_the_full_rate_one() {
    // the same AM signal: the decimated squared envelope at sample j equals the full-rate one at j / r
    let (fs, fm, m) = (8192.0, 16.0, 0.3);
    let x = am_signal(fs, fm, m);
    let (e, r) = squared_envelope_decimated(&mut Fft::new(), &x, fs, 900.0, 1100.0).unwrap();
    assert!(r < 0.2, "{r}");
    for (j, v) in e.iter().enumerate() {
        let t = j as f64 / r / fs;
        let want = (1.0 + m * (TAU * fm * t).cos()).powi(2);
        assert!((v - want).abs() < 1e-9, "{j}: {v} vs {want}");
    }
}

#[test]
fn segment_envelope_matches_the_closed_form() {
    // the AM signal of the tests above, 1 s at 8192 Hz, in segments of 1024 (8 Hz bins; the lines at
    // 984, 1000, 1016 Hz on bins, the band 900 .. 1100 Hz): the overlap-added envelope at decimated sample
    // j is (1 + m cos(2 pi fm t))^2 at t = j / r / fs, over the whole record, padded ends included
    let (fs, fm, m) = (8192.0, 16.0, 0.3);
    let x = am_signal(fs, fm, m);
    let (e, r) = squared_envelope_segments(&mut Fft::new(), &x, fs, 900.0, 1100.0, 1024).unwrap();
    assert_eq!(e.len() as f64, (x.len() as f64 * r).ceil());
    let edge = (512.0 * r) as usize;
    for (j, v) in e.iter().enumerate().take(e.len() - edge).skip(edge) {
        let t = j as f64 / r / fs;
        let want = (1.0 + m * (TAU * fm * t).cos()).powi(2);
        // lines on bins: each windowed segment's band holds its whole spectrum, so the sum is exact to
        // rounding
        assert!((v - want).abs() < 1e-9, "{j}: {v} vs {want}");
    }
    // (the first and last half segment hold the band-limited ringing of the record's hard ends, as any
    // band-pass filter would; the diagnosis averages over the whole record)
    // a line between bins (fc 1003.3 Hz, fm 13.7 Hz)
    let y: Vec<f64> = (0..8192)
        .map(|i| {
            let t = i as f64 / fs;
            (1.0 + m * (TAU * 13.7 * t).cos()) * (TAU * 1003.3 * t + 0.4).cos()
        })
        .collect();
    let (e, r) = squared_envelope_segments(&mut Fft::new(), &y, fs, 900.0, 1100.0, 1024).unwrap();
    for (j, v) in e.iter().enumerate().take(e.len() - edge).skip(edge) {
        let t = j as f64 / r / fs;
        let want = (1.0 + m * (TAU * 13.7 * t).cos()).powi(2);
        // off a bin, each windowed line leaks Hann sidelobes past the band's edges (11 bins away: about
        // -69 dB of the line each, a few of them): |c| off by about 1e-3, |c|^2 by twice that
        assert!((v - want).abs() < 4e-3, "{j}: {v} vs {want}");
    }
    assert!(squared_envelope_segments(&mut Fft::new(), &x, fs, 1100.0, 900.0, 1024).is_err());
}

#[test]
fn kurtogram_finds_the_band_of_the_impacts() {
    // Gaussian-like noise (sum of 12 uniforms) plus a decaying 3 kHz ring every 100 ms
    let fs = 16384.0;
    let mut centred = uniform_noise(7);
    let mut uni = || centred() + 0.5;
    let x: Vec<f64> = (0..65536)
        .map(|i| {
            let t = i as f64 / fs;
            let noise: f64 = (0..12).map(|_| uni()).sum::<f64>() - 6.0;
            let since = t % 0.1;
            noise + 4.0 * (-since * 400.0).exp() * (TAU * 3000.0 * since).sin()
        })
        .collect();
    let k = kurtogram(&mut Fft::new(), &x, fs, 5, 0.0).unwrap();
    let (_, _, lo, hi) = k.best;
    assert!(lo <= 3000.0 && 3000.0 <= hi, "band {lo} .. {hi}");
    assert!(k.best_kurtosis > 1.0, "{}", k.best_kurtosis);
    // white noise alone has SK near 0 in every band (Antoni: 0 for a Gaussian process)
    let noise: Vec<f64> = (0..65536).map(|_| (0..12).map(|_| uni()).sum::<f64>() - 6.0).collect();
    let kn = kurtogram(&mut Fft::new(), &noise, fs, 3, 0.0).unwrap();
    assert!(kn.best_kurtosis < 0.3, "{}", kn.best_kurtosis);
    assert!(kurtogram(&mut Fft::new(), &x[..1024], fs, 6, 0.0).is_err());
    // above 4 kHz the impacts' band is excluded
    let above = kurtogram(&mut Fft::new(), &x, fs, 5, 4000.0).unwrap();
    assert!(above.best.2 >= 4000.0);
}

#[test]
fn cepstrum_of_an_echo_peaks_at_its_delay() {
    // x(t) = s(t) + a s(t - tau): ln|1 + a e^{-i w tau}|^2 = 2 sum (-1)^(k+1) a^k cos(k w tau) / k, so
    // the cepstrum has a rahmonic of height a at quefrency tau (and -a^2/2 at 2 tau)
    let (a, tau) = (0.5, 37usize);
    let mut noise = uniform_noise(3);
    let s: Vec<f64> = (0..70_000).map(|_| noise()).collect();
    let x: Vec<f64> = (tau..s.len()).map(|i| s[i] + a * s[i - tau]).collect();
    let c = cepstrum(&mut Fft::new(), &x, 1024).unwrap();
    let peak = (10..400).max_by(|&i, &j| c[i].total_cmp(&c[j])).unwrap();
    assert_eq!(peak, tau);
    // averaged over 135 segments the noise's own cepstrum is small; the window smooths the log spectrum
    // slightly: within 10 %
    assert!((c[tau] - a).abs() < 0.05, "{}", c[tau]);
    assert!((c[2 * tau] + a * a / 2.0).abs() < 0.05, "{}", c[2 * tau]);
}

#[test]
fn order_spectrum_reads_orders_at_varying_speed() {
    // orders 3 (amplitude 1) and 14 (0.5) under a 10 % linear speed change
    let n = 100_000;
    let rate = |i: f64| 0.01 * (1.0 + 0.1 * i / n as f64);
    let mut th = 0.0;
    let mut starts = Vec::new();
    let x: Vec<f64> = (0..n)
        .map(|i| {
            let v = (TAU * 3.0 * th).cos() + 0.5 * (TAU * 14.0 * th).sin();
            let next = th + rate(i as f64);
            if next.floor() > th.floor() {
                starts.push(i as f64 + (next.floor() - th) / (next - th));
            }
            th = next;
            v
        })
        .collect();
    let map = AngleMap::from_pulses(&starts, 1);
    let (orders, amps) = order_spectrum(&mut Fft::new(), &x, &map, 64);
    let at =
        |o: f64| orders.iter().zip(&amps).filter(|(k, _)| (*k - o).abs() < 0.01).map(|(_, a)| *a).fold(0.0, f64::max);
    // whole revolutions: both orders on a bin, Hann-corrected amplitude exact up to the interpolation
    // (1e-3) and the starts' linear crossing times (about 1e-4 revolution)
    assert!((at(3.0) - 1.0).abs() < 0.01, "{}", at(3.0));
    assert!((at(14.0) - 0.5).abs() < 0.01, "{}", at(14.0));
    // in parts of at most 256 revolutions (about 1050 here: 5 parts of about 210), averaged in power:
    // the steady lines read the same amplitudes (each part's orders on its bins, as above)
    let (o5, a5, part) = order_spectrum_parts(&mut Fft::new(), &x, &map, 64, 256);
    assert_eq!(part, map.revolutions() / 5);
    assert!((o5[1] - 1.0 / part as f64).abs() < 1e-15);
    let at5 = |o: f64| a5[(o * part as f64).round() as usize];
    assert!((at5(3.0) - 1.0).abs() < 0.01, "{}", at5(3.0));
    assert!((at5(14.0) - 0.5).abs() < 0.01, "{}", at5(14.0));
    // a record within the limit is read whole, exactly as order_spectrum reads it
    let (o1, a1, whole) = order_spectrum_parts(&mut Fft::new(), &x, &map, 64, 4096);
    assert_eq!((o1, a1, whole), (orders, amps, map.revolutions()));
}

/// The overlap-add keeps only one segment's span of open sums; what it returns is, to the bit, the
/// record-long accumulation it replaced (every position's sum of the segments over it, in order).
#[test]
fn streamed_overlap_add_is_the_record_long_sum() {
    let (n, segment, fs) = (20_000usize, 1024usize, 8192.0);
    let mut noise = uniform_noise(7);
    let x: Vec<f64> = (0..n).map(|_| noise()).collect();
    let (streamed, r) = squared_envelope_segments(&mut Fft::new(), &x, fs, 700.0, 1500.0, segment).unwrap();
    // the reference: each segment's band inverse-transformed and added at its place in a record-long sum
    let probe = BandOverlapAdd::new(n, segment, fs, 700.0, 1500.0).unwrap();
    let (lo, width, len) = (probe.lo, probe.width, probe.len);
    let mut c = vec![(0.0f64, 0.0f64); (n * len).div_ceil(segment)];
    let mut fft = Fft::new();
    let half = (segment / 2) as isize;
    super::super::spectrum::averaged_power_each(&mut Fft::new(), &x, segment, 0.5, "t", true, |_, start, spec| {
        let sign = if ((start.div_euclid(half)) * lo as isize).rem_euclid(2) == 0 { 1.0 } else { -1.0 };
        let scale = 2.0 * sign / segment as f64;
        let mut buf = vec![(0.0, 0.0); len];
        for (b, v) in buf.iter_mut().zip(&spec[lo..lo + width]) {
            *b = (scale * v.0, scale * v.1);
        }
        fft.inverse_complex(&mut buf);
        let at = start.div_euclid(half) * (len / 2) as isize;
        for (j, b) in buf.iter().enumerate() {
            if let Some(v) = usize::try_from(at + j as isize).ok().and_then(|i| c.get_mut(i)) {
                *v = (v.0 + b.0, v.1 + b.1);
            }
        }
    })
    .unwrap();
    let reference: Vec<f64> = c.iter().map(|(re, im)| re * re + im * im).collect();
    assert_eq!(r, len as f64 / segment as f64);
    assert!(streamed == reference, "the streamed envelope differs from the record-long sum");
}
