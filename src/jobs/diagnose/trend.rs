//! Trend over recordings given in time order: every scored indicator of every recording against the
//! baseline's band, as a table (CSV and JSON Lines, one row per recording, gear, channel and indicator) and
//! a chart with the first recording that leaves the band marked.

use crate::Error;
use crate::report::summary::{Diagnosis, Score};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// One row of the trend table.
#[derive(Clone, Debug, Serialize)]
pub struct TrendRow {
    /// 1-based position of the recording in the given order.
    pub index: usize,
    /// Recording file.
    pub file: String,
    /// The recording's verdict.
    pub state: String,
    /// The score (gear, channel, indicator, value, baseline band, spreads, limits).
    #[serde(flatten)]
    pub score: Score,
}

/// Rows of the trend of `done` (recordings in time order) against the baseline's scores.
pub fn rows(done: &[Diagnosis]) -> Vec<TrendRow> {
    done.iter()
        .enumerate()
        .flat_map(|(i, d)| {
            d.scores.iter().map(move |s| TrendRow {
                index: i + 1,
                file: d.file.clone(),
                state: d.verdict.state.name().into(),
                score: s.clone(),
            })
        })
        .collect()
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
}

/// Writes `dir/trend.csv`, `dir/trend.jsonl` and `dir/trend.png`.
///
/// # Errors
/// A file cannot be written.
pub fn write(dir: &Path, done: &[Diagnosis]) -> Result<Vec<PathBuf>, Error> {
    let rows = rows(done);
    let mut csv = String::from(
        "index,file,state,gear,channel,indicator,value,baseline_centre,baseline_min,baseline_max,spreads,suspect_at,faulty_at\n",
    );
    let mut jsonl = String::new();
    for r in &rows {
        let s = &r.score;
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            r.index,
            csv_field(&r.file),
            r.state,
            s.gear.name(),
            s.channel,
            s.indicator,
            s.value,
            s.baseline_centre,
            s.baseline_range[0],
            s.baseline_range[1],
            s.spreads,
            s.suspect_at,
            s.faulty_at
        ));
        jsonl.push_str(&crate::report::summary::to_json_line(r));
        jsonl.push('\n');
    }
    let (csv_path, jsonl_path, png) = (dir.join("trend.csv"), dir.join("trend.jsonl"), dir.join("trend.png"));
    crate::io::write_atomic(&csv_path, csv.as_bytes())?;
    crate::io::write_atomic(&jsonl_path, jsonl.as_bytes())?;
    crate::report::figures::trend(&png, done)?;
    Ok(vec![csv_path, jsonl_path, png])
}
