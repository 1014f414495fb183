//! Seeded mutation test: more than 2,000 mutants of the bundled WAV, CSV, sidecar and scene files (bit
//! flips, truncation at every header byte, chunk sizes and fmt fields at extremes, NaN/Inf/1e308/-0 in
//! scenes and data, deep nesting, duplicate keys, long strings, BOM, CRLF, mixed separators) run through
//! the library entry points in this process. Each must return a result or an error naming its input,
//! without a panic and without any single allocation above a stated ceiling (a counting global allocator),
//! within a per-case bound that only a hang would exceed.

mod common;
use common::mutants::{self, XorShift};
use common::*;
use std::path::Path;

#[global_allocator]
static ALLOCATOR: mutants::Counting = mutants::Counting;

/// No input here is over 4 MB: 256 MiB in one request can only come from a size believed from a header
/// or an absurd value.
const CEILING: usize = 256 << 20;
/// Seconds a case may take before it counts as a hang (the slowest legitimate case takes well under 1 s).
const HANG_S: f64 = 30.0;

/// Runs one case (`mutants::case` with this test's ceiling and hang bound).
fn case(path: &Path, f: impl FnOnce(&Path) -> Result<(), String> + std::panic::UnwindSafe) {
    mutants::case(path, CEILING, HANG_S, f);
}

fn diagnose(path: &Path) -> Result<(), String> {
    let opts = gearvib::jobs::diagnose::Options::default();
    gearvib::jobs::diagnose::diagnose(path, &opts, None).map(|_| ()).map_err(|e| e.to_string())
}

fn simulate(path: &Path) -> Result<(), String> {
    let scene = gearvib::scene::Scene::load(&path.to_string_lossy()).map_err(|e| e.to_string())?;
    gearvib::jobs::simulate::simulate(&scene).map(|_| ()).map_err(|e| format!("{}: {e}", scene.file))
}

fn wav_mutants(rng: &mut XorShift, wav: &[u8]) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    // truncation at every header byte and a few data lengths
    for n in (0..=72).chain([100, 1001, 4096, wav.len() / 2, wav.len() - 1]) {
        out.push(wav[..n.min(wav.len())].to_vec());
    }
    // 32-bit size fields (RIFF size, fmt size, data size) and 16/32-bit fmt fields at extremes
    let fields32 = [4usize, 16, 24, 28];
    let fields16 = [20usize, 22, 32, 34, 36, 38, 40];
    let data_size_at = wav.windows(4).position(|w| w == b"data").map_or(64, |p| p + 4);
    for at in fields32.iter().copied().chain([data_size_at]) {
        for v in [0u32, 1, 2, 3, 0x7FFF_FFFF, 0xFFFF_FFFF, 0x8000_0000, 44, 45] {
            let mut m = wav.to_vec();
            m[at..at + 4].copy_from_slice(&v.to_le_bytes());
            out.push(m);
        }
    }
    for at in fields16 {
        for v in [0u16, 1, 2, 7, 8, 24, 33, 64, 0x7FFF, 0xFFFF, 3, 0xFFFE] {
            let mut m = wav.to_vec();
            m[at..at + 2].copy_from_slice(&v.to_le_bytes());
            out.push(m);
        }
    }
    // random bit flips, mostly in the header, and random bytes
    for i in 0..500 {
        let mut m = wav.to_vec();
        for _ in 0..1 + i % 4 {
            let at = if i % 3 == 0 { rng.below(m.len()) } else { rng.below(80) };
            m[at] ^= 1 << rng.below(8);
        }
        out.push(m);
    }
    out
}

fn csv_mutants(rng: &mut XorShift, csv: &str) -> Vec<String> {
    let mut out = Vec::new();
    let lines: Vec<&str> = csv.lines().collect();
    for n in [0, 1, 2, 3, 10, lines.len() / 2] {
        out.push(lines[..n.min(lines.len())].join("\n"));
    }
    out.push(format!("\u{feff}{csv}"));
    out.push(csv.replace('\n', "\r\n"));
    out.push(csv.replace(',', ";"));
    out.push(csv.replace(',', "\t"));
    for (i, v) in ["NaN", "inf", "-inf", "1e308", "-0", "1e-320", "", "x", "\"1\"", "1,5", "0x10"].iter().enumerate() {
        let mut ls: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
        let row = 1 + i % (ls.len() - 1);
        let mut fields: Vec<String> = ls[row].split(',').map(String::from).collect();
        let col = i % fields.len();
        fields[col] = v.to_string();
        ls[row] = fields.join(",");
        out.push(ls.join("\n"));
    }
    // mixed separators and random byte edits
    for _ in 0..250 {
        let mut b = csv.as_bytes().to_vec();
        for _ in 0..3 {
            let at = rng.below(b.len());
            let alphabet = b",;\t\n.-e0123456789 \"\r";
            b[at] = alphabet[rng.below(alphabet.len())];
        }
        out.push(String::from_utf8_lossy(&b).into_owned());
    }
    out
}

