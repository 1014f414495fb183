use super::*;

fn trigger(ratio: f64, local: bool) -> Trigger {
    Trigger {
        state: VerdictState::Faulty,
        ratio,
        text: String::new(),
        local,
        sideband: false,
        supporting: false,
        mesh_ratio: false,
        whole_record: false,
    }
}

fn gear(gear: Shaft, triggers: Vec<Trigger>) -> GearTriggers {
    GearTriggers { gear, channel: 1, triggers }
}

/// Between two faulty gears, the one whose indicators moved clearly further (25 %) takes the verdict
/// even when only the other's average holds an impulse; within that margin, or on a doubtful speed,
/// the impulse decides, and a higher state always does.
#[test]
fn a_gear_that_moved_clearly_further_outranks_an_impulse() {
    let t = Thresholds::default();
    let worn = |pinion: f64| {
        [
            gear(Shaft::Pinion, vec![trigger(pinion, false), trigger(1.5, false)]),
            gear(Shaft::Wheel, vec![trigger(2.2, true), trigger(1.6, true)]),
        ]
    };
    assert_eq!(worst_gear(&worn(2.9), &t, true).map(|g| g.gear), Some(Shaft::Pinion));
    assert_eq!(worst_gear(&worn(2.6), &t, true).map(|g| g.gear), Some(Shaft::Wheel));
    // on a doubtful speed (averages possibly smeared) the impulse decides
    assert_eq!(worst_gear(&worn(2.9), &t, false).map(|g| g.gear), Some(Shaft::Wheel));
    let suspect_only = [
        gear(Shaft::Pinion, vec![Trigger { state: VerdictState::Suspect, ..trigger(9.0, false) }]),
        gear(Shaft::Wheel, vec![trigger(1.2, true), trigger(1.1, false)]),
    ];
    assert_eq!(worst_gear(&suspect_only, &t, true).map(|g| g.gear), Some(Shaft::Wheel));
    // both averages hold an impulse and their strongest indicators moved about as far: the clearly
    // stronger impulse decides (a generated broken wheel tooth: spectral change 14.5 and 13.4 times
    // its limit on the pinion and the wheel, FM4 1.05 and 4.5 times)
    let broken = [
        gear(Shaft::Pinion, vec![trigger(14.5, false), trigger(1.05, true)]),
        gear(Shaft::Wheel, vec![trigger(13.4, false), trigger(4.5, true)]),
    ];
    assert_eq!(worst_gear(&broken, &t, true).map(|g| g.gear), Some(Shaft::Wheel));
    assert_eq!(worst_gear(&broken, &t, false).map(|g| g.gear), Some(Shaft::Wheel));
    // an impulse only 1.6 times stronger does not decide: the strongest indicator does
    let spall = [
        gear(Shaft::Pinion, vec![trigger(2.28, false), trigger(1.14, true)]),
        gear(Shaft::Wheel, vec![trigger(1.86, true)]),
    ];
    assert_eq!(worst_gear(&spall, &t, true).map(|g| g.gear), Some(Shaft::Pinion));
}

/// A whole-record trigger weighs in the choice between gears only for a gear without a block trigger: the
/// hold-out's worn 19/53 pinion (ER 8.4 spreads) beside a wheel whose block M6A moved 4.7 and whose
/// whole-record M6A read 7.1 spreads of a block's value stays on the pinion (8.4 is clearly further than
/// the wheel's block 5.0); a gear whose only triggers are whole-record ones is weighed on them (a spalled
/// wheel beside a pinion of energy measures).
#[test]
fn a_whole_record_trigger_weighs_only_where_no_block_one_does() {
    let t = Thresholds::default();
    let long = |ratio: f64| Trigger { whole_record: true, ..trigger(ratio, true) };
    let worn = [
        gear(Shaft::Pinion, vec![trigger(8.4, false), trigger(4.4, false)]),
        gear(Shaft::Wheel, vec![trigger(5.0, false), trigger(4.7, true), long(7.1)]),
    ];
    assert_eq!(worst_gear(&worn, &t, true).map(|g| g.gear), Some(Shaft::Pinion));
    assert_eq!(weight(&worn[1].triggers), (4.7, 5.0));
    let spall = [
        gear(Shaft::Pinion, vec![trigger(3.5, false), trigger(3.4, false)]),
        gear(Shaft::Wheel, vec![long(9.0), long(5.0)]),
    ];
    assert_eq!(weight(&spall[1].triggers), (9.0, 9.0));
    assert_eq!(worst_gear(&spall, &t, true).map(|g| g.gear), Some(Shaft::Wheel));
}

