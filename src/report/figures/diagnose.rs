//! The images of `diagnose`: spectra with the baseline and the marked lines, mesh zooms, TSAs, envelope,
//! kurtogram, cepstrum, order map, and the trend over recordings.

use super::*;

/// Writes the diagnosis images of one recording into `dir` (file names start with the recording's stem).
///
/// # Errors
/// Non-finite data or write failures.
pub fn diagnosis(d: &Diagnosis, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    let mut out = Vec::new();
    for f in diagnosis_figures(d) {
        let p = dir.join(&f.file);
        render_png(&p, f.width, f.height, &f.charts)?;
        out.push(p);
    }
    Ok(out)
}

/// One image of a report: its file name, size in pixels and charts (stacked).
#[derive(Clone, Debug)]
pub struct Figure {
    /// File name (no directory).
    pub file: String,
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// The charts, top to bottom.
    pub charts: Vec<Chart>,
}

/// With a machine whose verdict names a gear on `shaft`: that gear's name and teeth.
fn named_gear_teeth(d: &Diagnosis, shaft: &Shaft) -> Option<(String, u32)> {
    let (Shaft::Named(name), Some(md), Some(k)) = (shaft, &d.machine, d.verdict.stage) else { return None };
    if d.verdict.shaft.as_deref() != Some(&**name) {
        return None;
    }
    let stage = md.stages.get(k.checked_sub(1)?)?;
    let g = stage.gears.iter().find(|g| g.gear == d.verdict.gear && g.shaft.as_deref() == Some(&**name))?;
    Some((format!("(stage {k} {})", g.gear.name()), g.teeth))
}

