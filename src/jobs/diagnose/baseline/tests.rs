//! Tests of the statistical baseline: the robust spread of Gaussian values, the Student-t quantiles
//! against the published table, the spread's floor.

use super::local::SidebandNoise;
use super::*;

#[test]
fn robust_spread_of_gaussian_like_values() {
    // the 1.4826 MAD of a symmetric sample equals its standard deviation for a Gaussian; for the
    // evenly spaced quantiles of N(10, 1) at p = (i + 0.5) / 201 it is 1 within 2 %
    let q: Vec<f64> = (0..201).map(|i| 10.0 + acklam((i as f64 + 0.5) / 201.0)).collect();
    let s = Stat::of(&q, Scale::Linear);
    assert!((s.centre - 10.0).abs() < 1e-9);
    assert!((s.spread - 1.0).abs() < 0.02, "{}", s.spread);
}

/// Acklam's inverse normal CDF (relative error below 1.2e-9).
fn acklam(p: f64) -> f64 {
    let a = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.38357751867269e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    let b =
        [-5.447609879822406e1, 1.615858368580409e2, -1.556989798598866e2, 6.680131188771972e1, -1.328068155288572e1];
    let c = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    let d = [7.784695709041462e-3, 3.224671290700398e-1, 2.445134137142996, 3.754408661907416];
    let pl = 0.02425;
    if p < pl {
        let q = (-2.0 * p.ln()).sqrt();
        (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5])
            / ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0)
    } else if p <= 1.0 - pl {
        let q = p - 0.5;
        let r = q * q;
        (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q
            / (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0)
    } else {
        -acklam(1.0 - p)
    }
}

#[test]
fn student_t_matches_the_published_table() {
    // t quantiles from standard tables (e.g. NIST/SEMATECH e-Handbook 1.3.6.7.2): one-sided 0.999
    for (nu, t) in [(4.0, 7.173), (10.0, 4.144), (30.0, 3.385)] {
        let got = student_t(SUSPECT_Z, nu);
        // the expansion is asymptotic in 1 / nu: within 1 % at nu = 4, closer beyond
        assert!((got / t - 1.0).abs() < 0.01, "nu {nu}: {got} vs {t}");
    }
    assert!((student_t(SUSPECT_Z, 1e9) - SUSPECT_Z).abs() < 1e-6);
}

#[test]
fn spread_has_a_floor() {
    let s = Stat::of(&[2.0; 9], Scale::Linear);
    assert!((s.spread - 0.1).abs() < 1e-12);
    // on the log scale the floor is ln 1.05, and 2.1 against 2.0 is one spread
    let s = Stat::of(&[2.0; 9], Scale::Log);
    assert!(((2.1f64.ln() - s.centre) / s.spread - 1.0).abs() < 1e-12);
}

/// Nine healthy files, eight alike and one whose indicator sits ten block spreads higher (a load the
/// others were not recorded at): its own median is a healthy file's, so a recording like it must stay
/// under the suspect limit, which then lies the median's own scatter above that file's median; a
/// recording beyond it is still flagged, and blocks pooled from one file are scored on their own spread.
#[test]
fn files_that_differ_widen_the_spread_to_the_highest_file() {
    let file = |centre: f64| -> Vec<f64> { (0..30).map(|i| centre + 0.1 * acklam((i as f64 + 0.5) / 30.0)).collect() };
    let mut files: Vec<Vec<f64>> = (0..8).map(|_| file(1.0)).collect();
    files.push(file(2.0));
    let pooled: Vec<f64> = files.concat();
    let stat = Stat::of(&pooled, Scale::Linear).with_files(&files);
    let (suspect_at, _) = limits(stat.count);
    // without the widening a recording like the ninth file would stand some ten spreads up
    assert!((2.0 - stat.centre) / stat.spread > 2.0 * suspect_at);
    let (spread, widened) = stat.scoring_spread(30, suspect_at);
    assert!(widened);
    // the suspect limit: the highest file's median (2.0, the quantiles are symmetric) plus suspect_at times
    // the scatter of a median of 30 values, 1.2533 / sqrt(30) of the block spread
    let limit = stat.centre + suspect_at * spread;
    let expected = 2.0 + suspect_at * MEDIAN_SCATTER * stat.spread / 30f64.sqrt();
    assert!((limit - expected).abs() < 1e-9, "{limit} against {expected}");
    assert!((2.0 - stat.centre) / spread < suspect_at, "a recording like a healthy file is kept");
    assert!((2.3 - stat.centre) / spread > suspect_at, "three block spreads beyond every file is flagged");
    // one file: no file figure, the blocks' spread
    let one = Stat::of(&files[8], Scale::Linear).with_files(&files[8..]);
    assert_eq!(one.scoring_spread(30, suspect_at), (one.spread, false));
}

