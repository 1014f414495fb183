//! One chart: its ranges and axes (linear, logarithmic, symmetric-logarithmic), title, markers and series.

use super::heatmap::{colour_bar, draw_heatmap};
use super::legend::{Entry, draw_legend, entries, legend_rows};
use super::text::{fmt_log_tick, fmt_tick, font, marker_rows, shorten, text_size, wrap};
use super::*;
use plotters::prelude::*;

type DrawResult = Result<Geometry, Box<dyn std::error::Error>>;

/// x and y ranges of a chart.
pub(super) type Ranges = ((f64, f64), (f64, f64));

pub(super) fn data_range(chart: &Chart) -> Result<Ranges, ReportError> {
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

/// Symmetric-log axis: linear within +-1, logarithmic beyond (y' = sign(y) log10(1 + |y|)).
#[derive(Clone, Copy, Debug)]
pub(super) struct SymLog(f64, f64);

pub(super) fn symlog(v: f64) -> f64 {
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

/// `chart` without the symbols (points, hatched squares) whose value lies outside its fixed y range, and
/// without the series left empty by that (their legend entry would name nothing drawn); `None` when none
/// lies outside. A symbol marks a measured value: clamped onto the axis's edge it would sit at a value
/// it does not have (a sideband 12 dB over a simulation's floor 100 dB under the mesh line was drawn as a
/// dot on the bottom of the axis).
pub(super) fn symbols_in_range(chart: &Chart, (lo, hi): (f64, f64)) -> Option<Chart> {
    chart.y_range?;
    let symbol = |s: &Series| matches!(s.style, Style::Points | Style::Hatched);
    let outside = |y: f64| y < lo || y > hi;
    if !chart.series.iter().any(|s| symbol(s) && s.points.iter().any(|p| outside(p.1))) {
        return None;
    }
    let series = chart
        .series
        .iter()
        .filter_map(|s| {
            if !symbol(s) {
                return Some(s.clone());
            }
            let points: Vec<(f64, f64)> = s.points.iter().copied().filter(|p| !outside(p.1)).collect();
            (!points.is_empty()).then(|| Series { points, ..s.clone() })
        })
        .collect();
    Some(Chart { series, ..chart.clone() })
}

pub(super) fn draw(chart: &Chart, area: &Area<'_>) -> DrawResult {
    let ((x0, x1), (y0, y1)) = data_range(chart)?;
    let shown = symbols_in_range(chart, (y0.min(y1), y0.max(y1)));
    let chart = shown.as_ref().unwrap_or(chart);
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
    let ((x0, x1), (y0, y1)) = if chart.equal_axes {
        // the plot's pixels as the chart builder below lays them out
        let (pw, ph) = (px1 - px0, h - legend_h - top - MARGIN - X_LABEL_AREA);
        equal_scales((x0, x1), (y0, y1), (pw, ph))
    } else {
        ((x0, x1), (y0, y1))
    };
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

/// The x and y ranges widened about their centres (the shorter one in units per pixel) so that one unit
/// spans as many pixels on both axes of a `pixels` = (width, height) plot.
pub(super) fn equal_scales(x: (f64, f64), y: (f64, f64), pixels: (i32, i32)) -> ((f64, f64), (f64, f64)) {
    let (pw, ph) = (f64::from(pixels.0.max(1)), f64::from(pixels.1.max(1)));
    let per_px = ((x.1 - x.0) / pw).max((y.1 - y.0) / ph);
    let about = |(a, b): (f64, f64), px: f64| {
        let (c, half) = (0.5 * (a + b), 0.5 * per_px * px);
        (c - half, c + half)
    };
    (about(x, pw), about(y, ph))
}

/// What was laid out before the chart is built.
pub(super) struct Frame<'a, 'b> {
    title: Vec<String>,
    top: i32,
    legend: Vec<Entry>,
    rows: Vec<(i32, i32)>,
    legend_area: Area<'a>,
    visible: Vec<&'b Marker>,
    label_rows: Vec<Option<usize>>,
    right: i32,
}

/// A tick label on a logarithmic or a linear axis.
fn tick(log: bool, v: f64) -> String {
    if log { fmt_log_tick(v) } else { fmt_tick(v) }
}

pub(super) fn draw_in<X, Y>(chart: &Chart, area: &Area<'_>, frame: Frame<'_, '_>, xs: X, ys: Y) -> DrawResult
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
            tick(chart.x_log, *v)
        }
    };
    let y_fmt =
        |v: &f64| if chart.y_whole && (v - v.round()).abs() > 1e-9 { String::new() } else { tick(chart.y_log, *v) };
    // at most one x tick label per 90 px of plot: wider ones ("-0.0015") would run into each other
    let x_ticks = (c.plotting_area().dim_in_pixel().0 / 90).max(2) as usize;
    let y_ticks = (c.plotting_area().dim_in_pixel().1 / 40).max(2) as usize;
    let mut mesh = c.configure_mesh();
    mesh.x_labels(x_ticks);
    if chart.y_log {
        // at most one y tick label per 40 px: on a log axis spanning a decade or two the library otherwise
        // labels every 1..9 multiple, and 7e-4, 8e-4, 9e-4 and 0.001 run into each other
        mesh.y_labels(y_ticks);
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_scales_give_both_axes_the_same_units_per_pixel() {
        // a 400 x 200 px plot of (-1, 1) x (-1, 1): x has 0.005 per px, y 0.01; x widens to (-2, 2)
        let ((x0, x1), (y0, y1)) = equal_scales((-1.0, 1.0), (-1.0, 1.0), (400, 200));
        assert_eq!(((x0, x1), (y0, y1)), ((-2.0, 2.0), (-1.0, 1.0)));
        // the other way round, off-centre: y widens about its centre 1
        let ((x0, x1), (y0, y1)) = equal_scales((0.0, 4.0), (0.5, 1.5), (200, 200));
        assert_eq!(((x0, x1), (y0, y1)), ((0.0, 4.0), (-1.0, 3.0)));
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
}
