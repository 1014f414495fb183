//! The sections of `simulate`, `stability`, `sweep` and `bench`.

use super::{Badge, Section, Table, cell};
use crate::report::summary::{BenchReport, SimulateSummary, StabilitySummary, SweepSummary, VerdictState};
use std::path::PathBuf;

/// The section of a simulation: stability, solver and error, the strongest orders, the images.
pub fn simulation_section(s: &SimulateSummary, images: &[PathBuf]) -> Section {
    let mut sec = stability_section(&s.stability, images);
    sec.facts.push(format!(
        "{} RMS {} {}, peak to peak {} {}; orders of the {} ({} Hz).",
        s.quantity,
        cell(s.rms),
        s.unit,
        cell(s.peak_to_peak),
        s.unit,
        s.base,
        cell(s.base_hz)
    ));
    let mut lines = s.orders.clone();
    lines.sort_by(|a, b| b.amplitude.total_cmp(&a.amplitude));
    sec.tables.push(Table {
        caption: format!("Strongest orders ({})", s.unit),
        header: vec!["order".into(), "frequency [Hz]".into(), format!("amplitude [{}]", s.unit)],
        rows: lines
            .iter()
            .take(12)
            .map(|o| (vec![cell(o.order), cell(o.frequency_hz), cell(o.amplitude)], false))
            .collect(),
    });
    sec
}

/// The section of a Floquet analysis.
pub fn stability_section(s: &StabilitySummary, images: &[PathBuf]) -> Section {
    let state = if s.stable { VerdictState::Healthy } else { VerdictState::Faulty };
    Section {
        heading: s.scene.clone(),
        verdict: Some(Badge {
            state,
            word: if s.stable { "STABLE" } else { "UNSTABLE" }.into(),
            // six digits: a multiplier of 0.999995 must not read as 1
            line: format!("largest |multiplier| {}", crate::report::format::sig(s.rho_max, 6)),
        }),
        reasons: Vec::new(),
        facts: vec![
            format!(
                "Period {} s; solver {}, {} {}. Why: {}.",
                cell(s.period_s),
                s.method,
                s.steps,
                s.resolution_unit,
                s.method_reason.trim_end_matches('.')
            ),
            format!("Estimated error {} against the tolerance {}.", cell(s.error_estimate), cell(s.tolerance)),
        ],
        tables: Vec::new(),
        images: images.to_vec(),
    }
}

/// The section of a sweep: how many points are stable, unstable, untrusted or failed, the images.
pub fn sweep_section(s: &SweepSummary, images: &[PathBuf]) -> Section {
    let count = |f: &dyn Fn(&crate::report::summary::SweepPoint) -> bool| s.points.iter().filter(|p| f(p)).count();
    let unstable = count(&|p| p.stable == Some(false));
    Section {
        heading: format!("{}: sweep of {}", s.scene, crate::report::figures::parameter_label(&s.param)),
        verdict: Some(Badge {
            state: if unstable > 0 { VerdictState::Suspect } else { VerdictState::Healthy },
            word: if unstable > 0 { "UNSTABLE POINTS" } else { "ALL STABLE" }.into(),
            line: format!("{unstable} of {} points unstable", s.points.len()),
        }),
        reasons: Vec::new(),
        facts: vec![format!(
            "{} points; {} untrusted (error above the tolerance); {} failed.",
            s.points.len(),
            count(&|p| !p.trusted && p.error.is_none()),
            count(&|p| p.error.is_some())
        )],
        tables: if s.unstable_ranges.is_empty() {
            Vec::new()
        } else {
            vec![Table {
                caption: format!(
                    "Unstable ranges of {} (runs of consecutive unstable points)",
                    crate::report::figures::parameter_label(&s.param)
                ),
                header: ["from", "to", "points", "largest |rho|max"].iter().map(|h| h.to_string()).collect(),
                rows: s
                    .unstable_ranges
                    .iter()
                    .map(|r| (vec![cell(r.from), cell(r.to), r.points.to_string(), cell(r.rho_max)], true))
                    .collect(),
            }]
        },
        images: images.to_vec(),
    }
}

/// The section of a benchmark: every method's time and error against the reference, the images.
pub fn bench_section(b: &BenchReport, images: &[PathBuf]) -> Section {
    let table = Table {
        caption: "Time (median, whole solve) against error (relative to the converged reference)".into(),
        header: vec!["scene".into(), "method".into(), "resolution".into(), "time [s]".into(), "error".into()],
        rows: b
            .results
            .iter()
            .map(|r| {
                let (method, resolution) = bench_words(&r.method, r.resolution);
                (vec![r.scene.clone(), method, resolution, cell(r.time_s), cell(r.error)], false)
            })
            .collect(),
    };
    Section {
        heading: "Speed against error".into(),
        verdict: None,
        reasons: Vec::new(),
        facts: Vec::new(),
        tables: vec![table],
        images: images.to_vec(),
    }
}

/// A benchmark row's method and resolution in words: "auto@1e-6->hill" is "auto at tolerance 1e-6 (chose
/// hill)", and the resolution names its unit (steps of a time-stepping solver, harmonics of harmonic
/// balance), which the bare number did not.
fn bench_words(method: &str, resolution: usize) -> (String, String) {
    let (words, solver) = match method.strip_prefix("auto@").and_then(|r| r.split_once("->")) {
        Some((tol, solver)) => (format!("auto at tolerance {tol} (chose {solver})"), solver),
        None => (method.to_string(), method),
    };
    let unit = match solver {
        "hill" => "harmonics",
        "rk4" | "magnus4" => "steps",
        _ => "",
    };
    (words, format!("{resolution} {unit}").trim_end().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bench_rows_say_the_method_and_the_resolutions_unit() {
        assert_eq!(bench_words("rk4", 134), ("rk4".to_string(), "134 steps".to_string()));
        assert_eq!(bench_words("hill", 146), ("hill".to_string(), "146 harmonics".to_string()));
        assert_eq!(
            bench_words("auto@1e-6->magnus4", 40),
            ("auto at tolerance 1e-6 (chose magnus4)".to_string(), "40 steps".to_string())
        );
        assert_eq!(bench_words("other", 7).1, "7");
    }
}
