//! `gearvib simulate` on the bundled gear-train scenes: the method chosen and why, the machine's shaft and
//! mesh frequencies against the closed forms of the teeth, the recording with the machine's sensor and
//! tachometer channels, and bad scenes refused with the field named.

mod common;
use common::{gearvib, repo, temp_dir, write};

fn summary(scene: &str, extra: &[&str]) -> serde_json::Value {
    let path = repo(&format!("data/scenes/{scene}"));
    let mut args = vec!["simulate", path.as_str(), "--json"];
    args.extend_from_slice(extra);
    let run = gearvib(&args);
    assert_eq!(run.code, 0, "{}", run.stderr);
    serde_json::from_str(run.stdout.trim()).unwrap()
}

#[test]
fn a_short_common_period_is_solved_as_one_periodic_system() {
    let s = summary("train-two-stage-z20z40-z15z45-pinion-errors.json", &[]);
    assert_eq!(s["method"], "hill");
    assert!(s["method_reason"].as_str().unwrap().contains("2 : 1"), "{}", s["method_reason"]);
    // 1500 rpm input: intermediate 25 x 20/40, output 12.5 x 15/45; meshes 20 x 25 and 15 x 12.5 Hz
    let hz: Vec<f64> = s["shaft_hz"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert!((hz[0] - 25.0).abs() < 1e-12 && (hz[1] - 12.5).abs() < 1e-12 && (hz[2] - 12.5 / 3.0).abs() < 1e-12);
    assert!((s["mesh_hz"][0].as_f64().unwrap() - 500.0).abs() < 1e-9);
    assert!((s["mesh_hz"][1].as_f64().unwrap() - 187.5).abs() < 1e-9);
    // two input revolutions
    assert!((s["period_s"].as_f64().unwrap() - 0.08).abs() < 1e-15);
    assert_eq!(s["stable"], true);
    assert!(s["error_estimate"].as_f64().unwrap() <= 1e-8);
    assert_eq!(s["multipliers"].as_array().unwrap().len(), 8);
}

#[test]
fn a_long_common_period_takes_the_two_frequency_balance_and_writes_the_sensors() {
    let dir = temp_dir("gear_train_cli");
    let out = dir.join("train.wav").to_string_lossy().into_owned();
    let s = summary("train-two-stage-z23z61-z19z47-eccentric-gears.json", &["-o", &out]);
    assert_eq!(s["method"], "quasi-hb");
    let reason = s["method_reason"].as_str().unwrap();
    // stage periods 61 input and 47 x 61/23 input revolutions: nu1 : nu2 = 47 : 23, common period 2867 input
    // revolutions at 25 Hz
    assert!(reason.contains("47 : 23"), "{reason}");
    assert!((s["common_period_s"].as_f64().unwrap() - 2867.0 / 25.0).abs() < 1e-9);
    assert!(s["period_s"].is_null() && s["multipliers"].is_null());
    assert!(s["error_estimate"].as_f64().unwrap() <= 1e-8);
    assert!((s["mesh_hz"][1].as_f64().unwrap() - 25.0 * 23.0 / 61.0 * 19.0).abs() < 1e-9);
    // the machine has an accelerometer on channel 1 and the input tachometer on channel 2
    let side: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(format!("{out}.json")).unwrap()).unwrap();
    let ch = side["channels"].as_array().unwrap();
    assert_eq!(ch.len(), 2);
    assert_eq!(ch[0]["unit"], "m/s^2");
    assert_eq!(ch[1]["name"], "tacho input");
    assert_eq!(side["sample_rate_hz"].as_f64().unwrap(), 20000.0);
}

/// A change made to a scene's JSON.
type Edit = dyn Fn(&mut serde_json::Value);

#[test]
fn bad_train_scenes_are_refused_with_the_field() {
    let dir = temp_dir("gear_train_cli_bad");
    let base = std::fs::read_to_string(repo("data/scenes/train-two-stage-z20z40-z15z45-pinion-errors.json")).unwrap();
    let machine = repo("data/machines/two-stage-z20z40-z15z45.json");
    let cases: [(&str, &Edit, &str); 4] = [
        (
            "teeth",
            &|v| v["gear_train"]["stages"][1]["pinion"]["teeth"] = 16.into(),
            "gear_train.stages[1].pinion.teeth",
        ),
        (
            "shafts",
            &|v| {
                v["gear_train"]["shafts"].as_array_mut().unwrap().pop();
            },
            "gear_train.shafts",
        ),
        (
            "mesh",
            &|v| {
                v["gear_train"]["stages"][0]["mesh_stiffness"] =
                    serde_json::json!({"samples": {"values_n_per_m": [1e8, 2e8, 1e8]}})
            },
            "gear_train.stages[0].mesh_stiffness",
        ),
        ("unknown", &|v| v["gear_train"]["colour"] = "red".into(), "gear_train.colour"),
    ];
    for (name, edit, field) in cases {
        let mut v: serde_json::Value = serde_json::from_str(&base).unwrap();
        v["gear_train"]["machine"] = machine.clone().into();
        edit(&mut v);
        let path = write(&dir, &format!("{name}.json"), &v.to_string());
        let run = gearvib(&["simulate", &path]);
        assert_eq!(run.code, 2, "{name}: {}", run.stderr);
        assert!(run.stderr.contains(field), "{name}: expected `{field}` in {}", run.stderr);
        assert_eq!(run.stderr.trim().lines().count(), 1, "one line: {}", run.stderr);
    }
}
