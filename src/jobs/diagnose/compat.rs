//! Whether a baseline fits a recording: unit, channels, speed and operating point.

use super::*;
use crate::report::summary::Envelope;

/// Relative speed difference from the baseline beyond which a recording is refused: indicators change with
/// speed (resonances move against the mesh orders), so a baseline at another speed is another machine state.
pub const MAX_SPEED_DIFFERENCE: f64 = 0.10;
/// Relative speed difference from the baseline that is warned about.
pub const WARN_SPEED_DIFFERENCE: f64 = 0.03;

/// Relative speed difference from the baseline above which the operating point is taken to differ: 20
/// times the drift of a speed-controlled rig (100 ppm); an induction motor slows by about 0.4 % from no
/// load to 90 % load on the SpectraQuest rig of `data/realdata`, while a broken tooth changes its speed by
/// less than 0.05 %.
pub const OPERATING_POINT_SPEED_DIFFERENCE: f64 = 0.002;

/// What a recording is checked against: the facts of the first healthy recording of a baseline (or of a
/// profile), enough to tell whether a recording comes from the same machine and operating point.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaselineFacts {
    /// The healthy recording's file.
    pub file: String,
    /// Unit of its analysed channels ("" when its file names none).
    pub unit: String,
    /// Analysed channels (1-based).
    pub channels: Vec<usize>,
    /// Mean reference-shaft speed, Hz (`None` without a sample rate).
    pub speed_hz: Option<f64>,
    /// Shaft period, samples.
    pub shaft_period_samples: f64,
    /// Half the 10-90 % range of the revolutions' speeds, percent.
    pub fluctuation_percent: f64,
    /// Sample rate, Hz.
    pub sample_rate_hz: Option<f64>,
    /// Raw RMS of each analysed channel, in `unit`.
    pub raw_rms: Vec<f64>,
    /// Its envelope analysis (the recordings are demodulated in the same band).
    pub envelope: Option<Envelope>,
    /// The slowest and fastest mean speed of all the baseline's recordings, in the measure of
    /// `speed_of` (Hz, or revolutions per sample without a sample rate): a baseline learned over a range
    /// of loads holds every operating point in it. `None` in profiles written before it (the first
    /// recording's speed alone).
    #[serde(default)]
    pub speed_span: Option<[f64; 2]>,
    /// The doubts on the speed of the baseline's recordings, each with its file: averages on a speed that
    /// may be wrong cannot tell a healthy recording from a faulty one, so a recording judged against them
    /// is never cleared ([`BaselineFacts::doubt`]).
    #[serde(default)]
    pub speed_doubts: Vec<String>,
}

/// A diagnosis's mean reference-shaft speed: Hz, or revolutions per sample without a sample rate.
pub fn speed_of(d: &Diagnosis) -> f64 {
    d.speed_profile.mean_hz.unwrap_or(1.0 / d.shaft_period_samples)
}

/// The relative difference of `speed` from the span `[lo, hi]`: 0 inside it, else from its nearer end.
pub(super) fn beyond_span(speed: f64, [lo, hi]: [f64; 2]) -> f64 {
    if speed < lo {
        speed / lo - 1.0
    } else if speed > hi {
        speed / hi - 1.0
    } else {
        0.0
    }
}

impl BaselineFacts {
    /// The facts of a diagnosed healthy recording.
    pub fn of(b: &Diagnosis) -> Self {
        Self {
            file: b.file.clone(),
            unit: b.unit.clone(),
            channels: b.channels.clone(),
            speed_hz: b.speed_profile.mean_hz,
            shaft_period_samples: b.shaft_period_samples,
            fluctuation_percent: b.speed_profile.fluctuation_percent,
            sample_rate_hz: b.sample_rate_hz,
            raw_rms: b.raw.iter().map(|m| m.get(&Indicator::Rms).copied().unwrap_or(f64::NAN)).collect(),
            envelope: b.envelope.clone(),
            speed_span: Some([speed_of(b); 2]),
            speed_doubts: b.speed_doubt.iter().map(|why| format!("{}: {why}", b.file)).collect(),
        }
    }

