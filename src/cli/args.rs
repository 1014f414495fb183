//! Command-line arguments (clap). Only the shape of the flags lives here; their meaning is in `cli::run`.

use crate::model::Quantity;
use clap::{Parser, Subcommand};

/// gearvib: gear-pair vibration simulation, Floquet stability and gear-fault diagnosis.
#[derive(Parser, Debug)]
#[command(name = "gearvib", version, about, long_about = None)]
pub struct Cli {
    /// The command.
    #[command(subcommand)]
    pub command: Command,
}

impl Cli {
    /// Whether the command analyses recordings (record-long buffers allocated and freed by several
    /// threads at once), for the binary's choice of allocator settings.
    pub fn reads_recordings(&self) -> bool {
        matches!(self.command, Command::Diagnose(_))
    }
}

/// The commands.
#[derive(Subcommand, Debug)]
pub enum Command {
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
    Diagnose(Box<DiagnoseArgs>),
    /// Learn a healthy profile from healthy recordings of one machine (files or directories): the
    /// machine, the processing settings and every indicator's healthy distribution, for `diagnose
    /// --profile`.
    Learn(Box<LearnArgs>),
    /// Fit a gear-pair scene to a recording: tooth-error harmonics, per-tooth deviation, path gains, and
    /// optionally a local fault (pit or crack) on one tooth.
    Identify(Box<IdentifyArgs>),
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

/// Arguments of `diagnose`. Negative numbers reach the flags' own checks (`--rpm -5` is refused as a
/// speed, not as an unknown argument).
#[derive(clap::Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct DiagnoseArgs {
    /// Recordings (.wav or .csv), in time order (NA4 uses that order).
    #[arg(required = true)]
    pub recordings: Vec<String>,
    /// Analyse only this channel (1-based); default: all but the tachometer.
    #[arg(long)]
    pub channel: Option<usize>,
    /// Sample rate in Hz (needed for a CSV without a time column; one that contradicts the file's own is
    /// refused unless --fs-override).
    #[arg(long)]
    pub fs: Option<f64>,
    /// The --fs rate overrides the rate in the file's header or time column (a logger that wrote a wrong
    /// header).
    #[arg(long)]
    pub fs_override: bool,
    /// The sample rate is not known: analyse in orders of the estimated shaft period only.
    #[arg(long)]
    pub fs_unknown: bool,
    /// Pinion (input) shaft speed in rpm.
    #[arg(long, conflicts_with = "shaft_hz")]
    pub rpm: Option<f64>,
    /// Pinion (input) shaft speed in Hz.
    #[arg(long)]
    pub shaft_hz: Option<f64>,
    /// Relative tolerance of a given speed: with the teeth known, the mesh line is sought within it and
    /// the measured speed used (a nameplate speed is off by the motor's slip).
    #[arg(long, default_value_t = 0.05)]
    pub speed_tolerance: f64,
    /// Teeth of pinion and wheel, e.g. 14,39 (the one-stage shorthand of --machine).
    #[arg(long, value_name = "ZP,ZW")]
    pub teeth: Option<String>,
    /// Machine file (JSON: shafts, parallel and planetary stages, speed, tachometer, sensors): every
    /// shaft's speed from the ratio chain, every stage's lines, a TSA per shaft, the planets' averages;
    /// --rpm/--shaft-hz are then the speed of the machine's `speed.shaft`.
    #[arg(long, value_name = "MACHINE.json")]
    pub machine: Option<String>,
    /// Tachometer channel (1-based) on the pinion shaft (default: the sidecar's "tacho pinion"). It gives
    /// the speed; a speed given beside it is the nominal one, checked against it.
    #[arg(long)]
    pub tacho_channel: Option<usize>,
    /// Tachometer pulses per revolution.
    #[arg(long, default_value_t = 1)]
    pub pulses_per_rev: usize,
    /// Healthy recordings of the same machine to judge against (files or directories of .wav/.csv; the
    /// flag may be repeated or take several paths). Their blocks of whole revolutions make the statistical
    /// baseline. A single file cannot show how recordings at another load differ: its limits keep an
    /// allowance for a neighbouring load, and what stands between its own limits and those is said; two
    /// files or more, at the loads the machine runs at, judge more finely.
    #[arg(long, num_args = 1..)]
    pub baseline: Vec<String>,
    /// Envelope band in Hz, LO,HI (default: the band of largest spectral kurtosis from the kurtogram).
    #[arg(long, value_name = "LO,HI")]
    pub envelope_band: Option<String>,
    /// Remove this shaft's family of lines (pinion, or wheel with --teeth) by comb liftering of the real
    /// cepstrum before the envelope analysis, so what does not repeat with that shaft (a bearing, the other
    /// gear) shows in the envelope.
    #[arg(long, value_parser = ["pinion", "wheel"])]
    pub lifter: Option<String>,
    /// Deepest kurtogram level (band width fs / 2^(level + 1)); default 5.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=30))]
    pub kurtogram_levels: Option<u64>,
    /// Revolutions per block of the statistical baseline (default 8, fewer when the baseline is short).
    #[arg(long, value_parser = clap::value_parser!(u64).range(2..=10_000))]
    pub block_revs: Option<u64>,
    /// A healthy profile written by `learn`: the recordings are judged against it with exactly its
    /// settings (its teeth, speed, channels, tachometer, block length and band); only what describes a
    /// recording's own file (--fs, --fs-override, --unit, --sensitivity) may be given beside it, and
    /// --same-load.
    #[arg(long, conflicts_with = "baseline")]
    pub profile: Option<String>,
    /// The baseline (--baseline or --profile) was recorded at this recording's load and speed: the limits
    /// of a single baseline file are then its own blocks', without the allowance kept for a neighbouring
    /// load (which one file cannot show). Say it only when it is so: a healthy recording at another load
    /// may then be called suspect.
    #[arg(long)]
    pub same_load: bool,
    /// Scene to simulate at the recording's speed and compare with.
    #[arg(long)]
    pub scene: Option<String>,
    /// What the recording measures (for --scene): acceleration, velocity or displacement; by default what
    /// the unit says (sidecar, CSV header or --unit), else velocity.
    #[arg(long)]
    pub quantity: Option<Quantity>,
    /// Physical unit of the analysed channels when the file does not name one (m/s, m/s^2, g, ...).
    #[arg(long)]
    pub unit: Option<String>,
    /// Sensitivity: recorded value per physical unit (e.g. 0.1 for 100 mV per g); the samples are divided
    /// by it.
    #[arg(long, value_parser = positive_f64, allow_negative_numbers = true)]
    pub sensitivity: Option<f64>,
    /// Machine class for the ISO 10816-3 zones of the overall velocity (RMS, 10-1000 Hz, mm/s): group 1
    /// is 300 kW to 50 MW, group 2 15 to 300 kW, on rigid or flexible supports.
    #[arg(long, value_parser = ["group1-rigid", "group1-flexible", "group2-rigid", "group2-flexible"])]
    pub iso_class: Option<String>,
    /// How the report's spectrum image shows levels: amplitude (log axis, the signal's unit), db (20 log10
    /// of the amplitude re 1 unit) or psd (power spectral density, unit^2/Hz).
    #[arg(long, value_parser = ["amplitude", "db", "psd"])]
    pub spectrum: Option<String>,
    /// Exit with code 1 when any recording is at least this bad.
    #[arg(long, value_enum)]
    pub fail_on: Option<FailOn>,
    /// Write PNG images and the JSON summary into this directory.
    #[arg(long)]
    pub report: Option<String>,
    /// One JSON object per recording, one per line.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `learn`: the healthy recordings and the analysis flags of `diagnose`, and the profile to
/// write.
#[derive(clap::Args, Debug)]
pub struct LearnArgs {
    /// Where the profile goes (JSON).
    #[arg(short = 'o', long = "output", value_name = "PROFILE.json", required = true)]
    pub output: String,
    /// The healthy recordings and how they are analysed (the flags of `diagnose`; --baseline, --profile,
    /// --scene, --report and --fail-on do not apply).
    #[command(flatten)]
    pub analysis: DiagnoseArgs,
}

/// Arguments of `identify`.
#[derive(clap::Args, Debug)]
pub struct IdentifyArgs {
    /// Recording (.wav or .csv).
    pub recording: String,
    /// Scene JSON file of the gear pair (teeth, inertias, radii, Fourier mesh stiffness, damping, speed).
    #[arg(long)]
    pub scene: String,
    /// Pinion error orders 1..N to fit (N below half the pinion teeth).
    #[arg(long, default_value_t = 6)]
    pub pinion_orders: usize,
    /// Wheel error orders 1..M to fit (above 0: averaged over the hunting period; needs a wheel
    /// tachometer for absolute wheel phases).
    #[arg(long, default_value_t = 0)]
    pub wheel_orders: usize,
    /// Mesh harmonics to use (default: all the sample rate resolves, at most 10).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=200))]
    pub mesh_harmonics: Option<u64>,
    /// Local faults to search for on every tooth, comma-separated: crack, pit.
    #[arg(long, value_delimiter = ',')]
    pub faults: Vec<crate::jobs::identify::FaultKind>,
    /// Width of a pit in tooth pitches (6 sigma of its Gaussian profile).
    #[arg(long, default_value_t = 0.5)]
    pub pit_width: f64,
    /// Vibration channel (1-based); default: the first that is not a tachometer.
    #[arg(long)]
    pub channel: Option<usize>,
    /// Tachometer channel (1-based) on the pinion shaft, pulse at angle 0; default: the sidecar's
    /// "tacho pinion" channel, else the angle comes from the mesh phase (phases then relative).
    #[arg(long)]
    pub tacho_channel: Option<usize>,
    /// Sample rate in Hz (overrides the file).
    #[arg(long)]
    pub fs: Option<f64>,
    /// What the recording measures: acceleration, velocity or displacement (default: from its unit).
    #[arg(long)]
    pub quantity: Option<Quantity>,
    /// Write identify.json, PNG images and index.html into this directory.
    #[arg(long)]
    pub report: Option<String>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The verdict from which `--fail-on` exits with code 1.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq)]
