//! Tests of the comparison of a gear's average with a reference: alignment, local change, sideband growth,
//! block scatter, pattern change and own share, against closed forms and placed lines.

use super::*;
use std::f64::consts::PI;

/// A revolution of `l` points holding a few sidebands of a 17-tooth gear's manufacturing pattern.
fn pattern(l: usize, lag: f64) -> Vec<f64> {
    (0..l)
        .map(|i| {
            let t = i as f64 / l as f64 - lag;
            (2.0 * PI * 16.0 * t).sin()
                + 0.7 * (2.0 * PI * 18.0 * t + 1.0).cos()
                + 0.4 * (2.0 * PI * 35.0 * t).sin()
                + 0.3 * (2.0 * PI * 5.0 * t + 0.4).cos()
        })
        .collect()
}

#[test]
fn a_lag_is_found_to_a_small_fraction_of_a_point() {
    // the same band-limited pattern delayed by 0.3137 rev (not on any grid point): the lag is recovered
    // to 1e-9 rev (Newton on the exact correlation of a band-limited signal; rounding limits it)
    let mut fft = Fft::new();
    let r = order_spectrum(&mut fft, &pattern(512, 0.0), 64);
    let x = order_spectrum(&mut fft, &pattern(512, 0.3137), 64);
    let a = align(&mut fft, &x, &r);
    assert!((a.shift - 0.3137).abs() < 1e-9, "{a:?}");
    assert!((a.correlation - 1.0).abs() < 1e-9, "{a:?}");
    // advanced by the lag, the difference to the reference vanishes
    let back = advanced(&x, a.shift);
    let err: f64 = back.iter().zip(&r).map(|(p, q)| (p.0 - q.0).hypot(p.1 - q.1)).fold(0.0, f64::max);
    assert!(err < 1e-9, "{err}");
}

#[test]
fn a_local_change_is_found_on_its_tooth() {
    // the pattern plus a short burst over tooth 7 of 17 (angles 6/17..7/17) against the pattern scaled by
    // 1.1 (a change of load): the burst's pitch holds several times the median's energy, found on tooth 7
    let mut fft = Fft::new();
    let l = 1024;
    let r = order_spectrum(&mut fft, &pattern(l, 0.0), 200);
    // broadband noise over every order to 200 (fixed pseudo-random phases), 0.2 % of the pattern's lines each
    let noise = |i: usize| -> f64 {
        (1..200).map(|k| 0.002 * (2.0 * PI * k as f64 * i as f64 / l as f64 + (k * k % 97) as f64).cos()).sum()
    };
    let mut y: Vec<f64> = pattern(l, 0.0).iter().enumerate().map(|(i, v)| 1.1 * v + noise(i)).collect();
    let (a, b) = (6 * l / 17, 7 * l / 17);
    for (i, v) in y.iter_mut().enumerate().take(b).skip(a) {
        let t = (i - a) as f64 / (b - a) as f64;
        *v += 0.2 * (PI * t).sin().powi(2) * (2.0 * PI * 120.0 * i as f64 / l as f64).sin();
    }
    let x = order_spectrum(&mut fft, &y, 200);
    let c = concentration(&mut fft, &x, &r, 17).expect("a reference");
    assert_eq!(c.tooth, 7, "{c:?}");
    // the burst's mean power (0.2^2 x 3/16) against the noise's (199 x 0.002^2 / 2) per point: about 19x
    assert!(c.ratio > 10.0, "{c:?}");
    // the scaled pattern and the noise alone: least squares takes the load change out and no pitch stands
    // out (broadband noise over 17 pitches of about 23 degrees of freedom each: the largest holds under
    // twice the median's energy; 3 leaves a margin)
    let plain: Vec<f64> = pattern(l, 0.0).iter().enumerate().map(|(i, v)| 1.1 * v + noise(i)).collect();
    let x = order_spectrum(&mut fft, &plain, 200);
    let c = concentration(&mut fft, &x, &r, 17).expect("a reference");
    assert!(c.ratio < 3.0, "{c:?}");
}

#[test]
fn a_once_per_revolution_change_grows_the_first_sidebands() {
    // the pattern's sidebands of a 17-tooth gear's mesh harmonics (orders 16, 18, 35) against the same
    // pattern plus a mesh carrier (order 17) modulated once per revolution, which adds 0.5 cos at orders
    // 16 and 18: growth 0.5 / 1.65 = 0.30 before the least-squares scale (1.1087) takes part of the
    // order-18 change; numpy's rfft of the same two signals, by the same formula, gives 0.23587
    let mut fft = Fft::new();
    let l = 512;
    let base = pattern(l, 0.0);
    let r = order_spectrum(&mut fft, &base, 60);
    let modulated: Vec<f64> = base
        .iter()
        .enumerate()
        .map(|(i, v)| v + (2.0 * PI * 17.0 * i as f64 / l as f64).cos() * (2.0 * PI * i as f64 / l as f64).cos())
        .collect();
    let x = order_spectrum(&mut fft, &modulated, 60);
    let g = sideband_growth(&x, &r, 17).expect("a reference");
    // rounding only separates the two computations
    assert!((g - 0.235_873_79).abs() < 1e-6, "{g}");
    // the same pattern scaled (a load change) does not grow them
    let scaled: Vec<f64> = base.iter().map(|v| 1.2 * v).collect();
    let x = order_spectrum(&mut fft, &scaled, 60);
    assert!(sideband_growth(&x, &r, 17).expect("a reference") < 1e-20);
}

