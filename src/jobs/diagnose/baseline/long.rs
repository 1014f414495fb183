//! The whole record's average against the baseline files' own: FM4 and M6A of the difference signal of
//! the average over every revolution, where a local fault stands out of noise that an average of one
//! block (8 revolutions) still holds.
//!
//! Noise in the difference signal pulls FM4 towards 3 and M6A towards 15 (a normal signal's), so a block's
//! average dilutes an impulse that the whole record's shows: on the third generator's 25/50 machine (96
//! kHz, noise at 0.62 of the signal) a spalled wheel read FM4 3.6 as the median of its 29 blocks, 2.8 block
//! spreads over the baseline's blocks, and 5.95 over its 235 revolutions, where the healthy files read
//! 2.88 and 2.96. The recording's value is scored against the mean of the files' (natural logarithms; at
//! least a normal signal's, [`NORMAL`]), in the spread of one block's value, widened to the range of the
//! files' values when they differ more and to what healthy siblings differ by ([`LEAST_SPREAD`]).

use super::*;

/// The impulse measures compared over whole records.
pub(super) const LONG_INDICATORS: [Indicator; 2] = [Indicator::Fm4, Indicator::M6a];

/// A normal signal's FM4 and M6A (the fourth and sixth standardised moments of a Gaussian: 3 and 15).
/// Noise, and an average smeared by a dropout or a splice, pull a difference signal towards them, so only
/// what stands over the larger of the files' values and these counts: healthy gears whose own FM4 lies
/// under 3 (the fourth set's 23/59 pinion at 2.2) otherwise read a cut of half a revolution from the record
/// as 6 spreads "more impulsive" (a helper's review, 5 machines).
const NORMAL: [(Indicator, f64); 2] = [(Indicator::Fm4, 3.0), (Indicator::M6a, 15.0)];

/// Least spread (ln) of the whole-record scores: the largest difference between two healthy siblings'
/// whole-record values over the five Python sets (466 pairs of gear averages, every speed source: FM4 0.31,
/// M6A 0.95 in ln, the hold-out's 21/64 wheel) over 3, so that no healthy pair seen lies a suspect limit
/// apart (one block's spread alone let that wheel's healthy s1 read M6A 6.7 spreads over s2 and s3).
const LEAST_SPREAD: [(Indicator, f64); 2] = [(Indicator::Fm4, 0.31 / 3.0), (Indicator::M6a, 0.95 / 3.0)];

/// Largest ratio between a recording's revolutions and the baseline files' (median) for whole-record
/// averages to compare: an average over many more revolutions holds less noise, and a healthy gear's own
/// pattern then stands further from a normal signal's FM4 and M6A than in the files' shorter averages.
pub(super) const LONG_REVOLUTIONS_RATIO: f64 = 1.5;

/// One baseline file's whole-record average of a gear.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub(super) struct LongAverage {
    /// Revolutions averaged.
    revolutions: usize,
    /// FM4 of its difference signal.
    fm4: f64,
    /// M6A of its difference signal.
    m6a: f64,
}

impl LongAverage {
    /// The whole-record average of `g` (its indicators are those of the average over every revolution).
    pub(super) fn of(g: &GearIndicators) -> Self {
        let get = |k| g.indicators.get(&k).copied().unwrap_or(f64::NAN);
        Self { revolutions: g.revolutions, fm4: get(Indicator::Fm4), m6a: get(Indicator::M6a) }
    }

    fn value(&self, k: Indicator) -> f64 {
        if k == Indicator::Fm4 { self.fm4 } else { self.m6a }
    }
}

