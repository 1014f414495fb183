//! Ad-hoc phase timing used while tuning (not part of the test suite).
use gearvib::signal::spectrum::{AmplitudeOptions, Fft, amplitude_spectrum, welch_psd};
use gearvib::signal::tsa::{AngleMap, tsa};
fn main() {
    let path = std::env::args().nth(1).unwrap_or_else(|| "/tmp/big.wav".into());
    let t = std::time::Instant::now();
    let rec = gearvib::io::read_recording(std::path::Path::new(&path)).unwrap();
    println!("read {:.3} s", t.elapsed().as_secs_f64());
    let x = &rec.channels[0];
    let fs = rec.sample_rate_hz.unwrap();
    let mut fft = Fft::new();
    let t = std::time::Instant::now();
    let _ = amplitude_spectrum(&mut fft, x, fs, AmplitudeOptions::default()).unwrap();
    println!("amplitude spectrum {:.3} s", t.elapsed().as_secs_f64());
    let t = std::time::Instant::now();
    let _ = welch_psd(&mut fft, x, fs, 4096).unwrap();
    println!("welch {:.3} s", t.elapsed().as_secs_f64());
    let map = AngleMap::constant(fs / 30.0, 0.0, x.len());
    let t = std::time::Instant::now();
    let _ = tsa(x, &map, 1.0, 2048, 8).unwrap();
    println!("tsa pinion {:.3} s", t.elapsed().as_secs_f64());
    let t = std::time::Instant::now();
    let _ = tsa(x, &map, 14.0 / 39.0, 8192, 8).unwrap();
    println!("tsa wheel {:.3} s", t.elapsed().as_secs_f64());
}
