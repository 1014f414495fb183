//! `gearvib diagnose --machine` (issue 30, item 2) on recordings of the independent test generator
//! (`common::gearbox_gen`: a physics gearvib's engine does not simulate): a two-stage parallel box and a
//! planetary stage, each checked against what the generator seeded and against closed forms.

mod common;
use common::gearbox_gen::*;
use common::*;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// Cached recordings (the generator integrates at 60 kHz+: seconds per recording).
fn cache_dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("machine-diagnose-v{GENERATOR_VERSION}-plant"));
    std::fs::create_dir_all(&d).expect("cache dir");
    d
}

/// The surroundings of the test machines: one installation, so one noise level (half the gears' RMS),
/// shock rate, fan and mains for all their recordings (the seed still draws the noise, the shocks, the load
/// and the speed fluctuation). The generator's default draws a noise level of 0.35-0.7 per recording,
/// which makes two recordings of one machine differ like two sensors: a statistical baseline of two
/// recordings cannot tell that from a fault.
fn plant() -> Environment {
    Environment { noise: 0.5, shock_rate: 0.3, fan_blades: 9, mains_hz: 50.0 }
}

/// Seconds of each two-stage recording: the output shaft (0.152 of the input's 24.7 Hz) turns 3.75 times a
/// second, so 16 s give 60 output revolutions (7 blocks of 8).
const TWO_STAGE_S: f64 = 16.0;

/// A two-stage recording (accelerometer channel 1, input tachometer channel 2), cached by name; also returns
/// the true input angle at the first tachometer pulse, in revolutions.
fn two_stage_file(name: &str, fault: Option<StageFault>, seed: u64) -> (PathBuf, f64) {
    let path = cache_dir().join(format!("{name}.wav"));
    let angle_path = cache_dir().join(format!("{name}.first-pulse"));
    if !path.exists() || !angle_path.exists() {
        let rec = two_stage(&TwoStage::example(), fault, seed, Some(&plant()), TWO_STAGE_S);
        std::fs::write(&angle_path, format!("{}", first_pulse_revs(&rec))).expect("write angle");
        write_wav(&path, &rec);
    }
    let revs: f64 = std::fs::read_to_string(&angle_path).expect("angle").trim().parse().expect("number");
    (path, revs)
}

/// The true input angle (revolutions) at the first rising edge of the tachometer.
fn first_pulse_revs(rec: &Recording) -> f64 {
    let i = (1..rec.tacho.len()).find(|&i| rec.tacho[i] > 0.5 && rec.tacho[i - 1] <= 0.5).expect("a pulse");
    rec.angle[i] / (2.0 * PI)
}

fn machine_file(dir: &Path, name: &str, json: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, json).expect("write machine");
    p
}

const TWO_STAGE_MACHINE: &str = r#"{
  "machine": "two-stage test box",
  "shafts": ["input", "intermediate", "output"],
  "stages": [
    {"kind": "parallel", "driving": "input", "driven": "intermediate", "teeth": [23, 61]},
    {"kind": "parallel", "driving": "intermediate", "driven": "output", "teeth": [19, 47]}
  ],
  "speed": {"shaft": "input", "nominal_rpm": 1480, "tolerance": 0.05},
  "tachometer": {"channel": 2, "shaft": "input", "pulses_per_rev": 1},
  "sensors": [{"channel": 1, "position": "output bearing, radial", "unit": "m/s^2", "sensitivity": 1.0}]
}"#;

fn json_of(run: &Run) -> serde_json::Value {
    assert_eq!(run.code, 0, "stderr: {}", run.stderr);
    serde_json::from_str(run.stdout.lines().next().expect("a line")).expect("json")
}

const PLANETARY_S: f64 = 48.0;

