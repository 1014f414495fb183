//! The sections of `diagnose`: one recording's verdict, facts, indicator table and images; the trend page.

use super::{Badge, Section, Table, cell};
use crate::report::summary::{Diagnosis, Indicator, VerdictState};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Channel numbers as a list: "1, 2".
fn channel_list(c: &[usize]) -> String {
    c.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")
}

/// The section of one diagnosis: verdict and reasons, speed and tracking, warnings, the indicator table
/// against the baseline's band (or the indicators without one), the images.
pub fn diagnosis_section(
    d: &Diagnosis,
    images: &[PathBuf],
    iso_class: Option<crate::signal::velocity::MachineClass>,
) -> Section {
    let unit = crate::report::figures::unit_or(&d.unit);
    let mut facts = vec![match d.sample_rate_hz {
        Some(fs) => format!(
            "{} samples at {} Hz, channel(s) {}; amplitudes in {unit}.",
            d.samples,
            cell(fs),
            channel_list(&d.channels)
        ),
        None => format!(
            "{} samples, sample rate unknown: everything in orders of the shaft, no value in Hz; channel(s) {}.",
            d.samples,
            channel_list(&d.channels)
        ),
    }];
    let shafts: Vec<String> = d
        .shaft_hz
        .entries()
        .into_iter()
        .zip(d.shaft_hz.shafts())
        .filter_map(|((k, v), shaft)| {
            let k = if k == "estimated_shaft" { "shaft of the estimated period" } else { k };
            match v {
                Some(f) => Some(format!("{k} {} Hz ({} rpm)", cell(f), cell(60.0 * f))),
                None => d
                    .revolution_samples(shaft)
                    .map(|period| format!("{k}: one revolution every {} samples", cell(period))),
            }
        })
        .collect();
    facts.push(match (d.speed_given_hz, d.speed_deviation_percent) {
        (Some(g), Some(off)) => format!(
            "Speed: {} (measured on the recording; the given {g:.4} Hz is {off:+.2} % from it).",
            shafts.join(", ")
        ),
        _ => format!("Speed: {}; {}.", shafts.join(", "), speed_words(d.speed_source)),
    });
    let p = &d.speed_profile;
    facts.push(format!(
        "Shaft angle tracked by {}{}{}; speed change over the recording {} %.",
        p.tracking,
        p.refined_gain.map_or(String::new(), |g| format!(
            " and refined by lining the revolutions up with their average (its RMS {} times that on the line's angle)",
            crate::report::format::sig(g, 3)
        )),
        match (p.min_hz, p.max_hz) {
            (Some(lo), Some(hi)) => format!(", {}", revolution_range(lo, hi)),
            _ => String::new(),
        },
        cell(p.change_percent)
    ));
    match &d.machine {
        Some(m) => {
            facts.push(format!("Gearbox: {}; orders are of the tracked shaft {}.", m.machine, m.tracked_shaft));
            facts.extend(m.stages.iter().map(stage_fact));
        }
        None => facts.push(format!(
            "Mesh: order {} of the reference shaft ({}).",
            d.mesh_order,
            teeth_words(d.teeth_source)
        )),
    }
    facts.push(velocity_words(d, iso_class));
    if let Some(g) = &d.other_gear {
        facts.push(format!(
            "Meshing gear: {} teeth (estimated from its sidebands, confidence {}).",
            g.teeth,
            crate::report::format::sig(g.confidence, 2)
        ));
    }
    facts.extend(d.warnings.iter().map(|w| format!("Warning: {w}")));
    let mut tables = Vec::new();
    if d.scores.is_empty() {
        let keys = [
            Indicator::Fm0,
            Indicator::Fm4,
            Indicator::M6a,
            Indicator::Na4,
            Indicator::Er,
            Indicator::Si,
            Indicator::Ser,
            Indicator::Sbr,
            Indicator::Kurtosis,
            Indicator::CrestFactor,
        ];
        let mut t = Table {
            caption: "Condition indicators (no baseline: judged on the absolute limits the verdict names)".into(),
            header: [averaged(d).to_string(), "channel".to_string()]
                .into_iter()
                .chain(keys.iter().map(|k| k.label().to_string()))
                .collect(),
            rows: Vec::new(),
        };
        for g in &d.gears {
            let mut row = vec![g.gear.name().to_string(), g.channel.to_string()];
            row.extend(keys.iter().map(|k| cell(g.indicators.get(k).copied().unwrap_or(f64::NAN))));
            t.rows.push((row, false));
        }
        tables.push(t);
    } else {
        let mut t = Table {
            caption: "Indicators against the statistical baseline (median of this recording's blocks; spreads from the baseline's centre; limits for false-alarm rates 1e-3 and 1e-6)".into(),
            header: [averaged(d), "channel", "indicator", "value", "baseline centre", "baseline range", "spreads", "suspect at", "faulty at"]
                .iter()
                .map(|s| s.to_string())
                .collect(),
            rows: Vec::new(),
        };
        for s in &d.scores {
            let hit = s.over_suspect();
            t.rows.push((
                vec![
                    s.gear.name().to_string(),
                    s.channel.to_string(),
                    s.indicator.label().to_string(),
                    cell(s.value),
                    cell(s.baseline_centre),
                    format!("{} to {}", cell(s.baseline_range[0]), cell(s.baseline_range[1])),
                    match (s.decides, d.verdict.state) {
                        (true, _) => crate::report::format::sig(s.spreads, 3),
                        (false, VerdictState::NotJudged) => {
                            format!("{} (decides nothing)", crate::report::format::sig(s.spreads, 3))
                        }
                        (false, _) => "near zero".into(),
                    },
                    crate::report::format::sig(s.suspect_at, 3),
                    crate::report::format::sig(s.faulty_at, 3),
                ],
                hit,
            ));
        }
        tables.push(t);
    }
    Section {
        heading: Path::new(&d.file).file_name().and_then(|n| n.to_str()).unwrap_or(&d.file).to_string(),
        verdict: Some(Badge {
            state: d.verdict.state,
            word: d.verdict.state.name().replace('_', " ").to_uppercase(),
            // the terminal's `shaft` quotes are no words for a page
            line: format!("gear: {}", d.verdict.place().replace('`', "")),
        }),
        reasons: d
            .verdict
            .reasons
            .iter()
            .cloned()
            .chain(d.verdict.cross_talk.iter().map(|c| format!("Cross-talk: {c}")))
            .collect(),
        facts,
        tables,
        images: images.to_vec(),
    }
}

