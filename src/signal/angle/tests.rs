//! Tests of the order tracking: pulses, the mesh ridge, the phase lock and the demodulation.

use super::*;
use std::f64::consts::TAU;

/// The wander of speeds spread evenly over 1 +- 1 % is 0.8 % (the 10th and 90th percentiles of a
/// uniform spread), and two misread revolutions among a hundred do not move it.
#[test]
fn wander_is_the_half_range_between_the_speeds_deciles() {
    let even: Vec<f64> = (0..=100).map(|i| 0.99 + 0.02 * i as f64 / 100.0).collect();
    assert!((wander(&even) - 0.008).abs() < 1e-12, "{}", wander(&even));
    let mut misread = even.clone();
    misread[3] = 2.0;
    misread[60] = 0.1;
    assert!((wander(&misread) - 0.008).abs() < 2e-4, "{}", wander(&misread));
    assert_eq!(wander(&[]), 0.0);
}

/// A mesh of 14 teeth on a shaft whose speed follows `rate(t)` (revolutions per sample), with
/// sidebands at +-1 shaft order, noise-free; returns the samples and the true angle at each sample.
fn mesh_signal(n: usize, rate: impl Fn(f64) -> f64) -> (Vec<f64>, Vec<f64>) {
    let mut th = 0.0;
    let mut angle = Vec::with_capacity(n);
    let x = (0..n)
        .map(|i| {
            angle.push(th);
            let v = (TAU * 14.0 * th).cos() + 0.3 * (TAU * 13.0 * th).cos() + 0.2 * (TAU * th).sin();
            th += rate(i as f64);
            v
        })
        .collect();
    (x, angle)
}

/// A line at order 14 + 14/39 (a wheel sideband) of amplitude 0.3 beside a mesh line of amplitude 1, on
/// a shaft whose speed drifts by 1 %: read at its bin within 1 % (the 8-fold zero padding leaves at
/// most 1/16 bin, 0.6 % of Hann scalloping), and a bin with no line far below it.
#[test]
fn baseband_lines_read_a_sideband_on_a_drifting_shaft() {
    let n = 200_000;
    let rate = |i: f64| (1.0 + 0.01 * (i / n as f64)) / 333.3;
    let mut th = 0.0;
    let mut starts = Vec::new();
    let x: Vec<f64> = (0..n)
        .map(|i| {
            let next = th + rate(i as f64);
            if i == 0 || next.floor() > th.floor() {
                starts.push(if i == 0 { 0.0 } else { i as f64 + (next.floor() - th) / (next - th) });
            }
            let v = (TAU * 14.0 * th).cos() + 0.3 * (TAU * (14.0 + 14.0 / 39.0) * th + 0.4).cos();
            th = next;
            v
        })
        .collect();
    let map = AngleMap::from_pulses(&starts, 1);
    let a = baseband_lines(&mut Fft::new(), &x, &map, 14.0, 16);
    let bin = |d: f64| ((d * a.len() as f64 / 16.0).round() as isize).rem_euclid(a.len() as isize) as usize;
    assert!((a[bin(0.0)] - 1.0).abs() < 0.01, "{}", a[bin(0.0)]);
    assert!((a[bin(14.0 / 39.0)] - 0.3).abs() < 0.003, "{}", a[bin(14.0 / 39.0)]);
    assert!(a[bin(-14.0 / 39.0)] < 1e-3, "{}", a[bin(-14.0 / 39.0)]);
    // over a part of the record (revolutions 150..450): the same lines at the part's resolution, and
    // the whole range is the whole record's result
    let p = baseband_lines_over(&mut Fft::new(), &x, &map, 14.0, 16, 150..450);
    let pbin = |d: f64| ((d * p.len() as f64 / 16.0).round() as isize).rem_euclid(p.len() as isize) as usize;
    assert!((p[pbin(0.0)] - 1.0).abs() < 0.01, "{}", p[pbin(0.0)]);
    assert!((p[pbin(14.0 / 39.0)] - 0.3).abs() < 0.003, "{}", p[pbin(14.0 / 39.0)]);
    assert!(p[pbin(-14.0 / 39.0)] < 1e-3, "{}", p[pbin(-14.0 / 39.0)]);
    assert_eq!(baseband_lines_over(&mut Fft::new(), &x, &map, 14.0, 16, 0..map.revolutions()), a);
    assert!(baseband_lines_over(&mut Fft::new(), &x, &map, 14.0, 16, 0..map.revolutions() + 1).is_empty());
}