/// A planetary recording (accelerometer channel 1, carrier tachometer channel 2), cached by name.
fn planetary_file(name: &str, fault: Option<PlanetaryFault>, seed: u64) -> PathBuf {
    let path = cache_dir().join(format!("{name}-{PLANETARY_S}s.wav"));
    if !path.exists() {
        let rec = planetary(&Planetary::example(), fault, seed, Some(&plant()), PLANETARY_S);
        write_wav(&path, &rec);
    }
    path
}

/// The generator's stage: sun 21 on the input, ring 83 fixed, three planets of 31 at 0, 35 and 69 slots of
/// 360/104 degrees, carrier tachometer on channel 2.
fn planetary_machine() -> String {
    let p = Planetary::example();
    let angles: Vec<String> = (1..=3).map(|i| format!("{}", p.angle_deg(i))).collect();
    format!(
        r#"{{"machine": "planetary test stage", "shafts": ["sun", "carrier"],
  "stages": [{{"kind": "planetary", "sun": "sun", "carrier": "carrier", "ring": "fixed", "planets": 3,
     "teeth": {{"sun": 21, "planet": 31, "ring": 83}}, "planet_angles_deg": [{}]}}],
  "speed": {{"shaft": "sun", "nominal_rpm": 1500, "tolerance": 0.05}},
  "tachometer": {{"channel": 2, "shaft": "carrier", "pulses_per_rev": 1}},
  "sensors": [{{"channel": 1, "position": "ring, top", "unit": "m/s^2", "sensitivity": 1.0}}]}}"#,
        angles.join(", ")
    )
}

fn run_machine(rec: &Path, machine: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["diagnose", rec.to_str().unwrap(), "--machine", machine.to_str().unwrap(), "--json"];
    args.extend_from_slice(extra);
    json_of(&gearvib(&args))
}

/// The two healthy recordings of the two-stage box that make its baseline.
fn two_stage_baseline() -> [PathBuf; 2] {
    [two_stage_file("healthy-1", None, 1).0, two_stage_file("healthy-2", None, 2).0]
}

/// A 50 % crack on the intermediate shaft's pinion (stage 2's driving gear, 19 teeth) is flagged on that gear
/// (shaft `intermediate`, stage 2, `pinion`) and on its tooth. No tachometer watches the intermediate shaft,
/// so its teeth are counted from a relative origin, which the diagnosis states: the intermediate's angle at
/// the input's first tachometer pulse, 23/61 of the input's angle there (the generator starts every angle at
/// 0 together). The expected tooth is computed from the generator's truth: tooth n is centred (n - 1/2) / 19
/// of an intermediate revolution after its absolute origin.
#[test]
fn intermediate_pinion_crack_is_flagged_on_its_gear_and_tooth() {
    let dir = temp_dir("machine-two-stage-crack");
    let m = machine_file(&dir, "box.json", TWO_STAGE_MACHINE);
    let [h1, h2] = two_stage_baseline();
    let b = TwoStage::example();
    for (tooth, seed) in [(12, 4), (5, 3)] {
        let fault = StageFault { stage: 1, fault: Fault { kind: FaultKind::Crack(0.5), gear: Gear::Pinion, tooth } };
        let (rec, first_pulse) = two_stage_file(&format!("crack-pinion2-t{tooth}"), Some(fault), seed);
        let j = run_machine(&rec, &m, &["--baseline", h1.to_str().unwrap(), h2.to_str().unwrap()]);
        let v = &j["verdict"];
        assert_eq!(v["state"], "faulty", "{v}");
        assert_eq!(v["shaft"], "intermediate", "{v}");
        assert_eq!(v["stage"], 2, "{v}");
        assert_eq!(v["gear"], "pinion", "{v}");
        assert_eq!(v["tooth_origin"], "relative (no tachometer on this shaft)", "{v}");
        let z = b.teeth[2] as f64;
        // the pulse is at a whole input revolution; the intermediate has turned 23/61 of it there
        let origin = b.ratios()[1] * first_pulse.round();
        let relative = ((tooth as f64 - 0.5) / z - origin).rem_euclid(1.0);
        let expected = (relative * z).floor() as i64 + 1;
        let got = v["tooth"].as_i64().expect("a tooth");
        // the housing's ringing can only delay the impulse's centre (by up to one pitch: the generator's own
        // test), and the onset rule may land one pitch early on a sharp rise: exact or one off, cyclically
        let off = (got - expected).rem_euclid(b.teeth[2] as i64);
        assert!(off == 0 || off == 1 || off == b.teeth[2] as i64 - 1, "tooth {got}, expected {expected}: {v}");
        // the reasons say how the two gears of the shaft were told apart and where the teeth are counted from
        let reasons = v["reasons"].to_string();
        assert!(reasons.contains("the shaft carries 2 gears"), "{reasons}");
        assert!(reasons.contains("relative origin"), "{reasons}");
        // every shaft's speed is the tracked input's times its exact ratio
        let f = &j["shaft_hz"];
        let fin = f["input"].as_f64().unwrap();
        let r = b.ratios();
        for (name, ratio) in [("intermediate", r[1]), ("output", r[2])] {
            assert!((f[name].as_f64().unwrap() / fin - ratio).abs() < 1e-12, "{name}: {f}");
        }
    }
}

