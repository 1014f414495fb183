//! The stored healthy profile (issue 26, item 2): `learn` then `diagnose --profile` gives exactly what
//! `diagnose --baseline` gives in one call; a profile is readable JSON, refused with the field named when
//! damaged, and refused when it does not fit the recording.

mod common;
use common::*;
use serde_json::Value;

const HEALTHY: &str = "data/recordings/gear-z14z39-fs10kHz-healthy.wav";
const FAULTS: [&str; 3] = [
    "data/recordings/gear-z14z39-fs10kHz-cracked-pinion-tooth3.wav",
    "data/recordings/gear-z14z39-fs10kHz-pitted-pinion-tooth3.wav",
    "data/recordings/gear-z14z39-fs10kHz-wheel-eccentricity.wav",
];

fn json_of(run: &Run) -> Value {
    assert!(run.code == 0 || run.code == 3, "exit {}: {}", run.code, run.stderr);
    serde_json::from_str(run.stdout.lines().next().unwrap()).unwrap()
}

fn learn(dir: &std::path::Path, extra: &[&str]) -> String {
    let out = dir.join("profile.json").to_string_lossy().into_owned();
    let mut args = vec!["learn", &HEALTHY_PATH, "-o", &out];
    args.extend_from_slice(extra);
    let run = gearvib(&args.iter().map(|s| s.as_ref()).collect::<Vec<&str>>());
    assert_eq!(run.code, 0, "{}", run.stderr);
    out
}

static HEALTHY_PATH: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| repo(HEALTHY));

#[test]
fn profile_gives_the_same_verdict_and_scores_as_the_baseline() {
    let dir = temp_dir("profile-same");
    let profile = learn(&dir, &["--teeth", "14,39", "--rpm", "1800"]);
    let text = std::fs::read_to_string(&profile).unwrap();
    let p: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(p["format"], "gearvib healthy profile");
    assert_eq!(p["processing"]["teeth"], serde_json::json!([14, 39]));
    for f in FAULTS.iter().chain([&HEALTHY]) {
        let rec = repo(f);
        let a = json_of(&gearvib(&["diagnose", &rec, "--profile", &profile, "--json"]));
        let b = json_of(&gearvib(&[
            "diagnose",
            &rec,
            "--teeth",
            "14,39",
            "--rpm",
            "1800",
            "--baseline",
            &HEALTHY_PATH,
            "--json",
        ]));
        assert_eq!(a["verdict"]["state"], b["verdict"]["state"], "{f}");
        assert_eq!(a["verdict"]["gear"], b["verdict"]["gear"], "{f}");
        // every score the same: the profile holds the distributions the one-call baseline builds (a JSON
        // round trip of f64 is exact, so only the last bits of a re-summed mean could differ)
        let scores = |x: &Value| -> Vec<(String, f64)> {
            x["scores"]
                .as_array()
                .map(|v| v.iter().map(|s| (s["indicator"].to_string(), s["spreads"].as_f64().unwrap())).collect())
                .unwrap_or_default()
        };
        let (sa, sb) = (scores(&a), scores(&b));
        assert_eq!(sa.len(), sb.len(), "{f}");
        assert!(sa.len() >= 8, "{f}: every deciding indicator of both gears is scored");
        for ((ka, va), (kb, vb)) in sa.iter().zip(&sb) {
            assert_eq!(ka, kb);
            assert!((va - vb).abs() <= 1e-9 * vb.abs().max(1.0), "{f}: {ka} {va} against {vb}");
        }
    }
    // the profile is what the verdicts rest on: the healthy recording against it is healthy, the faults
    // are not (the bundled scenes' truths: cracked and pitted pinion, eccentric wheel)
    let verdict =
        |f: &str| json_of(&gearvib(&["diagnose", &repo(f), "--profile", &profile, "--json"]))["verdict"].clone();
    assert_eq!(verdict(HEALTHY)["state"], "healthy");
    assert_eq!(verdict(FAULTS[0])["gear"], "pinion");
    assert_eq!(verdict(FAULTS[2])["gear"], "wheel");
}

