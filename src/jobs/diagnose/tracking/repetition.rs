//! The shaft of a recording whose teeth are given and whose mesh comb could not clear its own speed, from
//! the signal's repetition period: how many turns of which gear the period holds.

use super::*;

/// Autocorrelation at the signal's repetition period from which it decides the speed over a mesh comb
/// that could not clear its own (a confidence under [`UNSURE_SPEED`] or a close second): a broken or
/// spalled tooth fills the spectrum with shaft harmonics whose combs outscore the mesh's (generated
/// machines of another physics, the teeth alone: 20 of 69 broken and spalled recordings taken 2-14 times
/// too slow), while its impulse repeats every turn of its gear at 0.4-0.6; a healthy mesh repeats at its
/// revolution far less (a real rig's 0.16-0.47).
pub(super) const REPETITION_OVER_UNSURE_COMB: f64 = 0.3;

/// The teeth's mesh comb's shaft `found`, or, when it carries a doubt ([`MeshShaft::doubt`]) and the
/// signal's repetition over `views` decides ([`repetition_decides`], [`shaft_of_repetition`]), the
/// repetition's, with a warning saying so. `n` is the record's length (samples); `fs` (Hz) is for the note.
pub(super) fn over_unsure_comb(
    found: MeshShaft,
    fft: &mut Fft,
    (views, full, n): (&[&[f32]], &[&[f32]], usize),
    o: &Options,
    fs: Option<f64>,
    warnings: &mut Vec<String>,
) -> MeshShaft {
    let (Some(teeth), Some(_)) = (o.teeth, found.doubt()) else { return found };
    let Ok(rep) = speed::estimate_period(fft, views, 16, n / o.min_revolutions.max(2)) else {
        return over_weak_comb(found, fft, (views, full, n), teeth, o, fs, warnings);
    };
    if !repetition_decides(&rep, o) {
        return over_weak_comb(found, fft, (views, full, n), teeth, o, fs, warnings);
    }
    let Some(shaft) = shaft_of_repetition(&rep, (views, full), teeth, fs) else { return found };
    let hz = |period: f64| revolution_text(period, fs);
    warnings.push(format!(
        "the teeth's mesh comb gave the pinion {} but could not clear it (confidence {:.2}{}), while the signal repeats strongly (autocorrelation {:.2} at {:.1} samples): the repetition decides the speed",
        hz(found.period_samples),
        found.confidence,
        found.close_second.map_or(String::new(), |c| format!(", a second candidate at {:.0} % of its evidence", 100.0 * c)),
        rep.confidence,
        rep.period_samples
    ));
    shaft
}

/// Smallest relative difference between the shaft of the strongest line and the comb's for the line's to
/// be another speed (the comb's grid and the followed line's mean agree within 2 %, [`COMB_AGREEMENT`]).
const OTHER_SPEED: f64 = 0.03;

/// The teeth's mesh comb's shaft `found` that could not clear its own, or the shaft of the spectrum's
/// strongest line over its local floor (between the slowest mesh the record's revolutions allow and
/// [`MESH_HIGHEST`]) followed and read as a mesh line of `zp` teeth ([`shaft_through_mesh`]: the
/// fundamental, or the harmonic whose sidebands stand on the followed angle), when that reading's confidence
/// is higher than the comb's (the scales differ: an engineering choice, checked on the sets below). A mesh whose speed wanders by a percent
/// keeps its fundamental as the spectrum's strongest hump while its higher harmonics smear into the floor,
/// and the comb then reads other lines: on the third generator's 25/50 machine at 96 kHz the comb gave
/// 9.1 times the speed on all eleven recordings, the line the true speed on ten; over the four generated
/// sets with the teeth alone and no baseline (253 recordings) the line's reading was taken on 17, right on
/// 15 (within 0.5 % of the true mean speed), and the two wrong ones had a wrong comb too. The speed chosen so rests on the line being the fundamental: said,
/// and kept as a doubt (no verdict of health rests on it).
fn over_weak_comb(
    found: MeshShaft,
    fft: &mut Fft,
    (views, full, n): (&[&[f32]], &[&[f32]], usize),
    (zp, zw): (usize, usize),
    o: &Options,
    fs: Option<f64>,
    warnings: &mut Vec<String>,
) -> MeshShaft {
    let Some(f) = strongest_line(fft, views, n, zp, o.min_revolutions) else { return found };
    let whose = Some((zp, "the given teeth"));
    let Ok(Some(line)) = shaft_through_mesh(fft, full, 1.0 / f, o.min_revolutions, whose, Some(zw)) else {
        return found;
    };
    if line.confidence <= found.confidence
        || (line.period_samples / found.period_samples - 1.0).abs() < OTHER_SPEED
        || comb_harmonic(&found, &line).is_some()
    {
        return found;
    }
    let hz = |period: f64| revolution_text(period, fs);
    let line_hz = fs.map_or(format!("{f:.5} cycles per sample"), |fs| format!("{:.1} Hz", f * fs));
    warnings.push(format!(
        "the teeth's mesh comb gave the pinion {} without confirming it (confidence {:.2}); the spectrum's strongest line ({line_hz}), followed and read as a mesh line of {zp} teeth, gives {} with a higher confidence ({:.2}): that speed is used",
        hz(found.period_samples),
        found.confidence,
        hz(line.period_samples),
        line.confidence
    ));
    let assumed = format!(
        "the shaft speed rests on the spectrum's strongest line ({line_hz}) being a mesh line of the given teeth, the mesh comb having given another speed it could not confirm: were the line another harmonic or another machine's, the averages would run on a wrong speed, so the indicators cannot clear the machine; give the shaft speed or a tachometer channel"
    );
    MeshShaft { assumed: Some(assumed), ..line }
}

