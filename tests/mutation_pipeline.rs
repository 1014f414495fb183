//! Seeded whole-pipeline mutation test (issue 29): more than 2,000 mutants of a short cut of the bundled
//! healthy recording (damaged tachometer pulses, truncated and bit-flipped WAV and CSV files, damaged
//! sidecars, absurd teeth, speeds and pulse counts) run through the diagnose and identify entry points in
//! this process (library calls, not only the readers), and a handful through the binary. Each must give a
//! result or a one-line error naming its input, with no panic, no single allocation above a stated
//! ceiling, and within a per-case bound that only a hang would exceed.

mod common;
use common::mutants::{self, XorShift};
use common::*;
use gearvib::jobs::diagnose::{self, Options};
use std::borrow::Cow;
use std::path::Path;

#[global_allocator]
static ALLOCATOR: mutants::Counting = mutants::Counting;

/// Every input here is under 1 MB (16000 frames): 256 MiB in one request can only come from a size
/// believed from a header or an absurd value.
const CEILING: usize = 256 << 20;
/// Seconds a case may take before it counts as a hang: the slowest legitimate case (an identify) takes
/// well under a second in a release build; a shared 2-core machine may be 10 times slower.
const HANG_S: f64 = 20.0;
/// Frames of the cut: 1.6 s at 10 kHz, 48 revolutions of the 30 Hz pinion (the TSA needs 8).
const FRAMES: usize = 16_000;

/// Runs one case (`mutants::case` with this test's ceiling and hang bound): whether `f` gave a result.
fn case(path: &Path, f: impl FnOnce(&Path) -> Result<(), String> + std::panic::UnwindSafe) -> bool {
    mutants::case(path, CEILING, HANG_S, f)
}

fn diagnose_with(o: Options) -> impl FnOnce(&Path) -> Result<(), String> + std::panic::UnwindSafe {
    move |p: &Path| diagnose::diagnose(p, &o, None).map(|_| ()).map_err(|e| e.to_string())
}

fn identify(p: &Path) -> Result<(), String> {
    let job = gearvib::jobs::identify::IdentifyJob {
        recording: p.to_path_buf(),
        scene: repo("data/scenes/gear-z14z39-healthy.json").into(),
        pinion_orders: 6,
        wheel_orders: 0,
        mesh_harmonics: None,
        faults: Vec::new(),
        pit_width_teeth: 0.5,
        channel: Some(1),
        tacho_channel: Some(2),
        fs_hz: None,
        quantity: None,
        report: None,
    };
    gearvib::jobs::identify::run(&job).map(|_| ()).map_err(|e| e.to_string())
}

fn tacho_options() -> Options {
    Options { tacho_channel: Some(2), teeth: Some((14, 39)), ..Default::default() }
}

/// The bundled healthy recording cut to its vibration and pinion tachometer channels, FRAMES long.
fn base() -> gearvib::io::Recording<'static> {
    let mut rec =
        gearvib::io::read_recording(Path::new(&repo("data/recordings/gear-z14z39-fs10kHz-healthy.wav"))).unwrap();
    rec.channels.truncate(2);
    rec.names.truncate(2);
    rec.units.truncate(2);
    for c in &mut rec.channels {
        *c = Cow::Owned(c[..FRAMES].to_vec());
    }
    rec
}

/// Tachometer damage: chatter bursts, missing pulses, extra pulses, a stuck or noisy channel, pulses of
/// random width, a tachometer that stops.
fn damaged_tacho(rng: &mut XorShift, t: &[f32]) -> Vec<f32> {
    let hi = t.iter().copied().fold(0.0f32, f32::max);
    let mut x = t.to_vec();
    match rng.below(8) {
        0 => {
            // chatter: short pulses every `period` samples over a random stretch
            let (start, len, period) = (rng.below(FRAMES), rng.below(FRAMES), 2 + rng.below(60));
            for (i, v) in x.iter_mut().enumerate().skip(start).take(len) {
                if i % period < period / 2 {
                    *v = hi;
                }
            }
        }
        1 => {
            // pulses removed (every k-th revolution, or a random stretch)
            let k = 2 + rng.below(5);
            let mut rev = 0;
            let mut i = 0;
            while i < FRAMES {
                if t[i] == hi && (i == 0 || t[i - 1] != hi) {
                    rev += 1;
                    let kill = rev % k == 0;
                    while i < FRAMES && t[i] == hi {
                        if kill {
                            x[i] = 0.0;
                        }
                        i += 1;
                    }
                }
                i += 1;
            }
        }
        2 => {
            // a few extra pulses at random places
            for _ in 0..1 + rng.below(20) {
                let at = rng.below(FRAMES);
                for v in x.iter_mut().skip(at).take(1 + rng.below(20)) {
                    *v = hi;
                }
            }
        }
        3 => x.iter_mut().for_each(|v| *v = if rng.below(2) == 0 { hi } else { 0.0 }),
        4 => x.iter_mut().for_each(|v| *v = hi),
        5 => {
            // the tachometer stops part way
            let at = rng.below(FRAMES);
            x[at..].iter_mut().for_each(|v| *v = 0.0);
        }
        6 => {
            // pulse edges jittered by up to 40 samples
            let mut i = 1;
            while i < FRAMES {
                if t[i] == hi && t[i - 1] != hi {
                    let shift = rng.below(80) as isize - 40;
                    let width = (0..).take_while(|k| i + k < FRAMES && t[i + k] == hi).count();
                    for k in 0..width {
                        x[i + k] = 0.0;
                    }
                    for k in 0..width {
                        let j = (i as isize + shift + k as isize).clamp(0, FRAMES as isize - 1) as usize;
                        x[j] = hi;
                    }
                    i += width;
                }
                i += 1;
            }
        }
        _ => {
            // a tachometer of a different (random) pulse rate: one revolution in k
            let k = 1 + rng.below(40);
            x.iter_mut().enumerate().for_each(|(i, v)| *v = if (i / k).is_multiple_of(7) { hi } else { 0.0 });
        }
    }
    x
}

