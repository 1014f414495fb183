//! Every `--report DIR` writes `DIR/index.html`; each page is rendered in headless Chromium (Debian's
//! `chromium`, installed by `.ci/run`), which must load every embedded image and show the verdict. Where
//! Chromium is not installed the rendering is skipped with a message; the page's own checks still run.

mod common;
use common::*;
use gearvib::report::plot::{Chart, Geometry, MIN_TEXT_PX, PAGE_WIDTH_PX, layout};
use std::path::Path;
use std::process::Command;

/// Width of the text on an A4 page between 14 mm margins (the page's @page rule), in points:
/// 182 mm / 25.4 mm per inch * 72 pt per inch.
const PRINT_WIDTH_PT: f64 = 182.0 / 25.4 * 72.0;

fn chromium() -> Option<&'static str> {
    ["/usr/bin/chromium", "/usr/bin/chromium-browser"].into_iter().find(|p| Path::new(p).exists())
}

/// Flags for a headless run on a closed network as root (the machine notes of this workplace).
const FLAGS: [&str; 8] = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
];

/// Renders `page` to `shot` and returns the DOM after a script, appended to a copy of the page, counted
/// its images: `data-images` (all) and `data-broken` (not decoded).
fn render(page: &Path, shot: &Path) -> Option<String> {
    let chrome = chromium()?;
    let dir = page.parent().unwrap();
    let profile = dir.join("chromium-profile");
    let html = std::fs::read_to_string(page).unwrap();
    let probe = dir.join("probe.html");
    // images seen and decoded; the smallest computed font size of any element that holds text (hundredths
    // of a CSS px; 12 px is 9 pt), and the widest image
    let script = "<script>window.addEventListener('load',()=>{const i=[...document.images];document.body.dataset.images=i.length;document.body.dataset.broken=i.filter(x=>!(x.complete&&x.naturalWidth>0)).length;const t=[...document.body.querySelectorAll('*')].filter(e=>[...e.childNodes].some(n=>n.nodeType==3&&n.textContent.trim()));document.body.dataset.minfont=Math.floor(100*Math.min(...t.map(e=>parseFloat(getComputedStyle(e).fontSize))));document.body.dataset.maxwidth=Math.max(0,...i.map(x=>x.naturalWidth));document.body.dataset.captionlines=Math.max(0,...[...document.querySelectorAll('caption,p.caption')].map(c=>Math.round(c.getBoundingClientRect().height/parseFloat(getComputedStyle(c).lineHeight))));});</script>";
    std::fs::write(&probe, html.replace("</body>", &format!("{script}</body>"))).unwrap();
    let url = format!("file://{}", probe.display());
    let profile_flag = format!("--user-data-dir={}", profile.display());
    let dom = Command::new(chrome)
        .args(FLAGS)
        .args([&profile_flag, "--virtual-time-budget=10000", "--dump-dom", &url])
        .output()
        .expect("chromium runs");
    let shot_flag = format!("--screenshot={}", shot.display());
    let status = Command::new(chrome)
        .args(FLAGS)
        .args([&profile_flag, "--window-size=1200,2400", &shot_flag, &format!("file://{}", page.display())])
        .output()
        .expect("chromium runs");
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    Some(String::from_utf8_lossy(&dom.stdout).into_owned())
}

fn attribute(dom: &str, name: &str) -> Option<usize> {
    let at = dom.find(&format!("{name}=\""))? + name.len() + 2;
    dom[at..].split('"').next()?.parse().ok()
}

/// The words of a page: tags, the style and the embedded images taken out, entities decoded.
fn page_text(html: &str) -> String {
    let html = html.split("<style>").map(|p| p.split_once("</style>").map_or(p, |x| x.1)).collect::<String>();
    let mut text = String::new();
    let mut in_tag = false;
    for c in html.chars() {
        match c {
            '<' => in_tag = true,
            '>' if in_tag => {
                in_tag = false;
                text.push(' ');
            }
            c if !in_tag => text.push(c),
            _ => {}
        }
    }
    text.replace("&lt;", "<").replace("&gt;", ">").replace("&quot;", "\"").replace("&amp;", "&")
}

