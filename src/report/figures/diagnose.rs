//! The images of `diagnose`, in the order the page shows them: TSAs, the spectrum (or order spectrum),
//! zooms, envelope, kurtogram, cepstrum, order map, the comparison with a model. The charts themselves
//! are in the sibling modules `tsa`, `spectra` and `beyond`; the trend over recordings in `trend`.

use super::beyond::{cepstrum_chart, envelope_chart, kurtogram_chart, order_map_chart};
use super::spectra::{mesh_zooms, order_spectrum_chart, scaled, spectrum_chart, tsa_order_spectrum_chart};
use super::*;
use crate::report::summary::Comparison;

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

/// The images of one diagnosis, as [`diagnosis`] writes them (file names start with the recording's stem).
pub fn diagnosis_figures(d: &Diagnosis) -> Vec<Figure> {
    let stem = Path::new(&d.file).file_stem().and_then(|s| s.to_str()).unwrap_or("recording").to_string();
    let mut figures = Vec::new();
    // TSA of each gear on the channel that decided the verdict
    let ch = deciding_channel(d);
    let tsas = super::tsa::tsa_charts(d, ch);
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
        (None, None) => mesh_zooms(d, ch),
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
            charts: titled(&stem, vec![envelope_chart(d, e)]),
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
            charts: titled(&stem, vec![cepstrum_chart(c)]),
        });
    }
    if let (Some(m), Some(fs)) = (&d.order_map, d.sample_rate_hz) {
        figures.push(Figure {
            file: format!("{stem}-order-map.png"),
            width: PAGE_WIDTH_PX,
            height: 700,
            charts: titled(&stem, vec![order_map_chart(d, m, fs)]),
        });
    }
    if let Some(c) = &d.comparison {
        figures.push(Figure {
            file: format!("{stem}-vs-model.png"),
            width: PAGE_WIDTH_PX,
            height: 560,
            charts: titled(&stem, vec![comparison_chart(c)]),
        });
    }
    figures
}

/// The measured lines against the model's: measured and model stems side by side at each order, the
/// lines the model misses (measured more than 6 dB above it) ringed.
fn comparison_chart(c: &Comparison) -> Chart {
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
    Chart {
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
    }
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

/// The first chart's title starts with the recording's name (an image pasted alone still says which
/// recording it shows).
fn titled(stem: &str, mut charts: Vec<Chart>) -> Vec<Chart> {
    if let Some(c) = charts.first_mut() {
        c.title = format!("{stem}: {}", c.title);
    }
    charts
}
