//! The verdict: condition, gear, tooth, and the scores against the baseline that decide it.

use super::Shaft;
use super::*;
use serde::Serialize;

/// Condition of a recording.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum VerdictState {
    /// The recording could not be scored (no comparable block, an indicator that is not a number, a gear
    /// the baseline does not hold): never taken for healthy. Lowest in the order, so that any gear that
    /// could be judged and shows a fault decides.
    NotJudged,
    /// No indicator beyond its limit.
    Healthy,
    /// One indicator beyond its first limit.
    Suspect,
    /// An indicator beyond its second limit, or several beyond their first.
    Faulty,
}

impl VerdictState {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::NotJudged => "not judged",
            Self::Healthy => "healthy",
            Self::Suspect => "suspect",
            Self::Faulty => "faulty",
        }
    }
}

/// The gear a verdict concerns.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum VerdictGear {
    /// The pinion.
    #[serde(rename = "pinion")]
    Pinion,
    /// The wheel.
    #[serde(rename = "wheel")]
    Wheel,
    /// The teeth were not given, so the gear cannot be named.
    #[serde(rename = "unknown (teeth not given)")]
    Unknown,
    /// A pair of equal teeth (1:1): both gears turn at one speed, so no period tells which one is faulty.
    #[serde(rename = "pinion or wheel")]
    Either,
    /// No gear (healthy).
    #[serde(rename = "none")]
    None,
    /// The sun of a planetary stage (`diagnose --machine`).
    #[serde(rename = "sun")]
    Sun,
    /// A planet of a planetary stage (which one: `Verdict::planet`).
    #[serde(rename = "planet")]
    Planet,
    /// The ring of a planetary stage.
    #[serde(rename = "ring")]
    Ring,
}

impl VerdictGear {
    /// Name shown to people and in the JSON.
    pub fn name(self) -> &'static str {
        match self {
            Self::Pinion => "pinion",
            Self::Wheel => "wheel",
            Self::Unknown => "unknown (teeth not given)",
            Self::Either => "pinion or wheel",
            Self::None => "none",
            Self::Sun => "sun",
            Self::Planet => "planet",
            Self::Ring => "ring",
        }
    }
}

impl VerdictGear {
    /// The shaft of a verdict on the pinion or the wheel of a pair (`None` for any other gear).
    pub fn pair_shaft(self) -> Option<Shaft> {
        match self {
            Self::Pinion => Some(Shaft::Pinion),
            Self::Wheel => Some(Shaft::Wheel),
            _ => None,
        }
    }
}

impl From<Shaft> for VerdictGear {
    fn from(s: Shaft) -> Self {
        match s {
            Shaft::Pinion => Self::Pinion,
            Shaft::Wheel => Self::Wheel,
            Shaft::Estimated | Shaft::Named(_) => Self::Unknown,
        }
    }
}

/// A recording's whole-record impulse measure (FM4, M6A of its average over every revolution) against
/// the baseline files' own (`baseline::long`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LongScore {
    /// Gear (shaft).
    pub gear: Shaft,
    /// 1-based channel.
    pub channel: usize,
    /// FM4 or M6A.
    pub indicator: Indicator,
    /// The recording's value over its whole record.
    pub value: f64,
    /// Revolutions the recording's average holds.
    pub revolutions: usize,
    /// Each baseline file's value over its whole record.
    pub files: Vec<f64>,
    /// (ln value - centre) / spread: the centre the mean of the files' ln values, at least a normal
    /// signal's (ln 3 for FM4, ln 15 for M6A); the spread one baseline block's, at least the range of the
    /// files' ln values and what healthy siblings differ by (`baseline::long`).
    pub spreads: f64,
    /// Spreads from which the measure makes its gear suspect: the block scores' suspect limit with two
    /// files or more; their faulty limit from one file, which cannot show how far healthy recordings'
    /// averages differ.
    pub suspect_at: f64,
    /// Spreads from which it makes its gear faulty (two files or more; never from one).
    pub faulty_at: f64,
}

