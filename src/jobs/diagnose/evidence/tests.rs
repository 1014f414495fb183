//! Tests of the evidence beyond the indicators: envelope, pattern, concentration and local change.

use super::*;
use crate::report::summary::{
    LocalChange, Score, ShaftHz, SpectrumScale, SpeedProfile, SpeedSource, TeethSource, Tracking,
};

/// A diagnosis suspect on the pinion from ER alone (an energy measure both averages share), with the given
/// FM4 of the pinion, and a wheel whose average changed at tooth 9 `wheel_change` times its limit; both
/// gears' patterns known and unchanged.
fn suspect_pinion(wheel_change: f64, pinion_fm4_spreads: f64) -> Diagnosis {
    let score = |indicator: Indicator, spreads: f64| Score {
        value: 1.0,
        faulty_at: 5.5,
        ..Score::test(Shaft::Pinion, indicator, spreads)
    };
    let change = |gear: Shaft, value: f64| LocalChange {
        gear,
        channel: 1,
        value,
        healthy: 1.0,
        limit: 3.0,
        alignment: 0.9,
        tooth: Some(9),
        sidebands: 0.1,
        sidebands_healthy: 0.1,
        sidebands_beyond_noise: 0.1,
        sidebands_noise: 0.05,
        sidebands_limit: 8.0,
        sidebands_limit_one_load: 8.0,
        pattern: 0.05,
        pattern_healthy: 0.1,
        own_share: None,
    };
    Diagnosis {
        file: "x.wav".into(),
        sample_rate_hz: Some(20_000.0),
        samples: 200_000,
        channels: vec![1],
        shaft_hz: ShaftHz::Pair { pinion: Some(20.0), wheel: Some(10.0) },
        shaft_period_samples: 1000.0,
        speed_source: SpeedSource::Tachometer,
        speed_confidence: 1.0,
        spectrum_scale: SpectrumScale::default(),
        speed_doubt: None,
        speed_given_hz: None,
        speed_deviation_percent: None,
        speed_profile: SpeedProfile {
            tracking: Tracking::Tachometer,
            mean_hz: Some(20.0),
            min_hz: Some(19.9),
            max_hz: Some(20.1),
            change_percent: 0.0,
            fluctuation_percent: 0.3,
            line_snr_db: None,
            refined_gain: None,
        },
        mesh_hz: Some(400.0),
        mesh_order: 20,
        teeth_source: TeethSource::Given,
        other_gear: None,
        mesh_harmonics: Vec::new(),
        indicators: Default::default(),
        gears: Vec::new(),
        raw: Vec::new(),
        verdict: Verdict::new(VerdictState::Suspect, VerdictGear::Pinion, vec!["pinion: ER".into()]),
        comparison: None,
        envelope: None,
        cepstrum: None,
        scores: vec![score(Indicator::Er, 3.8), score(Indicator::Fm4, pinion_fm4_spreads)],
        long_scores: Vec::new(),
        baseline_same_load: false,
        local_change: vec![change(Shaft::Pinion, 1.0), change(Shaft::Wheel, 3.0 * wheel_change)],
        unit: "m/s^2".into(),
        warnings: Vec::new(),
        spectra: Vec::new(),
        baseline_spectra: Vec::new(),
        baseline_tsas: Vec::new(),
        order_map: None,
        machine: None,
        teeth_misfit: Vec::new(),
    }
}

/// The verdict gear of [`suspect_pinion`] after the pattern and local-change evidence, the pinion's own
/// pattern at `pinion_pattern` times its healthy figure (the wheel's at half its).
fn judged_with(wheel_change: f64, pinion_fm4_spreads: f64, pinion_pattern: f64) -> (VerdictGear, bool) {
    let mut d = suspect_pinion(wheel_change, pinion_fm4_spreads);
    d.local_change[0].pattern = pinion_pattern * d.local_change[0].pattern_healthy;
    let decided = pattern_evidence(&mut d);
    local_change_evidence(&mut d, decided);
    assert_eq!(d.verdict.state, VerdictState::Suspect, "the state is kept");
    (d.verdict.gear, decided)
}

fn judged(wheel_change: f64, pinion_fm4_spreads: f64) -> VerdictGear {
    let (gear, decided) = judged_with(wheel_change, pinion_fm4_spreads, 1.5);
    assert!(decided, "the pinion's pattern changed: the patterns decided");
    gear
}

/// The pinion's own pattern changed (1.5 times its healthy figure) and the wheel's did not, so the patterns
/// keep the verdict on the pinion: a change at one wheel tooth 5.9 times its limit (the hold-out's 25 %
/// wheel crack whose pinion's SI took the verdict) still names the wheel; a change 2.2 times its limit (the
/// pinion of a worn wheel) does not, and neither does one beside a pinion whose own average holds an
/// impulse (FM4 over its suspect limit).
#[test]
fn a_change_at_one_tooth_far_over_its_limit_names_its_gear() {
    assert_eq!(judged(5.9, 0.5), VerdictGear::Wheel);
    assert_eq!(judged(LOCAL_CHANGE_NAMES, 0.5), VerdictGear::Wheel);
    assert_eq!(judged(2.2, 0.5), VerdictGear::Pinion);
    assert_eq!(judged(5.9, 3.5), VerdictGear::Pinion);
}

