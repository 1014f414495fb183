//! CSV (and tab/semicolon separated) signals: optional header row, an optional time column (named
//! `time`, `t`, `time_s` or starting with `time`; its unit s, ms or us from the header, `time [ms]`,
//! `time_us`, seconds when none is named, any other unit refused), comma, semicolon or tab delimiters (with `;`, a decimal
//! comma is accepted), trailing empty rows tolerated. Read line by line: memory grows with the data
//! actually present, never with a claimed size.

use super::{AtomicFile, DataError, Recording};
use std::borrow::Cow;
use std::io::{BufRead, BufWriter, Read, Write};
use std::path::Path;

/// Longest line read, bytes: far beyond a row of [`MAX_COLUMNS`] numbers of 30 characters, so that a file
/// without line breaks (a binary file, a device, a column of digits) is refused before it fills the memory.
const MAX_LINE_BYTES: u64 = 1 << 20;

/// Most fields a row may hold: a recording's channels (and a time column).
const MAX_COLUMNS: usize = 1024;

/// Most physical lines a header row may span (a quoted name holding line breaks): a quote left open is
/// refused there, not read on through the data.
const MAX_HEADER_LINES: usize = 16;

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

/// A header field without its surrounding double quotes, a doubled quote inside read as one (RFC 4180).
fn unquote(f: &str) -> String {
    let t = f.trim();
    match t.strip_prefix('"').and_then(|u| u.strip_suffix('"')) {
        Some(inner) => inner.replace("\"\"", "\""),
        None => t.to_string(),
    }
}

/// The delimiter of a file from its first row, outside double quotes: a tab when there is one, else a
/// semicolon when there is one (its numbers may then use a decimal comma: "1,5;2,5"), else a comma.
fn delimiter(line: &str) -> char {
    let mut quoted = false;
    let (mut tab, mut semicolon) = (false, false);
    for c in line.chars() {
        match c {
            '"' => quoted = !quoted,
            '\t' if !quoted => tab = true,
            ';' if !quoted => semicolon = true,
            _ => {}
        }
    }
    if tab {
        '\t'
    } else if semicolon {
        ';'
    } else {
        ','
    }
}

fn is_time_name(name: &str) -> bool {
    let n = name.trim().trim_matches('"').to_ascii_lowercase();
    n == "t" || n.starts_with("time") || n.starts_with("t [") || n.starts_with("t (")
}

/// Seconds per unit of a time column, from its header: a unit in brackets (`time [ms]`, `timestamp [ms]`,
/// `time [s] (UTC)`), in parentheses at the end of the name (`t (us)`), after an underscore right after
/// the name (`time_ms`), or a unit word after a space (`time ms`); none means seconds. Honoured: s, ms, us
/// (also µs, μs).
///
/// # Errors
/// Any other unit, named.
fn time_unit(name: &str) -> Result<f64, String> {
    let n = name.trim().trim_matches('"').to_lowercase();
    // a unit in brackets anywhere ("time [s] (UTC)"), before one in parentheses at the end
    let bracketed = n.rfind('[').and_then(|i| n[i + 1..].find(']').map(|j| &n[i + 1..i + 1 + j]));
    let parenthesized = n.strip_suffix(')').and_then(|r| r.rfind('(').map(|i| &r[i + 1..]));
    let rest = n.strip_prefix("time").or_else(|| n.strip_prefix('t')).unwrap_or(&n).trim();
    let word = n.rsplit_once(' ').map(|(_, w)| w).filter(|w| seconds_per(w).is_some());
    let Some(unit) = bracketed.or(parenthesized).or_else(|| rest.strip_prefix('_')).or(word) else {
        return Ok(1.0); // "time", "t", "timestamp": seconds
    };
    seconds_per(unit.trim()).ok_or_else(|| {
        format!(
            "time column {:?}: unit {:?} is not one of s, ms, us; convert the column or give the sample rate (and drop the column)",
            name.trim(),
            unit.trim()
        )
    })
}

/// Seconds per time unit `u` (s, ms, us and their spellings).
fn seconds_per(u: &str) -> Option<f64> {
    match u {
        "s" | "sec" | "second" | "seconds" => Some(1.0),
        "ms" | "msec" => Some(1e-3),
        "us" | "µs" | "μs" | "usec" => Some(1e-6),
        _ => None,
    }
}

