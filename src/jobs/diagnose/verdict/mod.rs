//! The verdict: condition indicators judged against the statistical baseline of the same machine (how many
//! of its block-to-block spreads they moved), or against absolute limits without one; NA4 over the
//! ensemble of recordings in time order.

use super::baseline::{self, Reference};
use crate::report::summary::{
    Diagnosis, GearIndicators, Indicator, Indicators, LocalChange, LongScore, Score, Shaft, Verdict, VerdictGear,
    VerdictState,
};
use crate::signal::indicators as ind;
use std::collections::BTreeMap;

mod absolute;

pub use absolute::{Limits, Thresholds};
use absolute::{absolute, own_energy};

/// Fills NA4 over the ensemble (recordings in time order): NA4 of record M uses the mean residual sum of
/// squares of records 1..=M of the same gear and channel.
pub fn ensemble_na4(results: &mut [Diagnosis]) {
    let mut history = Na4History::default();
    for d in results.iter_mut() {
        history.apply(d);
    }
}

/// The residual sums of squares seen so far per gear and channel: NA4 over the ensemble, one recording at a
/// time (so a stream of recordings needs no more than this).
#[derive(Default, Debug)]
pub struct Na4History {
    seen: BTreeMap<(Shaft, usize), Vec<f64>>,
}

impl Na4History {
    /// Adds the next recording (time order) and fills its NA4.
    pub fn apply(&mut self, d: &mut Diagnosis) {
        for g in &mut d.gears {
            let h = self.seen.entry((g.gear.baseline_key(), g.channel)).or_default();
            h.push(ind::sum_sq_dev(&g.residual));
            g.indicators.insert(Indicator::Na4, ind::na4(&g.residual, h));
        }
        if let Some(g) = d.gears.first() {
            d.indicators = g.indicators.clone();
        }
    }
}

struct Trigger {
    state: VerdictState,
    ratio: f64,
    text: String,
    /// A measure of one impulse in the gear's own average (FM4, M6A of the difference signal): a local
    /// fault keeps it whole in its own gear's average and smears it in the other's, where it raises the
    /// energy measures (ER, FM0, NA4*, spectral change) instead.
    local: bool,
    /// A measure of the sidebands at the gear's own shaft spacing (SBR, SER, SI): a modulation once per
    /// its own revolution, which the other gear's average does not hold in whole orders.
    sideband: bool,
    /// An indicator that alone makes a gear at most suspect (SBR): it does not count towards
    /// `Thresholds::faulty_count` either.
    supporting: bool,
    /// A ratio of what is not the mesh to the mesh lines (FM0, ER: [`Indicator::mesh_ratio`]): several of
    /// them count as one towards `Thresholds::faulty_count`.
    mesh_ratio: bool,
    /// A whole-record measure ([`LongScore`]): it raises the gear's state, and weighs in the choice between
    /// gears only for a gear without a block measure (its spreads are of a block's value, a scale on which
    /// a whole record's change reads larger than the block scores', and a worn 19/53 pinion sharpened the
    /// wheel's whole-record M6A 7 spreads).
    whole_record: bool,
}

fn level(value: f64, limits: Limits) -> Option<VerdictState> {
    if !value.is_finite() || value < limits.suspect {
        None
    } else if value >= limits.faulty {
        Some(VerdictState::Faulty)
    } else {
        Some(VerdictState::Suspect)
    }
}

fn get(m: &Indicators, k: Indicator) -> f64 {
    m.get(&k).copied().unwrap_or(f64::NAN)
}

