//! Images and the HTML section of `identify`: measured lines against the fitted model, the per-tooth
//! profile deviation with its uncertainty, and the residual against the noise.

use super::ReportError;
use super::format::{num, percent, sig};
use super::html::{Badge, Section, Table, cell};
use super::plot::{Chart, Marker, PAGE_WIDTH_PX, Series, Style, render_png};
use super::summary::{Identification, PerTooth, PhaseOrigin, VerdictState};
use std::path::{Path, PathBuf};

fn stem(out: &Identification) -> String {
    Path::new(&out.recording).file_stem().and_then(|s| s.to_str()).unwrap_or("recording").to_string()
}

/// Writes `STEM-identify-lines.png`, `STEM-identify-teeth.png` and `STEM-identify-residual.png` into `dir`.
///
/// # Errors
/// Drawing or writing failures.
pub fn figures(out: &Identification, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    let stem = stem(out);
    let mut files = Vec::new();
    let lines = dir.join(format!("{stem}-identify-lines.png"));
    render_png(&lines, PAGE_WIDTH_PX, 600, &[lines_chart(out, &stem)])?;
    files.push(lines);
    let teeth = dir.join(format!("{stem}-identify-teeth.png"));
    let charts = teeth_charts(out, &stem);
    render_png(&teeth, PAGE_WIDTH_PX, 460 * charts.len() as u32, &charts)?;
    files.push(teeth);
    let residual = dir.join(format!("{stem}-identify-residual.png"));
    render_png(&residual, PAGE_WIDTH_PX, 560, &[residual_chart(out, &stem)])?;
    files.push(residual);
    Ok(files)
}

fn mesh_markers(out: &Identification, z1: f64) -> Vec<Marker> {
    (1..=out.mesh_harmonics).map(|h| Marker { x: h as f64 * z1, label: format!("mesh {h}"), color: 8 }).collect()
}

fn lines_chart(out: &Identification, stem: &str) -> Chart {
    let z1 = out.pinion_teeth as f64;
    let pts = |f: &dyn Fn(&super::summary::FitLine) -> f64| -> Vec<(f64, f64)> {
        out.lines.iter().map(|l| (l.order, f(l))).filter(|p| p.1 > 0.0).collect()
    };
    let missed: Vec<(f64, f64)> =
        out.lines.iter().filter(|l| l.residual > 3.0 * l.noise).map(|l| (l.order, l.measured)).collect();
    let mut series = vec![
        Series { name: "measured".into(), points: pts(&|l| l.measured), style: Style::Stems, color: 0 },
        Series { name: "fitted model".into(), points: pts(&|l| l.model), style: Style::Points, color: 1 },
    ];
    if !missed.is_empty() {
        series.push(Series {
            name: "missed by the model (residual > 3 noise std)".into(),
            points: missed,
            style: Style::Hatched,
            color: 3,
        });
    }
    Chart {
        title: format!("{stem}: measured lines against the fitted gear model ({} mesh harmonics)", out.mesh_harmonics),
        x_label: "pinion order [-]".into(),
        y_label: format!("amplitude [{}]", out.unit),
        y_log: true,
        series,
        markers: mesh_markers(out, z1),
        ..Chart::default()
    }
}

fn residual_chart(out: &Identification, stem: &str) -> Chart {
    let z1 = out.pinion_teeth as f64;
    let floor = out.lines.iter().map(|l| l.noise).filter(|v| *v > 0.0).fold(f64::INFINITY, f64::min);
    let clamp = |v: f64| v.max(floor * 1e-2);
    let mut noise: Vec<(f64, f64)> = out.lines.iter().map(|l| (l.order, 3.0 * l.noise)).collect();
    noise.sort_by(|a, b| a.0.total_cmp(&b.0));
    Chart {
        title: format!("{stem}: what the fitted model leaves (|measured - model| per line)"),
        x_label: "pinion order [-]".into(),
        y_label: format!("residual amplitude [{}]", out.unit),
        y_log: true,
        series: vec![
            Series {
                name: "residual".into(),
                points: out.lines.iter().map(|l| (l.order, clamp(l.residual))).collect(),
                style: Style::Stems,
                color: 0,
            },
            Series { name: "3 x noise standard error".into(), points: noise, style: Style::Line, color: 8 },
        ],
        markers: mesh_markers(out, z1),
        ..Chart::default()
    }
}

