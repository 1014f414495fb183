//! The tooth of a verdict: a local fault's impulse in the deciding gear's difference signal (or the
//! local change against the baseline) placed on the tooth whose mesh holds it, counted from the
//! tachometer's pulse or from the tracked angle's arbitrary start.

use crate::report::format::num;
use crate::report::summary::{Diagnosis, Indicator, Score, Shaft, ToothOrigin, VerdictState};

/// How many times its share of the revolution's energy one pitch of the difference signal must hold for
/// the fault to be local and placed on a tooth: over z pitches of Gaussian noise the largest pitch holds
/// about 1.5-2 times its share (the maximum of z chi-square sums), a crack or a spall 4-10 times; a
/// distributed fault (wear, eccentricity) spreads over every tooth and is not placed.
pub(super) const LOCAL_CONCENTRATION: f64 = 3.0;

/// How the reason that a verdict names no tooth starts ([`place_tooth`]).
pub(super) const NO_TOOTH: &str = "no tooth named";

/// Puts a local fault on its tooth: the deciding gear's difference signal (its average less the mesh
/// lines) holds one impulse per revolution for a crack, a spall or a broken tooth. Counted from the
/// tachometer's pulse when the angle came from one, else from the arbitrary start of the tracked angle
/// (said so). A suspect verdict whose change against the baseline was measured and is not local names no
/// tooth: over the five generated sets (tests/holdout; nameplate and tachometer, one sibling and the
/// profile) that took the tooth off 49 suspect worn or eccentric gears and 6 local faults (3 teeth wrong
/// on the tachometer's angle, 3 counted from an arbitrary origin), and no right tooth. Nor does a faulty
/// one whose impulse measures (FM4, M6A, NA4*) all stay under their suspect limits: 18 worn or eccentric
/// gears there, no local fault (with FM4 and M6A alone 29, but 11 local faults, one right tooth).
pub(super) fn place_tooth(d: &mut Diagnosis) {
    // placed again after the verdict's gear or state moved: the last placing's word on no tooth goes
    d.verdict.reasons.retain(|r| !r.starts_with(NO_TOOTH));
    if d.verdict.state < VerdictState::Suspect {
        return;
    }
    let Some(shaft) = d.verdict.gear.pair_shaft() else { return };
    // a verdict that rests on a once-per-revolution modulation alone (SBR) is distributed: no tooth
    if over_suspect(&d.scores, &shaft).next().is_some() && !moved_for_a_tooth(&d.scores, &shaft) {
        return;
    }
    let origin =
        if d.speed_profile.tracking.tachometer_origin() { ToothOrigin::Tachometer } else { ToothOrigin::Arbitrary };
    // the local change against the baseline, when it counts, names the tooth where the average changed
    let changed = d.local_change.iter().find(|c| c.gear == shaft && c.value >= c.limit);
    if let Some(tooth) = changed.and_then(|c| c.tooth) {
        d.verdict.tooth = Some(tooth);
        d.verdict.tooth_origin = Some(origin);
        return;
    }
    // with the change against the baseline measured and not local (spread over the revolution, as wear and
    // eccentricity spread it), a suspect verdict names no tooth, nor a faulty one without an impulse
    let measured = d.local_change.iter().filter(|c| c.gear == shaft).max_by(|a, b| a.value.total_cmp(&b.value));
    let no_impulse =
        || !over_suspect(&d.scores, &shaft).any(|s| s.indicator.local() || s.indicator == Indicator::Na4Star);
    let spread = d.verdict.state == VerdictState::Suspect || no_impulse();
    if let Some(c) = measured.filter(|_| spread && changed.is_none()) {
        d.verdict.reasons.push(format!(
            "{NO_TOOTH}: the {shaft}'s change against the baseline's average is not local (its largest tooth pitch holds {} times the median pitch's energy, under the {} a local fault is counted from): a change spread over the revolution, as wear, eccentricity or a change of load spread it",
            num(c.value),
            num(c.limit)
        ));
        return;
    }
    let Some(g) = d.gears.iter().find(|g| g.gear == shaft) else { return };
    // the difference signal (first-order sidebands removed too) for an impulse; the residual (mesh lines
    // alone removed) for a smoother local fault such as a pit, whose sidebands carry it
    let Some(signal) =
        [&g.difference, &g.residual].into_iter().find(|x| concentration(x, g.mesh_order) >= LOCAL_CONCENTRATION)
    else {
        return;
    };
    if let Some(tooth) = impulse_tooth(signal, g.mesh_order) {
        d.verdict.tooth = Some(tooth);
        d.verdict.tooth_origin = Some(origin);
    }
}

/// The deciding scores of `gear` over their suspect limit.
fn over_suspect<'a>(scores: &'a [Score], gear: &'a Shaft) -> impl Iterator<Item = &'a Score> {
    scores.iter().filter(move |s| s.gear == *gear && s.over_suspect())
}

