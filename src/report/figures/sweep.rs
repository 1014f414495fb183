//! The images of `sweep` (the stability map) and `bench` (work against precision).

use super::*;

/// Axis label of a swept scene field from its name's unit suffix: `gear_pair.speed_rpm` -> `speed [rpm]`.
pub fn parameter_label(path: &str) -> String {
    let last = path.rsplit('.').next().unwrap_or(path);
    let suffixes = [
        ("_rpm", "rpm"),
        ("_n_per_m", "N/m"),
        ("_kg_m2", "kg m^2"),
        ("_m_per_rad", "m/rad"),
        ("_n_m_per_rad", "N m/rad"),
        ("_hz", "Hz"),
        ("_kg", "kg"),
        ("_rad", "rad"),
        ("_n", "N"),
        ("_m", "m"),
        ("_s", "s"),
        ("_ratio", "-"),
    ];
    for (suffix, unit) in suffixes {
        if let Some(name) = last.strip_suffix(suffix) {
            let name = if suffix == "_ratio" { last } else { name };
            return format!("{} [{unit}]", name.replace('_', " "));
        }
    }
    format!("{} [-]", last.replace('_', " "))
}

/// Ranges of unstable points as bands reaching half a step to each side, so a single unstable point shows.
pub(super) fn unstable_bands(points: &[SweepPoint]) -> Vec<Band> {
    let span = match (points.first(), points.last()) {
        (Some(a), Some(b)) => (b.value - a.value).abs(),
        _ => 0.0,
    };
    // at least 0.4 % of the axis wide, so that one unstable point among thousands is visible
    let step = if points.len() > 1 { (points[1].value - points[0].value).abs() } else { 0.0 }.max(0.004 * span);
    let mut bands: Vec<Band> = Vec::new();
    for p in points.iter().filter(|p| p.stable == Some(false)) {
        let (from, to) = (p.value - 0.5 * step, p.value + 0.5 * step);
        match bands.last_mut() {
            Some(b) if from <= b.to + 1e-9 * step.max(1e-300) => b.to = to,
            _ => bands.push(Band { from, to }),
        }
    }
    bands
}

/// Stability map of a sweep: the margin |1 - |rho|max| (on a log axis when it spans a decade or more; stable and unstable points in their
/// own colours, untrusted points marked), unstable ranges shaded, and the steady-state line amplitudes.
///
/// # Errors
/// Empty data or a failed write.
pub fn stability_map(
    path: &Path,
    scene: &str,
    param: &str,
    amplitude_unit: &str,
    points: &[SweepPoint],
) -> Result<(), ReportError> {
    let x_label = parameter_label(param);
    let ok: Vec<&SweepPoint> = points.iter().filter(|p| p.rho_max.is_some()).collect();
    let margin = |p: &&SweepPoint| (p.value, (1.0 - p.rho_max.unwrap_or(f64::NAN)).abs().max(1e-16));
    let stable: Vec<(f64, f64)> = ok.iter().filter(|p| p.stable == Some(true)).map(margin).collect();
    let unstable: Vec<(f64, f64)> = ok.iter().filter(|p| p.stable != Some(true)).map(margin).collect();
    let untrusted: Vec<(f64, f64)> = ok.iter().filter(|p| !p.trusted).map(margin).collect();
    let bands = unstable_bands(points);
    let (lo, hi) = (points.first().map_or(0.0, |p| p.value), points.last().map_or(1.0, |p| p.value));
    let mut series = vec![Series { name: "stable: 1 - |rho|max".into(), points: stable, style: Style::Line, color: 0 }];
    if !unstable.is_empty() {
        series.push(Series { name: "unstable: |rho|max - 1".into(), points: unstable, style: Style::Points, color: 1 });
    }
    if !untrusted.is_empty() {
        series.push(Series {
            name: "untrusted (error above the tolerance)".into(),
            points: untrusted,
            style: Style::Points,
            color: 3,
        });
    }
    // a log axis only when the margin spans a decade or more: within one it would carry a single labelled
    // tick (0.97 to 0.99 showed only "1")
    let (m_lo, m_hi) = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1))
        .fold((f64::INFINITY, 0.0f64), |(a, b), m| (a.min(m), b.max(m)));
    let top = Chart {
        title: format!("{scene}: Floquet stability margin over {x_label} (shaded: unstable)"),
        x_label: x_label.clone(),
        y_label: "|1 - |rho|max| [-]".into(),
        y_log: m_hi >= 10.0 * m_lo,
        x_range: Some((lo, hi)),
        series,
        bands: bands.clone(),
        ..Default::default()
    };
    let names: Vec<String> = ok.first().map(|p| p.lines.iter().map(|l| l.0.clone()).collect()).unwrap_or_default();
    let series: Vec<Series> = names
        .iter()
        .enumerate()
        .map(|(i, n)| Series {
            name: n.clone(),
            points: ok
                .iter()
                .filter(|p| p.stable == Some(true))
                .filter_map(|p| p.lines.get(i).map(|l| (p.value, l.1)))
                .filter(|q| q.1 > 0.0)
                .collect(),
            style: Style::Line,
            color: i + 4,
        })
        .filter(|s| !s.points.is_empty())
        .collect();
    let mut charts = vec![top];
    if !series.is_empty() {
        charts.push(Chart {
            title: "steady-state line amplitudes (stable points only)".into(),
            x_label,
            y_label: if amplitude_unit.is_empty() {
                "amplitude [unit of the output]".into()
            } else {
                format!("amplitude [{amplitude_unit}]")
            },
            y_log: true,
            x_range: Some((lo, hi)),
            series,
            bands,
            ..Default::default()
        });
    }
    render_png(path, PAGE_WIDTH_PX, 480 * charts.len() as u32, &charts)
}

/// Work-precision chart of one scene's results (log-log error against time).
pub(super) fn bench_chart(scene: &str, results: &[BenchResult]) -> Chart {
    let mut series = Vec::new();
    for (i, m) in ["rk4", "hill"].iter().enumerate() {
        let pts: Vec<(f64, f64)> = results
            .iter()
            .filter(|r| r.scene == scene && r.method == *m)
            .map(|r| (r.time_s, r.error.max(1e-16)))
            .collect();
        if !pts.is_empty() {
            let label = if *m == "rk4" {
                "rk4 product (paper), steps doubling"
            } else {
                "harmonic balance (Hill), harmonics x1.25"
            };
            series.push(Series { name: label.into(), points: pts, style: Style::LinePoints, color: i });
        }
    }
    let auto: Vec<(f64, f64)> = results
        .iter()
        .filter(|r| r.scene == scene && r.method.starts_with("auto"))
        .map(|r| (r.time_s, r.error.max(1e-16)))
        .collect();
    if !auto.is_empty() {
        series.push(Series {
            name: "auto at tolerance 1e-6, 1e-8, 1e-10 (full solve)".into(),
            points: auto,
            style: Style::Points,
            color: 3,
        });
    }
    Chart {
        title: format!("Speed against error: {scene}"),
        x_label: "wall time of one solve [s] (median)".into(),
        y_label: "relative error of the periodic solution [-]".into(),
        x_log: true,
        y_log: true,
        series,
        ..Default::default()
    }
}

/// Draws the work-precision chart of `scene` from `results` into `png`.
///
/// # Errors
/// Empty data or a failed write.
pub fn bench(png: &Path, scene: &str, results: &[BenchResult]) -> Result<(), ReportError> {
    render_png(png, PAGE_WIDTH_PX, 720, &[bench_chart(scene, results)])
}
