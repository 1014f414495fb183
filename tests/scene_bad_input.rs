//! Bad scenes: one clear stderr line naming the file and the field, exit code 2, no panic.

mod common;
use common::*;

fn fig8a() -> serde_json::Value {
    read_json(&repo("data/scenes/paper-gear-fig8a.json"))
}

fn check(name: &str, text: &str, needles: &[&str]) {
    let dir = temp_dir(&format!("bad-{name}"));
    let path = write(&dir, &format!("{name}.json"), text);
    for cmd in ["simulate", "stability"] {
        let run = gearvib(&[cmd, &path, "--json"]);
        let mut all = vec![name];
        all.extend_from_slice(needles);
        assert_one_line_error(&run, &all);
        assert!(run.stdout.is_empty(), "nothing on stdout: {}", run.stdout);
    }
}

fn edited(edit: impl Fn(&mut serde_json::Value)) -> String {
    let mut v = fig8a();
    edit(&mut v);
    v.to_string()
}

#[test]
fn syntax_error() {
    check("syntax", "{\"model\": \"gear_pair\",, }", &["line 1"]);
}

#[test]
fn truncated_and_empty_files() {
    let full = fig8a().to_string();
    check("truncated", &full[..full.len() / 2], &["EOF"]);
    check("empty", "", &["EOF"]);
}

#[test]
fn unknown_field() {
    check(
        "unknown",
        &edited(|v| v["gear_pair"]["pinion"]["colour"] = "red".into()),
        &["gear_pair.pinion.colour", "unknown field `colour`"],
    );
}

#[test]
fn missing_field() {
    check(
        "missing",
        &edited(|v| {
            v["gear_pair"].as_object_mut().unwrap().remove("speed_rpm");
        }),
        &["field `gear_pair`", "missing field `speed_rpm`"],
    );
}

#[test]
fn wrong_type() {
    check(
        "wrongtype",
        &edited(|v| v["gear_pair"]["pinion"]["teeth"] = "fourteen".into()),
        &["gear_pair.pinion.teeth", "invalid type"],
    );
}

#[test]
fn non_finite_number() {
    let text = fig8a().to_string().replace("\"speed_rpm\":1800.0", "\"speed_rpm\":1e999");
    assert!(text.contains("1e999"));
    check("nonfinite", &text, &["gear_pair.speed_rpm", "number out of range"]);
}

#[test]
fn physically_meaningless_values() {
    check(
        "negmass",
        &edited(|v| v["gear_pair"]["pinion"]["inertia_kg_m2"] = (-0.1).into()),
        &["gear_pair.pinion.inertia_kg_m2", "positive"],
    );
    check("zeroteeth", &edited(|v| v["gear_pair"]["wheel"]["teeth"] = 0.into()), &["gear_pair.wheel.teeth"]);
    check(
        "zerostiff",
        &edited(|v| v["gear_pair"]["mesh_stiffness"]["fourier"]["mean_n_per_m"] = 0.0.into()),
        &["mean_n_per_m"],
    );
    check("zerospeed", &edited(|v| v["gear_pair"]["speed_rpm"] = 0.0.into()), &["gear_pair.speed_rpm"]);
    check(
        "negdamp",
        &edited(|v| v["gear_pair"]["damping_ratio"] = (-0.01).into()),
        &["gear_pair.damping_ratio", ">= 0"],
    );
    check("tol", &edited(|v| v["solver"]["tolerance"] = 2.0.into()), &["solver.tolerance", "[1e-15, 1)"]);
    check("method", &edited(|v| v["solver"]["method"] = "euler".into()), &["solver.method", "euler"]);
}

#[test]
fn mismatched_matrix_sizes() {
    let json = ltp_scene(
        1.0,
        r#"[[{"mean": 1.0}, {"mean": 0.0}]]"#,
        r#"[[{"mean": 0.0}]]"#,
        r#"[[{"mean": 1.0}]]"#,
        r#"[{"mean": 0.0}]"#,
        "{}",
    );
    check("sizes", &json, &["ltp.mass[0]", "expected 1"]);
}

#[test]
fn singular_mass_matrix() {
    let m = r#"[[{"mean": 1.0}, {"mean": 2.0}], [{"mean": 2.0}, {"mean": 4.0}]]"#;
    let z = r#"[[{"mean": 0.0}, {"mean": 0.0}], [{"mean": 0.0}, {"mean": 0.0}]]"#;
    let json = ltp_scene(1.0, m, z, z, r#"[{"mean": 0.0}, {"mean": 0.0}]"#, "{}");
    check("singular", &json, &["ltp.mass", "singular"]);
}

#[test]
fn missing_file() {
    let run = gearvib(&["simulate", "no/such/scene.json"]);
    assert_one_line_error(&run, &["no/such/scene.json", "cannot read"]);
}

#[test]
fn huge_input_is_refused_not_allocated() {
    // a wheel with 99991 teeth (prime) and pinion errors: the hunting period holds 14 x 99991 mesh cycles
    check(
        "huge",
        &edited(|v| {
            v["gear_pair"]["wheel"]["teeth"] = 99991.into();
            v["gear_pair"]["wheel"]["errors"] = serde_json::json!([{"order": 1, "amplitude_m": 1e-6}]);
        }),
        &["mesh cycles"],
    );
}

#[test]
fn solver_choices_that_cannot_work() {
    // paper gear: k_z reaches harmonic 140 and the forcing 146 over one pinion revolution
    check(
        "fewharmonics",
        &edited(|v| v["solver"] = serde_json::json!({"method": "hill", "harmonics": 50})),
        &["solver.harmonics = 50", "146"],
    );
    // a jump in the coefficients: harmonic balance would converge only algebraically, so it is refused
    check(
        "hilljump",
        &edited(|v| {
            v["solver"] = serde_json::json!({"method": "hill"});
            v["gear_pair"]["mesh_stiffness"] =
                serde_json::json!({"rectangular": {"contact_ratio": 1.6, "pair_stiffness_n_per_m": 5e8}});
        }),
        &["harmonic balance needs Fourier-series coefficients"],
    );
    // an explicit step count far below the rk4 stability limit (67 steps per revolution here)
    check(
        "fewsteps",
        &edited(|v| v["solver"] = serde_json::json!({"method": "rk4", "steps": 10})),
        &["stability limit"],
    );
}

#[test]
fn mass_matrix_not_positive_definite() {
    // a negative mass once gave an "unstable" answer with exit 0
    let z = r#"[[{"mean": 0.0}]]"#;
    let json = ltp_scene(1.0, r#"[[{"mean": -1.0}]]"#, z, r#"[[{"mean": 4.0}]]"#, r#"[{"mean": 1.0}]"#, "{}");
    check("negmass-ltp", &json, &["ltp.mass", "positive definite"]);
    // an asymmetric mass matrix
    let m = r#"[[{"mean": 1.0}, {"mean": 0.5}], [{"mean": 0.0}, {"mean": 1.0}]]"#;
    let z2 = r#"[[{"mean": 0.0}, {"mean": 0.0}], [{"mean": 0.0}, {"mean": 0.0}]]"#;
    let k2 = r#"[[{"mean": 1.0}, {"mean": 0.0}], [{"mean": 0.0}, {"mean": 1.0}]]"#;
    let json = ltp_scene(1.0, m, z2, k2, r#"[{"mean": 0.0}, {"mean": 0.0}]"#, "{}");
    check("asym-ltp", &json, &["ltp.mass", "symmetric positive definite"]);
}