/// The images of one diagnosis, as [`diagnosis`] writes them (file names start with the recording's stem).
pub fn diagnosis_figures(d: &Diagnosis) -> Vec<Figure> {
    let stem = Path::new(&d.file).file_stem().and_then(|s| s.to_str()).unwrap_or("recording").to_string();
    let mut figures = Vec::new();
    // TSA of each gear on the channel that decided the verdict
    let ch = deciding_channel(d);
    // angle axis in teeth of the gear (tooth k between k - 1 and k), the origin at the tachometer pulse or,
    // with mesh-phase tracking, arbitrary
    let origin = if d.speed_profile.tracking.tachometer_origin() {
        "origin at the tachometer pulse"
    } else {
        "origin arbitrary: no tachometer"
    };
    let tsas: Vec<Chart> = d
        .tsas()
        .filter(|(g, _, _)| g.channel == ch)
        .flat_map(|(g, t, _)| {
            // with a machine, a shaft carrying the named gear is drawn in that gear's teeth (an intermediate
            // shaft's average otherwise counts its first gear's)
            let named = named_gear_teeth(d, &g.gear);
            let z = named.as_ref().map_or(g.mesh_order as f64, |(_, t)| f64::from(*t));
            let along = |v: &[f64]| -> Vec<(f64, f64)> {
                v.iter().enumerate().map(|(i, y)| (z * i as f64 / v.len() as f64, *y)).collect()
            };
            // with a machine only the tracked shaft (the first average) has the tachometer's origin
            let origin = match d.gears.first() {
                Some(t) if d.machine.is_some() && t.gear != g.gear && origin.starts_with("origin at") => {
                    "origin relative: its angle at the tracked shaft's pulse"
                }
                _ => origin,
            };
            let x_label = if g.gear == Shaft::Estimated {
                format!("mesh cycle [cycle k spans k-1 to k of {}; {origin}]", g.mesh_order)
            } else {
                match named {
                    Some((gear, teeth)) => {
                        format!("{} {gear} tooth in mesh [tooth k spans k-1 to k of {teeth}; {origin}]", g.gear)
                    }
                    None => format!("{} tooth in mesh [tooth k spans k-1 to k of {}; {origin}]", g.gear, g.mesh_order),
                }
            };
            let mut tsa_series = Vec::new();
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
                    color: BASELINE_GREY,
                });
            }
            // the recording over its baseline
            tsa_series.push(Series { name: "TSA of this recording".into(), points: along(t), style: Style::Line, color: 0 });
            [
                Chart {
                    title: format!(
                        "Time-synchronous average of the {} (channel {ch}, {} revolutions)",
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
                        "Residual (TSA without shaft orders 1-2 and the mesh harmonics) and difference signal of the {}",
                        g.gear
                    ),
                    x_label,
                    y_label: format!("signal [{}]", unit_or(&d.unit)),
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
        figures.push(Figure {
            file: format!("{stem}-tsa.png"),
            width: PAGE_WIDTH_PX,
            height: 420 * tsas.len() as u32,
            charts: titled(&stem, tsas),
        });
    }
    // the spectrum: in orders of the tracked angle when the speed changed, else in Hz with the mesh
    // harmonics and the sidebands that stand out
    if let Some(m) = &d.order_map {
        figures.push(Figure {
            file: format!("{stem}-order-spectrum.png"),
            width: PAGE_WIDTH_PX,
            height: 560,
            charts: titled(&stem, vec![order_spectrum_chart(d, m)]),
        });
    } else if let Some((_, amp)) = d.spectra().iter().find(|s| s.0 == ch) {
        figures.push(Figure {
            file: format!("{stem}-spectrum.png"),
            width: PAGE_WIDTH_PX,
            height: 600,
            charts: titled(&stem, vec![scaled(spectrum_chart(d, ch, amp), d.spectrum_scale, amp, &d.unit)]),
        });
    } else if let Some(chart) = tsa_order_spectrum_chart(d, ch) {
        // no sample rate: the order spectrum of the deciding gear's TSA stands in for the spectrum in Hz
        figures.push(Figure {
            file: format!("{stem}-order-spectrum.png"),
            width: PAGE_WIDTH_PX,
            height: 560,
            charts: titled(&stem, vec![chart]),
        });
    }
    // zooms in Hz only at a steady speed: a run-up smears every line over the speed range
    let zooms = match (&d.order_map, &d.machine) {
        (None, Some(md)) => super::machine::machine_zooms(d, md, ch),
        (None, None) => mesh_zooms(&stem, d, ch),
        _ => Vec::new(),
    };
    if !zooms.is_empty() {
        figures.push(Figure {
            file: format!("{stem}-zoom.png"),
            width: PAGE_WIDTH_PX,
            height: 440 * zooms.len() as u32,
            charts: titled(&stem, zooms),
        });
    }
    if let Some(e) = &d.envelope {
        figures.push(Figure {
            file: format!("{stem}-envelope.png"),
            width: PAGE_WIDTH_PX,
            height: 560,
            charts: titled(&stem, vec![envelope_chart(&stem, d, e)]),
        });
        if let Some(fs) = d.sample_rate_hz {
            figures.push(Figure {
                file: format!("{stem}-kurtogram.png"),
                width: PAGE_WIDTH_PX,
                height: 560,
                charts: titled(&stem, vec![kurtogram_chart(d, e, fs)]),
            });
        }
    }
    if let Some(c) = &d.cepstrum {
        figures.push(Figure {
            file: format!("{stem}-cepstrum.png"),
            width: PAGE_WIDTH_PX,
            height: 520,
            charts: titled(&stem, vec![cepstrum_chart(&stem, c)]),
        });
    }
    if let (Some(m), Some(fs)) = (&d.order_map, d.sample_rate_hz) {
        figures.push(Figure {
            file: format!("{stem}-order-map.png"),
            width: PAGE_WIDTH_PX,
            height: 700,
            charts: titled(&stem, vec![order_map_chart(&stem, d, m, fs)]),
        });
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
            Series { name: "model".into(), points: model, style: Style::Stems, color: 2 },
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
                "Measured against model ({}), levels relative to each one's first mesh line; distance {} dB",
                c.scene,
                num(c.distance_db)
            ),
            x_label: "order of the pinion rotation [-]".into(),
            y_label: "level [dB re 1x mesh]".into(),
            y_range: Some((lo, hi)),
            series,
            ..Default::default()
        };
        figures.push(Figure {
            file: format!("{stem}-vs-model.png"),
            width: PAGE_WIDTH_PX,
            height: 560,
            charts: titled(&stem, vec![chart]),
        });
    }
    figures
}

/// The channel whose analysis decided the verdict: the one whose spectrum the diagnosis kept, else the
/// one whose gear indicators are the diagnosis's own, else the first analysed.
pub fn deciding_channel(d: &Diagnosis) -> usize {
    d.spectra()
        .first()
        .map(|s| s.0)
        .or_else(|| d.gears.iter().find(|g| g.indicators == d.indicators).map(|g| g.channel))
        .unwrap_or(d.channels[0])
}

