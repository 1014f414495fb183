//! PNG charts with plotters (the only module that uses it). Fonts are embedded (Noto Sans through
//! ab_glyph): nothing is needed from the system at build or run time.
//!
//! Every image is drawn for the printed page: at most [`PAGE_WIDTH_PX`] wide (the page shows it across its
//! width, 182 mm on A4 between 14 mm margins) with no text smaller than [`MIN_TEXT_PX`], so nothing prints
//! under 9 pt. Each chart keeps its words out of its data: the title and the labels of the vertical
//! markers sit above the plot area, the legend below it, the colour bar of a heat map to its right; the
//! pixel boxes of all of them are returned as a [`Geometry`] so that tests can check that nothing covers
//! anything.

mod chart;
mod heatmap;
mod legend;
mod text;

use super::ReportError;
use chart::draw;
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
    /// A unit circle (for Floquet multipliers; with `equal_axes`).
    pub unit_circle: bool,
    /// Equal scales on x and y (a complex plane): the shorter range is widened about its centre so that
    /// one unit spans as many pixels on both axes (a circle is drawn round). Linear axes only.
    pub equal_axes: bool,
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
        chart::data_range(c)?;
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

    /// A symbol (a detection's dot) below a fixed y range is left out, not drawn on the axis's bottom edge
    /// at a value it does not have; a series with no symbol left loses its legend entry.
    #[test]
    fn symbols_outside_a_fixed_range_are_not_drawn_on_its_edge() {
        let line: Vec<(f64, f64)> = (0..5).map(|i| (f64::from(i), 10.0)).collect();
        let chart = |dots: Vec<(f64, f64)>| Chart {
            title: "t".into(),
            x_label: "x [-]".into(),
            y_label: "y [-]".into(),
            y_log: true,
            y_range: Some((1.0, 100.0)),
            x_range: Some((0.0, 10.0)),
            series: vec![
                Series { name: "recording".into(), points: line.clone(), style: Style::Line, color: 4 },
                Series { name: "detected".into(), points: dots, style: Style::Points, color: 1 },
            ],
            ..Default::default()
        };
        // one dot inside, one far under the axis: only the one inside is drawn
        let g = layout(PAGE_WIDTH_PX, 500, 1, &[chart(vec![(6.0, 20.0), (7.0, 1e-6)])]).unwrap();
        assert_eq!(g[0].data.len(), line.len() + 1, "{:?}", g[0].data);
        assert!(g[0].legend.is_some());
        // no dot inside: no dot and no legend entry for it (one series left: no legend)
        let g = layout(PAGE_WIDTH_PX, 500, 1, &[chart(vec![(7.0, 1e-6)])]).unwrap();
        assert_eq!(g[0].data.len(), line.len());
        assert!(g[0].legend.is_none(), "a legend entry for dots that are not drawn");
    }

    #[test]
    fn layout_rejects_images_wider_than_the_page() {
        assert!(layout(PAGE_WIDTH_PX + 1, 600, 1, &[busy_chart()]).is_err());
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
