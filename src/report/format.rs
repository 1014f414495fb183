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
    // rounded first: 999999.9 to four digits is 1e6, and takes the form of 1e6 (f64::MAX rounds beyond
    // the largest f64: kept, to be written 1.798e308)
    let v: f64 = format!("{v:.*e}", digits - 1).parse().ok().filter(|r: &f64| r.is_finite()).unwrap_or(v);
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

/// `text` with every long plain numeral (more than 20 digits: how Rust writes a huge or tiny `f64` such as
/// 1e308, a 1 and 308 zeros; a 64-bit integer, at most 20 digits, is kept as typed) in four significant digits as [`num`] writes it ("1e308", "1.798e308",
/// "1e-300"). A numeral counts when it stands alone: after the start, a space or one of `([="'` and
/// before the end, a space, one of `,;:)]"'` or a full stop (a dot before a space or the end: the dot of
/// `1234...5.csv` is a name's); digits inside words and paths are left alone, and so is a numeral in double
/// quotes on both sides (a quoted field of the user's file, already cut at 40 characters). Every error line
/// passes through this (see `crate::Error`), so no message prints a value 300 digits long.
pub fn compact_numerals(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < chars.len() {
        let starts =
            chars[i].is_ascii_digit() || (chars[i] == '-' && chars.get(i + 1).is_some_and(char::is_ascii_digit));
        let after_break = i == 0 || matches!(chars[i - 1], ' ' | '(' | '[' | '=' | '"' | '\'');
        if !(starts && after_break) {
            out.push(chars[i]);
            i += 1;
            continue;
        }
        let mut j = i + 1;
        while j < chars.len() && (chars[j].is_ascii_digit() || chars[j] == '.') {
            j += 1;
        }
        // a full stop after the numeral ends the sentence
        while j > i + 1 && chars[j - 1] == '.' {
            j -= 1;
        }
        let token: String = chars[i..j].iter().collect();
        let digits = token.chars().filter(char::is_ascii_digit).count();
        // (a full stop ends it, the dot of a file name's extension does not: "1234...5.csv" is a name)
        let full_stop = chars[j..].first() == Some(&'.') && chars.get(j + 1).is_none_or(|c| c.is_whitespace());
        let ends = j == chars.len() || matches!(chars[j], ' ' | ',' | ';' | ':' | ')' | ']' | '"' | '\'') || full_stop;
        // a numeral in double quotes is the user's own text quoted (a CSV field, cut at 40 characters)
        let in_quotes = i > 0 && chars[i - 1] == '"' && chars.get(j) == Some(&'"');
        match token.parse::<f64>() {
            Ok(v) if ends && digits > 20 && v.is_finite() && !in_quotes => out.push_str(&num(v)),
            _ => out.push_str(&token),
        }
        i = j;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_numerals_are_compacted_and_nothing_else() {
        // how Rust's Display writes these values, built independently of the code under test
        let huge = format!("1{}", "0".repeat(308));
        let tiny = format!("0.{}1", "0".repeat(299));
        let line = format!("--x: must be in (0, 1), got {huge}; and -{tiny}.");
        assert_eq!(compact_numerals(&line), "--x: must be in (0, 1), got 1e308; and -1e-300.");
        assert_eq!(compact_numerals(&format!("(got {})", f64::MAX)), "(got 1.798e308)");
        assert_eq!(compact_numerals("got 0.000000000000000000001"), "got 1e-21");
        // a file named by a long numeral keeps its name
        let name = "123456789012345678901234.csv: line 2: NaN";
        assert_eq!(compact_numerals(name), name);
        // a quoted field is shown as written
        let field = format!("line 2, column 1: \"{}\"... (41 characters) is out of range", "9".repeat(40));
        assert_eq!(compact_numerals(&field), field);
        // ordinary numbers, numerals in file names and words, and 64-bit integers are left as they are
        for keep in [
            "got 0.0234 at 420 Hz, 1800.5 rpm",
            "data/1234567890123456789.wav: not found",
            "rec-12345678901234567890-a.wav",
            "teeth 18446744073709551615 (u64::MAX)",
        ] {
            assert_eq!(compact_numerals(keep), keep);
        }
    }

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