/// Neither gear's pattern stands 1.25 times its healthy figure, so the patterns name no gear and a change
/// at one tooth over its limit names its gear as it did before the pattern rule: the first generator's
/// 10 % cracked 17/29 wheel against a sibling (its average changed at its tooth 2.4 times its limit, its
/// pattern 1.16 times its figure, the pinion's 0.42) goes from the pinion to the wheel, and so it does with
/// the pinion's pattern just under the margin.
#[test]
fn unchanged_patterns_leave_the_gear_to_the_change_at_one_tooth() {
    assert_eq!(judged_with(2.4, 0.5, 0.42), (VerdictGear::Wheel, false));
    assert_eq!(judged_with(2.4, 0.5, 1.2), (VerdictGear::Wheel, false));
}

/// One revolution of a difference signal of `z` teeth at 64 points per tooth: a ripple over every tooth
/// plus a bump of height `bump` at each tooth of `at` (a quarter pitch wide).
fn difference(z: usize, at: &[usize], bump: f64) -> Vec<f64> {
    let n = 64 * z;
    (0..n)
        .map(|i| {
            let ripple = (std::f64::consts::TAU * 3.7 * i as f64 / 64.0).sin();
            let tooth = i / 64;
            ripple + if at.contains(&tooth) && i % 64 < 16 { bump } else { 0.0 }
        })
        .collect()
}

fn gear(shaft: Shaft, z: usize, difference: Vec<f64>) -> GearIndicators {
    GearIndicators {
        gear: shaft,
        channel: 1,
        mesh_order: z,
        revolutions: 100,
        indicators: Default::default(),
        residual: difference.clone(),
        difference,
        tsa_amplitudes: Vec::new(),
        tsa: Vec::new(),
        blocks: Vec::new(),
    }
}

/// A suspect verdict on the wheel of a 10/89 pair whose pinion's FM4 is over its suspect limit against
/// the baseline: the pinion's average holds its impulse at tooth 3, the wheel's the pinion's impulses at
/// nine places (as a 10/89 broken pinion tooth put them, the wheel's NA4* taking the verdict). The
/// concentration, read by `tooth::concentration` itself, names the pinion; with the impulse whole in the
/// wheel's average and the pinion's spread, the wheel stays; without a baseline's scores nothing moves.
#[test]
fn an_impulse_at_one_tooth_of_the_other_gear_names_it() {
    let judged = |pinion: Vec<f64>, wheel: Vec<f64>, scored: bool| {
        let mut d = suspect_pinion(1.0, 3.5);
        d.verdict.gear = VerdictGear::Wheel;
        d.gears = vec![gear(Shaft::Pinion, 10, pinion), gear(Shaft::Wheel, 89, wheel)];
        if !scored {
            d.scores.clear();
        }
        concentration_evidence(&mut d);
        d.verdict.gear
    };
    let spread: Vec<usize> = (0..9).map(|k| 3 + 10 * k).collect();
    let (one, many) = (difference(10, &[3], 6.0), difference(89, &spread, 3.0));
    let (c1, c9) = (tooth::concentration(&one, 10), tooth::concentration(&many, 89));
    assert!(c1 >= CONCENTRATION_NAMES * c9, "the premise: {c1} against {c9}");
    assert_eq!(judged(one.clone(), many.clone(), true), VerdictGear::Pinion);
    assert_eq!(judged(difference(10, &spread[..1], 0.5), difference(89, &[40], 6.0), true), VerdictGear::Wheel);
    assert_eq!(judged(one, many, false), VerdictGear::Wheel);
}

/// The shared indicators put the verdict on the pinion; the wheel's pattern changed 1.31 times its healthy
/// figure (as the hold-out 21/64 machine's worn wheel case, gears swapped). While the pinion's own pattern
/// is repeated by its healthy files (figure 0.1), the verdict moves to the wheel; once the pinion's healthy
/// files differ by more than the pattern's whole energy (1.34: nothing repeated), its change cannot be read
/// and the patterns decide nothing: the verdict stays where the indicators put it.
#[test]
fn an_unrepeated_pattern_decides_nothing() {
    let mut moved = suspect_pinion(0.5, 0.0);
    moved.local_change[1].pattern = 0.228;
    moved.local_change[1].pattern_healthy = 0.173;
    assert!(pattern_evidence(&mut moved), "both patterns are known");
    assert_eq!(moved.verdict.gear, VerdictGear::Wheel, "{:?}", moved.verdict.reasons);
    let mut kept = suspect_pinion(0.5, 0.0);
    kept.local_change[1].pattern = 0.228;
    kept.local_change[1].pattern_healthy = 0.173;
    kept.local_change[0].pattern = 1.362;
    kept.local_change[0].pattern_healthy = 1.342;
    assert!(!pattern_evidence(&mut kept), "the pinion's pattern is not known");
    assert_eq!(kept.verdict.gear, VerdictGear::Pinion, "{:?}", kept.verdict.reasons);
}