/// The order spectrum of the TSA of the gear that decided (its own shaft's orders), mesh orders marked:
/// the spectrum of a recording without a sample rate.
fn tsa_order_spectrum_chart(d: &Diagnosis, ch: usize) -> Option<Chart> {
    let g = d
        .gears
        .iter()
        .filter(|g| g.channel == ch)
        .find(|g| g.indicators == d.indicators)
        .or_else(|| d.gears.iter().find(|g| g.channel == ch))?;
    let pts: Vec<(f64, f64)> =
        g.tsa_amplitudes.iter().enumerate().skip(1).map(|(k, a)| (k as f64, *a)).filter(|p| p.1 > 0.0).collect();
    if pts.is_empty() {
        return None;
    }
    let peak = pts.iter().map(|p| p.1).fold(f64::MIN_POSITIVE, f64::max);
    let top = (3.6 * g.mesh_order as f64).min(pts.len() as f64);
    let z = g.mesh_order as f64;
    let markers = (1..)
        .map(|k| k as f64 * z)
        .take_while(|o| *o <= top)
        .enumerate()
        .map(|(i, o)| Marker { x: o, label: format!("{}x mesh", i + 1), color: 0 })
        .collect();
    Some(Chart {
        title: format!("order spectrum of the TSA of the {}, channel {ch} (sample rate unknown: orders only)", g.gear),
        x_label: format!("order of the {} [-]", g.gear),
        y_label: format!("amplitude [{}]", unit_or(&d.unit)),
        y_log: true,
        x_range: Some((0.0, top)),
        y_range: Some((peak * 1e-3, peak * 3.0)),
        series: vec![Series { name: "TSA order spectrum".into(), points: pts, style: Style::Stems, color: 4 }],
        markers,
        ..Default::default()
    })
}

/// The first chart's title starts with the recording's name (an image pasted alone still says which
/// recording it shows).
fn titled(stem: &str, mut charts: Vec<Chart>) -> Vec<Chart> {
    if let Some(c) = charts.first_mut() {
        c.title = format!("{stem}: {}", c.title);
    }
    charts
}

/// The sidebands of `shaft` around the mesh harmonics that stand out (see [`stands_out`]), as (Hz, amplitude).
fn standing_out(d: &Diagnosis, amp: &crate::signal::Spectrum, shaft: Shaft, k: Option<usize>) -> Vec<(f64, f64)> {
    d.mesh_harmonics
        .iter()
        .filter(|h| k.is_none_or(|k| h.k == k))
        .flat_map(|h| h.sidebands.iter())
        .filter(|s| s.shaft == shaft && stands_out(amp, s))
        .filter_map(|s| s.frequency_hz.map(|f| (f, drawn_peak(amp, f))))
        .collect()
}

/// The shafts whose sidebands a diagnosis labels.
fn shafts(d: &Diagnosis) -> Vec<Shaft> {
    d.shaft_hz.shafts()
}

/// The amplitude spectrum up to 3.6 mesh frequencies: the healthy baseline light grey behind, this
/// recording over it, the mesh harmonics marked, and dots only on the sidebands that stand out.
fn spectrum_chart(d: &Diagnosis, ch: usize, amp: &crate::signal::Spectrum) -> Chart {
    // with a machine, up to 1.2 times the highest stage's third mesh harmonic
    let fm = match &d.machine {
        Some(md) => md.stages.iter().filter_map(|s| s.mesh_hz).fold(0.0, f64::max),
        None => d.mesh_hz.unwrap_or(0.0),
    };
    let max_f = if fm > 0.0 { 3.6 * fm } else { f64::INFINITY }.min(*amp.freqs_hz.last().unwrap_or(&1.0));
    let pts = in_band(amp, max_f);
    let peak = pts.iter().map(|p| p.1).fold(f64::MIN_POSITIVE, f64::max);
    let mut series = Vec::new();
    if let Some((_, b)) = d.baseline_spectra.iter().find(|s| s.0 == ch) {
        series.push(Series {
            name: "healthy baseline".into(),
            points: in_band(b, max_f),
            style: Style::Line,
            color: BASELINE_GREY,
        });
    }
    series.push(Series { name: "this recording".into(), points: pts, style: Style::Line, color: 4 });
    let (markers, what) = match &d.machine {
        Some(md) => {
            let (marks, markers) = super::machine::machine_marks(md, amp, 0.0, max_f, None);
            series.extend(marks);
            (markers, ": every stage's mesh lines")
        }
        None => {
            for (i, shaft) in shafts(d).into_iter().enumerate() {
                let pts = standing_out(d, amp, shaft, None);
                if !pts.is_empty() {
                    series.push(Series {
                        name: sideband_words(shaft),
                        points: pts,
                        style: Style::Points,
                        color: 1 + i,
                    });
                }
            }
            let markers = d
                .mesh_harmonics
                .iter()
                .filter_map(|h| h.frequency_hz.map(|f| Marker { x: f, label: format!("{}x mesh", h.k), color: 0 }))
                .collect();
            (markers, "")
        }
    };
    Chart {
        title: format!("amplitude spectrum, channel {ch} (Hann window, averaged){what}"),
        x_label: "frequency [Hz]".into(),
        y_label: format!("amplitude [{}]", unit_or(&d.unit)),
        y_log: true,
        x_range: Some((0.0, max_f)),
        y_range: Some((peak * 1e-5, peak * 3.0)),
        series,
        markers,
        ..Default::default()
    }
}

