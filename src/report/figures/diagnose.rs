//! The images of `diagnose`: spectra with the baseline and the marked lines, mesh zooms, TSAs, envelope,
//! kurtogram, cepstrum, order map, and the trend over recordings.

use super::*;

/// Writes the diagnosis images of one recording into `dir` (file names start with the recording's stem).
///
/// # Errors
/// Non-finite data or write failures.
pub fn diagnosis(d: &Diagnosis, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    let stem = Path::new(&d.file).file_stem().and_then(|s| s.to_str()).unwrap_or("recording").to_string();
    let mut out = Vec::new();
    // TSA of each gear (first channel)
    let ch = d.channels[0];
    // angle axis in teeth of the gear (tooth k between k - 1 and k), the origin at the tachometer pulse or,
    // with mesh-phase tracking, arbitrary
    let origin = if d.speed_profile.tracking.tachometer_origin() {
        "origin: tachometer pulse"
    } else {
        "origin arbitrary (no tachometer)"
    };
    let tsas: Vec<Chart> = d
        .tsas()
        .filter(|(g, _, _)| g.channel == ch)
        .flat_map(|(g, t, _)| {
            let z = g.mesh_order as f64;
            let along = |v: &[f64]| -> Vec<(f64, f64)> {
                v.iter().enumerate().map(|(i, y)| (z * i as f64 / v.len() as f64, *y)).collect()
            };
            let x_label = format!("{} tooth in mesh (tooth k spans k-1 .. k of {}; {origin})", g.gear, g.mesh_order);
            let mut tsa_series = vec![Series { name: "TSA".into(), points: along(t), style: Style::Line, color: 0 }];
            // the healthy baseline's TSA of the same channel and gear (aligned only with a tachometer)
            if let Some((_, _, b)) = d
                .baseline_tsas
                .iter()
                .find(|b| b.0 == ch && b.1.baseline_key() == g.gear.baseline_key() && b.2.len() == t.len())
            {
                // without a tachometer both origins are arbitrary: the baseline is turned to fit best
                let (b, how) = if d.speed_profile.tracking.tachometer_origin() {
                    (b.clone(), "tachometer-aligned")
                } else {
                    (aligned(b, t), "turned to the best fit")
                };
                tsa_series.push(Series {
                    name: format!("healthy baseline TSA ({how})"),
                    points: along(&b),
                    style: Style::Line,
                    color: 8,
                });
            }
            [
                Chart {
                    title: format!(
                        "{stem}: time-synchronous average, {} (channel {ch}, {} revolutions)",
                        g.gear, g.revolutions
                    ),
                    x_label: x_label.clone(),
                    y_label: format!("TSA [{}]", unit_or(&d.unit)),
                    series: tsa_series,
                    x_range: Some((0.0, z)),
                    ..Default::default()
                },
                Chart {
                    title: format!(
                        "{stem}: residual (TSA without shaft orders 1-2 and mesh harmonics) and difference, {}",
                        g.gear
                    ),
                    x_label,
                    y_label: format!("residual, difference [{}]", unit_or(&d.unit)),
                    series: vec![
                        Series { name: "residual".into(), points: along(&g.residual), style: Style::Line, color: 1 },
                        Series {
                            name: "difference (residual without the first sidebands)".into(),
                            points: along(&g.difference),
                            style: Style::Line,
                            color: 2,
                        },
                    ],
                    x_range: Some((0.0, z)),
                    ..Default::default()
                },
            ]
        })
        .collect();
    if !tsas.is_empty() {
        let p = dir.join(format!("{stem}-tsa.png"));
        render_png(&p, 1400, 380 * tsas.len() as u32, &tsas)?;
        out.push(p);
    }
    // spectrum with mesh harmonics and sidebands (when the sample rate is known)
    if let Some((_, amp)) = d.spectra().iter().find(|s| s.0 == ch) {
        let fm = d.mesh_hz.unwrap_or(0.0);
        let max_f = (3.6 * fm).min(*amp.freqs_hz.last().unwrap_or(&1.0));
        let pts = in_band(amp, max_f);
        let peak = pts.iter().map(|p| p.1).fold(0.0, f64::max);
        let mut series = vec![Series {
            name: "amplitude spectrum (Hann, averaged)".into(),
            points: pts,
            style: Style::Line,
            color: 4,
        }];
        // the healthy baseline on top, in black: where this recording's lines grew they stand out above it
        if let Some((_, b)) = d.baseline_spectra.iter().find(|s| s.0 == ch) {
            let base = in_band(b, max_f);
            series.push(Series { name: "baseline (healthy)".into(), points: base, style: Style::Line, color: 8 });
        }
        // unresolved sidebands (another shaft's line within the main lobe) are not drawn as measured, and
        // neither are sidebands under 3x the local noise floor: a marker on the floor would read as a detection
        let side = |shaft: Shaft| -> Vec<(f64, f64)> {
            d.mesh_harmonics
                .iter()
                .flat_map(|h| h.sidebands.iter())
                .filter(|s| s.shaft == shaft && s.resolved)
                .filter_map(|s| s.frequency_hz.map(|f| (f, s.amplitude)))
                .filter(|&(f, a)| a > DETECTION_OVER_FLOOR * noise_floor(amp, f))
                .collect()
        };
        let shafts = match d.shaft_hz {
            ShaftHz::Pair { .. } => vec![Shaft::Pinion, Shaft::Wheel],
            ShaftHz::Pinion { .. } => vec![Shaft::Pinion],
            ShaftHz::Estimated { .. } => vec![Shaft::Estimated],
        };
        for (i, shaft) in shafts.into_iter().enumerate() {
            let pts = side(shaft);
            if !pts.is_empty() {
                series.push(Series {
                    name: format!("{shaft} sidebands +-1..3 (detected)"),
                    points: pts,
                    style: Style::Points,
                    color: 1 + i,
                });
            }
        }
        let mesh_pts: Vec<(f64, f64)> =
            d.mesh_harmonics.iter().filter_map(|h| h.frequency_hz.map(|f| (f, h.amplitude))).collect();
        series.push(Series { name: "mesh harmonics".into(), points: mesh_pts, style: Style::Points, color: 0 });
        let markers = d
            .mesh_harmonics
            .iter()
            .filter_map(|h| h.frequency_hz.map(|f| Marker { x: f, label: format!("{}x mesh", h.k), color: 0 }))
            .collect();
        let chart = Chart {
            title: format!("{stem}: spectrum, channel {ch}; verdict {} ({})", d.verdict.state, d.verdict.gear),
            x_label: "frequency [Hz]".into(),
            y_label: format!("amplitude [{}]", unit_or(&d.unit)),
            y_log: true,
            x_range: Some((0.0, max_f)),
            y_range: Some((peak * 1e-5, peak * 10.0)),
            series,
            markers,
            ..Default::default()
        };
        let p = dir.join(format!("{stem}-spectrum.png"));
        render_png(&p, 1400, 700, &[chart])?;
        out.push(p);
    }
    let zooms = mesh_zooms(&stem, d, ch);
    if !zooms.is_empty() {
        let p = dir.join(format!("{stem}-zoom.png"));
        render_png(&p, 1400, 420 * zooms.len() as u32, &zooms)?;
        out.push(p);
    }
    if let Some(e) = &d.envelope {
        let p = dir.join(format!("{stem}-envelope.png"));
        render_png(&p, 1400, 600, &[envelope_chart(&stem, d, e)])?;
        out.push(p);
        if let Some(fs) = d.sample_rate_hz {
            let p = dir.join(format!("{stem}-kurtogram.png"));
            render_png(&p, 1400, 550, &[kurtogram_chart(&stem, e, fs)])?;
            out.push(p);
        }
    }
    if let Some(c) = &d.cepstrum {
        let p = dir.join(format!("{stem}-cepstrum.png"));
        render_png(&p, 1400, 550, &[cepstrum_chart(&stem, c)])?;
        out.push(p);
    }
    if let (Some(m), Some(fs)) = (&d.order_map, d.sample_rate_hz) {
        let p = dir.join(format!("{stem}-order-map.png"));
        render_png(&p, 1400, 800, &[order_map_chart(&stem, d, m, fs)])?;
        out.push(p);
    }
    if let Some(c) = &d.comparison {
        // one overlay: measured and model bars side by side at each order, the lines the model misses
        // (measured more than 6 dB above it) ringed
        let meas: Vec<(f64, f64)> = c.lines.iter().map(|l| (l.order as f64 - 0.15, l.measured_db)).collect();
        let model: Vec<(f64, f64)> = c.lines.iter().map(|l| (l.order as f64 + 0.15, l.model_db)).collect();
        let missed: Vec<(f64, f64)> =
            c.lines.iter().filter(|l| l.difference_db > 6.0).map(|l| (l.order as f64 - 0.15, l.measured_db)).collect();
        let lo = c.lines.iter().map(|l| l.measured_db.min(l.model_db)).fold(0.0, f64::min) - 5.0;
        let hi = c.lines.iter().map(|l| l.measured_db.max(l.model_db)).fold(0.0, f64::max) + 8.0;
        let mut series = vec![
            Series { name: "measured".into(), points: meas, style: Style::Stems, color: 0 },
            Series { name: format!("model ({})", c.scene), points: model, style: Style::Stems, color: 2 },
        ];
        if !missed.is_empty() {
            series.push(Series {
                name: "missed by the model (measured > model + 6 dB)".into(),
                points: missed,
                style: Style::Points,
                color: 1,
            });
        }
        let chart = Chart {
            title: format!(
                "{stem}: measured against model, levels relative to each one's first mesh line (distance {:.1} dB)",
                c.distance_db
            ),
            x_label: "order of the pinion rotation".into(),
            y_label: "level [dB re 1x mesh]".into(),
            y_range: Some((lo, hi)),
            series,
            ..Default::default()
        };
        let p = dir.join(format!("{stem}-vs-model.png"));
        render_png(&p, 1400, 600, &[chart])?;
        out.push(p);
    }
    Ok(out)
}