/// Reads a delimited text signal. Channels are the non-time columns; the sample rate comes from a time
/// column when there is one (which must be uniformly sampled). The channels are stored as f32 as they are
/// read (the time column as f64), so a file's values take 4 bytes each, never 8 first. A quoted header
/// field may hold a line break (RFC 4180): the header then runs over the lines its quotes span.
///
/// # Errors
/// Unreadable file, no data rows, a row with a different field count, a non-numeric or non-finite value or
/// one beyond the f32 range (named with its line and column), or a non-uniform time column.
pub fn read(path: &Path) -> Result<Recording<'static>, DataError> {
    let file = std::fs::File::open(path).map_err(|e| DataError::io(path, format!("cannot read: {e}")))?;
    let mut lines = Lines { reader: std::io::BufReader::with_capacity(1 << 16, file), raw: Vec::new(), lineno: 0 };
    let mut delim = None;
    let mut header: Option<Vec<String>> = None;
    let mut columns: Option<Columns> = None;
    let mut field = String::new();
    while let Some((lineno, line)) = lines.next(path, header.is_none() && columns.is_none())? {
        if line.trim().is_empty() {
            continue;
        }
        let d = *delim.get_or_insert_with(|| delimiter(&line));
        let fields = split_fields(&line, d);
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
        let cols = match &mut columns {
            Some(c) => c,
            None => {
                let numeric = fields.iter().all(|f| parse(f, d, &mut field).is_some());
                let names: Option<Vec<String>> = (!numeric).then(|| fields.iter().map(|f| unquote(f)).collect());
                let time = names.as_ref().and_then(|h| h.iter().position(|n| is_time_name(n)));
                let c = columns.insert(Columns::new(fields.len(), time));
                if names.is_some() {
                    header = names;
                    continue;
                }
                c
            }
        };
        cols.push(path, lineno, &fields, d, &mut field)?;
    }
    let Some(cols) = columns.filter(|c| c.rows > 0) else {
        let what = if header.is_some() { "header only, no data rows" } else { "no data rows" };
        return Err(DataError::format(path, what));
    };
    let names = header.unwrap_or_else(|| (1..=cols.channels.len()).map(|i| format!("ch{i}")).collect());
    let mut sample_rate_hz = None;
    if let Some((tc, t)) = &cols.time {
        let seconds = time_unit(&names[*tc]).map_err(|m| DataError::format(path, m))?;
        sample_rate_hz = Some(rate_from_time(path, t, &|row| cols.line_of(row))? / seconds);
    }
    let time_col = cols.time.as_ref().map(|t| t.0);
    let names: Vec<String> = names.into_iter().enumerate().filter(|(i, _)| Some(*i) != time_col).map(|x| x.1).collect();
    // "accel [m/s^2]" names the unit in brackets (gearvib writes its CSV headers that way)
    let (names, units): (Vec<String>, Vec<String>) = names.iter().map(|n| split_unit(n)).unzip();
    Ok(Recording {
        units,
        channels: cols.channels.into_iter().map(Cow::Owned).collect(),
        sample_rate_hz,
        names,
        warnings: Vec::new(),
    })
}

/// The file's lines, each read to at most [`MAX_LINE_BYTES`], with the number of the last one read.
struct Lines<R> {
    reader: R,
    raw: Vec<u8>,
    lineno: usize,
}

impl<R: BufRead> Lines<R> {
    /// The next line's number (its first physical line) and text without its line end (and without a
    /// byte-order mark on the first), or `None` at the end. With `header`, a line whose double quotes are
    /// not closed runs on over the next lines until they are (a quoted name holding a line break), at most
    /// [`MAX_HEADER_LINES`] physical lines.
    ///
    /// # Errors
    /// A line over [`MAX_LINE_BYTES`], not UTF-8, or a header quote left open.
    fn next(&mut self, path: &Path, header: bool) -> Result<Option<(usize, Cow<'_, str>)>, DataError> {
        self.raw.clear();
        let first = self.lineno + 1;
        let mut quotes = 0usize;
        loop {
            self.lineno += 1;
            let start = self.raw.len();
            let read = (&mut self.reader)
                .take(MAX_LINE_BYTES + 1)
                .read_until(b'\n', &mut self.raw)
                .map_err(|e| DataError::io(path, format!("line {}: cannot read: {e}", self.lineno)))?;
            if read == 0 && self.raw.is_empty() {
                return Ok(None);
            }
            if read as u64 > MAX_LINE_BYTES && self.raw.last() != Some(&b'\n') {
                let why = if self.raw[start..].contains(&b'\r') {
                    "its lines end in a carriage return alone (old Mac text): convert the line ends to LF or CRLF"
                } else {
                    "not a delimited text signal"
                };
                let at = self.lineno;
                return Err(DataError::format(
                    path,
                    format!("line {at} runs over {MAX_LINE_BYTES} bytes without a line break: {why}"),
                ));
            }
            // the quotes of the part just read: the whole is never scanned again
            quotes += self.raw[start..].iter().filter(|&&b| b == b'"').count();
            if !header || quotes.is_multiple_of(2) {
                break;
            }
            if read == 0 || self.lineno + 1 - first >= MAX_HEADER_LINES {
                return Err(DataError::format(
                    path,
                    format!(
                        "line {first}: a double quote opened in the header is not closed{}: close the quoted name",
                        if read == 0 {
                            " before the end of the file".to_string()
                        } else {
                            format!(" within {MAX_HEADER_LINES} lines")
                        }
                    ),
                ));
            }
        }
        let line = std::str::from_utf8(&self.raw)
            .map_err(|_| DataError::format(path, format!("line {first}: not UTF-8 text (a binary file?)")))?;
        // a UTF-8 byte-order mark (spreadsheet exports) is no part of the first field
        let line = if first == 1 { line.trim_start_matches('\u{feff}') } else { line };
        // a line break inside a quoted name is a space in the name
        let line = line.trim_end_matches('\n').trim_end_matches('\r');
        // a carriage return left inside a line ends lines on its own (old Mac text): the whole file would
        // read as one row
        if line.contains('\r') && line.replace("\r\n", "").contains('\r') {
            return Err(DataError::format(
                path,
                format!(
                    "line {first}: holds a carriage return that ends no line: its lines end in a carriage return alone (old Mac text): convert the line ends to LF or CRLF"
                ),
            ));
        }
        let text = if line.contains('\n') {
            Cow::Owned(line.replace("\r\n", " ").replace('\n', " "))
        } else {
            Cow::Borrowed(line)
        };
        Ok(Some((first, text)))
    }
}