/// An amplitude spectrum chart shown on `scale`: as it is, in dB re 1 unit (20 log10 A, a linear axis
/// 100 dB deep like the amplitude's five decades), or as the PSD of the same segments (every series' amplitudes
/// squared times [`crate::signal::spectrum::hann_psd_per_amplitude2`], nine decades). `amp` gives the segment
/// length; `unit` the signal's unit.
fn scaled(mut c: Chart, scale: SpectrumScale, amp: &crate::signal::Spectrum, unit: &str) -> Chart {
    let unit = unit_or(unit);
    let (to, y_label, title) = match scale {
        SpectrumScale::Amplitude => return c,
        SpectrumScale::Db => (
            Box::new(|a: f64| 20.0 * a.max(1e-300).log10()) as Box<dyn Fn(f64) -> f64>,
            format!("amplitude [dB re 1 {unit}]"),
            "amplitude spectrum in dB",
        ),
        SpectrumScale::Psd => {
            let bins = amp.values.len().max(2);
            let n = 2 * (bins - 1);
            let factor = crate::signal::spectrum::hann_psd_per_amplitude2(
                n,
                amp.freqs_hz.get(1).copied().unwrap_or(1.0) * n as f64,
            );
            (
                Box::new(move |a: f64| a * a * factor) as Box<dyn Fn(f64) -> f64>,
                format!("PSD [({unit})^2/Hz]"),
                "power spectral density",
            )
        }
    };
    for s in &mut c.series {
        s.points.iter_mut().for_each(|p| p.1 = to(p.1));
    }
    let peak = c.series.iter().flat_map(|s| s.points.iter().map(|p| p.1)).fold(f64::MIN, f64::max);
    (c.y_log, c.y_range) = match scale {
        SpectrumScale::Db => (false, Some((peak - 100.0, peak + 5.0))),
        _ => (true, Some((peak * 1e-9, peak * 9.0))),
    };
    c.y_label = y_label;
    c.title = c.title.replacen("amplitude spectrum", title, 1);
    c
}

/// The legend words for the sidebands of `shaft` that stand out, as the text says them.
pub fn sideband_words(shaft: Shaft) -> String {
    format!("{shaft} sidebands 12 dB over the local floor")
}

/// The order spectrum on the tracked angle (the mean of the order map's rows): a run-up's lines stay
/// sharp at their orders where a spectrum in Hz smears them over the speed range.
fn order_spectrum_chart(d: &Diagnosis, m: &crate::signal::order_map::OrderMap) -> Chart {
    let rows = m.amplitudes.len().max(1) as f64;
    let pts: Vec<(f64, f64)> = m
        .orders
        .iter()
        .enumerate()
        .map(|(i, o)| (*o, m.amplitudes.iter().map(|r| r.get(i).copied().unwrap_or(0.0)).sum::<f64>() / rows))
        .filter(|(o, a)| *o > 0.0 && *a > 0.0)
        .collect();
    let peak = pts.iter().map(|p| p.1).fold(f64::MIN_POSITIVE, f64::max);
    let top = m.orders.last().copied().unwrap_or(1.0);
    let z = d.mesh_order as f64;
    let markers = match &d.machine {
        Some(md) => super::machine::stage_order_markers(md, top),
        None => (1..)
            .map(|k| k as f64 * z)
            .take_while(|o| *o <= top)
            .enumerate()
            .map(|(i, o)| Marker { x: o, label: format!("{}x mesh", i + 1), color: 0 })
            .collect(),
    };
    let reference = reference_shaft(d);
    Chart {
        title: format!(
            "order spectrum on the tracked angle, channel {} (the speed changed {} % over the recording)",
            d.channels[0],
            num(d.speed_profile.change_percent)
        ),
        x_label: format!("order of the {reference} [-]"),
        y_label: format!("amplitude [{}]", unit_or(&d.unit)),
        y_log: true,
        x_range: Some((0.0, top)),
        y_range: Some((peak * 1e-5, peak * 3.0)),
        series: {
            let staged = d.machine.as_ref().map(|md| super::machine::stage_order_series(md, &pts, top));
            let mut series =
                vec![Series { name: "mean over the speed range".into(), points: pts, style: Style::Line, color: 4 }];
            series.extend(staged.unwrap_or_default());
            series
        },
        markers,
        ..Default::default()
    }
}

