//! Whether a revolution read from a mesh comb holds several turns of the shaft, or half of one: the
//! coherence of the record's halves at the orders a wrong revolution lacks or gains.

use super::*;

/// Coherence between the record's halves (`speed::Halves`) at the orders a revolution of several
/// turns lacks, under which they hold no synchronous content: on the tachometer's angle the right
/// revolutions of 273 generated recordings (the hold-out, fresh and first generators, 21 machines) kept
/// 0.76-1.0 at their odd orders, and a revolution of two true ones read -0.5 to 0.3 on 138 of the 154
/// hold-out and fresh recordings.
pub(super) const NO_SYNCHRONOUS: f64 = 0.4;
/// Coherence the orders a revolution of several turns keeps must reach: the angle follows a line of the
/// machine, its averages hold the machine (0.83-1.0 at the even orders of the hold-out and fresh recordings).
pub(super) const SYNCHRONOUS: f64 = 0.8;
/// Coherence the orders a revolution of several turns keeps must reach for the doubt
/// ([`turns_per_revolution`]): the averages hold something there. Lower than [`SYNCHRONOUS`]: the third
/// generator's broken 25/50 wheel, its revolution five wheel turns, kept 0.55 at the multiples of 5 (its
/// impacts ring the housing's kHz modes, where a 0.9 % speed fluctuation left on the followed angle blurs
/// the halves) while lacking -0.71 at the others; the 40 right revolutions of that set, teeth only, read
/// 0.52 or more at the orders that are not multiples of each d tried, so the doubt still needs both.
pub(super) const TURNS_KEPT: f64 = 0.5;
/// Coherence a shorter revolution must keep at its orders that are not multiples of its cycles of the
/// followed line (the shaft's own lines: runout, the teeth's errors, sidebands): on a signal that repeats
/// with every cycle of the line (a mesh alone on its own angle) a shorter revolution holds nothing there.
pub(super) const SHAFT_LINES: f64 = 0.5;

/// Whether a revolution of `cycles` cycles of the line `y` was resampled on ([`MESH_CYCLE_POINTS`] points
/// per cycle) is 1/`m` of a turn of the pinion (`zp` teeth, meshing with `zw`): over `m` times its length
/// the record's halves agree at the orders between the multiples of `m` as well as at the multiples (at
/// least [`SHAFT_LINES`] and [`SYNCHRONOUS`]), the shaft's own lines between those of a shaft turning `m`
/// times as fast. Two kinds of such orders are not the pinion's own:
/// - the wheel's lines: over m pinion turns the wheel's order j is order m j zp / zw, between the
///   multiples of m where zw shares a factor with m (a spalled 15/52 wheel's order 26 is order 15 of two
///   pinion turns, and read 0.96 there); left out;
/// - the multiples of one order q (not a multiple of m): when m times the revolution holds q turns of the
///   shaft, its lines are there alone (the first generator's broken 21/37 pinion, its revolution read as
///   3.5 turns: 0.80 at the odd orders of two revolutions, 0.33 without the multiples of 7). The agreement
///   must hold without the multiples of each such q up to zp.
///
/// Returns the least coherence between the multiples. m = 2, half a turn: on the fresh 24/37 machine at
/// twice its speed (the mesh's even harmonics standing over its odd ones) the odd orders read 0.65-0.91
/// with any q left out; on every right revolution of the fresh set with the teeth alone, -0.42 to 0.30.
pub(super) fn part_of_a_turn(
    fft: &mut Fft,
    y: &[f64],
    cycles: usize,
    m: usize,
    (zp, zw): (usize, usize),
) -> Option<f64> {
    if m < 2 {
        return None;
    }
    let h = speed::Halves::of(fft, y, m * cycles * MESH_CYCLE_POINTS)?;
    let between = |n: usize| between_multiples(n, m, (zp, zw));
    if h.coherence(&|n| n.is_multiple_of(m) && n > 0) < SYNCHRONOUS {
        return None;
    }
    let least = (2..=zp.max(3))
        .filter(|q| !q.is_multiple_of(m))
        .map(|q| h.coherence(&|n| between(n) && !n.is_multiple_of(q)))
        .fold(h.coherence(&between), f64::min);
    (least >= SHAFT_LINES).then_some(least)
}

