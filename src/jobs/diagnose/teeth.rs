//! The teeth checked and estimated: given teeth against the TSA's sideband family, the wheel's count
//! against its sidebands on the pinion's angle, the meshing gear's count estimated from them, and the mesh
//! order of a harmonic family.

use super::*;

/// A warning when the given teeth do not fit: the mesh family at the order z (the lines at z, 2z, 3z, 4z,
/// summed over channels) must hold more power than the family of any order of its +-1..3 sideband range, as
/// a mesh does; a stronger family says the mesh is elsewhere (13 or 15 given for 14 teeth, or the pinion and
/// wheel swapped). A family, not the single line: a fan's second harmonic at order 14 on a generated 17/29
/// machine with a 7-blade fan stood 8-28 times the line at 17, whose power lies in its higher harmonics
/// (a housing resonance), and the right teeth were called wrong. The other family must hold
/// [`MISFIT_POWER`] times the power. A tone locked to the shaft within +-3 orders of the mesh stays
/// ambiguous (on the hold-out's 13/37 machine an 11-blade fan stood 4.5-41 times over the mesh family):
/// the meshing gear's averages cannot settle it, since at the given ratio they hold every order z m of this
/// shaft at their own mesh order's multiples, a mesh's or not; so the warning names that alternative.
pub(super) fn teeth_misfit<'a>(tsas: impl Iterator<Item = &'a [f64]>, z: usize, gear: Shaft) -> Option<String> {
    let mut power: Vec<f64> = Vec::new();
    for t in tsas {
        let a = crate::signal::spectrum::periodic_amplitudes(t);
        power.resize(a.len(), 0.0);
        power.iter_mut().zip(&a).for_each(|(p, v)| *p += v * v);
    }
    let family = |k: usize| (1..=4).map(|m| power.get(m * k).copied().unwrap_or(0.0)).sum::<f64>();
    let (best, f_best) =
        (z.saturating_sub(3).max(1)..=z + 3).map(|k| (k, family(k))).max_by(|a, b| a.1.total_cmp(&b.1))?;
    let ratio = f_best / family(z).max(f64::MIN_POSITIVE);
    (best != z && ratio > MISFIT_POWER).then(|| {
        format!(
            "the given teeth do not fit the {gear}: its TSA lines at orders {best}, {}, {}, {} hold {ratio:.1} times the power of those at the given mesh order {z} and its harmonics (a mesh family stands above its sidebands); check the given teeth, unless a tone locked to the {gear}'s shaft stands there (a fan or impeller of {best} blades, which the averages cannot tell from a mesh)",
            2 * best,
            3 * best,
            4 * best,
        )
    })
}

/// Power ratio of another order's mesh family over the given one's from which the given teeth are said not
/// to fit: on the bundled cracked 14/39 recording, 13, 15 and 39 given for the pinion's 14 put the true
/// family 30, 10 and 6.9 times over the given one; a broken tooth's once-per-revolution impulse spreads
/// over every shaft order and lifted a neighbouring family to 2.0 and 3.2 times the mesh's on the generated
/// 17/29 machine (with the tachometer's angle), with the right teeth given.
const MISFIT_POWER: f64 = 4.5;

/// Largest share of the mesh line at order `z` in a line at order `k z` (k = 2, 3, 4) for the tachometer's
/// pulses per revolution to be taken as too many: a resonance near twice the mesh makes the first mesh
/// line 7-10 % of the second on the bundled scenes (`MESH_FUNDAMENTAL_SHARE` of the tracking), while a
/// revolution that really spans k revolutions has no line at all at order z (0.1 % on the bundled healthy
/// recording with 2 pulses per revolution given for 1): 1 % lies between the two. The same holds for every
/// mesh harmonic that is not a multiple of k z.
const PULSES_TOO_MANY_SHARE: f64 = 0.01;

/// Ratio by which a line at order z / k must exceed the mesh line for the tachometer to have k times more
/// pulses per revolution than given: a revolution that is really 1/k revolution puts the mesh fundamental
/// there, and the given mesh order holds only its k-th harmonic.
const PULSES_TOO_FEW_RATIO: f64 = 3.0;

