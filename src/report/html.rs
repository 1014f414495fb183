//! One self-contained HTML page per report directory (`DIR/index.html`): the verdict and its reasons first,
//! then the tables, then the images embedded as data URIs (no script, no network, no external file), with
//! print rules for A4. The PNGs stay next to it for people who paste them into their own documents.

use super::ReportError;
use super::summary::{BenchReport, Diagnosis, SimulateSummary, StabilitySummary, SweepSummary, VerdictState};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A table: header and rows of text cells; rows marked `true` are highlighted (a limit crossed).
#[derive(Clone, Debug, Default)]
pub struct Table {
    /// Caption above the table.
    pub caption: String,
    /// Column names.
    pub header: Vec<String>,
    /// Rows of cells, and whether each is highlighted.
    pub rows: Vec<(Vec<String>, bool)>,
}

/// A coloured word at the head of a section: the verdict of a diagnosis, or stable/unstable.
#[derive(Clone, Debug)]
pub struct Badge {
    /// Colour: green for healthy (stable), orange for suspect, red for faulty (unstable).
    pub state: VerdictState,
    /// The word on the badge.
    pub word: String,
    /// The text beside it.
    pub line: String,
}

/// One part of a page (one recording, one scene).
#[derive(Clone, Debug, Default)]
pub struct Section {
    /// Heading.
    pub heading: String,
    /// A badge (its colour from a verdict state, its word) and the line next to it.
    pub verdict: Option<Badge>,
    /// Bullet list under the verdict (its reasons).
    pub reasons: Vec<String>,
    /// Plain lines of facts (speed, tracking, warnings).
    pub facts: Vec<String>,
    /// Tables.
    pub tables: Vec<Table>,
    /// PNG files to embed, in order.
    pub images: Vec<PathBuf>,
}

/// Writes `dir/index.html` with `title` and `sections`, embedding every image.
///
/// # Errors
/// An image cannot be read, or the page cannot be written.
pub fn write(dir: &Path, title: &str, sections: &[Section]) -> Result<PathBuf, ReportError> {
    let mut page = String::new();
    let _ = write!(
        page,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title><style>{STYLE}</style></head><body>\n<h1>{}</h1>\n",
        escape(title),
        escape(title)
    );
    for s in sections {
        section(&mut page, s)?;
    }
    page.push_str("<footer>gearvib ");
    page.push_str(env!("CARGO_PKG_VERSION"));
    page.push_str(" &middot; images are also in this directory as PNG files</footer>\n</body></html>\n");
    let path = dir.join("index.html");
    crate::io::check_output(&path)
        .and_then(|_| crate::io::write_atomic(&path, page.as_bytes()))
        .map_err(|e| ReportError::Write { path: path.display().to_string(), message: e.to_string() })?;
    Ok(path)
}

const STYLE: &str = "body{font-family:'DejaVu Sans',Arial,sans-serif;max-width:60em;margin:1.5em auto;padding:0 1em;color:#222;line-height:1.4}\
h1{font-size:1.5em;border-bottom:2px solid #444;padding-bottom:.2em}h2{font-size:1.25em;margin-top:1.6em;border-bottom:1px solid #aaa}\
.verdict{font-size:1.15em;margin:.6em 0}.badge{display:inline-block;padding:.15em .6em;border-radius:.3em;color:#fff;font-weight:bold;margin-right:.5em}\
.healthy{background:#2e7d32}.suspect{background:#ef6c00}.faulty{background:#c62828}\
ul.reasons li{margin:.2em 0}.facts{color:#444;font-size:.92em}.facts p{margin:.15em 0}\
table{border-collapse:collapse;margin:.8em 0;font-size:.85em}caption{text-align:left;font-weight:bold;padding:.3em 0}\
th,td{border:1px solid #bbb;padding:.2em .5em;text-align:right}th{background:#eee}td:first-child,th:first-child{text-align:left}\
tr.hit td{background:#fde0dc;font-weight:bold}figure{margin:1em 0;page-break-inside:avoid;break-inside:avoid}img{max-width:100%;height:auto;border:1px solid #ddd}\
footer{margin-top:2em;font-size:.8em;color:#777}@page{size:A4;margin:14mm}@media print{body{max-width:none;margin:0}h2{page-break-after:avoid}table{page-break-inside:avoid}}";