/// Zooms centred on each of the first mesh harmonics (+-4.5 reference-shaft orders), the baseline overlaid,
/// sidebands of each shaft marked where detected (10 dB over the local floor), and sidebands that another
/// shaft's line lies too close to be told apart marked as unresolved.
pub(super) fn mesh_zooms(stem: &str, d: &Diagnosis, ch: usize) -> Vec<Chart> {
    let (Some((_, amp)), Some(f1)) = (d.spectra().iter().find(|s| s.0 == ch), d.shaft_hz.reference()) else {
        return Vec::new();
    };
    let cut = |s: &crate::signal::Spectrum, lo: f64, hi: f64| -> Vec<(f64, f64)> {
        s.freqs_hz.iter().zip(&s.values).filter(|(f, _)| **f >= lo && **f <= hi).map(|(f, v)| (*f, *v)).collect()
    };
    d.mesh_harmonics
        .iter()
        .filter_map(|h| {
            let fk = h.frequency_hz?;
            let (lo, hi) = (fk - 4.5 * f1, fk + 4.5 * f1);
            let pts = cut(amp, lo, hi);
            let peak = pts.iter().map(|p| p.1).fold(f64::MIN_POSITIVE, f64::max);
            let mut series =
                vec![Series { name: "amplitude spectrum".into(), points: pts, style: Style::Line, color: 4 }];
            if let Some((_, b)) = d.baseline_spectra.iter().find(|s| s.0 == ch) {
                series.push(Series {
                    name: "baseline (healthy)".into(),
                    points: cut(b, lo, hi),
                    style: Style::Line,
                    color: 8,
                });
            }
            for (i, shaft) in [Shaft::Pinion, Shaft::Wheel, Shaft::Estimated].into_iter().enumerate() {
                let detected: Vec<(f64, f64)> = h
                    .sidebands
                    .iter()
                    .filter(|s| s.shaft == shaft && s.resolved)
                    .filter_map(|s| s.frequency_hz.map(|f| (f, s.amplitude)))
                    .filter(|&(f, a)| a > DETECTION_OVER_FLOOR * noise_floor(amp, f))
                    .collect();
                if !detected.is_empty() {
                    series.push(Series {
                        name: format!("{shaft} sidebands (detected)"),
                        points: detected,
                        style: Style::Points,
                        color: 1 + i,
                    });
                }
            }
            let unresolved: Vec<(f64, f64)> = h
                .sidebands
                .iter()
                .filter(|s| !s.resolved)
                .filter_map(|s| s.frequency_hz.map(|f| (f, s.amplitude)))
                .collect();
            if !unresolved.is_empty() {
                series.push(Series {
                    name: "unresolved (lines of both shafts within 3 bins)".into(),
                    points: unresolved,
                    style: Style::Hatched,
                    color: 6,
                });
            }
            Some(Chart {
                title: format!("{stem}: zoom around {} x mesh = {fk:.1} Hz (channel {ch})", h.k),
                x_label: "frequency [Hz]".into(),
                y_label: format!("amplitude [{}]", unit_or(&d.unit)),
                y_log: true,
                x_range: Some((lo, hi)),
                y_range: Some((peak * 1e-4, peak * 10.0)),
                series,
                markers: vec![Marker { x: fk, label: format!("{}x mesh", h.k), color: 0 }],
                ..Default::default()
            })
        })
        .collect()
}