/// Where the pinion's TSAs (revolutions of the given tachometer pulses) put the mesh line of `z` teeth when
/// it is not at order z: at order k z when the line is missing at z (each averaged "revolution" spans k
/// revolutions: fewer pulses per revolution than given, or pulses missing), or at order z / k when that
/// line stands well above the one at z (more pulses per revolution than given). `None` when the line is
/// where the teeth put it or no other order explains the lines better.
pub(super) fn pulses_misfit<'a>(tsas: impl Iterator<Item = &'a [f64]>, z: usize) -> Option<usize> {
    let mut power: Vec<f64> = Vec::new();
    for t in tsas {
        let a = crate::signal::spectrum::periodic_amplitudes(t);
        power.resize(power.len().max(a.len()), 0.0);
        power.iter_mut().zip(&a).for_each(|(p, v)| *p += v * v);
    }
    let at = |k: usize| power.get(k).copied().unwrap_or(0.0).sqrt();
    let mesh = at(z);
    // an average spanning k revolutions holds the mesh family at the multiples of k z only: every harmonic
    // m z (m = 1..4) that is not one of them must be missing, not only the first (a housing resonance can
    // lift the fourth harmonic a hundred times over the first while the second and third still stand)
    let spans = (2..=4usize).filter(|&k| k * z < power.len()).map(|k| k * z).find(|&o| {
        (1..=4usize)
            .map(|m| m * z)
            .filter(|&h| h < power.len() && h % o != 0)
            .all(|h| at(h) < PULSES_TOO_MANY_SHARE * at(o))
    });
    // a line at z / k is the mesh only when it stands clear of the orders beside it too: on an average of
    // 1/k revolution the shaft's own orders (the mesh's sidebands) fall between whole orders and average
    // out, while on a true revolution a line at z / k among its neighbours is one of the shaft's harmonics
    // (a worn 27-tooth pinion's order 9 stood over its weakened mesh line on a generated machine)
    let clear = |o: usize| o + 1 < power.len() && at(o) > PULSES_TOO_FEW_RATIO * at(o - 1).max(at(o + 1));
    // and a line at z / k is one of a mesh family only when the family's other members that a true revolution
    // would not hold (the multiples m z / k, m not a multiple of k: the mesh harmonics 3, 5, 7 at k = 2) stand
    // clear too, two of the first three: a fan of z / k blades on the shaft puts a line at z / k clear of its
    // neighbours, with a harmonic or two, over a weak mesh line (a generated 18-tooth pinion with a 9-blade fan)
    // (and over 1 % of the line at z / k, so that rounding beside nothing is not a line)
    let member = |o: usize, m: usize| clear(m * o) && at(m * o) > PULSES_TOO_MANY_SHARE * at(o);
    let family = |k: usize, o: usize| (2..).filter(|m| m % k != 0).take(3).filter(|&m| member(o, m)).count() >= 2;
    let part = (2..=4usize)
        .filter(|k| z.is_multiple_of(*k))
        .map(|k| (k, z / k))
        .find(|&(k, o)| at(o) > PULSES_TOO_FEW_RATIO * mesh && at(o) > 0.0 && clear(o) && family(k, o))
        .map(|(_, o)| o);
    spans.or(part)
}

/// Smallest ratio of a wheel sideband to the floor around its mesh harmonic to count as present (12 dB).
const WHEEL_LINE_OVER_FLOOR: f64 = 4.0;

/// Ratio by which another wheel's sidebands must exceed the given wheel's for the given teeth to be
/// called wrong: a neighbouring count (38 for 39) falls a few bins from the true lines on a record of a few
/// hundred revolutions, where the Hann window's skirt still reads a strong line at a third of its height.
const WHEEL_MISFIT_RATIO: f64 = 3.0;

/// Ratio of another wheel's +-1 sidebands over the given wheel's beyond which the averages are doubted
/// (no verdict of health rests on them), ten times the warning's [`WHEEL_MISFIT_RATIO`]: noise-level
/// sidebands of a true-running wheel let another count stand up to 3-4 times (gearvib's own drifting
/// healthy recordings, the hold-out's broken wheel on its tachometer: 4.1), and up to 24 times on the
/// hold-out's teeth-only runs; a speed a third off on the bundled cracked pinion puts the pinion's own
/// sidebands on a count 197 times stronger (275 at +5.6 %, 1446 at twice the speed).
pub(super) const WHEEL_DOUBT_RATIO: f64 = 30.0;

