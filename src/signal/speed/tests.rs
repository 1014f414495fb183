//! Tests of the shaft speed: tachometer pulses and the period estimated from the signal.

use super::*;
use crate::signal::test_noise::uniform_noise;
use std::f64::consts::PI;

#[test]
fn a_known_revolution_is_not_cut_into_quarters() {
    // a shaft of 1000.37 samples whose fourth order is strong (a resonant fourth mesh harmonic, a cracked
    // gear) and whose first is weak: a quarter of the revolution repeats almost as well as the whole, so
    // the search for the shortest repetition takes the quarter; near the known revolution the window's own
    // peak is the revolution. The autocorrelation of two cosines peaks exactly at the common period, and
    // the parabolic refinement over its multiples leaves well under 0.05 samples on 40 revolutions
    let p = 1000.37;
    let x: Vec<f64> = (0..40_000)
        .map(|i| {
            let t = i as f64 / p;
            (2.0 * PI * 4.0 * t).cos()
                + 0.3 * (2.0 * PI * t + 0.5).cos()
                + 0.05 * ((i * 7919 % 1013) as f64 / 1013.0 - 0.5)
        })
        .collect();
    let mut fft = Fft::new();
    let quarter = refine_near(&mut fft, &[x.as_slice()], 1.01 * p, 0.03).expect("a period");
    assert!((quarter.period_samples / (p / 4.0) - 1.0).abs() < 0.01, "{quarter:?}");
    let whole = period_near(&mut fft, &[x.as_slice()], 1.01 * p, 0.03).expect("a period");
    assert!((whole.period_samples - p).abs() < 0.05, "{whole:?}");
    assert!(whole.mesh_lag.is_none());
    // a window between the quarter's multiples holds no peak of its own (only flanks): refused
    assert!(period_near(&mut fft, &[x.as_slice()], 0.375 * p, 0.05).is_err());
}

#[test]
fn tacho_pulses_works() {
    let x: Vec<f64> = (0..1000).map(|i| if (i as f64 / 100.3).fract() < 0.1 { 5.0 } else { 0.0 }).collect();
    let p = tacho_pulses(&x).unwrap();
    assert_eq!(p.len(), 9);
    for (k, w) in p.windows(2).enumerate() {
        assert!((w[1] - w[0] - 100.3).abs() < 1.0, "{k}");
    }
    assert!(tacho_pulses(&[1.0f64; 10]).is_err());
}

/// A comb of mesh cycles with a shaft of 14 teeth standing 0.1 above it, plain, alternating between
/// whole and half mesh cycles (the tracked line was the second harmonic: the shaft is then 28 of its
/// cycles), with ripple; and a comb with nothing above it.
#[test]
fn whole_cycle_period_finds_the_shaft_above_the_mesh_comb() {
    let ripple = |j: usize| 0.004 * ((j as f64 * 1.7).sin());
    let plain: Vec<f64> =
        (0..400).map(|j| 0.9 - 1e-4 * j as f64 + ripple(j) + if j % 14 == 0 { 0.1 } else { 0.0 }).collect();
    assert_eq!(whole_cycle_period(&plain, 8), Some(14));
    let alternating: Vec<f64> = (0..800)
        .map(|j| if j % 2 == 0 { 0.9 } else { 0.6 } + ripple(j) + if j % 28 == 0 { 0.05 } else { 0.0 })
        .collect();
    assert_eq!(whole_cycle_period(&alternating, 8), Some(28));
    let comb: Vec<f64> = (0..400).map(|j| 0.9 + ripple(j)).collect();
    assert_eq!(whole_cycle_period(&comb, 8), None);
    // a pinion of 14 and a wheel of 39 teeth both repeating, the wheel more strongly: the pinion
    let pair: Vec<f64> = (0..400)
        .map(|j| 0.8 + ripple(j) + if j % 14 == 0 { 0.05 } else { 0.0 } + if j % 39 == 0 { 0.08 } else { 0.0 })
        .collect();
    assert_eq!(whole_cycle_period(&pair, 8), Some(14));
    // three unrelated repetitions are not a gear pair
    let three: Vec<f64> = (0..400)
        .map(|j| 0.8 + ripple(j) + [14, 39, 23].iter().map(|q| if j % q == 0 { 0.05 } else { 0.0 }).sum::<f64>())
        .collect();
    assert_eq!(whole_cycle_period(&three, 8), None);
}

