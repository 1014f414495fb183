//! PNG charts with plotters (the only module that uses it). Fonts are embedded (Noto Sans through
//! ab_glyph): nothing is needed from the system at build or run time.

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
}

/// Dark blue (0) through teal and green to yellow (1): a perceptually ordered scale close to viridis.
fn heat_color(t: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 5] =
        [(68.0, 1.0, 84.0), (59.0, 82.0, 139.0), (33.0, 145.0, 140.0), (94.0, 201.0, 98.0), (253.0, 231.0, 37.0)];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 } * (STOPS.len() - 1) as f64;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - i as f64;
    let mix = |a: f64, b: f64| (a + (b - a) * f).round() as u8;
    RGBColor(mix(STOPS[i].0, STOPS[i + 1].0), mix(STOPS[i].1, STOPS[i + 1].1), mix(STOPS[i].2, STOPS[i + 1].2))
}

/// Colours by index; the last (black) is for limits and references.
const PALETTE: [RGBColor; 9] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
    RGBColor(0, 0, 0),
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
    // a legend (two or more series) sits in the upper right: room above the data so it covers none
    let legend = chart.series.len() > 1;
    let y = chart.y_range.unwrap_or_else(|| {
        let (lo, hi) = span(&ys, chart.y_log);
        match (legend, chart.y_log) {
            (false, _) => (lo, hi),
            (true, false) => (lo, hi + LEGEND_ROOM * (hi - lo)),
            (true, true) => (lo, hi * (hi / lo).powf(LEGEND_ROOM)),
        }
    });
    Ok((chart.x_range.unwrap_or_else(|| span(&xs, chart.x_log)), y))
}

/// Share of the data's height added above it for the legend of a chart with several series.
const LEGEND_ROOM: f64 = 0.3;

/// Renders `charts` stacked vertically into a PNG of `width` x `height` pixels, written atomically.
///
/// # Errors
/// Empty or non-finite data, drawing or writing failures.
pub fn render_png(path: &Path, width: u32, height: u32, charts: &[Chart]) -> Result<(), ReportError> {
    render_png_grid(path, width, height, 1, charts)
}

