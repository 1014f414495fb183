//! A given speed on a machine that runs up or coasts down during the recording: the followed mesh line
//! ends far from the given speed on average while passing through it.

use super::*;

/// Margin (fraction) by which a given speed may lie beyond the fastest or slowest revolution of a ramp
/// and still be one of its speeds: a coast-down given its start speed begins there, and its first
/// revolutions are read within a fraction of a percent (a tracked revolution's speed is good to about
/// 0.1 % on a clear line).
pub(in crate::jobs::diagnose) const RAMP_MARGIN: f64 = 0.01;

/// Whether the speed of `profile` changed over the record by more than `tolerance` (a fraction: a run-up
/// or a coast-down, not a wandering steady speed) and passed through the speed of a revolution of
/// `period` samples on the way (between its slowest and fastest revolutions, within [`RAMP_MARGIN`]).
pub(in crate::jobs::diagnose) fn passes_through(profile: &angle::SpeedProfile, period: f64, tolerance: f64) -> bool {
    profile.change.abs() > tolerance
        && super::super::compat::beyond_span(1.0 / period, [profile.min, profile.max]).abs() <= RAMP_MARGIN
}

/// Whether a followed line `t` is a run-up or coast-down through the nominal speed (a revolution of
/// `period` samples) and the given one (`given`, samples, when there is one): then its mean lies far from
/// both while the line is the machine's. A 19/53 pinion coasting from 30 to 26.4 Hz, given 1800 rpm, was
/// followed right, dropped for its mean 6 % off, averaged on a constant speed and called HEALTHY with a
/// cracked tooth. The loop must hold the line: a wrong line that a phase-locked loop holds and that moves
/// by more than the tolerance through the given speed is not a line of another source.
pub(super) fn ramp_through(t: &angle::Tracked, period: f64, given: Option<f64>, tolerance: f64) -> bool {
    let profile = angle::SpeedProfile::of(&t.map);
    t.locked
        && passes_through(&profile, period, tolerance)
        && given.is_none_or(|g| passes_through(&profile, g, tolerance))
}
