//! `simulate -o`: the written signal against an independent naive DFT, noise statistics, tachometer
//! pulses, sidecar, and refusals that leave no file behind.

mod common;
use common::*;
use std::f64::consts::PI;

/// Amplitude of the line at `f_hz` in `x` by a direct (naive) DFT sum; exact when the record holds a
/// whole number of periods of f.
fn naive_line(x: &[f64], fs: f64, f_hz: f64) -> f64 {
    let (mut re, mut im) = (0.0, 0.0);
    for (i, v) in x.iter().enumerate() {
        let (s, c) = (2.0 * PI * f_hz * i as f64 / fs).sin_cos();
        re += v * c;
        im -= v * s;
    }
    2.0 * re.hypot(im) / x.len() as f64
}

fn read_csv_columns(path: &str) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let mut cols = vec![Vec::new(); header.len()];
    for l in lines {
        for (c, f) in l.split(',').enumerate() {
            cols[c].push(f.parse::<f64>().unwrap());
        }
    }
    (header, cols)
}

fn scene_with(dir: &std::path::Path, edit: impl Fn(&mut serde_json::Value)) -> String {
    let mut v = read_json(&repo("data/scenes/paper-gear-fig8a.json"));
    edit(&mut v);
    write(dir, "scene.json", &v.to_string())
}

