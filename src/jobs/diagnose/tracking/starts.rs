//! The tracking's starts besides the recording's own estimate: what a second start is, the baseline's
//! speed as one, and as the only one where the recording gives none.

use super::*;

/// What a second start of the tracking is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(in crate::jobs::diagnose) enum SecondStart {
    /// The best speed of a mesh comb that stands too low to confirm the given speed ([`START_COMB_DB`] to
    /// [`MIN_COMB_DB`]), beside the given speed.
    WeakComb,
    /// The mesh comb's own peak, beside the speed its followed line refined it to
    /// ([`MeshShaft::comb_peak`]).
    CombPeak,
    /// The baseline's speed, beside the recording's own estimate ([`with_baseline_start`]).
    Baseline,
}

impl SecondStart {
    /// Whether this start is kept over the first when neither followed a line: not the weak comb's best
    /// beside a given speed (the averages then run on the given speed, as the reason says); the others,
    /// beside an estimate of the recording's own, are (the baseline's speed, which its healthy recordings
    /// ran at; the comb's own peak).
    pub(in crate::jobs::diagnose) fn kept_without_lines(self) -> bool {
        self != Self::WeakComb
    }

    /// The second start and the first, as the warning names them.
    pub(in crate::jobs::diagnose) fn names(self) -> (&'static str, &'static str) {
        match self {
            Self::WeakComb => ("the comb's best speed", "the given speed"),
            Self::CombPeak => ("the mesh comb's peak", "the speed its followed line gave"),
            Self::Baseline => ("the baseline's speed", "the recording's own estimate"),
        }
    }
}

/// An estimated speed with a baseline beside it: the recording's own estimate is one start for the
/// tracking, the baseline's speed the second, and the line followed clearly higher is kept (the analysis
/// stage decides: a start whose line is not followed loses to one whose line is). The fresh 31/43
/// machine's weak repetition lay 3 % off where the baseline's speed led to the mesh line; the hold-out
/// 27/35 pinion crack's mesh comb read 1.8 % off and its line was not followed from there; the hold-out
/// 13/37 wheel crack's weak repetition was right and the baseline's speed 1.2 % from it. Only with the
/// mesh order known (the teeth or the baseline's), and when the two starts differ.
pub(super) fn with_baseline_start(mut nominal: Nominal, o: &Options, geometry: Option<&Geometry>, n: usize) -> Nominal {
    let mesh_known = o.teeth.is_some() || geometry.and_then(|g| g.mesh_order).is_some();
    let own = nominal.map.mean_period_samples();
    if let Some(p) = geometry.and_then(|g| g.period_samples).filter(|&p| {
        mesh_known && nominal.alternative.is_none() && (p / own - 1.0).abs() > MAX_TRACKING_SHIFT_ESTIMATED
    }) {
        nominal.alternative = Some((AngleMap::constant(p, 0.0, n), SecondStart::Baseline));
    }
    nominal
}

/// The baseline's revolution `period` (samples) as the start of the tracking, where the recording's own
/// evidence finds no speed near it (neither the mesh comb nor a repetition): the mesh line is then sought
/// where the baseline's was, and the speed is the followed line's when the tracking ends within the
/// speed's own wander of the start ([`track`]); otherwise the averages assume the baseline's speed and the
/// verdict says that the angle could not be followed. On the fresh hold-out 31/43 machine the mesh comb
/// of a healthy recording read seven times the speed and nothing repeated near the baseline's period, so
/// the recording was refused ("no repetition period found"). The confidence is 0: the speed is only as
/// good as the line followed, and the tracking line says how well that was. No mesh order of its own: the
/// tracking takes the given teeth's or the baseline's.
pub(super) fn from_the_baseline(period: f64, fs: Option<f64>) -> MeshShaft {
    let hz = revolution_text(period, fs);
    MeshShaft {
        period_samples: period,
        mesh_order: None,
        confidence: 0.0,
        note: format!(
            "shaft speed: neither the mesh comb nor a repetition near the baseline's revolution stands out: the mesh line is followed from the baseline's speed ({hz}); give the speed or a tachometer channel when known"
        ),
        from_comb: false,
        close_second: None,
        turns: None,
        comb_peak: None,
        assumed: None,
    }
}
