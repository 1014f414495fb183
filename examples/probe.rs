//! Probe: largest bins of the averaged amplitude spectrum of a recording.
use gearvib::signal::spectrum::{AmplitudeOptions, Fft, amplitude_spectrum};
fn main() {
    let rec = gearvib::io::read_recording(std::path::Path::new(
        "data/recordings/gear-z14z39-fs10kHz-cracked-pinion-tooth3.wav",
    ))
    .unwrap();
    let s = amplitude_spectrum(&mut Fft::new(), &rec.channels[0], 10000.0, AmplitudeOptions::default()).unwrap();
    let mut v: Vec<(f64, f64)> = s.freqs_hz.iter().zip(&s.values).map(|(f, a)| (*f, *a)).collect();
    v.sort_by(|a, b| b.1.total_cmp(&a.1));
    println!("{:?}", &v[..8]);
    println!("{:?}", s.freqs_hz.iter().zip(&s.values).filter(|(f, _)| (**f - 670.0).abs() < 3.0).collect::<Vec<_>>());
}
