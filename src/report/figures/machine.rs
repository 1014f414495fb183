//! The machine's marks on the diagnosis images (`diagnose --machine`): every stage's mesh lines in its own
//! colour, each sideband family (a shaft's, or the planet pass) in its own colour, the legend naming the
//! stage's shafts and the family's shaft.

use super::spectra::{zoom_chart, zoom_traces};
use super::*;
use crate::report::summary::{MachineDiagnosis, MachineSideband, StageDiagnosis};

/// Palette indices of the stages' mesh lines (blue, green, cyan, then again): apart from the recording's
/// purple (4) and the families' colours.
const STAGE_COLORS: [usize; 3] = [0, 2, 7];
/// Palette indices of the sideband families, in order of first appearance (red, orange, brown, pink).
const FAMILY_COLORS: [usize; 4] = [1, 3, 5, 6];

/// Colour of stage `k` (0-based).
pub fn stage_color(k: usize) -> usize {
    STAGE_COLORS[k % STAGE_COLORS.len()]
}

/// The sideband families of the machine in a fixed order (each shaft's, then the planet pass), so that a
/// family keeps its colour in every image of the recording.
fn families(md: &MachineDiagnosis) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for s in &md.stages {
        for h in &s.mesh_harmonics {
            for sb in &h.sidebands {
                if !out.contains(&sb.family) {
                    out.push(sb.family.clone());
                }
            }
        }
    }
    out
}

/// Colour of family `name`.
fn family_color(md: &MachineDiagnosis, name: &str) -> usize {
    let i = families(md).iter().position(|f| f == name).unwrap_or(0);
    FAMILY_COLORS[i % FAMILY_COLORS.len()]
}

/// "stage 1 mesh: pinion 23 teeth on `input`, wheel 61 on `intermediate`".
pub fn stage_words(s: &StageDiagnosis) -> String {
    let gears: Vec<String> = s
        .gears
        .iter()
        .enumerate()
        .map(|(i, g)| {
            let teeth = if i == 0 { format!("{} teeth", g.teeth) } else { g.teeth.to_string() };
            match &g.shaft {
                Some(shaft) => format!("{} {teeth} on `{shaft}`", g.gear),
                None => format!("{} {teeth}", g.gear),
            }
        })
        .collect();
    format!("stage {} mesh: {}", s.stage, gears.join(", "))
}

/// Legend words of a family's sidebands that stand out.
pub fn family_words(name: &str) -> String {
    if name == "planet pass" {
        "planet-pass sidebands 12 dB over the local floor".into()
    } else {
        format!("shaft `{name}` sidebands 12 dB over the local floor")
    }
}

/// Whether a machine sideband stands out (the pair's rule: resolved, 12 dB over the local floor).
pub fn stands(amp: &crate::signal::Spectrum, s: &MachineSideband) -> bool {
    let (Some(f), Some(a)) = (s.frequency_hz, s.amplitude) else { return false };
    s.resolved
        && stands_out(
            amp,
            &Sideband {
                offset: s.offset,
                shaft: Shaft::Estimated,
                frequency_hz: Some(f),
                order: s.order,
                amplitude: a,
                resolved: true,
            },
        )
}

/// Series and markers of the machine's lines within [lo, hi] Hz: per stage its mesh harmonics (points at
/// their peaks, for the legend, and markers labelled "S1 2x"), per family the sidebands that stand out.
pub fn machine_marks(
    md: &MachineDiagnosis,
    amp: &crate::signal::Spectrum,
    lo: f64,
    hi: f64,
    harmonic: Option<(usize, u32)>,
) -> (Vec<Series>, Vec<Marker>) {
    let (mut series, mut markers) = (Vec::new(), Vec::new());
    let inside = |f: f64| f >= lo && f <= hi;
    for s in &md.stages {
        let mesh: Vec<(f64, f64)> = s
            .mesh_harmonics
            .iter()
            .filter_map(|h| h.frequency_hz)
            .filter(|f| inside(*f))
            .map(|f| (f, drawn_peak(amp, f)))
            .collect();
        for h in &s.mesh_harmonics {
            if let Some(f) = h.frequency_hz.filter(|f| inside(*f)) {
                markers.push(Marker { x: f, label: format!("S{} {}x", s.stage, h.k), color: stage_color(s.stage - 1) });
            }
        }
        if !mesh.is_empty() {
            series.push(Series {
                name: stage_words(s),
                points: mesh,
                style: Style::Points,
                color: stage_color(s.stage - 1),
            });
        }
    }
    for fam in families(md) {
        let pts: Vec<(f64, f64)> = md
            .stages
            .iter()
            .flat_map(|s| s.mesh_harmonics.iter().map(move |h| (s.stage, h)))
            .filter(|(k, h)| harmonic.is_none_or(|(stage, hk)| stage == *k && hk == h.k))
            .flat_map(|(_, h)| h.sidebands.iter())
            .filter(|sb| sb.family == fam && stands(amp, sb))
            .filter_map(|sb| sb.frequency_hz)
            .filter(|f| inside(*f))
            .map(|f| (f, drawn_peak(amp, f)))
            .collect();
        if !pts.is_empty() {
            series.push(Series {
                name: family_words(&fam),
                points: pts,
                style: Style::Points,
                color: family_color(md, &fam),
            });
        }
    }
    (series, markers)
}