/// Renders `charts` row by row into a grid of `columns` columns, written atomically.
///
/// # Errors
/// Empty or non-finite data, drawing or writing failures.
pub fn render_png_grid(
    path: &Path,
    width: u32,
    height: u32,
    columns: usize,
    charts: &[Chart],
) -> Result<(), ReportError> {
    register_font()?;
    for c in charts {
        data_range(c)?;
    }
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
    let result = (|| -> Result<(), ReportError> {
        let root = BitMapBackend::new(&tmp, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw_err(path, e))?;
        let columns = columns.clamp(1, charts.len().max(1));
        let areas = root.split_evenly((charts.len().div_ceil(columns), columns));
        for (chart, area) in charts.iter().zip(areas.iter()) {
            draw(chart, area).map_err(|e| draw_err(path, e))?;
        }
        root.present().map_err(|e| draw_err(path, e))?;
        Ok(())
    })();
    let done = match result {
        Ok(()) => std::fs::rename(&tmp, path)
            .map_err(|e| ReportError::Write { path: path.display().to_string(), message: e.to_string() }),
        Err(e) => Err(e),
    };
    if done.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    crate::io::unregister_temp(&tmp);
    done
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

type DrawResult = Result<(), Box<dyn std::error::Error>>;

fn draw(chart: &Chart, area: &DrawingArea<BitMapBackend<'_>, Shift>) -> DrawResult {
    let ((x0, x1), (y0, y1)) = data_range(chart)?;
    match (chart.x_log, chart.y_log) {
        (false, false) => draw_in(chart, area, x0..x1, y0..y1),
        (true, false) => draw_in(chart, area, (x0..x1).log_scale(), y0..y1),
        (false, true) => draw_in(chart, area, x0..x1, (y0..y1).log_scale()),
        (true, true) => draw_in(chart, area, (x0..x1).log_scale(), (y0..y1).log_scale()),
    }
}

fn draw_in<X, Y>(chart: &Chart, area: &DrawingArea<BitMapBackend<'_>, Shift>, xs: X, ys: Y) -> DrawResult
where
    X: plotters::coord::ranged1d::AsRangedCoord<Value = f64>,
    Y: plotters::coord::ranged1d::AsRangedCoord<Value = f64>,
    X::CoordDescType: plotters::coord::ranged1d::ValueFormatter<f64>,
    Y::CoordDescType: plotters::coord::ranged1d::ValueFormatter<f64>,
{
    let mut c = ChartBuilder::on(area)
        .caption(&chart.title, ("sans-serif", 26))
        .margin(12)
        .x_label_area_size(52)
        .y_label_area_size(95)
        .build_cartesian_2d(xs, ys)?;
    c.configure_mesh()
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .axis_desc_style(("sans-serif", 20))
        .label_style(("sans-serif", 16))
        .light_line_style(RGBColor(235, 235, 235))
        .y_label_formatter(&|v| fmt_tick(*v))
        .x_label_formatter(&|v| fmt_tick(*v))
        .draw()?;
    let (xr, yr) = (c.x_range(), c.y_range());
    if let Some(h) = &chart.heatmap {
        let (lo, hi) = h.range;
        let span = (hi - lo).max(f64::MIN_POSITIVE);
        for (j, row) in h.values.iter().enumerate() {
            let (y0, y1) = (h.y_edges[j], h.y_edges[j + 1]);
            c.draw_series(row.iter().enumerate().map(|(i, v)| {
                Rectangle::new([(h.x_edges[i], y0), (h.x_edges[i + 1], y1)], heat_color((v - lo) / span).filled())
            }))?;
        }
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
        c.draw_series(LineSeries::new(circle, BLACK.stroke_width(1)))?
            .label("unit circle |rho| = 1")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
    }
    for (i, m) in chart.markers.iter().enumerate() {
        if m.x < xr.start || m.x > xr.end {
            continue;
        }
        let col = color(m.color);
        c.draw_series(std::iter::once(PathElement::new(
            vec![(m.x, yr.start), (m.x, yr.end)],
            col.mix(0.35).stroke_width(1),
        )))?;
        // stagger labels on rows so that neighbours do not collide
        let row = (i % MARKER_LABEL_ROWS) as i32;
        let font = ("sans-serif", 14).into_font().color(&col).pos(plotters::style::text_anchor::Pos::new(
            plotters::style::text_anchor::HPos::Center,
            plotters::style::text_anchor::VPos::Top,
        ));
        c.draw_series(std::iter::once(
            EmptyElement::at((m.x, yr.end)) + Text::new(m.label.clone(), (0, 4 + MARKER_ROW_PX * row), font),
        ))?;
    }
    let (ylo, yhi) = (yr.start.min(yr.end), yr.start.max(yr.end));
    let (xlo, xhi) = (xr.start.min(xr.end), xr.start.max(xr.end));
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
        let legend = move |(x, y): (i32, i32)| PathElement::new(vec![(x, y), (x + 18, y)], col.stroke_width(3));
        match s.style {
            Style::Line => {
                // dense zig-zags (spectra) with a 2-px stroke get long miter spikes at sharp corners: 1 px
                let width = if pts.len() > 400 { 1 } else { 2 };
                c.draw_series(LineSeries::new(pts, col.stroke_width(width)))?.label(s.name.as_str()).legend(legend);
            }
            Style::LinePoints => {
                c.draw_series(LineSeries::new(pts.clone(), col.stroke_width(2)))?.label(s.name.as_str()).legend(legend);
                c.draw_series(pts.into_iter().map(|p| Circle::new(p, 4, col.filled())))?;
            }
            Style::Points => {
                c.draw_series(pts.into_iter().map(|p| Circle::new(p, 5, col.filled())))?
                    .label(s.name.as_str())
                    .legend(legend);
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
                }))?
                .label(s.name.as_str())
                .legend(move |(x, y)| {
                    EmptyElement::at((x + 9, y))
                        + Rectangle::new([(-6, -6), (6, 6)], col.stroke_width(2))
                        + PathElement::new(vec![(-6, 6), (6, -6)], col.stroke_width(2))
                });
            }
            Style::Bars => {
                let zero = 0.0f64.clamp(ylo, yhi);
                c.draw_series(
                    pts.into_iter()
                        .map(|(x, y)| Rectangle::new([(x - 0.3, zero), (x + 0.3, y)], col.mix(0.8).filled())),
                )?
                .label(s.name.as_str())
                .legend(legend);
            }
            Style::ErrorBars => {
                let style = col.stroke_width(2);
                c.draw_series(pts.chunks_exact(2).map(|w| {
                    let (x, lo, hi) = (w[0].0, w[0].1, w[1].1);
                    PathElement::new(
                        vec![(x - 0.15, lo), (x + 0.15, lo), (x, lo), (x, hi), (x - 0.15, hi), (x + 0.15, hi)],
                        style,
                    )
                }))?
                .label(s.name.as_str())
                .legend(legend);
            }
            Style::Stems => {
                let base = yr.start;
                c.draw_series(
                    pts.into_iter().map(|(x, y)| PathElement::new(vec![(x, base), (x, y)], col.stroke_width(2))),
                )?
                .label(s.name.as_str())
                .legend(legend);
            }
        }
    }
    if chart.series.len() > 1 || chart.unit_circle {
        let position = legend_position(chart, c.plotting_area().dim_in_pixel(), (xlo, xhi), (ylo, yhi));
        c.configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(180, 180, 180))
            .label_font(("sans-serif", 16))
            .position(position)
            .draw()?;
    }
    Ok(())
}

