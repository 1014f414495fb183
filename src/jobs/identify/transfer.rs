//! The model side of `identify`: the lines the fit uses, and the gear pair's response at them to the static
//! load, to each unit error harmonic, to a pit and to a crack.
//!
//! For a fixed mesh stiffness k_z(t), Eq 42 is affine in the transmission error e(t):
//!
//! ```text
//! m_red q'' + c_z q' + k_z(t) q = k0 q0 - (k_z(t) - k0) e(t) - c_z e'(t)
//! e(t) = sum_i Re(E_i exp(i i w1 t)) + sum_j Re(F_j exp(i j w2 t))
//! Y(m) = R0(m) + sum_i (Re E_i T_i^c(m) - Im E_i T_i^s(m)) + (same for F_j)
//! ```
//! with R0 the response to the static load alone and T^c, T^s the responses to e = cos, sin of one order
//! (no static load). All come from one harmonic-balance operator factored once ([`hill::solve_many`]). A
//! pit is one more error term (a Gaussian bump on one tooth), a crack changes k_z itself: its static-load
//! response is time-stepped, and the error transfers of the healthy mesh are kept (the crack's effect on
//! the error response is a product of two small terms, neglected in the search).
//!
//! A local fault on tooth n is the tooth-1 fault delayed by (n - 1) mesh periods; k_z is mesh-periodic, so
//! its response is delayed alike: Y_n(m) = Y_1(m) exp(-i 2 pi m (n - 1) / (P z1)), one solve for all teeth.

use crate::jobs::simulate::grid_coefficients;
use crate::model::Quantity;
use crate::model::gear::{Crack, Gear, GearPair, GearPairParams, ToothFault, gaussian_tooth_faults};
use crate::solver::{self, SolverError, hill};
use crate::system::gcd;
use crate::system::{FourierSeries, PeriodicSystem};
use nalgebra::Complex;
use std::f64::consts::PI;

type C64 = Complex<f64>;

/// What a fitted line is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineKind {
    /// Mesh harmonic h (order h z1 of the pinion).
    Mesh,
    /// Sideband of a pinion order: offset in pinion orders (+-i).
    Pinion(i32),
    /// Sideband of a wheel order: offset in wheel orders (+-j).
    Wheel(i32),
}

/// One line of the fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// Period order m (harmonic of 1 / P pinion revolutions).
    pub m: usize,
    /// Mesh harmonic h >= 1 whose band it is in (index h - 1 of the path gains).
    pub harmonic: usize,
    /// What it is.
    pub kind: LineKind,
}

/// The gear pair set up for identification: its parameters at the measured speed, the period and the
/// lines.
pub struct Setup {
    /// Parameters without errors, faults or crack, at the measured speed.
    pub params: GearPairParams,
    /// Pinion revolutions per period P.
    pub period_revs: usize,
    /// Pinion orders 1..=N fitted.
    pub pinion_orders: usize,
    /// Wheel orders 1..=M fitted.
    pub wheel_orders: usize,
    /// Mesh harmonics 1..=H used.
    pub harmonics: usize,
    /// The lines, mesh harmonic by mesh harmonic.
    pub lines: Vec<Line>,
    /// What the recording measures.
    pub quantity: Quantity,
}

impl Setup {
    /// Lines of mesh harmonics 1..=`harmonics` with their pinion and wheel sidebands; the parameters'
    /// own errors and crack are dropped (they are what the fit estimates).
    pub fn new(
        mut params: GearPairParams,
        pinion_orders: usize,
        wheel_orders: usize,
        harmonics: usize,
        quantity: Quantity,
    ) -> Self {
        params.pinion_errors = FourierSeries::constant(0.0);
        params.wheel_errors = FourierSeries::constant(0.0);
        params.crack = None;
        let (z1, z2) = (params.pinion_teeth, params.wheel_teeth);
        let period_revs = if wheel_orders > 0 { z2 / gcd(z1, z2) } else { 1 };
        let p = period_revs as i64;
        let wheel_step = (period_revs * z1 / z2) as i64; // period orders per wheel order
        let mut lines = Vec::new();
        for h in 1..=harmonics {
            let mesh = p * (h * z1) as i64;
            lines.push(Line { m: mesh as usize, harmonic: h, kind: LineKind::Mesh });
            for i in 1..=pinion_orders as i64 {
                for s in [-1, 1] {
                    lines.push(Line {
                        m: (mesh + s * i * p) as usize,
                        harmonic: h,
                        kind: LineKind::Pinion((s * i) as i32),
                    });
                }
            }
            for j in 1..=wheel_orders as i64 {
                for s in [-1, 1] {
                    let m = mesh + s * j * wheel_step;
                    lines.push(Line { m: m as usize, harmonic: h, kind: LineKind::Wheel((s * j) as i32) });
                }
            }
        }
        Self { params, period_revs, pinion_orders, wheel_orders, harmonics, lines, quantity }
    }

    /// Highest period order among the lines.
    pub fn max_m(&self) -> usize {
        self.lines.iter().map(|l| l.m).max().unwrap_or(0)
    }

