//! Reports: JSON summaries (serde) and PNG images (plotters).

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

/// Writes the diagnosis images and JSON summary into `dir`; returns the files written.
///
/// # Errors
/// The directory cannot be created or a file cannot be written.
pub fn diagnose_report(d: &crate::diagnose::Diagnosis, dir: &std::path::Path) -> Result<Vec<String>, crate::Error> {
    std::fs::create_dir_all(dir).map_err(|e| crate::Error::Other(format!("{}: {e}", dir.display())))?;
    let stem = std::path::Path::new(&d.file).file_stem().and_then(|s| s.to_str()).unwrap_or("recording").to_string();
    let json = dir.join(format!("{stem}-diagnosis.json"));
    crate::io::write_atomic(&json, summary::to_json_line(d).as_bytes())?;
    Ok(vec![json.display().to_string()])
}