/// Largest error of the revolution starts against the true angle, in revolutions.
fn start_error(map: &AngleMap, angle: &[f64]) -> f64 {
    let starts = map.starts();
    // the tracked origin is the mesh phase: compare angle increments from the first start
    let at = |s: f64| {
        let i = s as usize;
        angle[i] + (angle[i + 1] - angle[i]) * (s - i as f64)
    };
    let a0 = at(starts[0]);
    starts.iter().enumerate().map(|(k, &s)| (at(s) - a0 - k as f64).abs()).fold(0.0, f64::max)
}

#[test]
fn follows_a_twenty_percent_run_up() {
    // 100 samples per revolution at the start, 80 at the end (+25 % speed), over 300 revolutions
    let n = 27_000;
    let rate = |i: f64| 0.01 * (1.0 + 0.25 * i / n as f64);
    let (x, angle) = mesh_signal(n, rate);
    let t = track_mesh(&x, 90.0, 14.0).unwrap();
    // noise-free: measured 2.6e-4 rev, from sideband leakage through the moving averages whose zeros
    // miss the changing shaft frequency. 5e-4 rev is 0.044 rad of mesh phase at order 14: a TSA loses
    // 0.1 % of the mesh amplitude to it (a mesh period is 0.07 rev)
    let e = start_error(&t.map, &angle);
    assert!(e < 5e-4, "start error {e} rev");
    let p = SpeedProfile::of(&t.map);
    assert!((p.change - 0.25 / 1.125).abs() < 0.03, "{p:?}");
}

#[test]
fn follows_slow_random_fluctuation() {
    // 1 % speed fluctuation of a few slow sinusoids
    let n = 60_000;
    let rate = |i: f64| 0.01 * (1.0 + 0.006 * (i / 7000.0).sin() + 0.004 * (i / 2300.0 + 1.0).cos());
    let (x, angle) = mesh_signal(n, rate);
    let t = track_mesh(&x, 100.0, 14.0).unwrap();
    // as above
    let e = start_error(&t.map, &angle);
    assert!(e < 5e-4, "start error {e} rev");
    assert!(t.line_snr_db > 20.0);
}

#[test]
fn pulse_jitter_is_smoothed_and_a_run_up_kept() {
    // revolution k starts at t(k) = 300 k - 0.3 k^2 (a steady run-up), edges rounded to whole samples
    let truth: Vec<f64> = (0..200).map(|k| 300.0 * k as f64 - 0.3 * (k * k) as f64 / 2.0).collect();
    let pulses: Vec<f64> = truth.iter().map(|t| t.round()).collect();
    let map = from_pulses(&pulses, 1).unwrap();
    let err = |s: &[f64]| (s.iter().zip(&truth).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / s.len() as f64).sqrt();
    // rounding jitter is uniform in +-0.5 (rms 0.29 sample); the fit's noise gain is 0.36 in the
    // interior and up to about 0.6 at the ends: the rms error must fall below 0.6 of the raw one
    assert!(err(map.starts()) < 0.6 * err(&pulses), "{} vs {}", err(map.starts()), err(&pulses));
}