/// The data read so far: the time column (its index among the fields, its values) and the channels, each
/// stored as it will be kept.
struct Columns {
    fields: usize,
    time: Option<(usize, Vec<f64>)>,
    channels: Vec<Vec<f32>>,
    rows: usize,
    /// (row, line) where a row's line is not the one after the row before's (the first row, and after
    /// blank or empty lines): the line of every row, for messages, without a number kept per row.
    breaks: Vec<(usize, usize)>,
}

impl Columns {
    fn new(fields: usize, time: Option<usize>) -> Self {
        let channels = fields - usize::from(time.is_some());
        Self {
            fields,
            time: time.map(|t| (t, Vec::new())),
            channels: vec![Vec::new(); channels],
            rows: 0,
            breaks: Vec::new(),
        }
    }

    /// The file's line of data row `row` (0-based).
    fn line_of(&self, row: usize) -> usize {
        let i = self.breaks.partition_point(|b| b.0 <= row).saturating_sub(1);
        self.breaks.get(i).map_or(row + 1, |&(r, l)| l + (row - r))
    }

    /// Adds the row `fields` of line `lineno`.
    ///
    /// # Errors
    /// Another field count than the first row's; a field that is not a finite number, or a channel's beyond
    /// the f32 range.
    fn push(
        &mut self,
        path: &Path,
        lineno: usize,
        fields: &[&str],
        d: char,
        buf: &mut String,
    ) -> Result<(), DataError> {
        if fields.len() != self.fields {
            let (n, want) = (fields.len(), self.fields);
            return Err(DataError::format(path, format!("line {lineno}: {n} fields, expected {want}")));
        }
        let time_col = self.time.as_ref().map(|t| t.0);
        let mut channel = 0;
        for (c, f) in fields.iter().enumerate() {
            let at = || format!("line {lineno}, column {}", c + 1);
            let v = parse(f, d, buf)
                .ok_or_else(|| DataError::format(path, format!("{}: {} is not a number", at(), quoted(f))))?;
            if !v.is_finite() {
                return Err(DataError::format(path, format!("{}: non-finite value {}", at(), quoted(f))));
            }
            match &mut self.time {
                Some((_, t)) if Some(c) == time_col => t.push(v),
                _ => {
                    // (the f32 nearest: f32::MAX written with nine digits is 3.402823466e38, over it in f64)
                    if (v as f32).is_infinite() {
                        return Err(DataError::format(
                            path,
                            format!("{}: {} is out of range for 32-bit samples (|x| > 3.4e38)", at(), quoted(f)),
                        ));
                    }
                    self.channels[channel].push(v as f32);
                    channel += 1;
                }
            }
        }
        if self.breaks.last().is_none_or(|&(r, l)| l + (self.rows - r) != lineno) {
            self.breaks.push((self.rows, lineno));
        }
        self.rows += 1;
        Ok(())
    }
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

/// The sample rate (per the column's unit) of the time column `t`, whose row i stands on line
/// `line_of(i)` of the file.
///
/// # Errors
/// Fewer than 2 rows, a column that does not increase, a step off the usual one by over 1 % (named at its
/// line), or no finite rate.
fn rate_from_time(path: &Path, t: &[f64], line_of: &dyn Fn(usize) -> usize) -> Result<f64, DataError> {
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
                    "line {}: the time column is not uniformly sampled there (data row {}: step {step} from line {}, the usual step {usual}, in the column's unit)",
                    line_of(i + 1),
                    i + 2,
                    line_of(i)
                ),
            ));
        }
    }
    let rate = 1.0 / dt;
    if !(dt.is_finite() && rate.is_finite()) {
        return Err(DataError::format(
            path,
            format!("time column: its mean step {dt:e} (in the column's unit) gives no finite sample rate"),
        ));
    }
    Ok(rate)
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