fn section(page: &mut String, s: &Section) -> Result<(), ReportError> {
    let _ = writeln!(page, "<section><h2>{}</h2>", escape(&s.heading));
    if let Some(b) = &s.verdict {
        let _ = writeln!(
            page,
            "<p class=\"verdict\"><span class=\"badge {}\">{}</span>{}</p>",
            b.state.name(),
            escape(&b.word),
            escape(&b.line)
        );
    }
    if !s.reasons.is_empty() {
        page.push_str("<ul class=\"reasons\">");
        for r in &s.reasons {
            let _ = write!(page, "<li>{}</li>", escape(r));
        }
        page.push_str("</ul>\n");
    }
    if !s.facts.is_empty() {
        page.push_str("<div class=\"facts\">");
        for f in &s.facts {
            let _ = write!(page, "<p>{}</p>", escape(f));
        }
        page.push_str("</div>\n");
    }
    for t in &s.tables {
        table(page, t);
    }
    for img in &s.images {
        let bytes = std::fs::read(img).map_err(|e| ReportError::Write {
            path: img.display().to_string(),
            message: format!("cannot read: {e}"),
        })?;
        let name = img.file_name().and_then(|n| n.to_str()).unwrap_or("image");
        let _ = writeln!(
            page,
            "<figure><img alt=\"{}\" src=\"data:image/png;base64,{}\"></figure>",
            escape(name),
            base64(&bytes)
        );
    }
    page.push_str("</section>\n");
    Ok(())
}

fn table(page: &mut String, t: &Table) {
    let _ = write!(page, "<table><caption>{}</caption><tr>", escape(&t.caption));
    for h in &t.header {
        let _ = write!(page, "<th>{}</th>", escape(h));
    }
    page.push_str("</tr>\n");
    for (row, hit) in &t.rows {
        page.push_str(if *hit { "<tr class=\"hit\">" } else { "<tr>" });
        for c in row {
            let _ = write!(page, "<td>{}</td>", escape(c));
        }
        page.push_str("</tr>\n");
    }
    page.push_str("</table>\n");
}