fn reference_shaft(d: &Diagnosis) -> &'static str {
    match &d.shaft_hz {
        ShaftHz::Pair { .. } | ShaftHz::Pinion { .. } => "pinion",
        ShaftHz::Estimated { .. } => "shaft of the estimated period",
        ShaftHz::Machine(m) => m.0.first().map_or("tracked shaft", |s| s.0.name()),
    }
}

/// Zooms centred on each of the first mesh harmonics (+-4.5 reference-shaft orders): the baseline light
/// grey behind the recording, dots on the sidebands that stand out 12 dB over the local floor, and
/// hatched squares on sidebands that another shaft's line lies too close to be told apart.
pub(super) fn mesh_zooms(_stem: &str, d: &Diagnosis, ch: usize) -> Vec<Chart> {
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
            let mut series = Vec::new();
            if let Some((_, b)) = d.baseline_spectra.iter().find(|s| s.0 == ch) {
                series.push(Series {
                    name: "healthy baseline".into(),
                    points: cut(b, lo, hi),
                    style: Style::Line,
                    color: BASELINE_GREY,
                });
            }
            series.push(Series { name: "this recording".into(), points: pts, style: Style::Line, color: 4 });
            for (i, shaft) in shafts(d).into_iter().enumerate() {
                let detected = standing_out(d, amp, shaft, Some(h.k));
                if !detected.is_empty() {
                    series.push(Series {
                        name: sideband_words(shaft),
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
                    name: "unresolved: lines of both shafts within 3 bins".into(),
                    points: unresolved,
                    style: Style::Hatched,
                    color: 6,
                });
            }
            Some(Chart {
                title: format!("zoom around {}x mesh = {} Hz, channel {ch}", h.k, num(fk)),
                x_label: "frequency [Hz]".into(),
                y_label: format!("amplitude [{}]", unit_or(&d.unit)),
                y_log: true,
                x_range: Some((lo, hi)),
                y_range: Some((peak * 1e-4, peak * 3.0)),
                series,
                markers: vec![Marker { x: fk, label: format!("{}x mesh", h.k), color: 0 }],
                ..Default::default()
            })
        })
        .collect()
}

/// Whether the kurtogram's own best cell (largest spectral kurtosis at or above the lowest frequency of
/// the chosen band's search, 1.5 mesh frequencies) is the chosen band: when not, the band came from
/// elsewhere (the baseline's band, or `--envelope-band`).
fn band_is_own_best(e: &crate::report::summary::Envelope, fs: f64, from_hz: f64) -> bool {
    let mut best = (f64::NEG_INFINITY, 0.0, 0.0);
    for row in &e.kurtogram {
        let bw = fs / 2.0 / row.len().max(1) as f64;
        for (b, k) in row.iter().enumerate() {
            let lo = b as f64 * bw;
            if k.is_finite() && lo >= from_hz - 1e-9 && *k > best.0 {
                best = (*k, lo, lo + bw);
            }
        }
    }
    (best.1 - e.band_hz[0]).abs() < 1e-6 * fs && (best.2 - e.band_hz[1]).abs() < 1e-6 * fs
}