/// No impulse anywhere: a wheel FAULTY on ER alone (6 spreads) beside a pinion whose own sidebands moved
/// (SER) with its ER names the pinion (the fresh set's worn 18/29 pinion); not when an average holds an
/// impulse, when the worst gear's own sidebands moved too, or when two other gears' did.
#[test]
fn own_sidebands_name_the_gear_when_energy_measures_alone_decided() {
    let t = Thresholds::default();
    let energy = |ratio: f64, state: VerdictState| Trigger { state, ..trigger(ratio, false) };
    let sideband = |ratio: f64| Trigger { state: VerdictState::Suspect, sideband: true, ..trigger(ratio, false) };
    let worn = |wheel: Vec<Trigger>| {
        [gear(Shaft::Pinion, vec![energy(4.4, VerdictState::Suspect), sideband(4.4)]), gear(Shaft::Wheel, wheel)]
    };
    let named = |g: &[GearTriggers]| {
        let w = worst_gear(g, &t, true).unwrap();
        (w.gear, own_sidebands(g, w).gear)
    };
    let faulty_er = || energy(6.0, VerdictState::Faulty);
    assert_eq!(named(&worn(vec![faulty_er()])), (Shaft::Wheel, Shaft::Pinion));
    assert_eq!(named(&worn(vec![faulty_er(), trigger(3.6, true)])).1, Shaft::Wheel);
    assert_eq!(named(&worn(vec![faulty_er(), sideband(3.5)])).1, Shaft::Wheel);
    let [pinion, wheel] = worn(vec![faulty_er()]);
    let three = [pinion, wheel, gear(Shaft::Named("output"), vec![sideband(3.5)])];
    assert_eq!(named(&three).1, Shaft::Wheel);
}

/// Two indicators at their suspect limit make a gear faulty against a baseline, but SBR (supporting: a load
/// fluctuating near the shaft's rate raises it on a healthy gear) is not one of the two: FM0 and SBR of
/// the first generator's healthy 18/31 wheel against one sibling (4.5 and 4.3 spreads) are suspect.
#[test]
fn a_supporting_indicator_is_not_counted_towards_faulty() {
    let t = Thresholds::default();
    let suspect = |supporting: bool| Trigger { state: VerdictState::Suspect, supporting, ..trigger(4.4, false) };
    assert_eq!(gear_state(&[suspect(false), suspect(true)], &t), VerdictState::Suspect);
    assert_eq!(gear_state(&[suspect(false), suspect(false)], &t), VerdictState::Faulty);
    assert_eq!(gear_state(&[suspect(false), suspect(false), suspect(true)], &t), VerdictState::Faulty);
    assert_eq!(gear_state(&[suspect(true)], &t), VerdictState::Suspect);
}

/// FM0 and ER are both ratios of what is not the mesh to the mesh lines, and a weaker mesh raises them
/// together: at their suspect limits they are one piece of evidence (the same healthy 18/31 wheel against
/// one sibling, with the tachometer: FM0 6.5 and ER 5.4 spreads, suspect), while one of them beside an
/// indicator of another kind (FM4, NA4*) makes two, and either beyond its faulty limit is faulty alone.
#[test]
fn the_mesh_ratios_count_as_one_towards_faulty() {
    let t = Thresholds::default();
    let suspect = |mesh_ratio: bool| Trigger { state: VerdictState::Suspect, mesh_ratio, ..trigger(5.0, false) };
    assert_eq!(gear_state(&[suspect(true), suspect(true)], &t), VerdictState::Suspect);
    assert_eq!(gear_state(&[suspect(true), suspect(false)], &t), VerdictState::Faulty);
    assert_eq!(gear_state(&[suspect(true), suspect(true), suspect(false)], &t), VerdictState::Faulty);
    let faulty_ratio = Trigger { mesh_ratio: true, ..trigger(12.0, false) };
    assert_eq!(gear_state(&[faulty_ratio], &t), VerdictState::Faulty);
    assert!(Indicator::Fm0.mesh_ratio() && Indicator::Er.mesh_ratio() && !Indicator::Na4Star.mesh_ratio());
}

fn score(indicator: Indicator, spreads: f64) -> Score {
    Score {
        value: 0.12,
        baseline_centre: 0.05,
        baseline_spread: 0.24,
        baseline_range: [0.02, 0.07],
        suspect_at: 3.43,
        suspect_at_one_load: 3.43,
        ..Score::test(Shaft::Pinion, indicator, spreads)
    }
}

fn sidebands_grew(by: f64) -> LocalChange {
    LocalChange {
        gear: Shaft::Pinion,
        channel: 1,
        value: 1.0,
        healthy: 1.0,
        limit: 3.0,
        alignment: 0.9,
        tooth: None,
        sidebands: by,
        sidebands_healthy: 0.1,
        sidebands_beyond_noise: 0.1,
        sidebands_noise: 0.05,
        sidebands_limit: 1.0,
        sidebands_limit_one_load: 1.0,
        pattern: 0.1,
        pattern_healthy: 0.2,
        own_share: None,
    }
}