/// The order spectrum of a 17-tooth gear's average: mesh harmonics 1..=3 (orders 17, 34, 51), each
/// multiplied by the complex carrier `carrier[k]`, with the sidebands of `pattern` (a per-order modulation,
/// orders 1..=8 each side) around each, as an amplitude- and phase-modulated mesh puts them.
fn modulated(carrier: [(f64, f64); 3], pattern: &[(f64, f64)]) -> OrderSpectrum {
    let z = 17;
    let mut x = vec![(0.0, 0.0); 4 * z];
    for (k, c) in carrier.iter().enumerate() {
        let h = (k + 1) * z;
        x[h] = *c;
        // the modulation a(theta) = sum_j A_j exp(i j theta) times the carrier C exp(i h theta): order
        // h + j holds C A_j (here A_j = pattern[j - 1] above the harmonic, its re and im swapped below)
        for (j, m) in pattern.iter().enumerate() {
            let times = |a: (f64, f64)| (c.0 * a.0 - c.1 * a.1, c.0 * a.1 + c.1 * a.0);
            x[h + j + 1] = times(*m);
            x[h - j - 1] = times((m.1, m.0));
        }
    }
    x
}

#[test]
fn a_carrier_change_is_not_a_pattern_change() {
    // the same gear's pattern under other carriers (another mesh: each harmonic's amplitude and phase
    // changed differently) leaves nothing; a pattern changed at one order by a known amount leaves that
    // amount's energy share, to rounding
    let pattern: Vec<(f64, f64)> = (1..=8).map(|j| (0.3 / j as f64, 0.1 * (j as f64).sin())).collect();
    let r = modulated([(1.0, 0.0), (0.5, 0.2), (0.2, -0.1)], &pattern);
    let x = modulated([(0.4, 0.9), (-0.7, 0.1), (0.05, 0.3)], &pattern);
    let g = pattern_change(&x, &r, 17).expect("a reference");
    assert!(g < 1e-24, "{g}");
    // the global scale of [`sideband_growth`] does not take the per-harmonic change out
    assert!(sideband_growth(&x, &r, 17).expect("a reference") > 0.1);
    // a pattern change at the second sideband, 0.05 added to its modulation, with the carriers unchanged:
    // the band's least-squares scale absorbs a little of it, so the share lies just under the plain one
    let mut changed = pattern.clone();
    changed[1].0 += 0.05;
    let x = modulated([(1.0, 0.0), (0.5, 0.2), (0.2, -0.1)], &changed);
    let g = pattern_change(&x, &r, 17).expect("a reference");
    let plain = 2.0 * 0.05f64.powi(2) / (2.0 * pattern.iter().map(|m| m.0 * m.0 + m.1 * m.1).sum::<f64>());
    assert!(g < plain && g > 0.8 * plain, "{g} against {plain}");
}

#[test]
fn turning_phasors_match_direct_evaluation() {
    // against sin_cos of each order's own angle, whose argument 2 pi s k is itself rounded by up to
    // 2 pi k eps (6e-12 at order 4096): re-anchoring every 256 orders keeps the recurrence's own drift
    // (about eps per step) well under that, so 2e-11 holds both
    for s in [0.3137, 1e-6, 0.999_999, 0.5] {
        for (k, (c, sn)) in phasors(s).take(4097).enumerate() {
            let (b, a) = (2.0 * PI * s * k as f64).sin_cos();
            assert!((c - a).abs() < 2e-11 && (sn - b).abs() < 2e-11, "s {s} order {k}");
        }
    }
}

#[test]
fn nothing_to_compare_is_none() {
    let mut fft = Fft::new();
    let x = order_spectrum(&mut fft, &pattern(256, 0.0), 40);
    assert!(concentration(&mut fft, &x, &vec![(0.0, 0.0); 41], 17).is_none());
    assert!(concentration(&mut fft, &x, &x, 1).is_none());
    let a = align(&mut fft, &x, &[]);
    assert_eq!(a.correlation, 0.0);
}

