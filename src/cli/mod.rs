//! Command line: clap arguments -> validated jobs -> library calls -> printing.
//! The only module that prints; library code returns values and errors.

use crate::Error;
use crate::pipeline;
use crate::report::summary::{SimulateSummary, StabilitySummary, to_json_line};
use crate::scene::Scene;
use clap::{Parser, Subcommand};

/// gearvib: gear-pair vibration simulation, Floquet stability and gear-fault diagnosis.
#[derive(Parser, Debug)]
#[command(name = "gearvib", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Periodic steady state of a scene: orders, RMS, multipliers; optionally write the signal.
    Simulate {
        /// Scene JSON file.
        scene: String,
        /// Write the output quantity as a time signal (.wav or .csv) plus a sidecar OUT.json.
        #[arg(short = 'o', long = "output", value_name = "OUT")]
        output: Option<String>,
        /// Write even when the sample rate is below twice the highest line requested (warns).
        #[arg(long)]
        allow_aliasing: bool,
        /// Write PNG images and the JSON summary into this directory.
        #[arg(long)]
        report: Option<String>,
        /// Print one JSON object on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Floquet analysis and steady state over a range of one scene parameter (all cores).
    Sweep {
        /// Scene JSON file.
        scene: String,
        /// Parameter: speed, damping, load, or a dotted JSON path like gear_pair.damping_ratio.
        #[arg(long)]
        param: String,
        /// First value.
        #[arg(long, allow_hyphen_values = true)]
        from: f64,
        /// Last value.
        #[arg(long, allow_hyphen_values = true)]
        to: f64,
        /// Number of values.
        #[arg(long)]
        steps: usize,
        /// Stability map image.
        #[arg(short = 'o', long = "output", value_name = "MAP.png")]
        output: Option<String>,
        /// Write the map and the JSON into this directory.
        #[arg(long)]
        report: Option<String>,
        /// Print one JSON object on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Diagnose recordings (WAV/CSV): spectra, TSA, condition indicators, sidebands, verdict.
    Diagnose(DiagnoseArgs),
    /// Speed against error of every solver on the paper's scenes and the hard cases.
    Bench {
        /// Scenes (default: the paper's cases and the hard cases in data/scenes).
        scenes: Vec<String>,
        /// Write the table (JSON) and work-precision PNGs into this directory.
        #[arg(long)]
        report: Option<String>,
        /// Print one JSON object on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Monodromy matrix and Floquet multipliers of a scene.
    Stability {
        /// Scene JSON file.
        scene: String,
        /// Write the multiplier image and the JSON summary into this directory.
        #[arg(long)]
        report: Option<String>,
        /// Print one JSON object on stdout.
        #[arg(long)]
        json: bool,
    },
}

#[derive(clap::Args, Debug)]
struct DiagnoseArgs {
    /// Recordings (.wav or .csv), in time order (NA4 uses that order).
    #[arg(required = true)]
    recordings: Vec<String>,
    /// Analyse only this channel (1-based); default: all but the tachometer.
    #[arg(long)]
    channel: Option<usize>,
    /// Sample rate in Hz (overrides the file; needed for a CSV without a time column).
    #[arg(long)]
    fs: Option<f64>,
    /// The sample rate is not known: analyse in orders of the estimated shaft period only.
    #[arg(long)]
    fs_unknown: bool,
    /// Pinion (input) shaft speed in rpm.
    #[arg(long, conflicts_with = "shaft_hz")]
    rpm: Option<f64>,
    /// Pinion (input) shaft speed in Hz.
    #[arg(long)]
    shaft_hz: Option<f64>,
    /// Teeth of pinion and wheel, e.g. 14,39.
    #[arg(long, value_name = "ZP,ZW")]
    teeth: Option<String>,
    /// Tachometer channel (1-based) on the pinion shaft.
    #[arg(long)]
    tacho_channel: Option<usize>,
    /// Tachometer pulses per revolution.
    #[arg(long, default_value_t = 1)]
    pulses_per_rev: usize,
    /// Healthy recording of the same machine to judge against.
    #[arg(long)]
    baseline: Option<String>,
    /// Scene to simulate at the recording's speed and compare with.
    #[arg(long)]
    scene: Option<String>,
    /// What the recording measures (for --scene).
    #[arg(long, value_enum, default_value = "velocity")]
    quantity: QuantityArg,
    /// Exit with code 1 when any recording is at least this bad.
    #[arg(long, value_enum)]
    fail_on: Option<FailOn>,
    /// Write PNG images and the JSON summary into this directory.
    #[arg(long)]
    report: Option<String>,
    /// One JSON object per recording, one per line.
    #[arg(long)]
    json: bool,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum QuantityArg {
    Acceleration,
    Velocity,
    Displacement,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq)]
enum FailOn {
    Faulty,
    Suspect,
}

/// Parses the process arguments (clap prints usage errors itself and exits with code 2).
pub fn parse_args() -> Cli {
    Cli::parse()
}

/// Runs a parsed command; returns the process exit code (0 ok, 1 fault found with `--fail-on`).
///
/// # Errors
/// Any layer's error; the caller prints it on one line and exits with code 2.
pub fn run(cli: Cli) -> Result<u8, Error> {
    match cli.command {
        Command::Simulate { scene, output, allow_aliasing, report, json } => {
            simulate(&scene, output.as_deref(), allow_aliasing, report.as_deref(), json)
        }
        Command::Stability { scene, report, json } => stability(&scene, report.as_deref(), json),
        Command::Sweep { scene, param, from, to, steps, output, report, json } => {
            sweep(&scene, &param, (from, to, steps), output.as_deref(), report.as_deref(), json)
        }
        Command::Diagnose(args) => diagnose(&args),
        Command::Bench { scenes, report, json } => bench(&scenes, report.as_deref(), json),
    }
}

/// The warning that explains a refusal best (stability limit, then conditioning), for the one error line.
fn main_reason(warnings: &[String]) -> String {
    ["stability limit", "ill-conditioned", "near +1"]
        .iter()
        .find_map(|k| warnings.iter().find(|w| w.contains(k)))
        .map_or(String::new(), |w| format!("; {w}"))
}

fn warn_all(warnings: &[String]) {
    for w in warnings {
        eprintln!("gearvib: warning: {w}");
    }
}

fn report_dir(dir: &str) -> Result<std::path::PathBuf, Error> {
    let d = std::path::PathBuf::from(dir);
    std::fs::create_dir_all(&d)
        .map_err(|e| Error::Other(format!("--report {dir}: cannot create the directory: {e}")))?;
    Ok(d)
}

fn report_err(e: crate::report::ReportError) -> Error {
    Error::Other(e.to_string())
}

fn stability(path: &str, report: Option<&str>, json: bool) -> Result<u8, Error> {
    let scene = Scene::load(path)?;
    let steady =
        crate::solver::solve(scene.system(), &scene.solver).map_err(|e| Error::Other(format!("{path}: {e}")))?;
    let summary = StabilitySummary::new(&scene, &steady);
    if steady.error_estimate > scene.solver.tolerance {
        return Err(Error::Other(format!(
            "{path}: multipliers not trusted: estimated error {:.2e} is above solver.tolerance {:.1e}{}",
            steady.error_estimate,
            scene.solver.tolerance,
            main_reason(&summary.warnings)
        )));
    }
    warn_all(&summary.warnings);
    if let Some(dir) = report {
        let d = report_dir(dir)?;
        let p = crate::report::figures::multipliers(&scene, &steady, &d).map_err(report_err)?;
        crate::io::write_atomic(&d.join("stability.json"), to_json_line(&summary).as_bytes())?;
        if !json {
            println!("report: {}", p.display());
        }
    }
    if json {
        println!("{}", to_json_line(&summary));
    } else {
        print_stability(&summary);
    }
    Ok(0)
}

fn print_stability(s: &StabilitySummary) {
    println!("scene            {}", s.scene);
    println!("period           {:.6} s", s.period_s);
    println!(
        "method           {} ({} {}; rk4 stability limit {} steps), estimated error {:.2e} (tolerance {:.1e})",
        s.method, s.steps, s.resolution_unit, s.stability_limit_steps, s.error_estimate, s.tolerance
    );
    println!("why              {}", s.method_reason);
    println!("cond(I - Phi)    {:.3e}", s.cond_i_minus_phi);
    println!("|rho|max         {:.6e}  -> {}", s.rho_max, if s.stable { "asymptotically stable" } else { "UNSTABLE" });
    println!("multipliers      re            im            |rho|");
    for m in &s.multipliers {
        println!("                 {:+.6e} {:+.6e} {:.6e}", m.re, m.im, m.abs);
    }
    for n in &s.notes {
        println!("note             {n}");
    }
}

fn simulate(
    path: &str,
    output: Option<&str>,
    allow_aliasing: bool,
    report: Option<&str>,
    json: bool,
) -> Result<u8, Error> {
    let scene = Scene::load(path)?;
    if let Some(out) = output {
        // refuse a bad request before any computation
        crate::synth::check_request(&scene, std::path::Path::new(out), allow_aliasing, &mut Vec::new())?;
    }
    let sim = pipeline::simulate(&scene).map_err(|e| Error::Other(format!("{path}: {e}")))?;
    let mut summary = SimulateSummary::new(&scene, &sim);
    if !sim.steady.trusted {
        return Err(Error::Other(format!(
            "{path}: periodic solution not printed: it cannot meet solver.tolerance {:.1e} (estimated error {:.2e}, cond(I - Phi) {:.2e}){}",
            scene.solver.tolerance,
            sim.steady.error_estimate,
            sim.steady.cond_i_minus_phi,
            main_reason(&summary.stability.warnings)
        )));
    }
    warn_all(&summary.stability.warnings);
    if let Some(out) = output {
        let info = crate::synth::write_signal(&scene, &sim, std::path::Path::new(out), allow_aliasing)?;
        warn_all(&info.warnings);
        summary.signal_file = Some(info.file.clone());
        if !json {
            println!(
                "wrote {} ({} channels, {} frames at {} Hz, {}) and {}.json",
                info.file,
                info.channels.len(),
                info.frames,
                info.sample_rate_hz,
                info.format,
                info.file
            );
        }
    }
    if let Some(dir) = report {
        let d = report_dir(dir)?;
        let files = crate::report::figures::simulation(&scene, &sim, &d).map_err(report_err)?;
        crate::io::write_atomic(&d.join("simulate.json"), to_json_line(&summary).as_bytes())?;
        if !json {
            println!("report: {}", files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>().join(", "));
        }
    }
    if json {
        println!("{}", to_json_line(&summary));
    } else {
        print_stability(&summary.stability);
        println!(
            "output           {} [{}], RMS {:.4e}, peak-to-peak {:.4e}",
            summary.quantity, summary.unit, summary.rms, summary.peak_to_peak
        );
        let peak = summary.orders.iter().skip(1).map(|o| o.amplitude).fold(0.0, f64::max);
        println!("strongest lines (order of {} = {:.4} Hz, above 1 % of the largest):", summary.base, summary.base_hz);
        println!("  order     freq [Hz]    amplitude [{}]", summary.unit);
        let mut lines: Vec<_> = summary.orders.iter().skip(1).filter(|o| o.amplitude >= 0.01 * peak).collect();
        lines.sort_by(|a, b| b.amplitude.total_cmp(&a.amplitude));
        for o in lines.iter().take(20) {
            println!("  {:8.3}  {:10.3}   {:.4e}", o.order, o.frequency_hz, o.amplitude);
        }
    }
    Ok(0)
}

fn parse_teeth(s: &str) -> Result<(usize, usize), Error> {
    let bad = || Error::Other(format!("--teeth {s}: expected two whole numbers of teeth >= 3, like 14,39"));
    let (a, b) = s.split_once(',').ok_or_else(bad)?;
    let (a, b): (usize, usize) = (a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?);
    if a < 3 || b < 3 {
        return Err(bad());
    }
    Ok((a, b))
}

fn scene_teeth(path: &str) -> Result<Option<(usize, usize)>, Error> {
    let scene = Scene::load(path)?;
    Ok(match &scene.model {
        crate::scene::Model::GearPair(g) => Some((g.params().pinion_teeth, g.params().wheel_teeth)),
        _ => None,
    })
}

fn diagnose(a: &DiagnoseArgs) -> Result<u8, Error> {
    use crate::diagnose as dg;
    use rayon::prelude::*;
    let shaft_hz = match (a.rpm, a.shaft_hz) {
        (Some(r), _) if !(r.is_finite() && r > 0.0) => {
            return Err(Error::Other(format!("--rpm: must be positive, got {r}")));
        }
        (Some(r), _) => Some(r / 60.0),
        (_, Some(h)) if !(h.is_finite() && h > 0.0) => {
            return Err(Error::Other(format!("--shaft-hz: must be positive, got {h}")));
        }
        (_, h) => h,
    };
    let mut teeth = a.teeth.as_deref().map(parse_teeth).transpose()?;
    if teeth.is_none() {
        if let Some(sc) = &a.scene {
            teeth = scene_teeth(sc)?;
        }
    }
    let opts = dg::Options {
        channel: a.channel,
        fs_hz: a.fs,
        fs_unknown: a.fs_unknown,
        shaft_hz,
        teeth,
        tacho_channel: a.tacho_channel,
        pulses_per_rev: a.pulses_per_rev,
        quantity: match a.quantity {
            QuantityArg::Acceleration => dg::Quantity::Acceleration,
            QuantityArg::Velocity => dg::Quantity::Velocity,
            QuantityArg::Displacement => dg::Quantity::Displacement,
        },
        ..Default::default()
    };
    let baseline = match &a.baseline {
        Some(b) => Some(dg::diagnose(std::path::Path::new(b), &opts, None)?),
        None => None,
    };
    let geometry = baseline.as_ref().map(|b| dg::Geometry {
        period_samples: (b.speed_source == "estimated").then_some(b.shaft_period_samples),
        mesh_order: (b.teeth_source == "estimated").then_some(b.mesh_order),
    });
    let results: Vec<Result<dg::Diagnosis, Error>> =
        a.recordings.par_iter().map(|r| dg::diagnose(std::path::Path::new(r), &opts, geometry.as_ref())).collect();
    let mut done = Vec::with_capacity(results.len());
    for r in results {
        done.push(r?);
    }
    dg::ensemble_na4(&mut done);
    for d in &mut done {
        dg::judge(d, baseline.as_ref());
        if let Some(sc) = &a.scene {
            dg::compare(d, sc, opts.quantity)?;
        }
    }
    if let Some(dir) = &a.report {
        for d in &done {
            let dirp = report_dir(dir)?;
            let stem =
                std::path::Path::new(&d.file).file_stem().and_then(|s| s.to_str()).unwrap_or("recording").to_string();
            crate::io::write_atomic(&dirp.join(format!("{stem}-diagnosis.json")), to_json_line(d).as_bytes())?;
            let files = crate::report::figures::diagnosis(d, &dirp).map_err(report_err)?;
            if !a.json {
                println!("report: {}", files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>().join(", "));
            }
        }
    }
    for d in &done {
        if a.json {
            println!("{}", to_json_line(d));
        } else {
            print_diagnosis(d);
        }
    }
    let rank = |s: &str| match s {
        "faulty" => 2,
        "suspect" => 1,
        _ => 0,
    };
    let worst = done.iter().map(|d| rank(&d.verdict.state)).max().unwrap_or(0);
    Ok(match a.fail_on {
        Some(FailOn::Faulty) if worst >= 2 => 1,
        Some(FailOn::Suspect) if worst >= 1 => 1,
        _ => 0,
    })
}

fn print_diagnosis(d: &crate::diagnose::Diagnosis) {
    println!("file             {}", d.file);
    match d.sample_rate_hz {
        Some(fs) => println!("sample rate      {fs} Hz, {} samples, channels {:?}", d.samples, d.channels),
        None => println!("sample rate      unknown (orders only), {} samples, channels {:?}", d.samples, d.channels),
    }
    let shafts: Vec<String> = d
        .shaft_hz
        .iter()
        .map(|(k, v)| match v {
            Some(f) => format!("{k} {f:.4} Hz"),
            None => format!("{k} period {:.3} samples", d.shaft_period_samples),
        })
        .collect();
    println!("speed            {} ({}, confidence {:.2})", shafts.join(", "), d.speed_source, d.speed_confidence);
    match d.mesh_hz {
        Some(f) => println!("mesh             {f:.3} Hz = order {} ({})", d.mesh_order, d.teeth_source),
        None => println!("mesh             order {} ({})", d.mesh_order, d.teeth_source),
    }
    println!("VERDICT          {} (gear: {})", d.verdict.state.to_uppercase(), d.verdict.gear);
    for r in &d.verdict.reasons {
        println!("  - {r}");
    }
    println!("indicators (TSA of each gear's shaft; FM4/M6A/M8A on the difference signal, NA4 on the residual):");
    let keys = ["fm0", "fm4", "m6a", "m8a", "na4", "er", "si", "slf", "ser", "rms", "kurtosis", "crest_factor"];
    println!("  {:<10} {:>3} {}", "gear", "ch", keys.iter().map(|k| format!("{k:>10}")).collect::<String>());
    for g in &d.gears {
        let vals: String =
            keys.iter().map(|k| format!("{:>10.4}", g.indicators.get(*k).copied().unwrap_or(f64::NAN))).collect();
        println!("  {:<10} {:>3} {vals}", g.gear.chars().take(10).collect::<String>(), g.channel);
    }
    println!("mesh harmonics (channel {}):", d.channels[0]);
    for h in &d.mesh_harmonics {
        let f = h.frequency_hz.map_or("-".into(), |f| format!("{f:.2} Hz"));
        let mut sb = h.sidebands.iter().filter(|s| s.resolved).cloned().collect::<Vec<_>>();
        sb.sort_by(|a, b| b.amplitude.total_cmp(&a.amplitude));
        let top: Vec<String> =
            sb.iter().take(4).map(|s| format!("{:+} {} {:.3e}", s.offset, s.shaft, s.amplitude)).collect();
        println!("  {}x mesh  {f:>12}  {:.4e}   strongest sidebands: {}", h.k, h.amplitude, top.join("; "));
    }
    if let Some(c) = &d.comparison {
        println!(
            "model comparison ({} at {:.1} rpm): distance {:.2} dB over {} lines, scale at mesh {:.3e}",
            c.scene,
            c.model_speed_rpm,
            c.distance_db,
            c.lines.len(),
            c.scale_at_mesh
        );
        for m in &c.model_misses {
            println!("  model misses      {m}");
        }
        for m in &c.model_overpredicts {
            println!("  model overpredicts {m}");
        }
    }
    for w in &d.warnings {
        println!("warning          {w}");
    }
    println!();
}

/// A spinner on stderr when it is a terminal, nothing otherwise.
fn spinner() -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal;
    std::io::stderr().is_terminal().then(|| {
        let pb = indicatif::ProgressBar::new_spinner();
        pb.enable_steady_tick(std::time::Duration::from_millis(120));
        pb
    })
}

fn bench(scenes: &[String], report: Option<&str>, json: bool) -> Result<u8, Error> {
    let paths: Vec<String> = if scenes.is_empty() {
        crate::bench::DEFAULT_SCENES.iter().map(|s| s.to_string()).collect()
    } else {
        scenes.to_vec()
    };
    let loaded = paths.iter().map(|p| Scene::load(p)).collect::<Result<Vec<_>, _>>()?;
    let pb = spinner();
    let progress = |m: &str| {
        if let Some(pb) = &pb {
            pb.set_message(m.to_string());
        }
    };
    let mut all = crate::bench::BenchReport { results: Vec::new(), references: Vec::new() };
    for scene in &loaded {
        let (r, reference) = crate::bench::bench_scene(scene, &progress)?;
        all.results.extend(r);
        all.references.push(reference);
    }
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    if let Some(dir) = report {
        let dir = std::path::Path::new(dir);
        std::fs::create_dir_all(dir).map_err(|e| Error::Other(format!("{}: {e}", dir.display())))?;
        crate::io::write_atomic(&dir.join("bench.json"), to_json_line(&all).as_bytes())?;
        for scene in &loaded {
            let png = dir.join(format!("bench-{}.png", scene.name));
            crate::report::plot::render_png(&png, 1200, 800, &[crate::bench::chart(&scene.name, &all.results)])
                .map_err(|e| Error::Other(e.to_string()))?;
            if !json {
                println!("wrote {}", png.display());
            }
        }
    }
    if json {
        println!("{}", to_json_line(&all));
        return Ok(0);
    }
    println!("{:<36} {:<22} {:>10} {:>12} {:>12}", "scene", "method", "resolution", "time [s]", "error");
    for r in &all.results {
        println!("{:<36} {:<22} {:>10} {:>12.3e} {:>12.3e}", r.scene, r.method, r.resolution, r.time_s, r.error);
    }
    for r in &all.references {
        println!("reference {}: rk4 points against {}; hill points against {}", r.scene, r.for_rk4, r.for_hill);
    }
    Ok(0)
}

fn sweep(
    path: &str,
    param: &str,
    range: (f64, f64, usize),
    output: Option<&str>,
    report: Option<&str>,
    json: bool,
) -> Result<u8, Error> {
    let scene = Scene::load(path)?;
    let field = crate::sweep::resolve(&scene, param)?;
    let (from, to, steps) = range;
    let bar = {
        use std::io::IsTerminal;
        std::io::stderr().is_terminal().then(|| indicatif::ProgressBar::new(steps as u64))
    };
    let tick = || {
        if let Some(b) = &bar {
            b.inc(1);
        }
    };
    let points = crate::sweep::sweep(&scene, &field, from, to, steps, &tick)?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let failed = points.iter().filter(|p| p.error.is_some()).count();
    if failed > 0 {
        eprintln!("gearvib: warning: {failed} of {steps} points failed (listed with their error in the JSON)");
    }
    let doc = serde_json::json!({"scene": scene.name, "param": field, "points": points});
    let mut images = Vec::new();
    if let Some(dir) = report {
        let d = report_dir(dir)?;
        crate::io::write_atomic(&d.join("sweep.json"), doc.to_string().as_bytes())?;
        images.push(d.join(format!("stability-map-{}.png", scene.name)));
    }
    if let Some(o) = output {
        images.push(std::path::PathBuf::from(o));
    }
    for img in &images {
        crate::report::figures::stability_map(img, &scene.name, &field, &field, &points).map_err(report_err)?;
    }
    if json {
        println!("{doc}");
        return Ok(0);
    }
    println!("{:>14} {:>14} {:>8}  lines", field, "|rho|max", "stable");
    let stride = (points.len() / 40).max(1);
    for p in points.iter().step_by(stride) {
        match (p.rho_max, &p.error) {
            (Some(r), _) => {
                let lines: Vec<String> = p.lines.iter().map(|l| format!("{}={:.3e}", l.0, l.1)).collect();
                println!("{:>14.6} {:>14.6e} {:>8}  {}", p.value, r, p.stable.unwrap_or(false), lines.join(" "));
            }
            (None, e) => println!("{:>14.6} failed: {}", p.value, e.clone().unwrap_or_default()),
        }
    }
    for img in &images {
        println!("wrote {}", img.display());
    }
    Ok(0)
}