/// The fast kurtogram as a colour map: level up (level l has 2^l bands of width fs / 2^(l+1)), frequency
/// across, colour the spectral kurtosis; the envelope band outlined. The title says where the band came
/// from when it is not this recording's own most impulsive band.
pub(super) fn kurtogram_chart(d: &Diagnosis, e: &crate::report::summary::Envelope, fs: f64) -> Chart {
    // one column per band of the finest level (at most 1024: coarser columns take the largest value)
    let finest = e.kurtogram.iter().map(Vec::len).max().unwrap_or(1).clamp(1, 1024);
    let x_edges: Vec<f64> = (0..=finest).map(|i| fs / 2.0 * i as f64 / finest as f64).collect();
    // bands below the search's lowest frequency are left out of the colour scale (grey): there the shafts'
    // and the mesh's own lines beat into a peaky envelope that says nothing of a fault
    let from = 1.5 * d.mesh_hz.unwrap_or(0.0);
    let values: Vec<Vec<f64>> = e
        .kurtogram
        .iter()
        .map(|row| {
            let bw = fs / 2.0 / row.len().max(1) as f64;
            (0..finest)
                .map(|i| {
                    let centre = (i as f64 + 0.5) / finest as f64;
                    let b = ((centre * row.len() as f64) as usize).min(row.len().saturating_sub(1));
                    let searched = b as f64 * bw >= from - 1e-9;
                    row.get(b).copied().filter(|v| v.is_finite() && searched).unwrap_or(f64::NAN)
                })
                .collect()
        })
        .collect();
    let levels = values.len();
    let y_edges: Vec<f64> = (0..=levels).map(|l| l as f64 + 0.5).collect();
    let top = values.iter().flatten().copied().filter(|v| v.is_finite()).fold(0.0, f64::max).max(1.0);
    let bw = e.band_hz[1] - e.band_hz[0];
    let row = e.kurtogram.iter().position(|r| ((fs / 2.0 / r.len().max(1) as f64) - bw).abs() < 1e-6 * fs);
    let outline = row.map(|r| ((e.band_hz[0], r as f64 + 0.5), (e.band_hz[1], r as f64 + 1.5)));
    let origin = if band_is_own_best(e, fs, from) {
        "this recording's most impulsive band".to_string()
    } else if !d.baseline_spectra.is_empty() {
        "the band chosen on the healthy baseline, not this recording's most impulsive one".to_string()
    } else {
        "the band given on the command line".to_string()
    };
    Chart {
        title: format!(
            "fast kurtogram; envelope band {}-{} Hz outlined: {origin} (searched from {} Hz, 1.5 mesh frequencies; grey below)",
            num(e.band_hz[0]),
            num(e.band_hz[1]),
            num(from)
        ),
        x_label: "frequency [Hz]".into(),
        y_label: "level [-] (bands fs / 2^(level+1) wide)".into(),
        y_whole: true,
        heatmap: Some(Heatmap {
            x_edges,
            y_edges,
            values,
            range: (0.0, top),
            label: "spectral kurtosis [-]".into(),
            outline,
        }),
        ..Default::default()
    }
}

/// The squared envelope's order spectrum up to 3.5 orders of the reference shaft, the first orders of each
/// shaft marked by name, dots only on the orders that stand 10 dB above the envelope spectrum around them.
pub(super) fn envelope_chart(_stem: &str, d: &Diagnosis, e: &crate::report::summary::Envelope) -> Chart {
    let top = 3.5;
    let pts: Vec<(f64, f64)> =
        e.orders.iter().zip(&e.amplitudes).filter(|(o, _)| **o > 0.05 && **o <= top).map(|(o, a)| (*o, *a)).collect();
    let peak = pts.iter().map(|p| p.1).fold(f64::MIN_POSITIVE, f64::max);
    let mut series =
        vec![Series { name: "squared-envelope order spectrum".into(), points: pts, style: Style::Line, color: 4 }];
    let reference = reference_shaft(d);
    let mut markers = Vec::new();
    for (i, shaft) in [Shaft::Pinion, Shaft::Wheel, Shaft::Estimated].into_iter().enumerate() {
        let lines: Vec<_> = e.lines.iter().filter(|l| l.shaft == shaft).collect();
        let detected: Vec<(f64, f64)> =
            lines.iter().filter(|l| l.over_floor_db >= 10.0).map(|l| (l.reference_order, l.amplitude)).collect();
        markers.extend(lines.iter().map(|l| Marker {
            x: l.reference_order,
            label: format!("{}x {}", l.order, if shaft == Shaft::Estimated { "shaft" } else { shaft.name() }),
            color: 1 + i,
        }));
        if !detected.is_empty() {
            series.push(Series {
                name: format!("{shaft} orders 10 dB over the envelope spectrum around them"),
                points: detected,
                style: Style::Points,
                color: 1 + i,
            });
        }
    }
    Chart {
        title: format!(
            "envelope spectrum of the band {}-{} Hz (spectral kurtosis {}){}",
            num(e.band_hz[0]),
            num(e.band_hz[1]),
            num(e.spectral_kurtosis),
            e.liftered.map_or(String::new(), |s| format!(", {s} family liftered out"))
        ),
        x_label: format!("order of the {reference} [-] (tracked angle)"),
        y_label: format!("squared envelope [({})^2]", unit_or(&d.unit)),
        y_log: true,
        x_range: Some((0.0, top)),
        y_range: Some((peak * 1e-4, peak * 3.0)),
        series,
        markers,
        ..Default::default()
    }
}

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
/// strongest cell (colour bar at the right); the mesh harmonics marked above the map. A resonance shows
/// as a curve order = f / speed.
pub(super) fn order_map_chart(_stem: &str, d: &Diagnosis, m: &crate::signal::order_map::OrderMap, fs: f64) -> Chart {
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
    let last = *m.orders.last().unwrap_or(&0.0);
    let markers = (1..)
        .map(|h| Marker { x: h as f64 * z, label: format!("{h}x mesh"), color: 8 })
        .take_while(|mk| mk.x <= last)
        .collect();
    Chart {
        title: format!(
            "rpm-order map, channel {} (orders 0 to {} of the {})",
            d.channels[0],
            num(last),
            reference_shaft(d)
        ),
        x_label: format!("order of the {} [-]", reference_shaft(d)),
        y_label: format!("{} speed [rpm]", reference_shaft(d)),
        heatmap: Some(Heatmap {
            x_edges: edges(&m.orders),
            y_edges: edges(&rpm),
            values,
            range: (-ORDER_MAP_RANGE_DB, 0.0),
            label: "amplitude [dB re the strongest cell]".into(),
            outline: None,
        }),
        markers,
        ..Default::default()
    }
}

