//! The time-synchronous averages of a diagnosis: each gear's TSA over its healthy baseline, its residual
//! and difference signal, along the gear's teeth.

use super::*;

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

/// The TSA charts of each gear on channel `ch`: the average over the healthy baseline's (light grey,
/// tachometer-aligned or turned to the best fit), then the residual and the difference signal.
pub(super) fn tsa_charts(d: &Diagnosis, ch: usize) -> Vec<Chart> {
    // angle axis in teeth of the gear (tooth k between k - 1 and k), the origin at the tachometer pulse or,
    // with mesh-phase tracking, arbitrary
    let origin = if d.speed_profile.tracking.tachometer_origin() {
        "origin at the tachometer pulse"
    } else {
        "origin arbitrary: no tachometer"
    };
    d
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
        .collect()
}

/// `b` circularly shifted to the lag of largest correlation with `a` (same length; O(n^2), n <= 4096).
pub(super) fn aligned(b: &[f64], a: &[f64]) -> Vec<f64> {
    let n = a.len();
    let corr = |lag: usize| (0..n).map(|i| a[i] * b[(i + lag) % n]).sum::<f64>();
    let best = (0..n).max_by(|&x, &y| corr(x).total_cmp(&corr(y))).unwrap_or(0);
    (0..n).map(|i| b[(i + best) % n]).collect()
}