/// The kurtogram as one line per level: spectral kurtosis of each band at its centre frequency (level l has
/// 2^l bands of width fs / 2^(l+1)), the chosen band shaded.
pub(super) fn kurtogram_chart(stem: &str, e: &crate::report::summary::Envelope, fs: f64) -> Chart {
    let series = e
        .kurtogram
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let bw = fs / 2.0 / row.len() as f64;
            Series {
                name: format!("level {} (bands of {:.0} Hz)", i + 1, bw),
                points: row.iter().enumerate().map(|(b, k)| ((b as f64 + 0.5) * bw, *k)).collect(),
                style: Style::LinePoints,
                color: i,
            }
        })
        .collect();
    Chart {
        title: format!(
            "{stem}: fast kurtogram; envelope band {:.0}..{:.0} Hz (shaded; bands from 1.5 mesh frequencies up)",
            e.band_hz[0], e.band_hz[1]
        ),
        x_label: "band centre frequency [Hz]".into(),
        y_label: "spectral kurtosis [-] (0 for Gaussian noise)".into(),
        series,
        bands: vec![Band { from: e.band_hz[0], to: e.band_hz[1] }],
        x_range: Some((0.0, fs / 2.0)),
        ..Default::default()
    }
}

/// The squared envelope's order spectrum up to 3.5 orders of the reference shaft, with the first orders of
/// each shaft marked; a shaft order is drawn as detected only 10 dB above the envelope spectrum around it.
pub(super) fn envelope_chart(stem: &str, d: &Diagnosis, e: &crate::report::summary::Envelope) -> Chart {
    let top = 3.5;
    let pts: Vec<(f64, f64)> =
        e.orders.iter().zip(&e.amplitudes).filter(|(o, _)| **o > 0.05 && **o <= top).map(|(o, a)| (*o, *a)).collect();
    let peak = pts.iter().map(|p| p.1).fold(f64::MIN_POSITIVE, f64::max);
    let mut series =
        vec![Series { name: "squared-envelope order spectrum".into(), points: pts, style: Style::Line, color: 4 }];
    let reference = match d.shaft_hz {
        ShaftHz::Pair { .. } | ShaftHz::Pinion { .. } => "pinion",
        ShaftHz::Estimated { .. } => "estimated shaft",
    };
    let mut markers = Vec::new();
    for (i, shaft) in [Shaft::Pinion, Shaft::Wheel, Shaft::Estimated].into_iter().enumerate() {
        let lines: Vec<_> = e.lines.iter().filter(|l| l.shaft == shaft).collect();
        let detected: Vec<(f64, f64)> =
            lines.iter().filter(|l| l.over_floor_db >= 10.0).map(|l| (l.reference_order, l.amplitude)).collect();
        markers.extend(lines.iter().map(|l| Marker {
            x: l.reference_order,
            label: format!("{}x {}", l.order, shaft.name().split(' ').next().unwrap_or("shaft")),
            color: 1 + i,
        }));
        if !detected.is_empty() {
            series.push(Series {
                name: format!("{shaft} orders, 10 dB above the envelope spectrum around"),
                points: detected,
                style: Style::Points,
                color: 1 + i,
            });
        }
    }
    Chart {
        title: format!(
            "{stem}: envelope spectrum, band {:.0}..{:.0} Hz (spectral kurtosis {:.1}){}",
            e.band_hz[0],
            e.band_hz[1],
            e.spectral_kurtosis,
            e.liftered.map_or(String::new(), |s| format!(", {s} family liftered out"))
        ),
        x_label: format!("order of the {reference} (tracked angle)"),
        y_label: format!("squared envelope [({})^2]", unit_or(&d.unit)),
        y_log: true,
        x_range: Some((0.0, top)),
        y_range: Some((peak * 1e-4, peak * 10.0)),
        series,
        markers,
        ..Default::default()
    }
}

