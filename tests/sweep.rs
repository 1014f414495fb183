//! Sweeps: trusted points where the solver met its tolerance, unstable points found, all-failed refused.

mod common;
use common::*;

#[test]
fn light_damping_sweep_trusts_its_points_and_finds_the_tongues() {
    // once 1843 of 2000 points were marked untrusted by cond(I - Phi) of the unscaled state
    let dir = temp_dir("sweep-light");
    let run = gearvib(&[
        "sweep",
        &repo("data/scenes/hard-gear-light-damping.json"),
        "--param",
        "speed",
        "--from",
        "7000",
        "--to",
        "8000",
        "--steps",
        "101",
        "--report",
        dir.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let v: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    let points = v["points"].as_array().unwrap();
    assert_eq!(points.len(), 101);
    assert!(points.iter().all(|p| p["trusted"] == true), "untrusted points");
    // principal parametric resonance of the mesh near 2 f0 / 1 = 7450 rpm (f0 = 869.3 Hz, 14 teeth):
    // unstable there, stable at the ends
    let unstable: Vec<f64> =
        points.iter().filter(|p| p["stable"] == false).map(|p| p["value"].as_f64().unwrap()).collect();
    assert!(!unstable.is_empty());
    let centre = 2.0 * 869.3 * 60.0 / 14.0;
    assert!(unstable.iter().all(|s| (s - centre).abs() < 150.0), "{unstable:?} around {centre}");
    assert!(dir.join("sweep.json").exists() && dir.join("stability-map-hard-gear-light-damping.png").exists());
    assert!(!dir.join("sweep.partial.jsonl").exists(), "the partial record is removed once complete");
}

#[test]
fn sweep_where_every_point_fails_is_an_error() {
    // every speed below zero is refused by the scene's validation
    let run = gearvib(&[
        "sweep",
        &repo("data/scenes/paper-gear-fig8a.json"),
        "--param",
        "speed",
        "--from",
        "-10",
        "--to",
        "-1",
        "--steps",
        "5",
    ]);
    assert_one_line_error(&run, &["every one of the 5 sweep points failed", "speed_rpm"]);
}
