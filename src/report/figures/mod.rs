//! The report images: which data, which axes, which labels. Drawing itself is in [`super::plot`].

use super::ReportError;
use super::plot::{Band, Chart, Heatmap, Marker, Series, Style, render_png, render_png_grid};
use super::summary::{BenchResult, Diagnosis, OrderLine, Shaft, ShaftHz, Simulation, SweepPoint};
use crate::scene::{Model, Scene};
use std::path::{Path, PathBuf};

mod diagnose;
mod simulate;
mod sweep;

pub use diagnose::{diagnosis, trend};
pub use simulate::{multipliers, simulation};
pub use sweep::{bench, parameter_label, stability_map};

/// Kind of a spectral line of a gear pair, by its order of the pinion rotation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineKind {
    /// A mesh harmonic k z1.
    Mesh,
    /// k z1 +- j, j = 1..6 (pinion rotation).
    Pinion,
    /// k z1 +- j z1/z2, j = 1..6 (wheel rotation).
    Wheel,
    /// Anything else.
    Other,
}

/// Classifies `order` (pinion orders) for a pair with `z1`, `z2` teeth.
pub fn classify(order: f64, z1: usize, z2: usize) -> LineKind {
    let z = z1 as f64;
    let k = (order / z).round();
    let d = order - k * z;
    let near = |x: f64| (x - x.round()).abs() < 1e-6;
    if d.abs() < 1e-6 && k >= 1.0 {
        LineKind::Mesh
    } else if near(d) && d.abs() <= 6.5 {
        LineKind::Pinion
    } else if near(d * z2 as f64 / z) && (d * z2 as f64 / z).abs() <= 6.5 {
        LineKind::Wheel
    } else {
        LineKind::Other
    }
}

pub(super) fn gear_teeth(scene: &Scene) -> Option<(usize, usize)> {
    match &scene.model {
        Model::GearPair(g) => Some((g.params().pinion_teeth, g.params().wheel_teeth)),
        _ => None,
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

pub(super) fn mesh_markers(scene: &Scene, max_hz: f64) -> Vec<Marker> {
    let Some((z1, _)) = gear_teeth(scene) else { return Vec::new() };
    let fz = z1 as f64 * scene.output.base_hz;
    (1..)
        .map(|k| k as f64 * fz)
        .take_while(|f| *f <= max_hz)
        .enumerate()
        .map(|(i, f)| Marker { x: f, label: format!("{}x mesh", i + 1), color: 0 })
        .collect()
}

/// A sideband is drawn as detected only above this multiple of the local noise floor (about 10 dB).
const DETECTION_OVER_FLOOR: f64 = 3.0;

/// Median of the amplitude spectrum within 40 bins of `f_hz`, leaving out the 4 bins nearest to it: the
/// local noise floor (lines are sparse, so the median sits on the floor between them).
pub(super) fn noise_floor(s: &crate::signal::Spectrum, f_hz: f64) -> f64 {
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

/// The unit of a recording for axis labels: "unit of the file" when the file does not say.
pub(super) fn unit_or(unit: &str) -> &str {
    if unit.is_empty() { "unit of the file" } else { unit }
}
