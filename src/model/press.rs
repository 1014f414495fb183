//! Cam mechanism of the transport manipulator of a forging press (Eqs 22-35).
//!
//! ```text
//! q = [q1, q2]: q1 torsion of the flexible transmission (rad), q2 follower deflection (m)
//! M = [ I1 + m2 U'^2    m2 U' ;  m2 U'   m2 ]
//! C = [ c1 + 2 m2 W U' U''   0 ;  2 m2 W U''   c2 ]
//! K = [ k1 + F U'' + m2 W^2 (U' U''' + U''^2)   0 ;  m2 W^2 U'''   k2 ]
//! d = [ -F U' - m2 W^2 U' U'' ;  -F - m2 W^2 U'' ]                          (Eq 34)
//! U'(phi) = sum_k a_k cos k phi + b_k sin k phi,  phi = W t                 (Eq 35)
//! ```
//! U'' and U''' are derivatives with respect to phi (not t). Products of series are formed exactly, so the
//! press is a [`SecondOrderSystem`] with Fourier entries of period 2 pi / W.

use super::SecondOrderSystem;
use crate::system::{Coefficient, FourierSeries};
use std::f64::consts::PI;

/// Press parameters (SI; torsional k1 in N m/rad and c1 in N m s/rad).
#[derive(Clone, Debug, PartialEq)]
pub struct PressParams {
    /// Input speed n in rpm (W = 2 pi n / 60).
    pub speed_rpm: f64,
    /// Torsional stiffness k1 in N m/rad.
    pub k1_n_m_per_rad: f64,
    /// Follower stiffness k2 in N/m.
    pub k2_n_per_m: f64,
    /// Torsional damping c1 in N m s/rad.
    pub c1_n_m_s_per_rad: f64,
    /// Follower damping c2 in N s/m.
    pub c2_n_s_per_m: f64,
    /// Cam-shaft inertia I1 in kg m^2.
    pub inertia_kg_m2: f64,
    /// Follower mass m2 in kg.
    pub mass_kg: f64,
    /// Constant external load F in N.
    pub load_n: f64,
    /// a_k of U'(phi) in m/rad, k = 1..
    pub cam_cos_m_per_rad: Vec<f64>,
    /// b_k of U'(phi) in m/rad, k = 1..
    pub cam_sin_m_per_rad: Vec<f64>,
}

impl PressParams {
    /// Input angular speed W in rad/s.
    pub fn omega_rad_s(&self) -> f64 {
        self.speed_rpm / 60.0 * 2.0 * PI
    }

    /// Builds Eq 34 as a second-order system of period 2 pi / W.
    ///
    /// # Errors
    /// A singular mass matrix (only possible with m2 or I1 not positive).
    pub fn system(&self) -> Result<SecondOrderSystem, super::second_order::BuildError> {
        let w = self.omega_rad_s();
        let u1 = FourierSeries::new(w, 0.0, self.cam_cos_m_per_rad.clone(), self.cam_sin_m_per_rad.clone());
        let u2 = u1.derivative().scaled(1.0 / w);
        let u3 = u2.derivative().scaled(1.0 / w);
        let (m2, f) = (self.mass_kg, self.load_n);
        let c = |s: FourierSeries| Coefficient::Fourier(s);
        let k = FourierSeries::constant;
        let mass = vec![
            c(u1.times(&u1).scaled(m2).plus(&k(self.inertia_kg_m2))),
            c(u1.scaled(m2)),
            c(u1.scaled(m2)),
            c(k(m2)),
        ];
        let damping = vec![
            c(u1.times(&u2).scaled(2.0 * m2 * w).plus(&k(self.c1_n_m_s_per_rad))),
            c(k(0.0)),
            c(u2.scaled(2.0 * m2 * w)),
            c(k(self.c2_n_s_per_m)),
        ];
        let stiffness = vec![
            c(u2.scaled(f).plus(&u1.times(&u3).plus(&u2.times(&u2)).scaled(m2 * w * w)).plus(&k(self.k1_n_m_per_rad))),
            c(k(0.0)),
            c(u3.scaled(m2 * w * w)),
            c(k(self.k2_n_per_m)),
        ];
        let forcing =
            vec![c(u1.scaled(-f).plus(&u1.times(&u2).scaled(-m2 * w * w))), c(u2.scaled(-m2 * w * w).plus(&k(-f)))];
        SecondOrderSystem::new(2.0 * PI / w, mass, damping, stiffness, forcing)
    }
}
