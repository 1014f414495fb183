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
        .map(|(k, v)| {
            let k = if k == "estimated_shaft" { "shaft of the estimated period" } else { k };
            v.map_or(format!("{k}: one revolution every {} samples", cell(d.shaft_period_samples)), |f| {
                format!("{k} {} Hz ({} rpm)", cell(f), cell(60.0 * f))
            })
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
        "Shaft angle tracked by {}{}; speed change over the recording {} %.",
        p.tracking,
        match (p.min_hz, p.max_hz) {
            (Some(lo), Some(hi)) => format!(", revolutions from {} to {} Hz", cell(lo), cell(hi)),
            _ => String::new(),
        },
        cell(p.change_percent)
    ));
    facts.push(format!("Mesh: order {} of the reference shaft (teeth {}).", d.mesh_order, d.teeth_source));
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
            header: ["gear".to_string(), "channel".to_string()]
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
            header: ["gear", "channel", "indicator", "value", "baseline centre", "baseline range", "spreads", "suspect at", "faulty at"]
                .iter()
                .map(|s| s.to_string())
                .collect(),
            rows: Vec::new(),
        };
        for s in &d.scores {
            let hit = s.decides && s.spreads >= s.suspect_at;
            t.rows.push((
                vec![
                    s.gear.name().to_string(),
                    s.channel.to_string(),
                    s.indicator.label().to_string(),
                    cell(s.value),
                    cell(s.baseline_centre),
                    format!("{} to {}", cell(s.baseline_range[0]), cell(s.baseline_range[1])),
                    if s.decides { crate::report::format::sig(s.spreads, 3) } else { "near zero".into() },
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
            line: format!("gear: {}", d.verdict.place()),
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