/// Healthy recordings of seven other seeds against a healthy baseline of four are never called faulty nor
/// left unjudged.
///
/// It failed (seeds 5, 8 and 11 faulty, 9 suspect; the pair path `--teeth 23,61 --tacho-channel 2` 5 and
/// 11) while the tachometer's revolution starts were smoothed over 17 revolutions: the generator's speed
/// fluctuation of up to 2 % at up to 1.5 Hz (a cycle per 16 input revolutions) was taken out of the angle,
/// 0.02 revolution rms, which smeared the input's mesh harmonics (order 115: 16 rad of phase) and moved the
/// energy indicators from recording to recording. The window is now chosen by its prediction error.
#[test]
fn two_stage_healthy_is_never_faulty() {
    let dir = temp_dir("machine-two-stage-healthy");
    let m = machine_file(&dir, "box.json", TWO_STAGE_MACHINE);
    let baseline: Vec<PathBuf> = (1..=4).map(|k| two_stage_file(&format!("healthy-{k}"), None, k).0).collect();
    let mut args = vec!["--baseline"];
    args.extend(baseline.iter().map(|h| h.to_str().unwrap()));
    for seed in 5..=11 {
        let (rec, _) = two_stage_file(&format!("healthy-{seed}"), None, seed);
        let j = run_machine(&rec, &m, &args);
        assert_ne!(j["verdict"]["state"], "faulty", "seed {seed}: {}", j["verdict"]);
        assert_ne!(j["verdict"]["state"], "not_judged", "seed {seed}: {}", j["verdict"]);
        // a suspect verdict (seed 8: its output shaft modulated once per revolution, the envelope's output
        // order 1 and SBR, both at most suspect alone) names the shaft and its gear, and no tooth since no
        // average moved as a tooth's fault moves it
        if j["verdict"]["state"] == "suspect" {
            assert!(j["verdict"]["shaft"].is_string() && j["verdict"]["stage"].is_number(), "{}", j["verdict"]);
            assert!(j["verdict"]["tooth"].is_null(), "{}", j["verdict"]);
        }
    }
}

