//! What a baseline of a single healthy file cannot show: how far recordings made apart, at another
//! operating point, differ. Its blocks share one hour, temperature and load, so their scatter (and its
//! halves' difference) is all it holds; a later recording at a neighbouring load moves the indicators
//! further than that without any fault. From one file the limits keep an allowance for that move.
//!
//! Source of every figure: the real SpectraQuest rig (`data/realdata`, SOURCE.md; the 20 files of
//! kokikwbt/predictive-maintenance `datasets/gfd`), each healthy file judged against the healthy file of
//! each neighbouring load (10 % of the rated load apart, 18 comparisons, 4 channels, the shaft period
//! estimated). The allowance is 1.25 times the largest rise of the recording's median over the baseline's
//! median seen there; the rig's broken tooth stands 18-37 spreads over its own load's healthy file on the
//! spectral change (5-15 dB), far beyond these.

use super::{MEDIAN_SCATTER, Reference, Stat};
use crate::report::summary::Indicator;

/// Factor on the largest rise seen on the rig between neighbouring loads.
const MARGIN: f64 = 1.25;

/// How far a healthy recording's median may rise over a single baseline file's, on the indicator's
/// scale (natural log of the ratio; dB for the spectral change), for a change of operating point. The
/// largest rises on the rig (log): FM0 0.30 (30 % against 40 %: the mesh harmonics grew 67 % with the
/// load, the peak-to-peak less), FM4 0.15, M6A 0.36, NA4* 0.65, ER 0.16, SER 0.32, SBR 0.56, SI 0.59;
/// the spectral change 1.21 dB. Before this allowance FM0 (5.3 spreads) and the spectral change (3.8)
/// called one of those healthy files suspect.
pub fn allowance(k: Indicator) -> f64 {
    let largest = match k {
        Indicator::Fm0 => 0.30,
        Indicator::Fm4 => 0.15,
        Indicator::M6a => 0.36,
        Indicator::Na4Star => 0.65,
        Indicator::Er => 0.16,
        Indicator::Ser => 0.32,
        Indicator::Sbr => 0.56,
        Indicator::Si => 0.59,
        Indicator::SpectralChange => 1.21,
        _ => 0.0,
    };
    MARGIN * largest
}

/// The least sideband growth that counts against a single file. On the rig 4 of the 18 comparisons
/// grew 0.29-0.70 (the sidebands of the second and third mesh harmonics 1.45-1.6 times in amplitude
/// between 10 % and 20 % load while those harmonics stayed within 10 %: the load changes the modulation
/// itself, so no carrier reference takes it out); 1.25 times the largest. It costs the eccentric gears
/// of the generators that grow less than that against one sibling (0.28-1.0, 12-25 um): judged against
/// two files or more they keep the steeper limit of `SIDEBAND_RISE_STEEP`.
pub const SIDEBAND_LEAST: f64 = MARGIN * 0.705;

impl Stat {
    /// From a single file (`files` 1), with the `allowance` for a change of load (this module's).
    pub(super) fn with_one_file(self, files: usize, allowance: f64) -> Self {
        let one = files == 1 && allowance > 0.0;
        Self { load_allowance: one.then_some(allowance), ..self }
    }

    /// The suspect and faulty limits in spreads of `spread`, `suspect_at` and `faulty_at` raised where a
    /// load allowance a is kept, so that each lies a plus that many of the median's own scatter (a median
    /// of `blocks` values) above the centre: limit = max(at, (a + at 1.2533 s / sqrt(n)) / spread).
    pub(super) fn load_limits(&self, spread: f64, blocks: usize, suspect_at: f64, faulty_at: f64) -> (f64, f64) {
        let Some(a) = self.load_allowance else { return (suspect_at, faulty_at) };
        let of_median = MEDIAN_SCATTER * self.spread / (blocks.max(1) as f64).sqrt();
        let raise = |at: f64| ((a + at * of_median) / spread).max(at);
        (raise(suspect_at), raise(faulty_at))
    }
}

/// Whether the baseline's files were recorded at the load and speed of the recordings judged against
/// them: what the user knows and the files cannot show.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BaselineLoad {
    /// Not known: a single file's limits keep an allowance for a neighbouring load (1.25 times each
    /// indicator's largest rise between the real rig's loads 10 % apart) and count the sideband growth
    /// from 0.88.
    #[default]
    Unknown,
    /// Stated to be the recordings' own operating point: a single file's limits are its blocks' own (the
    /// limits `suspect_at_one_load` and `sidebands_limit_one_load` of the scores). On the rig's broken
    /// tooth, channel 3 alone against the healthy file of its load: healthy at every load with the
    /// allowance (sideband growth 0.29-0.51 at every load, over the own-load 0.25; the spectral change
    /// 2.8-6.7 spreads, over its own-load limit at seven loads, under the raised one at all), flagged at
    /// every load without it.
    Same,
}

impl Reference {
    /// This reference with the operating point of its files as stated: [`BaselineLoad::Same`] drops every
    /// load allowance of a single file (two files or more keep none).
    pub fn with_load(mut self, load: BaselineLoad) -> Self {
        self.same_load = load == BaselineLoad::Same;
        if self.same_load {
            for g in self.gears.values_mut() {
                g.stats.values_mut().for_each(|s| s.load_allowance = None);
            }
        }
        self
    }

    /// Whether the files were stated to be recorded at the recordings' load ([`Self::with_load`]).
    pub fn same_load(&self) -> bool {
        self.same_load
    }
}
