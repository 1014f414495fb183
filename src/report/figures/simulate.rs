//! The images of `simulate`: the output over one period, its order spectrum, the multipliers, the press.

use super::*;

/// Writes the simulation images of `summary` (names, units, lines, multipliers) and `series` (the curves)
/// into `dir`; returns their paths.
///
/// # Errors
/// Non-finite data or write failures.
pub fn simulation(
    summary: &SimulateSummary,
    series: &SimulationSeries,
    dir: &Path,
) -> Result<Vec<PathBuf>, ReportError> {
    let mut out = Vec::new();
    let (name, quantity) = (&summary.stability.scene, &summary.quantity);
    let (base_hz, base_name) = (summary.base_hz, &summary.base);
    let unit =
        if summary.unit.is_empty() { " [units of the model]".to_string() } else { format!(" [{}]", summary.unit) };
    let period = summary.stability.period_s;
    let period_samples = &series.period_samples;
    // waveform over (up to) three base revolutions, or three periods when the period is shorter
    let revs = (period * base_hz).max(1e-12);
    let copies = (3.0 / revs).ceil().clamp(1.0, 64.0) as usize;
    let m = period_samples.len();
    let shown = (copies * m).min(20_000);
    // seconds for slow machines (the press turns at 0.83 Hz), milliseconds for a gear mesh
    let span = period * shown as f64 / m as f64;
    let (to_unit, time_unit) = if span >= 1.0 { (1.0, "s") } else { (1e3, "ms") };
    let pts: Vec<(f64, f64)> =
        (0..shown).map(|i| (to_unit * period * i as f64 / m as f64, period_samples[i % m])).collect();
    let wave = Chart {
        title: format!("{name}: {quantity} over {span:.3} s of steady state"),
        x_label: format!("time [{time_unit}]"),
        y_label: format!("{quantity}{unit}"),
        series: vec![Series { name: quantity.clone(), points: pts, style: Style::Line, color: 0 }],
        ..Default::default()
    };
    let p = dir.join("waveform.png");
    render_png(&p, PAGE_WIDTH_PX, 520, &[wave])?;
    out.push(p);
    // spectrum with mesh harmonics and sidebands
    let orders = &summary.orders;
    let peak = orders.iter().skip(1).map(|l| l.amplitude).fold(0.0, f64::max);
    let floor = peak * 1e-5;
    let teeth = series.teeth;
    let max_hz = orders.last().map_or(1.0, |l| l.frequency_hz);
    // a gear pair reads in Hz (the mesh frequency is what an analyser shows); any other machine in orders
    // of its base rotation, where its harmonics fall on integers
    let spectrum = match teeth {
        Some(_) => Chart {
            title: format!("{name}: amplitude spectrum of {quantity} (steady state, one period)"),
            x_label: format!("frequency [Hz]   (orders of the {base_name} = {base_hz:.2} Hz)"),
            y_label: format!("amplitude{unit}"),
            y_log: true,
            // room on the right for the legend, above the data for the labels
            x_range: Some((0.0, max_hz * 1.02)),
            y_range: Some((floor, peak * 10.0)),
            series: order_stems(orders, teeth, floor),
            markers: mesh_markers(teeth, base_hz, max_hz),
            ..Default::default()
        },
        None => {
            let by_order: Vec<OrderLine> = orders.iter().map(|l| OrderLine { frequency_hz: l.order, ..*l }).collect();
            let max_order = orders.last().map_or(1.0, |l| l.order);
            Chart {
                title: format!(
                    "{name}: amplitude spectrum of {quantity} (steady state, one period; {base_name} = {base_hz:.3} Hz)"
                ),
                x_label: format!("order of the {base_name} [-]"),
                y_label: format!("amplitude{unit}"),
                y_log: true,
                x_range: Some((0.0, max_order + 1.0)),
                y_range: Some((floor, peak * 10.0)),
                series: order_stems(&by_order, None, floor),
                ..Default::default()
            }
        }
    };
    let p = dir.join("spectrum.png");
    render_png(&p, PAGE_WIDTH_PX, 620, &[spectrum])?;
    out.push(p);
    // zooms around the first three mesh harmonics (like the paper's Fig 13)
    if let Some((z1, z2)) = teeth {
        let fz = z1 as f64 * base_hz;
        let mut charts = Vec::new();
        for k in 1..=3 {
            let centre = k as f64 * fz;
            let (lo, hi) = (centre - 7.5 * base_hz, centre + 7.5 * base_hz);
            let lines: Vec<OrderLine> =
                orders.iter().filter(|l| l.frequency_hz >= lo && l.frequency_hz <= hi).copied().collect();
            if lines.iter().all(|l| l.amplitude <= floor) {
                continue;
            }
            let markers =
                lines.iter().filter(|l| l.amplitude > floor).filter_map(|l| zoom_marker(l, k, z1, z2)).collect();
            charts.push(Chart {
                title: format!(
                    "zoom around {k} x mesh = {centre:.0} Hz: sidebands labelled in pinion orders (w: wheel orders)"
                ),
                x_label: "frequency [Hz]".into(),
                y_label: format!("amplitude{unit}"),
                y_log: true,
                // centred on the mesh line; the legend sits below the labels, over the lower side's lines
                x_range: Some((lo, hi)),
                y_range: Some((floor, peak * 10.0)),
                series: order_stems(&lines, teeth, floor),
                markers,
                ..Default::default()
            });
        }
        if !charts.is_empty() {
            let p = dir.join("zoom-mesh.png");
            render_png(&p, PAGE_WIDTH_PX, 420 * charts.len() as u32, &charts)?;
            out.push(p);
        }
    }
    out.push(multipliers(&summary.stability, dir)?);
    if !series.press.is_empty() {
        out.push(press_figures(name, &series.press, dir)?);
    }
    Ok(out)
}