/// HTML text with &, <, >, " escaped.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// Standard base64 (RFC 4648, with padding).
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for (i, shift) in [18, 12, 6, 0].into_iter().enumerate() {
            if i <= chunk.len() {
                out.push(ALPHABET[((n >> shift) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A number for a table cell: four significant digits, scientific notation when very small or large.
pub fn cell(v: f64) -> String {
    if !v.is_finite() {
        "-".into()
    } else if v != 0.0 && (v.abs() < 1e-3 || v.abs() >= 1e5) {
        format!("{v:.3e}")
    } else {
        format!("{v:.4}")
    }
}

/// The section of one diagnosis: verdict and reasons, speed and tracking, warnings, the indicator table
/// against the baseline's band (or the indicators without one), the images.
pub fn diagnosis_section(d: &Diagnosis, images: &[PathBuf]) -> Section {
    let unit = if d.unit.is_empty() { "unit of the file" } else { d.unit.as_str() };
    let mut facts = vec![match d.sample_rate_hz {
        Some(fs) => format!("{} samples at {fs} Hz, channels {:?}, amplitudes in {unit}", d.samples, d.channels),
        None => format!("{} samples, sample rate unknown (orders only), channels {:?}", d.samples, d.channels),
    }];
    let shafts: Vec<String> = d
        .shaft_hz
        .entries()
        .into_iter()
        .map(|(k, v)| {
            v.map_or(format!("{k}: period {:.2} samples", d.shaft_period_samples), |f| format!("{k} {f:.4} Hz"))
        })
        .collect();
    facts.push(match (d.speed_given_hz, d.speed_deviation_percent) {
        (Some(g), Some(off)) => {
            format!("Speed: {} (measured; the given {g:.4} Hz is {off:+.2} % from it).", shafts.join(", "))
        }
        _ => format!("Speed: {} ({}).", shafts.join(", "), d.speed_source),
    });
    let p = &d.speed_profile;
    facts.push(format!(
        "Tracking: {}{}; change over the recording {:+.3} %.",
        p.tracking,
        match (p.min_hz, p.max_hz) {
            (Some(lo), Some(hi)) => format!(", revolutions from {lo:.4} to {hi:.4} Hz"),
            _ => String::new(),
        },
        p.change_percent
    ));
    facts.push(format!("Mesh: order {} ({}).", d.mesh_order, d.teeth_source));
    if let Some(g) = &d.other_gear {
        facts.push(format!(
            "Meshing gear: {} teeth (estimated from its sidebands, confidence {:.2}).",
            g.teeth, g.confidence
        ));
    }
    facts.extend(d.warnings.iter().map(|w| format!("Warning: {w}")));
    let mut tables = Vec::new();
    if d.scores.is_empty() {
        let keys = ["fm0", "fm4", "m6a", "na4", "er", "si", "ser", "kurtosis", "crest_factor"];
        let mut t = Table {
            caption: "Condition indicators (no baseline: absolute limits FM4 4.5/6, M6A 40/80, NA4 4.5/6)".into(),
            header: ["gear", "ch"].iter().chain(keys.iter()).map(|s| s.to_uppercase()).collect(),
            rows: Vec::new(),
        };
        for g in &d.gears {
            let mut row = vec![g.gear.name().to_string(), g.channel.to_string()];
            row.extend(keys.iter().map(|k| cell(g.indicators.get(*k).copied().unwrap_or(f64::NAN))));
            t.rows.push((row, false));
        }
        tables.push(t);
    } else {
        let mut t = Table {
            caption: "Indicators against the statistical baseline (median of this recording's blocks; spreads from the baseline's centre; limits for false-alarm rates 1e-3 and 1e-6)".into(),
            header: ["gear", "ch", "indicator", "value", "baseline centre", "baseline range", "spreads", "suspect at", "faulty at"]
                .iter()
                .map(|s| s.to_string())
                .collect(),
            rows: Vec::new(),
        };
        for s in &d.scores {
            let hit = s.decides && s.spreads >= s.suspect_at;
            t.rows.push((
                vec![
                    s.gear.name().to_string(),
                    s.channel.to_string(),
                    indicator_name(&s.indicator),
                    cell(s.value),
                    cell(s.baseline_centre),
                    format!("{} .. {}", cell(s.baseline_range[0]), cell(s.baseline_range[1])),
                    if s.decides { format!("{:.1}", s.spreads) } else { "near zero".into() },
                    format!("{:.1}", s.suspect_at),
                    format!("{:.1}", s.faulty_at),
                ],
                hit,
            ));
        }
        tables.push(t);
    }
    Section {
        heading: Path::new(&d.file).file_name().and_then(|n| n.to_str()).unwrap_or(&d.file).to_string(),
        verdict: Some(Badge {
            state: d.verdict.state,
            word: d.verdict.state.name().to_uppercase(),
            line: format!("gear: {}", d.verdict.place()),
        }),
        reasons: d
            .verdict
            .reasons
            .iter()
            .cloned()
            .chain(d.verdict.cross_talk.iter().map(|c| format!("Cross-talk: {c}")))
            .collect(),
        facts,
        tables,
        images: images.to_vec(),
    }
}

/// How an indicator key reads in a table: `na4_star` is NA4*, `spectral_change` "spectral change".
fn indicator_name(key: &str) -> String {
    match key {
        "na4_star" => "NA4*".into(),
        "spectral_change" => "spectral change".into(),
        k => k.to_uppercase(),
    }
}

/// The section of a simulation: stability, solver and error, the strongest orders, the images.
pub fn simulation_section(s: &SimulateSummary, images: &[PathBuf]) -> Section {
    let mut sec = stability_section(&s.stability, images);
    sec.facts.push(format!(
        "{} RMS {} {}, peak to peak {} {}; orders of the {} ({:.4} Hz).",
        s.quantity,
        cell(s.rms),
        s.unit,
        cell(s.peak_to_peak),
        s.unit,
        s.base,
        s.base_hz
    ));
    let mut lines = s.orders.clone();
    lines.sort_by(|a, b| b.amplitude.total_cmp(&a.amplitude));
    sec.tables.push(Table {
        caption: format!("Strongest orders ({})", s.unit),
        header: vec!["order".into(), "frequency [Hz]".into(), format!("amplitude [{}]", s.unit)],
        rows: lines
            .iter()
            .take(12)
            .map(|o| (vec![format!("{}", o.order), format!("{:.2}", o.frequency_hz), cell(o.amplitude)], false))
            .collect(),
    });
    sec
}

/// The section of a Floquet analysis.
pub fn stability_section(s: &StabilitySummary, images: &[PathBuf]) -> Section {
    let state = if s.stable { VerdictState::Healthy } else { VerdictState::Faulty };
    Section {
        heading: s.scene.clone(),
        verdict: Some(Badge {
            state,
            word: if s.stable { "STABLE" } else { "UNSTABLE" }.into(),
            line: format!("largest |multiplier| {:.6}", s.rho_max),
        }),
        reasons: Vec::new(),
        facts: vec![
            format!(
                "Period {} s; solver {} ({}), {} {}.",
                cell(s.period_s),
                s.method,
                s.method_reason,
                s.steps,
                s.resolution_unit
            ),
            format!("Estimated error {} against the tolerance {}.", cell(s.error_estimate), cell(s.tolerance)),
        ],
        tables: Vec::new(),
        images: images.to_vec(),
    }
}

/// The section of a sweep: how many points are stable, unstable, untrusted or failed, the images.
pub fn sweep_section(s: &SweepSummary, images: &[PathBuf]) -> Section {
    let count = |f: &dyn Fn(&super::summary::SweepPoint) -> bool| s.points.iter().filter(|p| f(p)).count();
    let unstable = count(&|p| p.stable == Some(false));
    Section {
        heading: format!("{}: sweep of {}", s.scene, s.param),
        verdict: Some(Badge {
            state: if unstable > 0 { VerdictState::Suspect } else { VerdictState::Healthy },
            word: if unstable > 0 { "UNSTABLE POINTS" } else { "ALL STABLE" }.into(),
            line: format!("{unstable} of {} points unstable", s.points.len()),
        }),
        reasons: Vec::new(),
        facts: vec![format!(
            "{} points; {} untrusted (error above the tolerance); {} failed.",
            s.points.len(),
            count(&|p| !p.trusted && p.error.is_none()),
            count(&|p| p.error.is_some())
        )],
        tables: Vec::new(),
        images: images.to_vec(),
    }
}

/// The section of a benchmark: every method's time and error against the reference, the images.
pub fn bench_section(b: &BenchReport, images: &[PathBuf]) -> Section {
    let table = Table {
        caption: "Time (median, whole solve) against error (relative to the converged reference)".into(),
        header: vec!["scene".into(), "method".into(), "resolution".into(), "time [s]".into(), "error".into()],
        rows: b
            .results
            .iter()
            .map(|r| {
                (
                    vec![r.scene.clone(), r.method.clone(), r.resolution.to_string(), cell(r.time_s), cell(r.error)],
                    false,
                )
            })
            .collect(),
    };
    Section {
        heading: "Speed against error".into(),
        verdict: None,
        reasons: Vec::new(),
        facts: Vec::new(),
        tables: vec![table],
        images: images.to_vec(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        // RFC 4648 section 10 test vectors
        for (input, want) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(input.as_bytes()), want);
        }
    }

    #[test]
    fn escape_handles_markup() {
        assert_eq!(escape("a<b & \"c\">"), "a&lt;b &amp; &quot;c&quot;&gt;");
    }
}