fn against_baseline(d: &mut Diagnosis, g: &GearIndicators, r: &Reference, levels: bool) -> Vec<Trigger> {
    let mut scores: Vec<Score> = baseline::score_one(g, r);
    if !levels {
        scores.iter_mut().filter(|s| s.indicator.level_dependent()).for_each(|s| s.decides = false);
    }
    if let Some(why) = lone_si(g.gear, g.channel, &scores, &d.local_change) {
        d.warnings.push(why);
    }
    let si_alone = si_without_sbr(&scores);
    let mut out = Vec::new();
    for sc in &scores {
        let (name, why) = (sc.indicator.label(), sc.indicator.meaning());
        if !sc.over_suspect() {
            continue;
        }
        let alone = matches!(sc.indicator, Indicator::Si | Indicator::Ser) && si_alone;
        let (state, cap) = match (sc.spreads >= sc.faulty_at, sc.indicator.supporting()) {
            (true, false) if alone => (
                VerdictState::Suspect,
                " (the mesh fundamental's sidebands alone, SBR of every mesh harmonic unchanged: a line of another source beside the mesh reads there, so at most suspect on its own)",
            ),
            (true, false) => (VerdictState::Faulty, ""),
            (true, true) => (
                VerdictState::Suspect,
                " (a load fluctuating near the shaft's rate modulates a healthy gear too: at most suspect on its own)",
            ),
            (false, _) => (VerdictState::Suspect, ""),
        };
        let files = if sc.spread_from_files {
            " (the spread widened to how far the baseline's files differ among themselves)".to_string()
        } else if sc.suspect_at > sc.suspect_at_one_load {
            format!(
                " (suspect from {} spreads, not {}: what a neighbouring load moves a healthy recording, which a single baseline file cannot show)",
                num(sc.suspect_at),
                num(sc.suspect_at_one_load)
            )
        } else {
            String::new()
        };
        out.push(Trigger {
            state,
            local: sc.indicator.local(),
            sideband: sc.indicator.sideband(),
            supporting: sc.indicator.supporting() || alone,
            mesh_ratio: sc.indicator.mesh_ratio(),
            whole_record: false,
            ratio: sc.spreads,
            text: format!(
                "{} (channel {}): {name} {} (median of {} blocks) against the baseline's {} (range {} .. {} over {} blocks): {} spreads above{files}; {why}{cap}",
                g.gear,
                g.channel,
                num(sc.value),
                sc.blocks,
                num(sc.baseline_centre),
                num(sc.baseline_range[0]),
                num(sc.baseline_range[1]),
                sc.baseline_blocks,
                if sc.spreads > 1000.0 { "over 1000".to_string() } else { format!("{:.1}", sc.spreads) }
            ),
        });
    }
    d.scores.extend(scores);
    let long = baseline::score_long(g, r);
    out.extend(long.iter().filter_map(|l| long_trigger(g, l)));
    d.long_scores.extend(long);
    out
}

/// The trigger of a whole-record impulse measure over its suspect limit ([`LongScore`]).
fn long_trigger(g: &GearIndicators, l: &LongScore) -> Option<Trigger> {
    if !l.over_suspect() {
        return None;
    }
    let state = if l.spreads >= l.faulty_at { VerdictState::Faulty } else { VerdictState::Suspect };
    let files: Vec<String> = l.files.iter().map(|&f| num(f)).collect();
    let normal = if l.indicator == Indicator::Fm4 { 3 } else { 15 };
    let text = format!(
        "{} (channel {}): {} {} of the whole record's average ({} revolutions) against the baseline files' {}: {:.1} spreads above their mean or a normal signal's {normal}, whichever is higher (suspect from {}); {}",
        g.gear,
        g.channel,
        l.indicator.label(),
        num(l.value),
        l.revolutions,
        files.join(", "),
        l.spreads,
        num(l.suspect_at),
        l.indicator.meaning()
    );
    Some(Trigger {
        state,
        ratio: l.spreads,
        text,
        local: true,
        sideband: false,
        supporting: false,
        mesh_ratio: false,
        whole_record: true,
    })
}

/// SI rose alone: when SI is the only indicator of a gear's average (`gear`, `channel`) over its limit, while the first sidebands of
/// all its mesh harmonics did not grow (SBR under its limit, the local change's sideband growth under its
/// own), the returned warning says what the verdict then rests on.
///
/// SI is two lines of the average, the orders z - 1 and z + 1 beside the mesh fundamental, and any line of
/// another source there reads as SI: a 10-blade fan's second harmonic is order 20 of a 19-tooth pinion's
/// shaft, its third order 30 of a 31-tooth one. An eccentric or modulated gear raises the first sidebands of
/// every mesh harmonic (SBR, sideband growth) with them. On the hold-out generator (a fan on the input
/// shaft, its phase new in each recording) SI alone put four wheel faults on the pinion, and the verdicts it
/// started and other evidence put on the wheel were right twice: SI still decides, with this caveat (and,
/// without SBR, at most suspect: [`si_without_sbr`]).
fn lone_si(gear: Shaft, channel: usize, scores: &[Score], changes: &[LocalChange]) -> Option<String> {
    let mut moved = scores.iter().filter(|s| s.over_suspect());
    let si = moved.next().filter(|s| s.indicator == Indicator::Si && moved.next().is_none())?;
    let grew = changes.iter().any(|c| c.gear == gear && c.channel == channel && c.sidebands >= c.sidebands_limit);
    (!sbr_moved(scores) && !grew).then(|| {
        format!(
            "{} (channel {}): SI {} rose {:.1} spreads over the baseline alone, while the first sidebands of its mesh harmonics did not grow (SBR and the sideband growth under their limits): SI is the two lines beside the mesh fundamental, where a line of another source (a fan's or another shaft's harmonic) reads as SI, so which gear changed is uncertain on SI alone",
            gear,
            channel,
            num(si.value),
            si.spreads
        )
    })
}

