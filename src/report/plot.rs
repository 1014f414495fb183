//! PNG charts with plotters (the only module that uses it). Fonts are embedded (Noto Sans through
//! ab_glyph): nothing is needed from the system at build or run time.
//!
//! Every image is drawn for the printed page: at most [`PAGE_WIDTH_PX`] wide (the page shows it across its
//! width, 182 mm on A4 between 14 mm margins) with no text smaller than [`MIN_TEXT_PX`], so nothing prints
//! under 9 pt. Each chart keeps its words out of its data: the title and the labels of the vertical
//! markers sit above the plot area, the legend below it, the colour bar of a heat map to its right; the
//! pixel boxes of all of them are returned as a [`Geometry`] so that tests can check that nothing covers
//! anything.

use super::ReportError;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Style {
    /// Connected line.
    Line,
    /// Line with a circle at each point.
    LinePoints,
    /// Vertical stems from the bottom of the axis (spectral lines).
    Stems,
    /// Circles only.
    Points,
    /// Hatched squares only (a value that could not be resolved: "there, but not measured alone").
    Hatched,
    /// Filled bars from y = 0, 0.6 x units wide (per-tooth values).
    Bars,
    /// Vertical error bars with caps: the points come in pairs (x, low), (x, high).
    ErrorBars,
}

/// One data series.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// (x, y) points.
    pub points: Vec<(f64, f64)>,
    /// Drawing style.
    pub style: Style,
    /// Palette index.
    pub color: usize,
}

/// A labelled vertical marker (for example a mesh harmonic or a sideband).
#[derive(Clone, Debug)]
pub struct Marker {
    /// Position on the x axis.
    pub x: f64,
    /// Short label drawn at the top.
    pub label: String,
    /// Palette index.
    pub color: usize,
}

/// A shaded x range (for example an unstable parameter range).
#[derive(Clone, Debug)]
pub struct Band {
    /// Start and end on the x axis.
    pub from: f64,
    /// End.
    pub to: f64,
}

/// One chart (panel).
#[derive(Clone, Debug, Default)]
pub struct Chart {
    /// Title above the panel.
    pub title: String,
    /// x-axis label with unit.
    pub x_label: String,
    /// y-axis label with unit.
    pub y_label: String,
    /// Logarithmic x axis.
    pub x_log: bool,
    /// Logarithmic y axis.
    pub y_log: bool,
    /// Series.
    pub series: Vec<Series>,
    /// Vertical markers.
    pub markers: Vec<Marker>,
    /// Shaded ranges.
    pub bands: Vec<Band>,
    /// Fixed x range.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range.
    pub y_range: Option<(f64, f64)>,
    /// A unit circle (for Floquet multipliers; equal axes expected).
    pub unit_circle: bool,
    /// Cells coloured by value, drawn under the series.
    pub heatmap: Option<Heatmap>,
    /// Symmetric-logarithmic y axis (linear within +-1, logarithmic beyond): for values in spreads that
    /// run from about 0 to hundreds.
    pub y_symlog: bool,
    /// Named x ticks (position, text) instead of numbers: file names of a trend.
    pub x_ticks: Vec<(f64, String)>,
    /// Only whole numbers as y tick labels (levels, counts).
    pub y_whole: bool,
}

/// A grid of coloured cells (an order map): cell (i, j) spans `x_edges[i]..x_edges[i + 1]` and
/// `y_edges[j]..y_edges[j + 1]`; its value is mapped from `range` onto a dark-blue-to-yellow scale.
#[derive(Clone, Debug, Default)]
pub struct Heatmap {
    /// Cell edges on x (one more than the columns).
    pub x_edges: Vec<f64>,
    /// Cell edges on y (one more than the rows).
    pub y_edges: Vec<f64>,
    /// Values row by row (`values[j][i]` for row j, column i).
    pub values: Vec<Vec<f64>>,
    /// Values at the bottom and top of the colour scale.
    pub range: (f64, f64),
    /// What the colour means, with its unit (written beside the colour bar).
    pub label: String,
    /// One cell range to outline, ((x0, y0), (x1, y1)) in data units: the chosen band of a kurtogram.
    pub outline: Option<((f64, f64), (f64, f64))>,
}

/// Dark blue (0) through teal and green to yellow (1): a perceptually ordered scale close to viridis; a
/// cell without a value (not finite: not computed, or left out of a search) is light grey.
fn heat_color(t: f64) -> RGBColor {
    if !t.is_finite() {
        return RGBColor(225, 225, 225);
    }
    const STOPS: [(f64, f64, f64); 5] =
        [(68.0, 1.0, 84.0), (59.0, 82.0, 139.0), (33.0, 145.0, 140.0), (94.0, 201.0, 98.0), (253.0, 231.0, 37.0)];
    let t = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - i as f64;
    let mix = |a: f64, b: f64| (a + (b - a) * f).round() as u8;
    RGBColor(mix(STOPS[i].0, STOPS[i + 1].0), mix(STOPS[i].1, STOPS[i + 1].1), mix(STOPS[i].2, STOPS[i + 1].2))
}

/// Palette index of the light grey used for a healthy baseline drawn behind a recording.
pub const BASELINE_GREY: usize = 9;

/// Colours by index; black (8) is for limits and references, light grey (9) for a baseline behind the data.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
    RGBColor(0, 0, 0),
    RGBColor(185, 185, 185),
];