fn teeth_charts(out: &Identification, stem: &str) -> Vec<Chart> {
    let mut charts = vec![teeth_chart(out, stem, "pinion", &out.tooth_deviation_m, &out.tooth_deviation_std_m, true)];
    if !out.tooth_deviation_m.wheel.is_empty() {
        charts.push(teeth_chart(out, stem, "wheel", &out.tooth_deviation_m, &out.tooth_deviation_std_m, false));
    }
    charts
}

fn teeth_chart(out: &Identification, stem: &str, gear: &str, dev: &PerTooth, std: &PerTooth, pinion: bool) -> Chart {
    let (d, s) = if pinion { (&dev.pinion, &std.pinion) } else { (&dev.wheel, &std.wheel) };
    let um = |v: f64| v * 1e6;
    let bars: Vec<(f64, f64)> = d.iter().enumerate().map(|(k, v)| ((k + 1) as f64, um(*v))).collect();
    let errs: Vec<(f64, f64)> = d
        .iter()
        .zip(s)
        .enumerate()
        .flat_map(|(k, (v, e))| [((k + 1) as f64, um(v - 2.0 * e)), ((k + 1) as f64, um(v + 2.0 * e))])
        .collect();
    let origin = match if pinion { out.phase_origin.pinion } else { out.phase_origin.wheel } {
        PhaseOrigin::Tachometer => "tooth 1 meshes first after the tachometer pulse",
        PhaseOrigin::Arbitrary => "numbering from an arbitrary origin: no tachometer",
    };
    let n = d.len() as f64;
    let gear_of = if pinion { crate::model::gear::Gear::Pinion } else { crate::model::gear::Gear::Wheel };
    let markers = out
        .local_fault
        .iter()
        .filter(|f| f.gear == gear_of)
        .map(|f| Marker {
            x: f.tooth as f64,
            label: format!("{}: {}", f.kind.name(), fault_size(f.kind, f.depth)),
            color: 1,
        })
        .collect();
    Chart {
        title: format!("{stem}: {gear} profile deviation at each tooth's mesh position"),
        x_label: format!("{gear} tooth [-] ({origin})"),
        y_label: "deviation e [um]".into(),
        series: vec![
            Series { name: "fitted deviation".into(), points: bars, style: Style::Bars, color: 0 },
            Series { name: "+-2 standard errors".into(), points: errs, style: Style::ErrorBars, color: 8 },
        ],
        x_range: Some((0.3, n + 0.7)),
        markers,
        ..Chart::default()
    }
}

/// The size of a local fault in words: a crack as the share of the tooth's mesh stiffness it removes
/// ("29.9 % stiffness loss"), a pit as its depth in micrometres; a negative pit depth is material added,
/// not a pit, and said so.
pub fn fault_size(kind: super::summary::FaultKind, depth: f64) -> String {
    match kind {
        super::summary::FaultKind::Crack => format!("{} stiffness loss", percent(depth)),
        super::summary::FaultKind::Pit if depth >= 0.0 => format!("{} um deep", sig(depth * 1e6, 3)),
        super::summary::FaultKind::Pit => {
            format!("no pit: the fit adds {} um of material (a bump, not a pit)", sig(-depth * 1e6, 3))
        }
    }
}

/// The fit's condition number as people read it: "8", "3.2e10" ("8.0e0" was printed), "infinite" for a
/// singular fit (never "inf"); the terminal says it so too.
pub fn condition_words(c: f64) -> String {
    if c.is_finite() { sig(c, 2) } else { "infinite (the lines do not determine the parameters)".into() }
}