/// Most revolutions [`other_gear_scan`] transforms at once: 4096 resolve 1/4096 of an order (the lines it
/// reads are at least 1/200 of an order from a whole one), and their padded baseband takes 8 MB where a
/// one-hour record's whole would take half a gigabyte (a record of up to 4096 revolutions is read whole).
const SCAN_REVS: usize = 4096;

/// One count of the other gear scored by [`other_gear_scan`].
#[derive(Clone, Copy, Debug)]
struct GearLines {
    /// Teeth of the other gear.
    teeth: usize,
    /// Summed ln(line / floor) of its +-1 lines that stand [`WHEEL_LINE_OVER_FLOOR`] over their floor.
    first_score: f64,
    /// How many of its +-1 lines stand there.
    first_present: usize,
    /// How many of its +-1 lines were read (not on a whole order of the tracked shaft, inside the band).
    first_read: usize,
    /// Summed amplitude of its +-1 lines.
    first_amplitude: f64,
    /// The score of its +-2 and +-3 lines.
    more_score: f64,
}

impl GearLines {
    fn score(&self) -> f64 {
        self.first_score + self.more_score
    }

    /// Whether its +-1 lines stand: two at least, and three quarters of those read.
    fn stands(&self) -> bool {
        self.first_present >= 2 && 4 * self.first_present >= 3 * self.first_read
    }
}

/// The other gear's lines around the first two mesh harmonics, read on the tracked shaft's angle over
/// the whole record ([`angle::baseband_lines`]; a long one in parts of at most [`SCAN_REVS`] revolutions
/// averaged in power): the tracked shaft meshes with z teeth, so another gear
/// of n teeth turns at z / n of its speed and puts its lines at k z +- j z / n orders. Every count n from
/// 8 to 200 (and `extra`) other than z is scored by its lines j = +-1 (which run-out, eccentricity and
/// local faults all give) and +-2..3 that stand [`WHEEL_LINE_OVER_FLOOR`] over their local floor (lines
/// within 12 resolution bins of a whole order of the tracked shaft are its own and do not count, nor
/// lines beyond the +-7 orders read). None when the record is shorter than 16 revolutions or no mesh
/// harmonic lies below 0.45 of the sample rate.
fn other_gear_scan(x: &[f32], map: &AngleMap, z: usize, extra: Option<usize>) -> Option<Vec<GearLines>> {
    const PER_REV: usize = 16;
    let period = map.mean_period_samples();
    // a record longer than SCAN_REVS revolutions is read in equal parts of at most that many, whose
    // amplitudes are averaged in power (the parts' bins fall on the same orders)
    let parts = map.revolutions().div_ceil(SCAN_REVS).max(1);
    let part = map.revolutions() / parts;
    let revs = part as f64;
    // the two harmonics' basebands in parallel
    let harmonics: Vec<Vec<f64>> = (1..=2usize)
        .into_par_iter()
        .filter(|k| ((k * z) as f64 + 4.0) / period < 0.45)
        .map(|k| {
            let order = (k * z) as f64;
            let mut fft = Fft::new();
            if parts == 1 {
                return angle::baseband_lines(&mut fft, x, map, order, PER_REV);
            }
            let mut power: Vec<f64> = Vec::new();
            for p in 0..parts {
                let a = angle::baseband_lines_over(&mut fft, x, map, order, PER_REV, p * part..(p + 1) * part);
                power.resize(a.len(), 0.0);
                power.iter_mut().zip(&a).for_each(|(s, v)| *s += v * v / parts as f64);
            }
            power.iter().map(|p| p.sqrt()).collect()
        })
        .filter(|a: &Vec<f64>| !a.is_empty())
        .collect();
    if harmonics.is_empty() || revs < 16.0 {
        return None;
    }
    let m = harmonics[0].len();
    let bin = |d: f64| ((d * m as f64 / PER_REV as f64).round() as isize).rem_euclid(m as isize) as usize;
    // padded bins per resolution bin (1 / revs orders); a line's floor is the median of 3..12 resolution
    // bins each side (outside the Hann main lobe of +-2), so the skirt of the mesh line is not a line
    let per_bin = m as f64 / (PER_REV as f64 * revs);
    let floor = |a: &[f64], centre: usize| -> f64 {
        let (inner, outer) = ((3.0 * per_bin) as isize, (12.0 * per_bin) as isize);
        let mut near: Vec<f64> = (inner..=outer)
            .flat_map(|o| [centre as isize + o, centre as isize - o])
            .map(|i| a[i.rem_euclid(m as isize) as usize])
            .collect();
        near.sort_by(f64::total_cmp);
        near[near.len() / 2].max(f64::MIN_POSITIVE)
    };
    // (score, lines present, lines read, summed amplitude) of n teeth on the lines j
    let lines = |n: usize, js: &[i32]| -> (f64, usize, usize, f64) {
        let (mut score, mut present, mut read, mut sum) = (0.0, 0, 0, 0.0);
        for a in &harmonics {
            for &j in js {
                let d = j as f64 * z as f64 / n as f64;
                if (d - d.round()).abs() < 12.0 / revs || d.abs() > PER_REV as f64 / 2.0 - 1.0 {
                    continue;
                }
                let k = bin(d);
                read += 1;
                sum += a[k];
                let over = a[k] / floor(a, k);
                if over >= WHEEL_LINE_OVER_FLOOR {
                    present += 1;
                    score += over.ln();
                }
            }
        }
        (score, present, read, sum)
    };
    let counts = (8..=200).chain(extra.filter(|n| !(8..=200).contains(n)));
    Some(
        counts
            .filter(|&n| n != z)
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|n| {
                let (first_score, first_present, first_read, first_amplitude) = lines(n, &[-1, 1]);
                GearLines {
                    teeth: n,
                    first_score,
                    first_present,
                    first_read,
                    first_amplitude,
                    more_score: lines(n, &[-3, -2, 2, 3]).0,
                }
            })
            .collect(),
    )
}