fn bytes_mutant(rng: &mut XorShift, b: &[u8], header: usize) -> Vec<u8> {
    let mut m = b.to_vec();
    match rng.below(3) {
        0 => m.truncate(rng.below(b.len())),
        1 => {
            for _ in 0..1 + rng.below(4) {
                let at = if rng.below(2) == 0 { rng.below(header.min(m.len())) } else { rng.below(m.len()) };
                m[at] ^= 1 << rng.below(8);
            }
        }
        _ => {
            let at = rng.below(m.len());
            m.truncate(at);
            for _ in 0..rng.below(3) {
                let at = rng.below(m.len().max(1));
                if at < m.len() {
                    m[at] ^= 0xFF;
                }
            }
        }
    }
    m
}

fn csv_mutant(rng: &mut XorShift, csv: &str) -> String {
    let mut b = csv.as_bytes().to_vec();
    match rng.below(4) {
        0 => b.truncate(rng.below(b.len())),
        1 => {
            for _ in 0..1 + rng.below(5) {
                let at = rng.below(b.len());
                let alphabet = b",;\t\n.-e0123456789 \"\rnaNI";
                b[at] = alphabet[rng.below(alphabet.len())];
            }
        }
        2 => {
            // the time column's header: units and names
            let heads = ["time [ms]", "time [us]", "time [min]", "t (s)", "time_ns", "timestamp", "x", "time [", ""];
            let text = String::from_utf8_lossy(&b).into_owned();
            let (first, rest) = text.split_once(',').unwrap_or(("", &text));
            let _ = first;
            return format!("{},{rest}", heads[rng.below(heads.len())]);
        }
        _ => {
            let at = rng.below(b.len());
            b[at] ^= 1 << rng.below(8);
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

fn sidecar_mutant(rng: &mut XorShift, text: &str) -> String {
    let mut b = text.as_bytes().to_vec();
    match rng.below(4) {
        0 => b.truncate(rng.below(b.len())),
        1 => {
            let at = rng.below(b.len());
            b[at] ^= 1 << rng.below(8);
        }
        2 => {
            let fields = ["\"full_scale\": null", "\"full_scale\": 0", "\"full_scale\": -1", "\"full_scale\": 1e39"];
            let s = String::from_utf8_lossy(&b).replace("\"full_scale\": null", fields[rng.below(fields.len())]);
            let rates = ["5000.0", "0", "-1", "1e308", "10000.5"];
            return s.replacen("10000.0", rates[rng.below(rates.len())], 1);
        }
        _ => {
            let at = rng.below(b.len());
            let alphabet = b"{}[]:,\"0123456789-e.";
            b[at] = alphabet[rng.below(alphabet.len())];
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

#[test]
fn two_thousand_pipeline_mutants_fail_cleanly() {
    let dir = temp_dir("pipeline-mutants");
    // a fresh campaign: MUTATION_SEED=<u64> (the default seed is the one the fixtures were found with)
    let seed = std::env::var("MUTATION_SEED").ok().and_then(|s| s.parse::<u64>().ok()).filter(|&s| s != 0);
    let mut rng = XorShift(seed.unwrap_or(0x2545_F491_4F6C_DD1D));
    let base = base();
    let (mut count, mut answered) = (0usize, 0usize);
    let mut run = |path: &Path, f: &mut dyn FnMut(&Path) -> bool| {
        count += 1;
        answered += usize::from(f(path));
    };
    // the intact cut is diagnosed (the mutants start from a recording that works)
    let intact = dir.join("intact.wav");
    gearvib::io::write_recording(&intact, &base).unwrap();
    assert!(case(&intact, diagnose_with(tacho_options())), "the intact cut is diagnosed");

    // 1. damaged tachometer pulses: diagnose with the tachometer and the teeth; every 10th also identify
    for i in 0..600 {
        let mut rec = base.clone();
        rec.channels[1] = Cow::Owned(damaged_tacho(&mut rng, &base.channels[1]));
        let p = dir.join(format!("tacho{i}.wav"));
        gearvib::io::write_recording(&p, &rec).unwrap();
        run(&p, &mut |p| case(p, diagnose_with(tacho_options())));
        if i % 10 == 0 {
            run(&p, &mut |p| case(p, identify));
        }
    }
    // 2. truncated and bit-flipped WAV files (the 44-byte header and its sidecar kept), default options and
    // with the tachometer
    let wav = std::fs::read(&intact).unwrap();
    let side = std::fs::read_to_string(gearvib::io::sidecar::path_of(&intact)).unwrap();
    for i in 0..500 {
        let p = dir.join(format!("wav{i}.wav"));
        std::fs::write(&p, bytes_mutant(&mut rng, &wav, 80)).unwrap();
        std::fs::write(gearvib::io::sidecar::path_of(&p), &side).unwrap();
        let o = if i % 2 == 0 { Options::default() } else { tacho_options() };
        run(&p, &mut |p| case(p, diagnose_with(o.clone())));
    }
    // 3. CSV: truncated, bytes replaced, time headers with units
    let csv_path = dir.join("intact.csv");
    gearvib::io::write_recording(&csv_path, &base).unwrap();
    let csv = std::fs::read_to_string(&csv_path).unwrap();
    for i in 0..300 {
        let p = dir.join(format!("csv{i}.csv"));
        std::fs::write(&p, csv_mutant(&mut rng, &csv)).unwrap();
        run(&p, &mut |p| case(p, diagnose_with(tacho_options())));
    }
    // 4. damaged sidecars next to an intact WAV
    for i in 0..300 {
        let p = dir.join(format!("side{i}.wav"));
        std::fs::write(&p, &wav).unwrap();
        std::fs::write(gearvib::io::sidecar::path_of(&p), sidecar_mutant(&mut rng, &side)).unwrap();
        run(&p, &mut |p| case(p, diagnose_with(tacho_options())));
    }
    // 5. absurd teeth, speeds and pulse counts on the intact cut
    let teeth =
        [(3, 3), (1, 1), (0, 5), (14, 0), (100_000, 100_000), (14, 100_000), (65_536, 3), (39, 14), (usize::MAX, 2)];
    let speeds =
        [None, Some(1e-300), Some(1e-3), Some(0.5), Some(30.0), Some(1e4), Some(1e12), Some(f64::NAN), Some(-30.0)];
    let pulses = [0, 1, 2, 3, 1000, usize::MAX];
    for i in 0..300 {
        let mut o = Options { teeth: Some(teeth[rng.below(teeth.len())]), ..Default::default() };
        match speeds[rng.below(speeds.len())] {
            Some(hz) => o.shaft_hz = Some(hz),
            None => {
                o.tacho_channel = Some(2);
                o.pulses_per_rev = pulses[rng.below(pulses.len())];
            }
        }
        if i % 3 == 0 {
            o.channel = Some(1);
        }
        let p = dir.join(format!("flags{i}.wav"));
        std::fs::copy(&intact, &p).unwrap();
        std::fs::copy(gearvib::io::sidecar::path_of(&intact), gearvib::io::sidecar::path_of(&p)).unwrap();
        run(&p, &mut |p| case(p, diagnose_with(o.clone())));
    }
    assert!(count >= 2000, "{count} mutants");
    // a healthy share of the mutants is still diagnosed (the test reaches the analysis, not only the readers)
    assert!(answered >= count / 5, "{answered} of {count} answered");
    eprintln!("{count} pipeline mutants, {answered} answered, the others refused with their file named");

    // a handful through the binary: exit 0, 2, or 3 (not judged: a damaged tachometer's angle can leave
    // no tooth mesh in the averages), one stderr line on 2, never a panic
    for name in ["tacho3.wav", "wav7.wav", "csv5.csv", "side2.wav", "flags4.wav", "tacho11.wav"] {
        let p = dir.join(name);
        let r = gearvib(&["diagnose", p.to_str().unwrap(), "--tacho-channel", "2", "--teeth", "14,39", "--json"]);
        assert!(matches!(r.code, 0 | 2 | 3), "{name}: exit {}: {}", r.code, r.stderr);
        assert!(!r.stderr.contains("panicked") && !r.stderr.contains("RUST_BACKTRACE"), "{name}: {}", r.stderr);
        if r.code == 2 {
            assert_eq!(r.stderr.lines().count(), 1, "{name}: {}", r.stderr);
            assert!(r.stderr.contains(name), "{name}: {}", r.stderr);
        }
    }
}
