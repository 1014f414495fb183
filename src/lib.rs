//! gearvib: steady-state vibration of gear pairs and other linear time-periodic (LTP) machine models,
//! Floquet stability, recording diagnosis and PNG reports.
//!
//! Flow: a JSON [`scene::Scene`] builds a [`model::PeriodicSystem`] (gear pair, forging press or generic
//! LTP system); [`solver::solve`] finds its periodic steady state and Floquet multipliers by the RK4
//! product method of Nguyen, Nguyen & Hoang (2009, Eqs 15-21); the `signal` layer analyses recorded or
//! simulated signals.
//!
//! ```
//! use gearvib::model::{catalog, PeriodicSystem};
//! use gearvib::solver::{solve, SolverOptions};
//! // m y'' + c y' + k y = cos(w t): the steady state is known in closed form
//! let sys = catalog::forced_oscillator(1.0, 0.2, 4.0, 1.0, 1.5);
//! let ss = solve(&sys, &SolverOptions { tolerance: 1e-9, ..Default::default() }).unwrap();
//! let (amp, lag) = catalog::forced_oscillator_response(1.0, 0.2, 4.0, 1.0, 1.5);
//! assert!((ss.x0[0] - amp * lag.cos()).abs() < 1e-8);
//! assert!(ss.floquet.stable);
//! ```

pub mod bench;
pub mod cli;
pub mod diagnose;
pub mod io;
pub mod model;
pub mod pipeline;
pub mod report;
pub mod scene;
pub mod signal;
pub mod solver;
pub mod sweep;
pub mod synth;

/// Top-level error: one variant per layer.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Scene reading or validation.
    #[error(transparent)]
    Scene(#[from] scene::SceneError),
    /// Solver failure.
    #[error(transparent)]
    Solver(#[from] solver::SolverError),
    /// Reading or writing data files.
    #[error(transparent)]
    Data(#[from] io::DataError),
    /// Signal analysis.
    #[error(transparent)]
    Signal(#[from] signal::SignalError),
    /// Anything else, with its message.
    #[error("{0}")]
    Other(String),
}