fn color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

fn register_font() -> Result<(), ReportError> {
    static ONCE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *ONCE.get_or_init(|| {
        plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, ttf_noto_sans::REGULAR).is_ok()
    });
    if ok { Ok(()) } else { Err(ReportError::BadData { what: "font".into(), why: "embedded font rejected".into() }) }
}

/// Widest image, px: the page shows each image across its width (182 mm on A4 with 14 mm margins).
pub const PAGE_WIDTH_PX: u32 = 1000;
/// Smallest text in any image, px: 18 px of a 1000 px image printed 182 mm wide is 3.3 mm, 9.3 pt.
pub const MIN_TEXT_PX: u32 = 18;
const TICK_PX: u32 = MIN_TEXT_PX;
const LEGEND_PX: u32 = MIN_TEXT_PX;
const MARKER_PX: u32 = MIN_TEXT_PX;
const AXIS_PX: u32 = 19;
const TITLE_PX: u32 = 21;
/// Rows of text, px.
const TITLE_ROW: i32 = 26;
const MARKER_ROW: i32 = 22;
const LEGEND_ROW: i32 = 26;
/// At most this many rows of marker labels above the plot (labels that find no free place are left out
/// and said in the geometry: `hidden_marker_labels`).
const MARKER_LABEL_ROWS: usize = 3;
const MARGIN: i32 = 10;
const Y_LABEL_AREA: i32 = 100;
const X_LABEL_AREA: i32 = 58;
const RIGHT_PAD: i32 = 24;
const COLOUR_BAR_AREA: i32 = 150;

/// A rectangle in image pixels (right and bottom exclusive).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PixelRect {
    /// Left edge, px.
    pub left: i32,
    /// Top edge, px.
    pub top: i32,
    /// Right edge (exclusive), px.
    pub right: i32,
    /// Bottom edge (exclusive), px.
    pub bottom: i32,
}

impl PixelRect {
    /// Whether the two rectangles share a pixel.
    pub fn intersects(&self, o: &PixelRect) -> bool {
        self.left < o.right && o.left < self.right && self.top < o.bottom && o.top < self.bottom
    }
    /// Whether the pixel (x, y) is inside or on the edge (an axis maps its ends onto the edges).
    pub fn contains(&self, (x, y): (i32, i32)) -> bool {
        x >= self.left && x <= self.right && y >= self.top && y <= self.bottom
    }
}

/// Where the parts of one chart were drawn, in pixels of the image.
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    /// The plot area (axes inside).
    pub plot: PixelRect,
    /// Lines of the title.
    pub title: Vec<PixelRect>,
    /// The legend box, when there is one.
    pub legend: Option<PixelRect>,
    /// The vertical markers' x positions, px.
    pub marker_x: Vec<i32>,
    /// The boxes of the marker labels drawn.
    pub marker_labels: Vec<PixelRect>,
    /// Marker labels left out for want of room (their markers are still drawn).
    pub hidden_marker_labels: usize,
    /// Every data point as drawn (line vertices, stem tops and feet, symbols' centres), px.
    pub data: Vec<(i32, i32)>,
    /// The colour bar of a heat map.
    pub colour_bar: Option<PixelRect>,
    /// The smallest text size used, px.
    pub smallest_text_px: u32,
}

/// x and y ranges of a chart.
type Ranges = ((f64, f64), (f64, f64));

fn data_range(chart: &Chart) -> Result<Ranges, ReportError> {
    let bad = |why: &str| ReportError::BadData { what: chart.title.clone(), why: why.into() };
    let mut pts: Vec<(f64, f64)> = chart.series.iter().flat_map(|s| s.points.iter().copied()).collect();
    if let Some(h) = &chart.heatmap {
        if h.values.len() + 1 != h.y_edges.len() || h.values.iter().any(|r| r.len() + 1 != h.x_edges.len()) {
            return Err(bad("heat map cells do not match their edges"));
        }
        let (x, y) = (&h.x_edges, &h.y_edges);
        if let (Some(x0), Some(x1), Some(y0), Some(y1)) = (x.first(), x.last(), y.first(), y.last()) {
            pts.extend([(*x0, *y0), (*x1, *y1)]);
        }
    }
    if pts.is_empty() {
        return Err(bad("no data points"));
    }
    if pts.iter().any(|(x, y)| !x.is_finite() || !y.is_finite()) {
        return Err(bad("non-finite data (NaN or infinity)"));
    }
    let keep = |v: f64, log: bool| !log || v > 0.0;
    let xs: Vec<f64> = pts.iter().map(|p| p.0).filter(|v| keep(*v, chart.x_log)).collect();
    let ys: Vec<f64> = pts.iter().map(|p| p.1).filter(|v| keep(*v, chart.y_log)).collect();
    if xs.is_empty() || ys.is_empty() {
        return Err(bad("no positive values for a logarithmic axis"));
    }
    let span = |v: &[f64], log: bool| {
        let (lo, hi) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
        if log {
            let (lo, hi) = if lo == hi { (lo / 2.0, hi * 2.0) } else { (lo, hi) };
            (lo / 1.5, hi * 1.5)
        } else {
            let pad = if hi > lo { 0.05 * (hi - lo) } else { lo.abs().max(1.0) * 0.1 };
            (lo - pad, hi + pad)
        }
    };
    // the legend sits below the plot: no room above the data is needed for it
    let y = chart.y_range.unwrap_or_else(|| span(&ys, chart.y_log));
    Ok((chart.x_range.unwrap_or_else(|| span(&xs, chart.x_log)), y))
}