/// The best-scoring count of a scan among those with at least three quarters of their +-1 lines present
/// (and at least two).
fn best_other_gear(scan: &[GearLines]) -> Option<GearLines> {
    scan.iter().copied().filter(GearLines::stands).max_by(|a, b| a.score().total_cmp(&b.score()))
}

/// What the given wheel teeth's check says when it has something to say.
#[derive(Debug, PartialEq)]
pub(super) enum WheelCheck {
    /// No count has its +-1 sidebands: the teeth could not be checked (a true-running wheel shows none).
    Unchecked(String),
    /// Another count's sidebands stand `ratio` ([`WHEEL_MISFIT_RATIO`] or more) times stronger: the given
    /// teeth, or the speed the averages rest on, do not fit the recording.
    Misfit {
        /// The warning.
        text: String,
        /// The best count's +-1 sidebands over the given count's (amplitude ratio).
        ratio: f64,
    },
}

impl WheelCheck {
    /// The warning's text.
    pub(super) fn text(&self) -> &str {
        match self {
            Self::Unchecked(text) | Self::Misfit { text, .. } => text,
        }
    }
}

/// The given wheel teeth checked against the wheel's sidebands on the pinion's angle ([`other_gear_scan`]
/// with z = zp): a misfit when the best count's +-1 sidebands are [`WHEEL_MISFIT_RATIO`] times stronger
/// than the given count's, unchecked when no count has its +-1 lines, else nothing to say.
pub(super) fn wheel_teeth(x: &[f32], map: &AngleMap, zp: usize, zw: usize) -> Option<WheelCheck> {
    let scan = other_gear_scan(x, map, zp, Some(zw))?;
    // a count dividing the given one puts its +-1 lines on the given wheel's +-(zw / n) lines, which a local
    // wheel fault lifts as much as its first ones (the hold-out's broken 45-tooth wheel: its +-5 lines, a
    // wheel of 9's +-1, stood 4 times over its +-1 lines through the housing's resonance): they fit the given
    // teeth and cannot contradict them (a given count twice the true one goes unflagged: its averages span
    // two revolutions and still hold the wheel's faults)
    let (scan, divisors): (Vec<GearLines>, Vec<GearLines>) =
        scan.into_iter().partition(|g| g.teeth == zw || !zw.is_multiple_of(g.teeth));
    let Some(best) = best_other_gear(&scan) else {
        return Some(WheelCheck::Unchecked(match best_other_gear(&divisors) {
            Some(d) => format!(
                "the wheel's teeth ({zw}) could not be checked on its first sidebands: only lines at +-{:.4} pinion orders stand, the given wheel's +-{} sidebands (which fit it)",
                zp as f64 / d.teeth as f64,
                zw / d.teeth
            ),
            None => format!(
                "the wheel's teeth ({zw}) could not be checked: no wheel's +-1 sidebands stand 12 dB above their floor around the first two mesh harmonics (a true-running healthy wheel shows none)"
            ),
        }));
    };
    let first = scan.iter().find(|g| g.teeth == zw).map_or(0.0, |g| g.first_amplitude);
    let ratio = best.first_amplitude / first.max(f64::MIN_POSITIVE);
    (best.teeth != zw && ratio > WHEEL_MISFIT_RATIO).then(|| WheelCheck::Misfit {
        text: format!(
            "the given wheel teeth ({zw}) do not fit: the mesh's sidebands stand at +-{:.4} pinion orders, a wheel of {} teeth, {ratio:.1} times those a wheel of {zw} would give; check the given teeth",
            zp as f64 / best.teeth as f64,
            best.teeth,
        ),
        ratio,
    })
}