/// A pair whose signal repeats wholly only every five revolutions (a pattern of period 5 p, the hunting
/// period) over a weaker pattern of each revolution p and noise: the shaft is p, not 5 p, though the
/// autocorrelation peaks highest at 5 p; a signal with no revolution pattern keeps 5 p.
#[test]
fn estimate_period_takes_the_revolution_inside_a_hunting_period() {
    let (p, n) = (431.0, 100_000);
    let mut noise = uniform_noise(7);
    // orders k / 5 of the shaft (k = 1..30, phases spread by the golden angle) for the five-revolution
    // pattern, orders 1..3 for the revolution's own
    let pattern =
        |th: f64, orders: &[(f64, f64)]| orders.iter().map(|(k, a)| a * (k * th + 2.4 * k * k).sin()).sum::<f64>();
    let hunting: Vec<(f64, f64)> = (1..=30).map(|k| (k as f64, 0.35)).collect();
    let shaft = [(1.0, 1.0), (2.0, 1.0), (3.0, 1.0)];
    let make = |with_shaft: bool, noise: &mut dyn FnMut() -> f64| -> Vec<f64> {
        (0..n)
            .map(|i| {
                let th = 2.0 * PI * i as f64 / p;
                pattern(th / 5.0, &hunting) + if with_shaft { pattern(th, &shaft) } else { 0.0 } + 2.0 * noise()
            })
            .collect()
    };
    let x = make(true, &mut noise);
    let e = estimate_period(&mut Fft::new(), &[&x], 64, 4000).unwrap();
    assert!((e.period_samples / p - 1.0).abs() < 0.005, "{}", e.period_samples);
    let y = make(false, &mut noise);
    let e = estimate_period(&mut Fft::new(), &[&y], 64, 4000).unwrap();
    assert!((e.period_samples / (5.0 * p) - 1.0).abs() < 0.005, "{}", e.period_samples);
}

#[test]
fn estimate_period_finds_fractional_period() {
    let period = 123.37;
    let x: Vec<f64> = (0..40_000)
        .map(|i| {
            let th = 2.0 * PI * i as f64 / period;
            th.cos() + 0.6 * (17.0 * th).sin() + 0.3 * (18.0 * th).cos()
        })
        .collect();
    let e = estimate_period(&mut Fft::new(), &[&x], 20, 1000).unwrap();
    // refined from the peak near lag 128 p: error ~ 1 / 128 sample
    assert!((e.period_samples - period).abs() < 0.02, "{}", e.period_samples);
    assert!(e.confidence > 0.9);
}

#[test]
fn mesh_comb_finds_the_true_speed_within_the_tolerance() {
    // 23 teeth at a true period of 400 samples, the mesh's harmonics 1..3, sidebands at +-1 and +-2 shaft
    // orders a third of the mesh's, noise; a nominal 3 % off (motor slip): the comb must come back to the
    // true period within a fraction of a bin (the refinement's centre of mass: 0.1 % is a tenth of a bin)
    let true_period = 400.0;
    let mut noise = uniform_noise(12345);
    let x: Vec<f64> = (0..200_000)
        .map(|i| {
            let th = 2.0 * PI * i as f64 / true_period;
            let mut v = 0.0;
            for k in 1..=3 {
                let m = (23 * k) as f64;
                v += (m * th).cos() / k as f64;
                for j in [-2.0, -1.0, 1.0, 2.0] {
                    v += 0.3 / k as f64 * ((m + j) * th + j).cos();
                }
            }
            v + 0.5 * noise()
        })
        .collect();
    for nominal in [true_period * 1.03, true_period / 1.03, true_period] {
        let (p, snr) = mesh_comb_period(&mut Fft::new(), &x, nominal, 23, 0.05).unwrap();
        assert!((p / true_period - 1.0).abs() < 1e-3, "nominal {nominal}: found {p}");
        assert!(snr > 20.0, "{snr}");
    }
}