/// A single file keeps an allowance for a change of load: its suspect limit, in spreads of its blocks,
/// lies the allowance plus the median's own scatter above its median, so a recording whose FM0 is 1.35
/// times the file's (the rig's 30 % file against its 40 % file: 5.3 block spreads) is kept and one 1.6
/// times it is flagged; the spread itself is the blocks' (a gear is still told from its mate by how far
/// it stands); two files, or no allowance, leave the limits as they were.
#[test]
fn one_file_keeps_an_allowance_for_a_change_of_load() {
    let blocks: Vec<f64> = (0..30).map(|i| (3.844f64.ln() + 0.057 * acklam((i as f64 + 0.5) / 30.0)).exp()).collect();
    let a = one_file::allowance(Indicator::Fm0);
    let stat = Stat::of(&blocks, Scale::Log).with_files(std::slice::from_ref(&blocks)).with_one_file(1, a);
    let (suspect_at, faulty_at) = limits(stat.count);
    let (spread, widened) = stat.scoring_spread(30, suspect_at);
    assert_eq!((spread, widened), (stat.spread, false));
    let (suspect, faulty) = stat.load_limits(spread, 30, suspect_at, faulty_at);
    let of_median = MEDIAN_SCATTER * stat.spread / 30f64.sqrt();
    assert!((suspect * spread - (a + suspect_at * of_median)).abs() < 1e-12, "{suspect}");
    assert!((faulty * spread - (a + faulty_at * of_median)).abs() < 1e-12, "{faulty}");
    let spreads = |ratio: f64| ratio.ln() / spread;
    assert!(spreads(1.35) > suspect_at, "over the blocks' own limit: {}", spreads(1.35));
    assert!(spreads(1.35) < suspect, "a neighbouring load's FM0 is kept: {} under {suspect}", spreads(1.35));
    assert!(spreads(1.6) > suspect, "beyond a load's move is flagged: {} over {suspect}", spreads(1.6));
    let two = Stat::of(&blocks, Scale::Log).with_one_file(2, a);
    assert_eq!(two.load_limits(two.spread, 30, suspect_at, faulty_at), (suspect_at, faulty_at));
    let none = Stat::of(&blocks, Scale::Log).with_one_file(1, 0.0);
    assert_eq!(none.load_limits(none.spread, 30, suspect_at, faulty_at), (suspect_at, faulty_at));
}

/// The sideband growth's limit: three times what the baseline's files show among themselves but at least 8
/// (noise-level sidebands grow by several times their energy between healthy recordings), or 4.5 times it
/// but at least 0.25 where that is lower (real sideband lines that the files reproduce closely); one file
/// shows nothing among itself and keeps the first path only.
#[test]
fn the_sideband_limit_takes_the_lower_path() {
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
    assert!(close(sidebands_limit(0.02), 0.25), "least growth of the steep path");
    assert!(close(sidebands_limit(0.1), 0.45), "4.5 x 0.1");
    assert!(close(sidebands_limit(2.0), 8.0), "4.5 x 2 = 9 is over the first path's floor of 8");
    assert!(close(sidebands_limit(5.0), 15.0), "3 x 5 is lower than 4.5 x 5");
    assert!(close(sidebands_limit(f64::NAN), SIDEBAND_MIN), "one file: the first path alone");
}

