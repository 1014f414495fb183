//! Beyond the spectrum: the fast kurtogram, the envelope spectrum, the rpm-order map and the cepstrum.

use super::spectra::reference_shaft;
use super::*;

/// Whether the kurtogram's own best cell (largest spectral kurtosis at or above the lowest frequency of
/// the chosen band's search, 1.5 mesh frequencies) is the chosen band: when not, the band came from
/// elsewhere (the baseline's band, or `--envelope-band`).
pub(super) fn band_is_own_best(e: &crate::report::summary::Envelope, fs: f64, from_hz: f64) -> bool {
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
pub(super) fn envelope_chart(d: &Diagnosis, e: &crate::report::summary::Envelope) -> Chart {
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

/// Dynamic range of the order map's colour scale, dB below its strongest cell.
pub(super) const ORDER_MAP_RANGE_DB: f64 = 60.0;

/// The rpm-order map as coloured cells: order across, speed up, colour the amplitude in dB re the
/// strongest cell (colour bar at the right); the mesh harmonics marked above the map. A resonance shows
/// as a curve order = f / speed.
pub(super) fn order_map_chart(d: &Diagnosis, m: &crate::signal::order_map::OrderMap, fs: f64) -> Chart {
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
pub(super) fn cepstrum_chart(c: &crate::report::summary::Cepstrum) -> Chart {
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
