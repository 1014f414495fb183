//! The files a job reads: directories expanded into their recordings, and the baseline's files as they
//! are used (each once, none that is also under test).

use super::{DiagnoseJob, bad};
use crate::Error;
use std::path::{Path, PathBuf};

/// The baseline files of a job as they are used ([`baseline_files`]).
pub(crate) struct BaselineFiles {
    /// Each once, in the order given.
    pub(crate) files: Vec<PathBuf>,
    /// Files given more than once (after the first).
    pub(crate) twice: Vec<PathBuf>,
    /// Files left out because they are also under test.
    pub(crate) under_test: Vec<PathBuf>,
}

impl BaselineFiles {
    /// What was done, one note per file, said with every verdict.
    pub(super) fn notes(&self) -> Vec<String> {
        let twice = self.twice.iter().map(|f| format!("{} is given twice as a baseline: it counts once", f.display()));
        let tested = self.under_test.iter().map(|f| {
            format!(
                "{} is left out of the baseline: it is also under test, and a recording against itself shows no change ({} healthy recording(s) remain)",
                f.display(),
                self.files.len()
            )
        });
        twice.chain(tested).collect()
    }
}

/// The baseline files of `job` (directories expanded), each once, less those that are also under test
/// while another remains: a baseline directory that holds the recording would count the recording among
/// its own healthy files, and a fault against itself shows no change.
///
/// # Errors
/// A baseline directory that cannot be read or holds no recording.
pub(crate) fn baseline_files(job: &DiagnoseJob) -> Result<BaselineFiles, Error> {
    let key = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    let mut seen = std::collections::HashSet::new();
    let (mut files, mut twice) = (Vec::new(), Vec::new());
    for f in expand_dirs(&job.baselines)? {
        if seen.insert(key(&f)) { files.push(f) } else { twice.push(f) }
    }
    // a recording directory that cannot be listed fails where the recordings are read
    let tested: std::collections::HashSet<PathBuf> =
        expand_dirs(&job.recordings).unwrap_or_default().iter().map(|r| key(r)).collect();
    let (under_test, others): (Vec<PathBuf>, Vec<PathBuf>) =
        files.iter().cloned().partition(|f| tested.contains(&key(f)));
    if others.is_empty() {
        return Ok(BaselineFiles { files, twice, under_test: Vec::new() });
    }
    Ok(BaselineFiles { files: others, twice, under_test })
}

/// Files of `paths`, directories replaced by their .wav and .csv files in name order.
///
/// # Errors
/// A directory that cannot be read or holds no recording.
pub(crate) fn expand_dirs(paths: &[PathBuf]) -> Result<Vec<PathBuf>, Error> {
    let mut out = Vec::new();
    for p in paths {
        if !p.is_dir() {
            out.push(p.clone());
            continue;
        }
        let mut files: Vec<PathBuf> = std::fs::read_dir(p)
            .map_err(|e| bad(p, format!("cannot read the directory: {e}")))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|f| {
                f.extension()
                    .and_then(|x| x.to_str())
                    .is_some_and(|x| x.eq_ignore_ascii_case("wav") || x.eq_ignore_ascii_case("csv"))
            })
            .collect();
        files.sort();
        if files.is_empty() {
            return Err(bad(p, "the directory holds no .wav or .csv recording"));
        }
        out.extend(files);
    }
    Ok(out)
}