#[test]
fn a_fast_speed_fluctuation_is_kept_and_the_jitter_still_smoothed() {
    // 1000 samples per revolution with a 2 % speed fluctuation of one cycle per 16 revolutions (1.5 Hz
    // at 1480 rpm): revolution k starts at t(k) = 1000 (k + a sin(2 pi k / 16)), the closed form of a
    // phase modulation whose speed swings by 2 pi a / 16 = 2 %; edges rounded to whole samples
    let a = 0.02 * 16.0 / std::f64::consts::TAU;
    let truth: Vec<f64> = (0..300).map(|k| 1000.0 * (k as f64 + a * (TAU * k as f64 / 16.0).sin())).collect();
    let pulses: Vec<f64> = truth.iter().map(|t| t.round()).collect();
    let map = from_pulses(&pulses, 1).unwrap();
    let err = |s: &[f64]| (s.iter().zip(&truth).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / s.len() as f64).sqrt();
    // the 17-revolution fit misses the fluctuation by samples (its residual is 4 samples rms on the
    // test generator's gearbox); a window that follows it leaves the rounding jitter (0.29 sample rms)
    // reduced by its noise gain (0.58 for 7 revolutions) plus a bias of a tenth of a sample: below the
    // raw edges' error
    assert!(err(map.starts()) < err(&pulses), "{} vs {}", err(map.starts()), err(&pulses));
    assert!(err(&quadratic_fit(&pulses, 17).0) > 1.0, "the widest window would have smoothed the fluctuation away");
}

#[test]
fn missing_pulses_are_refused() {
    let mut p: Vec<f64> = (0..20).map(|k| k as f64 * 100.0).collect();
    p.remove(7);
    let e = from_pulses(&p, 1).unwrap_err().to_string();
    assert!(e.contains("missing"), "{e}");
    assert!(from_pulses(&[0.0, 100.0], 1).is_err());
}

/// The phase-locked loop against its own linear theory: for a small phase modulation theta_b = a sin(w b)
/// the loop's error e = theta - prediction has the transfer E / Theta = (1 - u)^2 / (1 - (2 - K1 - K2) u +
/// (1 - K1) u^2), u = exp(-i w) (from its recursion: prediction p_b = phase_(b-1) + rate_(b-1), phase_b =
/// p_b + K1 e_b, rate_b = rate_(b-1) + K2 e_b), and the phase it returns, theta - (1 - K1) e, lags by
/// that. A frequency offset (a phase ramp) is followed with no error left (a type-2 loop).
#[test]
fn the_phase_lock_follows_its_linear_theory() {
    let per_rev = 16.0;
    let wn = TAU * LOCK_NATURAL_ORDER / per_rev;
    let (k1, k2) = (2.0 * LOCK_DAMPING * wn, wn * wn);
    let n = 4000;
    for w in [0.02, 0.1, 0.4] {
        let a = 0.01;
        let theta: Vec<f64> = (0..n).map(|b| a * (w * b as f64).sin()).collect();
        let z: Vec<(f64, f64)> = theta.iter().map(|t| ((TAU * t).cos(), (TAU * t).sin())).collect();
        let phase = phase_lock(&z, 1.0, (k1, k2), per_rev);
        // the error's amplitude over the settled second half, by projection on sin and cos of w b
        let (mut s, mut c) = (0.0, 0.0);
        for b in n / 2..n {
            let e = theta[b] - phase[b];
            s += e * (w * b as f64).sin();
            c += e * (w * b as f64).cos();
        }
        let measured = 2.0 * (s * s + c * c).sqrt() / (n / 2) as f64 / a;
        // |1 - H| for the returned phase: theta - phase = (1 - K1) e (the correction takes K1 e)
        let u = ((-w).cos(), (-w).sin());
        let mul = |x: (f64, f64), y: (f64, f64)| (x.0 * y.0 - x.1 * y.1, x.0 * y.1 + x.1 * y.0);
        let u2 = mul(u, u);
        let num = (1.0 - 2.0 * u.0 + u2.0, -2.0 * u.1 + u2.1);
        let den = (1.0 - (2.0 - k1 - k2) * u.0 + (1.0 - k1) * u2.0, -(2.0 - k1 - k2) * u.1 + (1.0 - k1) * u2.1);
        let theory = (1.0 - k1) * ((num.0 * num.0 + num.1 * num.1) / (den.0 * den.0 + den.1 * den.1)).sqrt();
        // the projection over 2000 blocks leaves the transient (decayed by exp(-zeta wn 2000)) and a
        // leakage of 1 / (w 2000) at most relative; the detector's sine departs from its argument by
        // (2 pi e)^2 / 6 < 1e-3 relative for e < 0.01 cycles: 2 % covers both
        assert!((measured - theory).abs() < 0.02 * theory.max(1e-3), "w {w}: {measured} against {theory}");
    }
    // a phase ramp of 0.05 cycles per block: followed to rounding once settled
    let z: Vec<(f64, f64)> = (0..n).map(|b| ((TAU * 0.05 * b as f64).cos(), (TAU * 0.05 * b as f64).sin())).collect();
    let phase = phase_lock(&z, 1.0, (k1, k2), per_rev);
    let e = (phase[n - 1] - 0.05 * (n - 1) as f64).rem_euclid(1.0);
    assert!(e.min(1.0 - e) < 1e-9, "{e}");
}