/// Marker labels are staggered on this many rows along the top, each this many pixels high.
const MARKER_LABEL_ROWS: usize = 3;
const MARKER_ROW_PX: i32 = 16;

/// Where the legend goes, in pixels of the plotting area (`size`; data ranges `x` and `y` as drawn): below
/// the rows of marker labels when there are markers, in the upper corner over less data (the right one
/// unless the data under it reaches higher than under the left one). Its width is estimated from its
/// longest entry (16 px text: at most about 7 px a character, plus the line sample and padding).
fn legend_position(chart: &Chart, size: (u32, u32), x: (f64, f64), y: (f64, f64)) -> SeriesLabelPosition {
    let longest = chart.series.iter().map(|s| s.name.chars().count()).max().unwrap_or(0).max(22);
    let width = (longest as f64 * 7.0 + 55.0).min(f64::from(size.0));
    let top = if chart.markers.is_empty() { 10 } else { 4 + MARKER_ROW_PX * MARKER_LABEL_ROWS as i32 + 8 };
    let right = i32::try_from(size.0).unwrap_or(0) - width as i32 - 10;
    let ((lo, hi), (ylo, yhi)) = (x, y);
    if hi <= lo || yhi <= ylo {
        return SeriesLabelPosition::Coordinate(right, top);
    }
    let share = width / f64::from(size.0.max(1));
    let at = |x: f64| if chart.x_log { (x / lo).ln() / (hi / lo).ln() } else { (x - lo) / (hi - lo) };
    // the highest point under each corner, as a share of the height from the bottom
    let height = |y: f64| if chart.y_log { (y / ylo).ln() / (yhi / ylo).ln() } else { (y - ylo) / (yhi - ylo) };
    let highest = |from: f64, to: f64| {
        chart
            .series
            .iter()
            .flat_map(|s| &s.points)
            .filter(|p| p.0.is_finite() && p.1.is_finite() && (from..=to).contains(&at(p.0)))
            .map(|p| height(p.1))
            .fold(f64::NEG_INFINITY, f64::max)
    };
    if highest(1.0 - share, 1.0) > highest(0.0, share) {
        SeriesLabelPosition::Coordinate(10, top)
    } else {
        SeriesLabelPosition::Coordinate(right, top)
    }
}

/// Tick labels: plain for moderate magnitudes, scientific otherwise.
fn fmt_tick(v: f64) -> String {
    let a = v.abs();
    // tick positions carry rounding noise: anything this small is the zero tick
    if a < 1e-12 {
        "0".into()
    } else if (9.999e-4..1e5).contains(&a) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}
