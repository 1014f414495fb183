//! The shaft found on the mesh line's angle ([`MeshShaft`]), and when no verdict of health can rest on
//! it: a comb of low confidence, a close runner-up, several turns per revolution, an assumed line.

use super::*;

/// The shaft found on the mesh line's angle.
pub(super) struct MeshShaft {
    /// Mean revolution length, samples.
    pub(super) period_samples: f64,
    /// Mesh order (cycles of the fundamental mesh per revolution), when the teeth were not given.
    pub(super) mesh_order: Option<usize>,
    /// Normalised autocorrelation at the shaft period on the mesh angle (0..1).
    pub(super) confidence: f64,
    /// What was done, for the warnings.
    pub(super) note: String,
    /// Whether the speed came from the mesh comb (its confidence is then on [`UNSURE_SPEED`]'s scale).
    pub(super) from_comb: bool,
    /// The runner-up's evidence as a share of the chosen candidate's, when it stands close enough that
    /// the speed is undecided ([`CLOSE_COMB`], [`CLOSE_CANDIDATES`]).
    pub(super) close_second: Option<f64>,
    /// Why the revolution may hold several turns of the shaft ([`turns_per_revolution`]), when it may.
    pub(super) turns: Option<String>,
    /// The mesh comb's own peak (revolution, samples), when the line followed from it refined the speed
    /// by more than [`MAX_TRACKING_SHIFT_ESTIMATED`]: a second start for the tracking. The followed line's
    /// mean covers the part of the record where it was held, and on the hold-out 16/45 healthy pinion it
    /// moved the comb's 17.36 Hz (true mean 17.32) to 17.46 Hz, the top of the speed's range, from where
    /// the mesh line's angle ended 0.8 % away and was dropped.
    pub(super) comb_peak: Option<f64>,
    /// What the speed rests on when it rests on an assumption (the strongest line read as the mesh
    /// fundamental over a comb that could not clear its own): a doubt, so no verdict of health rests on it.
    pub(super) assumed: Option<String>,
}

/// Confidence of a speed estimated from the teeth (the mesh comb's) under which no verdict of health rests
/// on it: on generated machines of another physics every wrong comb speed scored under it or called no
/// gear healthy, while the right ones on clear spectra score 0.5-1. (The autocorrelation's confidence of
/// the other routes is on another scale: a real rig's right period repeats at 0.16-0.3.)
pub(super) const UNSURE_SPEED: f64 = 0.2;
/// Normalised autocorrelation at an estimated repetition period under which no verdict of health rests on
/// it: a real rig's right periods repeat at 0.16-0.47 (the bundled SpectraQuest recordings), the wrong
/// periods taken on generated machines with a broken tooth at 0.03.
pub(super) const UNSURE_REPETITION: f64 = 0.1;

impl MeshShaft {
    /// Why no verdict of health can rest on this speed: a comb confidence under [`UNSURE_SPEED`], or a
    /// runner-up close enough that the pick between two speeds is undecided (averages on the wrong one hold
    /// no gear and look healthy).
    pub(super) fn doubt(&self) -> Option<String> {
        if self.confidence < UNSURE_SPEED && self.from_comb {
            return Some(format!(
                "the shaft speed was estimated from the teeth with confidence {:.2} (under {UNSURE_SPEED}): averages on a wrong speed hold no gear, so the indicators cannot clear it; give the shaft speed or a tachometer channel",
                self.confidence
            ));
        }
        self.close_second
            .map(|share| {
                format!(
                    "the shaft speed estimated from the teeth has a second candidate with {:.0} % of its evidence: averages on the wrong one hold no gear, so the indicators cannot clear it; give the shaft speed or a tachometer channel",
                    100.0 * share
                )
            })
            .or_else(|| self.turns.clone())
            .or_else(|| self.assumed.clone())
    }

    /// The constant nominal speed over `n` samples, its note added to `warnings`.
    pub(super) fn nominal(self, n: usize, warnings: &mut Vec<String>) -> Nominal {
        let doubt = self.doubt();
        warnings.push(self.note);
        Nominal {
            map: AngleMap::constant(self.period_samples, 0.0, n),
            source: SpeedSource::Estimated,
            confidence: self.confidence,
            mesh_order: self.mesh_order,
            doubt,
            unconfirmed_comb_db: None,
            alternative: self.comb_peak.map(|p| (AngleMap::constant(p, 0.0, n), SecondStart::CombPeak)),
        }
    }
}
