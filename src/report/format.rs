//! Numbers as people read them: one helper for every page, table and image title, so the same quantity
//! is never printed as 3125.6268 in one place and 3.126e3 in another.

/// `v` with four significant digits: plain notation from 0.001 to below 1e6 (trailing zeros after the
/// decimal point dropped: 5.12, 420, 0.0123), scientific beyond (1.23e-5, 2.5e7); "-" when not finite.
pub fn num(v: f64) -> String {
    sig(v, 4)
}

/// `v` with `digits` significant digits (at least 1), as [`num`].
pub fn sig(v: f64, digits: usize) -> String {
    let digits = digits.max(1);
    if !v.is_finite() {
        return "-".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    // rounded first: 999999.9 to four digits is 1e6, and takes the form of 1e6
    let v: f64 = format!("{v:.*e}", digits - 1).parse().unwrap_or(v);
    let a = v.abs();
    if !(1e-3..1e6).contains(&a) {
        let s = format!("{v:.*e}", digits - 1);
        // 1.230e-5 -> 1.23e-5
        return match s.split_once('e') {
            Some((m, e)) if m.contains('.') => format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.')),
            _ => s,
        };
    }
    // decimals for `digits` significant digits
    let magnitude = a.log10().floor() as i32;
    let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
}

/// `fraction` (0.299) as a percentage with three significant digits ("29.9 %").
pub fn percent(fraction: f64) -> String {
    format!("{} %", sig(100.0 * fraction, 3))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn num_works() {
        // expected strings written by hand from the rule: four significant digits, zeros dropped
        for (v, want) in [
            (3125.6268, "3126"),
            (5.12, "5.12"),
            (420.0, "420"),
            (0.0123456, "0.01235"),
            (-2.5, "-2.5"),
            (0.0, "0"),
            (1.23e-5, "1.23e-5"),
            (2.5e7, "2.5e7"),
            (999_999.9, "1e6"),
            (f64::NAN, "-"),
        ] {
            assert_eq!(num(v), want, "{v}");
        }
        assert_eq!(percent(0.29878), "29.9 %");
        assert_eq!(sig(9.96, 2), "10");
    }
}