/// Whether a revolution of `cycles` cycles of the line `y` was resampled on ([`MESH_CYCLE_POINTS`] points
/// per cycle) holds synchronous content at its orders between the multiples of `m` (at least
/// [`SYNCHRONOUS`]): content a shaft turning `m` times as fast cannot make, since over its `m` turns the
/// revolution holds lines at the multiples of `m` alone. The orders where that faster pinion's wheel (`zp`
/// and `zw` teeth) would put its lines are left out (as in [`part_of_a_turn`]). Returns that coherence when
/// it reaches [`SYNCHRONOUS`].
///
/// On the third generator's 29/31 machine (its second mesh harmonic 23 dB over the floor, the first 1 dB)
/// the comb of twice the speed held 60-65 % of the true comb's evidence, while the true revolution's odd
/// orders read 0.96-0.98 on all its 11 recordings; on the fresh 20/33 machine, whose comb of half the speed
/// was taken, the odd orders of that revolution (two true turns) read -0.33.
pub(super) fn lines_between_multiples(
    fft: &mut Fft,
    y: &[f64],
    cycles: usize,
    m: usize,
    (zp, zw): (usize, usize),
) -> Option<f64> {
    if m < 2 {
        return None;
    }
    let h = speed::Halves::of(fft, y, cycles * MESH_CYCLE_POINTS)?;
    let c = h.coherence(&|n| between_multiples(n, m, (zp, zw)));
    (c >= SYNCHRONOUS).then_some(c)
}

/// Whether order `n` of a revolution lies between its multiples of `m` and off the lines of the wheel
/// (`zw` teeth) of a pinion (`zp` teeth) turning `m` times in it: over m pinion turns the wheel's order j
/// is order m j zp / zw, whole where zw shares a factor with m.
fn between_multiples(n: usize, m: usize, (zp, zw): (usize, usize)) -> bool {
    !n.is_multiple_of(m) && !(n * zw).is_multiple_of(m * zp)
}

/// How many turns of the shaft a revolution may hold, and the coherences that said so.
#[derive(Clone, Copy, Debug)]
pub(super) struct Turns {
    pub(super) count: usize,
    pub(super) kept: f64,
    pub(super) lacking: f64,
}

/// Whether a revolution of `cycles` cycles of the line `y` was resampled on ([`MESH_CYCLE_POINTS`] points
/// per cycle), a pinion revolution of `zp` mesh cycles, may hold d = 2..=`most` turns of a shaft: its
/// orders that are not multiples of d hold no synchronous content ([`NO_SYNCHRONOUS`]) while those that
/// are do ([`TURNS_KEPT`]), and the revolution of 1/d of it holds lines of its own besides the supposed
/// mesh's harmonics (its orders n with n d not a multiple of zp: [`SHAFT_LINES`]). d divides `zp`: the comb
/// taken for the mesh, spaced zp orders of the revolution, is then a comb of that shaft's lines, where a d
/// that does not divide it would leave most of the comb's lines off the shaft's. The least such d is
/// returned; at most `most` turns (the mesh must stay below the highest frequency sought).
///
/// On its own a doubt, not a correction ([`faster_shaft`] corrects where the faster shaft's own comb and
/// line bear it out): a true revolution whose pinion carries little content of its own at those orders
/// reads the same (the first generator's 18/31 pinion beside a 9-blade fan: 0.17-0.26 at the orders
/// not divisible by 3, where the fresh 20/33 machine's true double revolutions read -0.33 to 0.12). The
/// third generator's broken 25/50 wheel took a comb of five wheel turns for the pinion's (its impacts a
/// line at every wheel order, the mesh one line): the orders of that revolution that are multiples of 5
/// read 0.55 ([`TURNS_KEPT`]), the others -0.71, and it was called healthy on averages 10 times too slow.
/// (The common-factor set's 20/40 machine beside a 6-blade fan read 0.89 and -0.29 at the multiples of 6
/// of its true revolution, the mesh followed on its third harmonic: 6 does not divide 20.)
pub(super) fn turns_per_revolution(
    fft: &mut Fft,
    y: &[f64],
    (cycles, zp): (usize, usize),
    most: usize,
) -> Option<Turns> {
    let period = cycles * MESH_CYCLE_POINTS;
    let whole = speed::Halves::of(fft, y, period)?;
    (2..=most.min(zp / 2)).filter(|&d| zp.is_multiple_of(d)).find_map(|d| {
        let lacking = whole.coherence(&|n| !n.is_multiple_of(d));
        let kept = whole.coherence(&|n| n.is_multiple_of(d) && n > 0);
        if lacking >= NO_SYNCHRONOUS || kept < TURNS_KEPT {
            return None;
        }
        let own = speed::Halves::of(fft, y, period / d)?.coherence(&|n| !(n * d).is_multiple_of(zp));
        (own >= SHAFT_LINES).then_some(Turns { count: d, kept, lacking })
    })
}