    /// The doubt a recording judged against this baseline carries when a baseline recording's speed was in
    /// doubt (the fresh hold-out set's 18/29 machine given its teeth only: its healthy s1, averaged at a
    /// constant speed that could not be followed, made s2 HEALTHY against it on half its true speed).
    pub fn doubt(&self) -> Option<String> {
        self.speed_doubts.first().map(|first| {
            format!(
                "the baseline's averages may rest on a wrong speed ({} of its recordings in doubt; {first}), so they cannot clear the machine; give the speed or a tachometer channel when the baseline is learned",
                self.speed_doubts.len()
            )
        })
    }

    /// The facts of a baseline of several recordings: the first's, with the span of the speeds measured
    /// on them (by a tachometer or a followed line; a constant speed assumed over a record is no measured
    /// operating point: the hold-out's 13/37 machine given its teeth only averaged two healthy files on
    /// speeds 0.5 and 1.1 % off, and a span over them let a third healthy file pass as one of their
    /// operating points); the first recording's speed alone when fewer than two were measured.
    pub fn of_all(baselines: &[Diagnosis]) -> Option<Self> {
        let mut facts = Self::of(baselines.first()?);
        facts.speed_doubts =
            baselines.iter().flat_map(|b| b.speed_doubt.iter().map(|why| format!("{}: {why}", b.file))).collect();
        let measured: Vec<&Diagnosis> = baselines
            .iter()
            .filter(|d| d.speed_profile.tracking != crate::report::summary::Tracking::Constant)
            .collect();
        if measured.len() < 2 {
            return Some(facts);
        }
        let speeds = measured.iter().map(|d| speed_of(d));
        let lo = speeds.clone().fold(f64::INFINITY, f64::min);
        let hi = speeds.fold(f64::NEG_INFINITY, f64::max);
        facts.speed_span = (lo.is_finite() && hi.is_finite()).then_some([lo, hi]);
        Some(facts)
    }
}

/// What [`compatibility`] found.
#[derive(Clone, Debug, Default)]
pub struct Compatibility {
    /// Warnings for the recording.
    pub warnings: Vec<String>,
    /// Why the operating point differs from the baseline's (the verdict then stays at most suspect).
    pub operating_point: Option<String>,
    /// Whether absolute levels compare: false when one side's unit is unknown (samples in the file's own
    /// scale, e.g. an integer WAV without its sidecar), so the indicators that scale with the level
    /// ([`Indicator::level_dependent`]) do not decide.
    pub levels_comparable: bool,
}

/// Ratio of a recording's overall level to its baseline's (either way) beyond which the two are not in the
/// same scale, whatever their units say: 40 dB. A load change or a fault moves a gearbox's vibration level
/// by a few times (the hold-out generator's faults, broken teeth the most, by 0.82-3.6 times its healthy
/// recordings');
/// the bundled healthy recording written as raw 16-bit counts but labelled m/s stands 3.3e5 times over its
/// WAV, and was called FAULTY against it on NA4* and the spectral change.
const SCALE_MISMATCH: f64 = 100.0;

