//! CSV (and tab/semicolon separated) signals: optional header row, an optional time column (named
//! `time`, `t`, `time_s` or starting with `time`; its unit s, ms or us from the header, `time [ms]`,
//! `time_us`, seconds when none is named, any other unit refused), comma, semicolon or tab delimiters (with `;`, a decimal
//! comma is accepted), trailing empty rows tolerated. Read line by line: memory grows with the data
//! actually present, never with a claimed size.

use super::{AtomicFile, DataError, Recording};
use std::io::{BufRead, BufWriter, Read, Write};
use std::path::Path;

/// Longest line read, bytes: far beyond a row of [`MAX_COLUMNS`] numbers of 30 characters, so that a file
/// without line breaks (a binary file, a device, a column of digits) is refused before it fills the memory.
const MAX_LINE_BYTES: u64 = 1 << 20;

/// Most fields a row may hold: a recording's channels (and a time column).
const MAX_COLUMNS: usize = 1024;

/// Longest field quoted in a message, characters (a longer one is cut, with its length said).
const QUOTED_CHARS: usize = 40;

/// `f` trimmed and quoted for a message, cut at [`QUOTED_CHARS`] characters.
fn quoted(f: &str) -> String {
    let t = f.trim();
    match t.char_indices().nth(QUOTED_CHARS) {
        Some((i, _)) => format!("{:?}... ({} characters)", &t[..i], t.chars().count()),
        None => format!("{t:?}"),
    }
}

/// The fields of `line` split at `delim` outside double quotes (a quoted header "sensor, 2" is one field).
fn split_fields(line: &str, delim: char) -> Vec<&str> {
    let mut fields = Vec::new();
    let (mut start, mut quoted) = (0, false);
    for (i, c) in line.char_indices() {
        if c == '"' {
            quoted = !quoted;
        } else if c == delim && !quoted {
            fields.push(&line[start..i]);
            start = i + c.len_utf8();
        }
    }
    fields.push(&line[start..]);
    fields
}

fn delimiter(line: &str) -> char {
    let count = |c| line.matches(c).count();
    [('\t', count('\t')), (';', count(';')), (',', count(','))].into_iter().max_by_key(|x| x.1).map_or(',', |x| x.0)
}

fn is_time_name(name: &str) -> bool {
    let n = name.trim().trim_matches('"').to_ascii_lowercase();
    n == "t" || n.starts_with("time") || n.starts_with("t [") || n.starts_with("t (")
}

/// Seconds per unit of a time column, from its header: a unit in brackets or parentheses (`time [ms]`,
/// `t (us)`) or after an underscore (`time_ms`); none means seconds. Honoured: s, ms, us (also µs, μs).
///
/// # Errors
/// Any other unit, named.
fn time_unit(name: &str) -> Result<f64, String> {
    let n = name.trim().trim_matches('"').to_lowercase();
    let rest = n.strip_prefix("time").or_else(|| n.strip_prefix('t')).unwrap_or(&n).trim();
    let unit = if let Some(u) = rest.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
        u
    } else if let Some(u) = rest.strip_prefix('(').and_then(|r| r.strip_suffix(')')) {
        u
    } else if let Some(u) = rest.strip_prefix('_') {
        u
    } else {
        return Ok(1.0); // "time", "t", "timestamp": seconds
    };
    match unit.trim() {
        "s" | "sec" | "second" | "seconds" => Ok(1.0),
        "ms" | "msec" => Ok(1e-3),
        "us" | "µs" | "μs" | "usec" => Ok(1e-6),
        other => Err(format!(
            "time column {:?}: unit {other:?} is not one of s, ms, us; convert the column or give the sample rate (and drop the column)",
            name.trim()
        )),
    }
}

