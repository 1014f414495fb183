//! A recording's scores against the reference: each deciding indicator's median over its blocks
//! ([`score_one`]) and the whole record's impulse measures ([`score_long`]).

use super::*;

/// Scores every deciding indicator of one gear and channel (empty when the reference lacks it).
pub fn score_one(g: &GearIndicators, r: &Reference) -> Vec<Score> {
    r.gears.get(&(g.gear.baseline_key(), g.channel)).map(|gr| score_gear(g, gr)).unwrap_or_default()
}

impl GearReference {
    /// The blocks of `g` whose averages reach every order of this reference's log spectrum (a block of a
    /// shorter average cannot be compared), and the number of orders compared plus one (order 0).
    pub(super) fn comparable<'a>(&self, g: &'a GearIndicators) -> (Vec<&'a Block>, usize) {
        let len = self.log_spectrum.len() + 1;
        (g.blocks.iter().filter(|b| b.amplitudes.len() >= len).collect(), len)
    }
}

fn score_gear(g: &GearIndicators, r: &GearReference) -> Vec<Score> {
    let (blocks, len) = r.comparable(g);
    Indicator::DECIDING
        .into_iter()
        .filter_map(|k| {
            let stat = r.stats.get(&k)?;
            let mut values: Vec<f64> = blocks
                .iter()
                .map(|b| match k {
                    Indicator::Na4Star => derived(b, r.residual_var, &r.log_spectrum, r.floor).0,
                    Indicator::SpectralChange => rms_db(&log_spectrum(&b.amplitudes[..len], r.floor), &r.log_spectrum),
                    _ => value(b, k),
                })
                .filter(|v| v.is_finite())
                .collect();
            if values.is_empty() {
                return None;
            }
            let v = median(&mut values);
            let near_zero = k == Indicator::Si && v.abs().max(stat.centre.abs()) < NEAR_ZERO_OF_RMS * r.rms;
            let (suspect_at, faulty_at) = limits(stat.count);
            let (spread, spread_from_files) = stat.scoring_spread(values.len(), suspect_at);
            let (raised_suspect, raised_faulty) = stat.load_limits(spread, values.len(), suspect_at, faulty_at);
            Some(Score {
                suspect_at: raised_suspect,
                faulty_at: raised_faulty,
                suspect_at_one_load: suspect_at,
                gear: g.gear,
                channel: g.channel,
                indicator: k,
                value: v,
                blocks: values.len(),
                baseline_centre: stat.scale.from(stat.centre),
                baseline_spread: spread,
                spread_from_files,
                scale: stat.scale,
                baseline_range: [stat.min, stat.max],
                baseline_blocks: stat.count,
                spreads: (stat.scale.to(v) - stat.centre) / spread,
                decides: !near_zero,
            })
        })
        .collect()
}

/// The whole-record impulse measures of `g` against the baseline files' (`baseline::long`); empty when the
/// reference holds no whole-record averages (a profile written before them) or the averages' lengths differ.
pub fn score_long(g: &GearIndicators, r: &Reference) -> Vec<LongScore> {
    r.gears.get(&(g.gear.baseline_key(), g.channel)).map(|gr| long::long_scores(g, gr)).unwrap_or_default()
}
