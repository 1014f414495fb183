//! The spectra of a diagnosis: the spectrum in Hz over the baseline (amplitude, dB or PSD), the mesh
//! zooms, the order spectrum on the tracked angle, and the TSA's order spectrum when the rate is unknown.

use super::*;

/// The order spectrum of the TSA of the gear that decided (its own shaft's orders), mesh orders marked:
/// the spectrum of a recording without a sample rate.
pub(super) fn tsa_order_spectrum_chart(d: &Diagnosis, ch: usize) -> Option<Chart> {
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

/// The sidebands of `shaft` around the mesh harmonics that stand out (see [`stands_out`]), as (Hz, amplitude).
pub(super) fn standing_out(
    d: &Diagnosis,
    amp: &crate::signal::Spectrum,
    shaft: Shaft,
    k: Option<usize>,
) -> Vec<(f64, f64)> {
    d.mesh_harmonics
        .iter()
        .filter(|h| k.is_none_or(|k| h.k == k))
        .flat_map(|h| h.sidebands.iter())
        .filter(|s| s.shaft == shaft && stands_out(amp, s))
        .filter_map(|s| s.frequency_hz.map(|f| (f, drawn_peak(amp, f))))
        .collect()
}

/// The shafts whose sidebands a diagnosis labels.
pub(super) fn shafts(d: &Diagnosis) -> Vec<Shaft> {
    d.shaft_hz.shafts()
}

/// The amplitude spectrum up to 3.6 mesh frequencies: the healthy baseline light grey behind, this
/// recording over it, the mesh harmonics marked, and dots only on the sidebands that stand out.
pub(super) fn spectrum_chart(d: &Diagnosis, ch: usize, amp: &crate::signal::Spectrum) -> Chart {
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
pub(super) fn scaled(mut c: Chart, scale: SpectrumScale, amp: &crate::signal::Spectrum, unit: &str) -> Chart {
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
pub(super) fn order_spectrum_chart(d: &Diagnosis, m: &crate::signal::order_map::OrderMap) -> Chart {
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

/// The shaft whose orders the charts count: the pinion, the estimated period's shaft, or a machine's
/// tracked shaft.
pub(super) fn reference_shaft(d: &Diagnosis) -> &'static str {
    match &d.shaft_hz {
        ShaftHz::Pair { .. } | ShaftHz::Pinion { .. } => "pinion",
        ShaftHz::Estimated { .. } => "shaft of the estimated period",
        ShaftHz::Machine(m) => m.0.first().map_or("tracked shaft", |s| s.0.name()),
    }
}

/// Zooms centred on each of the first mesh harmonics (+-4.5 reference-shaft orders): the baseline light
/// grey behind the recording, dots on the sidebands that stand out 12 dB over the local floor, and
/// hatched squares on sidebands that another shaft's line lies too close to be told apart.
pub(super) fn mesh_zooms(d: &Diagnosis, ch: usize) -> Vec<Chart> {
    let (Some((_, amp)), Some(f1)) = (d.spectra().iter().find(|s| s.0 == ch), d.shaft_hz.reference()) else {
        return Vec::new();
    };
    d.mesh_harmonics
        .iter()
        .filter_map(|h| {
            let fk = h.frequency_hz?;
            let (lo, hi) = (fk - 4.5 * f1, fk + 4.5 * f1);
            let (mut series, peak) = zoom_traces(d, ch, amp, lo, hi);
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
                markers: vec![Marker { x: fk, label: format!("{}x mesh", h.k), color: 0 }],
                ..zoom_chart(
                    d,
                    format!("zoom around {}x mesh = {} Hz, channel {ch}", h.k, num(fk)),
                    (lo, hi),
                    peak,
                    series,
                )
            })
        })
        .collect()
}

/// The (frequency in Hz, value) points of `s` above 0 Hz and up to `max_f` Hz.
/// The points of `s` from `lo` to `hi` Hz.
fn cut(s: &crate::signal::Spectrum, lo: f64, hi: f64) -> Vec<(f64, f64)> {
    s.freqs_hz.iter().zip(&s.values).filter(|(f, _)| **f >= lo && **f <= hi).map(|(f, v)| (*f, *v)).collect()
}

/// The traces of a zoom on `lo..hi` Hz of channel `ch`: the healthy baseline's spectrum in light grey behind
/// (when there is one), this recording's over it; and this recording's peak there.
pub(super) fn zoom_traces(
    d: &Diagnosis,
    ch: usize,
    amp: &crate::signal::Spectrum,
    lo: f64,
    hi: f64,
) -> (Vec<Series>, f64) {
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
    (series, peak)
}

/// A zoom's chart on `range` Hz: log amplitude from 1e-4 of this recording's `peak` there to 3 times it.
pub(super) fn zoom_chart(d: &Diagnosis, title: String, range: (f64, f64), peak: f64, series: Vec<Series>) -> Chart {
    Chart {
        title,
        x_label: "frequency [Hz]".into(),
        y_label: format!("amplitude [{}]", unit_or(&d.unit)),
        y_log: true,
        x_range: Some(range),
        y_range: Some((peak * 1e-4, peak * 3.0)),
        series,
        ..Default::default()
    }
}

pub(super) fn in_band(s: &crate::signal::Spectrum, max_f: f64) -> Vec<(f64, f64)> {
    s.freqs_hz.iter().zip(&s.values).filter(|(f, _)| **f > 0.0 && **f <= max_f).map(|(f, v)| (*f, *v)).collect()
}