/// Reads a delimited text signal. Channels are the non-time columns; the sample rate comes from a time
/// column when there is one (which must be uniformly sampled).
///
/// # Errors
/// Unreadable file, no data rows, a row with a different field count, a non-numeric or non-finite value
/// (named with its line and column), or a non-uniform time column.
pub fn read(path: &Path) -> Result<Recording<'static>, DataError> {
    let file = std::fs::File::open(path).map_err(|e| DataError::io(path, format!("cannot read: {e}")))?;
    let mut reader = std::io::BufReader::with_capacity(1 << 16, file);
    let mut raw: Vec<u8> = Vec::new();
    let mut delim = None;
    let mut header: Option<Vec<String>> = None;
    let mut columns: Vec<Vec<f64>> = Vec::new();
    let mut ncols = 0;
    let mut field = String::new();
    // first value per column beyond the f32 range of the stored channels: (line, text)
    let mut overflow: Vec<Option<(usize, String)>> = Vec::new();
    for lineno in 1.. {
        raw.clear();
        let read = (&mut reader)
            .take(MAX_LINE_BYTES + 1)
            .read_until(b'\n', &mut raw)
            .map_err(|e| DataError::io(path, format!("line {lineno}: cannot read: {e}")))?;
        if read == 0 {
            break;
        }
        if raw.len() as u64 > MAX_LINE_BYTES && raw.last() != Some(&b'\n') {
            let why = if raw.contains(&b'\r') {
                "its lines end in a carriage return alone (old Mac text): convert the line ends to LF or CRLF"
            } else {
                "not a delimited text signal"
            };
            return Err(DataError::format(
                path,
                format!("line {lineno} runs over {MAX_LINE_BYTES} bytes without a line break: {why}"),
            ));
        }
        let line = std::str::from_utf8(&raw)
            .map_err(|_| DataError::format(path, format!("line {lineno}: not UTF-8 text (a binary file?)")))?;
        // a UTF-8 byte-order mark (spreadsheet exports) is no part of the first field
        let line = if lineno == 1 { line.trim_start_matches('\u{feff}') } else { line };
        let line = line.trim_end_matches('\n').trim_end_matches('\r');
        if line.trim().is_empty() {
            continue;
        }
        let d = *delim.get_or_insert_with(|| delimiter(line));
        let fields = split_fields(line, d);
        if fields.len() > MAX_COLUMNS {
            return Err(DataError::format(
                path,
                format!(
                    "line {lineno}: {} fields, more than the {MAX_COLUMNS} columns a recording may hold",
                    fields.len()
                ),
            ));
        }
        if fields.iter().all(|f| f.trim().is_empty()) {
            continue; // an empty row such as ",,,"
        }
        if columns.is_empty() && header.is_none() {
            let numeric = fields.iter().all(|f| parse(f, d, &mut field).is_some());
            ncols = fields.len();
            columns = vec![Vec::new(); ncols];
            overflow = vec![None; ncols];
            if !numeric {
                header = Some(fields.iter().map(|f| f.trim().trim_matches('"').to_string()).collect());
                continue;
            }
        }
        if fields.len() != ncols {
            return Err(DataError::format(path, format!("line {lineno}: {} fields, expected {ncols}", fields.len())));
        }
        for (c, f) in fields.iter().enumerate() {
            let v = parse(f, d, &mut field).ok_or_else(|| {
                DataError::format(path, format!("line {lineno}, column {}: {} is not a number", c + 1, quoted(f)))
            })?;
            if !v.is_finite() {
                return Err(DataError::format(
                    path,
                    format!("line {lineno}, column {}: non-finite value {}", c + 1, quoted(f)),
                ));
            }
            if v.abs() > f64::from(f32::MAX) && overflow[c].is_none() {
                overflow[c] = Some((lineno, quoted(f)));
            }
            columns[c].push(v);
        }
    }
    if columns.first().is_none_or(Vec::is_empty) {
        let what = if header.is_some() { "header only, no data rows" } else { "no data rows" };
        return Err(DataError::format(path, what));
    }
    let names = header.clone().unwrap_or_else(|| (1..=ncols).map(|i| format!("ch{i}")).collect());
    let time_col = header.as_ref().and_then(|h| h.iter().position(|n| is_time_name(n)));
    if let Some((c, (lineno, text))) =
        overflow.iter().enumerate().find_map(|(c, o)| o.clone().filter(|_| Some(c) != time_col).map(|o| (c, o)))
    {
        return Err(DataError::format(
            path,
            format!("line {lineno}, column {}: {text} is out of range for 32-bit samples (|x| > 3.4e38)", c + 1),
        ));
    }
    let mut sample_rate_hz = None;
    if let Some(tc) = time_col {
        let seconds = time_unit(&names[tc]).map_err(|m| DataError::format(path, m))?;
        sample_rate_hz = Some(rate_from_time(path, &columns[tc])? / seconds);
    }
    // channels are kept as f32 (see `Recording`); each f64 column is dropped as soon as it is converted
    let (names, channels): (Vec<String>, Vec<Vec<f32>>) = names
        .into_iter()
        .zip(columns)
        .enumerate()
        .filter(|(i, _)| Some(*i) != time_col)
        .map(|(_, (name, col))| (name, col.into_iter().map(|v| v as f32).collect()))
        .unzip();
    // "accel [m/s^2]" names the unit in brackets (gearvib writes its CSV headers that way)
    let (names, units): (Vec<String>, Vec<String>) = names.iter().map(|n| split_unit(n)).unzip();
    Ok(Recording {
        units,
        channels: channels.into_iter().map(std::borrow::Cow::Owned).collect(),
        sample_rate_hz,
        names,
        warnings: Vec::new(),
    })
}