/// Checks that `d` and the baseline `b` come from the same machine and operating point (a speed within the
/// span of the baseline's recordings' speeds is one of its operating points): same unit and
/// channels (refused), speed within [`MAX_SPEED_DIFFERENCE`] (refused beyond, warned beyond
/// [`WARN_SPEED_DIFFERENCE`], operating point taken as different beyond
/// [`OPERATING_POINT_SPEED_DIFFERENCE`] or, when larger, beyond the wander of the speed within either
/// recording: a speed that wanders by +-1 % moves the mean of a few seconds by tenths of a percent),
/// sample rate and overall level (warned).
///
/// # Errors
/// An incompatible baseline, naming both files and what differs.
pub fn compatibility(d: &Diagnosis, b: &BaselineFacts) -> Result<Compatibility, Error> {
    let refuse = |what: String| -> Error {
        JobError::Value {
            what: Given::Baseline,
            message: format!("{} is not comparable with {}: {what}", b.file, d.file),
        }
        .into()
    };
    let mut warnings = Vec::new();
    if !d.unit.is_empty() && !b.unit.is_empty() && d.unit != b.unit {
        return Err(refuse(format!("it is in {} and the recording in {}", b.unit, d.unit)));
    }
    let mut levels_comparable = d.unit.is_empty() == b.unit.is_empty();
    if !levels_comparable {
        let (known, unknown) = if d.unit.is_empty() { (&b.file, &d.file) } else { (&d.file, &b.file) };
        warnings.push(format!(
            "{unknown} names no unit (its samples are in the file's own scale) while {known} is in {}: absolute levels cannot be compared, so NA4*, SI and the spectral change do not decide; the verdict rests on the level-free indicators (give the unit and sensitivity, or keep the sidecar, to compare levels)",
            if d.unit.is_empty() { &b.unit } else { &d.unit }
        ));
    }
    if let Some(c) = d.channels.iter().find(|c| !b.channels.contains(c)) {
        return Err(refuse(format!(
            "the recording's channel {c} is not among the baseline's analysed channels {:?}",
            b.channels
        )));
    }
    // against the span of the baseline's speeds (its first recording's in a profile written before it)
    let speed_b = b.speed_hz.unwrap_or(1.0 / b.shaft_period_samples);
    let ratio = beyond_span(speed_of(d), b.speed_span.unwrap_or([speed_b; 2]));
    if ratio.abs() > MAX_SPEED_DIFFERENCE {
        return Err(refuse(format!(
            "its shaft speed differs by {:+.1} % (at most {} % is accepted: another operating point)",
            -100.0 * ratio / (1.0 + ratio),
            100.0 * MAX_SPEED_DIFFERENCE
        )));
    }
    if ratio.abs() > WARN_SPEED_DIFFERENCE {
        warnings.push(format!(
            "the shaft speed differs from the baseline's by {:+.1} %: indicators that depend on speed may move",
            100.0 * ratio
        ));
    }
    // a machine whose speed wanders within each recording covers a range of speeds in both: means that
    // differ by less than that wander are one operating point
    let wander = 0.01 * d.speed_profile.fluctuation_percent.max(b.fluctuation_percent);
    let operating_point = (ratio.abs() > OPERATING_POINT_SPEED_DIFFERENCE.max(wander)).then(|| {
        format!(
            "the shaft runs {:.2} % {} than in the baseline{} ({} ppm is normal drift; within the recordings the speed wanders by +-{:.2} %): a different load or operating point, which changes the vibration by itself; against a baseline at another operating point a fault is judged at most suspect",
            100.0 * ratio.abs(),
            if ratio > 0.0 { "faster" } else { "slower" },
            match b.speed_span {
                Some([lo, hi]) if hi > lo && ratio > 0.0 => "'s fastest recording",
                Some([lo, hi]) if hi > lo => "'s slowest recording",
                _ => "",
            },
            (OPERATING_POINT_SPEED_DIFFERENCE * 1e6 / 20.0) as u32,
            100.0 * wander
        )
    });
    if let (Some(fd), Some(fb)) = (d.sample_rate_hz, b.sample_rate_hz) {
        if (fd / fb - 1.0).abs() > 1e-3 {
            warnings.push(format!("the baseline was sampled at {fb} Hz and this recording at {fd} Hz: the orders are compared, the raw spectra differ"));
        }
    }
    for (i, c) in d.channels.iter().enumerate() {
        if let Some(r) = level_ratio(d, b, i) {
            if levels_comparable && !(1.0 / SCALE_MISMATCH..=SCALE_MISMATCH).contains(&r) {
                levels_comparable = false;
                warnings.push(format!(
                    "channel {c}: the overall level is {r:.3e} times the baseline's, beyond any change of load: a unit, sensitivity or scale mismatch (raw counts against physical units?), so NA4*, SI and the spectral change do not decide; the verdict rests on the level-free indicators (give the unit and sensitivity that make the levels compare)"
                ));
            } else if levels_comparable && !(0.5..=2.0).contains(&r) {
                warnings.push(format!(
                    "channel {c}: the overall level is {r:.2} times the baseline's: the operating condition (load) may differ, and the indicators that scale with it move too"
                ));
            }
        }
    }
    Ok(Compatibility { warnings, operating_point, levels_comparable })
}

/// The raw RMS of `d`'s `i`-th analysed channel over the baseline's of the same channel (`None` when the
/// baseline did not analyse it; NaN when either level is missing).
fn level_ratio(d: &Diagnosis, b: &BaselineFacts, i: usize) -> Option<f64> {
    let j = b.channels.iter().position(|x| Some(x) == d.channels.get(i))?;
    let now = d.raw.get(i).and_then(|m| m.get(&Indicator::Rms)).copied().unwrap_or(f64::NAN);
    Some(now / b.raw_rms.get(j).copied().unwrap_or(f64::NAN))
}