/// Smallest confidence of an estimate of the other gear's teeth that is reported as an estimate (below,
/// the best count is named as unconfirmed): the bundled eccentric wheel reaches 0.68 and eccentric wheels
/// of other pairs 0.6-0.9; the spurious lines of the bundled rectangular-stiffness recording (no wheel
/// error at all) 0.05, and the real SpectraQuest recordings at 90 % load 0.30-0.33 (a count of 40 on
/// lines 18-19 dB over their floor, not confirmed).
pub(super) const MIN_OTHER_GEAR_CONFIDENCE: f64 = 0.5;

/// The other gear's teeth estimated from its sidebands on the tracked shaft's angle (mesh order z): the
/// best count of [`other_gear_scan`]. Its confidence (0..1) is the product of
/// - the share of its +-1 lines present;
/// - their strength: 1 - exp(-e / 2), e the mean of ln(line / floor) - ln 4 over the present lines (how
///   far they stand above the 12 dB needed; 0.07 for lines at 13 dB, 0.5 at 24 dB, 0.89 at 51 dB);
/// - its margin: 1 - r / s, s its score and r the best score of a count that qualifies too and shares none
///   of its lines (counts whose +-1..3 lines fall within 3 resolution bins of its +-1 lines, or whose +-1
///   lines fall on its +-2..3, are harmonics or neighbours of the same lines).
pub(super) fn other_gear_teeth(x: &[f32], map: &AngleMap, z: usize) -> Option<OtherGear> {
    let scan = other_gear_scan(x, map, z, None)?;
    let best = best_other_gear(&scan)?;
    let near = 3.0 / map.revolutions() as f64;
    let d = |n: usize| z as f64 / n as f64;
    let shares = |g: &GearLines| {
        (1..=3).any(|j| {
            let j = j as f64;
            (j * d(g.teeth) - d(best.teeth)).abs() <= near || (d(g.teeth) - j * d(best.teeth)).abs() <= near
        })
    };
    let rival = scan
        .iter()
        .filter(|g| g.first_present >= 2 && 4 * g.first_present >= 3 * g.first_read && !shares(g))
        .map(GearLines::score)
        .fold(0.0, f64::max);
    let margin = (1.0 - rival / best.score()).clamp(0.0, 1.0);
    let mean_db = 20.0 * best.first_score / best.first_present as f64 / std::f64::consts::LN_10;
    let excess = best.first_score / best.first_present as f64 - WHEEL_LINE_OVER_FLOOR.ln();
    let strength = 1.0 - (-0.5 * excess.max(0.0)).exp();
    let share = best.first_present as f64 / best.first_read.max(1) as f64;
    Some(OtherGear {
        teeth: best.teeth,
        confidence: share * strength * margin,
        sideband_orders: d(best.teeth),
        line_over_floor_db: mean_db,
    })
}

