//! A second-order system whose coefficients are the sum of two periodic parts of two base frequencies
//! (two gear stages whose common period is huge): what the two-frequency harmonic balance
//! (`solver::quasi`) solves.

use super::FourierSeries;

/// M y'' + C y' + (K_a(w_a t) + K_b(w_b t)) y = d_a(w_a t) + d_b(w_b t) with constant M and C.
#[derive(Clone, Debug)]
pub struct TwoToneForm {
    /// Degrees of freedom N.
    pub dof: usize,
    /// Base angular frequencies w_a, w_b, rad/s (the `omega_rad_s` of the series below are ignored).
    pub omega_rad_s: [f64; 2],
    /// Row-major N x N constant mass matrix.
    pub mass: Vec<f64>,
    /// Row-major N x N constant damping matrix.
    pub damping: Vec<f64>,
    /// Row-major N x N stiffness entries of each tone (their means add).
    pub stiffness: [Vec<FourierSeries>; 2],
    /// N forcing entries of each tone (their means add).
    pub forcing: [Vec<FourierSeries>; 2],
}