/// The real cepstrum up to 1.2 periods of the slowest shaft, with the rahmonics of each shaft marked.
/// `b` circularly shifted to the lag of largest correlation with `a` (same length; O(n^2), n <= 4096).
pub(super) fn aligned(b: &[f64], a: &[f64]) -> Vec<f64> {
    let n = a.len();
    let corr = |lag: usize| (0..n).map(|i| a[i] * b[(i + lag) % n]).sum::<f64>();
    let best = (0..n).max_by(|&x, &y| corr(x).total_cmp(&corr(y))).unwrap_or(0);
    (0..n).map(|i| b[(i + best) % n]).collect()
}

/// Dynamic range of the order map's colour scale, dB below its strongest cell.
const ORDER_MAP_RANGE_DB: f64 = 60.0;

/// The rpm-order map as coloured cells: order across, speed up, colour the amplitude in dB re the
/// strongest cell; the mesh harmonics marked. A resonance shows as a curve order = f / speed.
pub(super) fn order_map_chart(stem: &str, d: &Diagnosis, m: &crate::signal::order_map::OrderMap, fs: f64) -> Chart {
    let rpm: Vec<f64> = m.speeds.iter().map(|s| s * fs * 60.0).collect();
    let edges = |c: &[f64]| -> Vec<f64> {
        let mut e = Vec::with_capacity(c.len() + 1);
        let gap = |i: usize| if c.len() > 1 { c[i.min(c.len() - 2) + 1] - c[i.min(c.len() - 2)] } else { 1.0 };
        e.push(c[0] - 0.5 * gap(0));
        e.extend(c.windows(2).map(|w| 0.5 * (w[0] + w[1])));
        e.push(c[c.len() - 1] + 0.5 * gap(c.len() - 1));
        e
    };
    let top = m.amplitudes.iter().flatten().copied().fold(f64::MIN_POSITIVE, f64::max);
    let values = m
        .amplitudes
        .iter()
        .map(|r| r.iter().map(|a| 20.0 * (a.max(f64::MIN_POSITIVE) / top).log10()).collect())
        .collect();
    let z = d.mesh_order as f64;
    let markers = (1..=3)
        .map(|h| Marker { x: h as f64 * z, label: format!("{h}x mesh"), color: 8 })
        .filter(|mk| mk.x <= *m.orders.last().unwrap_or(&0.0))
        .collect();
    Chart {
        title: format!(
            "{stem}: rpm-order map, channel {} (colour: amplitude, dark blue -{ORDER_MAP_RANGE_DB:.0} dB to yellow 0 dB re the strongest line)",
            d.channels[0]
        ),
        x_label: "order of the reference shaft".into(),
        y_label: "reference shaft speed [rpm]".into(),
        heatmap: Some(Heatmap {
            x_edges: edges(&m.orders),
            y_edges: edges(&rpm),
            values,
            range: (-ORDER_MAP_RANGE_DB, 0.0),
        }),
        markers,
        ..Default::default()
    }
}

