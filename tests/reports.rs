//! PNG reports and parameter sweeps.

mod common;
use common::*;
use gearvib::report::plot::{Chart, PAGE_WIDTH_PX, Series, Style, render_png};

/// Every report image is drawn for the page width (its text then prints at 9 pt or more on A4).
const W: u32 = PAGE_WIDTH_PX;

/// Width and height from a PNG's IHDR chunk, after checking the signature.
fn png_size(path: &std::path::Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n", "{} is not a PNG", path.display());
    assert_eq!(&b[12..16], b"IHDR");
    (u32::from_be_bytes([b[16], b[17], b[18], b[19]]), u32::from_be_bytes([b[20], b[21], b[22], b[23]]))
}

#[test]
fn simulate_report_writes_png_images_of_the_stated_size() {
    let dir = temp_dir("report-sim");
    let out = dir.to_string_lossy().into_owned();
    let run = gearvib(&["simulate", &repo("data/scenes/paper-gear-fig8a.json"), "--report", &out]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    for (name, w, h) in [
        ("waveform.png", W, 520),
        ("spectrum.png", W, 620),
        ("zoom-mesh.png", W, 1260),
        // fig8a's multipliers lie within 0.013 of the origin: the unit circle and a zoomed panel side by side
        ("multipliers.png", W, 600),
    ] {
        assert_eq!(png_size(&dir.join(name)), (w, h), "{name}");
    }
    let summary = read_json(&dir.join("simulate.json").to_string_lossy());
    assert!(summary["orders"].is_array());
    // the press adds Figs 3-4
    let run = gearvib(&["simulate", &repo("data/scenes/paper-press-case1.json"), "--report", &out]);
    assert_eq!(run.code, 0);
    assert_eq!(png_size(&dir.join("press-q1-q2.png")), (W, 1500));
}

#[test]
fn diagnose_report_writes_images() {
    let dir = temp_dir("report-diag");
    let out = dir.to_string_lossy().into_owned();
    let rec = repo("data/recordings/gear-z14z39-fs10kHz-pitted-pinion-tooth3.wav");
    let run = gearvib(&[
        "diagnose",
        &rec,
        "--tacho-channel",
        "2",
        "--channel",
        "1",
        "--scene",
        &repo("data/scenes/gear-z14z39-healthy.json"),
        "--report",
        &out,
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let stem = "gear-z14z39-fs10kHz-pitted-pinion-tooth3";
    assert_eq!(png_size(&dir.join(format!("{stem}-spectrum.png"))), (W, 600));
    // TSA and residual of each of the two gears
    assert_eq!(png_size(&dir.join(format!("{stem}-tsa.png"))), (W, 4 * 420));
    assert_eq!(png_size(&dir.join(format!("{stem}-vs-model.png"))), (W, 560));
    assert_eq!(png_size(&dir.join(format!("{stem}-envelope.png"))), (W, 560));
    assert_eq!(png_size(&dir.join(format!("{stem}-cepstrum.png"))), (W, 520));
    assert_eq!(png_size(&dir.join(format!("{stem}-kurtogram.png"))), (W, 560));
    // zooms around the first three mesh harmonics
    assert_eq!(png_size(&dir.join(format!("{stem}-zoom.png"))), (W, 3 * 440));
    assert!(dir.join(format!("{stem}-diagnosis.json")).exists());
    assert!(dir.join("index.html").exists());
}

/// `--spectrum db` and `psd` draw the spectrum image on those scales (the numbers: the PSD unit test in
/// `signal::spectrum`, against Welch and Parseval; the images were opened and read), each a different image
/// from the default amplitude one, and another value is refused naming the flag and the values it takes.
#[test]
fn diagnose_spectrum_in_db_or_as_a_psd() {
    let rec = repo("data/recordings/gear-z14z39-fs10kHz-cracked-pinion-tooth3.wav");
    let stem = "gear-z14z39-fs10kHz-cracked-pinion-tooth3";
    let mut images = Vec::new();
    for scale in ["amplitude", "db", "psd"] {
        let dir = temp_dir(&format!("report-spectrum-{scale}"));
        let out = dir.to_string_lossy().into_owned();
        let run = gearvib(&["diagnose", &rec, "--spectrum", scale, "--report", &out]);
        assert_eq!(run.code, 0, "{}", run.stderr);
        let png = dir.join(format!("{stem}-spectrum.png"));
        assert_eq!(png_size(&png), (W, 600));
        images.push(std::fs::read(png).unwrap());
    }
    assert!(images[0] != images[1] && images[0] != images[2] && images[1] != images[2]);
    let run = gearvib(&["diagnose", &rec, "--spectrum", "loud"]);
    assert_eq!(run.code, 2);
    assert!(run.stderr.contains("--spectrum") && run.stderr.contains("psd"), "{}", run.stderr);
}

#[test]
fn empty_or_non_finite_data_is_refused_not_drawn_blank() {
    let dir = temp_dir("report-bad");
    let chart = |pts: Vec<(f64, f64)>| Chart {
        title: "t".into(),
        x_label: "x [s]".into(),
        y_label: "y [m]".into(),
        series: vec![Series { name: "s".into(), points: pts, style: Style::Line, color: 0 }],
        ..Default::default()
    };
    let p = dir.join("x.png");
    let e = render_png(&p, 400, 300, &[chart(vec![])]).unwrap_err();
    assert!(e.to_string().contains("no data"), "{e}");
    let e = render_png(&p, 400, 300, &[chart(vec![(0.0, 1.0), (1.0, f64::NAN)])]).unwrap_err();
    assert!(e.to_string().contains("non-finite"), "{e}");
    let mut log = chart(vec![(1.0, -1.0), (2.0, 0.0)]);
    log.y_log = true;
    assert!(render_png(&p, 400, 300, &[log]).is_err());
    assert!(!p.exists(), "no blank image is left behind");
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "no temporary files either");
}

#[test]
fn speed_sweep_finds_the_principal_parametric_resonance() {
    // instability where the mesh frequency is twice the natural frequency: z1 f1 = 2 f0, with
    // f0 = sqrt(k0 / m_red) / 2 pi = 869.3 Hz and z1 = 14: 60 * 2 * 869.3 / 14 = 7451 rpm
    let k0 = 8.1846e8f64;
    let (j1, j2, r1, r2) = (0.093f64, 0.272f64, 0.03046f64, 0.08486f64);
    let m = j1 * j2 / (j1 * r2 * r2 + j2 * r1 * r1);
    let rpm = 60.0 * 2.0 * (k0 / m).sqrt() / (2.0 * std::f64::consts::PI) / 14.0;
    let dir = temp_dir("sweep");
    let png = dir.join("map.png").to_string_lossy().into_owned();
    let run = gearvib(&[
        "sweep",
        &repo("data/scenes/hard-gear-light-damping.json"),
        "--param",
        "speed",
        "--from",
        "7000",
        "--to",
        "7900",
        "--steps",
        "61",
        "-o",
        &png,
        "--json",
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let v: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    let pts = v["points"].as_array().unwrap();
    assert_eq!(pts.len(), 61);
    let unstable: Vec<f64> =
        pts.iter().filter(|p| p["stable"] == false).map(|p| p["value"].as_f64().unwrap()).collect();
    assert!(!unstable.is_empty());
    let (lo, hi) = (unstable[0], unstable[unstable.len() - 1]);
    assert!(lo < rpm && rpm < hi, "zone {lo}..{hi} must contain {rpm}");
    // the zone is narrow: its width follows k1/k0 ~ 4 %, far below the swept 900 rpm
    assert!(hi - lo < 0.05 * rpm);
    // the unstable ranges of the JSON: one run holds the resonance, and the runs hold exactly the unstable
    // points (the same zone read two ways)
    let ranges = v["unstable_ranges"].as_array().unwrap();
    let holds = |r: &serde_json::Value| r["from"].as_f64().unwrap() <= rpm && rpm <= r["to"].as_f64().unwrap();
    assert_eq!(ranges.iter().filter(|r| holds(r)).count(), 1, "{ranges:?}");
    let counted: u64 = ranges.iter().map(|r| r["points"].as_u64().unwrap()).sum();
    assert_eq!(counted as usize, unstable.len());
    assert_eq!(png_size(std::path::Path::new(&png)), (W, 960));
    // the text says the same ranges, and that it thinned its rows
    let text = gearvib(&[
        "sweep",
        &repo("data/scenes/hard-gear-light-damping.json"),
        "--param",
        "speed",
        "--from",
        "7000",
        "--to",
        "7900",
        "--steps",
        "121",
    ]);
    assert_eq!(text.code, 0, "{}", text.stderr);
    assert!(text.stdout.contains("UNSTABLE at ") && text.stdout.contains(" of 121 points"), "{}", text.stdout);
    // 121 rows are more than the 40 or so the text shows
    assert!(text.stdout.contains("rows thinned"), "{}", text.stdout);
    let bad = gearvib(&[
        "sweep",
        &repo("data/scenes/hard-gear-light-damping.json"),
        "--param",
        "colour",
        "--from",
        "0",
        "--to",
        "1",
        "--steps",
        "3",
    ]);
    assert_one_line_error(&bad, &["--param colour", "no numeric field"]);
}

/// A batch's page names the recordings that could not be diagnosed, first and with a NOT DIAGNOSED badge,
/// beside the one that could: a page listing only the judged recordings reads as if the unread one had
/// passed. When every recording fails the page is still written (a stale page of an earlier run would
/// otherwise stand in the directory as this run's).
#[test]
fn a_batch_report_lists_the_recordings_it_could_not_diagnose() {
    let dir = temp_dir("report-failed");
    let bad = dir.join("cut-short.wav");
    std::fs::write(&bad, b"RIFF\x04\x00\x00\x00WAVE").unwrap();
    let out = dir.join("report");
    let (rec, bad_s, out_s) =
        (repo("data/recordings/gear-z14z39-fs10kHz-healthy.wav"), bad.to_string_lossy(), out.to_string_lossy());
    let run = gearvib(&["diagnose", &rec, &bad_s, "--tacho-channel", "2", "--channel", "1", "--report", &out_s]);
    assert_eq!(run.code, 2, "a failed recording makes the batch exit 2: {}", run.stderr);
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    let (failed_at, judged_at) =
        (page.find("cut-short.wav").unwrap(), page.find("gear-z14z39-fs10kHz-healthy").unwrap());
    assert!(page.contains("NOT DIAGNOSED") && page.contains("1 recording not diagnosed"));
    assert!(failed_at < judged_at, "the failure opens the page");
    std::fs::remove_dir_all(&out).unwrap();
    let run = gearvib(&["diagnose", &bad_s, "--report", &out_s]);
    assert_eq!(run.code, 2);
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(page.contains("cut-short.wav") && page.contains("NOT DIAGNOSED"));
}
