//! Signals and their analysis: spectra, windows, TSA, indicators, sidebands, comparison.
//! Knows nothing of ODEs or gears' equations of motion: it sees sample arrays, rates and orders.

pub mod spectrum;

/// Errors of the signal layer.
#[derive(Debug, thiserror::Error)]
pub enum SignalError {
    /// Input too short for the requested analysis.
    #[error("{what}: needs at least {needed} samples, got {got}")]
    TooShort {
        /// What needed them.
        what: String,
        /// Samples needed.
        needed: usize,
        /// Samples available.
        got: usize,
    },
    /// A parameter is out of range.
    #[error("{0}")]
    Invalid(String),
}

/// A uniformly sampled real signal.
#[derive(Clone, Debug, PartialEq)]
pub struct Signal {
    /// Samples in the signal's physical unit.
    pub samples: Vec<f64>,
    /// Sample rate in Hz.
    pub sample_rate_hz: f64,
}