/// Whether `gear`'s own indicators moved as a fault of some tooth moves them: a deciding score over its
/// suspect limit other than a supporting one (SBR, a once-per-revolution modulation, is no tooth's).
pub(super) fn moved_for_a_tooth(scores: &[Score], gear: &Shaft) -> bool {
    over_suspect(scores, gear).any(|s| !s.indicator.supporting())
}

/// The largest energy of `x` over one pitch (of `z` per revolution) against the mean pitch's.
pub fn concentration(x: &[f64], z: usize) -> f64 {
    let n = x.len();
    if z == 0 || n < z {
        return 0.0;
    }
    let w = (n / z).max(1);
    let e: Vec<f64> = x.iter().map(|v| v * v).collect();
    let total: f64 = e.iter().sum();
    if total <= 0.0 {
        return 0.0;
    }
    let mut sum: f64 = e[..w].iter().sum();
    let mut best = sum;
    for i in 0..n {
        sum += e[(i + w) % n] - e[i];
        best = best.max(sum);
    }
    best / (total * w as f64 / n as f64)
}

/// The tooth (1-based, of `z`) whose mesh holds the impulse of `x` (one revolution of the gear's difference
/// signal, sample 0 at angle 0). The energy, smoothed over a quarter pitch (centred), peaks inside the
/// impulse; a crack's or a spall's response builds up over the tooth's mesh and rings on after it, while the
/// separation of the mesh lines leaves a little pre-echo before it, so the impulse is taken to begin where,
/// going back from the peak, the energy last rose through half of it, and the tooth is the one meshing
/// halfway between that onset and the peak. `None` when the revolution is too short to tell teeth apart.
pub fn impulse_tooth(x: &[f64], z: usize) -> Option<usize> {
    let n = x.len();
    if z == 0 || n < 4 * z {
        return None;
    }
    let w = (n / (4 * z)).max(1);
    let e: Vec<f64> = x.iter().map(|v| v * v).collect();
    let smooth: Vec<f64> = (0..n).map(|i| (0..w).map(|k| e[(i + n + k - w / 2) % n]).sum::<f64>()).collect();
    let (peak_at, peak) =
        smooth.iter().enumerate().fold((0, f64::NEG_INFINITY), |a, (i, &v)| if v > a.1 { (i, v) } else { a });
    // back from the peak while the energy stays above half of it, at most one pitch
    let pitch = n / z;
    let mut back = 0;
    for k in 1..=pitch {
        if smooth[(peak_at + n - k) % n] < 0.5 * peak {
            break;
        }
        back = k;
    }
    let centre = (peak_at + n - back / 2) % n;
    Some(centre * z / n + 1)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A decaying ring starting at the start of tooth `k`'s pitch of `z` (what a crack's stiffness drop
    /// excites) on a revolution of `n` samples, plus a small even ripple over every tooth.
    pub(in crate::jobs::diagnose) fn ring(n: usize, z: usize, k: usize) -> Vec<f64> {
        let start = (k - 1) * n / z;
        (0..n)
            .map(|i| {
                let t = ((i + n - start) % n) as f64 / (n / z) as f64; // in pitches after the onset
                let ripple = 0.05 * (2.0 * std::f64::consts::PI * (z * i) as f64 / n as f64 * 3.0).sin();
                ripple + if t < 3.0 { (-1.2 * t).exp() * (2.0 * std::f64::consts::PI * 2.1 * t).sin() } else { 0.0 }
            })
            .collect()
    }

    #[test]
    fn an_impulse_is_placed_on_the_tooth_where_it_starts() {
        // the tooth under the first pitch of the ring: its energy peaks within the first pitch and decays
        // over the next two, so the half-way point between onset and peak lies in tooth k's pitch
        for (n, z, k) in [(512, 14, 3), (1024, 23, 17), (2048, 47, 1), (1024, 29, 29)] {
            let x = ring(n, z, k);
            assert_eq!(impulse_tooth(&x, z), Some(k), "n {n} z {z} k {k}");
            assert!(concentration(&x, z) > LOCAL_CONCENTRATION, "{}", concentration(&x, z));
        }
    }

    #[test]
    fn an_even_signal_is_not_local() {
        // a pure mesh-rate ripple spreads its energy evenly over the teeth: every pitch holds its share
        let (n, z) = (1024, 23);
        let x: Vec<f64> =
            (0..n).map(|i| (2.0 * std::f64::consts::PI * (z * i) as f64 / n as f64 * 2.0).cos()).collect();
        let c = concentration(&x, z);
        assert!((c - 1.0).abs() < 0.1, "{c}");
        assert_eq!(impulse_tooth(&x[..40], z), None, "too short a revolution to place a tooth");
    }
}