/// SI over its limit with nothing beside it (the hold-out's 19/53 pinion: SI 3.8 spreads from a fan
/// harmonic at order 20, SBR 0.5 and the sideband growth 0.55 of their limits) carries the caveat; SI
/// beside SBR or a grown sideband family, or beside another indicator, does not.
#[test]
fn si_alone_is_said_to_rest_on_two_lines() {
    let (si, sbr, er) = (score(Indicator::Si, 3.8), score(Indicator::Sbr, 1.7), score(Indicator::Er, 1.0));
    let quiet = [sidebands_grew(0.55)];
    let caveat = lone_si(Shaft::Pinion, 1, &[si.clone(), sbr.clone(), er.clone()], &quiet);
    assert!(caveat.is_some_and(|w| w.contains("SI 0.12 rose 3.8 spreads") && w.contains("uncertain")));
    let sbr_over = score(Indicator::Sbr, 3.5);
    assert!(lone_si(Shaft::Pinion, 1, &[si.clone(), sbr_over], &quiet).is_none());
    assert!(lone_si(Shaft::Pinion, 1, &[si.clone(), sbr.clone()], &[sidebands_grew(1.2)]).is_none());
    let er_over = score(Indicator::Er, 4.0);
    assert!(lone_si(Shaft::Pinion, 1, &[si.clone(), er_over], &quiet).is_none());
    // the growth of the other gear's sidebands is no support
    let wheel = LocalChange { gear: Shaft::Wheel, ..sidebands_grew(5.0) };
    assert!(lone_si(Shaft::Pinion, 1, &[si, sbr], &[wheel]).is_some());
}

/// Without a baseline, a gear of a pair whose average holds five times the other's ER over at least as
/// many revolutions is suspect (the third set's broken 13/43 pinion: ER 3.04 against the wheel's 0.081,
/// 415 revolutions against 125, FM4 4.8, HEALTHY before); not when the gear with the larger ER averaged
/// fewer revolutions (its average keeps more noise beside the shared mesh lines), nor at four times, nor
/// under an ER of 1 beside a nearly ideal mate, nor on a machine file's named shafts, whose meshes differ.
#[test]
fn a_gear_holding_far_more_energy_off_the_mesh_than_its_mate_is_suspect() {
    let with = |gear: Shaft, revolutions: usize, er: f64| GearIndicators {
        gear,
        channel: 1,
        mesh_order: 13,
        revolutions,
        indicators: [(Indicator::Er, er)].into_iter().collect(),
        residual: Vec::new(),
        difference: Vec::new(),
        tsa_amplitudes: Vec::new(),
        tsa: Vec::new(),
        blocks: Vec::new(),
    };
    let pair = [with(Shaft::Pinion, 415, 3.04), with(Shaft::Wheel, 125, 0.081)];
    let t = own_energy(&pair[0], &pair).expect("the pinion holds far more");
    assert_eq!(t.state, VerdictState::Suspect);
    assert!(t.text.contains("37.5 times"), "{}", t.text);
    assert!(own_energy(&pair[1], &pair).is_none());
    let fewer = [with(Shaft::Pinion, 100, 3.04), with(Shaft::Wheel, 125, 0.081)];
    assert!(own_energy(&fewer[0], &fewer).is_none(), "fewer revolutions: noise may explain it");
    let four = [with(Shaft::Pinion, 415, 0.324), with(Shaft::Wheel, 125, 0.081)];
    assert!(own_energy(&four[0], &four).is_none());
    // the bundled healthy 14/39 recording: a pinion ER of 0.18 beside an ideal wheel's 0.006
    let ideal = [with(Shaft::Pinion, 238, 0.176), with(Shaft::Wheel, 85, 0.006)];
    assert!(own_energy(&ideal[0], &ideal).is_none(), "under the floor");
    let named = [with(Shaft::named("input"), 415, 3.04), with(Shaft::named("output"), 125, 0.081)];
    assert!(own_energy(&named[0], &named).is_none());
}

/// The mesh fundamental's sidebands alone (SI, SER) with SBR under its limit: at most suspect, however far
/// over (a line of another source beside the mesh reads there); with SBR over its limit too, or another
/// indicator beside them, the usual states.
#[test]
fn the_fundamentals_sidebands_alone_are_at_most_suspect() {
    let sbr_at = |spreads: f64| score(Indicator::Sbr, spreads);
    assert!(si_without_sbr(&[score(Indicator::Si, 6.0), sbr_at(3.1)]));
    assert!(si_without_sbr(&[score(Indicator::Si, 6.0), score(Indicator::Ser, 3.5), sbr_at(3.1)]));
    assert!(!si_without_sbr(&[score(Indicator::Si, 6.0), sbr_at(3.5)]), "SBR moved with them");
    assert!(!si_without_sbr(&[score(Indicator::Si, 6.0), score(Indicator::Fm4, 4.0), sbr_at(1.0)]));
    assert!(!si_without_sbr(&[score(Indicator::Si, 1.0), sbr_at(1.0)]), "nothing over its limit");
}
