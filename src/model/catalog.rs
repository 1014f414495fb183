//! Reference problems with known answers, for tests and benchmarks (russell `Samples` style).
//!
//! Each function returns a system together with what is known about it independently of any solver.

use super::SecondOrderSystem;
use crate::system::{Coefficient, FourierSeries, PiecewiseConstant};
use std::f64::consts::PI;

fn c(v: f64) -> Coefficient {
    Coefficient::constant(v)
}

/// Forced damped oscillator m y'' + c y' + k y = F0 cos(w t), period 2 pi / w.
///
/// Exact steady state: y = F0 / sqrt((k - m w^2)^2 + (c w)^2) cos(w t - atan2(c w, k - m w^2)).
pub fn forced_oscillator(m: f64, cd: f64, k: f64, f0: f64, w: f64) -> SecondOrderSystem {
    let forcing = Coefficient::Fourier(FourierSeries::new(w, 0.0, vec![f0], vec![]));
    SecondOrderSystem::new(2.0 * PI / w, vec![c(m)], vec![c(cd)], vec![c(k)], vec![forcing]).expect("positive mass")
}

/// Exact amplitude and phase lag of [`forced_oscillator`]'s steady state.
pub fn forced_oscillator_response(m: f64, cd: f64, k: f64, f0: f64, w: f64) -> (f64, f64) {
    let re = k - m * w * w;
    (f0 / re.hypot(cd * w), (cd * w).atan2(re))
}

/// Mathieu equation y'' + (a - 2 q cos 2t) y = 0 (period pi), with damping `cd` y'.
pub fn mathieu(a: f64, q: f64, cd: f64) -> SecondOrderSystem {
    let k = Coefficient::Fourier(FourierSeries::new(2.0, a, vec![-2.0 * q], vec![]));
    SecondOrderSystem::new(PI, vec![c(1.0)], vec![c(cd)], vec![k], vec![c(0.0)]).expect("unit mass")
}

/// Meissner equation y'' + k(t) y = forcing with k = `k_hi` on [0, `duty` T) and `k_lo` on [duty T, T).
pub fn meissner(period_s: f64, duty: f64, k_hi: f64, k_lo: f64, force: f64) -> SecondOrderSystem {
    let k = Coefficient::Piecewise(PiecewiseConstant {
        period_s,
        starts: vec![0.0, duty * period_s],
        values: vec![k_hi, k_lo],
    });
    SecondOrderSystem::new(period_s, vec![c(1.0)], vec![c(0.0)], vec![k], vec![c(force)]).expect("unit mass")
}