/// Least evidence of the faster shaft's own mesh comb, as a share of the comb first taken, for a
/// revolution of several turns to be read as that shaft's ([`faster_shaft`]): the comb of the slower
/// speed holds every line of the faster one's and more (the fresh 20/33 machine beside a 10-blade fan:
/// the half speed's comb 19.5, the true one's 8.7, 45 %).
pub(super) const FASTER_COMB_SHARE: f64 = 0.25;

/// The shaft a revolution of `count` turns ([`turns_per_revolution`]) belongs to, when the record says so.
pub(super) struct FasterShaft {
    /// The pinion's speed, cycles per sample.
    pub(super) pinion: f64,
    /// The pinion revolution on the followed line, samples.
    pub(super) period: f64,
    /// The harmonic of the mesh followed.
    pub(super) harmonic: usize,
    /// The followed line's mesh frequency, cycles per sample.
    pub(super) mesh: f64,
    /// The record on the followed line's angle.
    pub(super) line: Vec<f64>,
    /// The faster comb's evidence (nats).
    pub(super) evidence: f64,
    /// Whether the turns were the wheel's (the pinion then count zw / zp times as fast).
    pub(super) wheel: bool,
}

/// The comb's revolution of pinion speed `fp` (cycles per sample) holds `count` turns of a shaft: that
/// shaft is the pinion turning count times as fast, or the wheel (the pinion count zw / zp times as
/// fast). Each reading is taken only where the record bears it out: its speed lies within `range`, its
/// own mesh comb stands (at least [`FASTER_COMB_SHARE`] of `first_evidence`), its mesh line is followed
/// within [`COMB_AGREEMENT`] of the comb ([`comb_line`]), and on that line's angle its revolution is one turn, neither
/// several again ([`turns_per_revolution`]) nor a part of one ([`part_of_a_turn`] of 2 and of `count`).
/// Of the readings that hold, the one whose comb stands higher. (The check the other way round is what
/// a slower comb taken by mistake fails: the revolution read three times as fast is a third of a turn.)
pub(super) fn faster_shaft(
    fft: &mut Fft,
    full: &[&[f32]],
    evidence: &crate::signal::mesh_comb::CombEvidence,
    (fp, count, first_evidence): (f64, usize, f64),
    (zp, zw): (usize, usize),
    range: (f64, f64),
) -> Option<FasterShaft> {
    let (z_p, z_w) = (zp as f64, zw as f64);
    let readings = [(count as f64 * fp, false), (count as f64 * fp * z_w / z_p, true)];
    readings
        .into_iter()
        .filter(|&(f, _)| f >= range.0 && f <= range.1)
        .filter_map(|(f, wheel)| {
            let score = evidence.at(z_p * f);
            if score < FASTER_COMB_SHARE * first_evidence {
                return None;
            }
            let CombLine { harmonic, mesh, followed } = comb_line(full, evidence, z_p * f);
            let (cycle, line) = followed?;
            let cycles = zp * harmonic;
            let most = (range.1 / f).floor() as usize;
            let one_turn = turns_per_revolution(fft, &line, (cycles, zp), most).is_none()
                && part_of_a_turn(fft, &line, cycles, 2, (zp, zw)).is_none()
                && part_of_a_turn(fft, &line, cycles, count, (zp, zw)).is_none();
            let period = z_p * harmonic as f64 * cycle;
            one_turn.then_some(FasterShaft { pinion: f, period, harmonic, mesh, line, evidence: score, wheel })
        })
        .max_by(|a, b| a.evidence.total_cmp(&b.evidence))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record on the followed line's angle, 20 cycles of it per supposed revolution (`MESH_CYCLE_POINTS`
    /// points per cycle), 64 revolutions, with lines at `orders` of that revolution and noise as strong.
    fn on_the_line(orders: &[f64]) -> Vec<f64> {
        on_the_line_over(orders, 64)
    }

    /// [`on_the_line`] over `revolutions` supposed revolutions.
    fn on_the_line_over(orders: &[f64], revolutions: usize) -> Vec<f64> {
        let period = 20 * MESH_CYCLE_POINTS;
        let mut state = 11_u64;
        (0..period * revolutions)
            .map(|i| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let noise = ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5;
                let t = i as f64 / period as f64;
                let lines: f64 = orders.iter().map(|k| 0.3 * (2.0 * std::f64::consts::PI * k * t + k).sin()).sum();
                lines + 1.5 * noise
            })
            .collect()
    }

    /// The fresh 20/33 machine's case: the comb of half the speed was taken, so the supposed revolution holds
    /// two turns (every line at an even order: the shaft's own lines 2 and 6, the fan's 20, the mesh's 40)
    /// and that is said; a true revolution (lines at odd orders too), or a signal that repeats with every
    /// cycle of the line (lines at multiples of 20 only: no shaft of its own), is not doubted.
    #[test]
    fn a_revolution_of_two_turns_is_doubted() {
        let mut fft = Fft::new();
        let two = turns_per_revolution(&mut fft, &on_the_line(&[2.0, 6.0, 20.0, 40.0, 42.0]), (20, 20), 8);
        assert!(two.is_some_and(|t| t.count == 2 && t.lacking < NO_SYNCHRONOUS), "{two:?}");
        assert!(turns_per_revolution(&mut fft, &on_the_line(&[1.0, 3.0, 20.0, 21.0, 40.0]), (20, 20), 8).is_none());
        assert!(turns_per_revolution(&mut fft, &on_the_line(&[20.0, 40.0, 60.0]), (20, 20), 8).is_none());
        // a revolution of two turns would put the mesh beyond the highest frequency sought
        assert!(turns_per_revolution(&mut fft, &on_the_line(&[2.0, 6.0, 20.0, 40.0, 42.0]), (20, 20), 1).is_none());
        let why = "the estimated revolution may hold 2 turns of the shaft".to_string();
        let doubted = MeshShaft { turns: Some(why), ..super::super::estimate::tests::shaft(0.9, true, None) };
        assert!(doubted.nominal(40_000, &mut Vec::new()).doubt.is_some_and(|d| d.contains("2 turns")));
    }

    /// The third generator's broken 25/50 wheel's case: the comb taken was that of five turns of a shaft in
    /// the supposed revolution (an impact every fifth of it: lines at every multiple of 5), which is said
    /// as five turns, not two; the same lines with the shaft's own order 1 beside them are one turn, a mesh
    /// of 10 followed on its second harmonic with nothing else is no shaft at all, and neither are a fan's
    /// tones at multiples of a number that does not divide the mesh's order.
    #[test]
    fn a_revolution_of_five_turns_is_doubted() {
        let mut fft = Fft::new();
        let impacts: Vec<f64> = (1..8).map(|j| 5.0 * j as f64).collect();
        let five = turns_per_revolution(&mut fft, &on_the_line(&impacts), (20, 20), 8);
        assert!(five.is_some_and(|t| t.count == 5), "{five:?}");
        let own: Vec<f64> = impacts.iter().copied().chain([1.0]).collect();
        assert!(turns_per_revolution(&mut fft, &on_the_line(&own), (20, 20), 8).is_none());
        // 20 mesh cycles on a line of 20 cycles per revolution read as 40 (its second harmonic followed)
        assert!(turns_per_revolution(&mut fft, &on_the_line(&[10.0, 20.0, 30.0]), (20, 10), 8).is_none());
        // a 3-blade fan's tones beside a mesh of 10 followed on its second harmonic: lines at multiples of
        // 3 alone, but 3 does not divide the mesh comb's spacing of 10, so it is no comb of such a shaft
        let fan = on_the_line(&[3.0, 6.0, 9.0, 12.0, 20.0, 40.0]);
        assert!(turns_per_revolution(&mut fft, &fan, (20, 10), 8).is_none());
    }

    /// The fresh 24/37 machine's case the other way round: the comb of twice the speed was taken, so the
    /// supposed revolution is half a turn, and over twice it the shaft's own lines stand at the odd orders
    /// (orders 0.5 and 1.5 of the supposed revolution); a true revolution holds nothing there. A 20/56
    /// wheel's order 7 lies at order 2.5 of a true pinion revolution, an odd order of two of them: left
    /// out, as the wheel's, while the pinion's own lines beside it still tell half a turn. Lines at
    /// orders 3.5 and 10.5 alone (orders 7 and 21 of twice the revolution) are a shaft turning 7 times in
    /// it, not the pinion's own.
    #[test]
    fn half_a_turn_is_told_by_the_odd_orders_of_twice_it() {
        let mut fft = Fft::new();
        let half = part_of_a_turn(&mut fft, &on_the_line(&[0.5, 1.0, 1.5, 20.0]), 20, 2, (20, 56));
        assert!(half.is_some_and(|c| c >= SHAFT_LINES), "{half:?}");
        assert!(part_of_a_turn(&mut fft, &on_the_line(&[1.0, 3.0, 20.0, 21.0]), 20, 2, (20, 56)).is_none());
        let wheel = on_the_line(&[1.0, 2.5, 3.0, 20.0]);
        assert!(part_of_a_turn(&mut fft, &wheel, 20, 2, (20, 56)).is_none(), "the wheel's line is left out");
        let own = on_the_line(&[0.5, 1.0, 1.5, 2.5, 20.0]);
        assert!(part_of_a_turn(&mut fft, &own, 20, 2, (20, 56)).is_some(), "the pinion's own lines beside the wheel's");
        // twice the revolution holds 7 turns: its odd lines (orders 7 and 21 of it) are multiples of 7 alone
        let seven = on_the_line(&[1.0, 3.5, 10.5, 20.0]);
        assert!(part_of_a_turn(&mut fft, &seven, 20, 2, (20, 57)).is_none(), "the lines of a revolution of 7 turns");
        assert!(part_of_a_turn(&mut fft, &on_the_line(&[0.5, 1.0, 1.5, 3.5, 20.0]), 20, 2, (20, 57)).is_some());
    }

    /// The third generator's 29/31 machine's case: a comb of twice the speed (the mesh's second harmonic
    /// standing over its first) is a rival unless the chosen revolution holds lines at its odd orders,
    /// which a shaft turning twice as fast cannot make. A revolution of two turns (lines at even orders
    /// alone) holds none; neither does one whose only odd line is where that faster pinion's 56-tooth wheel
    /// puts its own (order 5 of two turns of a 20-tooth pinion: 5 x 56 is a multiple of 2 x 20), while a
    /// 57-tooth wheel puts nothing there, so the same line is the shaft's own.
    #[test]
    fn odd_orders_rule_out_a_shaft_twice_as_fast() {
        let mut fft = Fft::new();
        let own = lines_between_multiples(&mut fft, &on_the_line(&[1.0, 3.0, 20.0, 40.0]), 20, 2, (20, 56));
        assert!(own.is_some_and(|c| c >= SYNCHRONOUS), "{own:?}");
        let two = on_the_line(&[2.0, 6.0, 20.0, 40.0]);
        assert!(lines_between_multiples(&mut fft, &two, 20, 2, (20, 56)).is_none(), "a revolution of two turns");
        let wheel = on_the_line(&[2.0, 5.0, 20.0, 40.0]);
        assert!(lines_between_multiples(&mut fft, &wheel, 20, 2, (20, 56)).is_none(), "the faster wheel's line");
        assert!(lines_between_multiples(&mut fft, &wheel, 20, 2, (20, 57)).is_some(), "no wheel's line there");
        assert!(lines_between_multiples(&mut fft, &on_the_line(&[1.0, 20.0]), 20, 1, (20, 56)).is_none());
    }

    /// The fresh 31/43 machine's case: its mesh's seventh harmonic stands on a housing mode, so the comb
    /// of seven times the speed was taken (its lines the true mesh's 7th, 14th, ...) and the supposed
    /// revolution is a seventh of a turn; over seven of them the pinion's own lines stand at orders that
    /// are not multiples of 7 (orders 1 and 2 of the true turn: 1/7 and 2/7 of the supposed revolution).
    /// A true revolution (a mesh of 20 with the shaft's orders 1 and 3) holds nothing between the
    /// multiples of 7 of seven revolutions; neither does one whose lines between them are the wheel's (a
    /// wheel of 70 teeth turns twice in seven pinion turns: its lines fall on even orders there).
    #[test]
    fn a_seventh_of_a_turn_is_told_by_the_orders_between_the_sevenths() {
        let mut fft = Fft::new();
        let seventh = on_the_line_over(&[1.0 / 7.0, 2.0 / 7.0, 1.0, 20.0], 7 * 32);
        let told = part_of_a_turn(&mut fft, &seventh, 20, 7, (20, 43));
        assert!(told.is_some_and(|c| c >= SHAFT_LINES), "{told:?}");
        let whole = on_the_line_over(&[1.0, 3.0, 20.0, 21.0], 7 * 32);
        assert!(part_of_a_turn(&mut fft, &whole, 20, 7, (20, 43)).is_none());
        let wheel = on_the_line_over(&[2.0 / 7.0, 4.0 / 7.0, 1.0, 20.0], 7 * 32);
        assert!(part_of_a_turn(&mut fft, &wheel, 20, 7, (20, 70)).is_none(), "the wheel's lines are left out");
        assert!(part_of_a_turn(&mut fft, &seventh, 20, 1, (20, 43)).is_none(), "one turn is no part of one");
    }
}