/// Every stage's mesh harmonics and the sideband families of every shaft on it, at the closed-form orders
/// of the tracked input shaft: stage 1 at 23 k, stage 2 at 23 x 19 / 61 k; an intermediate family spaced by
/// 23/61 around both meshes, the output's by 23 x 19 / (61 x 47) around stage 2's only.
#[test]
fn two_stage_lines_sit_at_closed_form_orders() {
    let dir = temp_dir("machine-two-stage-lines");
    let m = machine_file(&dir, "box.json", TWO_STAGE_MACHINE);
    let (rec, _) = two_stage_file("healthy-1", None, 1);
    let j = run_machine(&rec, &m, &[]);
    let stages = j["machine"]["stages"].as_array().unwrap();
    let (r1, r2) = (23.0 / 61.0, 23.0 * 19.0 / (61.0 * 47.0));
    for (s, mesh, families) in [
        (&stages[0], 23.0, vec![("input", 1.0), ("intermediate", r1)]),
        (&stages[1], 19.0 * r1, vec![("intermediate", r1), ("output", r2)]),
    ] {
        assert!((s["mesh_order"].as_f64().unwrap() - mesh).abs() < 1e-12, "{s}");
        for h in s["mesh_harmonics"].as_array().unwrap() {
            let k = h["k"].as_f64().unwrap();
            assert!((h["order"].as_f64().unwrap() - k * mesh).abs() < 1e-9);
            for sb in h["sidebands"].as_array().unwrap() {
                let fam = sb["family"].as_str().unwrap();
                let spacing = families.iter().find(|f| f.0 == fam).unwrap_or_else(|| panic!("family {fam}")).1;
                let want = k * mesh + sb["offset"].as_f64().unwrap() * spacing;
                assert!((sb["order"].as_f64().unwrap() - want).abs() < 1e-9, "{sb}");
            }
        }
    }
    assert_eq!(stages[0]["mesh_order_exact"], "23");
    assert_eq!(stages[1]["mesh_order_exact"], "437/61");
}

/// Each stage's table lists the mesh harmonics the sample rate allows: every one up to 0.45 fs, at most 16.
/// A recording of pure tones at 8 kHz (the two-stage box at 1480 rpm with a once-per-revolution input
/// tachometer): stage 1 meshes at 23 x 24.67 = 567.3 Hz, so harmonics 1..6 (6 x 567.3 = 3404 Hz, the 7th
/// at 3971 Hz is above 3600 Hz though below the Nyquist frequency); stage 2 at 19 x 23/61 x 24.67 = 176.7
/// Hz, so 20 fit and 16 are listed. Every listed harmonic (beyond the former 3) reads the amplitude given
/// to its tone.
#[test]
fn stage_tables_list_the_mesh_harmonics_the_sample_rate_allows() {
    let dir = temp_dir("machine-harmonics");
    let m = machine_file(&dir, "box.json", TWO_STAGE_MACHINE);
    let (fs, f_in) = (8000.0, 1480.0 / 60.0);
    let mesh = [23.0 * f_in, 19.0 * 23.0 / 61.0 * f_in];
    // amplitudes: stage 1 harmonic h 1 / h (m/s^2), stage 2's 0.4 / h; the 7th of stage 1 present too
    let amp = |s: usize, h: usize| if s == 0 { 1.0 / h as f64 } else { 0.4 / h as f64 };
    let tones: Vec<(f64, f64)> = (1..=7)
        .map(|h| (h as f64 * mesh[0], amp(0, h)))
        .chain((1..=20).map(|h| (h as f64 * mesh[1], amp(1, h))))
        .collect();
    let n = (8.0 * fs) as usize;
    let accel: Vec<f64> =
        (0..n).map(|i| tones.iter().map(|(f, a)| a * (2.0 * PI * f * i as f64 / fs + 0.3 * f).sin()).sum()).collect();
    // the tachometer is high over the first 5 % of each input revolution
    let tacho: Vec<f64> = (0..n).map(|i| if (i as f64 / fs * f_in).fract() < 0.05 { 1.0 } else { 0.0 }).collect();
    let rec = dir.join("tones-8kHz.wav");
    write_channels(&rec, fs, &[&accel, &tacho]);
    let j = run_machine(&rec, &m, &[]);
    let stages = j["machine"]["stages"].as_array().unwrap();
    for (s, want) in [(0, 6), (1, 16)] {
        let hs = stages[s]["mesh_harmonics"].as_array().unwrap();
        assert_eq!(hs.len(), want, "stage {}: {} harmonics", s + 1, hs.len());
        for (i, h) in hs.iter().enumerate() {
            assert_eq!(h["k"], i + 1);
            let f = h["frequency_hz"].as_f64().unwrap();
            let a = h["amplitude"].as_f64().unwrap();
            let (f0, a0) = ((i + 1) as f64 * mesh[s], amp(s, i + 1));
            // the line's frequency within a tenth of a hertz (the scalloping correction's offset is exact for
            // an isolated Hann line; the nearest other tone is 9 Hz away) and its amplitude within 2 % (the
            // 32-bit float samples and the neighbours' Hann sidelobes, below 1e-3 of them at 9 Hz)
            assert!((f - f0).abs() < 0.1, "stage {} harmonic {}: {f} Hz against {f0}", s + 1, i + 1);
            assert!((a - a0).abs() < 0.02 * a0, "stage {} harmonic {}: {a} against {a0}", s + 1, i + 1);
        }
    }
}