/// The real cepstrum up to 1.1 times the longest rahmonic marked, with the rahmonics of each shaft marked.
pub(super) fn cepstrum_chart(_stem: &str, c: &crate::report::summary::Cepstrum) -> Chart {
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
            label: format!("{} {}", if r.shaft == Shaft::Estimated { "shaft" } else { r.shaft.name() }, r.k),
            color: if r.shaft == Shaft::Wheel { 2 } else { 1 },
        })
        .collect();
    Chart {
        title: "real power cepstrum with the rahmonics of each shaft (a shaft's family of lines)".into(),
        x_label: "quefrency [ms]".into(),
        y_label: "cepstrum [-]".into(),
        series: vec![Series { name: "cepstrum".into(), points: pts, style: Style::Line, color: 4 }],
        markers,
        ..Default::default()
    }
}

/// The indicator families of a trend: one panel each (their spreads differ by orders of magnitude).
const TREND_FAMILIES: [(&str, &[&str]); 3] = [
    (
        "peakiness of the averaged signal (FM4, M6A, M8A, NA4*, FM0, kurtosis)",
        &["fm4", "m6a", "m8a", "na4_star", "na4", "fm0", "kurtosis", "crest_factor"],
    ),
    ("energy around the mesh (ER, SER, SI, SLF)", &["er", "ser", "si", "slf"]),
    ("spectral change from the baseline", &["spectral_change"]),
];

/// The name shown for an indicator key (`na4_star` is NA4*).
pub fn indicator_label(key: &str) -> String {
    match key {
        "na4_star" => "NA4*".into(),
        "spectral_change" => "spectral change".into(),
        "crest_factor" => "crest factor".into(),
        "kurtosis" => "kurtosis".into(),
        "rms" => "RMS".into(),
        k => k.to_uppercase(),
    }
}

/// Short names of recordings for an axis: the file stems without what they all share at the start and
/// the end, "#i" in front (the page's table lists the whole names).
pub fn short_names(files: &[String]) -> Vec<String> {
    let stems: Vec<String> =
        files.iter().map(|f| Path::new(f).file_stem().and_then(|s| s.to_str()).unwrap_or(f).to_string()).collect();
    let common = |rev: bool| -> usize {
        let chars = |s: &String| -> Vec<char> { if rev { s.chars().rev().collect() } else { s.chars().collect() } };
        let first = stems.first().map(chars).unwrap_or_default();
        stems.iter().map(|s| first.iter().zip(chars(s)).take_while(|(a, b)| **a == *b).count()).min().unwrap_or(0)
    };
    let (pre, post) = if stems.len() > 1 { (common(false), common(true)) } else { (0, 0) };
    stems
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let c: Vec<char> = s.chars().collect();
            let (a, b) = (pre.min(c.len()), c.len().saturating_sub(post).max(pre.min(c.len())));
            let part: String =
                c[a..b].iter().collect::<String>().trim_matches(|ch: char| ch == '-' || ch == '_').to_string();
            if part.is_empty() { format!("#{}", i + 1) } else { format!("#{} {part}", i + 1) }
        })
        .collect()
}