/// Uniform noise in +-0.5 (xorshift from `seed`), its rms 0.29.
fn uniform_noise(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}

/// A mesh harmonic at order 60 (15 teeth, fourth harmonic) with sidebands at +-1 order and noise, on a
/// shaft whose speed swings by 1.5 % once every 8 revolutions (1.5 Hz at 12 Hz): the line's phase swings
/// by +-1.15 cycles around a steady angle and its frequency by +-0.9 orders, beyond the demodulation's
/// +-0.5 orders. Returns the samples and the true angle (revolutions) at each sample.
fn fluctuating_mesh(n: usize, period: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut th = 0.0;
    let mut angle = Vec::with_capacity(n);
    let mut noise = uniform_noise(seed);
    let x = (0..n)
        .map(|_| {
            angle.push(th);
            let v = (TAU * 60.0 * th).cos()
                + 0.3 * (TAU * 59.0 * th + 0.5).cos()
                + 0.3 * (TAU * 61.0 * th + 1.0).cos()
                + 0.5 * (TAU * th).sin()
                + 0.35 * noise();
            th += (1.0 + 0.015 * (TAU * th / 8.0).sin()) / period;
            v
        })
        .collect();
    (x, angle)
}

/// Rms and largest error of the angle at 16 points per revolution (through [`AngleMap::sample_at`])
/// against the true angle, in cycles of `order`, the origin removed.
fn angle_error(map: &AngleMap, angle: &[f64], order: f64) -> (f64, f64) {
    let at = |s: f64| {
        let i = s as usize;
        angle[i] + (angle[i + 1] - angle[i]) * (s - i as f64)
    };
    let e: Vec<f64> = (0..map.revolutions() * 16).map(|j| j as f64 / 16.0).map(|r| at(map.sample_at(r)) - r).collect();
    let mean = e.iter().sum::<f64>() / e.len() as f64;
    let rms = (e.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / e.len() as f64).sqrt();
    (rms * order, e.iter().map(|v| (v - mean).abs()).fold(0.0, f64::max) * order)
}

#[test]
fn follows_a_speed_fluctuation_of_a_few_revolutions_at_a_high_mesh_order() {
    let (n, period) = (60_000, 250.0);
    let (x, angle) = fluctuating_mesh(n, period, 7);
    let t = track_mesh(&x, period, 60.0).unwrap();
    let (rms, max) = angle_error(&t.map, &angle, 60.0);
    // measured 0.012 cycles rms and 0.063 at most (in the first revolution, where the averages are
    // one-sided): the loop leaves 0.1 of the +-1.15-cycle swing, the twice-applied averages 0.04 of
    // that and the demodulation passes 0.19^2 of the rest; the sidebands and the noise leak a little
    // through the averages whose zeros sit at whole orders of the mean speed. The ridge and the
    // demodulation alone slip whole cycles (below): 0.02 rms and 0.1 at most tell the two apart
    assert!(rms < 0.02 && max < 0.1, "error {rms} cycles rms, {max} at most (order 60)");
    // the ridge and the demodulation alone slip whole cycles of the line
    let r = mesh_ridge(&x, period, 60.0).unwrap();
    let mut theta = r.knots.clone();
    for _ in 0..2 {
        theta = demodulate(&x, &theta, period, 60.0);
    }
    let old = AngleMap::from_pulses(&integer_crossings(&theta[1..theta.len() - 1]), 1);
    let (old_rms, _) = angle_error(&old, &angle, 60.0);
    assert!(old_rms > 0.3, "{old_rms}");
}

