//! Which mesh line the tracking follows: the strongest low mesh harmonic on the channel where it stands
//! out most (and the next channel's, and a resonance-lifted higher harmonic, when none stands clear), and
//! the whole mesh comb where a single line is too weak or smeared to follow.

use super::*;

/// Height of the followed mesh line over its band under which the whole mesh comb is followed as well
/// ([`angle::comb_ridges`]) and kept when its strongest harmonic stands higher, dB: the height under which a
/// given speed counts as not confirmed. On the hold-out's 27/35 machine (a 1.7 % speed wander within a few
/// revolutions, sensor noise 0.57 of the signal) the single lines in frames of 8 revolutions stood 5-8 dB
/// over their band, noise's own height; its ninth harmonic stands 11-15 dB in frames of one revolution.
pub(super) const COMB_FALLBACK_DB: f64 = 10.0;

/// The mesh-phase tracking of the whole mesh comb of `z` teeth within +-`tolerance` of the revolution of
/// `period` samples, on the analysed channel where its line stands highest: on each channel the ridges
/// of the frame lengths are followed, the highest line first, until the phase-locked loop holds one (a
/// ridge the loop loses gives an angle that slips whole cycles of the line); the channels in turn until
/// one's line stands [`CLEAR_LINE_DB`] over its band. `None` when no channel allows it.
pub(super) fn comb_tracked(
    rec: &Recording,
    channels: &[usize],
    period: f64,
    z: usize,
    tolerance: f64,
) -> Option<angle::Tracked> {
    // channel after channel (each comb's frames are transformed in parallel): the first whose line stands
    // clear ends the search
    let mut best: Option<angle::Tracked> = None;
    for &c in channels {
        let x = &rec.channels[c - 1];
        let Ok(ridges) = angle::comb_ridges(x, period, z, tolerance) else { continue };
        let found = ridges
            .into_iter()
            .filter(|r| r.line_snr_db >= MIN_TRACKING_SNR_DB)
            .find_map(|r| angle::follow_ridge(x, r).ok().filter(|t| t.locked));
        if let Some(t) = found.filter(|t| best.as_ref().is_none_or(|b| t.line_snr_db > b.line_snr_db)) {
            let clear = t.line_snr_db >= CLEAR_LINE_DB;
            best = Some(t);
            if clear {
                break;
            }
        }
    }
    best
}

/// A channel and the mesh ridge found on it (or why none was).
pub(super) type ChannelRidge = (usize, Result<angle::MeshRidge, crate::signal::SignalError>);

/// The strongest of the first four mesh harmonics k z below 0.4 cycles per sample on a shaft of `period`
/// samples, by its line within +-0.2 orders: (its order, its amplitude); the harmonic the tracking follows
/// when one stands out. `None` when none lies below 0.4.
pub(in crate::jobs::diagnose) fn strongest_low_harmonic(x: &[f32], period: f64, z: usize) -> Option<(f64, f64)> {
    (1..=4)
        .map(|k| (k * z) as f64)
        .filter(|o| o / period < 0.4)
        .map(|o| (o, ind_line(x, o / period, 0.2 / period)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

/// The mesh ridges worth following on a shaft of `period` samples with mesh order `z`, best line first:
/// the strongest of the first four mesh harmonics below 0.4 cycles per sample (a resonance can make the
/// second ten times the first) on the channel where it stands out most against the channel's RMS; the
/// second channel's too unless the first's line stands clear of its band; and, when neither does, the
/// harmonic standing highest over its local floor (up to the 16th) on the channel where it stands highest
/// (the first four can lie under the sensor noise while a resonance lifts a higher one 10-15 dB).
pub(super) fn ridges_to_follow(rec: &Recording, channels: &[usize], period: f64, z: usize) -> Vec<ChannelRidge> {
    let mut candidates: Vec<(usize, f64, f64)> = channels
        .par_iter()
        .map(|&c| {
            let x = &rec.channels[c - 1];
            let (order, amp) = strongest_low_harmonic(x, period, z).unwrap_or((z as f64, 0.0));
            (c, order, amp / ind::rms(&x[..x.len().min(1 << 16)]).max(f64::MIN_POSITIVE))
        })
        .collect();
    candidates.sort_by(|a, b| b.2.total_cmp(&a.2));
    let ridge_of = |&(c, order, _): &(usize, f64, f64)| (c, angle::mesh_ridge(&rec.channels[c - 1], period, order));
    let clear =
        |ridges: &[ChannelRidge]| ridges.iter().any(|r| r.1.as_ref().is_ok_and(|r| r.line_snr_db >= CLEAR_LINE_DB));
    let mut ridges: Vec<_> = candidates.iter().take(1).map(ridge_of).collect();
    if !clear(&ridges) {
        ridges.extend(candidates.iter().skip(1).take(1).map(ridge_of));
        if !clear(&ridges) {
            let high = channels
                .par_iter()
                .filter_map(|&c| {
                    speed::strongest_mesh_harmonic(&rec.channels[c - 1], period, z, 0.4).map(|(o, h)| (c, o, h))
                })
                .collect::<Vec<_>>()
                .into_iter()
                .max_by(|a, b| a.2.total_cmp(&b.2));
            let tried = &candidates[..ridges.len().min(candidates.len())];
            if let Some(h) = high.filter(|h| !tried.iter().any(|t| t.0 == h.0 && t.1 == h.1)) {
                ridges.push(ridge_of(&h));
            }
        }
    }
    // the demodulation (which keeps the ridge's line height) follows the higher one, and the other when
    // that one fails
    ridges.sort_by(|a, b| match (&a.1, &b.1) {
        (Ok(x), Ok(y)) => y.line_snr_db.total_cmp(&x.line_snr_db),
        (Ok(_), Err(_)) => std::cmp::Ordering::Less,
        (Err(_), Ok(_)) => std::cmp::Ordering::Greater,
        _ => std::cmp::Ordering::Equal,
    });
    ridges
}