/// Zooms around each stage's first two mesh harmonics (+-4.5 orders of the stage's slower shaft, at least
/// +-4.5 planet-pass orders), every stage's and family's lines marked.
pub fn machine_zooms(d: &Diagnosis, md: &MachineDiagnosis, ch: usize) -> Vec<Chart> {
    let Some((_, amp)) = d.spectra().iter().find(|s| s.0 == ch) else { return Vec::new() };
    let mut out = Vec::new();
    for s in &md.stages {
        // the widest family spacing of the stage, in Hz: its +-1 sideband's distance from the mesh line
        let spacing = s
            .mesh_harmonics
            .first()
            .and_then(|h| {
                let f0 = h.frequency_hz?;
                h.sidebands
                    .iter()
                    .filter(|sb| sb.offset == 1)
                    .filter_map(|sb| sb.frequency_hz.map(|f| (f - f0).abs()))
                    .reduce(f64::max)
            })
            .unwrap_or(0.0);
        for h in s.mesh_harmonics.iter().take(2) {
            let Some(fk) = h.frequency_hz else { continue };
            if spacing <= 0.0 || fk + 4.5 * spacing > *amp.freqs_hz.last().unwrap_or(&0.0) {
                continue;
            }
            let (lo, hi) = (fk - 3.5 * spacing, fk + 3.5 * spacing);
            let (mut series, peak) = zoom_traces(d, ch, amp, lo, hi);
            let (marks, markers) = machine_marks(md, amp, lo, hi, Some((s.stage, h.k)));
            series.extend(marks);
            // lines of two families (or stages) within three bins: their amplitude belongs to neither
            let unresolved: Vec<(f64, f64)> = h
                .sidebands
                .iter()
                .filter(|sb| !sb.resolved)
                .filter_map(|sb| sb.frequency_hz.map(|f| (f, drawn_peak(amp, f))))
                .filter(|p| p.1 > 0.0)
                .collect();
            if !unresolved.is_empty() {
                series.push(Series {
                    name: "unresolved: lines of two families within 3 bins".into(),
                    points: unresolved,
                    style: Style::Hatched,
                    color: 8,
                });
            }
            out.push(Chart {
                markers,
                ..zoom_chart(
                    d,
                    format!("zoom around stage {} {}x mesh = {} Hz, channel {ch}", s.stage, h.k, num(fk)),
                    (lo, hi),
                    peak,
                    series,
                )
            });
        }
    }
    out
}

/// Markers of every stage's mesh orders (of the tracked shaft) up to `top`, in the stage's colour.
pub fn stage_order_markers(md: &MachineDiagnosis, top: f64) -> Vec<Marker> {
    md.stages
        .iter()
        .flat_map(|s| {
            (1..=3u32)
                .map(move |h| (s, h, h as f64 * s.mesh_order))
                .filter(move |(_, _, o)| *o <= top)
                .map(|(s, h, o)| Marker { x: o, label: format!("S{} {h}x", s.stage), color: stage_color(s.stage - 1) })
        })
        .collect()
}

/// Legend entries of every stage's mesh orders on an order spectrum `pts` (order, amplitude): a point on
/// the spectrum at each harmonic up to `top`, in the stage's colour, named with its shafts.
pub fn stage_order_series(md: &MachineDiagnosis, pts: &[(f64, f64)], top: f64) -> Vec<Series> {
    let at = |o: f64| -> f64 {
        // the largest value within half an order (the order axis of a run-up's mean spectrum is fine)
        pts.iter().filter(|p| (p.0 - o).abs() <= 0.5).map(|p| p.1).fold(0.0, f64::max)
    };
    md.stages
        .iter()
        .filter_map(|s| {
            let points: Vec<(f64, f64)> = (1..=3u32)
                .map(|h| h as f64 * s.mesh_order)
                .filter(|o| *o <= top)
                .map(|o| (o, at(o)))
                .filter(|p| p.1 > 0.0)
                .collect();
            (!points.is_empty()).then(|| Series {
                name: stage_words(s),
                points,
                style: Style::Points,
                color: stage_color(s.stage - 1),
            })
        })
        .collect()
}