pub(super) fn cepstrum_chart(stem: &str, c: &crate::report::summary::Cepstrum) -> Chart {
    let q_max = c.rahmonics.iter().map(|r| r.quefrency_s).fold(0.0, f64::max) * 1.1;
    let pts: Vec<(f64, f64)> = c
        .values
        .iter()
        .enumerate()
        .map(|(i, v)| (1e3 * i as f64 * c.dq_s, *v))
        .filter(|(q, _)| *q >= 1e3 * 5.0 * c.dq_s && *q <= 1e3 * q_max)
        .collect();
    let markers = c
        .rahmonics
        .iter()
        .map(|r| Marker {
            x: 1e3 * r.quefrency_s,
            label: format!("{} {}", r.shaft.name().split(' ').next().unwrap_or("shaft"), r.k),
            color: if r.shaft == Shaft::Wheel { 2 } else { 1 },
        })
        .collect();
    Chart {
        title: format!("{stem}: real power cepstrum with the rahmonics of each shaft"),
        x_label: "quefrency [ms]".into(),
        y_label: "cepstrum [-]".into(),
        series: vec![Series { name: "cepstrum".into(), points: pts, style: Style::Line, color: 4 }],
        markers,
        ..Default::default()
    }
}

/// Trend chart: for each gear on the first channel, every scored indicator in spreads from the baseline's
/// centre over the recordings in time order, the suspect limit, and a marker at the first recording that
/// leaves the band.
///
/// # Errors
/// Nothing scored (no baseline), or the image cannot be written.
pub fn trend(png: &Path, done: &[Diagnosis]) -> Result<(), ReportError> {
    let Some(ch) = done.first().and_then(|d| d.channels.first().copied()) else {
        return Err(ReportError::BadData { what: "trend".into(), why: "no recording".into() });
    };
    let mut gears: Vec<Shaft> = Vec::new();
    for s in done.iter().flat_map(|d| &d.scores) {
        if !gears.contains(&s.gear) {
            gears.push(s.gear);
        }
    }
    let mut charts = Vec::new();
    for gear in gears {
        let scores = |i: usize| done[i].scores.iter().filter(move |s| s.gear == gear && s.channel == ch);
        let names: Vec<String> = scores(0).map(|s| s.indicator.clone()).collect();
        let series: Vec<Series> = names
            .iter()
            .enumerate()
            .map(|(k, name)| Series {
                name: name.replace('_', " "),
                points: (0..done.len())
                    .filter_map(|i| scores(i).find(|s| &s.indicator == name).map(|s| ((i + 1) as f64, s.spreads)))
                    .collect(),
                style: Style::LinePoints,
                color: k,
            })
            .collect();
        let limit = scores(0).map(|s| s.suspect_at).fold(0.0, f64::max);
        let first = (0..done.len()).find(|&i| scores(i).any(|s| s.decides && s.spreads >= s.suspect_at));
        let mut all = series;
        all.push(Series {
            name: format!("suspect limit ({limit:.1} spreads)"),
            points: vec![(1.0, limit), (done.len() as f64, limit)],
            style: Style::Line,
            color: 8,
        });
        charts.push(Chart {
            title: format!("trend of the {gear} (channel {ch}) against the baseline's band"),
            x_label: "recording (time order)".into(),
            y_label: "spreads above the baseline's centre [-]".into(),
            series: all,
            markers: first
                .map(|i| Marker { x: (i + 1) as f64, label: format!("first outside: #{}", i + 1), color: 1 })
                .into_iter()
                .collect(),
            x_range: Some((0.5, done.len() as f64 + 0.5)),
            ..Default::default()
        });
    }
    if charts.is_empty() {
        return Err(ReportError::BadData {
            what: "trend".into(),
            why: "no indicator was scored against a baseline".into(),
        });
    }
    let h = 450 * charts.len() as u32;
    render_png(png, 1400, h, &charts)
}

/// The (frequency in Hz, value) points of `s` above 0 Hz and up to `max_f` Hz.
fn in_band(s: &crate::signal::Spectrum, max_f: f64) -> Vec<(f64, f64)> {
    s.freqs_hz.iter().zip(&s.values).filter(|(f, _)| **f > 0.0 && **f <= max_f).map(|(f, v)| (*f, *v)).collect()
}
