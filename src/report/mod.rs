//! Reports: JSON summaries (serde), PNG images (plotters) and one HTML page per report directory.

pub mod figures;
pub mod format;
pub mod html;
pub mod identify;
pub mod plot;
pub mod summary;

/// Errors of the report layer.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// Data cannot be drawn (empty, non-finite).
    #[error("cannot draw {what}: {why}")]
    BadData {
        /// Which image.
        what: String,
        /// What is wrong with the data.
        why: String,
    },
    /// Writing failed.
    #[error("{path}: {message}")]
    Write {
        /// Output path.
        path: String,
        /// What failed.
        message: String,
    },
}