/// The mesh harmonics of the comb's speed that the strongest line is tested for ([`comb_harmonic`]).
const COMB_HARMONICS: std::ops::RangeInclusive<usize> = 3..=4;

/// The harmonic k (in [`COMB_HARMONICS`]) of the comb's mesh that the strongest line's reading `line`
/// stands on, when its speed is k times the comb's `found` within [`OTHER_SPEED`]: the line is then the
/// comb's own k-th mesh harmonic, read as the fundamental, and agrees with the comb rather than
/// contradicting it. On the fourth generator's 26/41 machine (tests/holdout/gen_fourth.py) the third mesh
/// harmonic stands highest on four recordings and its reading (three times the speed, at a confidence of
/// 0.48 against the comb's 0.27) replaced the comb's right speed. Not k = 2: a comb at half the speed is a
/// comb's common mistake (a revolution of two turns), and on the fresh 18/29 machine's cracked pinion the
/// line at twice the comb's speed was the right one.
fn comb_harmonic(found: &MeshShaft, line: &MeshShaft) -> Option<usize> {
    let ratio = found.period_samples / line.period_samples;
    COMB_HARMONICS.into_iter().find(|&k| (ratio / k as f64 - 1.0).abs() < OTHER_SPEED)
}

/// The frequency (cycles per sample) of the line of the first of `views` that stands highest over its
/// local floor in the averaged spectrum, between the slowest mesh of `zp` teeth that `min_revs` revolutions
/// of a record of `n` samples allow and [`MESH_HIGHEST`].
fn strongest_line(fft: &mut Fft, views: &[&[f32]], n: usize, zp: usize, min_revs: usize) -> Option<f64> {
    let x = views.first()?;
    let segment = (x.len() / 16).next_power_of_two().clamp(1024, 1 << 15).min(x.len());
    let (power, m) = crate::signal::spectrum::averaged_power(fft, x, segment, 0.5, "line spectrum").ok()?;
    let floor = crate::signal::mesh_comb::local_floor(&power);
    let slowest = (min_revs.max(2) + 2) as f64 * zp as f64 / n as f64;
    let lowest = (slowest * m as f64).ceil() as usize + 3;
    let highest = ((MESH_HIGHEST * m as f64) as usize).min(power.len().saturating_sub(1));
    let (bin, _) = (lowest..highest)
        .map(|i| (i, power[i] / floor[i].max(f64::MIN_POSITIVE)))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    Some(bin as f64 / m as f64)
}

/// Whether the repetition `rep` can be a number of revolutions of the pinion of the given teeth: it
/// repeats at [`REPETITION_OVER_UNSURE_COMB`] or more, over at least [`MIN_SAMPLES_PER_REV`] samples and
/// 4 max(zp, zw) + 16 (the shortest revolution the mesh comb takes: a TSA resolving both mesh orders with
/// their sidebands), and its pinion mesh lies below [`MESH_HIGHEST`]: a ringing resonance or a mesh lag
/// repeats at a few dozen to a few hundred samples.
pub(super) fn repetition_decides(rep: &speed::PeriodEstimate, o: &Options) -> bool {
    let Some((zp, zw)) = o.teeth else { return false };
    rep.confidence >= REPETITION_OVER_UNSURE_COMB
        && rep.period_samples >= shortest_revolution(zp, zw)
        && zp as f64 / rep.period_samples < MESH_HIGHEST
}