/// A fixed pattern of `len` orders plus, per block, complex noise uniform in +-a/2 in each part (variance
/// a^2 / 12 per part, a^2 / 6 per complex order).
pub(crate) fn noisy_blocks(n: usize, len: usize, a: f64, seed: u64) -> Vec<OrderSpectrum> {
    let mut u = crate::signal::test_noise::uniform_noise(seed);
    let pattern = |k: usize| ((k as f64 * 0.37).sin(), (k as f64 * 1.3).cos());
    (0..n).map(|_| (0..len).map(|k| (pattern(k).0 + a * u(), pattern(k).1 + a * u())).collect()).collect()
}

#[test]
fn block_scatter_is_the_noise_at_the_sidebands() {
    // z = 10 below order 60: the 12 orders 1, 9, 11, ..., 59 carry sidebands; the expected scatter is
    // 12 a^2 / 6. From 40 blocks the estimate of a sum of 24 equal variances with 39 degrees of freedom
    // each has a relative standard deviation of sqrt(2 / (24 x 39)) = 4.6 %: 15 % is over 3 of them
    let a = 0.2;
    let s = sideband_scatter(&noisy_blocks(40, 60, a, 7), 10).expect("blocks");
    let expected = 12.0 * a * a / 6.0;
    assert_eq!(s.blocks, 40);
    assert!((s.energy / expected - 1.0).abs() < 0.15, "{} against {expected}", s.energy);
    // too few blocks or teeth: nothing to say
    assert!(sideband_scatter(&noisy_blocks(1, 60, a, 7), 10).is_none());
    assert!(sideband_scatter(&noisy_blocks(5, 60, a, 7), 2).is_none());
}

#[test]
fn pattern_scatter_is_the_noise_and_not_the_carrier_wander() {
    // z = 10 below order 60: 54 orders are not mesh harmonics (60 less 0, 10, ..., 50). Each block is
    // the pattern scaled by its own complex factor in every band (a carrier wandering 20 % in amplitude
    // and 0.3 rad in phase from block to block) plus uniform noise of a^2 / 6 per complex order. The
    // band's scale taken out (two real parameters of 2 x 9 or more per band: about 11 % fewer degrees
    // of freedom than the plain sum), the scatter is the noise's 54 a^2 / 6 to within 20 % (a sum of
    // 54 variances over 39 degrees of freedom each: 3 % standard deviation; 11 % for the fit), while
    // the plain scatter of the same blocks holds the carrier's wander many times over.
    let a = 0.05;
    let mut blocks = noisy_blocks(40, 60, a, 11);
    for (b, block) in blocks.iter_mut().enumerate() {
        for (o, v) in block.iter_mut().enumerate() {
            let band = (o + 4) / 10; // the bands of `pattern_parts`: (k - 1/2) z < o <= (k + 1/2) z
            let (g, ph) = (1.0 + 0.2 * ((b * 7 + band * 3) as f64).sin(), 0.3 * ((b * 5 + band) as f64).cos());
            let (c, s) = (g * ph.cos(), g * ph.sin());
            *v = (c * v.0 - s * v.1, c * v.1 + s * v.0);
        }
    }
    let expected = 54.0 * a * a / 6.0;
    let s = pattern_scatter(&blocks, 10).expect("blocks");
    assert!((s.energy / expected - 1.0).abs() < 0.2, "{} against {expected}", s.energy);
    let plain = scatter_at(&blocks, (1..60).filter(|o| o % 10 != 0)).expect("blocks");
    assert!(plain.energy > 10.0 * expected, "{} against {expected}", plain.energy);
    assert!(pattern_scatter(&blocks[..1], 10).is_none());
    assert!(pattern_scatter(&blocks, 2).is_none());
}

#[test]
fn own_share_tells_a_change_of_the_gear_from_one_repeating_n_times() {
    // the same healthy pattern on both sides; an impulse added once per revolution (its orders all
    // equal) or three times per revolution (only every third order): shares of 1 and 0 by construction
    let orders = 300usize;
    let pattern: OrderSpectrum =
        (0..=orders).map(|k| if k == 0 { (0.0, 0.0) } else { ((k as f64).sin(), (k as f64 * 0.7).cos()) }).collect();
    let with = |every: usize| -> OrderSpectrum {
        pattern.iter().enumerate().map(|(k, c)| if k > 0 && k % every == 0 { (c.0 + 0.5, c.1) } else { *c }).collect()
    };
    let once = own_share(&with(1), &pattern, 3).unwrap();
    let thrice = own_share(&with(3), &pattern, 3).unwrap();
    // the least-squares scale takes a little of the added change into the pattern: within 5 %
    assert!((once - 1.0).abs() < 0.05, "own change read as {once}");
    assert!(thrice < 0.05, "a change every third order read as {thrice}");
    assert!(own_share(&with(1), &pattern, 1).is_none());
}
