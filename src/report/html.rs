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
table{border-collapse:collapse;margin:.8em 0;font-size:9.5pt}caption{text-align:left;font-weight:bold;padding:.3em 0}\
th,td{border:1px solid #bbb;padding:.2em .5em;text-align:right}th{background:#eee}td:first-child,th:first-child,td.t{text-align:left}\
tr.hit td{background:#fde0dc;font-weight:bold}figure{margin:1em 0;page-break-inside:avoid;break-inside:avoid}img{display:block;max-width:100%;height:auto;border:1px solid #ddd}\
dl.glossary{font-size:9.5pt}dl.glossary dt{font-weight:bold;margin-top:.4em}dl.glossary dd{margin-left:1.5em}\
footer{margin-top:2em;font-size:9pt;color:#555}@page{size:A4;margin:14mm}\
@media print{body{max-width:none;margin:0;padding:0;font-size:10.5pt}img{width:100%;max-width:100%}h2{page-break-after:avoid;break-after:avoid}table{page-break-inside:avoid}}";

/// The terms a page may use, each explained once in the glossary at its end: (term as shown, the words
/// that reveal it on the page, explanation). Definitions as in `signal::indicators` (after Lebold et al.
/// 2000, Decker 2002, Zakrajsek et al. 1993; see the project's diagnostics reference).
const GLOSSARY: &[(&str, &[&str], &str)] = &[
    (
        "TSA (time-synchronous average)",
        &["TSA", "time-synchronous"],
        "the signal resampled on the tracked angle of one shaft and averaged over its revolutions: what does not repeat with that shaft (noise, the other gear) averages out.",
    ),
    (
        "residual signal",
        &["residual"],
        "the TSA without the shaft orders 1-2 and the mesh harmonics: what is left shows a local fault on one tooth.",
    ),
    (
        "difference signal",
        &["difference"],
        "the residual also without the first-order sidebands of the mesh harmonics; FM4, M6A and M8A are computed on it.",
    ),
    (
        "FM0",
        &["FM0"],
        "peak-to-peak of the TSA divided by the sum of the mesh-harmonic amplitudes: rises with a broken tooth or heavy wear.",
    ),
    (
        "FM4",
        &["FM4"],
        "kurtosis (normalised 4th moment) of the difference signal: about 3 for a healthy gear, above 3 when one or a few teeth are damaged.",
    ),
    (
        "M6A, M8A",
        &["M6A", "M8A"],
        "6th and 8th normalised moments of the difference signal (15 and 105 for Gaussian noise): more sensitive to single peaks than FM4.",
    ),
    (
        "NA4",
        &["NA4"],
        "kurtosis of the residual signal normalised by the mean variance of the residuals of all recordings so far in time order: about 3 when healthy, and it keeps growing as damage spreads.",
    ),
    (
        "NA4*",
        &["NA4*"],
        "NA4 normalised by the residual variance of the healthy baseline only (Decker): a different number from NA4 when a baseline is given.",
    ),
    (
        "ER (energy ratio)",
        &["ER "],
        "RMS of the difference signal over RMS of the regular (mesh) signal: rises with wear spread over many teeth.",
    ),
    (
        "SI, SLF, SER",
        &["SI", "SLF", "SER"],
        "sideband indicators around the first mesh harmonic: SI the mean of the first sideband pair, SLF that pair over the TSA RMS, SER the six sideband pairs over the mesh line (above 1: the sidebands outweigh the mesh).",
    ),
    (
        "kurtosis, crest factor, RMS",
        &["kurtosis", "crest", "RMS"],
        "4th normalised moment (3 for Gaussian noise), peak over RMS, and root mean square of the signal named.",
    ),
    ("spectral change", &["spectral change"], "the distance in dB of a block's order spectrum from the baseline's."),
    (
        "local change",
        &["local change"],
        "the gear's residual signal less the baseline's mean residual (shifted to the same angle and scaled to the same load): the energy of that difference over the tooth pitch where it is largest, over the median pitch's. Healthy recordings differ by 1.5-4; a crack, spall or broken tooth raises it at its tooth. It counts from 2.5 times what the baseline's own files show among themselves.",
    ),
    (
        "spreads",
        &["spreads"],
        "how far an indicator lies from the healthy baseline's centre, in units of the baseline's spread (1.4826 times the median absolute deviation of its blocks, on a logarithmic scale for ratio indicators): a robust z-score.",
    ),
    (
        "suspect and faulty limits",
        &["suspect at", "suspect limit", "faulty at", "faulty limit"],
        "Student-t prediction limits in spreads for a false-alarm rate of 1e-3 (suspect) and 1e-6 (faulty) per indicator, given the number of baseline blocks.",
    ),
    (
        "baseline",
        &["baseline"],
        "healthy recordings of the same machine, cut into blocks of whole revolutions; their indicators' spread sets the limits.",
    ),
    (
        "mesh harmonic, order",
        &["mesh", "order"],
        "the tooth-mesh frequency (teeth times shaft speed) and its multiples; an order is a multiple of a shaft's rotation, so lines stay at the same order when the speed changes.",
    ),
    (
        "sideband",
        &["sideband"],
        "a line beside a mesh harmonic at a multiple of a shaft's speed: modulation by that shaft (eccentricity, a cracked or pitted tooth). Marked only when 12 dB over the local noise floor.",
    ),
    (
        "kurtogram, spectral kurtosis",
        &["kurtogram", "spectral kurtosis"],
        "the kurtosis of the signal filtered in bands of halving widths (levels): impulsive bands (a fault's impacts) stand out; 0 for Gaussian noise.",
    ),
    (
        "envelope spectrum",
        &["envelope"],
        "the spectrum of the squared envelope of one band, in orders of the tracked shaft: a local fault gives a line at its shaft's order.",
    ),
    (
        "cepstrum, rahmonic",
        &["cepstrum"],
        "the inverse transform of the log power spectrum; a family of equally spaced lines (one shaft's sidebands) becomes one peak and its rahmonics at the shaft's period.",
    ),
    (
        "rpm-order map",
        &["order map", "rpm-order"],
        "order spectra of successive groups of revolutions against their speed: lines of the machine stay vertical, a resonance crosses them.",
    ),
    (
        "Floquet multipliers, |rho|max",
        &["multiplier"],
        "eigenvalues of the monodromy matrix of the periodic system; stable when all lie inside the unit circle (|rho|max < 1).",
    ),
    (
        "chi2/dof",
        &["chi2"],
        "the fit's weighted squared residual per degree of freedom: about 1 when the model explains the lines to their noise.",
    ),
    (
        "velocity RMS, ISO zones",
        &["velocity RMS"],
        "the RMS vibration velocity over 10-1000 Hz in mm/s; the zones A (new), B (long-term), C (limited time), D (damaging) of ISO 10816-3 / 20816-3 for the machine class given.",
    ),
];

/// Whether `needle` occurs in `text` as a whole word (acronyms must not match inside other words).
fn has_word(text: &str, needle: &str) -> bool {
    let word = |c: Option<char>| c.is_some_and(|c| c.is_alphanumeric());
    text.match_indices(needle).any(|(i, _)| {
        let before = text[..i].chars().next_back();
        let after = text[i + needle.len()..].chars().next();
        // lower-case words may take an ending ("sidebands"); acronyms may not ("SI" is not in "SIDE")
        !word(before) && (!word(after) || needle.chars().any(char::is_lowercase))
    })
}

/// The glossary of the terms `page` uses, appended to it.
fn glossary(page: &mut String) {
    // the page's words, without the embedded images
    let text: String = page.split("data:image/png;base64,").map(|p| p.split_once('"').map_or(p, |x| x.1)).collect();
    let used: Vec<_> = GLOSSARY.iter().filter(|(_, needles, _)| needles.iter().any(|n| has_word(&text, n))).collect();
    if used.is_empty() {
        return;
    }
    page.push_str("<section><h2>Glossary</h2><dl class=\"glossary\">");
    for (term, _, meaning) in used {
        let _ = write!(page, "<dt>{}</dt><dd>{}</dd>", escape(term), escape(meaning));
    }
    page.push_str("</dl></section>\n");
}

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
            // words read from the left, numbers line up on the right
            let numeric = c.starts_with(|ch: char| ch.is_ascii_digit() || ch == '-' || ch == '+' || ch == '.');
            let class = if numeric { "" } else { " class=\"t\"" };
            let _ = write!(page, "<td{class}>{}</td>", escape(c));
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

/// A number for a table cell: four significant digits ([`super::format::num`]).
pub fn cell(v: f64) -> String {
    super::format::num(v)
}

/// Channel numbers as a list: "1, 2".
fn channel_list(c: &[usize]) -> String {
    c.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")
}

/// The section of one diagnosis: verdict and reasons, speed and tracking, warnings, the indicator table
/// against the baseline's band (or the indicators without one), the images.
pub fn diagnosis_section(
    d: &Diagnosis,
    images: &[PathBuf],
    iso_class: Option<crate::signal::velocity::MachineClass>,
) -> Section {
    let unit = super::figures::unit_or(&d.unit);
    let mut facts = vec![match d.sample_rate_hz {
        Some(fs) => format!(
            "{} samples at {} Hz, channel(s) {}; amplitudes in {unit}.",
            d.samples,
            cell(fs),
            channel_list(&d.channels)
        ),
        None => format!(
            "{} samples, sample rate unknown: everything in orders of the shaft, no value in Hz; channel(s) {}.",
            d.samples,
            channel_list(&d.channels)
        ),
    }];
    let shafts: Vec<String> = d
        .shaft_hz
        .entries()
        .into_iter()
        .map(|(k, v)| {
            let k = if k == "estimated_shaft" { "shaft of the estimated period" } else { k };
            v.map_or(format!("{k}: one revolution every {} samples", cell(d.shaft_period_samples)), |f| {
                format!("{k} {} Hz ({} rpm)", cell(f), cell(60.0 * f))
            })
        })
        .collect();
    facts.push(match (d.speed_given_hz, d.speed_deviation_percent) {
        (Some(g), Some(off)) => format!(
            "Speed: {} (measured on the recording; the given {g:.4} Hz is {off:+.2} % from it).",
            shafts.join(", ")
        ),
        _ => format!("Speed: {}; {}.", shafts.join(", "), speed_words(d.speed_source)),
    });
    let p = &d.speed_profile;
    facts.push(format!(
        "Shaft angle tracked by {}{}; speed change over the recording {} %.",
        p.tracking,
        match (p.min_hz, p.max_hz) {
            (Some(lo), Some(hi)) => format!(", revolutions from {} to {} Hz", cell(lo), cell(hi)),
            _ => String::new(),
        },
        cell(p.change_percent)
    ));
    facts.push(format!("Mesh: order {} of the reference shaft (teeth {}).", d.mesh_order, d.teeth_source));
    facts.push(velocity_words(d, iso_class));
    if let Some(g) = &d.other_gear {
        facts.push(format!(
            "Meshing gear: {} teeth (estimated from its sidebands, confidence {}).",
            g.teeth,
            super::format::sig(g.confidence, 2)
        ));
    }
    facts.extend(d.warnings.iter().map(|w| format!("Warning: {w}")));
    let mut tables = Vec::new();
    if d.scores.is_empty() {
        let keys = ["fm0", "fm4", "m6a", "na4", "er", "si", "ser", "kurtosis", "crest_factor"];
        let mut t = Table {
            caption: "Condition indicators (no baseline: absolute limits FM4 4.5/6, M6A 40/80, NA4 4.5/6)".into(),
            header: ["gear".to_string(), "channel".to_string()]
                .into_iter()
                .chain(keys.iter().map(|k| super::figures::indicator_label(k)))
                .collect(),
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
            header: ["gear", "channel", "indicator", "value", "baseline centre", "baseline range", "spreads", "suspect at", "faulty at"]
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
                    super::figures::indicator_label(&s.indicator),
                    cell(s.value),
                    cell(s.baseline_centre),
                    format!("{} to {}", cell(s.baseline_range[0]), cell(s.baseline_range[1])),
                    if s.decides { super::format::sig(s.spreads, 3) } else { "near zero".into() },
                    super::format::sig(s.suspect_at, 3),
                    super::format::sig(s.faulty_at, 3),
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
            word: d.verdict.state.name().replace('_', " ").to_uppercase(),
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

/// Lower edge, upper edge of the overall-velocity band, Hz (ISO 10816-3 for machines above 600 rpm).
const VELOCITY_BAND_HZ: (f64, f64) = (10.0, 1000.0);

/// The overall velocity RMS of the deciding channel over 10-1000 Hz in mm/s, and with a machine class its
/// ISO 10816-3 zone and boundaries; or why it could not be computed.
pub fn velocity_words(d: &Diagnosis, iso_class: Option<crate::signal::velocity::MachineClass>) -> String {
    use crate::signal::velocity::{measured_from_unit, velocity_rms_mm_s};
    let (lo, hi) = VELOCITY_BAND_HZ;
    let why_not = |why: String| format!("Overall velocity RMS over {lo}-{hi} Hz not computed: {why}.");
    let Some((ch, spectrum)) = d.spectra().first() else {
        return why_not("the sample rate is unknown".into());
    };
    let Some(measured) = measured_from_unit(&d.unit) else {
        return why_not(if d.unit.is_empty() {
            "the file names no unit (give --unit m/s, mm/s, m/s^2 or g)".into()
        } else {
            format!("the unit {} is neither a velocity nor an acceleration", d.unit)
        });
    };
    let Some(v) = velocity_rms_mm_s(spectrum, measured, VELOCITY_BAND_HZ) else {
        return why_not(format!("the sample rate does not reach {hi} Hz"));
    };
    let integrated = match measured {
        crate::signal::velocity::Measured::Acceleration(_) => ", integrated from the acceleration",
        crate::signal::velocity::Measured::Velocity(_) => "",
    };
    let mut s =
        format!("Overall velocity RMS over {lo}-{hi} Hz: {} mm/s (channel {ch}{integrated})", super::format::sig(v, 3));
    match iso_class {
        Some(c) => {
            let [ab, bc, cd] = c.boundaries_mm_s();
            let _ = write!(
                s,
                "; ISO 10816-3 / 20816-3 {}: {} (boundaries A/B {ab}, B/C {bc}, C/D {cd} mm/s, as publicly quoted, not checked against the standard's text).",
                c.name(),
                c.zone(v).words()
            );
        }
        None => s.push_str("; give --iso-class for its ISO 10816-3 / 20816-3 zone."),
    }
    s
}

fn speed_words(s: super::summary::SpeedSource) -> &'static str {
    match s {
        super::summary::SpeedSource::Given => "given on the command line",
        super::summary::SpeedSource::Tachometer => "from the tachometer",
        super::summary::SpeedSource::Estimated => "estimated from the signal",
    }
}

/// The section that opens a trend page: the trend images and one row per recording with its verdict, gear
/// and first reason, in time order as given.
pub fn trend_section(done: &[Diagnosis], images: &[PathBuf]) -> Section {
    let names = super::figures::short_names(&done.iter().map(|d| d.file.clone()).collect::<Vec<_>>());
    let rows = done
        .iter()
        .zip(&names)
        .map(|(d, short)| {
            let file = Path::new(&d.file).file_name().and_then(|n| n.to_str()).unwrap_or(&d.file).to_string();
            let worst = d.scores.iter().filter(|s| s.decides).map(|s| s.spreads).fold(f64::NAN, f64::max);
            (
                vec![
                    short.split(' ').next().unwrap_or("").to_string(),
                    file,
                    d.verdict.state.name().replace('_', " "),
                    d.verdict.gear.name().to_string(),
                    super::format::sig(worst, 3),
                    d.verdict.reasons.first().cloned().unwrap_or_default(),
                ],
                d.verdict.state != VerdictState::Healthy,
            )
        })
        .collect();
    Section {
        heading: format!("Trend over {} recordings (time order as given)", done.len()),
        facts: vec![
            "Every scored indicator in spreads from the baseline's centre, one panel per gear and indicator family, with the suspect and faulty limits; the numbers are in trend.csv and trend.jsonl.".into(),
        ],
        tables: vec![Table {
            caption: "Verdict of each recording (rows not healthy highlighted)".into(),
            header: ["#", "recording", "verdict", "gear", "largest spreads", "first reason"]
                .iter()
                .map(|s| s.to_string())
                .collect(),
            rows,
        }],
        images: images.to_vec(),
        ..Default::default()
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
        heading: format!("{}: sweep of {}", s.scene, super::figures::parameter_label(&s.param)),
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
        tables: if s.unstable_ranges.is_empty() {
            Vec::new()
        } else {
            vec![Table {
                caption: format!(
                    "Unstable ranges of {} (runs of consecutive unstable points)",
                    super::figures::parameter_label(&s.param)
                ),
                header: ["from", "to", "points", "largest |rho|max"].iter().map(|h| h.to_string()).collect(),
                rows: s
                    .unstable_ranges
                    .iter()
                    .map(|r| (vec![cell(r.from), cell(r.to), r.points.to_string(), cell(r.rho_max)], true))
                    .collect(),
            }]
        },
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