#[test]
fn mesh_comb_is_not_taken_by_an_impulsive_faults_sideband_family() {
    // a mesh of 14 teeth (harmonics 1..6, amplitude 1) and an impulse once per revolution that puts
    // every shaft order 1..100 at amplitude 0.05 (a cracked tooth), a true period of 333.3 samples,
    // little noise: every candidate comb f m / 14 lines up with shaft orders, and only the true one
    // with the mesh lines, 26 dB higher; nominal 3 % low and high
    let true_period = 1000.0 / 3.0;
    let mut noise = uniform_noise(99);
    let x: Vec<f64> = (0..300_000)
        .map(|i| {
            let th = 2.0 * PI * i as f64 / true_period;
            let mesh: f64 = (1..=6).map(|k| ((14 * k) as f64 * th).cos()).sum();
            let shaft: f64 =
                (1..=100).filter(|o| 14 * 6 >= *o || o % 14 != 0).map(|o| 0.05 * (o as f64 * th).cos()).sum();
            mesh + shaft + 0.01 * noise()
        })
        .collect();
    for nominal in [true_period * 1.03, true_period / 1.03] {
        let (p, db) = mesh_comb_period(&mut Fft::new(), &x, nominal, 14, 0.05).unwrap();
        assert!((p / true_period - 1.0).abs() < 1e-3, "nominal {nominal}: found {p}");
        assert!(db > 20.0, "{db}");
    }
}

/// The halves of a record repeating every P/2 points agree at the even orders of a P-point revolution and
/// hold only noise at the odd ones (coherence near 0: 256 orders of noise give a spread of about 1/16); a
/// record whose revolution is P agrees at both. The noise is about as strong as the lines together.
#[test]
fn halves_coherence_tells_a_revolution_holding_two_turns() {
    let period: usize = 512;
    let revs: usize = 64;
    let mut draw = uniform_noise(7);
    // uniform on +-0.85: variance 0.24, the six lines' together 0.27
    let noise: Vec<f64> = (0..period * revs).map(|_| 1.7 * draw()).collect();
    let line = |k: f64, t: f64, phase: f64| (2.0 * PI * k * t + phase).sin();
    let record = |orders: &[f64]| -> Vec<f64> {
        (0..period * revs)
            .map(|i| {
                let t = i as f64 / period as f64;
                orders.iter().enumerate().map(|(j, &k)| 0.3 * line(k, t, j as f64)).sum::<f64>() + noise[i]
            })
            .collect()
    };
    let mut fft = Fft::new();
    // the coherence at the orders not divisible by d and at those that are
    let halves_coherence = |fft: &mut Fft, y: &[f64], period: usize, d: usize| {
        Halves::of(fft, y, period).map(|h| (h.coherence(&|k| k % d != 0), h.coherence(&|k| k % d == 0)))
    };
    // every line at an even order: the shaft turns twice per supposed revolution
    let twice = record(&[2.0, 4.0, 10.0, 20.0, 22.0, 40.0]);
    let (odd, even) = halves_coherence(&mut fft, &twice, period, 2).unwrap();
    assert!(odd.abs() < 0.25 && even > 0.8, "two turns: odd {odd}, even {even}");
    // odd orders too: a true revolution
    let once = record(&[1.0, 2.0, 9.0, 10.0, 11.0, 20.0]);
    let (odd, even) = halves_coherence(&mut fft, &once, period, 2).unwrap();
    assert!(odd > 0.8 && even > 0.8, "one turn: odd {odd}, even {even}");
    // and a third: every line at a multiple of 3
    let thrice = record(&[3.0, 9.0, 30.0, 33.0]);
    let (other, third) = halves_coherence(&mut fft, &thrice, period, 3).unwrap();
    assert!(other.abs() < 0.25 && third > 0.8, "three turns: {other}, {third}");
    assert!(halves_coherence(&mut fft, &twice[..7 * period], period, 2).is_none());
}