/// Trend chart: for each gear on the first channel and each indicator family, the scored indicators in
/// spreads from the baseline's centre over the recordings in time order (file names on the x axis), the
/// suspect and faulty limits, on a symmetric-log scale (a limit of 3.5 spreads and a crack at 200 both
/// readable).
///
/// # Errors
/// Nothing scored (no baseline), or the image cannot be written.
pub fn trend(png: &Path, done: &[Diagnosis]) -> Result<(), ReportError> {
    let charts = trend_charts(done)?;
    let h = TREND_PANEL_PX * charts.len() as u32;
    render_png(png, PAGE_WIDTH_PX, h, &charts)
}

/// Height of one trend panel, px.
pub const TREND_PANEL_PX: u32 = 470;

/// The panels of [`trend`].
///
/// # Errors
/// Nothing scored (no baseline).
pub fn trend_charts(done: &[Diagnosis]) -> Result<Vec<Chart>, ReportError> {
    let Some(ch) = done.first().and_then(|d| d.channels.first().copied()) else {
        return Err(ReportError::BadData { what: "trend".into(), why: "no recording".into() });
    };
    let mut gears: Vec<Shaft> = Vec::new();
    for s in done.iter().flat_map(|d| &d.scores) {
        if !gears.contains(&s.gear) {
            gears.push(s.gear);
        }
    }
    let files: Vec<String> = done.iter().map(|d| d.file.clone()).collect();
    let ticks: Vec<(f64, String)> =
        short_names(&files).into_iter().enumerate().map(|(i, n)| ((i + 1) as f64, n)).collect();
    let last = done.len() as f64;
    let mut charts = Vec::new();
    for gear in gears {
        let scores = |i: usize| done[i].scores.iter().filter(move |s| s.gear == gear && s.channel == ch);
        let mut names: Vec<String> = Vec::new();
        for i in 0..done.len() {
            for s in scores(i) {
                if !names.contains(&s.indicator) {
                    names.push(s.indicator.clone());
                }
            }
        }
        for (family, keys) in TREND_FAMILIES {
            let members: Vec<&String> = names
                .iter()
                .filter(|n| {
                    keys.contains(&n.as_str())
                        || (family.starts_with("peak") && !TREND_FAMILIES.iter().any(|f| f.1.contains(&n.as_str())))
                })
                .collect();
            if members.is_empty() {
                continue;
            }
            let mut series: Vec<Series> = members
                .iter()
                .enumerate()
                .map(|(k, name)| Series {
                    name: indicator_label(name),
                    points: (0..done.len())
                        .filter_map(|i| scores(i).find(|s| &s.indicator == *name).map(|s| ((i + 1) as f64, s.spreads)))
                        .collect(),
                    style: Style::LinePoints,
                    color: [0, 2, 4, 5, 7, 3, 6, 1][k % 8],
                })
                .collect();
            let limit = |f: fn(&crate::report::summary::Score) -> f64| {
                (0..done.len()).flat_map(|i| scores(i).map(f)).fold(0.0, f64::max)
            };
            let (suspect, faulty) = (limit(|s| s.suspect_at), limit(|s| s.faulty_at));
            series.push(Series {
                name: format!("suspect limit ({} spreads)", sig(suspect, 3)),
                points: vec![(0.6, suspect), (last + 0.4, suspect)],
                style: Style::Line,
                color: 3,
            });
            series.push(Series {
                name: format!("faulty limit ({} spreads)", sig(faulty, 3)),
                points: vec![(0.6, faulty), (last + 0.4, faulty)],
                style: Style::Line,
                color: 1,
            });
            let hi = series.iter().flat_map(|s| &s.points).map(|p| p.1).fold(faulty, f64::max);
            let lo = series.iter().flat_map(|s| &s.points).map(|p| p.1).fold(0.0, f64::min);
            charts.push(Chart {
                title: format!("{gear}, channel {ch}: {family}"),
                x_label: "recording [time order as given]".into(),
                y_label: "spreads from the baseline [-]".into(),
                series,
                x_range: Some((0.5, last + 0.5)),
                y_range: Some((lo * 1.5 - 0.5, hi * 2.0)),
                y_symlog: true,
                x_ticks: ticks.clone(),
                ..Default::default()
            });
        }
    }
    if charts.is_empty() {
        return Err(ReportError::BadData {
            what: "trend".into(),
            why: "no indicator was scored against a baseline".into(),
        });
    }
    Ok(charts)
}

/// The (frequency in Hz, value) points of `s` above 0 Hz and up to `max_f` Hz.
fn in_band(s: &crate::signal::Spectrum, max_f: f64) -> Vec<(f64, f64)> {
    s.freqs_hz.iter().zip(&s.values).filter(|(f, _)| **f > 0.0 && **f <= max_f).map(|(f, v)| (*f, *v)).collect()
}
