//! The fit turned into what a user reads: error harmonics, tooth deviations, the lines against the model,
//! and the warnings when the teeth or the fit do not hold.

use super::*;

/// chi2/dof above which the fit is said not to explain the recording.
pub const POOR_FIT_CHI2: f64 = 25.0;

/// A warning when the scene's teeth do not fit the recording: the measured line at the first mesh order
/// h z1 must stand above every sideband of its band, as a mesh line does (a wrong z1 puts the "mesh" on a
/// sideband or between lines).
pub(super) fn teeth_misfit(setup: &Setup, y: &[C64]) -> Option<String> {
    let mesh = setup.lines.iter().zip(y).find(|(l, _)| l.harmonic == 1 && l.kind == LineKind::Mesh)?.1.norm();
    let (line, top) = setup
        .lines
        .iter()
        .zip(y)
        .filter(|(l, _)| l.harmonic == 1 && l.kind != LineKind::Mesh)
        .map(|(l, v)| (l, v.norm()))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    (top > mesh).then(|| {
        format!(
            "the scene's teeth ({}, {}) do not fit this recording: the line at the mesh order {} is {:.2} times weaker than the one at order {} beside it; check the scene",
            setup.params.pinion_teeth,
            setup.params.wheel_teeth,
            setup.params.pinion_teeth,
            top / mesh,
            line.m as f64 / setup.period_revs as f64
        )
    })
}

/// Sideband energy explained: 1 - sum |Y - Yhat|^2 / sum |Y|^2 over the sidebands.
pub(super) fn explained(setup: &Setup, y: &[C64], model: &[C64]) -> f64 {
    let (mut res, mut tot) = (0.0, 0.0);
    for ((l, v), m) in setup.lines.iter().zip(y).zip(model) {
        if l.kind != LineKind::Mesh {
            res += (v - m).norm_sqr();
            tot += v.norm_sqr();
        }
    }
    if tot > 0.0 { 1.0 - res / tot } else { 0.0 }
}

/// Error harmonics from the parameters (Re E, Im E pairs) and their covariance:
/// amplitude |E|, phase arg E, standard errors by the delta method.
pub(super) fn harmonics(setup: &Setup, f: &fit::Fit) -> (Vec<ErrorHarmonic>, Vec<ErrorHarmonic>) {
    let one = |k: usize, order: usize| {
        let (re, im) = (f.params[2 * k], f.params[2 * k + 1]);
        let c = &f.covariance;
        let (vrr, vii, vri) = (c[2 * k][2 * k], c[2 * k + 1][2 * k + 1], c[2 * k][2 * k + 1]);
        let a = re.hypot(im);
        let a2 = (a * a).max(f64::MIN_POSITIVE);
        let var_a = (re * re * vrr + im * im * vii + 2.0 * re * im * vri) / a2;
        let var_p = (im * im * vrr + re * re * vii - 2.0 * re * im * vri) / (a2 * a2);
        let amplitude_std_m = var_a.max(0.0).sqrt();
        ErrorHarmonic {
            order,
            amplitude_m: a,
            phase_rad: im.atan2(re),
            amplitude_std_m,
            phase_std_rad: var_p.max(0.0).sqrt().min(PI),
            resolved: a > 3.0 * amplitude_std_m,
        }
    };
    let n = setup.pinion_orders;
    let pinion = (0..n).map(|k| one(k, k + 1)).collect();
    let wheel = (0..setup.wheel_orders).map(|k| one(n + k, k + 1)).collect();
    (pinion, wheel)
}

/// e of each gear at its teeth's centres theta_n = 2 pi (n - 1/2) / z, from the fitted harmonics (plus a
/// found pit on its gear), with standard errors from the covariance (the pit depth's own variance added).
pub(super) fn tooth_deviations(
    setup: &Setup,
    f: &fit::Fit,
    fault: Option<&LocalFault>,
    pit_width: f64,
    np: usize,
) -> (PerTooth, PerTooth) {
    let gear_dev = |z: usize, first: usize, orders: usize, gear: Gear| -> (Vec<f64>, Vec<f64>) {
        if orders == 0 {
            return (Vec::new(), Vec::new());
        }
        let pit = fault.filter(|l| l.kind == FaultKind::Pit && l.gear == gear).map(|l| {
            let g = crate::model::gear::gaussian_tooth_faults(
                z,
                &[crate::model::gear::ToothFault { tooth: l.tooth, depth_m: 1.0, width_teeth: pit_width }],
                1e-9,
            );
            (g, l.depth)
        });
        (1..=z)
            .map(|n| {
                let theta = 2.0 * PI * (n as f64 - 0.5) / z as f64;
                // d = sum_i Re E_i cos(i theta) - Im E_i sin(i theta): gradient g over (Re, Im) pairs
                let grad: Vec<f64> =
                    (1..=orders).flat_map(|i| [(i as f64 * theta).cos(), -(i as f64 * theta).sin()]).collect();
                let idx = |k: usize| first + k;
                let mut d: f64 = grad.iter().enumerate().map(|(k, g)| g * f.params[idx(k)]).sum();
                let mut var: f64 = (0..grad.len())
                    .flat_map(|a| (0..grad.len()).map(move |b| (a, b)))
                    .map(|(a, b)| grad[a] * grad[b] * f.covariance[idx(a)][idx(b)])
                    .sum();
                if let Some((g, depth)) = &pit {
                    let shape = g.eval(theta / g.omega_rad_s);
                    d += depth * shape;
                    if f.params.len() > np {
                        var += shape * shape * f.covariance[np][np];
                    }
                }
                (d, var.max(0.0).sqrt())
            })
            .unzip()
    };
    let (p, ps) = gear_dev(setup.params.pinion_teeth, 0, setup.pinion_orders, Gear::Pinion);
    let (w, ws) = gear_dev(setup.params.wheel_teeth, 2 * setup.pinion_orders, setup.wheel_orders, Gear::Wheel);
    (PerTooth { pinion: p, wheel: w }, PerTooth { pinion: ps, wheel: ws })
}

pub(super) fn label(kind: LineKind, h: usize) -> String {
    match kind {
        LineKind::Mesh => format!("mesh {h}"),
        LineKind::Pinion(s) => format!("mesh {h} {} pinion {}", if s < 0 { "-" } else { "+" }, s.abs()),
        LineKind::Wheel(s) => format!("mesh {h} {} wheel {}", if s < 0 { "-" } else { "+" }, s.abs()),
    }
}

pub(super) fn fit_lines(setup: &Setup, y: &[C64], model: &[C64], noise: &[f64]) -> Vec<FitLine> {
    setup
        .lines
        .iter()
        .enumerate()
        .map(|(k, l)| FitLine {
            order: l.m as f64 / setup.period_revs as f64,
            frequency_hz: setup.frequency_hz(l.m),
            label: label(l.kind, l.harmonic),
            measured: y[k].norm(),
            model: model[k].norm(),
            residual: (y[k] - model[k]).norm(),
            noise: noise[k],
        })
        .collect()
}