/// Renders `charts` stacked vertically into a PNG of `width` x `height` pixels, written atomically.
///
/// # Errors
/// Empty or non-finite data, drawing or writing failures.
pub fn render_png(path: &Path, width: u32, height: u32, charts: &[Chart]) -> Result<(), ReportError> {
    render_png_grid(path, width, height, 1, charts).map(|_| ())
}

/// Renders `charts` row by row into a grid of `columns` columns, written atomically; returns where each
/// chart's parts were drawn.
///
/// # Errors
/// Empty or non-finite data, an image wider than [`PAGE_WIDTH_PX`], drawing or writing failures.
pub fn render_png_grid(
    path: &Path,
    width: u32,
    height: u32,
    columns: usize,
    charts: &[Chart],
) -> Result<Vec<Geometry>, ReportError> {
    register_font()?;
    check_charts(width, charts)?;
    crate::io::check_output(path).map_err(|e| match e {
        crate::io::DataError::Io { path, message } | crate::io::DataError::Format { path, message } => {
            ReportError::Write { path, message }
        }
    })?;
    let mut name = path.file_name().map(|n| n.to_os_string()).unwrap_or_default();
    name.push(format!(".{}.tmp.png", std::process::id()));
    let tmp = path.with_file_name(name);
    crate::io::prepare_temporaries();
    // a plain OS message for a missing directory or no permission (plotters would wrap it in debug text)
    std::fs::File::create(&tmp)
        .map_err(|e| ReportError::Write { path: path.display().to_string(), message: format!("cannot write: {e}") })?;
    crate::io::register_temp(&tmp);
    let result = (|| -> Result<Vec<Geometry>, ReportError> {
        let root = BitMapBackend::new(&tmp, (width, height)).into_drawing_area();
        let shapes = draw_all(&root, columns, charts).map_err(|e| draw_err(path, e))?;
        root.present().map_err(|e| draw_err(path, e))?;
        Ok(shapes)
    })();
    let done = match result {
        Ok(shapes) => std::fs::rename(&tmp, path)
            .map(|_| shapes)
            .map_err(|e| ReportError::Write { path: path.display().to_string(), message: e.to_string() }),
        Err(e) => Err(e),
    };
    if done.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    crate::io::unregister_temp(&tmp);
    done
}

/// Draws `charts` as [`render_png_grid`] would, in memory, and returns where each chart's parts went
/// (for checks of the layout; nothing is written).
///
/// # Errors
/// Empty or non-finite data, an image wider than [`PAGE_WIDTH_PX`], drawing failures.
pub fn layout(width: u32, height: u32, columns: usize, charts: &[Chart]) -> Result<Vec<Geometry>, ReportError> {
    register_font()?;
    check_charts(width, charts)?;
    let mut buffer = vec![0u8; width as usize * height as usize * 3];
    let root = BitMapBackend::with_buffer(&mut buffer, (width, height)).into_drawing_area();
    let shapes = draw_all(&root, columns, charts).map_err(|e| draw_err(Path::new("memory"), e))?;
    root.present().map_err(|e| draw_err(Path::new("memory"), e))?;
    Ok(shapes)
}

fn check_charts(width: u32, charts: &[Chart]) -> Result<(), ReportError> {
    for c in charts {
        data_range(c)?;
    }
    if width > PAGE_WIDTH_PX {
        let what = charts.first().map_or(String::new(), |c| c.title.clone());
        return Err(ReportError::BadData {
            what,
            why: format!("{width} px is wider than the page ({PAGE_WIDTH_PX} px): its text would print too small"),
        });
    }
    Ok(())
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

fn draw_all(root: &Area<'_>, columns: usize, charts: &[Chart]) -> Result<Vec<Geometry>, Box<dyn std::error::Error>> {
    root.fill(&WHITE)?;
    let columns = columns.clamp(1, charts.len().max(1));
    let areas = root.split_evenly((charts.len().div_ceil(columns), columns));
    let mut shapes = Vec::new();
    for (chart, area) in charts.iter().zip(areas.iter()) {
        shapes.push(draw(chart, area)?);
    }
    Ok(shapes)
}

fn draw_err(path: &Path, e: impl std::fmt::Display) -> ReportError {
    // plotters puts a failed write in debug text (ImageError(IoError(Os { .., message: "No space left on
    // device" })), or IoError(Custom { .., error: "..." })): the OS's message alone is the line a user needs
    let text = e.to_string();
    let quoted = text.contains("IoError(").then(|| text.rsplit_once(": \"")).flatten();
    let message = match quoted.and_then(|(_, r)| r.split_once('"')) {
        Some((m, _)) => format!("cannot write: {m}"),
        None => text,
    };
    ReportError::Write { path: path.display().to_string(), message }
}

type DrawResult = Result<Geometry, Box<dyn std::error::Error>>;

fn font(px: u32) -> TextStyle<'static> {
    ("sans-serif", px).into_font().color(&BLACK)
}

/// Text width and height in px as drawn on `area`.
fn text_size(area: &Area<'_>, text: &str, px: u32) -> (i32, i32) {
    area.estimate_text_size(text, &font(px))
        .map(|(w, h)| (w as i32, h as i32))
        .unwrap_or((text.chars().count() as i32 * px as i32 * 6 / 10, px as i32))
}