/// The whole-record scores of `g` against `r`'s files, when both averages are long enough alike
/// ([`LONG_REVOLUTIONS_RATIO`]) and every value is a positive number.
pub(super) fn long_scores(g: &GearIndicators, r: &GearReference) -> Vec<LongScore> {
    let mut revs: Vec<f64> = r.long_files.iter().map(|f| f.revolutions as f64).collect();
    if revs.is_empty() || g.revolutions == 0 {
        return Vec::new();
    }
    let ratio = g.revolutions as f64 / median(&mut revs);
    if !(1.0 / LONG_REVOLUTIONS_RATIO..=LONG_REVOLUTIONS_RATIO).contains(&ratio) {
        return Vec::new();
    }
    let own = LongAverage::of(g);
    LONG_INDICATORS
        .into_iter()
        .filter_map(|k| {
            let stat = r.stats.get(&k).filter(|s| s.scale == Scale::Log)?;
            let v = own.value(k);
            let files: Vec<f64> = r.long_files.iter().map(|f| f.value(k)).collect();
            if !(v > 0.0 && files.iter().all(|&f| f > 0.0)) {
                return None;
            }
            let logs: Vec<f64> = files.iter().map(|f| f.ln()).collect();
            let of = |table: [(Indicator, f64); 2]| table.iter().find(|t| t.0 == k).map_or(0.0, |t| t.1);
            let centre = (logs.iter().sum::<f64>() / logs.len() as f64).max(of(NORMAL).ln());
            let range = logs.iter().copied().fold(f64::NEG_INFINITY, f64::max)
                - logs.iter().copied().fold(f64::INFINITY, f64::min);
            let spread = stat.spread.max(range).max(of(LEAST_SPREAD));
            let (suspect, faulty) = limits(stat.count);
            let (suspect_at, faulty_at) = if files.len() >= 2 { (suspect, faulty) } else { (faulty, f64::INFINITY) };
            let spreads = (v.ln() - centre) / spread;
            Some(LongScore {
                gear: g.gear,
                channel: g.channel,
                indicator: k,
                value: v,
                revolutions: g.revolutions,
                files,
                spreads,
                suspect_at,
                faulty_at,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pinion average of `revolutions` revolutions whose whole-record FM4 is `fm4` (M6A 15, a normal
    /// signal's).
    fn gear(revolutions: usize, fm4: f64) -> GearIndicators {
        let indicators = [(Indicator::Fm4, fm4), (Indicator::M6a, 15.0)].into_iter().collect();
        GearIndicators { revolutions, indicators, ..super::super::fit::tests::pinion(20, Vec::new()) }
    }

    /// A reference whose 60 blocks read FM4 and M6A with a spread of 0.1 in ln (values e^(c +- 0.1 k)),
    /// and whose files' whole records read `fm4` each over 200 revolutions.
    fn reference(fm4: &[f64]) -> GearReference {
        let mut r = super::super::fit::tests::reference(&[1.0, 1.0]).gears.into_values().next().unwrap();
        for (k, c) in [(Indicator::Fm4, 3.0f64), (Indicator::M6a, 15.0)] {
            let blocks: Vec<f64> = (0..60).map(|i| (c.ln() + 0.1 * ((i % 3) as f64 - 1.0)).exp()).collect();
            r.stats.insert(k, Stat::of(&blocks, Scale::Log));
        }
        r.long_files = fm4.iter().map(|&f| LongAverage { revolutions: 200, fm4: f, m6a: 15.0 }).collect();
        r
    }

    /// An impulse that stands out of the whole record's average is scored in a block's spread over the
    /// files' mean (the spread of these blocks' ln values is 0.1 x 1.4826 x MAD = 0.148, over the files'
    /// range ln(3.1/2.9) = 0.067 and FM4's least spread 0.103; the files' mean 2.998 is raised to a normal
    /// signal's 3): FM4 6 reads ln 2 / 0.148 = 4.7 spreads; M6A, at its normal 15, reads 0; a healthy 3.0
    /// reads 0; an average of three times the revolutions is not compared; one file cannot make a gear
    /// faulty and makes it suspect only from the block scores' faulty limit; files that differ more than
    /// their blocks widen the spread to their range; files under a normal signal's FM4 (a smooth healthy
    /// gear) leave a rise up to 3 unscored, which noise or a smeared average gives.
    #[test]
    fn the_whole_record_is_scored_against_the_files_whole_records() {
        let r = reference(&[2.9, 3.1]);
        let spread = 1.4826 * 0.1;
        let s = long_scores(&gear(200, 6.0), &r);
        let fm4 = s.iter().find(|l| l.indicator == Indicator::Fm4).expect("FM4 scored");
        assert!((fm4.spreads - 2.0f64.ln() / spread).abs() < 1e-9, "{fm4:?}");
        let (suspect, faulty) = limits(60);
        assert_eq!((fm4.suspect_at, fm4.faulty_at), (suspect, faulty));
        let m6a = s.iter().find(|l| l.indicator == Indicator::M6a).expect("M6A scored");
        assert!(m6a.spreads.abs() < 1e-9, "{m6a:?}");
        let healthy = long_scores(&gear(200, 3.0), &r);
        assert!(healthy.iter().all(|l| l.spreads.abs() < 0.1), "{healthy:?}");
        assert!(long_scores(&gear(600, 6.0), &r).is_empty(), "three times the revolutions");
        assert!(!long_scores(&gear(280, 6.0), &r).is_empty(), "1.4 times the revolutions");
        let one = long_scores(&gear(200, 6.0), &reference(&[3.0]));
        assert!(one.iter().all(|l| l.suspect_at == faulty && l.faulty_at.is_infinite()), "{one:?}");
        // files that differ more than their blocks widen the spread to their range
        let apart = long_scores(&gear(200, 6.0), &reference(&[2.0, 4.0]));
        let fm4 = apart.iter().find(|l| l.indicator == Indicator::Fm4).unwrap();
        assert!((fm4.spreads - 1.0).abs() < 1e-9, "{fm4:?}");
        let smooth = long_scores(&gear(200, 2.97), &reference(&[2.2, 2.3]));
        assert!(smooth.iter().all(|l| l.spreads <= 0.0), "{smooth:?}");
    }
}