/// What the indicator tables' first column names: a pair's gears, or the shafts of a machine or of an
/// estimated period (their averages are a shaft's, whatever gears it carries).
fn averaged(d: &Diagnosis) -> &'static str {
    match d.shaft_hz {
        crate::report::summary::ShaftHz::Machine(_) | crate::report::summary::ShaftHz::Estimated { .. } => "shaft",
        _ => "gear",
    }
}

/// The slowest and fastest revolutions' speeds with the digits that tell them apart ("from 14.999 to
/// 15.002 Hz", never "from 15 to 15 Hz"), or the one speed when every revolution had it.
fn revolution_range(lo: f64, hi: f64) -> String {
    use crate::report::format::sig;
    match (4..=7).find(|&n| sig(lo, n) != sig(hi, n)) {
        Some(n) => format!("revolutions from {} to {} Hz", sig(lo, n), sig(hi, n)),
        None => format!("every revolution at {} Hz", sig(lo, 7)),
    }
}

/// Where the mesh order came from, in words.
fn teeth_words(source: crate::report::summary::TeethSource) -> &'static str {
    match source {
        crate::report::summary::TeethSource::Given => "teeth given",
        crate::report::summary::TeethSource::Baseline => "mesh order as estimated on the baseline recording",
        crate::report::summary::TeethSource::Estimated => "mesh order estimated from this recording's average",
    }
}

/// One stage of a machine in words: "Stage 2 mesh: pinion 15 teeth on shaft intermediate, wheel 45 teeth
/// on shaft output; order 7.5 (15/2) of the tracked shaft, 187.5 Hz."
fn stage_fact(s: &crate::report::summary::StageDiagnosis) -> String {
    use crate::report::format::num;
    let gears: Vec<String> = s
        .gears
        .iter()
        .map(|g| match &g.shaft {
            Some(shaft) => format!("{} {} teeth on shaft {shaft}", g.gear.name(), g.teeth),
            None => format!("{} {} teeth", g.gear.name(), g.teeth),
        })
        .collect();
    let exact = if s.mesh_order_exact == num(s.mesh_order) || s.mesh_order_exact == format!("{}", s.mesh_order) {
        String::new()
    } else {
        format!(" ({})", s.mesh_order_exact)
    };
    format!(
        "Stage {} mesh: {}; order {}{exact} of the tracked shaft{}.",
        s.stage,
        gears.join(", "),
        num(s.mesh_order),
        s.mesh_hz.map_or(String::new(), |f| format!(", {} Hz", num(f)))
    )
}