fn json_mutants(rng: &mut XorShift, v: &serde_json::Value) -> Vec<String> {
    let text = v.to_string();
    let mut out = Vec::new();
    // every number in turn replaced by an extreme
    let numbers: Vec<usize> = text.match_indices(|c: char| c.is_ascii_digit()).map(|(i, _)| i).collect();
    for (k, bad) in ["NaN", "Infinity", "1e308", "-1e308", "-0", "1e-320", "0", "-1", "1e999", "\"x\"", "null", "[]"]
        .iter()
        .enumerate()
    {
        for j in 0..40 {
            let at = numbers[(k * 131 + j * 977) % numbers.len()];
            let end =
                text[at..].find(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c))).map_or(text.len(), |e| at + e);
            let start = text[..at].rfind(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c))).map_or(0, |s| s + 1);
            out.push(format!("{}{}{}", &text[..start], bad, &text[end..]));
        }
    }
    // truncations, deep nesting, duplicate keys, long strings
    for n in (0..text.len()).step_by((text.len() / 60).max(1)) {
        out.push(text[..n].to_string());
    }
    out.push(format!("{}{}", "[".repeat(100_000), "]".repeat(100_000)));
    out.push(format!("{{\"model\": {}1{}}}", "[".repeat(5000), "]".repeat(5000)));
    out.push(text.replacen("{", "{\"model\": \"ltp\", ", 1));
    out.push(text.replacen("\"name\"", &format!("\"name\": \"{}\", \"name\"", "x".repeat(1 << 20)), 1));
    out.push(format!("\u{feff}{text}"));
    out.push(text.replace(',', ",\r\n"));
    for _ in 0..150 {
        let mut b = text.as_bytes().to_vec();
        let at = rng.below(b.len());
        let alphabet = b"{}[]:,\"0123456789-e.";
        b[at] = alphabet[rng.below(alphabet.len())];
        out.push(String::from_utf8_lossy(&b).into_owned());
    }
    out
}

#[test]
fn two_thousand_mutants_fail_cleanly() {
    let dir = temp_dir("mutants");
    let mut rng = XorShift(0x9E37_79B9_7F4A_7C15);
    let mut count = 0;
    // WAV (integer, extensible header, 3 channels) with and without its sidecar
    let wav = std::fs::read(repo("data/recordings/gear-z14z39-fs10kHz-healthy.wav")).unwrap();
    let sidecar = std::fs::read_to_string(repo("data/recordings/gear-z14z39-fs10kHz-healthy.wav.json")).unwrap();
    for (i, m) in wav_mutants(&mut rng, &wav).iter().enumerate() {
        let p = dir.join(format!("w{i}.wav"));
        std::fs::write(&p, m).unwrap();
        case(&p, |p| gearvib::io::read_recording(p).map(|_| ()).map_err(|e| e.to_string()));
        if i % 8 == 0 {
            case(&p, diagnose);
        }
        count += 1;
    }
    // sidecar mutants next to an intact WAV
    let side_v: serde_json::Value = serde_json::from_str(&sidecar).unwrap();
    for (i, m) in json_mutants(&mut rng, &side_v).iter().enumerate().take(300) {
        let p = dir.join(format!("s{i}.wav"));
        std::fs::write(&p, &wav).unwrap();
        std::fs::write(dir.join(format!("s{i}.wav.json")), m).unwrap();
        case(&p, |p| gearvib::io::read_recording(p).map(|_| ()).map_err(|e| e.to_string()));
        count += 1;
    }
    // CSV: the first 3000 rows of a real recording
    let csv: String = std::fs::read_to_string(repo("data/realdata/h30hz0.csv"))
        .unwrap()
        .lines()
        .take(3000)
        .collect::<Vec<_>>()
        .join("\n");
    for (i, m) in csv_mutants(&mut rng, &csv).iter().enumerate() {
        let p = dir.join(format!("c{i}.csv"));
        std::fs::write(&p, m).unwrap();
        case(&p, |p| gearvib::io::read_recording(p).map(|_| ()).map_err(|e| e.to_string()));
        count += 1;
    }
    // scenes: a gear pair and an ltp, loaded and simulated
    for scene in ["data/scenes/gear-z14z39-healthy.json", "data/scenes/paper-press-case1.json"] {
        let v = read_json(&repo(scene));
        for (i, m) in json_mutants(&mut rng, &v).iter().enumerate() {
            let p = dir.join(format!("j{count}-{i}.json"));
            std::fs::write(&p, m).unwrap();
            case(&p, simulate);
            count += 1;
        }
    }
    assert!(count >= 2000, "{count} mutants");
    eprintln!("{count} mutants");
}