/// The report's spectrum marks each stage's mesh lines and each family in its own colour, the legend naming
/// the stage's shafts.
#[test]
fn report_marks_every_stage_in_its_own_colour() {
    let dir = temp_dir("machine-report");
    let m = machine_file(&dir, "box.json", TWO_STAGE_MACHINE);
    let opts = gearvib::jobs::diagnose::Options {
        machine: Some(gearvib::scene::machine::load_machine_file(m.to_str().unwrap()).unwrap()),
        ..Default::default()
    };
    // a steady-speed recording: the speed-change rule (order spectrum instead) keeps the Hz spectrum here
    let rec = two_stage(&TwoStage::example(), None, 11, Some(&Environment::quiet()), 8.0);
    let path = dir.join("steady.wav");
    write_wav(&path, &rec);
    let d = gearvib::jobs::diagnose::diagnose(&path, &opts, None).unwrap();
    let figures = gearvib::report::figures::diagnosis_figures(&d);
    let charts: Vec<&gearvib::report::plot::Chart> = figures.iter().flat_map(|f| f.charts.iter()).collect();
    let spectrum = charts
        .iter()
        .find(|c| c.title.contains("spectrum") && c.series.iter().any(|s| s.name.starts_with("stage 1 mesh")))
        // (an order spectrum when the generator's speed fluctuation exceeds 2 %, else the spectrum in Hz)
        .expect("a spectrum with stage 1's mesh lines");
    let stage =
        |k: usize| spectrum.series.iter().find(|s| s.name.starts_with(&format!("stage {k} mesh"))).expect("stage");
    let (s1, s2) = (stage(1), stage(2));
    assert_ne!(s1.color, s2.color);
    assert!(s1.name.contains("on `input`") && s1.name.contains("on `intermediate`"), "{}", s1.name);
    assert!(s2.name.contains("on `intermediate`") && s2.name.contains("on `output`"), "{}", s2.name);
    let colours: Vec<usize> = spectrum.markers.iter().map(|m| m.color).collect();
    assert!(colours.contains(&s1.color) && colours.contains(&s2.color), "markers {colours:?}");
    // the highest stage's third mesh harmonic is on the chart: order 3 x 23 of the input, or 3 x 23 x the
    // input's frequency in Hz (the generator's 1480 rpm within its 2 % fluctuation)
    let top = spectrum.x_range.expect("a range").1;
    let third = if spectrum.x_label.contains("order") { 69.0 } else { 69.0 * 1480.0 / 60.0 * 1.02 };
    assert!(top > third, "the chart stops at {top}, before the third mesh harmonic {third}");
    // the legend and labels stay off the data (the layout rule of every report image)
    for f in &figures {
        gearvib::report::plot::layout(f.width, f.height, 1, &f.charts).unwrap_or_else(|e| panic!("{}: {e}", f.file));
    }
}

