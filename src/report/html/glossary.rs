//! The glossary at the end of a page: every term the page uses, explained once.

use super::escape;
use std::fmt::Write as _;

/// The terms a page may use, each explained once in the glossary at its end: (term as shown, the words
/// that reveal it on the page, explanation). Definitions as in `signal::indicators` (after Lebold et al.
/// 2000, Decker 2002, Zakrajsek et al. 1993; see the project's diagnostics reference).
const GLOSSARY: &[(&str, &[&str], &str)] = &[
    (
        "TSA (time-synchronous average)",
        &["TSA", "time-synchronous"],
        "the signal resampled on the tracked angle of one shaft and averaged over its revolutions: what does not repeat with that shaft (noise, the other gear) averages out.",
    ),
    (
        "residual signal",
        &["residual"],
        "the TSA without the shaft orders 1-2 and the mesh harmonics: what is left shows a local fault on one tooth.",
    ),
    (
        "difference signal",
        &["difference"],
        "the residual also without the first-order sidebands of the mesh harmonics; FM4, M6A and M8A are computed on it.",
    ),
    (
        "FM0",
        &["FM0"],
        "peak-to-peak of the TSA divided by the sum of the mesh-harmonic amplitudes: rises with a broken tooth or heavy wear.",
    ),
    (
        "FM4",
        &["FM4"],
        "kurtosis (normalised 4th moment) of the difference signal: about 3 for a healthy gear, above 3 when one or a few teeth are damaged.",
    ),
    (
        "M6A, M8A",
        &["M6A", "M8A"],
        "6th and 8th normalised moments of the difference signal (15 and 105 for Gaussian noise): more sensitive to single peaks than FM4.",
    ),
    (
        "NA4",
        &["NA4"],
        "kurtosis of the residual signal normalised by the mean variance of the residuals of all recordings so far in time order: about 3 when healthy, and it keeps growing as damage spreads.",
    ),
    (
        "NA4*",
        &["NA4*"],
        "NA4 normalised by the residual variance of the healthy baseline only (Decker): a different number from NA4 when a baseline is given.",
    ),
    (
        "ER (energy ratio)",
        &["ER "],
        "RMS of the difference signal over RMS of the regular (mesh) signal: rises with wear spread over many teeth.",
    ),
    (
        "SI, SLF, SER",
        &["SI", "SLF", "SER"],
        "sideband indicators around the first mesh harmonic: SI the mean of the first sideband pair, SLF that pair over the TSA RMS, SER the six sideband pairs over the mesh line (above 1: the sidebands outweigh the mesh).",
    ),
    (
        "kurtosis, crest factor, RMS",
        &["kurtosis", "crest", "RMS"],
        "4th normalised moment (3 for Gaussian noise), peak over RMS, and root mean square of the signal named.",
    ),
    ("spectral change", &["spectral change"], "the distance in dB of a block's order spectrum from the baseline's."),
    (
        "local change",
        &["local change"],
        "the gear's residual signal less the baseline's mean residual (shifted to the same angle and scaled to the same load): the energy of that difference over the tooth pitch where it is largest, over the median pitch's. Healthy recordings differ by 1.5-4; a crack, spall or broken tooth raises it at its tooth. It counts from 2.5 times what the baseline's own files show among themselves.",
    ),
    (
        "sideband growth",
        &["sideband growth"],
        "the same difference's energy at every mesh harmonic's first-order sidebands over the baseline's own energy there: an eccentric or unevenly worn gear modulates its mesh once per revolution and raises it. It counts from 3 times what the baseline's files show among themselves, and at least 8.",
    ),
    (
        "spreads",
        &["spreads"],
        "how far an indicator lies from the healthy baseline's centre, in units of the baseline's spread (1.4826 times the median absolute deviation of its blocks, on a logarithmic scale for ratio indicators): a robust z-score.",
    ),
    (
        "suspect and faulty limits",
        &["suspect at", "suspect limit", "faulty at", "faulty limit"],
        "Student-t prediction limits in spreads for a false-alarm rate of 1e-3 (suspect) and 1e-6 (faulty) per indicator, given the number of baseline blocks.",
    ),
    (
        "baseline",
        &["baseline"],
        "healthy recordings of the same machine, cut into blocks of whole revolutions; their indicators' spread sets the limits.",
    ),
    (
        "mesh harmonic, order",
        &["mesh", "order"],
        "the tooth-mesh frequency (teeth times shaft speed) and its multiples; an order is a multiple of a shaft's rotation, so lines stay at the same order when the speed changes.",
    ),
    (
        "sideband",
        &["sideband"],
        "a line beside a mesh harmonic at a multiple of a shaft's speed: modulation by that shaft (eccentricity, a cracked or pitted tooth). Marked only when 12 dB over the local noise floor.",
    ),
    (
        "kurtogram, spectral kurtosis",
        &["kurtogram", "spectral kurtosis"],
        "the kurtosis of the signal filtered in bands of halving widths (levels): impulsive bands (a fault's impacts) stand out; 0 for Gaussian noise.",
    ),
    (
        "envelope spectrum",
        &["envelope"],
        "the spectrum of the squared envelope of one band, in orders of the tracked shaft: a local fault gives a line at its shaft's order.",
    ),
    (
        "cepstrum, rahmonic",
        &["cepstrum"],
        "the inverse transform of the log power spectrum; a family of equally spaced lines (one shaft's sidebands) becomes one peak and its rahmonics at the shaft's period.",
    ),
    (
        "rpm-order map",
        &["order map", "rpm-order"],
        "order spectra of successive groups of revolutions against their speed: lines of the machine stay vertical, a resonance crosses them.",
    ),
    (
        "Floquet multipliers, |rho|max",
        &["multiplier"],
        "eigenvalues of the monodromy matrix of the periodic system; stable when all lie inside the unit circle (|rho|max < 1).",
    ),
    (
        "chi2/dof",
        &["chi2"],
        "the fit's weighted squared residual per degree of freedom: about 1 when the model explains the lines to their noise.",
    ),
    (
        "velocity RMS, ISO zones",
        &["velocity RMS"],
        "the RMS vibration velocity over 10-1000 Hz in mm/s; the zones A (new), B (long-term), C (limited time), D (damaging) of ISO 10816-3 / 20816-3 for the machine class given.",
    ),
];

/// Whether `needle` occurs in `text` as a whole word (acronyms must not match inside other words).
fn has_word(text: &str, needle: &str) -> bool {
    let word = |c: Option<char>| c.is_some_and(|c| c.is_alphanumeric());
    text.match_indices(needle).any(|(i, _)| {
        let before = text[..i].chars().next_back();
        let after = text[i + needle.len()..].chars().next();
        // lower-case words may take an ending ("sidebands"); acronyms may not ("SI" is not in "SIDE")
        !word(before) && (!word(after) || needle.chars().any(char::is_lowercase))
    })
}

/// The glossary of the terms `page` uses, appended to it.
pub(super) fn glossary(page: &mut String) {
    // the page's words, without the embedded images
    let text: String = page.split("data:image/png;base64,").map(|p| p.split_once('"').map_or(p, |x| x.1)).collect();
    let used: Vec<_> = GLOSSARY.iter().filter(|(_, needles, _)| needles.iter().any(|n| has_word(&text, n))).collect();
    if used.is_empty() {
        return;
    }
    page.push_str("<section><h2>Glossary</h2><dl class=\"glossary\">");
    for (term, _, meaning) in used {
        let _ = write!(page, "<dt>{}</dt><dd>{}</dd>", escape(term), escape(meaning));
    }
    page.push_str("</dl></section>\n");
}