/// Whether the only indicators of one gear's average over their limits are SI and SER (the lines beside
/// the mesh fundamental) while SBR (the first sidebands of every mesh harmonic against the harmonics) is
/// under its own: they then make the gear suspect, never faulty, and count as no piece of corroboration.
/// A line of another source beside the mesh fundamental reads as SI, SER and the sideband growth (whose
/// orders hold the fundamental's sidebands too), not as SBR: eleven healthy recordings of the
/// hold-out's 19/53 machine (another shaft's mesh at 198 Hz, its second harmonic 2 Hz from the pinion
/// mesh's lower sideband), judged against a profile of two of them with the tachometer, read SI 0.10-0.32
/// against their 0.054, and two of nine were FAULTY on SI at 6.0 spreads (one with SER at 3.35 beside it)
/// with SBR at 3.1-3.2 under 3.25.
fn si_without_sbr(scores: &[Score]) -> bool {
    let fundamental = |s: &Score| matches!(s.indicator, Indicator::Si | Indicator::Ser);
    let mut moved = scores.iter().filter(|s| s.over_suspect()).peekable();
    let only = moved.peek().is_some() && moved.all(fundamental);
    only && !sbr_moved(scores)
}

/// Whether SBR (the first sidebands of every mesh harmonic against the harmonics) stands at or over its
/// suspect limit among `scores`.
fn sbr_moved(scores: &[Score]) -> bool {
    scores.iter().any(|s| s.indicator == Indicator::Sbr && s.spreads >= s.suspect_at)
}

/// A number with four significant digits, in plain or scientific notation by size.
fn num(v: f64) -> String {
    crate::report::format::num(v)
}

/// The state a gear's triggers give: the worst single one, or faulty when `faulty_count` pieces of
/// evidence fire together (supporting indicators left out, the mesh ratios FM0 and ER counted as one).
fn gear_state(triggers: &[Trigger], t: &Thresholds) -> VerdictState {
    let top = triggers.iter().map(|x| x.state).max().unwrap_or(VerdictState::Healthy);
    let counted = triggers.iter().filter(|x| !x.supporting);
    let ratios = counted.clone().filter(|x| x.mesh_ratio).count().min(1);
    let pieces = counted.filter(|x| !x.mesh_ratio).count() + ratios;
    if pieces >= t.faulty_count { VerdictState::Faulty } else { top }
}

/// Why a gear could not be judged, or `None` when it could: against a baseline, every deciding indicator
/// must have been scored on at least one block of the same length as the baseline's; without one, FM4, M6A
/// and NA4 must be numbers.
fn unscored(d: &Diagnosis, g: &GearIndicators, reference: Option<&Reference>) -> Option<String> {
    let what = format!("{} (channel {})", g.gear, g.channel);
    match reference {
        Some(r) if !r.covers(g) => {
            Some(format!("{what}: the baseline holds no such gear and channel, so it cannot be scored"))
        }
        Some(_) => {
            let scored = d.scores.iter().filter(|s| s.gear == g.gear && s.channel == g.channel).count();
            (scored == 0).then(|| {
                format!(
                    "{what}: none of its {} block(s) could be scored against the baseline (their averages do not hold the baseline's orders, or every value is not a number)",
                    g.blocks.len()
                )
            })
        }
        None => {
            let bad: Vec<&str> = [Indicator::Fm4, Indicator::M6a, Indicator::Na4]
                .into_iter()
                .filter(|&k| !get(&g.indicators, k).is_finite())
                .map(Indicator::label)
                .collect();
            (!bad.is_empty()).then(|| {
                format!(
                    "{what}: {} not a number (the average holds no difference or residual signal to measure: check the teeth and the speed)",
                    bad.join(", ")
                )
            })
        }
    }
}

