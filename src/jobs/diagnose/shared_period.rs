//! The gear of a fault on a pair whose teeth share a factor.
//!
//! A pair of z_p and z_w teeth with g = gcd(z_p, z_w) > 1 meshes the same tooth pairs every z_w / g pinion
//! revolutions (z_p / g wheel revolutions). Its pinion's lines then fall on the wheel's orders that are
//! multiples of n_w = z_w / g, and the wheel's on the pinion's orders that are multiples of n_p = z_p / g:
//! a time-synchronous average no longer averages the other gear away. A 20/40 pair's pinion crack stands
//! in the wheel's average as two equal impulses half a revolution apart, as strong as in the pinion's own,
//! and was put on the wheel; a 1:1 pair's two averages are one.
//!
//! What the other gear puts into an average lies wholly in the orders they share
//! ([`tsa::split_period`]); a gear's own local fault puts (n - 1) / n of its impulse into the other orders.
//! So the largest value of the own part of the gear's difference signal over that of its shared part is
//! n - 1 for its own impulse and near 0 for the other gear's.

use super::*;
use crate::report::format::num;
use crate::system::gcd;

/// Under this fraction of n - 1 (the ratio of the own part's largest value to the shared part's that a
/// gear's own impulse gives), the verdict gear's impulse is taken for the other gear's: on noise alone the
/// ratio is about sqrt(n - 1) (the two parts' energies), 1 to 1.4 of n - 1 for n = 2, 3; its own impulse
/// gives n - 1; 0.3 leaves room for noise under an impulse of the other gear about three times its level.
pub const BORN_ELSEWHERE: f64 = 0.3;

/// From this fraction of n - 1 the other gear's average holds an impulse of its own ...
pub const OWN_IMPULSE: f64 = 0.6;

/// ... when, moreover, that own part's largest value stands this many times over its RMS (the largest of
/// 1000-4000 points of Gaussian noise stands 3.3-3.9 times over it).
pub const OWN_STANDOUT: f64 = 5.0;

/// Under this [`LocalChange::own_share`] the verdict gear's change against the baseline is taken for the
/// other gear's (about 1 for a change of the gear's own or noise, 0 for one repeating n times per
/// revolution), unless its own orders hold an impulse ([`OWN_IMPULSE`]).
pub const CHANGE_ELSEWHERE: f64 = 0.35;

/// gcd(z, z_other) of a pinion's or wheel's average `g` and the other gear of the pair on the same channel;
/// 1 without the other gear.
fn common_factor(gears: &[GearIndicators], g: &GearIndicators) -> usize {
    let Some(other) = g.gear.partner() else { return 1 };
    gears.iter().find(|o| o.gear == other && o.channel == g.channel).map_or(1, |o| gcd(g.mesh_order, o.mesh_order))
}

/// z / gcd(z, z_other) of a pinion's or wheel's average `g` (its orders that are multiples of it are shared
/// with the other gear of the pair, on the same channel); 1 on coprime teeth or without the other gear.
pub(super) fn shared_step(gears: &[GearIndicators], g: &GearIndicators) -> usize {
    match common_factor(gears, g) {
        0 | 1 => 1,
        f => g.mesh_order / f,
    }
}

/// Whether the pair's teeth share a factor (gcd(z_p, z_w) > 1).
pub(super) fn teeth_share_a_factor(gears: &[GearIndicators]) -> bool {
    gears.iter().any(|g| g.gear == Shaft::Pinion && common_factor(gears, g) > 1)
}

/// One gear's difference signal split by the orders it shares with the other gear.
struct Split {
    /// Shared orders' step n = z / g (1: every order shared).
    n: usize,
    own_peak: f64,
    own_rms: f64,
    shared_peak: f64,
}

impl Split {
    fn of(fft: &mut Fft, g: &GearIndicators, n: usize) -> Self {
        let (own, shared) = tsa::split_period(fft, &g.difference, n);
        let peak = |x: &[f64]| x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        Self { n, own_peak: peak(&own), own_rms: ind::rms(&own), shared_peak: peak(&shared) }
    }

    /// The own part's largest value over the shared part's, in units of n - 1 (NaN when every order is
    /// shared).
    fn ownership(&self) -> f64 {
        if self.n < 2 || self.shared_peak <= 0.0 {
            return f64::NAN;
        }
        self.own_peak / self.shared_peak / (self.n - 1) as f64
    }

    /// Whether the own part holds an impulse of the gear's own.
    fn own_impulse(&self) -> bool {
        self.ownership() >= OWN_IMPULSE && self.own_peak >= OWN_STANDOUT * self.own_rms
    }
}

/// Names the gear of a suspect or faulty verdict of a single pair whose teeth share a factor: a 1:1 pair's
/// verdict is put on "pinion or wheel"; otherwise the verdict gear's impulse lying in the orders it shares
/// with the other gear moves the verdict there, and the other gear's own orders holding an impulse while
/// the verdict gear has no orders of its own moves it too. Nothing changes on a pair of coprime teeth.
pub(super) fn shared_period_evidence(d: &mut Diagnosis) {
    if d.verdict.state < VerdictState::Suspect {
        return;
    }
    let Some((this, that)) = evidence::pair_averages(d) else { return };
    let (named, other, channel) = (this.gear, that.gear, this.channel);
    let g = gcd(this.mesh_order, that.mesh_order);
    if g <= 1 {
        return;
    }
    let (zt, zo) = (this.mesh_order, that.mesh_order);
    if zt == zo {
        d.verdict.gear = VerdictGear::Either;
        // one average twice: neither holds the other's fault as cross-talk
        d.verdict.cross_talk.clear();
        d.verdict.reasons.insert(0, format!(
            "the pair's teeth are equal ({zt}/{zo}): both gears turn at one speed, so no period tells which of them is faulty (the averages of both are one); inspect both, the tooth named counted on the {named}"
        ));
        return;
    }
    let mut fft = Fft::new();
    let (mine, theirs) = (Split::of(&mut fft, this, zt / g), Split::of(&mut fft, that, zo / g));
    let mine_r = mine.ownership();
    let change = d.local_change.iter().find(|c| c.gear == named && c.channel == channel).and_then(|c| c.own_share);
    let reason = if mine_r < BORN_ELSEWHERE {
        format!(
            "the {named}'s impulse repeats {} times per {named} revolution: it lies in the orders the {named} shares with the {other} ({zt}/{zo} teeth share the factor {g}), where only a fault of the {other}, turning {} times as fast, puts one (the {named}'s own orders hold {:.2} of the n - 1 = {} their own impulse gives)",
            mine.n,
            num(zt as f64 / zo as f64),
            mine_r,
            mine.n - 1
        )
    } else if let Some(share) = change.filter(|&s| s < CHANGE_ELSEWHERE && mine_r < OWN_IMPULSE) {
        format!(
            "the {named}'s change against the baseline lies in the orders it shares with the {other} ({zt}/{zo} teeth share the factor {g}), where only a change of the {other} lands: its other orders hold {share:.2} of their share of an even change"
        )
    } else if mine.n < 2 && theirs.own_impulse() {
        format!(
            "the {other}'s average holds an impulse in its own orders ({:.2} of what its own impulse gives, {:.1} times the RMS of those orders), which the {named} cannot put there ({zt}/{zo} teeth: every {named} order is shared with the {other}, which shows a fault of the {other} as strongly as its own)",
            theirs.ownership(),
            theirs.own_peak / theirs.own_rms
        )
    } else {
        return;
    };
    let indicators = that.indicators.clone();
    evidence::name_partner(d, indicators, &reason, &reason);
}