/// Internal keys (snake_case words such as `estimated_shaft`, `crest_factor`) and Rust debug text
/// (`Some(`, `None`, a list printed as `[1, 2]`) in the words of a page; file names and paths, and the
/// formula symbols e_i and alpha_i that the identify tables define, are not keys.
fn internal_words(text: &str) -> Vec<String> {
    let mut bad = Vec::new();
    for raw in text.split_whitespace() {
        let t = raw.trim_matches(|c: char| ",;:()[]'\"".contains(c));
        let keyish = t.contains('_')
            && t.split('_').all(|p| !p.is_empty() && p.chars().all(|c| c.is_ascii_alphanumeric()))
            && !["e_i", "alpha_i"].contains(&t);
        let debug = raw.starts_with("Some(")
            || raw == "None"
            || (raw.starts_with('[') && raw[1..].starts_with(|c: char| c.is_ascii_digit()));
        if (keyish && !t.contains('.') && !t.contains('/')) || debug {
            bad.push(raw.to_string());
        }
    }
    bad
}

/// Width of a PNG from its header.
fn png_width(bytes: &[u8]) -> u32 {
    u32::from_be_bytes([bytes[16], bytes[17], bytes[18], bytes[19]])
}

/// The page's own promises: self-contained (no external reference), every image embedded, the verdict
/// text present, no internal key or debug text, a print rule, every image drawn for the page width (its
/// smallest text then prints at 9 pt or more); in Chromium every image decodes and no text is smaller
/// than 9 pt.
fn check_page(dir: &Path, expect: &[&str], images: usize) {
    let page = dir.join("index.html");
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(!html.contains("http://") && !html.contains("https://"), "the page must not reach the network");
    assert!(!html.contains("<script"), "the page needs no script");
    assert_eq!(html.matches("src=\"data:image/png;base64,").count(), images, "embedded images");
    for e in expect {
        assert!(html.contains(e), "page lacks {e:?}");
    }
    let text = page_text(&html);
    assert_eq!(internal_words(&text), Vec::<String>::new(), "internal keys or debug text on {}", page.display());
    assert!(html.contains("@media print") && html.contains("@page{size:A4;margin:14mm}"), "print rules");
    assert!(text.contains("Glossary") || !text.contains("spreads"), "terms used without the glossary");
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.extension().is_some_and(|e| e == "png") && p.file_name().is_some_and(|n| n != "screenshot.png") {
            let w = png_width(&std::fs::read(&p).unwrap());
            // the page shows an image across the text width: its smallest text prints at this size
            let pt = f64::from(MIN_TEXT_PX) * PRINT_WIDTH_PT / f64::from(w);
            assert!(w <= PAGE_WIDTH_PX && pt >= 9.0, "{}: {w} px wide, text {pt:.1} pt in print", p.display());
        }
    }
    let shot = dir.join("screenshot.png");
    match render(&page, &shot) {
        Some(dom) => {
            assert_eq!(attribute(&dom, "data-images"), Some(images), "images seen by Chromium");
            assert_eq!(attribute(&dom, "data-broken"), Some(0), "broken images");
            // 9 pt is 12 CSS px; the print rules keep the same point sizes
            let min = attribute(&dom, "data-minfont").expect("font sizes measured");
            assert!(min >= 1200, "text of {} px on {}", min as f64 / 100.0, page.display());
            assert!(attribute(&dom, "data-maxwidth").is_some_and(|w| w <= PAGE_WIDTH_PX as usize));
            // a table's caption reads as a line or two across the page, not a narrow column over a narrow
            // table (identify's captions were wrapped into four lines)
            let lines = attribute(&dom, "data-captionlines").expect("captions measured");
            assert!(lines <= 2, "a caption of {lines} lines on {}", page.display());
            assert!(std::fs::metadata(&shot).unwrap().len() > 10_000, "screenshot written");
        }
        None => eprintln!(
            "SKIPPED: Chromium is not installed here (.ci/run installs Debian's chromium); the rendering of {} was not checked",
            page.display()
        ),
    }
}