/// Whether a further healthy recording `d` of a baseline is of the same machine and recorder as its first
/// (`first`), as the limits learned from them all need: the same unit (or none on both), channels and
/// sample rate, and levels within [`SCALE_MISMATCH`] of each other. Where [`compatibility`] only warns of
/// these for a recording under test, a baseline that mixes them learns limits of no machine: a 10 kHz
/// 14/39 file with a 20 kHz file of a 19/53 machine in no unit gave a profile whose NA4* reached 1.3e6.
///
/// # Errors
/// What differs, naming both files.
pub fn same_recorder(d: &Diagnosis, first: &BaselineFacts) -> Result<(), Error> {
    let refuse = |what: String| -> Error {
        JobError::Value {
            what: Given::Baseline,
            message: format!("{} and {} cannot be one baseline: {what}", first.file, d.file),
        }
        .into()
    };
    if d.unit != first.unit {
        let name = |u: &str| if u.is_empty() { "no unit".to_string() } else { u.to_string() };
        return Err(refuse(format!("their units differ ({} and {})", name(&first.unit), name(&d.unit))));
    }
    if d.channels != first.channels {
        return Err(refuse(format!("their analysed channels differ ({:?} and {:?})", first.channels, d.channels)));
    }
    match (first.sample_rate_hz, d.sample_rate_hz) {
        (Some(a), Some(b)) if (a / b - 1.0).abs() > 1e-3 => {
            return Err(refuse(format!("they were sampled at {a} Hz and {b} Hz")));
        }
        (Some(_), None) | (None, Some(_)) => {
            return Err(refuse("one has a sample rate and the other none".into()));
        }
        _ => {}
    }
    for (i, c) in d.channels.iter().enumerate() {
        let r = level_ratio(d, first, i).unwrap_or(f64::NAN);
        if r.is_finite() && !(1.0 / SCALE_MISMATCH..=SCALE_MISMATCH).contains(&r) {
            return Err(refuse(format!(
                "channel {c}'s overall level differs {r:.3e} times, beyond any change of load (another scale or sensor)"
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{BaselineFacts, beyond_span};

    fn facts(doubts: &[&str]) -> BaselineFacts {
        BaselineFacts {
            file: "h1.wav".into(),
            unit: "m/s^2".into(),
            channels: vec![1],
            speed_hz: Some(30.0),
            shaft_period_samples: 1000.0,
            fluctuation_percent: 0.5,
            sample_rate_hz: Some(30_000.0),
            raw_rms: vec![1.0],
            envelope: None,
            speed_span: None,
            speed_doubts: doubts.iter().map(|d| d.to_string()).collect(),
        }
    }

    #[test]
    fn a_baseline_whose_speed_is_in_doubt_cannot_clear_a_recording() {
        assert_eq!(facts(&[]).doubt(), None);
        let d = facts(&["h1.wav: could not be followed", "h2.wav: weak comb"]).doubt().unwrap();
        assert!(d.contains("2 of its recordings in doubt") && d.contains("h1.wav: could not be followed"), "{d}");
        assert!(d.contains("cannot clear the machine"), "{d}");
        // a profile written before the field reads as no doubt
        let mut json = serde_json::to_value(facts(&[])).unwrap();
        json.as_object_mut().unwrap().remove("speed_doubts");
        json.as_object_mut().unwrap().remove("speed_span");
        let old: BaselineFacts = serde_json::from_value(json).unwrap();
        assert!(old.speed_doubts.is_empty() && old.speed_span.is_none());
    }

    #[test]
    fn a_speed_inside_the_span_is_none_of_its_difference() {
        assert_eq!(beyond_span(30.05, [30.0, 30.1]), 0.0);
        // outside, from the nearer end: 1 % above the fastest, 2 % below the slowest
        assert!((beyond_span(30.401, [30.0, 30.1]) - 0.01).abs() < 1e-12);
        assert!((beyond_span(29.4, [30.0, 30.1]) + 0.02).abs() < 1e-12);
        // a one-recording span is its speed
        assert!((beyond_span(30.3, [30.0, 30.0]) - 0.01).abs() < 1e-12);
    }
}