#[test]
fn damaged_profiles_are_refused_naming_the_field() {
    let dir = temp_dir("profile-damaged");
    let profile = learn(&dir, &["--teeth", "14,39"]);
    let good: Value = serde_json::from_str(&std::fs::read_to_string(&profile).unwrap()).unwrap();
    let rec = repo(FAULTS[0]);
    let cases: Vec<(&str, Value, &[&str])> = vec![
        ("version", serde_json::json!({"version": 99}), &["version 99"]),
        ("format", serde_json::json!({"format": "something else"}), &["not a gearvib profile"]),
        ("unknown", serde_json::json!({"extra_field": 1}), &["extra_field"]),
        ("teeth", serde_json::json!({"processing": {"teeth": [1, 39]}}), &["processing.teeth"]),
        ("block", serde_json::json!({"processing": {"block_revs": 0}}), &["processing.block_revs"]),
        ("type", serde_json::json!({"geometry": {"tsa_points": "many"}}), &["geometry.tsa_points"]),
        // the command line's bounds, said with the profile's field rather than a flag never given
        ("blocks", serde_json::json!({"processing": {"block_revs": 1_000_000_000_000u64}}), &["processing.block_revs"]),
        (
            "revolutions",
            serde_json::json!({"processing": {"min_revolutions": 1_000_000_000_000u64}}),
            &["processing.min_revolutions"],
        ),
        ("no revolutions", serde_json::json!({"processing": {"min_revolutions": 0}}), &["processing.min_revolutions"]),
        ("fs", serde_json::json!({"processing": {"fs_hz": -5.0}}), &["processing.fs_hz"]),
        ("speed", serde_json::json!({"baseline": {"speed_hz": -30.0}}), &["baseline.speed_hz"]),
        ("rate", serde_json::json!({"baseline": {"sample_rate_hz": 0.0}}), &["baseline.sample_rate_hz"]),
        ("period", serde_json::json!({"baseline": {"shaft_period_samples": 0.0}}), &["baseline.shaft_period_samples"]),
        ("band", serde_json::json!({"geometry": {"envelope_band": [3000.0, 1000.0]}}), &["envelope_band"]),
        (
            "wide",
            serde_json::json!({"geometry": {"envelope_band": [1000.0, 1e9]}}),
            &["half the baseline's sample rate"],
        ),
        // found on reading the recording, said with the profile's field too (it named --tacho-channel)
        (
            "tacho",
            serde_json::json!({"processing": {"tacho_channel": 99}}),
            &["processing.tacho_channel", "channel 99"],
        ),
    ];
    for (name, patch, needles) in cases {
        let mut v = good.clone();
        merge(&mut v, &patch);
        let path = write(&dir, &format!("{name}.json"), &v.to_string());
        let run = gearvib(&["diagnose", &rec, "--profile", &path]);
        assert_eq!(run.code, 2, "{name}: {}", run.stdout);
        assert_one_line_error(&run, needles);
    }
    // truncated and empty files, a directory
    let text = std::fs::read_to_string(&profile).unwrap();
    for (name, body) in [("truncated", &text[..text.len() / 2]), ("empty", "")] {
        let path = write(&dir, &format!("{name}.json"), body);
        let run = gearvib(&["diagnose", &rec, "--profile", &path]);
        assert_eq!(run.code, 2, "{name}");
        assert_one_line_error(&run, &[&path]);
    }
    let run = gearvib(&["diagnose", &rec, "--profile", dir.to_str().unwrap()]);
    assert_one_line_error(&run, &["not a regular file"]);
}

