//! What a single baseline file leaves open: the indicators and sideband growths that stand over what its
//! blocks show but under the allowance for a neighbouring load (`baseline::one_file`). Said in one
//! warning, so that a fault of that size is not passed over in silence, nor called out where a change of
//! load explains it as well.

use crate::report::format::num;
use crate::report::summary::Diagnosis;

/// One line naming every indicator and sideband growth of `d` (judged against a single baseline file)
/// that a change of load and a fault could both explain; `None` when there is none.
pub fn warning(d: &Diagnosis) -> Option<String> {
    let mut items: Vec<String> = d
        .scores
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
        d.local_change
            .iter()
            .filter(|c| c.sidebands < c.sidebands_limit && c.sidebands >= c.sidebands_limit_one_load)
            .map(|c| {
                format!(
                    "{} channel {} sideband growth {} (limit {} at the file's own load, {} for a neighbouring load)",
                    c.gear,
                    c.channel,
                    num(c.sidebands),
                    num(c.sidebands_limit_one_load),
                    num(c.sidebands_limit)
                )
            }),
    );
    (!items.is_empty()).then(|| {
        format!(
            "against a single baseline file, {} stand over what its blocks show but within what a neighbouring load (10 % of the rated load) moves them on a real rig: a change of load and a fault of this size cannot be told apart from one file; a baseline recorded at this recording's load, or learnt from recordings at two loads or more, decides",
            items.join("; ")
        )
    })
}
