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
        /// Print one JSON object on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Monodromy matrix and Floquet multipliers of a scene.
    Stability {
        /// Scene JSON file.
        scene: String,
        /// Print one JSON object on stdout.
        #[arg(long)]
        json: bool,
    },
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
        Command::Simulate { scene, output, allow_aliasing, json } => {
            simulate(&scene, output.as_deref(), allow_aliasing, json)
        }
        Command::Stability { scene, json } => stability(&scene, json),
    }
}

fn warn_all(warnings: &[String]) {
    for w in warnings {
        eprintln!("gearvib: warning: {w}");
    }
}

fn stability(path: &str, json: bool) -> Result<u8, Error> {
    let scene = Scene::load(path)?;
    let steady = crate::solver::solve(scene.system(), &scene.solver)?;
    let summary = StabilitySummary::new(&scene, &steady);
    warn_all(&summary.warnings);
    if steady.error_estimate > scene.solver.tolerance {
        return Err(Error::Other(format!(
            "{path}: multipliers not trusted: estimated error {:.2e} is above solver.tolerance {:.1e}",
            steady.error_estimate, scene.solver.tolerance
        )));
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
        "method           {} ({} steps, stability limit {} steps), estimated error {:.2e} (tolerance {:.1e})",
        s.method, s.steps, s.stability_limit_steps, s.error_estimate, s.tolerance
    );
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

fn simulate(path: &str, output: Option<&str>, allow_aliasing: bool, json: bool) -> Result<u8, Error> {
    let scene = Scene::load(path)?;
    if let Some(out) = output {
        // refuse a bad request before any computation
        crate::synth::check_request(&scene, std::path::Path::new(out), allow_aliasing, &mut Vec::new())?;
    }
    let sim = pipeline::simulate(&scene)?;
    let mut summary = SimulateSummary::new(&scene, &sim);
    warn_all(&summary.stability.warnings);
    if !sim.steady.trusted {
        return Err(Error::Other(format!(
            "{path}: periodic solution not printed: it cannot meet solver.tolerance {:.1e} (estimated error {:.2e}, cond(I - Phi) {:.2e})",
            scene.solver.tolerance, sim.steady.error_estimate, sim.steady.cond_i_minus_phi
        )));
    }
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