/// The patterns of both gears with their healthy figures: (pinion's, its figure, wheel's, its figure),
/// the verdict on the pinion from an energy measure both averages share.
fn with_patterns(pinion: (f64, f64), wheel: (f64, f64)) -> VerdictGear {
    let mut d = suspect_pinion(0.5, 0.0);
    (d.local_change[0].pattern, d.local_change[0].pattern_healthy) = pinion;
    (d.local_change[1].pattern, d.local_change[1].pattern_healthy) = wheel;
    assert!(pattern_evidence(&mut d), "both patterns are known");
    d.verdict.gear
}

/// A larger excess within the other gear's own noise names nothing: the third generator's spalled 13/43
/// pinion (its pattern 16 times its healthy figure, the wheel's twice its, the wheel's excess over it by
/// 0.03 where its figure is 0.41) stays on the pinion. The first generator's worn 17/29 pinion, read from
/// the wheel's side (the wheel 23 times its small figure, the pinion 4.6 times its own but its excess
/// larger by 0.57, over its figure of 0.38), moves; so does a change that stands further beyond its figure.
#[test]
fn an_excess_within_the_other_gears_noise_names_nothing() {
    assert_eq!(with_patterns((0.413, 0.026), (0.827, 0.41)), VerdictGear::Pinion);
    assert_eq!(with_patterns((0.80, 0.035), (1.715, 0.376)), VerdictGear::Wheel);
    assert_eq!(with_patterns((0.093, 0.21), (0.346, 0.127)), VerdictGear::Wheel);
}

/// [`suspect_pinion`] with the pinion's average holding one decaying ring from the start of tooth 5's pitch
/// (20 teeth), its state `state`, and the pinion's local change against the baseline `local` times its limit
/// (`None`: no baseline's change measured).
fn ringing_pinion(state: VerdictState, local: Option<f64>) -> Diagnosis {
    let z = 20;
    let ring = super::super::tooth::tests::ring(1024, z, 5);
    let mut d = suspect_pinion(0.1, 4.0);
    d.verdict.state = state;
    d.gears = vec![GearIndicators {
        gear: Shaft::Pinion,
        channel: 1,
        mesh_order: z,
        revolutions: 300,
        indicators: Default::default(),
        residual: ring.clone(),
        difference: ring,
        tsa_amplitudes: Vec::new(),
        tsa: Vec::new(),
        blocks: Vec::new(),
    }];
    match local {
        None => d.local_change.clear(),
        Some(times) => d.local_change[0].value = times * d.local_change[0].limit,
    }
    d
}

/// A suspect pinion whose difference signal rings at tooth 5 is given that tooth without a baseline's
/// change, and the local change's own tooth (9) when that change counts; when the change was measured and
/// does not count (spread over the revolution, as wear and eccentricity spread it) a suspect verdict names
/// no tooth, a faulty one the ring's while FM4 stands over its limit, none on ER alone.
#[test]
fn a_suspect_change_that_is_not_local_names_no_tooth() {
    let tooth = |state, local| {
        let mut d = ringing_pinion(state, local);
        place_tooth(&mut d);
        d.verdict.tooth
    };
    assert_eq!(tooth(VerdictState::Suspect, None), Some(5));
    assert_eq!(tooth(VerdictState::Suspect, Some(1.5)), Some(9));
    assert_eq!(tooth(VerdictState::Suspect, Some(0.5)), None);
    // placed twice (after a verdict moved), the word on no tooth stands once
    let mut d = ringing_pinion(VerdictState::Suspect, Some(0.5));
    place_tooth(&mut d);
    place_tooth(&mut d);
    assert_eq!(d.verdict.reasons.iter().filter(|r| r.starts_with("no tooth named")).count(), 1);
    assert!(
        d.verdict.reasons.last().is_some_and(|r| r.starts_with("no tooth named") && r.contains("1.5 times")),
        "{:?}",
        d.verdict.reasons
    );
    assert_eq!(tooth(VerdictState::Faulty, Some(0.5)), Some(5));
    // faulty on ER alone (FM4 under its suspect limit), the change not local: no impulse, no tooth
    let mut d = ringing_pinion(VerdictState::Faulty, Some(0.5));
    d.scores.retain(|s| s.indicator != Indicator::Fm4);
    place_tooth(&mut d);
    assert_eq!(d.verdict.tooth, None);
}
