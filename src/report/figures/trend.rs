//! The trend over recordings: the scored indicators in spreads from the baseline, one panel per gear and
//! indicator family, with the suspect and faulty limits.

use super::*;

/// The indicator families of a trend: one panel each (their spreads differ by orders of magnitude).
pub(super) const TREND_FAMILIES: [(&str, &[Indicator]); 3] = [
    (
        "peakiness of the averaged signal",
        &[
            Indicator::Fm4,
            Indicator::M6a,
            Indicator::M8a,
            Indicator::Na4Star,
            Indicator::Na4,
            Indicator::Fm0,
            Indicator::Kurtosis,
            Indicator::CrestFactor,
        ],
    ),
    ("energy around the mesh", &[Indicator::Er, Indicator::Ser, Indicator::Sbr, Indicator::Si, Indicator::Slf]),
    ("spectral change from the baseline", &[Indicator::SpectralChange]),
];

/// Short names of recordings for an axis: the file stems without what they all share at the start and
/// the end, "#i" in front (the page's table lists the whole names).
pub fn short_names(files: &[String]) -> Vec<String> {
    let stems: Vec<String> =
        files.iter().map(|f| Path::new(f).file_stem().and_then(|s| s.to_str()).unwrap_or(f).to_string()).collect();
    let common = |rev: bool| -> usize {
        let chars = |s: &String| -> Vec<char> { if rev { s.chars().rev().collect() } else { s.chars().collect() } };
        let first = stems.first().map(chars).unwrap_or_default();
        stems.iter().map(|s| first.iter().zip(chars(s)).take_while(|(a, b)| **a == *b).count()).min().unwrap_or(0)
    };
    let (pre, post) = if stems.len() > 1 { (common(false), common(true)) } else { (0, 0) };
    stems
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let c: Vec<char> = s.chars().collect();
            let (a, b) = (pre.min(c.len()), c.len().saturating_sub(post).max(pre.min(c.len())));
            let part: String =
                c[a..b].iter().collect::<String>().trim_matches(|ch: char| ch == '-' || ch == '_').to_string();
            if part.is_empty() { format!("#{}", i + 1) } else { format!("#{} {part}", i + 1) }
        })
        .collect()
}

/// Trend chart: for each gear on the first channel and each indicator family, the scored indicators in
/// spreads from the baseline's centre over the recordings in time order (file names on the x axis), the
/// suspect and faulty limits, on a symmetric-log scale (a limit of 3.5 spreads and a crack at 200 both
/// readable).
///
/// # Errors
/// Nothing scored (no baseline), or the image cannot be written.
pub fn trend(png: &Path, done: &[Diagnosis]) -> Result<(), ReportError> {
    let charts = trend_charts(done)?;
    let h = TREND_PANEL_PX * charts.len() as u32;
    render_png(png, PAGE_WIDTH_PX, h, &charts)
}

/// Height of one trend panel, px.
pub const TREND_PANEL_PX: u32 = 470;