/// Lower edge, upper edge of the overall-velocity band, Hz (ISO 10816-3 for machines above 600 rpm).
const VELOCITY_BAND_HZ: (f64, f64) = (10.0, 1000.0);

/// The overall velocity RMS of the deciding channel over 10-1000 Hz in mm/s, and with a machine class its
/// ISO 10816-3 zone and boundaries; or why it could not be computed.
pub fn velocity_words(d: &Diagnosis, iso_class: Option<crate::signal::velocity::MachineClass>) -> String {
    use crate::signal::velocity::{measured_from_unit, velocity_rms_mm_s};
    let (lo, hi) = VELOCITY_BAND_HZ;
    let why_not = |why: String| format!("Overall velocity RMS over {lo}-{hi} Hz not computed: {why}.");
    let Some((ch, spectrum)) = d.spectra().first() else {
        return why_not("the sample rate is unknown".into());
    };
    let Some(measured) = measured_from_unit(&d.unit) else {
        return why_not(if d.unit.is_empty() {
            "the file names no unit (give its unit: m/s, mm/s, m/s^2 or g)".into()
        } else {
            format!("the unit {} is neither a velocity nor an acceleration", d.unit)
        });
    };
    let Some(v) = velocity_rms_mm_s(spectrum, measured, VELOCITY_BAND_HZ) else {
        return why_not(format!("the sample rate does not reach {hi} Hz"));
    };
    let integrated = match measured {
        crate::signal::velocity::Measured::Acceleration(_) => ", integrated from the acceleration",
        crate::signal::velocity::Measured::Velocity(_) => "",
    };
    let mut s = format!(
        "Overall velocity RMS over {lo}-{hi} Hz: {} mm/s (channel {ch}{integrated})",
        crate::report::format::sig(v, 3)
    );
    match iso_class {
        Some(c) => {
            let [ab, bc, cd] = c.boundaries_mm_s();
            let _ = write!(
                s,
                "; ISO 10816-3 / 20816-3 {}: {} (boundaries A/B {ab}, B/C {bc}, C/D {cd} mm/s, as publicly quoted, not checked against the standard's text).",
                c.name(),
                c.zone(v).words()
            );
        }
        None => s.push_str("; give the machine's ISO class for its ISO 10816-3 / 20816-3 zone."),
    }
    s
}

fn speed_words(s: crate::report::summary::SpeedSource) -> &'static str {
    match s {
        crate::report::summary::SpeedSource::Given => "given on the command line",
        crate::report::summary::SpeedSource::Tachometer => "from the tachometer",
        crate::report::summary::SpeedSource::Estimated => "estimated from the signal",
    }
}

/// The section that opens a trend page: the trend images and one row per recording with its verdict, gear
/// and first reason, in time order as given.
pub fn trend_section(done: &[Diagnosis], images: &[PathBuf]) -> Section {
    let names = crate::report::figures::short_names(&done.iter().map(|d| d.file.clone()).collect::<Vec<_>>());
    let rows = done
        .iter()
        .zip(&names)
        .map(|(d, short)| {
            let file = Path::new(&d.file).file_name().and_then(|n| n.to_str()).unwrap_or(&d.file).to_string();
            let worst = d.scores.iter().filter(|s| s.decides).map(|s| s.spreads).fold(f64::NAN, f64::max);
            (
                vec![
                    short.split(' ').next().unwrap_or("").to_string(),
                    file,
                    d.verdict.state.name().replace('_', " "),
                    d.verdict.gear.name().to_string(),
                    crate::report::format::sig(worst, 3),
                    d.verdict.reasons.first().cloned().unwrap_or_default(),
                ],
                d.verdict.state != VerdictState::Healthy,
            )
        })
        .collect();
    Section {
        heading: format!("Trend over {} recordings (time order as given)", done.len()),
        facts: vec![
            "Every scored indicator in spreads from the baseline's centre, one panel per gear and indicator family, with the suspect and faulty limits; the numbers are in trend.csv and trend.jsonl.".into(),
        ],
        tables: vec![Table {
            caption: "Verdict of each recording (rows not healthy highlighted)".into(),
            header: ["#", "recording", "verdict", "gear", "largest spreads", "first reason"]
                .iter()
                .map(|s| s.to_string())
                .collect(),
            rows,
        }],
        images: images.to_vec(),
        ..Default::default()
    }
}

