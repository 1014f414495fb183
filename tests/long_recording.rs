//! Issue 29's one-hour recording, generated on demand and never committed (2.95 GB): the bundled healthy
//! scene simulated by `gearvib simulate -o` for an hour at 51.2 kHz in 32-bit float with its two
//! tachometer channels, and a second vibration sensor added as channel 4 (channel 1 seen through another
//! path: 0.6 times it, 7 samples later, with its own noise). It is written to
//! `target/tmp/long-1h-4ch.wav` with its sidecar and kept there for the memory and time measurements of
//! the README (`/usr/bin/time -v gearvib diagnose ...`); timings never decide a test.
//!
//! ```sh
//! cargo test --release --test long_recording -- --ignored --nocapture
//! ```

mod common;
use common::*;
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// Frames of the hour at 51.2 kHz.
const FRAMES: u64 = 3600 * 51_200;
/// Channels of the written file.
const CHANNELS: u64 = 4;

/// The one-hour four-channel recording, written unless a complete one is there already.
fn long_recording() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"));
    let out = dir.join("long-1h-4ch.wav");
    let data_bytes = FRAMES * CHANNELS * 4;
    let side = PathBuf::from(format!("{}.json", out.display()));
    if std::fs::metadata(&out).is_ok_and(|m| m.len() == 44 + data_bytes) && side.exists() {
        return out;
    }
    // the healthy scene for an hour at 51.2 kHz, float samples, its tachometers
    let mut scene = read_json(&repo("data/scenes/gear-z14z39-healthy.json"));
    let o = &mut scene["output"];
    o["sample_rate_hz"] = 51_200.0.into();
    o["duration_s"] = 3600.0.into();
    o["wav_format"] = "f32".into();
    o.as_object_mut().unwrap().remove("full_scale");
    let scene_path = write(dir, "long-1h.json", &scene.to_string());
    let three = dir.join("long-1h-3ch.wav");
    let run = gearvib(&["simulate", &scene_path, "-o", three.to_str().unwrap()]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    // channel 4: a second sensor, 0.6 times channel 1 seven samples later plus its own noise
    let mut input = BufReader::with_capacity(1 << 20, std::fs::File::open(&three).unwrap());
    let data = seek_data(&mut input);
    assert_eq!(data, FRAMES * 3 * 4, "the simulated file holds an hour of three channels");
    let tmp = dir.join("long-1h-4ch.wav.partial");
    let mut w = BufWriter::with_capacity(1 << 20, std::fs::File::create(&tmp).unwrap());
    write_header(&mut w, data_bytes);
    let mut delay = [0.0f32; 7];
    let mut rng = 0x9E37_79B9_7F4A_7C15u64;
    let mut frame = [0u8; 12];
    for i in 0..FRAMES as usize {
        input.read_exact(&mut frame).unwrap();
        let ch1 = f32::from_le_bytes([frame[0], frame[1], frame[2], frame[3]]);
        let earlier = delay[i % 7];
        delay[i % 7] = ch1;
        // xorshift, two uniforms summed: zero mean, 2e-4 RMS (the scene's own noise level)
        let mut uniform = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let noise = (uniform() + uniform()) * 2e-4 * 6f64.sqrt();
        let ch4 = (0.6 * f64::from(earlier) + noise) as f32;
        w.write_all(&frame).unwrap();
        w.write_all(&ch4.to_le_bytes()).unwrap();
    }
    w.flush().unwrap();
    drop(w);
    let mut info = read_json(&format!("{}.json", three.display()));
    info["file"] = "long-1h-4ch.wav".into();
    info["channels"].as_array_mut().unwrap().push(serde_json::json!({
        "name": "dq/dt second sensor",
        "unit": "m/s",
        "description": "0.6 times channel 1 seven samples later, plus white noise of 2e-4 m/s RMS (tests/long_recording.rs)"
    }));
    std::fs::write(&side, serde_json::to_string_pretty(&info).unwrap()).unwrap();
    std::fs::rename(&tmp, &out).unwrap();
    let _ = std::fs::remove_file(&three);
    let _ = std::fs::remove_file(format!("{}.json", three.display()));
    out
}

/// Moves `r` to the start of the data chunk and returns its size in bytes.
fn seek_data(r: &mut (impl Read + Seek)) -> u64 {
    let mut head = [0u8; 12];
    r.read_exact(&mut head).unwrap();
    assert_eq!(&head[0..4], b"RIFF");
    loop {
        let mut ch = [0u8; 8];
        r.read_exact(&mut ch).unwrap();
        let size = u64::from(u32::from_le_bytes([ch[4], ch[5], ch[6], ch[7]]));
        if &ch[0..4] == b"data" {
            return size;
        }
        r.seek(SeekFrom::Current((size + (size & 1)) as i64)).unwrap();
    }
}

/// A 44-byte header of a four-channel 51.2 kHz 32-bit float WAV holding `data_bytes`.
fn write_header(w: &mut impl Write, data_bytes: u64) {
    let rate = 51_200u32;
    let align = (CHANNELS * 4) as u16;
    let mut h = Vec::with_capacity(44);
    h.extend_from_slice(b"RIFF");
    h.extend_from_slice(&u32::try_from(36 + data_bytes).unwrap().to_le_bytes());
    h.extend_from_slice(b"WAVEfmt ");
    h.extend_from_slice(&16u32.to_le_bytes());
    h.extend_from_slice(&3u16.to_le_bytes()); // IEEE float
    h.extend_from_slice(&(CHANNELS as u16).to_le_bytes());
    h.extend_from_slice(&rate.to_le_bytes());
    h.extend_from_slice(&(rate * u32::from(align)).to_le_bytes());
    h.extend_from_slice(&align.to_le_bytes());
    h.extend_from_slice(&32u16.to_le_bytes());
    h.extend_from_slice(b"data");
    h.extend_from_slice(&u32::try_from(data_bytes).unwrap().to_le_bytes());
    w.write_all(&h).unwrap();
}

/// The valid one-hour recording once panicked in the block indicators (issue 29): the diagnosis of its
/// first channel at the given speed and teeth now completes, healthy, at the scene's 30 Hz.
#[test]
#[ignore = "writes 5 GB to target/tmp and runs for a minute or two: run on demand"]
fn one_hour_recording_is_diagnosed() {
    let path = long_recording();
    let p = path.to_str().unwrap();
    let run = gearvib(&["diagnose", p, "--channel", "1", "--rpm", "1800", "--teeth", "14,39", "--json"]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let d: serde_json::Value = serde_json::from_str(run.stdout.lines().next().unwrap()).unwrap();
    // the scene turns the pinion at 1800 rpm with a drift of at most 100 ppm
    let hz = d["shaft_hz"]["pinion"].as_f64().unwrap();
    assert!((hz - 30.0).abs() < 30.0 * 1e-3, "{hz}");
    assert_eq!(d["samples"].as_u64().unwrap(), FRAMES);
    assert_eq!(d["verdict"]["state"], "healthy", "{}", d["verdict"]);
    println!("{p}");
}