/// Planetary stage: a 50 % crack on one planet names that planet (against a healthy baseline), for faults on
/// each planet, several teeth and seeds; sun, planet and ring fault orders are the closed forms for 21/31/83
/// teeth and 3 planets (gearboxes.md section 2).
///
/// Regression: a crack on planet 2's tooth 7 was named planet 3 in 4 of 4 seeds. The planet's fault also
/// reaches the sensor through its sun mesh at every carrier angle; squaring the raw signal multiplied that
/// copy with planet 3's meshing while planet 3 passed the sensor, and planet 3's gate grew more than planet
/// 2's (the planet-fault energy is now taken on the tooth-to-tooth difference).
#[test]
fn planetary_fault_names_the_planet() {
    let dir = temp_dir("machine-planetary");
    let m = machine_file(&dir, "stage.json", &planetary_machine());
    let baseline = planetary_file("planetary-healthy-1", None, 1);
    let cases = [
        (1, 3, 6),
        (2, 20, 8),
        (3, 20, 4),
        (1, 7, 9),
        (1, 13, 10),
        (2, 7, 9),
        (2, 7, 10),
        (2, 7, 11),
        (3, 7, 9),
        (3, 13, 10),
    ];
    for (planet, tooth, seed) in cases {
        let fault = PlanetaryFault { member: Member::Planet(planet), kind: FaultKind::Crack(0.5), tooth };
        let rec = planetary_file(&format!("planetary-p{planet}t{tooth}-s{seed}"), Some(fault), seed);
        let j = run_machine(&rec, &m, &["--baseline", baseline.to_str().unwrap()]);
        let v = &j["verdict"];
        assert!(v["state"] == "faulty" || v["state"] == "suspect", "planet {planet} tooth {tooth} seed {seed}: {v}");
        assert_eq!(v["gear"], "planet", "planet {planet} tooth {tooth} seed {seed}: {v}");
        assert_eq!(v["planet"], planet, "planet {planet} tooth {tooth} seed {seed}: {v}");
        assert_eq!(v["stage"], 1, "{v}");
        // closed forms (carrier orders; ring fixed): sun fault N_p z_r / z_s, ring fault N_p, planet fault
        // z_r / z_p, planet pass N_p, the sun turning (z_s + z_r) / z_s times the carrier
        let p = &j["machine"]["stages"][0]["planetary"];
        let (zs, zp, zr, np) = (21.0, 31.0, 83.0, 3.0);
        for (key, want) in [
            ("sun_fault", np * zr / zs),
            ("ring_fault", np),
            ("planet_fault", zr / zp),
            ("planet_fault_both", 2.0 * zr / zp),
            ("planet_pass", np),
            ("mesh", zr),
        ] {
            let got = p["orders"][key].as_f64().unwrap();
            assert!((got - want).abs() < 1e-12 * want, "{key}: {got} against {want}");
        }
        let fc = j["shaft_hz"]["carrier"].as_f64().unwrap();
        let fs = j["shaft_hz"]["sun"].as_f64().unwrap();
        assert!((fs / fc - (zs + zr) / zs).abs() < 1e-12);
        // in Hz: sun fault N_p (f_s - f_c), ring fault N_p f_c
        let hz = |k: &str| p["frequencies_hz"][k].as_f64().unwrap();
        assert!((hz("sun_fault") - np * (fs - fc)).abs() < 1e-9 * hz("sun_fault"));
        assert!((hz("ring_fault") - np * fc).abs() < 1e-9 * hz("ring_fault"));
    }
}

/// Healthy planetary recordings of three other seeds against the healthy baseline name no planet and are
/// never faulty.
#[test]
fn planetary_healthy_is_never_faulty() {
    let dir = temp_dir("machine-planetary-healthy");
    let m = machine_file(&dir, "stage.json", &planetary_machine());
    let baseline = planetary_file("planetary-healthy-1", None, 1);
    for seed in [2, 5, 7] {
        let rec = planetary_file(&format!("planetary-healthy-{seed}"), None, seed);
        let j = run_machine(&rec, &m, &["--baseline", baseline.to_str().unwrap()]);
        assert_ne!(j["verdict"]["state"], "faulty", "seed {seed}: {}", j["verdict"]);
        assert!(j["verdict"]["planet"].is_null(), "seed {seed}: {}", j["verdict"]);
    }
}

