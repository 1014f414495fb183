//! Text in the images: the font, measured sizes, wrapping and shortening, tick labels, marker label rows.

use super::*;
use plotters::prelude::*;

pub(super) fn font(px: u32) -> TextStyle<'static> {
    ("sans-serif", px).into_font().color(&BLACK)
}

/// Text width and height in px as drawn on `area`.
pub(super) fn text_size(area: &Area<'_>, text: &str, px: u32) -> (i32, i32) {
    area.estimate_text_size(text, &font(px))
        .map(|(w, h)| (w as i32, h as i32))
        .unwrap_or((text.chars().count() as i32 * px as i32 * 6 / 10, px as i32))
}

/// Words of `text` in lines no wider than `width` px.
pub(super) fn wrap(area: &Area<'_>, text: &str, px: u32, width: i32) -> Vec<String> {
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

/// Marker labels in rows above the plot: the row of each (None when no row has room), from the labels'
/// approximate pixel centres `xs` and widths.
pub(super) fn marker_rows(xs: &[(i32, i32)]) -> Vec<Option<usize>> {
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

/// `text` cut to `width` px with an ellipsis.
pub(super) fn shorten(area: &Area<'_>, text: &str, px: u32, width: i32) -> String {
    if text_size(area, text, px).0 <= width {
        return text.to_string();
    }
    let mut s: String = text.to_string();
    while !s.is_empty() && text_size(area, &format!("{s}…"), px).0 > width {
        s.pop();
    }
    format!("{s}…")
}
/// Tick labels: plain for moderate magnitudes, scientific otherwise.
pub(super) fn fmt_tick(v: f64) -> String {
    let a = v.abs();
    // tick positions carry rounding noise: anything this small is the zero tick
    if a < 1e-12 { "0".into() } else { fmt_log_tick(v) }
}

/// A tick label on a logarithmic axis, where no tick is zero (1e-13 is a decade, not rounding noise).
pub(super) fn fmt_log_tick(v: f64) -> String {
    if (9.999e-4..1e5).contains(&v.abs()) {
        // four significant digits: 0.0015 and 0.002 stay apart, a tick at 12250 is not rounded
        crate::report::format::sig(v, 4)
    } else {
        format!("{v:.0e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A linear axis snaps rounding noise to zero; a log axis labels every decade, 1e-14 included.
    #[test]
    fn log_ticks_are_never_zero() {
        assert_eq!(fmt_tick(3e-17), "0");
        assert_eq!(fmt_log_tick(1e-14), "1e-14");
        assert_eq!(fmt_log_tick(1e-13), "1e-13");
        assert_eq!(fmt_log_tick(0.001), fmt_tick(0.001));
    }
}