/// A line too weak against its noise to be locked on: the two directions drift apart and the lock gives
/// way (the ridge and the demodulation passes take over).
#[test]
fn a_line_lost_in_noise_is_not_locked() {
    let (n, period) = (60_000, 250.0);
    let (clean, _) = fluctuating_mesh(n, period, 9);
    // the line at 0.05 of noise of rms 2.9 (a tenth of the helper's noise, amplified 100 times)
    let mut noise = uniform_noise(12345);
    let x: Vec<f64> = clean.iter().map(|v| 0.05 * v + 10.0 * noise()).collect();
    let r = mesh_ridge(&x, period, 60.0).unwrap();
    assert!(lock(&x, &r.knots, period, 60.0, LOCK_NATURAL_ORDER).is_none());
    assert!(lock(&x, &r.knots, period, 60.0, LOCK_WIDE_NATURAL_ORDER).is_none());
}

/// A mesh comb of 20 teeth whose first harmonics lie in the noise and whose ninth stands out (a
/// resonance), with noise of rms 1.15 times the ninth harmonic's amplitude, on a shaft whose speed swings by
/// +-1.5 % once every 8 revolutions and +-0.5 % every 23: the ninth harmonic's frequency swings by +-2.7
/// orders (over 40 bins of a frame of 13.6 revolutions) and its phase by +-3.4 cycles. Returns the
/// samples and the true angle (revolutions) at each sample.
fn wandering_comb(n: usize, period: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut noise = uniform_noise(seed);
    // harmonic k of the mesh: its amplitude (the ninth lifted, its neighbours half as much)
    let amp = |k: usize| match k {
        9 => 1.0,
        8 | 10 => 0.5,
        _ => 0.08,
    };
    let mut th = 0.0;
    let mut angle = Vec::with_capacity(n);
    let x = (0..n)
        .map(|_| {
            angle.push(th);
            let mut v = 4.0 * noise();
            for k in 1..=12 {
                let m = (20 * k) as f64;
                v += amp(k) * ((TAU * m * th).cos() + 0.3 * (TAU * (m + 1.0) * th + 0.7).cos());
            }
            th += (1.0 + 0.015 * (TAU * th / 8.0).sin() + 0.005 * (TAU * th / 23.0 + 1.0).sin()) / period;
            v
        })
        .collect();
    (x, angle)
}

/// The whole comb's ridge, followed from a nominal speed 1.2 % off, gives an angle locked to the ninth
/// harmonic; the reference is the angle the samples were made with.
#[test]
fn the_mesh_combs_ridge_follows_a_wandering_shaft_from_a_nominal_speed() {
    let (n, period) = (180_000, 1200.0);
    let (x, angle) = wandering_comb(n, period, 11);
    let true_period = n as f64 / angle[n - 1];
    let ridges = comb_ridges(&x, 1.012 * true_period, 20, 0.05).unwrap();
    let t = ridges.into_iter().find_map(|r| follow_ridge(&x, r).ok().filter(|t| t.locked)).unwrap();
    let (rms, max) = angle_error(&t.map, &angle, 180.0);
    // the tachometer-free angle is as good as the line allows: a few hundredths of a cycle of order 180
    // (a slipped cycle would put the rms near 0.3 and the largest error near 1)
    // measured 0.031 cycles rms and 0.16 at most
    assert!(rms < 0.05 && max < 0.3, "error {rms} cycles rms, {max} at most (order 180)");
    // the ninth harmonic's line alone, from the same start, is lost (it slips about a hundred cycles)
    let single = track_mesh(&x, 1.012 * true_period, 180.0).unwrap();
    assert!(angle_error(&single.map, &angle, 180.0).0 > 1.0);
}
