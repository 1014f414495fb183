//! The same samples through every path give the same answer (issue 26, item 1): a bundled recording as
//! WAV with its sidecar, the WAV copied without its sidecar (samples in the file's own scale, restored
//! with `--unit` and `--sensitivity`), the samples as CSV with a time column, with and without the
//! tachometer, with the speed given exactly, 3 % off (a nameplate speed off by the slip) or not at all
//! (a tachometer, the sidecar's or a named channel, gives the speed beside a given one).
//! Every path must give the same verdict state and gear, and the level-free indicators within stated
//! tolerances of the reference path's.

mod common;
use common::*;
use serde_json::Value;
use std::path::Path;

/// Physical value of integer full scale in the bundled recordings' sidecars.
const FULL_SCALE: f64 = 0.1;

/// The bundled WAV's channels as f64 in physical units (i16 / 32768 x full scale), read with hound.
fn channels(wav: &str) -> (u32, Vec<Vec<f64>>) {
    let mut r = hound::WavReader::open(wav).unwrap();
    let spec = r.spec();
    let n = spec.channels as usize;
    let mut out = vec![Vec::new(); n];
    for (i, s) in r.samples::<i16>().enumerate() {
        out[i % n].push(s.unwrap() as f64 / 32768.0 * FULL_SCALE);
    }
    (spec.sample_rate, out)
}

/// The samples as CSV: a time column in seconds, the vibration in m/s and, with `tacho`, the pinion's
/// pulse channel.
fn write_csv(dir: &Path, name: &str, fs: u32, ch: &[Vec<f64>], tacho: bool) -> String {
    let mut s = String::from(if tacho { "time [s],dq/dt [m/s],tacho\n" } else { "time [s],dq/dt [m/s]\n" });
    for (i, v) in ch[0].iter().enumerate() {
        s.push_str(&format!("{:.7},{v:.9e}", i as f64 / fs as f64));
        if tacho {
            s.push_str(&format!(",{:.4e}", ch[1][i]));
        }
        s.push('\n');
    }
    write(dir, name, &s)
}

fn diagnose_json(args: &[&str]) -> Value {
    let mut all = vec!["diagnose"];
    all.extend_from_slice(args);
    all.push("--json");
    let run = gearvib(&all);
    assert!(run.code == 0, "{all:?}: exit {} {}", run.code, run.stderr);
    serde_json::from_str(run.stdout.lines().next().unwrap()).unwrap()
}

/// Every path for one recording, as (description, arguments).
fn paths(wav: &str, dir: &Path, stem: &str) -> Vec<(String, Vec<String>)> {
    let (fs, ch) = channels(wav);
    let bare = dir.join(format!("{stem}-bare.wav"));
    std::fs::copy(wav, &bare).unwrap();
    let bare = bare.to_string_lossy().into_owned();
    let csv = write_csv(dir, &format!("{stem}.csv"), fs, &ch, false);
    let csv_tacho = write_csv(dir, &format!("{stem}-tacho.csv"), fs, &ch, true);
    let teeth = ["--teeth", "14,39"];
    let mut out: Vec<(String, Vec<String>)> = Vec::new();
    let mut add = |what: &str, args: &[&str]| {
        out.push((what.to_string(), args.iter().chain(teeth.iter()).map(|s| s.to_string()).collect()));
    };
    add("wav + sidecar, tachometer from the sidecar", &[wav]);
    add("wav + sidecar, speed given", &[wav, "--rpm", "1800"]);
    add("wav + sidecar, speed given 3 % low", &[wav, "--rpm", "1746"]);
    add("wav + sidecar, speed given 3 % high", &[wav, "--rpm", "1854"]);
    add("wav without sidecar, unit restored", &[&bare, "--unit", "m/s", "--sensitivity", "10"]);
    add(
        "wav without sidecar, tachometer channel",
        &[&bare, "--unit", "m/s", "--sensitivity", "10", "--tacho-channel", "2", "--channel", "1"],
    );
    add(
        "wav without sidecar, tachometer channel, speed given 3 % low",
        &[&bare, "--unit", "m/s", "--sensitivity", "10", "--tacho-channel", "2", "--channel", "1", "--rpm", "1746"],
    );
    add("csv", &[&csv]);
    add("csv, speed 3 % high", &[&csv, "--rpm", "1854"]);
    add("csv with tachometer", &[&csv_tacho, "--tacho-channel", "2"]);
    out
}

/// The level-free indicators compared between paths, with their tolerance: the tachometer's angle and
/// the mesh-phase angle differ by the tracking's own noise, and a CSV stores 10 significant digits, so
/// the averages differ by far less than a percent; moments of the difference signal (FM4, M6A) amplify
/// that to a few percent on a noisy healthy mesh. 10 % is well inside the baseline spreads that decide.
const LEVEL_FREE: [(&str, f64); 4] = [("fm4", 0.10), ("m6a", 0.15), ("er", 0.10), ("kurtosis", 0.10)];