/// The growth that noise alone gives a comparison of two means of noisy blocks is what their scatter
/// predicts, and a sideband added to one stands beyond it.
#[test]
fn noise_alone_grows_the_sidebands_by_what_the_scatter_predicts() {
    use crate::signal::tsa_change::tests::noisy_blocks;
    // 300 trials of a mean of 8 blocks against a mean of 16 (noise 0.2 on a pattern of unit lines): the
    // growth over its prediction averages 1 (each trial's ratio is a sum of 24 noise terms, relative
    // deviation about 0.3, so the mean of 300 is within 0.02 of its expectation; 0.08 is 4 of them)
    let (mut sum, trials) = (0.0, 300);
    for t in 0..trials {
        let (xb, rb) = (noisy_blocks(8, 60, 0.2, 2 * t + 1), noisy_blocks(16, 60, 0.2, 2 * t + 2));
        let mean = |b: &[OrderSpectrum]| tsa_change::mean(&slices(b));
        let (x, r) = (mean(&xb), mean(&rb));
        let c = tsa_change::sideband_change(&x, &r, 10).expect("a reference");
        let (sx, sr) = (tsa_change::sideband_scatter(&xb, 10).unwrap(), tsa_change::sideband_scatter(&rb, 10).unwrap());
        let n = SidebandNoise { x: sx.energy / 8.0, r: sr.energy / 16.0 };
        sum += (c.change / c.own) / n.growth(c);
    }
    let ratio = sum / trials as f64;
    assert!((ratio - 1.0).abs() < 0.08, "growth over prediction {ratio}");
    // one sideband (order 11) raised by 0.5 in the recording's blocks: what stands beyond the noise is its
    // energy 0.25 over the reference's sideband energy, within the noise's own scatter (the noise's
    // expected growth is about 0.02 of that energy here; 20 % covers its spread)
    let mut xb = noisy_blocks(8, 60, 0.2, 1001);
    for b in &mut xb {
        b[11].0 += 0.5;
    }
    let rb = noisy_blocks(16, 60, 0.2, 1002);
    let (x, r) = (tsa_change::mean(&slices(&xb)), tsa_change::mean(&slices(&rb)));
    let c = tsa_change::sideband_change(&x, &r, 10).expect("a reference");
    let n = SidebandNoise {
        x: tsa_change::sideband_scatter(&xb, 10).unwrap().energy / 8.0,
        r: tsa_change::sideband_scatter(&rb, 10).unwrap().energy / 16.0,
    };
    let own: f64 =
        [1, 9, 11, 19, 21, 29, 31, 39, 41, 49, 51, 59].iter().map(|&k| r[k].0.powi(2) + r[k].1.powi(2)).sum();
    let expected = 0.25 / (c.scale * c.scale * own);
    assert!((n.beyond(c) / expected - 1.0).abs() < 0.2, "{} against {expected}", n.beyond(c));
}

#[test]
fn a_noisier_recording_reads_its_pattern_at_the_baseline_noise() {
    use crate::signal::tsa_change::tests::noisy_blocks;
    // a baseline file of 16 blocks at noise 0.1 against a reference of 32 blocks (the other files), and
    // a recording of 16 blocks of the same gear at three times the noise (its mate's lines, which do not
    // repeat on this gear's revolution): the gear's teeth are the same, so its pattern change read at the
    // baseline's noise must be the file's, while the plain figure holds 9 times the file's noise (6.3 times
    // the file's figure, which holds the reference's noise too). Averaged over 100 trials (each figure a
    // sum of 54 noise terms, relative deviation about 0.2: the mean of 100 is within 0.02 of its
    // expectation). The read figure is the plain one less two noise estimates (the recording's, 9 times the
    // file's, and the file's put back), each through its own fit of every band's scale: 25 % of the file's
    // figure is 4 % of what was taken out (16 % measured with these seeds)
    let mean = |b: &[OrderSpectrum]| tsa_change::mean(&slices(b));
    let (mut read, mut file, mut plain) = (0.0, 0.0, 0.0);
    for t in 0..100 {
        let r = mean(&noisy_blocks(32, 60, 0.1, 3 * t + 1));
        let fb = noisy_blocks(16, 60, 0.1, 3 * t + 2);
        let xb = noisy_blocks(16, 60, 0.3, 3 * t + 3);
        let f = tsa_change::pattern_parts(&mean(&fb), &r, 10).expect("a reference");
        let x = tsa_change::pattern_parts(&mean(&xb), &r, 10).expect("a reference");
        let base = tsa_change::pattern_scatter(&fb, 10).unwrap().of_mean() / f.own;
        file += f.change / f.own;
        plain += x.change / x.own;
        read += local::at_baseline_noise(x, tsa_change::pattern_scatter(&xb, 10), &[base]);
    }
    let (read, file, plain) = (read / 100.0, file / 100.0, plain / 100.0);
    assert!((read / file - 1.0).abs() < 0.25, "read at the baseline's noise {read} against the file's {file}");
    assert!(plain > 4.0 * file, "plain {plain} against the file's {file}");
    // without the baseline's noise (a profile written before it) the figure is the plain one
    let x = tsa_change::pattern_parts(&mean(&noisy_blocks(16, 60, 0.3, 7)), &mean(&noisy_blocks(32, 60, 0.1, 8)), 10);
    let x = x.expect("a reference");
    assert_eq!(
        local::at_baseline_noise(x, tsa_change::pattern_scatter(&noisy_blocks(16, 60, 0.3, 7), 10), &[]),
        x.change / x.own
    );
}