/// Verdict against the statistical baseline of the same machine, or on absolute limits without one. A gear
/// that cannot be scored (no comparable block, a number that is not one, a gear the baseline lacks) is never taken for healthy: when no judged gear shows a fault,
/// the recording is [`VerdictState::NotJudged`] with the reasons.
pub fn judge(d: &mut Diagnosis, reference: Option<&Reference>, t: &Thresholds) {
    judge_levels(d, reference, t, true);
}

/// [`judge`], with `levels` false when absolute levels do not compare with the baseline's (one side's
/// unit unknown): the level-dependent indicators are scored but do not decide.
pub fn judge_levels(d: &mut Diagnosis, reference: Option<&Reference>, t: &Thresholds, levels: bool) {
    let absolute_only = Thresholds { faulty_count: usize::MAX, ..t.clone() };
    let t = if reference.is_none() { &absolute_only } else { t };
    let (per_gear, not_judged) = gear_triggers(d, reference, t, levels);
    let trusted = d.speed_doubt.is_none();
    let worst = worst_gear(&per_gear, t, trusted).map(|w| if trusted { own_sidebands(&per_gear, w) } else { w });
    // the worst state of any gear (the gear named may be another: `own_sidebands`)
    let state_all = per_gear.iter().map(|g| gear_state(&g.triggers, t)).max().unwrap_or(VerdictState::Healthy);
    let mut reasons = Vec::new();
    let mut cross_talk = Vec::new();
    let (state, gear) = match worst {
        Some(w) if state_all > VerdictState::Healthy => {
            // the deciding gear's reasons, strongest first; the other shafts' triggers are its cross-talk
            // (a local fault is synchronous with its own gear, so its own average keeps it whole while the
            // other gear's average holds it smeared)
            let mut own: Vec<&Trigger> =
                per_gear.iter().filter(|g| g.gear == w.gear).flat_map(|g| &g.triggers).collect();
            own.sort_by(|a, b| b.ratio.total_cmp(&a.ratio));
            reasons.extend(own.iter().take(t.max_reasons).map(|t| t.text.clone()));
            // a gear that could not be scored is not judged; a doubt on the speed qualifies the verdict
            reasons.extend(not_judged.iter().map(|why| match &d.speed_doubt {
                Some(doubt) if doubt == why => format!("with a doubt on the speed: {why}"),
                _ => format!("not judged: {why}"),
            }));
            let unit = if reference.is_some() { "spreads" } else { "times its healthy value" };
            cross_talk = cross_talk_notes(&per_gear, w, unit);
            if let Some(g) = d.gears.iter().find(|g| g.gear == w.gear && g.channel == w.channel) {
                d.indicators = g.indicators.clone();
            }
            (state_all, VerdictGear::from(w.gear))
        }
        _ if !not_judged.is_empty() || d.gears.is_empty() => {
            if d.gears.is_empty() {
                reasons.push("no gear average could be computed".into());
            }
            reasons.extend(not_judged.iter().cloned());
            (VerdictState::NotJudged, VerdictGear::None)
        }
        _ => {
            reasons.push(healthy_reason(d, reference, t));
            (VerdictState::Healthy, VerdictGear::None)
        }
    };
    if reference.is_none() {
        reasons.push("without a baseline only absolute thresholds apply; a healthy recording of the same machine makes the verdict much stronger".into());
    }
    // a smeared average mimics a distributed fault, never an impulse: the deciding gear's own faulty
    // FM4/M6A keeps the verdict
    let impulse = worst.is_some_and(|w| w.triggers.iter().any(|x| x.local && x.state == VerdictState::Faulty));
    let state = match reference.and_then(|r| weaker_angle(d, r)) {
        Some(why) if state == VerdictState::Faulty && !impulse => {
            reasons.push(why);
            VerdictState::Suspect
        }
        _ => state,
    };
    d.verdict = Verdict::new(state, gear, reasons);
    d.verdict.cross_talk = cross_talk;
    d.verdict.deciding = worst.filter(|_| state > VerdictState::Healthy).map(|w| w.gear);
    super::tooth::place_tooth(d);
}

/// One gear average's triggers: the indicators over their limits.
struct GearTriggers {
    gear: Shaft,
    channel: usize,
    triggers: Vec<Trigger>,
}