/// The section of `index.html`: the local fault (or none) as the badge, the error harmonics and gains.
pub fn section(out: &Identification, images: &[PathBuf]) -> Section {
    let badge = match &out.local_fault {
        Some(f) => Badge {
            state: VerdictState::Faulty,
            word: "LOCAL FAULT".into(),
            line: format!(
                "{} on {} tooth {}: {} (explains {} of the residual; significance {}, reported above 25)",
                f.kind.name(),
                f.gear.name(),
                f.tooth,
                fault_size(f.kind, f.depth),
                percent(f.improvement),
                num(f.significance)
            ),
        },
        None => Badge {
            state: VerdictState::Healthy,
            word: "NO LOCAL FAULT".into(),
            line: if out.fault_candidates.is_empty() {
                "no local-fault search asked (cracks, pits)".into()
            } else {
                "no local fault: no pit or crack on any tooth explains the lines beyond their noise".into()
            },
        },
    };
    let mut facts = vec![
        format!(
            "{} sampled at {} Hz; mean speed {:.3} Hz (scene {:.3} Hz); {} periods of {} pinion revolution(s) averaged; {} mesh harmonics.",
            out.quantity.name(),
            out.sample_rate_hz,
            out.speed.mean_hz,
            out.speed.scene_hz,
            out.periods,
            out.period_revolutions,
            out.mesh_harmonics
        ),
        format!(
            "Fit: {:.1} % of the sideband energy explained, chi2/dof {:.2}, condition number {}{}.",
            100.0 * out.explained_fraction,
            out.chi2_per_dof,
            condition_words(out.condition),
            if out.identifiable { "" } else { " (NOT identifiable)" }
        ),
    ];
    facts.extend(out.warnings.iter().map(|w| format!("Note: {w}")));
    let mut tables = vec![errors_table("Pinion transmission-error harmonics", &out.pinion_errors)];
    if !out.wheel_errors.is_empty() {
        tables.push(errors_table("Wheel transmission-error harmonics", &out.wheel_errors));
    }
    tables.push(Table {
        caption: "Transfer-path gains (measured / model) per mesh harmonic".into(),
        header: vec!["mesh harmonic".into(), "|G|".into(), "arg G [rad]".into()],
        rows: out
            .path_gains
            .iter()
            .map(|g| (vec![g.harmonic.to_string(), cell(g.magnitude), format!("{:.3}", g.phase_rad)], false))
            .collect(),
    });
    if !out.fault_candidates.is_empty() {
        tables.push(Table {
            caption: format!(
                "Best local-fault candidate of each kind (reported when the significance exceeds 25; {} = reported)",
                "highlighted"
            ),
            header: vec![
                "kind".into(),
                "gear".into(),
                "tooth".into(),
                "size".into(),
                "explains".into(),
                "significance".into(),
            ],
            rows: out
                .fault_candidates
                .iter()
                .map(|c| {
                    let reported = out
                        .local_fault
                        .as_ref()
                        .is_some_and(|f| f.kind == c.kind && f.gear == c.gear && f.tooth == c.tooth);
                    (
                        vec![
                            c.kind.name().into(),
                            c.gear.name().into(),
                            c.tooth.to_string(),
                            fault_size(c.kind, c.depth),
                            percent(c.improvement),
                            num(c.significance),
                        ],
                        reported,
                    )
                })
                .collect(),
        });
    }
    if !out.residual_lines.is_empty() {
        tables.push(Table {
            caption: format!("Lines the fitted model misses by more than 3 noise standard errors ({})", out.unit),
            header: vec![
                "line".into(),
                "order".into(),
                "Hz".into(),
                "measured".into(),
                "model".into(),
                "residual / noise".into(),
            ],
            rows: out
                .residual_lines
                .iter()
                .map(|l| {
                    (
                        vec![
                            l.label.clone(),
                            format!("{:.3}", l.order),
                            format!("{:.1}", l.frequency_hz),
                            cell(l.measured),
                            cell(l.model),
                            format!("{:.1}", l.residual / l.noise),
                        ],
                        false,
                    )
                })
                .collect(),
        });
    }
    Section {
        heading: format!("{} fitted with {}", out.recording, out.scene),
        verdict: Some(badge),
        reasons: Vec::new(),
        facts,
        tables,
        images: images.to_vec(),
    }
}

fn errors_table(caption: &str, e: &[super::summary::ErrorHarmonic]) -> Table {
    Table {
        caption: format!("{caption}: e(t) = sum e_i cos(i w t + alpha_i); rows not resolved are highlighted"),
        header: vec!["order".into(), "e_i [um]".into(), "std [um]".into(), "alpha_i [rad]".into(), "std [rad]".into()],
        rows: e
            .iter()
            .map(|h| {
                (
                    vec![
                        h.order.to_string(),
                        format!("{:.3}", h.amplitude_m * 1e6),
                        format!("{:.3}", h.amplitude_std_m * 1e6),
                        format!("{:.3}", h.phase_rad),
                        format!("{:.3}", h.phase_std_rad),
                    ],
                    !h.resolved,
                )
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_condition_number_reads_as_a_number() {
        assert_eq!(condition_words(8.0), "8");
        assert_eq!(condition_words(8.04), "8");
        assert_eq!(condition_words(3.2e10), "3.2e10");
        assert!(condition_words(f64::INFINITY).starts_with("infinite"));
    }
}
