//! gearvib: steady-state vibration of gear pairs and other linear time-periodic (LTP) machine models,
//! Floquet stability, recording diagnosis and PNG reports.
//!
//! # Flow
//! ```text
//! scene JSON --scene--> model (GearPair, press, SecondOrderSystem) --implements--> system::PeriodicSystem
//!     --solver::solve--> solver::SteadyState (periodic x(t), Floquet multipliers, error estimate)
//!     --jobs::simulate--> jobs::simulate::Simulation (orders, RMS) --io--> WAV/CSV + sidecar
//! WAV/CSV --io--> io::Recording --jobs::diagnose (signal: spectra, TSA, indicators)--> report::summary::Diagnosis
//! ```
//! Layers, with dependencies pointing one way: `cli` -> `jobs` -> {`report`, `scene`, `io`, `signal`,
//! `solver`, `model`} -> `system`. The solver never knows what a gear is ([`system::PeriodicSystem`] is all
//! it sees), `signal` knows no ODE, `jobs` never see the command line, and `report` draws what jobs hand
//! it. Principal types: [`scene::Scene`], [`system::PeriodicSystem`], [`solver::SteadyState`],
//! [`io::Recording`], [`report::summary::Diagnosis`].
//!
//! The method is the RK4 product method of Nguyen, Nguyen & Hoang (2009, Eqs 15-21), with harmonic
//! balance and a fourth-order Magnus scheme as faster or A-stable alternatives.
//!
//! ```
//! use gearvib::model::catalog;
//! use gearvib::solver::{solve, SolverOptions};
//! // m y'' + c y' + k y = cos(w t): the steady state is known in closed form
//! let sys = catalog::forced_oscillator(1.0, 0.2, 4.0, 1.0, 1.5);
//! let ss = solve(&sys, &SolverOptions { tolerance: 1e-9, ..Default::default() }).unwrap();
//! let (amp, lag) = catalog::forced_oscillator_response(1.0, 0.2, 4.0, 1.0, 1.5);
//! assert!((ss.x0[0] - amp * lag.cos()).abs() < 1e-8);
//! assert!(ss.floquet.stable);
//! ```

pub mod cli;
pub mod io;
pub mod jobs;
pub mod model;
pub mod report;
pub mod scene;
pub mod signal;
pub mod solver;
pub mod system;

/// Top-level error: one variant per layer, each wrapping that layer's enum. Its message is the layer's with
/// huge and tiny values written compactly ([`report::format::compact_numerals`]: 1e308, not a 1 and 308
/// zeros).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Scene reading or validation.
    #[error("{}", compact(&.0))]
    Scene(#[from] scene::SceneError),
    /// Solver failure.
    #[error("{}", compact(&.0))]
    Solver(#[from] solver::SolverError),
    /// Reading or writing data files.
    #[error("{}", compact(&.0))]
    Data(#[from] io::DataError),
    /// Signal analysis.
    #[error("{}", compact(&.0))]
    Signal(#[from] signal::SignalError),
    /// Drawing or writing reports.
    #[error("{}", compact(&.0))]
    Report(#[from] report::ReportError),
    /// A job (simulate, sweep, bench, diagnose) refused its input or could not finish.
    #[error("{}", compact(&.0))]
    Job(#[from] jobs::JobError),
    /// A command-line flag that is wrong in itself or does not fit the input.
    #[error("{}", compact(&.0))]
    Cli(#[from] cli::CliError),
}

/// A layer error's message with long numerals compacted.
fn compact(e: &dyn std::fmt::Display) -> String {
    report::format::compact_numerals(&e.to_string())
}
