//! The report images: which data, which axes, which labels. Drawing itself is in [`super::plot`].

use super::ReportError;
use super::format::{num, sig};
use super::plot::{
    BASELINE_GREY, Band, Chart, Heatmap, Marker, PAGE_WIDTH_PX, Series, Style, render_png, render_png_grid,
};
use super::summary::{
    BenchResult, Diagnosis, Indicator, OrderLine, PressCoordinate, Shaft, ShaftHz, Sideband, SimulateSummary,
    SimulationSeries, SpectrumScale, StabilitySummary, SweepPoint,
};
use std::path::{Path, PathBuf};

mod beyond;
mod diagnose;
mod machine;
mod simulate;
mod spectra;
mod sweep;
mod trend;
mod tsa;

pub use diagnose::{Figure, deciding_channel, diagnosis, diagnosis_figures};
pub use machine::{family_words, stage_words, stands as machine_sideband_stands_out};
pub use simulate::{multipliers, simulation};
pub use spectra::sideband_words;
pub use sweep::{bench, parameter_label, stability_map};
pub use trend::{TREND_PANEL_PX, short_names, trend, trend_charts};

/// Kind of a spectral line of a gear pair, by its order of the pinion rotation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineKind {
    /// A mesh harmonic k z1.
    Mesh,
    /// k z1 +- j for a whole j (pinion rotation), k the nearest mesh harmonic.
    Pinion,
    /// k z1 +- j z1/z2 for a whole j (wheel rotation) that is not a pinion order.
    Wheel,
    /// Anything else.
    Other,
}

/// Classifies `order` (pinion orders) for a pair with `z1`, `z2` teeth: every whole pinion order that is
/// not a mesh harmonic is a pinion sideband of its nearest mesh harmonic (order 7 of a 14-tooth pinion
/// too: it is the 7th pinion order below 1x mesh), every other whole wheel order a wheel sideband.
pub fn classify(order: f64, z1: usize, z2: usize) -> LineKind {
    let z = z1 as f64;
    let k = (order / z).round();
    let d = order - k * z;
    let near = |x: f64| (x - x.round()).abs() < 1e-6;
    if d.abs() < 1e-6 && k >= 1.0 {
        LineKind::Mesh
    } else if near(d) {
        LineKind::Pinion
    } else if near(d * z2 as f64 / z) {
        LineKind::Wheel
    } else {
        LineKind::Other
    }
}

/// Spectral lines as coloured stems (mesh, pinion and wheel sidebands apart) in Hz, log amplitude.
pub(super) fn order_stems(lines: &[OrderLine], teeth: Option<(usize, usize)>, floor: f64) -> Vec<Series> {
    let mut groups: Vec<(LineKind, &str, usize)> = vec![(LineKind::Other, "other lines", 4)];
    if teeth.is_some() {
        groups = vec![
            (LineKind::Mesh, "mesh harmonics k fz", 0),
            (LineKind::Pinion, "pinion sidebands k fz +- j f1", 1),
            (LineKind::Wheel, "wheel sidebands k fz +- j f2", 2),
            (LineKind::Other, "other lines", 4),
        ];
    }
    groups
        .into_iter()
        .filter_map(|(kind, name, color)| {
            let pts: Vec<(f64, f64)> = lines
                .iter()
                .filter(|l| l.order > 0.0 && l.amplitude > floor)
                .filter(|l| teeth.map_or(LineKind::Other, |(z1, z2)| classify(l.order, z1, z2)) == kind)
                .map(|l| (l.frequency_hz, l.amplitude))
                .collect();
            (!pts.is_empty()).then(|| Series { name: name.into(), points: pts, style: Style::Stems, color })
        })
        .collect()
}

/// A sideband is drawn as standing out only above this multiple of the local noise floor (12 dB, the
/// rule of the diagnosis's own wheel-teeth check, so the images and the warnings agree).
const DETECTION_OVER_FLOOR: f64 = 3.981;

/// Median of the amplitude spectrum within 40 bins of `f_hz`, leaving out the 4 bins nearest to it: the
/// local noise floor (lines are sparse, so the median sits on the floor between them).
pub fn noise_floor(s: &crate::signal::Spectrum, f_hz: f64) -> f64 {
    let df = s.freqs_hz.get(1).copied().unwrap_or(1.0).max(f64::MIN_POSITIVE);
    let k = (f_hz / df).round() as isize;
    let mut v: Vec<f64> = (k - 40..=k + 40)
        .filter(|i| (i - k).abs() > 4 && *i >= 0 && (*i as usize) < s.values.len())
        .map(|i| s.values[i as usize])
        .collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Whether a sideband stands out: resolved (no other shaft's line within its main lobe), and both its
/// measured amplitude and the spectrum drawn at it over 12 dB (3.98 times) above the local noise floor of `spectrum` (see [`noise_floor`]). The images put a dot on these
/// and the text lists these, in the same words ([`sideband_words`]).
pub fn stands_out(spectrum: &crate::signal::Spectrum, s: &Sideband) -> bool {
    s.resolved
        && s.frequency_hz.is_some_and(|f| {
            let floor = DETECTION_OVER_FLOOR * noise_floor(spectrum, f);
            s.amplitude > floor && drawn_peak(spectrum, f) > floor
        })
}

/// The largest value of `spectrum` within one bin of `f_hz`: the line as the image draws it.
pub fn drawn_peak(spectrum: &crate::signal::Spectrum, f_hz: f64) -> f64 {
    let df = spectrum.freqs_hz.get(1).copied().unwrap_or(1.0).max(f64::MIN_POSITIVE);
    let k = (f_hz / df).round() as isize;
    (k - 1..=k + 1)
        .filter(|i| *i >= 0 && (*i as usize) < spectrum.values.len())
        .map(|i| spectrum.values[i as usize])
        .fold(0.0, f64::max)
}

/// The unit of a recording for axis labels: "as recorded" when the file names none.
pub fn unit_or(unit: &str) -> &str {
    if unit.is_empty() { "as recorded, unit not given" } else { unit }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_of_a_pair_are_classed_by_the_shaft_whose_order_they_are() {
        // a 14/39 pair: order 28 is 2x mesh, 7 and 21 are the pinion's 7th orders around 1x mesh (once
        // "other lines"), 14 + 14/39 is the wheel's 40th order, 0.5 belongs to neither shaft
        assert_eq!(classify(28.0, 14, 39), LineKind::Mesh);
        assert_eq!(classify(7.0, 14, 39), LineKind::Pinion);
        assert_eq!(classify(21.0, 14, 39), LineKind::Pinion);
        assert_eq!(classify(13.0, 14, 39), LineKind::Pinion);
        assert_eq!(classify(14.0 + 14.0 / 39.0, 14, 39), LineKind::Wheel);
        assert_eq!(classify(0.5, 14, 39), LineKind::Other);
    }
}
