//! The legend below the plot: its entries, their rows, the box drawn.

use super::text::{font, shorten, text_size};
use super::*;
use plotters::prelude::*;

/// One legend entry: its label, how its sample is drawn, its colour.
pub(super) struct Entry {
    pub(super) label: String,
    pub(super) style: Option<Style>,
    pub(super) color: RGBColor,
    pub(super) width: i32,
}

/// The legend: one entry per series with a name (and the unit circle), only when there are two or more.
pub(super) fn entries(chart: &Chart, area: &Area<'_>) -> Vec<Entry> {
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
pub(super) fn legend_rows(entries: &[Entry], width: i32) -> Vec<(i32, i32)> {
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

/// The legend below the plot, its entries in rows; returns its box.
pub(super) fn draw_legend(
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