/// Splits a column name "name [unit]" into name and unit (empty when there are no brackets).
fn split_unit(name: &str) -> (String, String) {
    let t = name.trim();
    match (t.rfind(" ["), t.ends_with(']')) {
        (Some(i), true) => (t[..i].trim().to_string(), t[i + 2..t.len() - 1].trim().to_string()),
        _ => (t.to_string(), String::new()),
    }
}

fn parse(f: &str, delim: char, buf: &mut String) -> Option<f64> {
    let t = f.trim().trim_matches('"');
    if t.is_empty() {
        return None;
    }
    if delim == ';' && t.contains(',') {
        buf.clear();
        buf.push_str(&t.replace(',', "."));
        return buf.parse().ok();
    }
    t.parse().ok()
}

fn rate_from_time(path: &Path, t: &[f64]) -> Result<f64, DataError> {
    if t.len() < 2 {
        return Err(DataError::format(path, "time column needs at least 2 rows to give a sample rate"));
    }
    let dt = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    if dt.is_nan() || dt <= 0.0 {
        return Err(DataError::format(path, "time column does not increase"));
    }
    // each step against the usual one (the median): one gap moves the mean, and every step then looked
    // off; with every step within 1 % of the median, the mean is too
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let mid = steps.len() / 2;
    let usual = *steps.select_nth_unstable_by(mid, f64::total_cmp).1;
    for (i, w) in t.windows(2).enumerate() {
        let step = w[1] - w[0];
        if (step - usual).abs() > 0.01 * usual {
            return Err(DataError::format(
                path,
                format!(
                    "time column is not uniformly sampled near data row {} (step {step}, the usual step {usual}, in the column's unit)",
                    i + 2
                ),
            ));
        }
    }
    Ok(1.0 / dt)
}

/// Streaming CSV writer (time column first) behind an [`AtomicFile`].
pub struct CsvOut {
    out: BufWriter<std::fs::File>,
    guard: AtomicFile,
    path: std::path::PathBuf,
    channels: usize,
    sample_rate_hz: f64,
    frame: u64,
}

impl CsvOut {
    /// Creates `path` with a header `time_s,<names...>`.
    ///
    /// # Errors
    /// The file cannot be created.
    pub fn create(path: &Path, names: &[String], sample_rate_hz: f64) -> Result<Self, DataError> {
        let (guard, file) = AtomicFile::create(path)?;
        let mut out = BufWriter::with_capacity(1 << 20, file);
        writeln!(out, "time_s,{}", names.join(",")).map_err(|e| DataError::io(path, e))?;
        Ok(Self { out, guard, path: path.to_path_buf(), channels: names.len(), sample_rate_hz, frame: 0 })
    }

    /// Appends interleaved frames.
    ///
    /// # Errors
    /// Writing fails.
    pub fn write(&mut self, interleaved: &[f64]) -> Result<(), DataError> {
        for frame in interleaved.chunks(self.channels) {
            let t = self.frame as f64 / self.sample_rate_hz;
            write!(self.out, "{t:.9}").map_err(|e| DataError::io(&self.path, e))?;
            for v in frame {
                write!(self.out, ",{v:.9e}").map_err(|e| DataError::io(&self.path, e))?;
            }
            writeln!(self.out).map_err(|e| DataError::io(&self.path, e))?;
            self.frame += 1;
        }
        Ok(())
    }

    /// Flushes and renames into place.
    ///
    /// # Errors
    /// Flushing or renaming fails.
    pub fn finish(mut self) -> Result<AtomicFile, DataError> {
        self.out.flush().map_err(|e| DataError::io(&self.path, e))?;
        drop(self.out);
        Ok(self.guard)
    }
}
