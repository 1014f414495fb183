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

fn teeth_sweep(from: &str, to: &str, steps: &str) -> Run {
    gearvib(&[
        "sweep",
        &repo("data/scenes/paper-gear-fig8a.json"),
        "--param",
        "gear_pair.pinion.teeth",
        "--from",
        from,
        "--to",
        to,
        "--steps",
        steps,
        "--json",
    ])
}

#[test]
fn a_whole_number_parameter_is_swept_in_distinct_whole_values() {
    let run = teeth_sweep("10", "20", "6");
    assert_eq!(run.code, 0, "{}", run.stderr);
    let v: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    let points = v["points"].as_array().unwrap();
    // six values evenly from 10 to 20 are 10, 12, ..., 20: whole already
    let values: Vec<f64> = points.iter().map(|p| p["value"].as_f64().unwrap()).collect();
    assert_eq!(values, [10.0, 12.0, 14.0, 16.0, 18.0, 20.0]);
    for p in points {
        assert!(p["error"].is_null(), "{p}");
        // each point's mesh lines are at its own tooth count
        let z = p["value"].as_f64().unwrap();
        assert_eq!(p["lines"][0][0], format!("1x mesh (order {z})"));
    }
    // the point at the scene's own 14 teeth is the scene itself: simulate gives the same multipliers and
    // mesh line (two solves of one scene, each within solver.tolerance 1e-8: far below 1e-6 apart)
    let sim = gearvib(&["simulate", &repo("data/scenes/paper-gear-fig8a.json"), "--json"]);
    let s: serde_json::Value = serde_json::from_str(&sim.stdout).unwrap();
    let line14 = s["orders"].as_array().unwrap().iter().find(|o| o["order"] == 14.0).unwrap()["amplitude"].as_f64();
    let p14 = &points[2];
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * b.abs();
    assert!(close(p14["rho_max"].as_f64().unwrap(), s["rho_max"].as_f64().unwrap()));
    assert!(close(p14["lines"][0][1].as_f64().unwrap(), line14.unwrap()));
    // Liouville: the product of the two multipliers is exp(-(c/m) T), set by the damping and the period, not
    // the teeth; a complex pair has modulus its square root, so |rho|max is the same at every tooth count
    // (to the multipliers' error estimate, about 1e-10 here)
    let rho: Vec<f64> = points.iter().map(|p| p["rho_max"].as_f64().unwrap()).collect();
    assert!(rho.iter().all(|r| close(*r, rho[0])), "{rho:?}");
    // a count with a fraction is rounded: 10.4 to 13.6 has the whole numbers 11, 12, 13
    let run = teeth_sweep("10.4", "13.6", "3");
    let v: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    let values: Vec<f64> = v["points"].as_array().unwrap().iter().map(|p| p["value"].as_f64().unwrap()).collect();
    assert_eq!(values, [11.0, 12.0, 13.0]);
}

#[test]
fn more_whole_values_than_the_range_holds_is_refused_naming_steps() {
    assert_one_line_error(&teeth_sweep("10", "12", "7"), &["--steps", "gear_pair.pinion.teeth", "holds 3", "7 values"]);
    assert_one_line_error(&teeth_sweep("10.2", "10.8", "2"), &["--steps", "holds 0"]);
}
