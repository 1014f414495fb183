//! Diagnosis on recordings whose speed drifts, fluctuates or ramps, without a tachometer: order tracking,
//! speed and teeth plausibility, and the statistical baseline (issue "Diagnosis that holds on real
//! machines", acceptance).
//!
//! The recordings are simulated from the bundled 14/39 gear scenes with a speed change (random drift of
//! 1 % peak over seconds, which contains the rig's 100 ppm drift, or a +-20 % ramp) and no tachometer, so
//! the angle comes from the mesh phase. The truth is known: the scene's speed (30 Hz nominal), its teeth,
//! its fault.

mod common;
use common::*;
use std::path::Path;

/// Writes a copy of a bundled gear scene with the given output seed, speed change and no tachometer,
/// simulates it to `<name>.wav` and returns the recording's path.
fn recording(dir: &Path, scene: &str, name: &str, seed: u64, change: serde_json::Value) -> String {
    recording_with(dir, scene, name, seed, change, false)
}

/// [`recording`] with or without the tachometer channels.
fn recording_with(dir: &Path, scene: &str, name: &str, seed: u64, change: serde_json::Value, tacho: bool) -> String {
    let mut s = read_json(&repo(&format!("data/scenes/gear-z14z39-{scene}.json")));
    let o = s["output"].as_object_mut().unwrap();
    o.insert("tacho".into(), tacho.into());
    o.insert("seed".into(), seed.into());
    o.remove("speed_drift");
    // orders up to 120 stay below the 5 kHz Nyquist frequency at 1.2 x 30 Hz
    o.insert("max_order".into(), 120.into());
    for (k, v) in change.as_object().unwrap() {
        o.insert(k.clone(), v.clone());
    }
    let scene_path = write(dir, &format!("{name}.json"), &s.to_string());
    let wav = dir.join(format!("{name}.wav")).to_string_lossy().into_owned();
    let run = gearvib(&["simulate", &scene_path, "-o", &wav]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    wav
}

fn drift() -> serde_json::Value {
    serde_json::json!({"speed_drift": {"ppm": 10000, "time_scale_s": 2}})
}

/// Diagnoses `recordings` (one call) and returns one JSON object per recording.
fn diagnose(recordings: &[String], extra: &[&str]) -> Vec<serde_json::Value> {
    let mut args: Vec<&str> = vec!["diagnose"];
    args.extend(recordings.iter().map(String::as_str));
    args.extend_from_slice(extra);
    args.push("--json");
    let run = gearvib(&args);
    assert_eq!(run.code, 0, "{}", run.stderr);
    run.stdout.lines().map(|l| serde_json::from_str(l).unwrap()).collect()
}

#[test]
fn drifting_healthy_recordings_pass_and_local_faults_are_found() {
    let dir = temp_dir("tracking-drift");
    let base = recording(&dir, "healthy", "base", 500, drift());
    let healthy: Vec<String> =
        (0..20).map(|k| recording(&dir, "healthy", &format!("healthy{k}"), 600 + k, drift())).collect();
    // 1 % fluctuation hides the shaft period from the autocorrelation (see the next test for what is said
    // then): the speed is given as nominal, and tracking follows the fluctuation
    let verdicts = diagnose(&healthy, &["--baseline", &base, "--teeth", "14,39", "--rpm", "1800"]);
    let state = |d: &serde_json::Value| d["verdict"]["state"].as_str().unwrap().to_string();
    let suspect = verdicts.iter().filter(|d| state(d) == "suspect").count();
    let faulty: Vec<_> = verdicts.iter().filter(|d| state(d) == "faulty").map(|d| d["verdict"].clone()).collect();
    // 20 recordings x 2 gears x 9 indicators at a false-alarm rate of 1e-3 each: about 0.4 suspect expected
    assert!(suspect <= 1, "{suspect} suspect of 20");
    assert!(faulty.is_empty(), "{faulty:?}");
    let reasons = |d: &serde_json::Value| d["verdict"]["reasons"].to_string();
    for d in &verdicts {
        assert_eq!(d["speed_profile"]["tracking"], "mesh phase");
        // the envelope against the baseline raises no alarm on a healthy gear
        assert!(!reasons(d).contains("envelope spectrum"), "{}", d["verdict"]);
    }
    for fault in ["cracked-pinion-tooth3", "pitted-pinion-tooth3"] {
        let rec = recording(&dir, fault, fault, 700, drift());
        let d = &diagnose(&[rec], &["--baseline", &base, "--teeth", "14,39", "--rpm", "1800"])[0];
        assert_eq!(d["verdict"]["state"], "faulty", "{fault}: {}", d["verdict"]);
        assert_eq!(d["verdict"]["gear"], "pinion", "{fault}: {}", d["verdict"]);
        // and the crack's impacts show in the envelope, in the baseline's band: its pinion order 1 rose by
        // 28 dB (measured; the 20 healthy recordings rise by at most 3.3 dB; the pit by 7 dB, under the
        // 10 dB rule, so the pit is found by the TSA indicators alone)
        if fault.starts_with("cracked") {
            assert!(
                reasons(d).contains("envelope spectrum") && reasons(d).contains("pinion order 1"),
                "{}",
                d["verdict"]
            );
        }
    }
}

#[test]
fn a_twenty_percent_run_up_is_tracked_and_the_crack_found() {
    let dir = temp_dir("tracking-ramp");
    let ramp = serde_json::json!({"speed_ramp": {"from": 0.8, "to": 1.2}});
    let base = recording(&dir, "healthy", "base", 800, ramp.clone());
    let cracked = recording(&dir, "cracked-pinion-tooth3", "cracked", 801, ramp);
    let report = dir.join("report");
    let d = &diagnose(
        &[cracked],
        &["--baseline", &base, "--teeth", "14,39", "--rpm", "1800", "--report", report.to_str().unwrap()],
    )[0];
    // a speed that changes by more than 2 % gets the rpm-order map
    assert!(report.join("cracked-order-map.png").is_file());
    let p = &d["speed_profile"];
    assert_eq!(p["tracking"], "mesh phase");
    let hz = |k: &str| p[k].as_f64().unwrap();
    // the ramp runs from 24 to 36 Hz (1.5 Hz/s over 8 s); the tracked span loses about two revolutions at
    // each end, where the speed is 24.1 and 35.9 Hz, and a revolution's mean speed differs from its start
    // by 0.2 % at most: min and max within 1 % of the ends
    assert!((hz("min_hz") / 24.0 - 1.0).abs() < 0.01, "{p}");
    assert!((hz("max_hz") / 36.0 - 1.0).abs() < 0.01, "{p}");
    // the mean over the tracked revolutions: 30 Hz up to the asymmetric end trim (about 0.07 %)
    assert!((hz("mean_hz") / 30.0 - 1.0).abs() < 0.002, "{p}");
    // tenths are counted in revolutions: the first 24 of 240 take about 1 s (mean 24.75 Hz), the last 24
    // about 0.67 s (mean 35.5 Hz): (35.5 - 24.75) / 30 = +35.8 %, within 1.5 % for the trimmed ends
    assert!((p["change_percent"].as_f64().unwrap() - 35.8).abs() < 1.5, "{p}");
    assert_eq!(d["verdict"]["state"], "faulty", "{}", d["verdict"]);
    assert_eq!(d["verdict"]["gear"], "pinion", "{}", d["verdict"]);
}

#[test]
fn speed_and_mesh_are_found_without_rpm_or_teeth() {
    let dir = temp_dir("tracking-estimate");
    let rig_drift = serde_json::json!({"speed_drift": {"ppm": 100, "time_scale_s": 4}});
    // the faulty pinions carry their shaft, and so does the healthy reference (the paper's small pinion
    // errors of Fig 8a, orders 1..6), under the rig's drift and under a 1 % fluctuation (the raw signal's
    // autocorrelation smears over a hundred revolutions there: the shaft is found on the mesh line's angle)
    let mut recs = Vec::new();
    for (k, s) in ["cracked-pinion-tooth3", "pitted-pinion-tooth3", "healthy"].iter().enumerate() {
        recs.push(recording(&dir, s, &format!("{s}-rig"), 900 + k as u64, rig_drift.clone()));
        recs.push(recording(&dir, s, &format!("{s}-1pct"), 910 + k as u64, drift()));
    }
    // and every bundled recording as it is (their sidecar names the pinion's tachometer)
    for f in std::fs::read_dir(repo("data/recordings")).unwrap() {
        let p = f.unwrap().path();
        if p.extension().is_some_and(|e| e == "wav") {
            recs.push(p.to_string_lossy().into_owned());
        }
    }
    for d in diagnose(&recs, &[]) {
        // a speed from the pinion's tachometer is the pinion's, so the shaft and a fault found on its TSA are
        // named (teeth or not); an estimated period belongs to a shaft nobody named
        let measured = d["speed_source"] == "tachometer";
        let f = d["shaft_hz"][if measured { "pinion" } else { "estimated_shaft" }].as_f64().unwrap();
        if measured && d["file"].as_str().unwrap().contains("cracked") {
            assert_eq!(d["verdict"]["gear"], "pinion", "{}", d["verdict"]);
        }
        // the drift moves the mean speed by up to 1 %; the shaft must be the pinion (30 Hz), not the mesh
        // (420 Hz) nor the wheel (10.8 Hz)
        assert!((f / 30.0 - 1.0).abs() < 0.012, "{}: {f} Hz", d["file"]);
        assert_eq!(d["mesh_order"], 14, "{}", d["file"]);
        assert!(d["warnings"].to_string().contains("estimated"), "{}", d["file"]);
    }
    // a mesh of identical teeth (the healthy scene without its pinion errors) repeats every mesh period
    // and holds no shaft order: no shaft speed can be read from it, and the mesh is not taken for a shaft
    let mut s = read_json(&repo("data/scenes/gear-z14z39-healthy.json"));
    s["gear_pair"]["pinion"].as_object_mut().unwrap().remove("errors");
    let o = s["output"].as_object_mut().unwrap();
    o.insert("tacho".into(), false.into());
    o.insert("max_order".into(), 120.into());
    let scene = write(&dir, "identical.json", &s.to_string());
    let wav = dir.join("identical.wav").to_string_lossy().into_owned();
    assert_eq!(gearvib(&["simulate", &scene, "-o", &wav]).code, 0);
    assert_one_line_error(&gearvib(&["diagnose", &wav]), &["no plausible shaft speed", "--rpm"]);
}

/// Without `--rpm` or a tachometer, under a 1 % fluctuation, a baseline's estimated speed is no help to the
/// raw repetition search near its period (the autocorrelation of a revolution smears over a hundred of
/// them): the recording is followed on its mesh line, as its baseline was. This once failed with "no
/// repetition period found between 323 and 345 samples" (healthy) or a speed 50 % off the baseline's
/// (cracked), with and without `--teeth`.
#[test]
fn a_baseline_without_rpm_holds_under_a_one_percent_fluctuation() {
    let dir = temp_dir("tracking-baseline-estimated");
    let base = recording(&dir, "healthy", "base", 920, drift());
    let healthy = recording(&dir, "healthy", "healthy", 921, drift());
    let cracked = recording(&dir, "cracked-pinion-tooth3", "cracked", 922, drift());
    let ecc = recording(&dir, "wheel-eccentricity", "ecc", 923, drift());
    for teeth in [&["--teeth", "14,39"][..], &[]] {
        let mut args = vec!["--baseline", base.as_str()];
        args.extend_from_slice(teeth);
        let all = diagnose(&[healthy.clone(), cracked.clone(), ecc.clone()], &args);
        for d in &all {
            // the speed is estimated (30 Hz moved by at most 1 % by the fluctuation) and the mesh is the
            // baseline's order 14, for all three including the wheel's (a 39-cycle repetition)
            let f = d["speed_profile"]["mean_hz"].as_f64().unwrap();
            assert!((f / 30.0 - 1.0).abs() < 0.012, "{teeth:?} {}: {f} Hz", d["file"]);
            assert_eq!(d["mesh_order"], 14, "{teeth:?} {}", d["file"]);
            assert_eq!(d["speed_source"], "estimated", "{teeth:?} {}", d["file"]);
        }
        assert_ne!(all[0]["verdict"]["state"], "faulty", "{teeth:?}: {}", all[0]["verdict"]);
        assert_eq!(all[1]["verdict"]["state"], "faulty", "{teeth:?}: {}", all[1]["verdict"]);
        if !teeth.is_empty() {
            assert_eq!(all[1]["verdict"]["gear"], "pinion", "{}", all[1]["verdict"]);
            assert_eq!(all[2]["verdict"]["gear"], "wheel", "{}", all[2]["verdict"]);
        }
    }
}

/// Without `--teeth`, the meshing gear's teeth are estimated from its sidebands when its run-out puts them
/// there, with a confidence; when no other gear shows, nothing is guessed. The pairs are other machines
/// than the bundled 14/39 (the eccentric wheel's scene with other teeth and speeds), under a drift of
/// 1000 ppm and no tachometer.
#[test]
fn the_meshing_gears_teeth_are_estimated_when_its_sidebands_show() {
    let dir = temp_dir("tracking-other-teeth");
    let base = read_json(&repo("data/scenes/gear-z14z39-wheel-eccentricity.json"));
    let pair = |zp: usize, zw: usize, rpm: f64| -> String {
        let mut s = base.clone();
        s["gear_pair"]["pinion"]["teeth"] = zp.into();
        s["gear_pair"]["wheel"]["teeth"] = zw.into();
        s["gear_pair"]["speed_rpm"] = rpm.into();
        let o = s["output"].as_object_mut().unwrap();
        o.insert("tacho".into(), false.into());
        o.insert("seed".into(), (zp * 100 + zw).into());
        o.insert("speed_drift".into(), serde_json::json!({"ppm": 1000, "time_scale_s": 2}));
        o.insert("sample_rate_hz".into(), 20000.into());
        // orders below 0.45 of the sample rate
        o.insert("max_order".into(), ((9000.0 / (rpm / 60.0)) as usize).into());
        let name = format!("p{zp}w{zw}");
        let scene = write(&dir, &format!("{name}.json"), &s.to_string());
        let wav = dir.join(format!("{name}.wav")).to_string_lossy().into_owned();
        assert_eq!(gearvib(&["simulate", &scene, "-o", &wav]).code, 0);
        wav
    };
    // the speed is given: without it, the shaft of these pairs is found or refused depending on the noise
    // seed (a clear error when refused; see speed_and_mesh_are_found_without_rpm_or_teeth)
    for (zp, zw, rpm) in [(20, 53, 1800.0), (25, 31, 1500.0), (17, 41, 1500.0), (31, 73, 900.0)] {
        let d = &diagnose(&[pair(zp, zw, rpm)], &["--rpm", &rpm.to_string()])[0];
        assert_eq!(d["mesh_order"], zp, "{zp}/{zw}");
        let g = &d["other_gear"];
        assert_eq!(g["teeth"], zw, "{zp}/{zw}: {}", d["warnings"]);
        assert!(g["confidence"].as_f64().unwrap() >= 0.5, "{zp}/{zw}: {g}");
        let w = d["warnings"].to_string();
        assert!(w.contains(&format!("teeth as {zp},{zw}")), "{zp}/{zw}: {w}");
    }
    // no other gear's sidebands: a true-running wheel; and the rectangular stiffness, whose spurious lines
    // at 13 dB once made a wheel of 22 teeth
    for f in ["healthy", "rectangular-stiffness"] {
        let d = &diagnose(&[repo(&format!("data/recordings/gear-z14z39-fs10kHz-{f}.wav"))], &[])[0];
        assert!(d["other_gear"].is_null(), "{f}: {}", d["other_gear"]);
        assert!(d["warnings"].to_string().contains("teeth were not estimated"), "{f}: {}", d["warnings"]);
    }
    // with the teeth given, nothing is estimated
    let ecc = repo("data/recordings/gear-z14z39-fs10kHz-wheel-eccentricity.wav");
    assert!(diagnose(&[ecc], &["--teeth", "14,39"])[0]["other_gear"].is_null());
}

#[test]
fn wrong_teeth_are_warned_about() {
    let rec = repo("data/recordings/gear-z14z39-fs10kHz-cracked-pinion-tooth3.wav");
    for teeth in ["13,39", "15,39", "39,14"] {
        let d = &diagnose(std::slice::from_ref(&rec), &["--teeth", teeth])[0];
        let w = d["warnings"].to_string();
        assert!(w.contains("do not fit"), "{teeth}: {w}");
    }
    // equal teeth: the two averages are one signal, and the fault cannot be put on one gear
    let d = &diagnose(std::slice::from_ref(&rec), &["--teeth", "14,14"])[0];
    assert!(d["warnings"].to_string().contains("equal teeth"), "{}", d["warnings"]);
    let d = &diagnose(&[rec], &["--teeth", "14,39"])[0];
    assert!(!d["warnings"].to_string().contains("do not fit"), "{}", d["warnings"]);
    assert!(!d["warnings"].to_string().contains("equal teeth"), "{}", d["warnings"]);
    // a healthy, true-running wheel has no sidebands of its own: its teeth are said to be unchecked
    assert!(d["warnings"].to_string().contains("wheel's teeth (39) could not be checked"), "{}", d["warnings"]);
    // a wrong wheel count leaves the pinion's TSA as it was; the eccentric wheel's +-1 sidebands (at
    // 14/39 = 0.359 pinion orders, 0.009 orders from those of 38 or 40 teeth: 2 resolution bins of the
    // 8 s record) say which count is right. The wrong counts' sidebands stand far (30 times) under the
    // true ones: the wheel's averages on a wrong count hold no wheel, so the machine is not judged (exit 3)
    let ecc = repo("data/recordings/gear-z14z39-fs10kHz-wheel-eccentricity.wav");
    for (teeth, wrong) in [("14,38", true), ("14,40", true), ("14,39", false)] {
        let run = gearvib(&["diagnose", &ecc, "--teeth", teeth, "--json"]);
        assert_eq!(run.code, if wrong { 3 } else { 0 }, "{teeth}: {}", run.stderr);
        let d: serde_json::Value = serde_json::from_str(run.stdout.lines().next().unwrap()).unwrap();
        assert_eq!(d["verdict"]["state"] == "not_judged", wrong, "{teeth}: {}", d["verdict"]);
        let w = d["warnings"].to_string();
        assert_eq!(
            w.contains("wheel teeth") && w.contains("do not fit") && w.contains("a wheel of 39 teeth"),
            wrong,
            "{teeth}: {w}"
        );
        assert!(!w.contains("could not be checked"), "{teeth}: {w}");
    }
}

#[test]
fn baselines_that_do_not_fit_are_refused_or_warned() {
    let dir = temp_dir("tracking-compat");
    let rec = repo("data/recordings/gear-z14z39-fs10kHz-cracked-pinion-tooth3.wav");
    // a baseline 15 % slower: another operating point, refused
    let constant = |r: f64| serde_json::json!({"speed_ramp": {"from": r, "to": r}});
    let slow = recording_with(&dir, "healthy", "slow", 1000, constant(0.85), true);
    let run = gearvib(&["diagnose", &rec, "--baseline", &slow, "--teeth", "14,39"]);
    assert_one_line_error(&run, &["baseline", "not comparable", "speed differs"]);
    // 0.5 % slower: a change of load; judged, but at most suspect and saying why
    let near = recording_with(&dir, "healthy", "near", 1001, constant(0.995), true);
    let d = &diagnose(std::slice::from_ref(&rec), &["--baseline", &near, "--teeth", "14,39"])[0];
    assert_eq!(d["verdict"]["state"], "suspect", "{}", d["verdict"]);
    assert!(d["verdict"]["reasons"][0].as_str().unwrap().contains("operating point"), "{}", d["verdict"]);
    // a baseline in another unit (CSV header units)
    let csv_a = write(&dir, "a.csv", &csv_of(&rec_samples(), "m/s"));
    let csv_b = write(&dir, "b.csv", &csv_of(&rec_samples(), "g"));
    let run = gearvib(&["diagnose", &csv_a, "--baseline", &csv_b, "--fs", "10000", "--rpm", "1800"]);
    assert_one_line_error(&run, &["baseline", "m/s", "g"]);
}

/// 2 s of a 30 Hz mesh-like signal at 10 kHz with mild noise (deterministic).
fn rec_samples() -> Vec<f64> {
    let mut rng = Rng::new(12345);
    (0..20_000)
        .map(|i| {
            let noise = rng.centered();
            let th = std::f64::consts::TAU * 30.0 * i as f64 / 1e4;
            (14.0 * th).sin() + 0.2 * (13.0 * th).sin() + 0.1 * th.sin() + 0.05 * noise
        })
        .collect()
}

fn csv_of(x: &[f64], unit: &str) -> String {
    let mut s = format!("time [s],accel [{unit}]\n");
    for (i, v) in x.iter().enumerate() {
        s.push_str(&format!("{},{v}\n", i as f64 / 1e4));
    }
    s
}

#[test]
fn tachometer_with_missing_pulses_is_refused() {
    let dir = temp_dir("tracking-tacho");
    let x = rec_samples();
    let mut s = String::from("vib,tacho\n");
    for (i, v) in x.iter().enumerate() {
        // one pulse per revolution of 333.3 samples, the 20th missing
        let rev = i as f64 / (1e4 / 30.0);
        let pulse = rev.fract() < 0.05 && rev.floor() as i64 != 20;
        s.push_str(&format!("{v},{}\n", if pulse { 5.0 } else { 0.0 }));
    }
    let f = write(&dir, "tacho.csv", &s);
    let run = gearvib(&["diagnose", &f, "--fs", "10000", "--tacho-channel", "2", "--channel", "1"]);
    assert_one_line_error(&run, &["tachometer", "missing"]);
}

/// Amplitude of `order` in `simulate --json` of the healthy scene at `rpm` (constant speed).
fn steady_amplitude(dir: &Path, rpm: f64, order: f64) -> f64 {
    let mut s = read_json(&repo("data/scenes/gear-z14z39-healthy.json"));
    s["gear_pair"]["speed_rpm"] = rpm.into();
    s["output"]["max_order"] = 120.into();
    let path = write(dir, &format!("steady-{rpm}.json"), &s.to_string());
    let run = gearvib(&["simulate", &path, "--json"]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let v: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    let lines = v["orders"].as_array().unwrap();
    let line = lines.iter().find(|l| (l["order"].as_f64().unwrap() - order).abs() < 1e-9).unwrap();
    line["amplitude"].as_f64().unwrap()
}

#[test]
fn a_run_up_is_quasi_static_and_its_order_map_follows_the_steady_state_at_each_speed() {
    use gearvib::signal::order_map::order_map;
    use gearvib::signal::spectrum::Fft;
    use gearvib::signal::tsa::AngleMap;
    let dir = temp_dir("ramp-quasi-static");
    let mut s = read_json(&repo("data/scenes/gear-z14z39-healthy.json"));
    let o = s["output"].as_object_mut().unwrap();
    o.remove("speed_drift");
    for (k, v) in [
        ("speed_ramp", serde_json::json!({"from": 0.8, "to": 1.2})),
        ("tacho", true.into()),
        ("noise_rms", 0.0.into()),
        ("wav_format", "f32".into()),
        ("max_order", 120.into()),
    ] {
        o.insert(k.into(), v);
    }
    let scene = write(&dir, "ramp.json", &s.to_string());
    let wav = dir.join("ramp.wav");
    let run = gearvib(&["simulate", &scene, "-o", wav.to_str().unwrap()]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let rec = gearvib::io::read_recording(&wav).unwrap();
    let fs = rec.sample_rate_hz.unwrap();
    // the tachometer's rising edges are the true revolution starts (the synthesiser's own angle)
    let pulses = gearvib::signal::speed::tacho_pulses(&rec.channels[1]).unwrap();
    let map = AngleMap::from_pulses(&pulses, 1);
    let m = order_map(&mut Fft::new(), &rec.channels[0], &map, 512, 8, 4, 50.0).unwrap();
    // order 14 (mesh, 340 .. 500 Hz) and 42 (3x mesh) at grid speeds of the quasi-static synthesis, where
    // no interpolation between steady states is involved; rows whose mean speed is within 0.5 % of it
    let mut checked = 0;
    for s_rel in [0.85, 1.0, 1.15] {
        let hz = 30.0 * s_rel;
        let (row, speed) = m
            .speeds
            .iter()
            .enumerate()
            .map(|(i, v)| (i, v * fs))
            .min_by(|a, b| (a.1 - hz).abs().total_cmp(&(b.1 - hz).abs()))
            .unwrap();
        assert!((speed / hz - 1.0).abs() < 0.005, "no row near {hz} Hz: {speed}");
        for order in [14.0, 42.0] {
            let want = steady_amplitude(&dir, 1800.0 * s_rel, order);
            let got = m.amplitudes[row][(order * 8.0) as usize];
            // 5 %: the 8-revolution segment spans +-0.7 % of speed around its mean and the Hann-weighted
            // amplitude follows the steady state's slope over it; the row's mean is within 0.5 % of s
            assert!((got / want - 1.0).abs() < 0.05, "order {order} at {hz} Hz: {got:e} vs steady {want:e}");
            checked += 1;
        }
    }
    assert_eq!(checked, 6);
    // the test discriminates: the steady state itself changes over the ramp by far more than 5 %
    let (a, b) = (steady_amplitude(&dir, 1530.0, 42.0), steady_amplitude(&dir, 2070.0, 42.0));
    assert!((a / b - 1.0).abs() > 0.2, "{a} {b}");
}

/// A recording of a shaft at `f0` Hz whose speed wanders by the sinusoids `wander` ((relative amplitude,
/// Hz) each), `seconds` long at `fs`: each sample is `noise` times a centred random number (seed `seed`)
/// plus `lines(angle)` of the shaft's angle (radians). Written as a CSV with a time column to
/// `dir/name`; returns its path and the true mean speed (Hz).
fn wandering_csv(
    dir: &Path,
    name: &str,
    (fs, f0, seconds): (f64, f64, f64),
    wander: &[(f64, f64)],
    (seed, noise): (u64, f64),
    lines: impl Fn(f64) -> f64,
) -> (String, f64) {
    let mut rng = Rng::new(seed);
    let mut theta = 0.0f64;
    let mut csv = String::from("time [s],accel [m/s^2]\n");
    for i in 0..(fs * seconds) as usize {
        let t = i as f64 / fs;
        let f = f0 * (1.0 + wander.iter().map(|&(a, w)| a * (std::f64::consts::TAU * w * t).sin()).sum::<f64>());
        let v = noise * rng.centered() + lines(std::f64::consts::TAU * theta);
        csv.push_str(&format!("{t},{v}\n"));
        theta += f / fs;
    }
    (write(dir, name, &csv), theta / seconds)
}

/// A mesh of `z` teeth, harmonics 1-8 of amplitude `a(k)` with first sidebands `sb(k)`, at shaft angle `th`.
fn mesh_lines(z: f64, th: f64, amplitudes: impl Fn(usize) -> (f64, f64)) -> f64 {
    (1..=8)
        .map(|k| {
            let (a, sb) = amplitudes(k);
            let m = k as f64 * z;
            a * (m * th).sin() + sb * ((m + 1.0) * th).sin() + sb * ((m - 1.0) * th).sin()
        })
        .sum()
}

/// A nominal speed 2.5 % off on a machine whose first four mesh harmonics lie under the noise while a
/// resonance lifts harmonics 6-8 (as on the hold-out generator's machines): the speed is measured on the
/// lifted harmonics and followed, within 0.2 % of the true mean. The truth is the signal's own angle,
/// integrated from a speed fluctuating 1.2 % and 0.5 % at 0.4 and 1.3 Hz (a line's place in an averaged
/// spectrum of 8-revolution segments is good to a fraction of a bin, 0.1 %, and the tracked mean to far
/// less; 0.2 % is under the 0.31 % off at which the wheel's sideband of harmonic 6, 0.36 pinion orders from
/// its order 114, would put a tracking that followed it). The previous comb of harmonics 1-4 left this
/// recording on the given speed, not judged.
#[test]
fn a_nominal_speed_is_measured_on_resonance_lifted_mesh_harmonics() {
    let dir = temp_dir("tracking-lifted");
    let (fs, f0, z, seconds) = (20_000.0, 22.0, 19.0, 8.0);
    let (path, true_mean) =
        wandering_csv(&dir, "lifted.csv", (fs, f0, seconds), &[(0.012, 0.4), (0.005, 1.3)], (2024, 2.0), |th| {
            mesh_lines(z, th, |k| if k >= 6 { (0.3, 0.1) } else { (0.005, 0.002) })
        });
    let rpm = format!("{}", 60.0 * f0 * 1.025);
    let d = &diagnose(&[path], &["--teeth", "19,53", "--rpm", &rpm])[0];
    let measured = d["shaft_hz"]["pinion"].as_f64().unwrap();
    assert!(
        rel(measured, true_mean) < 2e-3,
        "measured {measured} Hz against the true mean {true_mean} Hz: {}",
        d["warnings"]
    );
    assert_eq!(d["speed_profile"]["tracking"], "mesh phase", "{}", d["warnings"]);
}

/// A given speed's window holds for the followed line too: a 31-tooth mesh at 19 Hz with a 1 % speed wander
/// (harmonics 1-4 weak, 5-8 lifted by a resonance), a fan tone on the same shaft at orders 30, 60, 90 and
/// 120 (the first 3.2 % below the mesh, far over it), and the nameplate 2.1 % above the true speed. The
/// mesh line followed from the comb's start strayed onto the fan's line, 5.2 % below the given speed,
/// beyond the 5 % tolerance, and that speed was used (as on a hold-out-style 31/43 machine, where the comb
/// then found the true speed). The speed used must lie within the tolerance of the given one, and unless
/// it is the true mean within 0.2 % (the tolerance of the test above) the output must say that the
/// tracking followed another line. (Here the fan's four harmonics also make a comb of 31 at 30/31 of the
/// speed, inside the window, which the comb itself takes: that is left as it is, and said.)
#[test]
fn a_fan_line_beside_the_mesh_does_not_take_the_speed_out_of_its_window() {
    let dir = temp_dir("tracking-fan");
    let (fs, f0, z, seconds) = (44_100.0, 19.0, 31.0, 10.0);
    let (path, true_mean) =
        wandering_csv(&dir, "fan.csv", (fs, f0, seconds), &[(0.008, 0.3), (0.004, 1.1)], (7, 0.5), |th| {
            let fan: f64 = [(30.0, 0.9), (60.0, 0.6), (90.0, 0.5), (120.0, 0.4)]
                .iter()
                .map(|&(h, a)| a * (h * th + 0.7).sin())
                .sum();
            mesh_lines(z, th, |k| if k >= 5 { (0.3, 0.05) } else { (0.05, 0.01) }) + fan
        });
    let rpm = format!("{}", 60.0 * true_mean * 1.021);
    let d = &diagnose(&[path], &["--teeth", "31,43", "--rpm", &rpm])[0];
    let measured = d["shaft_hz"]["pinion"].as_f64().unwrap();
    let given = true_mean * 1.021;
    assert!(rel(measured, given) <= 0.05, "measured {measured} Hz against the given {given} Hz: {}", d["warnings"]);
    assert!(
        rel(measured, true_mean) < 2e-3 || d["warnings"].to_string().contains("followed another line"),
        "measured {measured} Hz against the true mean {true_mean} Hz, and nothing said: {}",
        d["warnings"]
    );
}

/// `diagnose --json` of a recording in tests/fixtures/unseen with the teeth alone: its JSON and the pinion
/// speed it used, Hz.
fn teeth_only(name: &str, teeth: &str) -> (serde_json::Value, f64) {
    teeth_only_with(name, teeth, &[])
}

/// [`teeth_only`] with more arguments (a baseline, a given speed).
fn teeth_only_with(name: &str, teeth: &str, more: &[&str]) -> (serde_json::Value, f64) {
    let wav = repo(&format!("tests/fixtures/unseen/{name}"));
    let mut args = vec!["diagnose", &wav, "--teeth", teeth, "--json"];
    args.extend_from_slice(more);
    let run = gearvib(&args);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let d: serde_json::Value = serde_json::from_str(run.stdout.lines().next().unwrap()).unwrap();
    let hz = d["speed_profile"]["mean_hz"].as_f64().unwrap();
    (d, hz)
}

/// A machine of another physics (tests/holdout/gen_holdout.py `--fresh`, machine m14: an 18/29 pair at
/// 39.03 Hz mean, +-0.7 %, 20 kHz, noise at 0.65 of the signal, an 8-blade fan, 50 Hz hum, an 807 Hz
/// second mesh, housing modes at 266-8321 Hz; seed 15151; the healthy-s1 recording as a vibration-only
/// i16 WAV) with the teeth alone: the mesh comb of half the pinion speed (every other line the mesh's,
/// shaft lines at the rest) won the comb search, and the pinion was taken at 19.80 Hz, not judged. The
/// comb's second line stands 5 nats over its first: the mesh is its second harmonic, and the speed is
/// the true one to 1 % (the mean of a tracked angle is good to 0.1 %; half and double lie 50 % and 100 %
/// off).
#[test]
fn a_comb_of_half_the_mesh_is_doubled_to_the_mesh() {
    let (d, hz) = teeth_only("m14-z18z29-healthy-s1-i16.wav", "18,29");
    assert!((hz / 39.0257 - 1.0).abs() < 0.01, "pinion {hz} Hz against the true 39.03: {}", d["warnings"]);
    assert_eq!(d["verdict"]["state"], "healthy", "{}", d["verdict"]);
}

/// The hold-out machine m4 (tests/holdout/gen_holdout.py: a 21/64 pair at 28.97 Hz mean, 25.6 kHz, noise
/// at 0.79 of the signal, a 9-blade fan, 60 Hz hum, housing modes at 5.5-7.6 kHz; seed 4095) with a broken
/// pinion tooth, teeth alone: the mesh's even harmonics stand over its odd ones, the comb was read as a
/// divisor of its second harmonic, and the pinion taken at 57.93 Hz. Over twice that revolution the
/// record's halves agree at the odd orders (0.98): the shaft's own lines, so that was half a turn. The
/// speed is the true one to 1 % (half and double lie 50 % and 100 % off), the fault on the pinion.
#[test]
fn half_a_turn_is_doubled_to_the_revolution() {
    let (d, hz) = teeth_only("m4-z21z64-broken-pinion-i16.wav", "21,64");
    assert!((hz / 28.9661 - 1.0).abs() < 0.01, "pinion {hz} Hz against the true 28.97: {}", d["warnings"]);
    assert!(d["warnings"].to_string().contains("that was half a turn"), "{}", d["warnings"]);
    assert_eq!(d["verdict"]["state"], "faulty", "{}", d["verdict"]);
    assert_eq!(d["verdict"]["gear"], "pinion", "{}", d["verdict"]);
}

/// The fresh hold-out machine m13 (tests/holdout/gen_holdout.py `--fresh`: a 31/43 pair, 44.1 kHz, noise at
/// 0.48 of the signal, a 10-blade fan, 60 Hz hum, a second mesh at 274 Hz; seed 14141), healthy, teeth
/// alone. The mesh comb's peak (19.22 Hz) lies 0.74 % over the true mean 19.08 Hz, inside the +-0.9 % the
/// speed wanders; the mesh line followed from it was dropped for lying more than 0.5 % from the estimate,
/// and the constant speed left the recording not judged. The followed line is kept now: the speed is the
/// true mean to 0.2 % (a tracked mean is good to about 0.1 %; the comb's peak lay 0.74 % off), the same as
/// the nameplate path's to 1e-6 (one line followed), and the verdict healthy.
#[test]
fn a_teeth_estimate_off_within_the_wander_keeps_the_followed_line() {
    let name = "m13-z31z43-healthy-s1-i16.wav";
    let (d, hz) = teeth_only(name, "31,43");
    assert!((hz / 19.0797 - 1.0).abs() < 2e-3, "pinion {hz} Hz against the true 19.08: {}", d["warnings"]);
    assert_eq!(d["speed_profile"]["tracking"], "mesh phase", "{}", d["warnings"]);
    assert_eq!(d["verdict"]["state"], "healthy", "{}", d["verdict"]);
    let (_, nameplate) = teeth_only_with(name, "31,43", &["--rpm", "1160"]);
    assert!((hz / nameplate - 1.0).abs() < 1e-6, "teeth alone {hz} Hz, nameplate path {nameplate} Hz");
}

/// The same machine's healthy-s3 (seed 14143, true mean 19.017 Hz; housing modes at 4317 and 8340 Hz),
/// teeth alone: its mesh's seventh harmonic (4.13 kHz) stands on the housing mode, the comb of seven times
/// the speed won, and the pinion was taken at 133 Hz: not judged alone, and refused against healthy-s1
/// ("no repetition period found") until the baseline's speed became a start. Over seven of those
/// revolutions the record's halves agree between the multiples of 7 (the pinion's own lines): that was a
/// seventh of a turn. The speed is the true mean to 0.2 % (a tracked mean is good to about 0.1 %; 7 times
/// lies 600 % off), healthy alone and against its sibling, as on the nameplate path.
#[test]
fn a_seventh_of_a_turn_is_lengthened_to_the_revolution() {
    let baseline = repo("tests/fixtures/unseen/m13-z31z43-healthy-s1-i16.wav");
    let name = "m13-z31z43-healthy-s3-i16.wav";
    let (alone, hz) = teeth_only(name, "31,43");
    assert!((hz / 19.0169 - 1.0).abs() < 2e-3, "pinion {hz} Hz against the true 19.02: {}", alone["warnings"]);
    assert!(alone["warnings"].to_string().contains("that was 1/7 of a turn"), "{}", alone["warnings"]);
    assert_eq!(alone["verdict"]["state"], "healthy", "{}", alone["verdict"]);
    let (d, hz) = teeth_only_with(name, "31,43", &["--baseline", &baseline]);
    assert!((hz / 19.0169 - 1.0).abs() < 2e-3, "pinion {hz} Hz against the true 19.02: {}", d["warnings"]);
    assert_eq!(d["verdict"]["state"], "healthy", "{}", d["verdict"]);
    let (n, _) = teeth_only_with(name, "31,43", &["--baseline", &baseline, "--rpm", "1160"]);
    assert_eq!(n["verdict"]["state"], "healthy", "the nameplate path: {}", n["verdict"]);
}

/// The fresh hold-out machine m10 (tests/holdout/gen_holdout.py `--fresh`: a 20/33 pair at 33.05 Hz mean,
/// 32.62-33.87 Hz, 24 kHz, noise at 0.41 of the signal, a 10-blade fan on the pinion shaft, 50 Hz hum, a
/// second mesh at 476 Hz; seed 11111), healthy, teeth alone. The fan's tones (pinion orders 10, 30, ...)
/// fill the odd places of the comb of half the speed, whose 20 "teeth" then explain every line: that comb
/// won (evidence 19.5 against the true one's 8.7) and the pinion was taken at 16.5 Hz, not judged. The
/// record's halves agree at the even orders of that revolution (1.00) and not at the odd ones (-0.33): it
/// holds two turns, and the faster pinion's own comb stands, its mesh line is followed, and on its angle
/// the revolution is one turn. The speed is the true mean to 0.2 % (a tracked mean is good to about 0.1 %;
/// half lies 50 % off), the same as the nameplate path's to 1e-6 (one line followed), and the verdict the
/// nameplate path's: healthy.
#[test]
fn a_revolution_of_two_turns_is_read_as_the_faster_shaft() {
    let name = "m10-z20z33-healthy-s1-i16.wav";
    let (d, hz) = teeth_only(name, "20,33");
    assert!((hz / 33.0495 - 1.0).abs() < 2e-3, "pinion {hz} Hz against the true 33.05: {}", d["warnings"]);
    assert!(d["warnings"].to_string().contains("holds 2 turns of the pinion"), "{}", d["warnings"]);
    assert_eq!(d["verdict"]["state"], "healthy", "{}", d["verdict"]);
    let (n, nameplate) = teeth_only_with(name, "20,33", &["--rpm", "2000"]);
    assert!((hz / nameplate - 1.0).abs() < 1e-6, "teeth alone {hz} Hz, nameplate path {nameplate} Hz");
    assert_eq!(n["verdict"]["state"], d["verdict"]["state"], "the nameplate path: {}", n["verdict"]);
}