/// Every gear average's triggers (against the baseline, or on absolute limits without one; `d.scores` is
/// filled on the way), and why some could not be judged (a gear the baseline could not score, a doubt on
/// the speed).
fn gear_triggers(
    d: &mut Diagnosis,
    reference: Option<&Reference>,
    t: &Thresholds,
    levels: bool,
) -> (Vec<GearTriggers>, Vec<String>) {
    let mut per_gear = Vec::new();
    let mut not_judged = Vec::new();
    d.scores.clear();
    d.long_scores.clear();
    let gears = d.gears.clone();
    for g in &gears {
        let triggers = match reference {
            Some(r) if r.covers(g) => against_baseline(d, g, r, levels),
            Some(_) => Vec::new(),
            None => absolute(g, t),
        };
        if let Some(why) = unscored(d, g, reference) {
            not_judged.push(why);
        }
        per_gear.push(GearTriggers { gear: g.gear, channel: g.channel, triggers });
    }
    // (on a doubtful speed the averages may hold no gear, and their ratio says nothing)
    if reference.is_none() && d.speed_doubt.is_none() {
        for (g, trigger) in gears.iter().filter_map(|g| own_energy(g, &gears).map(|x| (g, x))) {
            if let Some(p) = per_gear.iter_mut().find(|p| p.gear == g.gear && p.channel == g.channel) {
                p.triggers.push(trigger);
            }
        }
    }
    if let Some(doubt) = &d.speed_doubt {
        not_judged.push(doubt.clone());
    }
    (per_gear, not_judged)
}

/// The largest ratio of an impulse measure (FM4, M6A) among `triggers`, and the largest of any (spreads
/// against a baseline, times its healthy value without); whole-record triggers only for a gear without a
/// block trigger.
fn weight(triggers: &[Trigger]) -> (f64, f64) {
    let blocks = triggers.iter().any(|x| !x.whole_record);
    let counted = || triggers.iter().filter(move |x| !(blocks && x.whole_record));
    let local = counted().filter(|x| x.local).map(|x| x.ratio).fold(0.0, f64::max);
    (local, counted().map(|x| x.ratio).fold(0.0, f64::max))
}

/// How much further (as a ratio of the strongest triggers' ratios to their limits) one gear's indicators
/// must have moved than another's to decide between them before an impulse does. A distributed fault
/// (wear) moves its own gear's energy and sideband indicators far and can sharpen the other gear's
/// difference signal a little: the hold-out's worn 19-tooth pinion moved its ER 2.9 times its limit and
/// the wheel's M6A 2.2 times, and the impulse alone put it on the wheel. An engineering choice: at 1.25
/// both generators' scorecards lost no gear and gained that one in two modes.
const CLEARLY_FURTHER: f64 = 1.25;

/// How many times stronger (as a ratio to its limit) one gear's impulse (FM4, M6A) must be than the
/// other's, when both averages hold one, to decide between them: a local fault is whole in its own gear's
/// average and spread over the other's revolutions there, so its impulse in the other's average is weaker;
/// a generated broken wheel tooth stood 4.3 times stronger in the wheel's (FM4) than in the pinion's, while
/// a hold-out pinion spall raised the wheel's M6A 1.6 times higher than the pinion's own impulse (its
/// NA4*, ER and FM0 then decide for the pinion).
const CLEARLY_STRONGER_IMPULSE: f64 = 2.0;

/// The gear a verdict goes to: the worst state; among equal states (with `speed_trusted`) the one whose
/// indicators moved [`CLEARLY_FURTHER`] than the others', else the one whose own average holds an impulse
/// (FM4, M6A: a local fault is whole in its own gear's average, smeared in the other's), or, when both
/// do, the one whose impulse stands [`CLEARLY_STRONGER_IMPULSE`] times over the other's, then the one
/// whose strongest indicator moved furthest. On a doubtful speed the averages can be smeared, which moves the energy
/// measures of a gear far without a fault of its own, so the impulse decides first.
fn worst_gear<'a>(per_gear: &'a [GearTriggers], t: &Thresholds, speed_trusted: bool) -> Option<&'a GearTriggers> {
    let key = |g: &GearTriggers| (gear_state(&g.triggers, t), weight(&g.triggers));
    let by = |margin: f64| {
        move |a: f64, b: f64| {
            if a > margin * b {
                std::cmp::Ordering::Greater
            } else if b > margin * a {
                std::cmp::Ordering::Less
            } else {
                std::cmp::Ordering::Equal
            }
        }
    };
    let (clearly, stronger) = (by(CLEARLY_FURTHER), by(CLEARLY_STRONGER_IMPULSE));
    per_gear.iter().max_by(|a, b| {
        let ((sa, (la, xa)), (sb, (lb, xb))) = (key(a), key(b));
        let further = if speed_trusted { clearly(xa, xb) } else { std::cmp::Ordering::Equal };
        // a broken wheel tooth: the wheel's FM4 4.5 times its limit, the pinion's 1.05
        let impulse = || (la > 0.0).cmp(&(lb > 0.0)).then_with(|| stronger(la, lb));
        sa.cmp(&sb).then(further).then_with(impulse).then(xa.total_cmp(&xb))
    })
}

