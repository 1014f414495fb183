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
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("machine-diagnose-v{GENERATOR_VERSION}"));
    std::fs::create_dir_all(&d).expect("cache dir");
    d
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
        let rec = two_stage(&TwoStage::example(), fault, seed, None, TWO_STAGE_S);
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

#[test]
#[ignore]
fn explore_two_stage() {
    let dir = temp_dir("machine-explore");
    let m = machine_file(&dir, "box.json", TWO_STAGE_MACHINE);
    let fault = StageFault { stage: 1, fault: Fault { kind: FaultKind::Crack(0.5), gear: Gear::Pinion, tooth: 12 } };
    let (h1, _) = two_stage_file("healthy-1", None, 1);
    let (h2, _) = two_stage_file("healthy-2", None, 2);
    let (c, first) = two_stage_file("crack-pinion2-t12", Some(fault), 4);
    eprintln!("first pulse at input revolution {first}");
    for args in [
        vec!["diagnose", c.to_str().unwrap(), "--machine", m.to_str().unwrap()],
        vec![
            "diagnose",
            c.to_str().unwrap(),
            "--machine",
            m.to_str().unwrap(),
            "--baseline",
            h1.to_str().unwrap(),
            h2.to_str().unwrap(),
        ],
        vec!["diagnose", h1.to_str().unwrap(), "--machine", m.to_str().unwrap(), "--baseline", h2.to_str().unwrap()],
    ] {
        let r = gearvib(&args);
        eprintln!("{}\n{}", r.stdout, r.stderr);
    }
}

fn intermediate_tsa(path: &Path, m: &Path) -> Vec<f64> {
    let opts = gearvib::jobs::diagnose::Options {
        machine: Some(gearvib::scene::machine::load_machine_file(m.to_str().unwrap()).unwrap()),
        ..Default::default()
    };
    let d = gearvib::jobs::diagnose::diagnose(path, &opts, None).unwrap();
    d.gears.iter().find(|g| g.gear.name() == "intermediate").unwrap().tsa.clone()
}

fn spectrum(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    (0..n / 2)
        .map(|k| {
            let (mut re, mut im) = (0.0, 0.0);
            for (j, v) in x.iter().enumerate() {
                let p = 2.0 * PI * (k * j) as f64 / n as f64;
                re += v * p.cos();
                im -= v * p.sin();
            }
            (re * re + im * im) / (n * n) as f64 * 4.0
        })
        .collect()
}

#[test]
#[ignore]
fn explore_band() {
    let dir = temp_dir("machine-explore-band");
    let m = machine_file(&dir, "box.json", TWO_STAGE_MACHINE);
    let (h1, _) = two_stage_file("healthy-1", None, 1);
    let b = spectrum(&intermediate_tsa(&h1, &m)[..]);
    for (name, stage, gear, tooth) in [
        ("crack-wheel1-t17", 0, Gear::Wheel, 17),
        ("crack-pinion2-t5", 1, Gear::Pinion, 5),
        ("healthy-2", 9, Gear::Wheel, 1),
    ] {
        let fault =
            (stage < 9).then_some(StageFault { stage, fault: Fault { kind: FaultKind::Crack(0.5), gear, tooth } });
        let (c, _) = two_stage_file(name, fault, 3);
        let x = spectrum(&intermediate_tsa(&c, &m)[..]);
        let nyq = x.len();
        for (z, other) in [(61usize, 19usize), (19, 61)] {
            let near_other = |k: usize| {
                let h = (k as f64 / other as f64).round() as usize;
                k.abs_diff(h * other) <= 1
            };
            for nmax in [1usize, 3, 6] {
                let (mut ex, mut eb, mut cnt) = (0.0, 0.0, 0);
                for h in 1..=(nyq / z).min(6) {
                    for n in 1..=nmax {
                        for k in [h * z - n, h * z + n] {
                            if k < nyq && !near_other(k) {
                                ex += x[k];
                                eb += b[k];
                                cnt += 1;
                            }
                        }
                    }
                }
                eprintln!("{name} z {z} n<={nmax}: growth {:.2} ({cnt} bins) x {ex:.3e} b {eb:.3e}", ex / eb);
            }
        }
    }
}

#[test]
#[ignore]
fn explore_width() {
    let dir = temp_dir("machine-explore-width");
    let m = machine_file(&dir, "box.json", TWO_STAGE_MACHINE);
    let opts = gearvib::jobs::diagnose::Options {
        machine: Some(gearvib::scene::machine::load_machine_file(m.to_str().unwrap()).unwrap()),
        ..Default::default()
    };
    for (name, stage, gear, tooth, seed) in [
        ("crack-wheel1-t17", 0, Gear::Wheel, 17, 3),
        ("crack-pinion2-t5", 1, Gear::Pinion, 5, 3),
        ("crack-wheel1-t40", 0, Gear::Wheel, 40, 4),
        ("crack-pinion2-t12", 1, Gear::Pinion, 12, 4),
        ("healthy-2", 9, Gear::Wheel, 1, 2),
    ] {
        let fault =
            (stage < 9).then_some(StageFault { stage, fault: Fault { kind: FaultKind::Crack(0.5), gear, tooth } });
        let (c, _) = two_stage_file(name, fault, seed);
        let d = gearvib::jobs::diagnose::diagnose(&c, &opts, None).unwrap();
        let g = d.gears.iter().find(|g| g.gear.name() == "intermediate").unwrap();
        for sig in [&g.difference, &g.residual] {
            let n = sig.len();
            let e: Vec<f64> = sig.iter().map(|v| v * v).collect();
            let tot: f64 = e.iter().sum();
            let frac = |w: usize| (0..n).map(|i| (0..w).map(|k| e[(i + k) % n]).sum::<f64>()).fold(0.0, f64::max) / tot;
            let mut line = format!("{name}: ");
            for z in [61usize, 19] {
                for c in [1.0, 2.0, 3.0] {
                    let w = ((c * n as f64 / z as f64).round() as usize).max(1);
                    line += &format!(" z{z} x{c}: {:.3} ({:.3} of uniform)", frac(w), frac(w) / (w as f64 / n as f64));
                }
            }
            eprintln!("{line}");
        }
    }
}