#[test]
fn every_report_page_renders_with_its_images() {
    let root = temp_dir("report-html");
    let rec = |n: &str| repo(&format!("data/recordings/gear-z14z39-fs10kHz-{n}.wav"));
    let d = root.join("diagnose");
    let d_s = d.to_string_lossy().into_owned();
    let run = gearvib(&[
        "diagnose",
        &rec("cracked-pinion-tooth3"),
        &rec("healthy"),
        "--teeth",
        "14,39",
        "--baseline",
        &rec("healthy"),
        "--report",
        &d_s,
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    // the trend of the two recordings, and a TSA, a spectrum, a mesh zoom, an envelope, a kurtogram and a
    // cepstrum image each
    check_page(&d, &["FAULTY", "HEALTHY", "NA4*", "spreads", "Trend over 2 recordings"], 13);

    let s = root.join("simulate");
    let scene = repo("data/scenes/paper-gear-fig8a.json");
    let run = gearvib(&["simulate", &scene, "--report", &s.to_string_lossy()]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let pngs = std::fs::read_dir(&s)
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "png"))
        .count();
    check_page(&s, &["STABLE", "Strongest orders"], pngs);

    let st = root.join("stability");
    let run = gearvib(&["stability", &scene, "--report", &st.to_string_lossy()]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    check_page(&st, &["largest |multiplier|"], 1);

    let sw = root.join("sweep");
    let run = gearvib(&[
        "sweep",
        &scene,
        "--param",
        "speed",
        "--from",
        "1000",
        "--to",
        "2000",
        "--steps",
        "12",
        "--report",
        &sw.to_string_lossy(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    check_page(&sw, &["points unstable"], 1);

    // a recording without a sample rate: the order spectrum of the deciding channel's TSA stands in
    let real = root.join("real");
    let run = gearvib(&[
        "diagnose",
        &repo("data/realdata/b30hz90.csv"),
        "--fs-unknown",
        "--baseline",
        &repo("data/realdata/h30hz90.csv"),
        "--report",
        &real.to_string_lossy(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    check_page(&real, &["sample rate unknown", "Glossary"], 2);

    let id = root.join("identify");
    let run = gearvib(&[
        "identify",
        &rec("cracked-pinion-tooth3"),
        "--scene",
        &repo("data/scenes/gear-z14z39-healthy.json"),
        "--faults",
        "crack,pit",
        "--report",
        &id.to_string_lossy(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    // the crack in words: the share of the tooth's stiffness lost (truth 30 %), no negative pit depth
    check_page(&id, &["stiffness loss", "LOCAL FAULT"], 3);
    let text = page_text(&std::fs::read_to_string(id.join("index.html")).unwrap());
    assert!(!text.contains("depth -") && !text.contains("fits better than none"), "{text}");
}

/// Every chart's drawn geometry: all data inside the plot area; the legend, the marker labels, the title
/// and a colour bar outside it and clear of each other; every axis (and colour bar) with a unit.
fn check_geometry(name: &str, charts: &[Chart], shapes: &[Geometry]) {
    assert_eq!(charts.len(), shapes.len(), "{name}");
    for (c, g) in charts.iter().zip(shapes) {
        let what = format!("{name}: {}", c.title);
        for label in [&c.x_label, &c.y_label] {
            assert!(label.contains('[') && label.contains(']'), "{what}: axis {label:?} has no unit");
        }
        if let Some(h) = &c.heatmap {
            assert!(h.label.contains('[') && g.colour_bar.is_some(), "{what}: colour bar without unit");
        }
        assert!(g.data.iter().all(|p| g.plot.contains(*p)), "{what}: data outside the plot area");
        assert_eq!(g.hidden_marker_labels, 0, "{what}: marker labels left out");
        let mut boxes: Vec<(&str, _)> = g.marker_labels.iter().map(|m| ("marker label", *m)).collect();
        boxes.extend(g.title.iter().map(|t| ("title", *t)));
        boxes.extend(g.legend.map(|l| ("legend", l)));
        boxes.extend(g.colour_bar.map(|b| ("colour bar", b)));
        for (i, (kind, b)) in boxes.iter().enumerate() {
            assert!(!b.intersects(&g.plot), "{what}: {kind} {b:?} over the plot {:?}", g.plot);
            assert!(g.data.iter().all(|p| !b.contains(*p)), "{what}: {kind} over data");
            for (other, o) in &boxes[i + 1..] {
                assert!(!b.intersects(o), "{what}: {kind} {b:?} over {other} {o:?}");
            }
        }
        assert!(g.smallest_text_px >= MIN_TEXT_PX, "{what}");
    }
}

/// Runs `gearvib diagnose ARGS` through the library (the same job as the command line) and returns the
/// diagnoses.
fn diagnoses(args: &[&str]) -> Vec<gearvib::report::summary::Diagnosis> {
    let cli = gearvib::cli::parse_from(["gearvib", "diagnose"].iter().chain(args)).unwrap();
    let gearvib::cli::Command::Diagnose(a) = cli.command else { unreachable!("parsed as diagnose") };
    let job = gearvib::cli::diagnose_job(&a).unwrap();
    gearvib::jobs::diagnose::run(&job).unwrap().diagnoses
}

#[test]
fn no_legend_or_label_covers_data_in_any_diagnosis_image() {
    let rec = |n: &str| repo(&format!("data/recordings/gear-z14z39-fs10kHz-{n}.wav"));
    let scene = repo("data/scenes/gear-z14z39-healthy.json");
    let done = diagnoses(&[
        &rec("cracked-pinion-tooth3"),
        &rec("healthy"),
        &rec("wheel-eccentricity"),
        "--teeth",
        "14,39",
        "--tacho-channel",
        "2",
        "--channel",
        "1",
        "--baseline",
        &rec("healthy"),
        "--scene",
        &scene,
    ]);
    let mut real = diagnoses(&[
        &repo("data/realdata/b30hz90.csv"),
        "--fs-unknown",
        "--baseline",
        &repo("data/realdata/h30hz90.csv"),
    ]);
    let mut figures = 0;
    for d in done.iter().chain(&real) {
        for f in gearvib::report::figures::diagnosis_figures(d) {
            let shapes = layout(f.width, f.height, 1, &f.charts).unwrap();
            check_geometry(&f.file, &f.charts, &shapes);
            figures += 1;
        }
    }
    // per recording with a sample rate: TSA, spectrum, zoom, envelope, kurtogram, cepstrum, model overlay;
    // without: TSA and the TSA order spectrum
    assert_eq!(figures, 3 * 7 + 2);
    let trend = gearvib::report::figures::trend_charts(&done).unwrap();
    let h = gearvib::report::figures::TREND_PANEL_PX * trend.len() as u32;
    check_geometry("trend", &trend, &layout(PAGE_WIDTH_PX, h, 1, &trend).unwrap());
    // the trend axis names the recordings, and the limits are both drawn
    assert!(trend[0].x_ticks.iter().any(|t| t.1.contains("cracked-pinion-tooth3")), "{:?}", trend[0].x_ticks);
    assert!(trend.iter().all(|c| c.series.iter().any(|s| s.name.starts_with("faulty limit"))));
    // a panel's title lists the indicators it draws, and no other (M8A and kurtosis, never scored, were
    // listed)
    for c in &trend {
        if let Some((_, list)) = c.title.rsplit_once(" (") {
            for name in list.trim_end_matches(')').split(", ") {
                assert!(c.series.iter().any(|s| s.name == name), "{}: {name} is not drawn", c.title);
            }
        }
    }
    real.clear();
}