/// A machine that does not fit is refused on one line naming the flag or the machine's field, exit code 2.
#[test]
fn machine_that_does_not_fit_is_refused_naming_the_field() {
    let dir = temp_dir("machine-errors");
    let m = machine_file(&dir, "box.json", TWO_STAGE_MACHINE);
    let (rec, _) = two_stage_file("healthy-1", None, 1);
    let rec = rec.to_str().unwrap();
    let fail = |args: &[&str], needle: &str| {
        let r = gearvib(args);
        assert_eq!(r.code, 2, "{args:?}: {}", r.stderr);
        assert!(r.stderr.contains(needle), "{args:?}: {}", r.stderr);
        assert_eq!(r.stderr.trim().lines().count(), 1, "{}", r.stderr);
        assert!(!r.stderr.contains("panicked"));
    };
    fail(&["diagnose", rec, "--machine", m.to_str().unwrap(), "--teeth", "23,61"], "--teeth");
    let absent = machine_file(
        &dir,
        "absent.json",
        &TWO_STAGE_MACHINE.replace(r#""channel": 1, "position""#, r#""channel": 5, "position""#),
    );
    fail(&["diagnose", rec, "--machine", absent.to_str().unwrap()], "sensors[0].channel");
    let tacho = machine_file(
        &dir,
        "tacho.json",
        &TWO_STAGE_MACHINE.replace(r#""tachometer": {"channel": 2"#, r#""tachometer": {"channel": 3"#),
    );
    fail(&["diagnose", rec, "--machine", tacho.to_str().unwrap()], "tachometer.channel");
    let teeth = machine_file(&dir, "teeth.json", &TWO_STAGE_MACHINE.replace("[19, 47]", "[19, 0]"));
    fail(&["diagnose", rec, "--machine", teeth.to_str().unwrap()], "stages[1].teeth");
    fail(&["diagnose", rec, "--machine", dir.join("missing.json").to_str().unwrap()], "missing.json");
    let profile = dir.join("p.json");
    fail(&["diagnose", rec, "--machine", m.to_str().unwrap(), "--profile", profile.to_str().unwrap()], "--machine");
}

/// `learn --machine` stores the machine in the profile; `diagnose --profile` applies it and gives the same
/// verdict, gear and scores as `--baseline` with the machine in one call.
#[test]
fn learned_profile_carries_the_machine() {
    let dir = temp_dir("machine-profile");
    let m = machine_file(&dir, "box.json", TWO_STAGE_MACHINE);
    let [h1, h2] = two_stage_baseline();
    let profile = dir.join("box-profile.json");
    let r = gearvib(&[
        "learn",
        h1.to_str().unwrap(),
        h2.to_str().unwrap(),
        "--machine",
        m.to_str().unwrap(),
        "-o",
        profile.to_str().unwrap(),
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let stored: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&profile).unwrap()).unwrap();
    assert_eq!(stored["processing"]["machine"]["machine"], "two-stage test box");
    // the summary names the machine, not "estimated" teeth
    assert!(r.stdout.contains("the machine `two-stage test box`: 2 stage(s)"), "{}", r.stdout);
    let fault = StageFault { stage: 1, fault: Fault { kind: FaultKind::Crack(0.5), gear: Gear::Pinion, tooth: 12 } };
    let (rec, _) = two_stage_file("crack-pinion2-t12", Some(fault), 4);
    let by_profile =
        json_of(&gearvib(&["diagnose", rec.to_str().unwrap(), "--profile", profile.to_str().unwrap(), "--json"]));
    let by_baseline = run_machine(&rec, &m, &["--baseline", h1.to_str().unwrap(), h2.to_str().unwrap()]);
    for key in ["state", "shaft", "stage", "gear"] {
        assert_eq!(by_profile["verdict"][key], by_baseline["verdict"][key], "{key}");
    }
    let scores = |j: &serde_json::Value| -> Vec<(String, String, f64)> {
        j["scores"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| (s["gear"].to_string(), s["indicator"].to_string(), s["spreads"].as_f64().unwrap()))
            .collect()
    };
    let (a, b) = (scores(&by_profile), scores(&by_baseline));
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        // the stored centres come back through exp(ln x) and JSON: equal to rounding
        assert!(x.0 == y.0 && x.1 == y.1 && (x.2 - y.2).abs() < 1e-6 * (1.0 + y.2.abs()), "{x:?} {y:?}");
    }
}

/// Writes `target/tmp/machine-speed/two-stage-60s-4ch.wav` (four vibration channels, the input tachometer in
/// channel 5) and its machine file, for the timing in the README (`cargo test --release --test
/// machine_diagnose speed_recording -- --ignored`; timings are never a test).
#[test]
#[ignore]
fn speed_recording() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("machine-speed");
    std::fs::create_dir_all(&dir).unwrap();
    let rec = two_stage(&TwoStage::example(), None, 21, Some(&plant()), 60.0);
    let mut rng = common::gearbox_gen::Rng::new(77);
    // three more sensors: the same vibration through other gains, with their own noise
    let others: Vec<Vec<f64>> =
        [0.8, 1.3, 0.6].iter().map(|g| rec.accel.iter().map(|v| g * v + 0.2 * rng.normal()).collect()).collect();
    write_channels(
        &dir.join("two-stage-60s-4ch.wav"),
        rec.fs,
        &[&rec.accel, &others[0], &others[1], &others[2], &rec.tacho],
    );
    let machine = TWO_STAGE_MACHINE.replace(r#""channel": 2, "shaft": "input""#, r#""channel": 5, "shaft": "input""#);
    std::fs::write(dir.join("two-stage-4ch.json"), machine).unwrap();
}

/// A profile learned with a planetary machine stores the planets' healthy energies and names the faulty
/// planet as `--baseline` does.
#[test]
fn planetary_profile_names_the_planet() {
    let dir = temp_dir("machine-planetary-profile");
    let m = machine_file(&dir, "stage.json", &planetary_machine());
    let baseline = planetary_file("planetary-healthy-1", None, 1);
    let profile = dir.join("stage-profile.json");
    let r = gearvib(&[
        "learn",
        baseline.to_str().unwrap(),
        "--machine",
        m.to_str().unwrap(),
        "-o",
        profile.to_str().unwrap(),
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let stored: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&profile).unwrap()).unwrap();
    assert_eq!(stored["planets"][0]["planet_fault_energy"].as_array().map(Vec::len), Some(3), "{}", stored["planets"]);
    let fault = PlanetaryFault { member: Member::Planet(1), kind: FaultKind::Crack(0.5), tooth: 3 };
    let rec = planetary_file("planetary-p1t3-s6", Some(fault), 6);
    let j = json_of(&gearvib(&["diagnose", rec.to_str().unwrap(), "--profile", profile.to_str().unwrap(), "--json"]));
    assert_eq!(j["verdict"]["gear"], "planet", "{}", j["verdict"]);
    assert_eq!(j["verdict"]["planet"], 1, "{}", j["verdict"]);
    // a profile learned before the planets' energy was measured on the tooth-to-tooth difference (no
    // `planet_measure`) is refused with the field named, not applied with energies that no longer compare
    let mut old = stored.clone();
    old.as_object_mut().unwrap().remove("planet_measure");
    let old_path = dir.join("old-profile.json");
    std::fs::write(&old_path, old.to_string()).unwrap();
    let r = gearvib(&["diagnose", rec.to_str().unwrap(), "--profile", old_path.to_str().unwrap()]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("planet_measure") && r.stderr.lines().count() == 1, "{}", r.stderr);
}