/// The label of a line of the zoom around the `k`-th mesh harmonic of a pair with `z1`, `z2` teeth: "kfz"
/// for the mesh line, its distance in pinion orders ("-2") for a pinion sideband, in wheel orders ("+1w")
/// for a wheel sideband, each in its stem's colour; none for other lines.
fn zoom_marker(l: &OrderLine, k: usize, z1: usize, z2: usize) -> Option<Marker> {
    let d = l.order - (k * z1) as f64;
    let (label, color) = match classify(l.order, z1, z2) {
        LineKind::Mesh => (format!("{k}fz"), 0),
        LineKind::Pinion => (format!("{:+}", d.round() as i64), 1),
        LineKind::Wheel => (format!("{:+}w", (d * z2 as f64 / z1 as f64).round() as i64), 2),
        LineKind::Other => return None,
    };
    Some(Marker { x: l.frequency_hz, label, color })
}

/// Dashed lines at the mesh harmonics up to `max_hz` of a pair with `teeth` whose pinion turns at
/// `base_hz`.
fn mesh_markers(teeth: Option<(usize, usize)>, base_hz: f64, max_hz: f64) -> Vec<Marker> {
    let Some((z1, _)) = teeth else { return Vec::new() };
    let fz = z1 as f64 * base_hz;
    (1..)
        .map(|k| k as f64 * fz)
        .take_while(|f| *f <= max_hz)
        .enumerate()
        .map(|(i, f)| Marker { x: f, label: format!("{}x mesh", i + 1), color: 0 })
        .collect()
}

/// Floquet multipliers of `summary` in the complex plane with the unit circle.
///
/// # Errors
/// Write failures.
pub fn multipliers(summary: &StabilitySummary, dir: &Path) -> Result<PathBuf, ReportError> {
    let pts: Vec<(f64, f64)> = summary.multipliers.iter().map(|r| (r.re, r.im)).collect();
    let rho = summary.rho_max;
    let r = rho.max(1.0) * 1.15;
    let verdict = if summary.stable { "stable" } else { "NOT asymptotically stable" };
    let chart = Chart {
        title: format!("{}: multipliers, |rho|max = {} ({verdict})", summary.scene, num(rho)),
        x_label: "Re rho [-]".into(),
        y_label: "Im rho [-]".into(),
        x_range: Some((-r, r)),
        y_range: Some((-r, r)),
        unit_circle: true,
        equal_axes: true,
        series: vec![Series { name: "multipliers".into(), points: pts.clone(), style: Style::Points, color: 1 }],
        ..Default::default()
    };
    let p = dir.join("multipliers.png");
    // multipliers far inside the circle sit on a dot at this scale: a second panel zoomed onto them
    if rho > 0.0 && rho < 0.3 {
        let z = rho * 1.3;
        let zoom = Chart {
            title: format!("zoomed to |rho| <= {} (the unit circle is off this panel)", num(z)),
            x_label: "Re rho [-]".into(),
            y_label: "Im rho [-]".into(),
            x_range: Some((-z, z)),
            y_range: Some((-z, z)),
            equal_axes: true,
            series: vec![Series { name: "multipliers".into(), points: pts, style: Style::Points, color: 1 }],
            ..Default::default()
        };
        render_png_grid(&p, PAGE_WIDTH_PX, 600, 2, &[chart, zoom])?;
    } else {
        render_png(&p, 800, 820, &[chart])?;
    }
    Ok(p)
}

/// The press: q1 and q2 over one period with their spectra (the paper's Figs 3 and 4).
fn press_figures(name: &str, press: &[PressCoordinate], dir: &Path) -> Result<PathBuf, ReportError> {
    let mut charts = Vec::new();
    for (idx, c) in press.iter().enumerate() {
        let peak = c.lines.iter().map(|l| l.1).fold(0.0, f64::max);
        let fig = if idx == 0 { "3" } else { "4" };
        charts.push(Chart {
            title: format!("{name}: {} over one input revolution (Fig {fig}a)", c.name),
            x_label: "time [s]".into(),
            y_label: format!("{} [{}]", c.name, c.unit),
            series: vec![Series { name: c.name.clone(), points: c.points.clone(), style: Style::Line, color: idx }],
            ..Default::default()
        });
        charts.push(Chart {
            title: format!("spectrum of {} by order of the input speed W (Fig {fig}b)", c.name),
            x_label: "order of W [-]".into(),
            y_label: format!("amplitude [{}]", c.unit),
            y_log: true,
            x_range: Some((0.0, 25.0)),
            y_range: Some((peak * 1e-6, peak * 3.0)),
            series: vec![Series { name: c.name.clone(), points: c.lines.clone(), style: Style::Stems, color: idx }],
            ..Default::default()
        });
    }
    let p = dir.join("press-q1-q2.png");
    render_png(&p, PAGE_WIDTH_PX, 1500, &charts)?;
    Ok(p)
}
