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
        }
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

/// Checks that `d` and the baseline `b` come from the same machine and operating point: same unit and
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
    let speed_d = d.speed_profile.mean_hz.unwrap_or(1.0 / d.shaft_period_samples);
    let speed_b = b.speed_hz.unwrap_or(1.0 / b.shaft_period_samples);
    let ratio = speed_d / speed_b - 1.0;
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
            "the shaft runs {:.2} % {} than in the baseline ({} ppm is normal drift; within the recordings the speed wanders by +-{:.2} %): a different load or operating point, which changes the vibration by itself; a fault is judged only against a baseline at the same operating point, so this verdict is at most suspect",
            100.0 * ratio.abs(),
            if ratio > 0.0 { "faster" } else { "slower" },
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
        let j = b.channels.iter().position(|x| x == c);
        if let Some(j) = j {
            let now = d.raw.get(i).and_then(|m| m.get(&Indicator::Rms)).copied().unwrap_or(f64::NAN);
            let r = now / b.raw_rms.get(j).copied().unwrap_or(f64::NAN);
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
