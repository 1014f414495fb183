//! Reference problems with known answers, for tests and benchmarks (russell `Samples` style): the builders
//! below, and [`problems`], each with its exact answer and where that answer comes from.
//!
//! Each function returns a system together with what is known about it independently of any solver.

use super::SecondOrderSystem;
use crate::system::{Coefficient, FourierSeries, PiecewiseConstant};
use nalgebra::{Complex, DMatrix, DVector};
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

/// A catalog problem: a system, what is known about it exactly, and where that knowledge comes from.
#[derive(Clone, Debug)]
pub struct Problem {
    /// Short name for test messages.
    pub name: &'static str,
    /// Where the exact answer comes from.
    pub citation: &'static str,
    /// The system.
    pub system: SecondOrderSystem,
    /// The exact answer.
    pub exact: Exact,
}

/// Exact answers of a [`Problem`].
#[derive(Clone, Debug)]
pub struct Exact {
    /// Periodic initial state x0 = [y(0), y'(0)] of the steady state (unique: no multiplier is 1).
    pub x0: Vec<f64>,
    /// Every Floquet multiplier, when known individually.
    pub multipliers: Option<Vec<Complex<f64>>>,
    /// |rho|max.
    pub rho_max: f64,
}

/// Multipliers exp(lambda T) of m y'' + c y' + k y = 0 with constant coefficients, lambda the roots of
/// m lambda^2 + c lambda + k = 0.
fn constant_multipliers(m: f64, cd: f64, k: f64, period: f64) -> Vec<Complex<f64>> {
    let disc = Complex::new(cd * cd - 4.0 * m * k, 0.0).sqrt();
    [1.0, -1.0].iter().map(|s| ((Complex::new(-cd, 0.0) + disc * *s) / (2.0 * m) * period).exp()).collect()
}

fn rho_max(m: &[Complex<f64>]) -> f64 {
    m.iter().map(|r| r.norm()).fold(0.0, f64::max)
}

/// Exact monodromy of y'' + c y' + k(t) y = F with piecewise-constant k (the [`meissner`] form) and its
/// periodic state, by matrix exponentials of each constant piece: on a piece, x - x* evolves by exp(A t)
/// with x* = (F / k, 0).
fn meissner_exact(period: f64, duty: f64, k_hi: f64, k_lo: f64, cd: f64, force: f64) -> (DMatrix<f64>, Vec<f64>) {
    let piece = |k: f64, dt: f64| DMatrix::from_row_slice(2, 2, &[0.0, dt, -k * dt, -cd * dt]).exp();
    let (e1, e2) = (piece(k_hi, duty * period), piece(k_lo, (1.0 - duty) * period));
    let (s1, s2) = (DVector::from_vec(vec![force / k_hi, 0.0]), DVector::from_vec(vec![force / k_lo, 0.0]));
    // x(T) = s2 + E2 (s1 + E1 (x0 - s1) - s2) = Phi x0 + c
    let phi = &e2 * &e1;
    let c = &s2 + &e2 * (&s1 - &e1 * &s1 - &s2);
    let x0 = (DMatrix::identity(2, 2) - &phi).lu().solve(&c).unwrap_or_else(|| DVector::zeros(2));
    (phi, x0.iter().copied().collect())
}

/// Every catalog problem with an exact answer.
pub fn problems() -> Vec<Problem> {
    let mut out = Vec::new();
    // undamped oscillator with a constant force: y = F/k + free vibration at w0 = 2 (period 1)
    out.push(Problem {
        name: "undamped oscillator",
        citation: "closed form: y'' + 4 y = 1 has the periodic state y = 1/4 and multipliers exp(+-2i)",
        system: SecondOrderSystem::new(1.0, vec![c(1.0)], vec![c(0.0)], vec![c(4.0)], vec![c(1.0)]).expect("unit mass"),
        exact: Exact { x0: vec![0.25, 0.0], multipliers: Some(constant_multipliers(1.0, 0.0, 4.0, 1.0)), rho_max: 1.0 },
    });
    let mults = constant_multipliers(2.0, 0.5, 4.0, 1.3);
    out.push(Problem {
        name: "constant coefficients",
        citation: "closed form: 2 y'' + 0.5 y' + 4 y = 1.5 over T = 1.3 s: y = 1.5/4, multipliers exp(lambda T)",
        system: SecondOrderSystem::new(1.3, vec![c(2.0)], vec![c(0.5)], vec![c(4.0)], vec![c(1.5)]).expect("mass 2"),
        exact: Exact { x0: vec![0.375, 0.0], rho_max: rho_max(&mults), multipliers: Some(mults) },
    });
    let (amp, lag) = forced_oscillator_response(1.0, 0.2, 4.0, 1.0, 1.5);
    let mults = constant_multipliers(1.0, 0.2, 4.0, 2.0 * PI / 1.5);
    out.push(Problem {
        name: "forced damped oscillator",
        citation: "closed form: y = F0 / |k - m w^2 + i c w| cos(w t - lag) (any vibration textbook)",
        system: forced_oscillator(1.0, 0.2, 4.0, 1.0, 1.5),
        exact: Exact {
            x0: vec![amp * lag.cos(), amp * 1.5 * lag.sin()],
            rho_max: rho_max(&mults),
            multipliers: Some(mults),
        },
    });
    // damped Mathieu inside the stable regions (a0, b1) and (a1, b2) at q = 1 (Abramowitz & Stegun Table
    // 20.1): y = exp(-c t/2) z with z bounded, so both multipliers have modulus exp(-c pi / 2)
    for (name, a) in [("Mathieu (a0, b1) q = 1", -0.3), ("Mathieu (a1, b2) q = 1", 2.5)] {
        let cd = 0.1;
        let forced = {
            let k = Coefficient::Fourier(FourierSeries::new(2.0, a, vec![-2.0], vec![]));
            SecondOrderSystem::new(PI, vec![c(1.0)], vec![c(cd)], vec![k], vec![c(0.0)]).expect("unit mass")
        };
        out.push(Problem {
            name,
            citation: "Abramowitz & Stegun Table 20.1 (stability regions at q = 1); |rho| = exp(-c T / 2) for both multipliers of a stable damped Mathieu equation (Liouville: det Phi = exp(-c T))",
            system: forced,
            exact: Exact { x0: vec![0.0, 0.0], multipliers: None, rho_max: (-cd * PI / 2.0).exp() },
        });
    }
    let (phi, x0) = meissner_exact(2.0, 0.37, 9.0, 2.5, 0.1, 1.5);
    let mults: Vec<Complex<f64>> = phi.complex_eigenvalues().iter().copied().collect();
    let system = {
        let k = Coefficient::Piecewise(PiecewiseConstant {
            period_s: 2.0,
            starts: vec![0.0, 0.74],
            values: vec![9.0, 2.5],
        });
        SecondOrderSystem::new(2.0, vec![c(1.0)], vec![c(0.1)], vec![k], vec![c(1.5)]).expect("unit mass")
    };
    out.push(Problem {
        name: "damped Meissner",
        citation: "exact matrix exponentials of each constant piece (Meissner 1918; Richards, Analysis of Periodically Time-Varying Systems, 1983)",
        system,
        exact: Exact { x0, rho_max: rho_max(&mults), multipliers: Some(mults) },
    });
    out
}