/// Words of `text` in lines no wider than `width` px.
fn wrap(area: &Area<'_>, text: &str, px: u32, width: i32) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in text.split(' ') {
        match lines.last_mut() {
            Some(last) if text_size(area, &format!("{last} {word}"), px).0 <= width => {
                last.push(' ');
                last.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

/// One legend entry: its label, how its sample is drawn, its colour.
struct Entry {
    label: String,
    style: Option<Style>,
    color: RGBColor,
    width: i32,
}

/// The legend: one entry per series with a name (and the unit circle), only when there are two or more.
fn entries(chart: &Chart, area: &Area<'_>) -> Vec<Entry> {
    let mut e: Vec<Entry> = chart
        .series
        .iter()
        .filter(|s| !s.name.is_empty())
        .map(|s| Entry { label: s.name.clone(), style: Some(s.style), color: color(s.color), width: 0 })
        .collect();
    if chart.unit_circle {
        e.push(Entry { label: "unit circle |rho| = 1".into(), style: None, color: BLACK, width: 0 });
    }
    if e.len() < 2 && !chart.unit_circle {
        return Vec::new();
    }
    for entry in &mut e {
        entry.width = 34 + text_size(area, &entry.label, LEGEND_PX).0 + 22;
    }
    e
}

/// Legend entries placed in rows no wider than `width`: (row, x offset) of each.
fn legend_rows(entries: &[Entry], width: i32) -> Vec<(i32, i32)> {
    let (mut row, mut x) = (0, 0);
    entries
        .iter()
        .map(|e| {
            if x > 0 && x + e.width > width {
                row += 1;
                x = 0;
            }
            let at = (row, x);
            x += e.width;
            at
        })
        .collect()
}

/// Marker labels in rows above the plot: the row of each (None when no row has room), from the labels'
/// approximate pixel centres `xs` and widths.
fn marker_rows(xs: &[(i32, i32)]) -> Vec<Option<usize>> {
    let mut taken: Vec<Vec<(i32, i32)>> = vec![Vec::new(); MARKER_LABEL_ROWS];
    xs.iter()
        .map(|&(x, w)| {
            let (l, r) = (x - w / 2 - 4, x + w / 2 + 4);
            let row = taken.iter().position(|row| row.iter().all(|&(a, b)| r <= a || l >= b))?;
            taken[row].push((l, r));
            Some(row)
        })
        .collect()
}

/// Symmetric-log axis: linear within +-1, logarithmic beyond (y' = sign(y) log10(1 + |y|)).
#[derive(Clone, Copy, Debug)]
struct SymLog(f64, f64);

fn symlog(v: f64) -> f64 {
    v.signum() * v.abs().ln_1p() / std::f64::consts::LN_10
}

impl plotters::coord::ranged1d::Ranged for SymLog {
    type FormatOption = plotters::coord::ranged1d::DefaultFormatting;
    type ValueType = f64;
    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let (a, b) = (symlog(self.0), symlog(self.1));
        let t = if b > a { (symlog(*v) - a) / (b - a) } else { 0.5 };
        limit.0 + (t * f64::from(limit.1 - limit.0)).round() as i32
    }
    fn key_points<H: plotters::coord::ranged1d::KeyPointHint>(&self, _hint: H) -> Vec<f64> {
        let mut v = vec![0.0];
        for d in [1.0, 10.0, 100.0, 1e3, 1e4, 1e5] {
            for m in [1.0, 3.0] {
                v.extend([m * d, -m * d]);
            }
        }
        v.retain(|x| *x >= self.0 && *x <= self.1);
        v.sort_by(f64::total_cmp);
        v
    }
    fn range(&self) -> std::ops::Range<f64> {
        self.0..self.1
    }
}

fn draw(chart: &Chart, area: &Area<'_>) -> DrawResult {
    let ((x0, x1), (y0, y1)) = data_range(chart)?;
    let (w, h) = area.dim_in_pixel();
    let (w, h) = (w as i32, h as i32);
    let inner = w - 2 * MARGIN;
    let title = if chart.title.is_empty() { Vec::new() } else { wrap(area, &chart.title, TITLE_PX, inner) };
    let mut legend = entries(chart, area);
    let rows = legend_rows(&legend, inner);
    let legend_h = rows.iter().map(|r| r.0 + 1).max().map_or(0, |n| n * LEGEND_ROW + 12);
    for (e, &(row, x)) in legend.iter_mut().zip(&rows) {
        e.width = e.width.min(inner - x);
        let _ = row;
    }
    // approximate pixel x of each marker for the label rows (the exact positions are used to draw)
    let right = if chart.heatmap.is_some() { COLOUR_BAR_AREA } else { RIGHT_PAD };
    let (px0, px1) = (MARGIN + Y_LABEL_AREA, w - right);
    let frac = |x: f64| if chart.x_log { (x / x0).ln() / (x1 / x0).ln() } else { (x - x0) / (x1 - x0) };
    let visible: Vec<&Marker> = chart.markers.iter().filter(|m| m.x >= x0.min(x1) && m.x <= x0.max(x1)).collect();
    let approx: Vec<(i32, i32)> = visible
        .iter()
        .map(|m| (px0 + (frac(m.x) * f64::from(px1 - px0)) as i32, text_size(area, &m.label, MARKER_PX).0))
        .collect();
    let label_rows = marker_rows(&approx);
    let used_rows = label_rows.iter().flatten().map(|r| r + 1).max().unwrap_or(0) as i32;
    let top = MARGIN + title.len() as i32 * TITLE_ROW + used_rows * MARKER_ROW + 8;
    let (plot_area, legend_area) = area.split_vertically(h - legend_h);
    let frame = Frame { title, top, legend, rows, legend_area, visible, label_rows, right };
    match (chart.x_log, chart.y_log, chart.y_symlog) {
        (false, false, false) => draw_in(chart, &plot_area, frame, x0..x1, y0..y1),
        (true, false, false) => draw_in(chart, &plot_area, frame, (x0..x1).log_scale(), y0..y1),
        (false, true, _) => draw_in(chart, &plot_area, frame, x0..x1, (y0..y1).log_scale()),
        (true, true, _) => draw_in(chart, &plot_area, frame, (x0..x1).log_scale(), (y0..y1).log_scale()),
        (false, false, true) => draw_in(chart, &plot_area, frame, x0..x1, SymLog(y0, y1)),
        (true, false, true) => draw_in(chart, &plot_area, frame, (x0..x1).log_scale(), SymLog(y0, y1)),
    }
}

/// What was laid out before the chart is built.
struct Frame<'a, 'b> {
    title: Vec<String>,
    top: i32,
    legend: Vec<Entry>,
    rows: Vec<(i32, i32)>,
    legend_area: Area<'a>,
    visible: Vec<&'b Marker>,
    label_rows: Vec<Option<usize>>,
    right: i32,
}

fn draw_in<X, Y>(chart: &Chart, area: &Area<'_>, frame: Frame<'_, '_>, xs: X, ys: Y) -> DrawResult
where
    X: plotters::coord::ranged1d::AsRangedCoord<Value = f64>,
    Y: plotters::coord::ranged1d::AsRangedCoord<Value = f64>,
    X::CoordDescType: plotters::coord::ranged1d::ValueFormatter<f64>,
    Y::CoordDescType: plotters::coord::ranged1d::ValueFormatter<f64>,
{
    let mut geo = Geometry { smallest_text_px: MIN_TEXT_PX, ..Default::default() };
    let mut c = ChartBuilder::on(area)
        .margin(MARGIN)
        .margin_top(frame.top)
        .margin_right(frame.right)
        .set_label_area_size(LabelAreaPosition::Left, Y_LABEL_AREA)
        .set_label_area_size(LabelAreaPosition::Bottom, X_LABEL_AREA)
        .build_cartesian_2d(xs, ys)?;
    let named = !chart.x_ticks.is_empty();
    let x_fmt = |v: &f64| {
        if named {
            chart.x_ticks.iter().find(|t| (t.0 - *v).abs() < 1e-9).map_or(String::new(), |t| t.1.clone())
        } else {
            fmt_tick(*v)
        }
    };
    let y_fmt = |v: &f64| if chart.y_whole && (v - v.round()).abs() > 1e-9 { String::new() } else { fmt_tick(*v) };
    // at most one x tick label per 90 px of plot: wider ones ("-0.0015") would run into each other
    let x_ticks = (c.plotting_area().dim_in_pixel().0 / 90).max(2) as usize;
    let mut mesh = c.configure_mesh();
    mesh.x_labels(x_ticks);
    mesh.x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .axis_desc_style(("sans-serif", AXIS_PX))
        .label_style(("sans-serif", TICK_PX))
        .light_line_style(RGBColor(235, 235, 235))
        .y_label_formatter(&y_fmt)
        .x_label_formatter(&x_fmt);
    if named {
        mesh.x_labels(0).disable_x_mesh();
    }
    mesh.draw()?;
    let (xr, yr) = (c.x_range(), c.y_range());
    let (ylo, yhi) = (yr.start.min(yr.end), yr.start.max(yr.end));
    let (xlo, xhi) = (xr.start.min(xr.end), xr.start.max(xr.end));
    let (rx, ry) = c.plotting_area().get_pixel_range();
    geo.plot = PixelRect { left: rx.start, top: ry.start, right: rx.end, bottom: ry.end };
    let base = area.get_base_pixel();
    // named x ticks: drawn under the axis, each centred on its position, shortened to its share of the width
    if named {
        let share = (geo.plot.right - geo.plot.left) / chart.x_ticks.len().max(1) as i32 - 8;
        for (x, text) in &chart.x_ticks {
            let (px, _) = c.backend_coord(&(*x, ylo));
            let text = shorten(area, text, TICK_PX, share);
            let (tw, _) = text_size(area, &text, TICK_PX);
            area.draw_text(&text, &font(TICK_PX), (px - tw / 2 - base.0, geo.plot.bottom + 6 - base.1))?;
            area.draw(&PathElement::new(
                vec![(px - base.0, geo.plot.bottom - base.1), (px - base.0, geo.plot.bottom + 4 - base.1)],
                BLACK,
            ))?;
        }
    }
    // the title, line by line
    for (i, line) in frame.title.iter().enumerate() {
        let (tw, th) = text_size(area, line, TITLE_PX);
        // centred over the plot when it fits there, else over the whole image (a wrapped line is at most
        // the image's width less the margins)
        let (w, _) = area.dim_in_pixel();
        let over_plot = (geo.plot.left + geo.plot.right) / 2 - tw / 2 - base.0;
        let x = if over_plot + tw <= w as i32 - MARGIN { over_plot } else { (w as i32 - tw) / 2 };
        let y = MARGIN + i as i32 * TITLE_ROW;
        area.draw_text(line, &font(TITLE_PX), (x.max(0), y))?;
        geo.title.push(PixelRect {
            left: x.max(0) + base.0,
            top: y + base.1,
            right: x.max(0) + tw + base.0,
            bottom: y + th + base.1,
        });
    }
    if let Some(hm) = &chart.heatmap {
        draw_heatmap(&mut c, hm)?;
        geo.colour_bar = Some(colour_bar(area, &geo.plot, hm)?);
    }
    for b in &chart.bands {
        c.draw_series(std::iter::once(Rectangle::new(
            [(b.from, yr.start), (b.to, yr.end)],
            RGBColor(255, 200, 200).mix(0.5).filled(),
        )))?;
    }
    if chart.unit_circle {
        let circle: Vec<(f64, f64)> =
            (0..=360).map(|d| (f64::from(d).to_radians().cos(), f64::from(d).to_radians().sin())).collect();
        c.draw_series(LineSeries::new(circle, BLACK.stroke_width(1)))?;
    }
    // markers: a light line across the plot, the label in its row above the plot
    let label_top = geo.title.len() as i32 * TITLE_ROW + MARGIN + 4;
    for (m, row) in frame.visible.iter().zip(&frame.label_rows) {
        let col = color(m.color);
        c.draw_series(std::iter::once(PathElement::new(
            vec![(m.x, yr.start), (m.x, yr.end)],
            col.mix(0.45).stroke_width(1),
        )))?;
        let (px, _) = c.backend_coord(&(m.x, ylo));
        geo.marker_x.push(px);
        let Some(row) = row else {
            geo.hidden_marker_labels += 1;
            continue;
        };
        let (tw, th) = text_size(area, &m.label, MARKER_PX);
        let x = (px - tw / 2).clamp(base.0, base.0 + area.dim_in_pixel().0 as i32 - tw) - base.0;
        let y = label_top + *row as i32 * MARKER_ROW;
        area.draw_text(&m.label, &font(MARKER_PX).color(&col), (x, y))?;
        geo.marker_labels.push(PixelRect {
            left: x + base.0,
            top: y + base.1,
            right: x + tw + base.0,
            bottom: y + th + base.1,
        });
    }
    for s in &chart.series {
        let col = color(s.color);
        // keep x inside the axis and clamp y into it: segments with an end outside a log axis are drawn
        // as spikes by the backend
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| (!chart.x_log || *x > 0.0) && (!chart.y_log || *y > 0.0) && *x >= xlo && *x <= xhi)
            .map(|(x, y)| (x, y.clamp(ylo, yhi)))
            .collect();
        geo.data.extend(pts.iter().map(|p| c.backend_coord(p)));
        match s.style {
            Style::Line => {
                // dense zig-zags (spectra) with a 2-px stroke get long miter spikes at sharp corners: 1 px
                let width = if pts.len() > 400 { 1 } else { 2 };
                c.draw_series(LineSeries::new(pts, col.stroke_width(width)))?;
            }
            Style::LinePoints => {
                c.draw_series(LineSeries::new(pts.clone(), col.stroke_width(2)))?;
                c.draw_series(pts.into_iter().map(|p| Circle::new(p, 4, col.filled())))?;
            }
            Style::Points => {
                c.draw_series(pts.into_iter().map(|p| Circle::new(p, 5, col.filled())))?;
            }
            Style::Hatched => {
                // a square of half-width 7 px: outline and three diagonals
                let (h, style) = (7, col.stroke_width(2));
                c.draw_series(pts.into_iter().map(|p| {
                    EmptyElement::at(p)
                        + Rectangle::new([(-h, -h), (h, h)], style)
                        + PathElement::new(vec![(-h, h), (h, -h)], style)
                        + PathElement::new(vec![(-h, 0), (0, -h)], style)
                        + PathElement::new(vec![(0, h), (h, 0)], style)
                }))?;
            }
            Style::Bars => {
                let zero = 0.0f64.clamp(ylo, yhi);
                c.draw_series(
                    pts.into_iter()
                        .map(|(x, y)| Rectangle::new([(x - 0.3, zero), (x + 0.3, y)], col.mix(0.8).filled())),
                )?;
            }
            Style::ErrorBars => {
                let style = col.stroke_width(2);
                c.draw_series(pts.chunks_exact(2).map(|w| {
                    let (x, lo, hi) = (w[0].0, w[0].1, w[1].1);
                    PathElement::new(
                        vec![(x - 0.15, lo), (x + 0.15, lo), (x, lo), (x, hi), (x - 0.15, hi), (x + 0.15, hi)],
                        style,
                    )
                }))?;
            }
            Style::Stems => {
                let foot = yr.start;
                geo.data.extend(pts.iter().map(|p| c.backend_coord(&(p.0, foot))));
                c.draw_series(
                    pts.into_iter().map(|(x, y)| PathElement::new(vec![(x, foot), (x, y)], col.stroke_width(2))),
                )?;
            }
        }
    }
    geo.legend = draw_legend(&frame.legend_area, &frame.legend, &frame.rows)?;
    Ok(geo)
}

/// `text` cut to `width` px with an ellipsis.
fn shorten(area: &Area<'_>, text: &str, px: u32, width: i32) -> String {
    if text_size(area, text, px).0 <= width {
        return text.to_string();
    }
    let mut s: String = text.to_string();
    while !s.is_empty() && text_size(area, &format!("{s}…"), px).0 > width {
        s.pop();
    }
    format!("{s}…")
}

fn draw_heatmap<DB, X, Y>(
    c: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    h: &Heatmap,
) -> Result<(), Box<dyn std::error::Error>>
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
    X: plotters::coord::ranged1d::Ranged<ValueType = f64>,
    Y: plotters::coord::ranged1d::Ranged<ValueType = f64>,
{
    let (lo, hi) = h.range;
    let span = (hi - lo).max(f64::MIN_POSITIVE);
    for (j, row) in h.values.iter().enumerate() {
        let (y0, y1) = (h.y_edges[j], h.y_edges[j + 1]);
        c.draw_series(row.iter().enumerate().map(|(i, v)| {
            Rectangle::new([(h.x_edges[i], y0), (h.x_edges[i + 1], y1)], heat_color((v - lo) / span).filled())
        }))?;
    }
    if let Some((a, b)) = h.outline {
        // white under black: the outline shows on dark and on light cells
        c.draw_series(std::iter::once(Rectangle::new([a, b], WHITE.stroke_width(5))))?;
        c.draw_series(std::iter::once(Rectangle::new([a, b], BLACK.stroke_width(2))))?;
    }
    Ok(())
}

/// The colour bar right of the plot: the scale from `range.0` (bottom) to `range.1` (top), five ticks,
/// and the heat map's label turned along it.
fn colour_bar(area: &Area<'_>, plot: &PixelRect, h: &Heatmap) -> Result<PixelRect, Box<dyn std::error::Error>> {
    let base = area.get_base_pixel();
    let (left, right) = (plot.right + 14 - base.0, plot.right + 34 - base.0);
    let (top, bottom) = (plot.top - base.1, plot.bottom - base.1);
    let n = (bottom - top).max(1);
    for i in 0..n {
        let t = 1.0 - f64::from(i) / f64::from(n);
        area.draw(&Rectangle::new([(left, top + i), (right, top + i + 1)], heat_color(t).filled()))?;
    }
    area.draw(&Rectangle::new([(left, top), (right, bottom)], BLACK))?;
    let (lo, hi) = h.range;
    let span = (hi - lo).max(f64::MIN_POSITIVE);
    // round ticks: a step of 1, 2 or 5 times a power of ten giving 3 to 6 ticks
    let raw = span / 4.0;
    let p = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * p).find(|s| span / s <= 5.5).unwrap_or(10.0 * p);
    let mut v = (lo / step).ceil() * step;
    while v <= hi + 1e-9 * span {
        let y = bottom - ((v - lo) / span * f64::from(n)) as i32;
        area.draw(&PathElement::new(vec![(right, y), (right + 4, y)], BLACK))?;
        let text = super::format::sig(v, 3);
        let (_, th) = text_size(area, &text, TICK_PX);
        area.draw_text(&text, &font(TICK_PX), (right + 7, y - th / 2))?;
        v += step;
    }
    if !h.label.is_empty() {
        let (tw, th) = text_size(area, &h.label, AXIS_PX);
        let style = font(AXIS_PX).transform(FontTransform::Rotate90);
        area.draw_text(&h.label, &style, (right + 70 + th, (top + bottom) / 2 - tw / 2))?;
    }
    Ok(PixelRect { left: left + base.0, top: top + base.1, right: right + base.0, bottom: bottom + base.1 })
}

/// The legend below the plot, its entries in rows; returns its box.
fn draw_legend(
    area: &Area<'_>,
    entries: &[Entry],
    rows: &[(i32, i32)],
) -> Result<Option<PixelRect>, Box<dyn std::error::Error>> {
    if entries.is_empty() {
        return Ok(None);
    }
    let base = area.get_base_pixel();
    let (w, h) = area.dim_in_pixel();
    let used = entries.iter().zip(rows).map(|(e, r)| r.1 + e.width).max().unwrap_or(0);
    let left = ((w as i32 - used) / 2).max(MARGIN);
    let (top, bottom) = (2, h as i32 - 4);
    area.draw(&Rectangle::new([(left - 6, top), (left + used + 6, bottom)], RGBColor(180, 180, 180)))?;
    for (e, &(row, x)) in entries.iter().zip(rows) {
        let (x, y) = (left + x, top + 6 + row * LEGEND_ROW + LEGEND_ROW / 2 - 2);
        let col = e.color;
        match e.style {
            Some(Style::Points) => area.draw(&Circle::new((x + 14, y), 5, col.filled()))?,
            Some(Style::Hatched) => {
                area.draw(&Rectangle::new([(x + 8, y - 6), (x + 20, y + 6)], col.stroke_width(2)))?;
                area.draw(&PathElement::new(vec![(x + 8, y + 6), (x + 20, y - 6)], col.stroke_width(2)))?;
            }
            Some(Style::Bars) => {
                area.draw(&Rectangle::new([(x + 6, y - 6), (x + 22, y + 6)], col.mix(0.8).filled()))?
            }
            Some(Style::LinePoints) => {
                area.draw(&PathElement::new(vec![(x + 2, y), (x + 26, y)], col.stroke_width(3)))?;
                area.draw(&Circle::new((x + 14, y), 4, col.filled()))?;
            }
            _ => area.draw(&PathElement::new(vec![(x + 2, y), (x + 26, y)], col.stroke_width(3)))?,
        }
        let label = shorten(area, &e.label, LEGEND_PX, e.width - 40);
        let (_, th) = text_size(area, &label, LEGEND_PX);
        area.draw_text(&label, &font(LEGEND_PX), (x + 34, y - th / 2))?;
    }
    Ok(Some(PixelRect {
        left: left - 6 + base.0,
        top: top + base.1,
        right: left + used + 6 + base.0,
        bottom: bottom + base.1,
    }))
}

/// Tick labels: plain for moderate magnitudes, scientific otherwise.
fn fmt_tick(v: f64) -> String {
    let a = v.abs();
    // tick positions carry rounding noise: anything this small is the zero tick
    if a < 1e-12 {
        "0".into()
    } else if (9.999e-4..1e5).contains(&a) {
        // four significant digits: 0.0015 and 0.002 stay apart, a tick at 12250 is not rounded
        super::format::sig(v, 4)
    } else {
        format!("{v:.0e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn busy_chart() -> Chart {
        // a spectrum-like line filling the whole width and height, markers, three series: a legend that
        // sat in a corner would cover data or a marker
        let line: Vec<(f64, f64)> =
            (0..2000).map(|i| (f64::from(i), 1.0 + (f64::from(i) * 0.37).sin().abs() * 100.0)).collect();
        Chart {
            title: "a long title that has to be wrapped onto a second line because it is far wider than the image: "
                .repeat(2),
            x_label: "frequency [Hz]".into(),
            y_label: "amplitude [m/s]".into(),
            y_log: true,
            series: vec![
                Series {
                    name: "baseline (healthy)".into(),
                    points: line.clone(),
                    style: Style::Line,
                    color: BASELINE_GREY,
                },
                Series { name: "recording".into(), points: line, style: Style::Line, color: 4 },
                Series {
                    name: "detected".into(),
                    points: vec![(1999.0, 101.0), (1.0, 101.0)],
                    style: Style::Points,
                    color: 1,
                },
            ],
            markers: (1..=9)
                .map(|k| Marker { x: 200.0 * f64::from(k), label: format!("{k}x mesh"), color: 0 })
                .collect(),
            ..Default::default()
        }
    }

    #[test]
    fn layout_keeps_legend_and_labels_off_the_data() {
        let g = layout(PAGE_WIDTH_PX, 600, 1, &[busy_chart()]).unwrap();
        let g = &g[0];
        let legend = g.legend.expect("three series have a legend");
        // every data point and marker line lies inside the plot, which nothing else touches
        assert!(g.data.iter().all(|p| g.plot.contains(*p)), "data outside the plot area");
        assert!(!legend.intersects(&g.plot), "legend {legend:?} over the plot {:?}", g.plot);
        assert!(g.data.iter().all(|p| !legend.contains(*p)));
        for (i, l) in g.marker_labels.iter().enumerate() {
            assert!(!l.intersects(&g.plot) && !l.intersects(&legend));
            assert!(g.title.iter().all(|t| !t.intersects(l)), "marker label under the title");
            assert!(g.marker_labels[i + 1..].iter().all(|m| !m.intersects(l)), "marker labels overlap");
        }
        assert_eq!(g.marker_x.len(), 9);
        assert_eq!(g.hidden_marker_labels, 0);
        assert_eq!(g.title.len(), 2, "the long title is wrapped: {:?}", g.title);
        assert!(g.smallest_text_px >= MIN_TEXT_PX);
    }

    #[test]
    fn layout_rejects_images_wider_than_the_page() {
        assert!(layout(PAGE_WIDTH_PX + 1, 600, 1, &[busy_chart()]).is_err());
    }

    #[test]
    fn symlog_is_monotonic_and_odd() {
        let s = SymLog(-100.0, 1000.0);
        let mut last = i32::MIN;
        for v in [-100.0, -3.0, -1.0, 0.0, 0.5, 1.0, 3.5, 10.0, 999.0] {
            let p = plotters::coord::ranged1d::Ranged::map(&s, &v, (0, 1000));
            assert!(p > last, "not increasing at {v}");
            last = p;
        }
        assert!((symlog(3.5) + symlog(-3.5)).abs() < 1e-15);
        // symlog(9) = log10(10) = 1 exactly (up to rounding)
        assert!((symlog(9.0) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn heatmap_has_a_colour_bar_beside_the_plot() {
        let chart = Chart {
            title: "map".into(),
            x_label: "order [-]".into(),
            y_label: "speed [rpm]".into(),
            heatmap: Some(Heatmap {
                x_edges: vec![0.0, 1.0, 2.0],
                y_edges: vec![0.0, 1.0, 2.0],
                values: vec![vec![0.0, -10.0], vec![-20.0, -60.0]],
                range: (-60.0, 0.0),
                label: "level [dB]".into(),
                outline: Some(((0.0, 0.0), (1.0, 1.0))),
            }),
            ..Default::default()
        };
        let g = layout(800, 500, 1, &[chart]).unwrap();
        let bar = g[0].colour_bar.expect("colour bar");
        assert!(!bar.intersects(&g[0].plot) && bar.left >= g[0].plot.right);
    }
}
