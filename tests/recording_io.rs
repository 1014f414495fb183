//! `io::write_recording` against `io::read_recording`: what is written is read back (samples, names,
//! units, sample rate), and a recording that cannot be written is refused with the file named.

mod common;
use common::temp_dir;
use gearvib::io::{Recording, read_recording, write_recording};
use std::borrow::Cow;

fn two_channels(fs: f64) -> Recording<'static> {
    let n = 70_000; // more than one 65 536-frame block
    let a: Vec<f32> = (0..n).map(|i| (0.37 * i as f32).sin() * 1.5e-3).collect();
    let b: Vec<f32> = (0..n).map(|i| if i % 100 < 5 { 1.0 } else { 0.0 }).collect();
    Recording {
        channels: vec![Cow::Owned(a), Cow::Owned(b)],
        sample_rate_hz: Some(fs),
        names: vec!["accel".into(), "tacho pinion".into()],
        units: vec!["m/s".into(), "pulse".into()],
        warnings: Vec::new(),
    }
}

#[test]
fn a_written_recording_reads_back_the_same() {
    let dir = temp_dir("recording_io");
    let rec = two_channels(2048.0);
    for name in ["r.wav", "r.csv"] {
        let path = dir.join(name);
        write_recording(&path, &rec).unwrap();
        let back = read_recording(&path).unwrap();
        assert_eq!(back.names, rec.names, "{name}");
        assert_eq!(back.units, rec.units, "{name}");
        // the CSV's time column gives the rate back to its printed digits (9 decimals of a second)
        assert!((back.sample_rate_hz.unwrap() - 2048.0).abs() < 1e-6, "{name}: {:?}", back.sample_rate_hz);
        for (x, y) in rec.channels.iter().zip(&back.channels) {
            assert_eq!(x.len(), y.len(), "{name}");
            // f32 WAV: exact; CSV: 10 significant digits, more than an f32 holds, so exact after rounding
            assert!(x.iter().zip(y.iter()).all(|(a, b)| a == b), "{name}: samples differ");
        }
    }
}

#[test]
fn what_cannot_be_written_is_refused_with_the_file_named() {
    let dir = temp_dir("recording_io_bad");
    let mut ragged = two_channels(2048.0);
    ragged.channels[1].to_mut().pop();
    let mut empty = two_channels(2048.0);
    empty.channels.clear();
    let mut comma = two_channels(2048.0);
    comma.names[0] = "a,b".into();
    let cases: Vec<(&str, Recording<'static>, &str)> = vec![
        ("ragged.wav", ragged, "one length"),
        ("empty.wav", empty, "one length"),
        ("half.wav", two_channels(2048.5), "whole number"),
        ("no-rate.csv", Recording { sample_rate_hz: None, ..two_channels(1.0) }, "sample rate"),
        ("comma.csv", comma, "comma"),
        ("r.flac", two_channels(2048.0), "extension"),
    ];
    for (name, rec, why) in cases {
        let path = dir.join(name);
        let msg = write_recording(&path, &rec).unwrap_err().to_string();
        assert!(msg.contains(name) && msg.contains(why), "{name}: {msg}");
        assert!(!path.exists(), "{name}: nothing is left under the name");
    }
}
