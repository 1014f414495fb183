//! What a single baseline file leaves open: the indicators and sideband growths that stand over what its
//! blocks show but under the allowance for a neighbouring load (`baseline::one_file`). Said in one
//! warning, so that a fault of that size is not passed over in silence, nor called out where a change of
//! load explains it as well.

use crate::report::format::num;
use crate::report::summary::{LocalChange, Score};

/// One line naming every indicator of `scores` and sideband growth of `changes` (judged against a single
/// baseline file) that a change of load and a fault could both explain; `None` when there is none.
pub fn warning(scores: &[Score], changes: &[LocalChange]) -> Option<String> {
    let mut items: Vec<String> = scores
        .iter()
        .filter(|s| s.decides && !s.over_suspect() && s.spreads >= s.suspect_at_one_load)
        .map(|s| {
            format!(
                "{} channel {} {} {} spreads (suspect from {} at the file's own load, {} for a neighbouring load)",
                s.gear,
                s.channel,
                s.indicator.label(),
                num(s.spreads),
                num(s.suspect_at_one_load),
                num(s.suspect_at)
            )
        })
        .collect();
    items.extend(
        changes.iter().filter(|c| c.sidebands < c.sidebands_limit && c.sidebands >= c.sidebands_limit_one_load).map(
            |c| {
                format!(
                    "{} channel {} sideband growth {} (limit {} at the file's own load, {} for a neighbouring load)",
                    c.gear,
                    c.channel,
                    num(c.sidebands),
                    num(c.sidebands_limit_one_load),
                    num(c.sidebands_limit)
                )
            },
        ),
    );
    (!items.is_empty()).then(|| {
        format!(
            "against a single baseline file, over what its blocks show but within what a neighbouring load (10 % of the rated load) moves a healthy recording on a real rig: {}; a change of load and a fault of this size cannot be told apart from one file: a baseline learnt from recordings at two loads or more decides, or, if this file was recorded at this recording's load, stating that has the recording judged on the file's own limits",
            items.join("; ")
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::summary::{Indicator, Shaft};

    fn score(spreads: f64, decides: bool) -> Score {
        Score {
            value: 1.0,
            baseline_spread: 0.05,
            baseline_range: [0.9, 1.1],
            suspect_at: 7.0,
            faulty_at: 9.5,
            decides,
            ..Score::test(Shaft::Pinion, Indicator::Fm0, spreads)
        }
    }

    /// Only what lies between the limit at the file's own load and the raised limit is named: under the
    /// first is healthy either way, over the second is a verdict's, and an indicator that does not decide
    /// says nothing.
    #[test]
    fn names_only_what_a_load_and_a_fault_both_explain() {
        assert!(warning(&[score(3.0, true), score(8.0, true), score(5.0, false)], &[]).is_none());
        let w = warning(&[score(5.0, true)], &[]).expect("5 spreads lies between 3.4 and 7");
        assert!(w.contains("FM0 5 spreads") && w.contains("3.4") && w.contains("two loads"), "{w}");
    }
}