pub enum FailOn {
    /// Faulty recordings only.
    Faulty,
    /// Suspect or faulty recordings.
    Suspect,
}

/// Parses the process arguments: help and version as clap prints them; any other error as one line on
/// stderr (see [`one_line`]) and exit code 2.
pub fn parse_args() -> Cli {
    match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                e.exit();
            }
            eprintln!("gearvib: error: {}", one_line(&e.render().to_string()));
            std::process::exit(2);
        }
    }
}

/// Parses `args` (the program name first) as the command line would be.
///
/// # Errors
/// The one-line message of [`parse_args`] (help and version requests come back as their text).
pub fn parse_from<I, T>(args: I) -> Result<Cli, String>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    Cli::try_parse_from(args).map_err(|e| one_line(&e.render().to_string()))
}

/// clap's error text in one line with every hint it gives kept: the error, the names it lists on the
/// next lines, its tips ("a similar argument exists: '--tacho-channel'"), the possible values, and the
/// pointer to `--help`; only the usage block, which repeats the help, is left out. Long numerals are
/// compacted as in every error line ([`crate::report::format::compact_numerals`]).
pub fn one_line(rendered: &str) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut in_usage = false;
    for line in rendered.lines().map(str::trim) {
        if line.is_empty() {
            in_usage = false;
            continue;
        }
        if line.starts_with("Usage:") {
            in_usage = true;
            continue;
        }
        if in_usage {
            continue;
        }
        let line = line.trim_start_matches("error: ");
        // a list under "...:" (the missing arguments) joins its heading
        match parts.last_mut() {
            Some(last) if last.ends_with(':') || line.starts_with('[') => {
                last.push(' ');
                last.push_str(line);
            }
            _ => parts.push(line.to_string()),
        }
    }
    if parts.is_empty() {
        "invalid arguments; try 'gearvib --help'".into()
    } else {
        crate::report::format::compact_numerals(&parts.join("; "))
    }
}