/// The panels of [`trend`].
///
/// # Errors
/// Nothing scored (no baseline).
pub fn trend_charts(done: &[Diagnosis]) -> Result<Vec<Chart>, ReportError> {
    let Some(ch) = done.first().and_then(|d| d.channels.first().copied()) else {
        return Err(ReportError::BadData { what: "trend".into(), why: "no recording".into() });
    };
    let mut gears: Vec<Shaft> = Vec::new();
    for s in done.iter().flat_map(|d| &d.scores) {
        if !gears.contains(&s.gear) {
            gears.push(s.gear);
        }
    }
    let files: Vec<String> = done.iter().map(|d| d.file.clone()).collect();
    // a recording not judged has no point: its tick says why the column is empty
    let ticks: Vec<(f64, String)> = short_names(&files)
        .into_iter()
        .enumerate()
        .map(|(i, n)| {
            let empty = done[i].verdict.state == crate::report::summary::VerdictState::NotJudged;
            ((i + 1) as f64, if empty { format!("{n} (not judged)") } else { n })
        })
        .collect();
    let last = done.len() as f64;
    let mut charts = Vec::new();
    for gear in gears {
        let scores = |i: usize| done[i].scores.iter().filter(move |s| s.gear == gear && s.channel == ch);
        let mut names: Vec<Indicator> = Vec::new();
        for i in 0..done.len() {
            for s in scores(i) {
                if !names.contains(&s.indicator) {
                    names.push(s.indicator);
                }
            }
        }
        for (family, keys) in TREND_FAMILIES {
            let members: Vec<&Indicator> = names
                .iter()
                .filter(|n| {
                    keys.contains(n) || (family.starts_with("peak") && !TREND_FAMILIES.iter().any(|f| f.1.contains(n)))
                })
                .collect();
            if members.is_empty() {
                continue;
            }
            // each indicator's deciding scores (not a near-zero SI, nor a recording that lost its
            // baseline's mesh), drawn as runs of consecutive recordings: no line crosses one without a
            // point (the first run carries the legend's name)
            let mut series: Vec<Series> = Vec::new();
            for (k, name) in members.iter().enumerate() {
                let points: Vec<(f64, f64)> = (0..done.len())
                    .filter_map(|i| {
                        scores(i).find(|s| &s.indicator == *name && s.decides).map(|s| ((i + 1) as f64, s.spreads))
                    })
                    .collect();
                let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
                for p in points {
                    match runs.last_mut() {
                        Some(run) if run.last().is_some_and(|q| p.0 - q.0 < 1.5) => run.push(p),
                        _ => runs.push(vec![p]),
                    }
                }
                for (r, run) in runs.into_iter().enumerate() {
                    series.push(Series {
                        name: if r == 0 { name.label().to_string() } else { String::new() },
                        points: run,
                        style: Style::LinePoints,
                        color: [0, 2, 4, 5, 7, 3, 6, 1][k % 8],
                    });
                }
            }
            let limit = |f: fn(&crate::report::summary::Score) -> f64| {
                (0..done.len()).flat_map(|i| scores(i).map(f)).fold(0.0, f64::max)
            };
            let (suspect, faulty) = (limit(|s| s.suspect_at), limit(|s| s.faulty_at));
            series.push(Series {
                name: format!("suspect limit ({} spreads)", sig(suspect, 3)),
                points: vec![(0.6, suspect), (last + 0.4, suspect)],
                style: Style::Line,
                color: 3,
            });
            series.push(Series {
                name: format!("faulty limit ({} spreads)", sig(faulty, 3)),
                points: vec![(0.6, faulty), (last + 0.4, faulty)],
                style: Style::Line,
                color: 1,
            });
            let hi = series.iter().flat_map(|s| &s.points).map(|p| p.1).fold(faulty, f64::max);
            let lo = series.iter().flat_map(|s| &s.points).map(|p| p.1).fold(0.0, f64::min);
            // the title names the indicators drawn (it once listed M8A and kurtosis, which are not scored)
            let drawn = if keys.len() > 1 {
                format!(" ({})", members.iter().map(|m| m.label()).collect::<Vec<_>>().join(", "))
            } else {
                String::new()
            };
            charts.push(Chart {
                title: format!("{gear}, channel {ch}: {family}{drawn}"),
                x_label: "recording [time order as given]".into(),
                y_label: "spreads from the baseline [-]".into(),
                series,
                x_range: Some((0.5, last + 0.5)),
                y_range: Some((lo * 1.5 - 0.5, hi * 2.0)),
                y_symlog: true,
                x_ticks: ticks.clone(),
                ..Default::default()
            });
        }
    }
    if charts.is_empty() {
        return Err(ReportError::BadData {
            what: "trend".into(),
            why: "no indicator was scored against a baseline".into(),
        });
    }
    Ok(charts)
}