/// One indicator of one gear and channel scored against the statistical baseline.
#[derive(Clone, Debug, Serialize)]
pub struct Score {
    /// Gear (shaft).
    pub gear: Shaft,
    /// 1-based channel.
    pub channel: usize,
    /// Indicator name (lower case).
    pub indicator: Indicator,
    /// Median over this recording's blocks.
    pub value: f64,
    /// Blocks of this recording.
    pub blocks: usize,
    /// Median over the baseline's blocks.
    pub baseline_centre: f64,
    /// Spread of the baseline's blocks (1.4826 x median absolute deviation, at least 5 % of the centre), on
    /// `scale`.
    pub baseline_spread: f64,
    /// Whether `baseline_spread` was widened because the baseline's files differ among themselves more
    /// than their blocks do (the suspect limit then lies the median's own scatter over the highest file's
    /// median).
    pub spread_from_files: bool,
    /// `log` when the indicator is scored on its natural logarithm (the spread is then of ln value).
    pub scale: Scale,
    /// Smallest and largest baseline block value.
    pub baseline_range: [f64; 2],
    /// Baseline blocks.
    pub baseline_blocks: usize,
    /// (value - centre) / spread: how many spreads above the baseline's centre.
    pub spreads: f64,
    /// Suspect limit in spreads (false-alarm probability 1e-3 per indicator and block, Student-t prediction
    /// limit for the number of baseline blocks).
    pub suspect_at: f64,
    /// Faulty limit in spreads (false-alarm probability 1e-6).
    pub faulty_at: f64,
    /// The suspect limit for a recording at the baseline's own operating point; against a single
    /// baseline file `suspect_at` and `faulty_at` are raised over it by what a neighbouring load moves a
    /// healthy recording (`baseline::one_file`), else the two are equal.
    pub suspect_at_one_load: f64,
    /// Whether this indicator takes part in the verdict (a near-zero amplitude does not, nor any score of
    /// a recording that does not show its baseline's mesh).
    pub decides: bool,
}

impl Score {
    /// Whether the indicator takes part in the verdict and stands at or over its suspect limit.
    pub fn over_suspect(&self) -> bool {
        self.decides && self.spreads >= self.suspect_at
    }
}

#[cfg(test)]
impl Score {
    /// A deciding score for unit tests: `indicator` of `gear` on channel 1 at `spreads`, on the log scale
    /// with centre 1 and spread 0.1 over 30 blocks against 30, limits 3.4 and 5.6 spreads at the file's own
    /// load; a test sets what else it reads (`Score { value, ..Score::test(...) }`).
    pub(crate) fn test(gear: Shaft, indicator: Indicator, spreads: f64) -> Self {
        Self {
            gear,
            channel: 1,
            indicator,
            value: (0.1 * spreads).exp(),
            blocks: 30,
            baseline_centre: 1.0,
            baseline_spread: 0.1,
            spread_from_files: false,
            scale: Scale::Log,
            baseline_range: [0.8, 1.2],
            baseline_blocks: 30,
            spreads,
            suspect_at: 3.4,
            suspect_at_one_load: 3.4,
            faulty_at: 5.6,
            decides: true,
        }
    }
}

/// Where one gear's average changed against the baseline's: the phase-aligned difference of its residual
/// signal from the baseline's mean residual, how much of that difference's energy one tooth pitch holds, and
/// how much its first-order mesh sidebands grew.
#[derive(Clone, Debug, Serialize)]
pub struct LocalChange {
    /// Gear (shaft).
    pub gear: Shaft,
    /// 1-based channel.
    pub channel: usize,
    /// Energy of the difference over the tooth pitch where it is largest, over the median pitch's.
    pub value: f64,
    /// The largest of the same measure between the baseline's own files (each against the others).
    pub healthy: f64,
    /// From here the change counts as evidence of a local fault: 2.5 times `healthy`, at least 3.
    pub limit: f64,
    /// Normalised correlation of the recording's residual with the baseline's at the best shift (1: the same
    /// pattern).
    pub alignment: f64,
    /// The tooth (1-based, from the recording's angle origin) where the change is largest.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tooth: Option<usize>,
    /// Sideband growth: the difference's energy at the first-order sidebands (k z +- 1) over the baseline's
    /// own there; a change once per revolution (an eccentric gear, uneven wear) raises it.
    pub sidebands: f64,
    /// The largest of the same between the baseline's own files.
    pub sidebands_healthy: f64,
    /// The largest of the same between the baseline's own files less what their noise explains (NaN from a
    /// profile written before it).
    pub sidebands_beyond_noise: f64,
    /// The growth the noise of the recording's blocks and of the baseline's average explains (their block
    /// scatter at those orders over their block counts, over the baseline's own energy there), taken 7/6
    /// times over from a single baseline file (`baseline::ONE_FILE_NOISE_MARGIN`); NaN when not known (a
    /// profile written before it, fewer than two blocks).
    pub sidebands_noise: f64,
    /// From here the growth counts as evidence: the lower of `baseline::sidebands_limit` of
    /// `sidebands_healthy` and of `sidebands_beyond_noise` + `sidebands_noise` (each the lower of 3 times
    /// its argument but at least 8, and 4.5 times it but at least 0.25); from a single baseline file at
    /// least what a neighbouring load grows (`baseline::one_file`).
    pub sidebands_limit: f64,
    /// The limit before that single-file least: the growth a recording at the baseline file's own
    /// operating point is held to (`sidebands_limit` from two files or more).
    pub sidebands_limit_one_load: f64,
    /// Pattern change: the difference's energy at every order that is not a mesh harmonic, after each mesh
    /// harmonic's band is scaled by its own complex factor (a change of the mesh's carrier taken out), over
    /// the baseline's own there: how much the gear's own teeth changed (wear, runout, a local fault). Read at
    /// the baseline's noise: the recording's own noise there (its blocks' scatter, each band's scale taken
    /// out) replaced by the baseline files' mean (`baseline::local::at_baseline_noise`), so that a noisier
    /// average (the mate's lines, which do not repeat on this gear's revolution) does not read as a change
    /// of this gear's teeth. NaN when it could not be computed.
    pub pattern: f64,
    /// The largest of the same between the baseline's own files (NaN from one file, or a profile written
    /// before it).
    pub pattern_healthy: f64,
    /// On a pair whose teeth share a factor g: the change's energy at the orders the gear does not share
    /// with the other gear (not multiples of z / g) over the share those orders hold of an even change
    /// (`signal::tsa_change::own_share`): about 1 for the gear's own change, near 0 for the other gear's.
    /// Absent on coprime teeth.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub own_share: Option<f64>,
}