    /// Pinion rotation frequency in Hz.
    pub fn pinion_hz(&self) -> f64 {
        self.params.speed_rpm / 60.0
    }

    /// Frequency of period order m in Hz.
    pub fn frequency_hz(&self, m: usize) -> f64 {
        m as f64 * self.pinion_hz() / self.period_revs as f64
    }

    fn pair(&self) -> GearPair {
        GearPair::new(self.params.clone())
    }

    /// Output coefficient of the measured quantity from the coefficient Y of q (one-sided, so 2 Y) at
    /// period order m: velocity i m w Y, acceleration -(m w)^2 Y.
    fn output(&self, y: C64, m: usize) -> C64 {
        let w = 2.0 * PI * self.frequency_hz(m);
        let d = 2.0 * y;
        match self.quantity {
            Quantity::Displacement => d,
            Quantity::Velocity => d * C64::new(0.0, w),
            Quantity::Acceleration => d * (-w * w),
        }
    }

    fn at_lines(&self, sol: &hill::HillSolution) -> Vec<C64> {
        self.lines.iter().map(|l| self.output(sol.coefficient(0, l.m), l.m)).collect()
    }
}

/// The healthy model at the lines: the static-load response and one column per real error parameter.
pub struct Transfers {
    /// R0 at each line.
    pub base: Vec<C64>,
    /// One column per parameter: Re E_1, Im E_1, ..., Re E_N, Im E_N, then Re F_1, Im F_1, ... (wheel).
    pub columns: Vec<Vec<C64>>,
}

/// Unit cosine (or sine) of `order` in a gear angle.
fn unit(order: usize, sine: bool) -> FourierSeries {
    let mut c = vec![0.0; order];
    let mut s = vec![0.0; order];
    if sine {
        s[order - 1] = 1.0
    } else {
        c[order - 1] = 1.0
    }
    FourierSeries::new(1.0, 0.0, c, s)
}

/// Harmonic-balance truncation for responses up to period order `max_m`: the solve of the static load
/// plus every unit error to 1e-10, starting at `max_m`.
fn truncation(
    pair: &GearPair,
    revs: f64,
    pe: &FourierSeries,
    we: &FourierSeries,
    max_m: usize,
) -> Result<usize, SolverError> {
    let form = pair.fourier_form_with(revs, pe, we, true).ok_or(SolverError::Singular)?;
    let (sol, _, _) = hill::solve(&form, max_m + 1, 1e-10, 64 * (max_m + 64))?;
    Ok(sol.harmonics.max(max_m + 1))
}

/// The healthy transfers (one operator, one factorisation per residue class).
///
/// # Errors
/// The mesh stiffness is not a Fourier series (then the pair has no harmonic-balance form), or a harmonic
/// is in resonance.
pub fn healthy(setup: &Setup) -> Result<Transfers, SolverError> {
    let pair = setup.pair();
    let revs = setup.period_revs as f64;
    let zero = FourierSeries::constant(0.0);
    let mut forcings: Vec<(FourierSeries, FourierSeries)> = Vec::new();
    for i in 1..=setup.pinion_orders {
        forcings.push((unit(i, false), zero.clone()));
        forcings.push((unit(i, true), zero.clone()));
    }
    for j in 1..=setup.wheel_orders {
        forcings.push((zero.clone(), unit(j, false)));
        forcings.push((zero.clone(), unit(j, true)));
    }
    let all_p = forcings.iter().fold(zero.clone(), |a, f| a.plus(&f.0));
    let all_w = forcings.iter().fold(zero.clone(), |a, f| a.plus(&f.1));
    let h = truncation(&pair, revs, &all_p, &all_w, setup.max_m())?;
    let form = pair.fourier_form_with(revs, &zero, &zero, true).ok_or(SolverError::Singular)?;
    let mut rhs = vec![form.forcing.clone()];
    for (pe, we) in &forcings {
        let f = pair.fourier_form_with(revs, pe, we, false).ok_or(SolverError::Singular)?;
        rhs.push(f.forcing);
    }
    let sols = hill::solve_many(&form, h, &rhs)?;
    let base = setup.at_lines(&sols[0]);
    // e = Re(E e^{i k theta}) = Re E cos - Im E sin: the Im E column is minus the sine response
    let columns = sols[1..]
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let col = setup.at_lines(s);
            if k % 2 == 1 { col.into_iter().map(|v| -v).collect() } else { col }
        })
        .collect();
    Ok(Transfers { base, columns })
}

