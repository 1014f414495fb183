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
    let (marks, markers) = envelope_marks(e);
    series.extend(marks);
    let reference = reference_shaft(d);
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

/// The shafts of `shafts` in order of first appearance: a pair's pinion and wheel, the shaft of an
/// estimated period, or every shaft of a machine file.
fn distinct_shafts(shafts: impl IntoIterator<Item = Shaft>) -> Vec<Shaft> {
    let mut out: Vec<Shaft> = Vec::new();
    for s in shafts {
        if !out.contains(&s) {
            out.push(s);
        }
    }
    out
}

/// Palette index of the `i`-th shaft marked on the envelope spectrum and the cepstrum (red, green,
/// orange, brown, pink, cyan, blue; the data's purple is left out).
fn shaft_colour(i: usize) -> usize {
    [1, 2, 3, 5, 6, 7, 0][i % 7]
}

/// A shaft's name on a marker ("shaft" for the shaft of an estimated period).
fn shaft_label(shaft: Shaft) -> &'static str {
    if shaft == Shaft::Estimated { "shaft" } else { shaft.name() }
}

/// The envelope spectrum's marks: every shaft's first orders (a pair's pinion and wheel, or each shaft of
/// a machine) as labelled markers, and a dot on those 10 dB over the envelope spectrum around them.
pub(super) fn envelope_marks(e: &crate::report::summary::Envelope) -> (Vec<Series>, Vec<Marker>) {
    let (mut series, mut markers) = (Vec::new(), Vec::new());
    for (i, shaft) in distinct_shafts(e.lines.iter().map(|l| l.shaft)).into_iter().enumerate() {
        let lines: Vec<_> = e.lines.iter().filter(|l| l.shaft == shaft).collect();
        let detected: Vec<(f64, f64)> =
            lines.iter().filter(|l| l.over_floor_db >= 10.0).map(|l| (l.reference_order, l.amplitude)).collect();
        markers.extend(lines.iter().map(|l| Marker {
            x: l.reference_order,
            label: format!("{}x {}", l.order, shaft_label(shaft)),
            color: shaft_colour(i),
        }));
        if !detected.is_empty() {
            series.push(Series {
                name: format!("{shaft} orders 10 dB over the envelope spectrum around them"),
                points: detected,
                style: Style::Points,
                color: shaft_colour(i),
            });
        }
    }
    (series, markers)
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
    // one colour per shaft: a machine's three shafts were all drawn red
    let shafts = distinct_shafts(c.rahmonics.iter().map(|r| r.shaft));
    let markers = c
        .rahmonics
        .iter()
        .map(|r| Marker {
            x: 1e3 * r.quefrency_s,
            label: format!("{} {}", shaft_label(r.shaft), r.k),
            color: shaft_colour(shafts.iter().position(|s| *s == r.shaft).unwrap_or(0)),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::summary::{Envelope, EnvelopeLine};

    fn line(shaft: Shaft, order: usize, reference_order: f64, over_floor_db: f64) -> EnvelopeLine {
        EnvelopeLine { shaft, order, reference_order, amplitude: 1.0, over_floor_db }
    }

    /// A machine's shafts are marked on the envelope spectrum as a pair's are (they were left out: the
    /// two-stage gearbox's "output order 1 stands 21.3 dB" had neither marker nor dot), each in its own
    /// colour.
    #[test]
    fn envelope_marks_every_shaft_of_a_machine() {
        let (input, output) = (Shaft::named("input"), Shaft::named("output"));
        let e = Envelope {
            band_hz: [5000.0, 10000.0],
            level: 1,
            spectral_kurtosis: 3.0,
            lines: vec![line(input, 1, 1.0, 7.0), line(input, 2, 2.0, 3.0), line(output, 1, 1.0 / 6.0, 21.3)],
            liftered: None,
            orders: Vec::new(),
            amplitudes: Vec::new(),
            kurtogram: Vec::new(),
        };
        let (series, markers) = envelope_marks(&e);
        let labels: Vec<&str> = markers.iter().map(|m| m.label.as_str()).collect();
        assert_eq!(labels, ["1x input", "2x input", "1x output"]);
        assert_ne!(markers[0].color, markers[2].color, "two shafts in one colour");
        assert_eq!(series.len(), 1, "only the output's line stands 10 dB out");
        assert_eq!(series[0].points, vec![(1.0 / 6.0, 1.0)]);
        assert!(series[0].name.starts_with("output orders"), "{}", series[0].name);
    }

    /// Each shaft's rahmonics in their own colour (a machine's three shafts were all red).
    #[test]
    fn cepstrum_gives_each_shaft_its_colour() {
        use crate::report::summary::{Cepstrum, Rahmonic};
        let rahmonic =
            |name: &str, k: usize, q: f64| Rahmonic { shaft: Shaft::named(name), k, quefrency_s: q, value: 0.1 };
        let c = Cepstrum {
            rahmonics: vec![rahmonic("input", 1, 0.04), rahmonic("intermediate", 1, 0.08), rahmonic("output", 1, 0.24)],
            dq_s: 1e-4,
            values: vec![0.0; 4000],
        };
        let colours: Vec<usize> = cepstrum_chart(&c).markers.iter().map(|m| m.color).collect();
        assert!(colours[0] != colours[1] && colours[1] != colours[2] && colours[0] != colours[2], "{colours:?}");
    }
}