/// The verdict.
#[derive(Clone, Debug, Serialize)]
pub struct Verdict {
    /// Condition.
    pub state: VerdictState,
    /// Gear concerned.
    pub gear: VerdictGear,
    /// Reasons in plain words.
    pub reasons: Vec<String>,
    /// The tooth of a local fault (1-based), when the gear's difference signal holds one impulse per
    /// revolution that places it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tooth: Option<usize>,
    /// Where tooth 1 is counted from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tooth_origin: Option<ToothOrigin>,
    /// The other gears whose indicators moved with the fault's, said to be its cross-talk (their averages
    /// hold the faulty gear's impulses, smeared), not second faults.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub cross_talk: Vec<String>,
    /// With a machine: the name of the shaft that carries the faulty gear (`gear` is then `pinion` for the
    /// stage's driving gear, `wheel` for its driven gear, or `sun`, `planet`, `ring`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shaft: Option<String>,
    /// With a machine: the stage of the faulty gear, 1-based (machine file order).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stage: Option<usize>,
    /// With a machine and a faulty planet: the planet, 1-based (the order they pass the sensor).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub planet: Option<usize>,
    /// The average (gear or shaft) whose indicators decided a suspect or faulty verdict.
    #[serde(skip)]
    pub deciding: Option<Shaft>,
}

impl Verdict {
    /// The gear and, when placed, the tooth, in words: "pinion, tooth 3 (counted from the tachometer
    /// pulse)".
    pub fn place(&self) -> String {
        let gear = match (&self.shaft, self.stage, self.planet) {
            (_, Some(k), Some(p)) => format!("stage {k} planet {p}"),
            (Some(s), Some(k), None) => format!("stage {k} {} on shaft `{s}`", self.gear.name()),
            _ => self.gear.name().to_string(),
        };
        match (self.tooth, self.tooth_origin) {
            (Some(t), Some(ToothOrigin::Tachometer)) => {
                format!("{gear}, tooth {t} (counted from the tachometer pulse)")
            }
            (Some(t), Some(ToothOrigin::Relative)) => format!(
                "{gear}, tooth {t} (counted from a relative origin: no tachometer on this shaft, so only the distance between teeth is meaningful)"
            ),
            (Some(t), _) => format!(
                "{gear}, tooth {t} (counted from an arbitrary origin: no tachometer, so only the distance between teeth is meaningful)"
            ),
            _ => gear,
        }
    }

    /// A verdict without a tooth or cross-talk.
    pub fn new(state: VerdictState, gear: VerdictGear, reasons: Vec<String>) -> Self {
        Self {
            state,
            gear,
            reasons,
            tooth: None,
            tooth_origin: None,
            cross_talk: Vec::new(),
            shaft: None,
            stage: None,
            planet: None,
            deciding: None,
        }
    }
}

/// Where a placed tooth is counted from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum ToothOrigin {
    /// Tooth 1 is the one meshing at the tachometer's pulse.
    #[serde(rename = "tachometer pulse")]
    Tachometer,
    /// No tachometer: tooth 1 is where the tracked angle happened to start; only the distance between teeth
    /// is meaningful (another recording of the same machine may number them from elsewhere).
    #[serde(rename = "arbitrary (no tachometer)")]
    Arbitrary,
    /// With a machine: a shaft that the tachometer does not watch; tooth 1 is where its angle stood at the
    /// tracked shaft's first pulse (the tracked angle times the exact ratio), which depends on how many
    /// revolutions the machine had turned: only the distance between teeth is meaningful.
    #[serde(rename = "relative (no tachometer on this shaft)")]
    Relative,
}

impl LongScore {
    /// Whether the measure lies at or over its suspect limit.
    pub fn over_suspect(&self) -> bool {
        self.spreads >= self.suspect_at
    }
}