/// The gear a verdict names when no average holds an impulse: the worst gear `w` (by [`worst_gear`]),
/// unless its triggers are energy measures alone (ER, FM0, NA4*, spectral change: both averages of a pair
/// hold the same mesh harmonics, so these move on both for a change of either gear) while exactly one other
/// gear's own sidebands (SBR, SER, SI: at its shaft spacing, which the other average does not hold in whole
/// orders) moved; that gear is named, and the verdict keeps the worst state. The fresh set's worn 18/29
/// pinion (its first sidebands 4 times the baseline's, SER and SBR over their limits) was put on the wheel,
/// FAULTY on the wheel's ER alone (6-8 spreads, the pinion's 4.2-4.4), against two siblings.
fn own_sidebands<'a>(per_gear: &'a [GearTriggers], w: &'a GearTriggers) -> &'a GearTriggers {
    let any = |g: &GearTriggers, f: fn(&Trigger) -> bool| g.triggers.iter().any(f);
    if per_gear.iter().any(|g| any(g, |x| x.local)) || any(w, |x| x.sideband) {
        return w;
    }
    let mut moved = per_gear.iter().filter(|g| g.gear != w.gear && any(g, |x| x.sideband));
    match (moved.next(), moved.next()) {
        (Some(one), None) => one,
        _ => w,
    }
}

/// What the other gears' triggers are beside the deciding gear `w`'s: its fault smeared over their
/// revolutions (cross-talk, not a second fault), with why `w` was chosen (`unit` of the ratios).
fn cross_talk_notes(per_gear: &[GearTriggers], w: &GearTriggers, unit: &str) -> Vec<String> {
    let gear = w.gear;
    let (own_local, own_max) = weight(&w.triggers);
    per_gear
        .iter()
        .filter(|g| g.gear != gear && !g.triggers.is_empty())
        .map(|g| {
            let other = g.gear;
            let strongest = g.triggers.iter().max_by(|a, b| a.ratio.total_cmp(&b.ratio));
            let (local, max) = weight(&g.triggers);
            let sidebands = |x: &GearTriggers| x.triggers.iter().any(|t| t.sideband);
            let why = if own_local > 0.0 {
                format!(
                    "the {gear}'s own average holds the impulse (FM4/M6A {own_local:.1} {unit}, the {other}'s {local:.1})"
                )
            } else if sidebands(w) && !sidebands(g) {
                format!(
                    "the {gear}'s own sidebands moved (at its shaft spacing, which the {other}'s average does not hold in whole orders), the {other}'s did not: the energy measures both averages share moved with them"
                )
            } else {
                format!("the {gear}'s indicators moved further ({own_max:.1} {unit}, the {other}'s {max:.1})")
            };
            format!(
                "the {other}'s indicators moved too ({}): its average holds the {gear}'s fault smeared over its own revolutions, which is cross-talk, not a second fault: {why}",
                strongest.map_or(String::new(), |t| t.text.split_once(": ").map_or(t.text.as_str(), |x| x.1).to_string()),
            )
        })
        .collect()
}

