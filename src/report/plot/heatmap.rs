//! Heat maps: the colour scale, the cells with an optional outline, the colour bar beside the plot.

use super::text::{font, text_size};
use super::*;
use plotters::prelude::*;

/// Dark blue (0) through teal and green to yellow (1): a perceptually ordered scale close to viridis; a
/// cell without a value (not finite: not computed, or left out of a search) is light grey.
pub(super) fn heat_color(t: f64) -> RGBColor {
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

pub(super) fn draw_heatmap<DB, X, Y>(
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
pub(super) fn colour_bar(
    area: &Area<'_>,
    plot: &PixelRect,
    h: &Heatmap,
) -> Result<PixelRect, Box<dyn std::error::Error>> {
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
        let text = crate::report::format::sig(v, 3);
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
