//! One self-contained HTML page per report directory (`DIR/index.html`): the verdict and its reasons first,
//! then the tables, then the images embedded as data URIs (no script, no network, no external file), with
//! print rules for A4. The PNGs stay next to it for people who paste them into their own documents.

mod diagnosis;
mod glossary;
mod simulate;

pub use diagnosis::{diagnosis_section, failures_section, trend_section, velocity_words};
pub use simulate::{bench_section, simulation_section, stability_section, sweep_section};

use super::ReportError;
use super::summary::VerdictState;
use glossary::glossary;
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
    glossary(&mut page);
    page.push_str("<footer>gearvib ");
    page.push_str(env!("CARGO_PKG_VERSION"));
    page.push_str(" &middot; images are also in this directory as PNG files</footer>\n</body></html>\n");
    let path = dir.join("index.html");
    crate::io::check_output(&path)
        .and_then(|_| crate::io::write_atomic(&path, page.as_bytes()))
        .map_err(|e| ReportError::Write { path: path.display().to_string(), message: e.to_string() })?;
    Ok(path)
}

/// The page's style. Sizes in points so that the printed page keeps them: the smallest text (tables,
/// notes, footer) is 9 pt; images span the text width, which on A4 is 182 mm, the width the images are
/// drawn for (see `plot::PAGE_WIDTH_PX`).
const STYLE: &str = "body{font-family:'DejaVu Sans',Arial,sans-serif;font-size:11pt;max-width:60em;margin:1.5em auto;padding:0 1em;color:#222;line-height:1.4}\
h1{font-size:16pt;border-bottom:2px solid #444;padding-bottom:.2em}h2{font-size:13.5pt;margin-top:1.6em;border-bottom:1px solid #aaa}\
.verdict{font-size:12.5pt;margin:.6em 0}.badge{display:inline-block;padding:.15em .6em;border-radius:.3em;color:#fff;font-weight:bold;margin-right:.5em}\
.healthy{background:#2e7d32}.suspect{background:#ef6c00}.faulty{background:#c62828}.not_judged{background:#616161}\
ul.reasons li{margin:.2em 0}.facts{color:#444;font-size:10pt}.facts p{margin:.15em 0}\
table{border-collapse:collapse;margin:0 0 .8em;font-size:9.5pt}p.caption{font-size:9.5pt;font-weight:bold;margin:.8em 0 .3em}\
th,td{border:1px solid #bbb;padding:.2em .5em;text-align:right}th{background:#eee}td:first-child,th:first-child,td.t,th.t{text-align:left}\
tr.hit td{background:#fde0dc;font-weight:bold}figure{margin:1em 0;page-break-inside:avoid;break-inside:avoid}img{display:block;max-width:100%;height:auto;border:1px solid #ddd}\
dl.glossary{font-size:9.5pt}dl.glossary dt{font-weight:bold;margin-top:.4em}dl.glossary dd{margin-left:1.5em}\
footer{margin-top:2em;font-size:9pt;color:#555}@page{size:A4;margin:14mm}\
@media print{body{max-width:none;margin:0;padding:0;font-size:10.5pt}img{width:100%;max-width:100%}h2{page-break-after:avoid;break-after:avoid}div.table{page-break-inside:avoid;break-inside:avoid}}";

/// The style class that colours a badge of `state` (one word: a state's name can hold a space, which
/// would make two classes, neither coloured, and leave the white word on white).
fn badge_class(state: VerdictState) -> &'static str {
    match state {
        VerdictState::NotJudged => "not_judged",
        VerdictState::Healthy => "healthy",
        VerdictState::Suspect => "suspect",
        VerdictState::Faulty => "faulty",
    }
}

fn section(page: &mut String, s: &Section) -> Result<(), ReportError> {
    let _ = writeln!(page, "<section><h2>{}</h2>", escape(&s.heading));
    if let Some(b) = &s.verdict {
        let _ = writeln!(
            page,
            "<p class=\"verdict\"><span class=\"badge {}\">{}</span>{}</p>",
            badge_class(b.state),
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
    // the caption above the table as a paragraph: a <caption> is held to the table's width, and over a
    // narrow table of five numbers it was wrapped into a column of four lines
    let _ = write!(page, "<div class=\"table\"><p class=\"caption\">{}</p><table><tr>", escape(&t.caption));
    // words read from the left, numbers line up on the right
    let numeric = |c: &str| c.starts_with(|ch: char| ch.is_ascii_digit() || ch == '-' || ch == '+' || ch == '.');
    for (i, h) in t.header.iter().enumerate() {
        // a header stands over its column as the column's cells do ("first reason" stood at the right end
        // of a column of sentences read from the left)
        let words = t.rows.iter().any(|(row, _)| row.get(i).is_some_and(|c| !numeric(c)));
        let class = if words { " class=\"t\"" } else { "" };
        let _ = write!(page, "<th{class}>{}</th>", escape(h));
    }
    page.push_str("</tr>\n");
    for (row, hit) in &t.rows {
        page.push_str(if *hit { "<tr class=\"hit\">" } else { "<tr>" });
        for c in row {
            let class = if numeric(c) { "" } else { " class=\"t\"" };
            let _ = write!(page, "<td{class}>{}</td>", escape(c));
        }
        page.push_str("</tr>\n");
    }
    page.push_str("</table></div>\n");
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

/// A number for a table cell: four significant digits ([`super::format::num`]).
pub fn cell(v: f64) -> String {
    super::format::num(v)
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

    /// Every state's badge carries one class that the page's style colours (a "not judged" badge once
    /// had the two classes "not" and "judged", no background, and its white word was invisible).
    #[test]
    fn every_badge_has_a_coloured_class() {
        for state in [VerdictState::NotJudged, VerdictState::Healthy, VerdictState::Suspect, VerdictState::Faulty] {
            let mut page = String::new();
            let badge = Badge { state, word: "W".into(), line: String::new() };
            section(&mut page, &Section { verdict: Some(badge), ..Default::default() }).unwrap();
            let class = page.split("class=\"badge ").nth(1).and_then(|r| r.split('"').next()).unwrap();
            assert!(!class.contains(' '), "{class}");
            assert!(STYLE.contains(&format!(".{class}{{background:")), "{class} has no colour");
        }
    }

    /// A column of words has its header on the left, as its cells; a column of numbers on the right.
    #[test]
    fn headers_stand_where_their_columns_read() {
        let t = Table {
            caption: "c".into(),
            header: vec!["#".into(), "value".into(), "first reason".into()],
            rows: vec![(vec!["#1".into(), "3.5".into(), "pinion (channel 1): NA4*".into()], false)],
        };
        let mut page = String::new();
        table(&mut page, &t);
        assert!(page.contains("<th class=\"t\">first reason</th>"), "{page}");
        assert!(page.contains("<th>value</th>"), "{page}");
        assert!(STYLE.contains("th.t{text-align:left}") || STYLE.contains(",th.t{text-align:left}"));
    }

    #[test]
    fn escape_handles_markup() {
        assert_eq!(escape("a<b & \"c\">"), "a&lt;b &amp; &quot;c&quot;&gt;");
    }
}