/// Why a recording whose every gear was judged is healthy: the suspect limits against the baseline, or
/// the absolute limits without one.
fn healthy_reason(d: &Diagnosis, reference: Option<&Reference>, t: &Thresholds) -> String {
    match reference {
        Some(r) => {
            let lo = d.scores.iter().map(|s| s.suspect_at_one_load).fold(f64::INFINITY, f64::min);
            let hi = d.scores.iter().map(|s| s.suspect_at_one_load).fold(0.0, f64::max);
            let range = if hi - lo < 0.05 { format!("{lo:.1}") } else { format!("{lo:.1} to {hi:.1}") };
            // "; n of the m <how>" when n scores were scored so
            let share = |n: usize, how: &str| {
                if n > 0 { format!("; {n} of the {} {how}", d.scores.len()) } else { String::new() }
            };
            let files = share(
                d.scores.iter().filter(|s| s.spread_from_files).count(),
                "on a spread widened to how far the baseline's files differ among themselves",
            );
            let raised = share(
                d.scores.iter().filter(|s| s.suspect_at > s.suspect_at_one_load).count(),
                "with the limit raised to what a neighbouring load moves a healthy recording (a single baseline file cannot show it)",
            );
            let load =
                if r.same_load() && r.files == 1 { ", at this recording's load and speed as stated" } else { "" };
            format!(
                "every condition indicator lies below its suspect limit ({range} spreads above the centre of the baseline's blocks, for a false-alarm rate of 1e-3 per indicator; {} healthy recording(s){load}{files}{raised})",
                r.files
            )
        }
        None => format!(
            "FM4, M6A and NA4 are under their absolute limits ({} {}, {} {}, {} {}: no baseline given)",
            Indicator::Fm4,
            num(t.fm4_absolute.suspect),
            Indicator::M6a,
            num(t.m6a_absolute.suspect),
            Indicator::Na4,
            num(t.na4_absolute.suspect)
        ),
    }
}

/// How much weaker (dB) than the baseline's weakest the mesh line a recording's angle was followed on may be
/// before its averages are taken as possibly smeared: a tracked angle that slips part of a mesh cycle
/// smears the average, which lowers its mesh lines and raises ER, FM0 and NA4* as a distributed fault does
/// (two healthy recordings of a generated machine of another physics, followed on lines of 8.0 and 8.3 dB
/// against the baseline's 11.2 dB, with a tracked speed 0.7 % off the true one, were faulty on ER by 14-17
/// spreads). 3 dB is twice the noise's amplitude over the line.
const WEAKER_LINE_DB: f64 = 3.0;

/// Mesh line height over its band (dB) from which a tracked angle does not slip: the phase-locked tracking
/// held every generated recording whose line stood 10.6 dB or more (README, tracking); the healthy
/// recordings that slipped were followed on lines of 8.0 and 8.3 dB. 14 dB leaves a margin of 3.4 dB.
const SLIP_FREE_LINE_DB: f64 = 14.0;

/// Why a faulty verdict against `reference` is only suspect: the recording's angle was followed on a mesh
/// line [`WEAKER_LINE_DB`] weaker than the baseline files' weakest and under [`SLIP_FREE_LINE_DB`], so its
/// averages may be smeared where the baseline's are not; or its angle was not followed at all (a constant
/// speed). The caller keeps a faulty verdict whose own gear's FM4 or M6A is faulty (an impulse, which a
/// smeared average never shows); a distributed change on such an angle is suspect until a tachometer's
/// angle confirms it.
fn weaker_angle(d: &Diagnosis, reference: &Reference) -> Option<String> {
    use crate::report::summary::Tracking;
    if d.speed_profile.tracking == Tracking::Constant {
        // hold-out machines, teeth only: two healthy recordings averaged on a constant estimated speed
        // 0.6-0.8 % off their wandering shaft were faulty on SER by 11-15 spreads against their sibling
        return Some(
            "at most suspect: the angle could not be followed, so the averages assume a constant speed on a shaft that may wander, which smears them as a distributed fault does; a tachometer channel would decide".into(),
        );
    }
    let base = reference.tracked_line_db?;
    let own = d.speed_profile.line_snr_db.filter(|_| d.speed_profile.tracking == Tracking::MeshPhase)?;
    (own < base - WEAKER_LINE_DB && own < SLIP_FREE_LINE_DB).then(|| {
        format!(
            "at most suspect: the angle was followed on a mesh line {own:.1} dB over its band against {base:.1} dB in the baseline, so the averages may be smeared by a slipping angle, which mimics a distributed fault; a tachometer channel would decide"
        )
    })
}

/// Lowers a faulty verdict to suspect when the recording's operating point differs from the baseline's,
/// with `why` as the first reason (a change of load is not a fault, and the baseline cannot tell them
/// apart).
pub fn cap_at_suspect(d: &mut Diagnosis, why: String) {
    if d.verdict.state == VerdictState::Faulty {
        d.verdict.state = VerdictState::Suspect;
    }
    if d.verdict.state > VerdictState::Healthy {
        d.verdict.reasons.insert(0, why);
    } else {
        d.warnings.push(why);
    }
}

#[cfg(test)]
mod tests;