#[test]
fn a_profile_that_does_not_fit_the_recording_is_refused() {
    let dir = temp_dir("profile-misfit");
    let profile = learn(&dir, &["--teeth", "14,39"]);
    // a recording in another unit (the same samples said to be in g): not comparable
    let bare = dir.join("bare.wav");
    std::fs::copy(repo(FAULTS[0]), &bare).unwrap();
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(&profile).unwrap()).unwrap();
    v["baseline"]["unit"] = "g".into();
    let other = write(&dir, "other-unit.json", &v.to_string());
    let run = gearvib(&["diagnose", &repo(FAULTS[0]), "--profile", &other]);
    assert_one_line_error(&run, &["in g and the recording in m/s"]);
    // flags that the profile fixes cannot be given with it
    let run = gearvib(&["diagnose", &repo(FAULTS[0]), "--profile", &profile, "--teeth", "14,39"]);
    assert_one_line_error(&run, &["--teeth", "--profile"]);
}

fn merge(v: &mut Value, patch: &Value) {
    match (v, patch) {
        (Value::Object(a), Value::Object(b)) => {
            for (k, pv) in b {
                match a.get_mut(k) {
                    Some(av) if pv.is_object() => merge(av, pv),
                    _ => {
                        a.insert(k.clone(), pv.clone());
                    }
                }
            }
        }
        (v, p) => *v = p.clone(),
    }
}

/// Healthy recordings of another recorder cannot be one baseline: the bundled healthy WAV with its
/// sidecar (m/s) and its copy without one (the file's own scale, no unit) are refused naming both, in
/// either order (the order once decided whether a mixed baseline was learned at all).
#[test]
fn healthy_files_in_different_units_are_not_one_baseline() {
    let dir = temp_dir("mixed-recorders");
    let bare = dir.join("bare.wav");
    std::fs::copy("data/recordings/gear-z14z39-fs10kHz-healthy.wav", &bare).unwrap();
    let bare = bare.to_string_lossy().into_owned();
    let out = dir.join("p.json").to_string_lossy().into_owned();
    let with_unit = "data/recordings/gear-z14z39-fs10kHz-healthy.wav";
    // "-" is no file: it once wrote a profile named "-"
    let run = gearvib(&["learn", with_unit, "-o", "-"]);
    assert_one_line_error(&run, &["-o -", "standard output"]);
    for pair in [[with_unit, bare.as_str()], [bare.as_str(), with_unit]] {
        let run = gearvib(&["learn", pair[0], pair[1], "--teeth", "14,39", "-o", &out]);
        assert_one_line_error(&run, &["cannot be one baseline", "units differ", "bare.wav"]);
        assert!(!std::path::Path::new(&out).exists());
    }
}

/// A CSV without a time column is judged against a profile with its sample rate given (`--fs` describes
/// the file, not the machine, so it may go with `--profile`): the cracked pinion's samples as such a CSV
/// get the WAV's verdict and gear against the profile learned from the healthy WAV.
#[test]
fn a_csv_without_time_is_judged_against_a_profile_with_its_rate_given() {
    let dir = temp_dir("profile-csv");
    let profile = learn(&dir, &["--teeth", "14,39"]);
    let rec = gearvib::io::read_recording(std::path::Path::new(&repo(FAULTS[0]))).unwrap();
    let header: Vec<String> = rec
        .names
        .iter()
        .zip(&rec.units)
        .map(|(n, u)| if u.is_empty() { n.clone() } else { format!("{n} [{u}]") })
        .collect();
    let mut text = header.join(",") + "\n";
    for i in 0..rec.channels[0].len() {
        let row: Vec<String> = rec.channels.iter().map(|c| format!("{:e}", c[i])).collect();
        text.push_str(&(row.join(",") + "\n"));
    }
    let csv = write(&dir, "cracked.csv", &text);
    let wav = json_of(&gearvib(&["diagnose", &repo(FAULTS[0]), "--profile", &profile, "--json"]));
    let run = gearvib(&["diagnose", &csv, "--profile", &profile, "--fs", "10000", "--json"]);
    let csv_d = json_of(&run);
    assert_eq!(csv_d["verdict"]["state"], wav["verdict"]["state"], "{}", csv_d["verdict"]);
    assert_eq!(csv_d["verdict"]["gear"], wav["verdict"]["gear"], "{}", csv_d["verdict"]);
}