/// Mesh order: the family z (z >= 8) whose first harmonics hold the most TSA energy per harmonic, summed
/// over channels.
pub(super) fn mesh_family<'a>(fft: &mut Fft, tsas: impl Iterator<Item = &'a [f64]>) -> usize {
    let power = family_power(fft, tsas);
    let half = power.len().saturating_sub(1);
    (8..=(half / 2).max(8))
        .max_by(|&a, &b| {
            let score = |z: usize| {
                let h = (half / z).clamp(1, 4);
                (1..=h).map(|k| power.get(k * z).copied().unwrap_or(0.0)).sum::<f64>() / h as f64
            };
            score(a).total_cmp(&score(b))
        })
        .unwrap_or(8)
}

/// Each order's share of its average's power (orders 1 and up), summed over the averages `tsas`.
fn family_power<'a>(fft: &mut Fft, tsas: impl Iterator<Item = &'a [f64]>) -> Vec<f64> {
    let mut power: Vec<f64> = Vec::new();
    for t in tsas {
        let a = crate::signal::spectrum::periodic_amplitudes_with(fft, t);
        let total: f64 = a.iter().skip(1).map(|v| v * v).sum::<f64>().max(f64::MIN_POSITIVE);
        power.resize(a.len(), 0.0);
        for (p, v) in power.iter_mut().zip(&a) {
            *p += v * v / total;
        }
    }
    power
}

/// Power of a mesh family's odd harmonics (z, 3z) over its even ones (2z, 4z) under which an estimated
/// family z may be the family 2z: the even harmonics carry the family's score then, and 2z explains them
/// alone. The averages cannot tell the two apart, so this only says so. 1/30 (-15 dB): on the real
/// SpectraQuest rig (its pair repeats every five pinion revolutions, which 32 and 80 teeth fit) the family 16
/// estimated at 90 % load has its odd harmonics 19-24 dB under, while 32 is estimated at 0 % load; the
/// bundled 14/39 scenes, whose resonance lifts the second mesh harmonic, read 15-18 dB without the teeth
/// (the warning is right there too: only the teeth say 14).
const ODD_HARMONICS_SHARE: f64 = 1.0 / 30.0;