#[test]
fn written_csv_has_the_orders_lines() {
    let dir = temp_dir("out-csv");
    let scene = scene_with(&dir, |_| {});
    let out = dir.join("fig8a.csv").to_string_lossy().into_owned();
    let run = gearvib(&["simulate", &scene, "-o", &out, "--json"]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let summary: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    let (header, cols) = read_csv_columns(&out);
    assert_eq!(header, ["time_s", "dq/dt [m/s]"]);
    // 2 s at 10 kHz: 20000 samples, exactly 60 pinion periods, so every order falls on a DFT bin
    assert_eq!(cols[1].len(), 20000);
    assert!((cols[0][1] - 1e-4).abs() < 1e-12);
    let orders = summary["orders"].as_array().unwrap();
    let peak = orders.iter().skip(1).map(|o| o["amplitude"].as_f64().unwrap()).fold(0.0, f64::max);
    let mut checked = 0;
    for o in orders.iter().skip(1) {
        let (f, a) = (o["frequency_hz"].as_f64().unwrap(), o["amplitude"].as_f64().unwrap());
        if a > 1e-3 * peak {
            let got = naive_line(&cols[1], 10_000.0, f);
            // CSV keeps 10 significant digits; the Hermite table is exact to ~1e-8: 1e-6 relative
            assert!(rel(got, a) < 1e-6, "line {f} Hz: file {got} vs orders {a}");
            checked += 1;
        }
    }
    assert!(checked > 30, "{checked}");
}

#[test]
fn wav_with_noise_and_tacho_and_sidecar() {
    let dir = temp_dir("out-wav");
    let clean_scene = scene_with(&dir, |v| v["output"]["tacho"] = true.into());
    let clean = dir.join("clean.wav").to_string_lossy().into_owned();
    assert_eq!(gearvib(&["simulate", &clean_scene, "-o", &clean]).code, 0);
    let noisy_scene = scene_with(&dir, |v| {
        v["output"]["tacho"] = true.into();
        v["output"]["noise_rms"] = 1e-3.into();
        v["output"]["seed"] = 42.into();
    });
    let noisy = dir.join("noisy.wav").to_string_lossy().into_owned();
    let again = dir.join("again.wav").to_string_lossy().into_owned();
    assert_eq!(gearvib(&["simulate", &noisy_scene, "-o", &noisy]).code, 0);
    assert_eq!(gearvib(&["simulate", &noisy_scene, "-o", &again]).code, 0);
    assert_eq!(std::fs::read(&noisy).unwrap(), std::fs::read(&again).unwrap(), "fixed seed: identical files");
    let a = gearvib::io::read_recording(std::path::Path::new(&clean)).unwrap();
    let b = gearvib::io::read_recording(std::path::Path::new(&noisy)).unwrap();
    assert_eq!(a.channels.len(), 3);
    assert_eq!(a.sample_rate_hz, Some(10_000.0));
    let n = a.channels[0].len() as f64;
    let diff: Vec<f64> = a.channels[0].iter().zip(b.channels[0].iter()).map(|(x, y)| f64::from(y - x)).collect();
    let mean = diff.iter().sum::<f64>() / n;
    let rms = (diff.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / n).sqrt();
    // 20000 samples: the RMS estimate of white noise has relative standard error 1/sqrt(2N) = 0.5 %; 3 %
    assert!(rel(rms, 1e-3) < 0.03, "noise rms {rms}");
    assert!(mean.abs() < 4.0 * 1e-3 / n.sqrt(), "noise mean {mean}");
    // tacho: one rising edge per pinion revolution (60 in 2 s) and per wheel revolution (60 * 14/39)
    let edges = |c: &[f32]| c.windows(2).filter(|w| w[0] < 0.5 && w[1] >= 0.5).count() + usize::from(c[0] >= 0.5);
    assert_eq!(edges(&a.channels[1]), 60);
    assert_eq!(edges(&a.channels[2]), (60.0f64 * 14.0 / 39.0).ceil() as usize);
    let side = read_json(&format!("{clean}.json"));
    assert_eq!(side["sample_rate_hz"], 10_000.0);
    assert_eq!(side["channels"][0]["unit"], "m/s");
    assert_eq!(side["channels"][1]["name"], "tacho pinion");
}

#[test]
fn integer_wav_states_its_scale() {
    let dir = temp_dir("out-i16");
    let scene = scene_with(&dir, |v| {
        v["output"]["wav_format"] = "i16".into();
        v["output"]["full_scale"] = 0.05.into();
    });
    let out = dir.join("x.wav").to_string_lossy().into_owned();
    let csv = dir.join("x.csv").to_string_lossy().into_owned();
    assert_eq!(gearvib(&["simulate", &scene, "-o", &out]).code, 0);
    assert_eq!(gearvib(&["simulate", &scene, "-o", &csv]).code, 0);
    let side = read_json(&format!("{out}.json"));
    assert_eq!(side["full_scale"], 0.05);
    let w = gearvib::io::read_recording(std::path::Path::new(&out)).unwrap();
    let (_, cols) = read_csv_columns(&csv);
    for (x, y) in w.channels[0].iter().zip(&cols[1]) {
        // the reader applies the sidecar's full scale; 16-bit quantisation is half a step of 0.05 / 32768,
        // plus f32 storage (6e-8 relative of 0.05)
        assert!((f64::from(*x) - y).abs() <= 0.5 * 0.05 / 32768.0 + 1e-8);
    }
}

fn no_files_left(dir: &std::path::Path) {
    let left: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n != "scene.json")
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn bad_output_requests_are_refused_without_leftovers() {
    let dir = temp_dir("out-bad");
    let scene = scene_with(&dir, |_| {});
    let run = gearvib(&["simulate", &scene, "-o", "/nonexistent/dir/x.wav"]);
    assert_one_line_error(&run, &["/nonexistent/dir/x.wav", "cannot write"]);
    let mp3 = dir.join("x.mp3").to_string_lossy().into_owned();
    assert_one_line_error(&gearvib(&["simulate", &scene, "-o", &mp3]), &["x.mp3", "unknown extension"]);
    no_files_left(&dir);
    // 6 kHz < 2 x 154 x 30 Hz = 9240 Hz
    let low = scene_with(&dir, |v| v["output"]["sample_rate_hz"] = 6000.0.into());
    let out = dir.join("low.wav").to_string_lossy().into_owned();
    assert_one_line_error(&gearvib(&["simulate", &low, "-o", &out]), &["output.sample_rate_hz", "alias"]);
    no_files_left(&dir);
    let run = gearvib(&["simulate", &low, "-o", &out, "--allow-aliasing"]);
    assert_eq!(run.code, 0);
    assert!(run.stderr.contains("warning") && run.stderr.contains("alias"));
    std::fs::remove_file(&out).unwrap();
    std::fs::remove_file(format!("{out}.json")).unwrap();
    let huge = scene_with(&dir, |v| v["output"]["duration_s"] = 1e9.into());
    assert_one_line_error(&gearvib(&["simulate", &huge, "-o", &out]), &["output.duration_s", "exceed"]);
    let zero = scene_with(&dir, |v| v["output"]["duration_s"] = 0.0.into());
    assert_one_line_error(&gearvib(&["simulate", &zero, "-o", &out]), &["output.duration_s"]);
    let tooth = scene_with(&dir, |v| {
        v["gear_pair"]["pinion"]["tooth_faults"] = serde_json::json!([{"tooth": 15, "depth_m": 1e-6}])
    });
    assert_one_line_error(&gearvib(&["simulate", &tooth, "-o", &out]), &["tooth_faults[0].tooth", "1..=14"]);
    let crack = scene_with(&dir, |v| {
        v["gear_pair"]["crack"] = serde_json::json!({"gear": "wheel", "tooth": 40, "stiffness_loss": 0.2})
    });
    assert_one_line_error(&gearvib(&["simulate", &crack, "-o", &out]), &["crack.tooth"]);
    for eps in [0.9, 3.0] {
        let rect = scene_with(&dir, |v| {
            v["gear_pair"]["mesh_stiffness"] =
                serde_json::json!({"rectangular": {"contact_ratio": eps, "pair_stiffness_n_per_m": 5e8}})
        });
        assert_one_line_error(&gearvib(&["simulate", &rect, "-o", &out]), &["contact_ratio", "[1, 3)"]);
    }
    no_files_left(&dir);
}