/// The response at the lines to a unit-depth pit (Gaussian profile deviation of `width_teeth` pitches,
/// 6 sigma) on tooth 1 of `gear`; [`delayed`] moves it to another tooth.
///
/// # Errors
/// As [`healthy`].
pub fn pit(setup: &Setup, gear: Gear, width_teeth: f64) -> Result<Vec<C64>, SolverError> {
    let pair = setup.pair();
    let z = match gear {
        Gear::Pinion => setup.params.pinion_teeth,
        Gear::Wheel => setup.params.wheel_teeth,
    };
    // the bump's mean stays: a constant error e0 forces -(k_z - k0) e0 at the mesh lines
    let g = gaussian_tooth_faults(z, &[ToothFault { tooth: 1, depth_m: 1.0, width_teeth }], 1e-9);
    let zero = FourierSeries::constant(0.0);
    let (pe, we) = match gear {
        Gear::Pinion => (g, zero),
        Gear::Wheel => (zero, g),
    };
    let revs = setup.period_revs as f64;
    let h = truncation(&pair, revs, &pe, &we, setup.max_m())?;
    let form = pair.fourier_form_with(revs, &pe, &we, false).ok_or(SolverError::Singular)?;
    let sol = hill::solve_many(&form, h, std::slice::from_ref(&form.forcing))?;
    Ok(setup.at_lines(&sol[0]))
}

/// Fixed RK4 steps per revolution of the cracked gear for its responses: the grid is aligned on the crack
/// window, so responses at different losses share their discretisation error, which cancels in the
/// differences the search uses (about 1e-5 of the response left at 2048 steps, against line noise of
/// 1e-3 and more of a sideband).
pub const CRACK_STEPS: usize = 2048;

/// Responses at the lines of the pair with a crack of stiffness `loss` on tooth `tooth` of `gear`,
/// time-stepped on [`CRACK_STEPS`] steps: to the static load with `errors` = `None`, else to the error
/// series (pinion, wheel) alone without the static load.
///
/// # Errors
/// Solver failures.
pub fn cracked(
    setup: &Setup,
    gear: Gear,
    tooth: usize,
    loss: f64,
    errors: Option<(&FourierSeries, &FourierSeries)>,
) -> Result<Vec<C64>, SolverError> {
    let mut params = setup.params.clone();
    params.crack = Some(Crack { gear, tooth, loss });
    if let Some((pe, we)) = errors {
        params.pinion_errors = pe.clone();
        params.wheel_errors = we.clone();
        params.static_deflection_m = 0.0;
    }
    let pair = GearPair::new(params);
    let solver_revs = pair.revolutions_per_period();
    let steps = (CRACK_STEPS as f64 * solver_revs.max(1.0)).round() as usize;
    // one run: the accuracy at this resolution is checked against harmonic balance in the tests
    let steady = solver::steady::solve_once(&pair, steps)?;
    // harmonic k of the solver's period is period order k P / revs
    let per = setup.period_revs as f64 / solver_revs;
    let kmax = (setup.max_m() as f64 / per).ceil() as usize + 1;
    // velocity is state 1 directly (acceleration i k w times it); displacement state 0
    let component = usize::from(setup.quantity != Quantity::Displacement);
    let z = grid_coefficients(&pair, &steady, kmax, &[component]).ok_or(SolverError::Singular)?;
    let w = 2.0 * PI / pair.period_s();
    Ok(setup
        .lines
        .iter()
        .map(|l| {
            let k = l.m as f64 / per;
            let kr = k.round() as usize;
            if (k - kr as f64).abs() > 1e-9 || kr > kmax {
                return C64::new(0.0, 0.0); // not a harmonic of the solver's period
            }
            let v = 2.0 * z[0][kr];
            match setup.quantity {
                Quantity::Acceleration => v * C64::new(0.0, kr as f64 * w),
                Quantity::Displacement | Quantity::Velocity => v,
            }
        })
        .collect())
}

/// The error columns (as in [`Transfers::columns`]) of the pair with a crack, time-stepped: one solve per
/// column, in parallel.
///
/// # Errors
/// Solver failures.
pub fn cracked_columns(setup: &Setup, gear: Gear, tooth: usize, loss: f64) -> Result<Vec<Vec<C64>>, SolverError> {
    use rayon::prelude::*;
    let zero = FourierSeries::constant(0.0);
    let mut forcings: Vec<(FourierSeries, FourierSeries, bool)> = Vec::new();
    for i in 1..=setup.pinion_orders {
        forcings.push((unit(i, false), zero.clone(), false));
        forcings.push((unit(i, true), zero.clone(), true));
    }
    for j in 1..=setup.wheel_orders {
        forcings.push((zero.clone(), unit(j, false), false));
        forcings.push((zero.clone(), unit(j, true), true));
    }
    forcings
        .par_iter()
        .map(|(pe, we, sine)| {
            let col = cracked(setup, gear, tooth, loss, Some((pe, we)))?;
            Ok(if *sine { col.into_iter().map(|v| -v).collect() } else { col })
        })
        .collect()
}

/// A tooth-1 response moved to tooth `tooth` (1-based): delayed by (tooth - 1) mesh periods.
pub fn delayed(setup: &Setup, response: &[C64], tooth: usize) -> Vec<C64> {
    let pz = (setup.period_revs * setup.params.pinion_teeth) as f64;
    setup
        .lines
        .iter()
        .zip(response)
        .map(|(l, v)| v * C64::from_polar(1.0, -2.0 * PI * l.m as f64 * (tooth - 1) as f64 / pz))
        .collect()
}