/// When the estimated mesh family `z` could be the family `2z`: the odd harmonics' power over the even ones'
/// on the averages `tsas` (dB, negative), under [`ODD_HARMONICS_SHARE`]; `None` when they stand above it or
/// the family 2z does not fit the averages.
pub(super) fn doubled_family<'a>(fft: &mut Fft, tsas: impl Iterator<Item = &'a [f64]>, z: usize) -> Option<f64> {
    let power = family_power(fft, tsas);
    let at = |k: usize| power.get(k * z).copied();
    let even = at(2)? + at(4).unwrap_or(0.0);
    let odd = at(1)? + at(3).unwrap_or(0.0);
    (even > 0.0 && odd < ODD_HARMONICS_SHARE * even).then(|| 10.0 * (odd.max(f64::MIN_POSITIVE) / even).log10())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    /// An average of `points` samples holding cosines of the given (order, amplitude).
    fn average(points: usize, lines: &[(usize, f64)]) -> Vec<f64> {
        (0..points)
            .map(|i| lines.iter().map(|&(o, a)| a * (TAU * o as f64 * i as f64 / points as f64).cos()).sum())
            .collect()
    }

    /// A family 16 whose odd harmonics (16, 48: amplitudes 0.05, 0.04) lie far under its even ones (32, 64:
    /// 1.0, 0.6) may be the family 32: the doubt is given with the power ratio 10 log10((0.05^2 + 0.04^2) /
    /// (1 + 0.36)) = -28.1 dB; a family whose fundamental stands (0.5 against 1.0) is not doubted.
    #[test]
    fn a_family_carried_by_its_even_harmonics_is_doubted() {
        let weak_odd = average(512, &[(16, 0.05), (32, 1.0), (48, 0.04), (64, 0.6)]);
        let db = doubled_family(&mut Fft::new(), std::iter::once(weak_odd.as_slice()), 16).unwrap();
        let expected = 10.0 * ((0.05f64.powi(2) + 0.04f64.powi(2)) / 1.36).log10();
        // the lines are whole orders of the average: read exactly, to rounding
        assert!((db - expected).abs() < 1e-6, "{db} against {expected}");
        let standing = average(512, &[(16, 0.5), (32, 1.0), (48, 0.2), (64, 0.6)]);
        assert_eq!(doubled_family(&mut Fft::new(), std::iter::once(standing.as_slice()), 16), None);
    }

    /// Two pulses per revolution given as one on a 28-tooth pinion: each average spans half a revolution,
    /// so the mesh (fundamental 1, harmonics 0.1-0.3) stands at orders 14, 28, 42, 70, 98 with nothing
    /// beside it (the shaft's orders fall between whole ones): order 14 is found. A worn 27-tooth pinion,
    /// averaged right, whose mesh line (0.2) lies under its shaft harmonic 9 (1.0, beside orders 8 and 10
    /// at 0.5), that harmonic alone, or a fan tone of 9 blades with two harmonics over an 18-tooth mesh:
    /// not taken for a fraction of a revolution, since no mesh family stands at the multiples of 9.
    #[test]
    fn a_mesh_at_a_fraction_of_the_order_must_stand_clear_of_its_neighbours() {
        // half a revolution averaged: the mesh family of 14 teeth at the multiples of 14 of the 28 given
        let half = average(1024, &[(14, 1.0), (28, 0.2), (42, 0.3), (70, 0.2), (98, 0.1)]);
        assert_eq!(pulses_misfit(std::iter::once(half.as_slice()), 28), Some(14));
        let worn = average(1024, &[(8, 0.5), (9, 1.0), (10, 0.5), (27, 0.2), (54, 0.5), (81, 0.2)]);
        assert_eq!(pulses_misfit(std::iter::once(worn.as_slice()), 27), None);
        // a shaft harmonic standing alone is not a mesh family: neither is a 9-blade fan's tone with two
        // harmonics over a weak mesh line of 18 teeth on a true revolution
        let alone = average(1024, &[(9, 1.0), (27, 0.2), (54, 0.5), (81, 0.2)]);
        assert_eq!(pulses_misfit(std::iter::once(alone.as_slice()), 27), None);
        let fan = average(1024, &[(9, 1.0), (18, 0.2), (27, 0.15), (36, 0.1), (54, 0.05)]);
        assert_eq!(pulses_misfit(std::iter::once(fan.as_slice()), 18), None);
        // a third of a revolution: the mesh family of 9 at the multiples of 9 of the 27 given
        let third = average(1024, &[(9, 1.0), (18, 0.3), (27, 0.2), (36, 0.2), (45, 0.1), (54, 0.5)]);
        assert_eq!(pulses_misfit(std::iter::once(third.as_slice()), 27), Some(9));
    }

    /// A 14-tooth pinion meshing with a 39-tooth wheel over 5000 revolutions, more than [`SCAN_REVS`]: the
    /// scan reads it in two parts of 2500 averaged in power and still finds the wheel's +-1 sidebands
    /// (0.1 of the mesh line, against uniform noise of 0.05 RMS): 39 teeth fit, 45 are said not to.
    #[test]
    fn a_long_record_is_scanned_in_parts() {
        let (period, revs) = (64.0, 5000usize);
        let n = (period * revs as f64) as usize + 1;
        let mut uniform = crate::signal::test_noise::uniform_noise(3);
        let x: Vec<f32> = (0..n)
            .map(|i| {
                let noise = uniform() * 12f64.sqrt();
                let th = i as f64 / period;
                let side = 14.0 / 39.0;
                ((TAU * 14.0 * th).cos()
                    + 0.1 * (TAU * (14.0 - side) * th).cos()
                    + 0.1 * (TAU * (14.0 + side) * th + 0.3).cos()
                    + 0.05 * noise) as f32
            })
            .collect();
        let map = AngleMap::constant(period, 0.0, n);
        assert!(map.revolutions() > SCAN_REVS);
        assert_eq!(wheel_teeth(&x, &map, 14, 39), None);
        let w = wheel_teeth(&x, &map, 14, 45).expect("45 teeth do not fit");
        assert!(matches!(&w, WheelCheck::Misfit { text, .. } if text.contains("a wheel of 39 teeth")), "{w:?}");
    }
}