/// Share of the mean line at the orders that are multiples of r below which the other orders of a
/// repetition count as empty, so that it holds r turns ([`shaft_of_repetition`]): a shaft's harmonics
/// fill every order of its own revolution, and a period of r turns leaves the orders between its multiples
/// of r to the noise (well under a fifth of a line that stands 10 dB over it).
pub(super) const EMPTY_ORDERS: f64 = 0.2;
/// Orders of each kind compared by [`shaft_of_repetition`].
const ORDERS_COMPARED: usize = 6;

/// The shortest pinion revolution (samples) a repetition may give: [`MIN_SAMPLES_PER_REV`], and
/// 4 max(zp, zw) + 16 (the shortest the mesh comb takes: a TSA resolving both mesh orders with their
/// sidebands).
fn shortest_revolution(zp: usize, zw: usize) -> f64 {
    MIN_SAMPLES_PER_REV.max(4.0 * zp.max(zw) as f64 + 16.0)
}

/// The shaft of a repetition `rep` that decided over an unsure mesh comb ([`repetition_decides`]): the
/// period holds r = 4, 3 or 2 turns when the orders between the multiples of r are empty
/// ([`EMPTY_ORDERS`]), else one; the turn is the wheel's when its mesh (zw orders, best of the first four
/// harmonics) stands over twice the pinion's (zp orders), else the pinion's. The teeth `(zp, zw)` give the
/// pinion's revolution either way, read on `views` (the record's first 2^20 samples) and refined on
/// the mesh line followed over `full`; `fs` (Hz) is for the note. `None` when no harmonic 1-4 of that
/// mesh can be followed at the period's rate ([`COMB_AGREEMENT`]): the period is then no turn of a gear of
/// those teeth (a resonance ringing, a fan).
pub(super) fn shaft_of_repetition(
    rep: &speed::PeriodEstimate,
    (views, full): (&[&[f32]], &[&[f32]]),
    (zp, zw): (usize, usize),
    fs: Option<f64>,
) -> Option<MeshShaft> {
    let p = rep.period_samples;
    let line = |order: f64| -> f64 {
        let f = order / p;
        if f >= 0.45 { 0.0 } else { views.iter().map(|c| ind_line(c, f, 0.2 / p)).sum() }
    };
    let mean = |orders: &mut dyn Iterator<Item = usize>| {
        let v: Vec<f64> = orders.map(|j| line(j as f64)).collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let turns = [4, 3, 2]
        .into_iter()
        .find(|&r| {
            let on = mean(&mut (1..=ORDERS_COMPARED).map(|j| j * r));
            let off = mean(&mut (1..=ORDERS_COMPARED * r).filter(|j| j % r != 0));
            on > 0.0 && off < EMPTY_ORDERS * on
        })
        .unwrap_or(1);
    let turn = p / turns as f64;
    // the turn is the wheel's when its mesh orders hold the stronger line
    let mesh = |z: usize| (1..=4).map(|k| line((k * z * turns) as f64)).fold(0.0, f64::max);
    let wheel = zw != zp && mesh(zw) > 2.0 * mesh(zp);
    let z = if wheel { zw } else { zp };
    // that gear's mesh must be a line that can be followed at one of its first four harmonics, its mean
    // cycle agreeing with the period (a ringing resonance or a fan repeats without one); the followed
    // cycle refines the turn
    let (k, cycle) = (1..=4).find_map(|k| {
        let lag = turn / (k * z) as f64;
        follow_line(full, lag).ok().filter(|(c, _)| (c / lag - 1.0).abs() <= COMB_AGREEMENT).map(|(c, _)| (k, c))
    })?;
    let turn = (k * z) as f64 * cycle;
    let period = if wheel { turn * zp as f64 / zw as f64 } else { turn };
    if period < shortest_revolution(zp, zw) {
        return None;
    }
    let hz = |period: f64| revolution_text(period, fs);
    Some(MeshShaft {
        period_samples: period,
        mesh_order: None,
        confidence: rep.confidence,
        note: format!(
            "pinion speed from the signal's repetition: {} ({} turn{} of the {} in {p:.1} samples{}); give the speed or a tachometer channel when known",
            hz(period),
            turns,
            if turns == 1 { "" } else { "s" },
            if wheel { "wheel, whose mesh line stands over the pinion's" } else { "pinion" },
            if turns > 1 { ", the orders between its multiples empty" } else { "" }
        ),
        from_comb: false,
        close_second: None,
        turns: None,
        comb_peak: None,
        assumed: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::test_noise::uniform_noise;
    use std::f64::consts::PI;

    /// A pinion of 13 teeth at 64 samples per mesh cycle with a broken tooth: its mesh, and a decaying
    /// ring of 7 mesh cycles' period once per turn (832 samples), in noise.
    fn broken_pinion(n: usize) -> Vec<f32> {
        let turn = 832.0;
        let mut noise = uniform_noise(7);
        (0..n)
            .map(|i| {
                let t = i as f64;
                let since = t % turn;
                let ring = 3.0 * (-since / 40.0).exp() * (2.0 * PI * since / 9.0).sin();
                ((2.0 * PI * 13.0 * t / turn).sin() + ring + 0.3 * noise()) as f32
            })
            .collect()
    }

    /// A repetition of two turns is read as two (every odd order of it empty: a shaft's harmonics are
    /// the even ones), one turn as one: the pinion's revolution is 832 samples either way. The order
    /// lines are exact for a constant speed, and the followed mesh line's mean cycle is good to 1e-4 of it
    /// over 60 turns.
    #[test]
    fn a_repetition_of_two_turns_of_a_broken_pinion_is_halved() {
        let x = broken_pinion(832 * 60);
        let views = [&x[..]];
        for (period, turns) in [(1664.0, 2), (832.0, 1)] {
            let rep = speed::PeriodEstimate { period_samples: period, confidence: 0.6, mesh_lag: None };
            let found = shaft_of_repetition(&rep, (&views, &views), (13, 43), None).expect("a followed mesh line");
            assert!((found.period_samples / 832.0 - 1.0).abs() < 1e-4, "{period}: {}", found.period_samples);
            assert!(found.note.contains(&format!("{turns} turn")), "{}", found.note);
            assert!(!found.from_comb);
        }
    }

    /// A period holding a turn of the wheel, whose mesh line stands at its 43 orders (and nothing at the
    /// 13 orders a pinion's turn would put it at), gives the pinion 13/43 of it.
    #[test]
    fn a_repetition_whose_mesh_is_at_the_wheel_orders_is_the_wheel_turn() {
        let turn = 2752.0;
        let mut noise = uniform_noise(3);
        let x: Vec<f32> = (0..turn as usize * 20)
            .map(|i| {
                let t = i as f64;
                ((2.0 * PI * 43.0 * t / turn).sin() + 0.2 * (2.0 * PI * t / turn).sin() + 0.3 * noise()) as f32
            })
            .collect();
        let rep = speed::PeriodEstimate { period_samples: turn, confidence: 0.5, mesh_lag: None };
        let found =
            shaft_of_repetition(&rep, (&[&x[..]], &[&x[..]]), (13, 43), Some(1000.0)).expect("the wheel's mesh");
        assert!((found.period_samples / (turn * 13.0 / 43.0) - 1.0).abs() < 1e-4, "{}", found.period_samples);
        assert!(found.note.contains("wheel"), "{}", found.note);
    }

    /// Samples per turn of [`wandering_mesh`]'s pinion.
    const TURN: f64 = 2000.0;

    /// 120 turns of a 25-tooth mesh line alone (no harmonics) under a 1 % slow wander (zero mean over the
    /// record's six periods of it), a strong slow tone and noise.
    fn wandering_mesh() -> Vec<f32> {
        let mut noise = uniform_noise(11);
        let mut phase = 0.0;
        (0..TURN as usize * 120)
            .map(|i| {
                let t = i as f64;
                phase += 25.0 / TURN * (1.0 + 0.01 * (2.0 * PI * t / (20.0 * TURN)).sin());
                let slow = 5.0 * (2.0 * PI * t / 9000.0).sin();
                ((2.0 * PI * phase).sin() + slow + 0.3 * noise()) as f32
            })
            .collect()
    }

    /// A mesh comb's shaft of `period_samples` and `confidence`.
    fn comb(period_samples: f64, confidence: f64) -> MeshShaft {
        MeshShaft {
            period_samples,
            mesh_order: None,
            confidence,
            note: String::new(),
            from_comb: true,
            close_second: None,
            turns: None,
            comb_peak: None,
            assumed: None,
        }
    }

    /// A pinion of 25 teeth turning once per 2000 samples with a 1 % slow wander: its mesh fundamental
    /// alone (no harmonics: they smear into the floor on a real machine) over noise, and a strong slow
    /// tone under the slowest mesh the record allows. The strongest line is the mesh (80 samples per cycle),
    /// not the slow tone; read as the fundamental and followed it gives the pinion's mean revolution
    /// (2000 samples: the wander's mean is zero over its whole periods) and replaces a weak comb's reading of
    /// nine times the speed, with the assumption kept as a doubt; a comb that repeats better stays.
    #[test]
    fn a_weak_comb_gives_way_to_the_mesh_fundamental_read_with_the_teeth() {
        let x = wandering_mesh();
        let (views, n) = ([&x[..]], x.len());
        let line = strongest_line(&mut Fft::new(), &views, n, 25, 8).expect("a line");
        assert!((line * 80.0 - 1.0).abs() < 0.01, "{} samples per cycle", 1.0 / line);
        let o = Options { teeth: Some((25, 50)), min_revolutions: 8, ..Options::default() };
        let mut warnings = Vec::new();
        let weak = comb(TURN / 9.0, 0.1);
        let found = over_weak_comb(weak, &mut Fft::new(), (&views, &views, n), (25, 50), &o, None, &mut warnings);
        assert!((found.period_samples / TURN - 1.0).abs() < 2e-3, "{}", found.period_samples);
        assert!(found.doubt().is_some_and(|d| d.contains("mesh line of the given teeth")), "{:?}", found.doubt());
        assert!(warnings[0].contains("strongest line"), "{warnings:?}");
        let strong = comb(TURN / 9.0, 0.99);
        let kept = over_weak_comb(strong, &mut Fft::new(), (&views, &views, n), (25, 50), &o, None, &mut Vec::new());
        assert_eq!(kept.period_samples, TURN / 9.0);
    }

    /// The same record read by a weak comb at a third or a quarter of the line's speed: the strongest line is
    /// then the comb's third or fourth mesh harmonic (the fourth generator's 26/41 machine, where the line's
    /// reading gave three times the true speed), which agrees with the comb: the comb stays. At 2.5 times the
    /// line's turn (no whole harmonic) and at twice it (a comb's half-speed mistake) the line's reading
    /// replaces it.
    #[test]
    fn a_strongest_line_on_a_mesh_harmonic_of_the_comb_keeps_the_comb() {
        let x = wandering_mesh();
        let (views, n) = ([&x[..]], x.len());
        let o = Options { teeth: Some((25, 50)), min_revolutions: 8, ..Options::default() };
        for k in [3.0, 4.0] {
            let weak = comb(k * TURN, 0.1);
            let kept = over_weak_comb(weak, &mut Fft::new(), (&views, &views, n), (25, 50), &o, None, &mut Vec::new());
            assert_eq!(kept.period_samples, k * TURN, "harmonic {k}");
        }
        for k in [2.0, 2.5] {
            let weak = comb(k * TURN, 0.1);
            let moved = over_weak_comb(weak, &mut Fft::new(), (&views, &views, n), (25, 50), &o, None, &mut Vec::new());
            assert!((moved.period_samples / TURN - 1.0).abs() < 2e-3, "{k}: {}", moved.period_samples);
        }
    }

    /// A repetition that holds no mesh of the given teeth (noise with a ringing tone of its own period)
    /// gives no shaft: no line at its mesh orders can be followed.
    #[test]
    fn a_repetition_without_the_teeth_mesh_gives_no_shaft() {
        let mut noise = uniform_noise(5);
        let x: Vec<f32> =
            (0..446 * 200).map(|i| ((2.0 * PI * i as f64 / 446.0).sin() + 0.5 * noise()) as f32).collect();
        let rep = speed::PeriodEstimate { period_samples: 446.0, confidence: 0.4, mesh_lag: None };
        assert!(shaft_of_repetition(&rep, (&[&x[..]], &[&x[..]]), (22, 49), None).is_none());
    }

    /// The repetition decides only when it repeats strongly, over a shaft's worth of samples, and the
    /// teeth are given; a ringing resonance of a few dozen samples (the third set's 96 kHz 25/50 machine with a
    /// broken tooth: 0.94 at 72 samples, a mesh of 25 teeth over it above a quarter of the rate) does not.
    #[test]
    fn a_weak_or_ringing_repetition_does_not_decide() {
        let o = |teeth| Options { teeth, ..Options::default() };
        let rep = |period_samples, confidence| speed::PeriodEstimate { period_samples, confidence, mesh_lag: None };
        assert!(repetition_decides(&rep(832.0, 0.4), &o(Some((13, 43)))));
        assert!(!repetition_decides(&rep(146.0, 0.38), &o(Some((22, 49)))));
        assert!(!repetition_decides(&rep(832.0, 0.25), &o(Some((13, 43)))));
        assert!(!repetition_decides(&rep(72.0, 0.94), &o(Some((25, 50)))));
        assert!(!repetition_decides(&rep(832.0, 0.9), &o(None)));
    }
}