/// A finite number above zero (for factors such as `--sensitivity`).
fn positive_f64(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(v) => Err(format!("must be a finite number above 0, got {v}")),
        Err(_) => Err(format!("{s:?} is not a number")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn error_of(args: &[&str]) -> String {
        match parse_from(std::iter::once("gearvib").chain(args.iter().copied())) {
            Ok(_) => panic!("{args:?} parsed"),
            Err(e) => e,
        }
    }

    #[test]
    fn one_line_keeps_clap_hints() {
        // the values clap lists, its did-you-mean, and the pointer to --help, all on one line
        let e = error_of(&["diagnose", "x.wav", "--fail-on", "bad"]);
        assert!(e.contains("[possible values: faulty, suspect]"), "{e}");
        assert!(e.contains("--help"), "{e}");
        assert!(!e.contains('\n'), "{e}");
        let e = error_of(&["diagnose", "x.wav", "--tacho-chanel", "2"]);
        assert!(e.contains("'--tacho-channel'"), "{e}");
        let e = error_of(&["diagnose"]);
        assert!(e.contains("<RECORDINGS>"), "{e}");
        // a flag of another command is not suggested (clap offers identify's own --fs)
        let e = error_of(&["identify", "x.wav", "--scene", "s.json", "--fs-unknown"]);
        assert!(e.contains("unexpected argument '--fs-unknown'"), "{e}");
        assert!(!e.contains("exists: '--fs-unknown'"), "{e}");
        let e = error_of(&["diagnose", "x.wav", "--sensitivity", "-1"]);
        assert!(e.contains("above 0"), "{e}");
    }
}