fn check_same_answer(file: &str, stem: &str, baseline: Option<&str>) {
    let dir = temp_dir(&format!("paths-{stem}-{}", baseline.is_some()));
    let wav = repo(file);
    let base = baseline.map(repo);
    let mut reference: Option<(String, Value)> = None;
    for (what, args) in paths(&wav, &dir, stem) {
        let mut a: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
        if let Some(b) = &base {
            a.extend(["--baseline", b.as_str()]);
        }
        let d = diagnose_json(&a);
        let Some((ref_what, r)) = &reference else {
            reference = Some((what, d));
            continue;
        };
        assert_eq!(d["verdict"]["state"], r["verdict"]["state"], "{stem}: {what} against {ref_what}: {}", d["verdict"]);
        assert_eq!(d["verdict"]["gear"], r["verdict"]["gear"], "{stem}: {what} against {ref_what}: {}", d["verdict"]);
        // the measured speed is the same whatever was given (a nominal speed is searched)
        let speed = |x: &Value| x["shaft_hz"]["pinion"].as_f64().unwrap();
        assert!(rel(speed(&d), speed(r)) < 1e-3, "{stem}: {what}: speed {} against {}", speed(&d), speed(r));
        for (k, tol) in LEVEL_FREE {
            let (x, y) = (d["indicators"][k].as_f64().unwrap(), r["indicators"][k].as_f64().unwrap());
            assert!(rel(x, y) < tol, "{stem}: {what}: {k} {x} against {y} ({ref_what})");
        }
    }
}

#[test]
fn healthy_recording_same_answer_through_every_path() {
    check_same_answer("data/recordings/gear-z14z39-fs10kHz-healthy.wav", "healthy", None);
}

#[test]
fn cracked_recording_same_answer_through_every_path() {
    check_same_answer("data/recordings/gear-z14z39-fs10kHz-cracked-pinion-tooth3.wav", "cracked", None);
}

#[test]
fn healthy_against_itself_is_healthy_through_every_path() {
    let base = "data/recordings/gear-z14z39-fs10kHz-healthy.wav";
    check_same_answer(base, "healthy-self", Some(base));
}

#[test]
fn cracked_against_the_healthy_is_faulty_on_the_pinion_through_every_path() {
    check_same_answer(
        "data/recordings/gear-z14z39-fs10kHz-cracked-pinion-tooth3.wav",
        "cracked-base",
        Some("data/recordings/gear-z14z39-fs10kHz-healthy.wav"),
    );
}

/// A baseline directory that holds the recording under test: the recording is left out of the baseline
/// and said to be, and the cracked pinion is faulty against the healthy file alone (it was HEALTHY
/// against "2 healthy recordings", itself among them). A file given twice counts once (said), and `learn`
/// refuses it. The cracked recording against itself alone cannot show a change: it is judged on the
/// absolute limits, as without a baseline (the same verdict as with none), never healthy for want of a
/// change.
#[test]
fn a_recording_is_never_its_own_baseline_among_others() {
    let dir = temp_dir("baseline-holds-recording");
    for name in ["cracked-pinion-tooth3", "healthy"] {
        let src = format!("data/recordings/gear-z14z39-fs10kHz-{name}.wav");
        std::fs::copy(&src, dir.join(format!("{name}.wav"))).unwrap();
        std::fs::copy(format!("{src}.json"), dir.join(format!("{name}.wav.json"))).unwrap();
    }
    let cracked = dir.join("cracked-pinion-tooth3.wav").to_string_lossy().into_owned();
    let healthy = dir.join("healthy.wav").to_string_lossy().into_owned();
    let dir_s = dir.to_string_lossy().into_owned();
    let run = gearvib(&["diagnose", &cracked, "--baseline", &dir_s, "--baseline", &healthy, "--json"]);
    let d: Value = serde_json::from_str(run.stdout.lines().next().unwrap()).unwrap();
    assert_eq!(d["verdict"]["state"], "faulty", "{}", d["verdict"]);
    assert_eq!(d["verdict"]["gear"], "pinion", "{}", d["verdict"]);
    let warnings = d["warnings"].to_string();
    assert!(warnings.contains("left out of the baseline: it is also under test"), "{warnings}");
    assert!(warnings.contains("given twice as a baseline: it counts once"), "{warnings}");
    let learn = gearvib(&["learn", &healthy, &dir_s, "-o", &dir.join("p.json").to_string_lossy()]);
    assert_one_line_error(&learn, &["healthy.wav", "given twice"]);
    assert!(!dir.join("p.json").exists());
    // against itself alone: the absolute limits, as without a baseline
    let alone = gearvib(&["diagnose", &cracked, "--json"]);
    let alone: Value = serde_json::from_str(alone.stdout.lines().next().unwrap()).unwrap();
    let selfish = gearvib(&["diagnose", &cracked, "--baseline", &cracked, "--json"]);
    let selfish: Value = serde_json::from_str(selfish.stdout.lines().next().unwrap()).unwrap();
    assert_ne!(alone["verdict"]["state"], "healthy", "{}", alone["verdict"]);
    assert_eq!(selfish["verdict"]["state"], alone["verdict"]["state"], "{}", selfish["verdict"]);
    assert_eq!(selfish["verdict"]["gear"], alone["verdict"]["gear"], "{}", selfish["verdict"]);
    assert!(selfish["warnings"].to_string().contains("judged on the absolute limits"), "{}", selfish["warnings"]);
}