/// The section that opens the page of a batch in which some recordings could not be diagnosed: a
/// NOT DIAGNOSED badge and one row per recording (`(file, error)`) with what stopped it, so that the page
/// never reads as if every recording given had been judged.
pub fn failures_section(failed: &[(String, String)]) -> Section {
    let rows = failed
        .iter()
        .map(|(file, error)| {
            let name = Path::new(file).file_name().and_then(|n| n.to_str()).unwrap_or(file).to_string();
            (vec![name, error.clone()], true)
        })
        .collect();
    let n = failed.len();
    Section {
        heading: format!("{n} recording{} not diagnosed", if n == 1 { "" } else { "s" }),
        verdict: Some(Badge {
            state: VerdictState::NotJudged,
            word: "NOT DIAGNOSED".into(),
            line: format!(
                "{} could not be read or analysed: no verdict, healthy or not, is given for {}",
                if n == 1 { "one recording" } else { "these recordings" },
                if n == 1 { "it" } else { "them" }
            ),
        }),
        tables: vec![Table {
            caption: "Recordings not diagnosed and why".into(),
            header: vec!["recording".into(), "what stopped it".into()],
            rows,
        }],
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::summary::{StageDiagnosis, StageGear, StageKind, TeethSource, VerdictGear};

    /// The revolutions' speeds keep the digits that tell them apart: a tracked 900 rpm shaft's were "from 15
    /// to 15 Hz" (14.999 and 15.002), a simulation's "from 25 to 25 Hz".
    #[test]
    fn the_range_of_revolution_speeds_is_never_one_number_twice() {
        assert_eq!(revolution_range(14.99904, 15.00213), "revolutions from 14.999 to 15.002 Hz");
        assert_eq!(revolution_range(29.9928, 30.0099), "revolutions from 29.99 to 30.01 Hz");
        assert_eq!(revolution_range(25.0, 25.0), "every revolution at 25 Hz");
        assert_eq!(revolution_range(25.0, 25.0 + 1e-12), "every revolution at 25 Hz");
    }

    /// The mesh order's source in words, not the JSON's key ("teeth baseline" was printed).
    #[test]
    fn the_teeth_source_is_said_in_words() {
        for t in [TeethSource::Given, TeethSource::Baseline, TeethSource::Estimated] {
            assert!(teeth_words(t).split(' ').count() > 1, "{}", teeth_words(t));
        }
        assert!(teeth_words(TeethSource::Baseline).contains("baseline recording"));
    }

    /// A machine's stages are on the page (only the first stage's mesh order was), without the terminal's
    /// quotes around shaft names.
    #[test]
    fn a_stage_is_said_with_its_gears_shafts_and_mesh() {
        let gear = |gear, shaft: &str, teeth| StageGear { gear, shaft: Some(shaft.into()), teeth };
        let stage = StageDiagnosis {
            stage: 2,
            kind: StageKind::Parallel,
            gears: vec![gear(VerdictGear::Pinion, "intermediate", 15), gear(VerdictGear::Wheel, "output", 45)],
            mesh_order_exact: "15/2".into(),
            mesh_order: 7.5,
            mesh_hz: Some(187.5),
            mesh_harmonics: Vec::new(),
            planetary: None,
        };
        assert_eq!(
            stage_fact(&stage),
            "Stage 2 mesh: pinion 15 teeth on shaft intermediate, wheel 45 teeth on shaft output; order 7.5 (15/2) of the tracked shaft, 187.5 Hz."
        );
        let first =
            StageDiagnosis { stage: 1, mesh_order_exact: "20".into(), mesh_order: 20.0, mesh_hz: None, ..stage };
        assert!(stage_fact(&first).ends_with("; order 20 of the tracked shaft."), "{}", stage_fact(&first));
    }
}
