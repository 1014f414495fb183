//! Text output of every command (the JSON forms are `report::summary`). Writes to any `Write`, so a
//! closed pipe comes back as an `io::Error` of kind `BrokenPipe` instead of a panic.

use crate::report::figures::stands_out;
use crate::report::format::num;
use crate::report::identify::{condition_words, fault_size};
use crate::report::summary::{
    BenchReport, Diagnosis, ErrorHarmonic, Identification, Indicator, PhaseOrigin, SimulateSummary, StabilitySummary,
    SweepSummary,
};
use std::io::{self, Write};

/// The text form of `stability`.
pub fn stability(w: &mut dyn Write, s: &StabilitySummary) -> io::Result<()> {
    writeln!(w, "scene            {}", s.scene)?;
    writeln!(w, "period           {:.6} s", s.period_s)?;
    writeln!(
        w,
        "method           {} ({} {}; rk4 stability limit {} steps), estimated error {:.2e} (tolerance {:.1e})",
        s.method, s.steps, s.resolution_unit, s.stability_limit_steps, s.error_estimate, s.tolerance
    )?;
    writeln!(
        w,
        "error parts      periodic solution {:.2e}, monodromy (multipliers) {:.2e}",
        s.state_error, s.multiplier_error
    )?;
    writeln!(w, "why              {}", s.method_reason)?;
    writeln!(w, "conditioning     {:.3e} (||(I - Phi)^-1|| max(||Phi||, 1), balanced state)", s.cond_i_minus_phi)?;
    writeln!(
        w,
        "|rho|max         {:.6e}  -> {}",
        s.rho_max,
        if s.stable { "asymptotically stable" } else { "UNSTABLE" }
    )?;
    writeln!(w, "multipliers      re            im            |rho|")?;
    for m in &s.multipliers {
        writeln!(w, "                 {:+.6e} {:+.6e} {:.6e}", m.re, m.im, m.abs)?;
    }
    for n in &s.notes {
        writeln!(w, "note             {n}")?;
    }
    Ok(())
}

/// Channel numbers as a list: "1, 2".
fn channels(c: &[usize]) -> String {
    c.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")
}

/// The text form of one diagnosis.
pub fn diagnosis(
    w: &mut dyn Write,
    d: &Diagnosis,
    iso_class: Option<crate::signal::velocity::MachineClass>,
) -> io::Result<()> {
    writeln!(w, "file             {}", d.file)?;
    match d.sample_rate_hz {
        Some(fs) => {
            writeln!(w, "sample rate      {fs} Hz, {} samples, channel(s) {}", d.samples, channels(&d.channels))?
        }
        None => writeln!(
            w,
            "sample rate      unknown (orders only), {} samples, channel(s) {}",
            d.samples,
            channels(&d.channels)
        )?,
    }
    let shafts: Vec<String> = d
        .shaft_hz
        .entries()
        .into_iter()
        .zip(d.shaft_hz.shafts())
        .filter_map(|((k, v), shaft)| {
            let k = if k == "estimated_shaft" { "shaft of the estimated period" } else { k };
            match v {
                Some(f) => Some(format!("{k} {} Hz", num(f))),
                None => d
                    .revolution_samples(shaft)
                    .map(|period| format!("{k}: one revolution every {} samples", num(period))),
            }
        })
        .collect();
    match (d.speed_given_hz, d.speed_deviation_percent) {
        (Some(g), Some(off)) => {
            writeln!(w, "speed            {} (measured; given {g:.4} Hz, {off:+.2} % from it)", shafts.join(", "))?
        }
        _ => writeln!(
            w,
            "speed            {} ({}, confidence {:.2})",
            shafts.join(", "),
            d.speed_source,
            d.speed_confidence
        )?,
    }
    let p = &d.speed_profile;
    let range = match (p.min_hz, p.max_hz) {
        (Some(lo), Some(hi)) => {
            format!("revolutions from {lo:.4} to {hi:.4} Hz (10-90 % within +-{:.3} %), ", p.fluctuation_percent)
        }
        _ => format!("revolutions 10-90 % within +-{:.3} %, ", p.fluctuation_percent),
    };
    let snr = p.line_snr_db.map_or(String::new(), |s| format!(", tracked line {s:.0} dB above its band"));
    let snr = match p.refined_gain {
        Some(g) => format!("{snr}, refined on the synchronous average (its RMS x{g:.2})"),
        None => snr,
    };
    writeln!(w, "tracking         {}: {range}change {:+.3} % over the recording{snr}", p.tracking, p.change_percent)?;
    match d.mesh_hz {
        Some(f) => writeln!(w, "mesh             {f:.3} Hz = order {} ({})", d.mesh_order, d.teeth_source)?,
        None => writeln!(w, "mesh             order {} ({})", d.mesh_order, d.teeth_source)?,
    }
    if let Some(g) = &d.other_gear {
        writeln!(
            w,
            "meshing gear     {} teeth (estimated from its sidebands, confidence {:.2})",
            g.teeth, g.confidence
        )?;
    }
    writeln!(w, "VERDICT          {} (gear: {})", d.verdict.state.name().to_uppercase(), d.verdict.place())?;
    for r in &d.verdict.reasons {
        writeln!(w, "  - {r}")?;
    }
    for c in &d.verdict.cross_talk {
        writeln!(w, "  cross-talk: {c}")?;
    }
    writeln!(w, "indicators (TSA of each gear's shaft; FM4/M6A/M8A on the difference signal, NA4 on the residual):")?;
    let keys = Indicator::TABLE;
    let name_width = d.gears.iter().map(|g| g.gear.name().len()).max().unwrap_or(4).max(4);
    let head: String = keys.iter().map(|k| format!(" {:>10}", k.column())).collect();
    writeln!(w, "  {:<name_width$} {:>3}{head}", "gear", "ch")?;
    for g in &d.gears {
        let vals: String = keys
            .iter()
            .map(|k| format!(" {:>10}", table_number(g.indicators.get(k).copied().unwrap_or(f64::NAN))))
            .collect();
        writeln!(w, "  {:<name_width$} {:>3}{vals}", g.gear.name(), g.channel)?;
    }
    match &d.machine {
        Some(md) if d.order_map.is_none() => machine_lines(w, d, md)?,
        _ => mesh_harmonics(w, d)?,
    }
    if let Some(e) = &d.envelope {
        let lines: Vec<String> = e
            .lines
            .iter()
            .filter(|l| l.order == 1)
            .map(|l| format!("{} order 1 {:+.1} dB over the envelope spectrum around", l.shaft, l.over_floor_db))
            .collect();
        writeln!(
            w,
            "envelope         band {:.0}-{:.0} Hz (spectral kurtosis {:.2}{}): {}",
            e.band_hz[0],
            e.band_hz[1],
            e.spectral_kurtosis,
            e.liftered.map_or(String::new(), |s| format!("; {s} family removed by comb liftering")),
            lines.join("; ")
        )?;
    }
    if let Some(c) = &d.comparison {
        writeln!(
            w,
            "model comparison ({} at {:.1} rpm): distance {:.2} dB over {} lines, scale at mesh {:.3e}",
            c.scene,
            c.model_speed_rpm,
            c.distance_db,
            c.lines.len(),
            c.scale_at_mesh
        )?;
        for m in &c.model_misses {
            writeln!(w, "  model misses      {m}")?;
        }
        for m in &c.model_overpredicts {
            writeln!(w, "  model overpredicts {m}")?;
        }
    }
    writeln!(w, "velocity         {}", crate::report::html::velocity_words(d, iso_class))?;
    for warning in &d.warnings {
        writeln!(w, "warning          {warning}")?;
    }
    writeln!(w)?;
    Ok(())
}

/// The mesh harmonics and, in the words of the images, the sidebands that stand out 12 dB over the local
/// floor; at a changing speed (a run-up) a spectrum in Hz smears every line, so only the order spectrum
/// image is pointed to.
fn mesh_harmonics(w: &mut dyn Write, d: &Diagnosis) -> io::Result<()> {
    let unit = crate::report::figures::unit_or(&d.unit);
    if d.order_map.is_some() {
        return writeln!(
            w,
            "mesh harmonics   the speed changed {} % over the recording: lines in Hz are smeared, no sideband table (the report's order spectrum and rpm-order map show them in orders)",
            num(d.speed_profile.change_percent)
        );
    }
    let spectrum = d.spectra().iter().find(|s| s.0 == d.channels[0]).map(|s| &s.1);
    writeln!(w, "mesh harmonics (channel {}, amplitudes in {unit}):", d.channels[0])?;
    for h in &d.mesh_harmonics {
        let f = h.frequency_hz.map_or("-".into(), |f| format!("{} Hz", num(f)));
        let mut sb: Vec<_> =
            h.sidebands.iter().filter(|s| spectrum.map_or(s.resolved, |sp| stands_out(sp, s))).collect();
        sb.sort_by(|a, b| b.amplitude.total_cmp(&a.amplitude));
        let top: Vec<String> = sb.iter().map(|s| format!("{:+} {} {}", s.offset, s.shaft, num(s.amplitude))).collect();
        let top = if top.is_empty() { "none".to_string() } else { top.join("; ") };
        writeln!(w, "  {}x mesh  {f:>10}  {}   sidebands 12 dB over the local floor: {top}", h.k, num(h.amplitude))?;
    }
    Ok(())
}

/// Every stage of a machine: its mesh harmonics and the sidebands that stand out, labelled by the family's
/// shaft; a planetary stage's characteristic orders and its planets' averages.
fn machine_lines(w: &mut dyn Write, d: &Diagnosis, md: &crate::report::summary::MachineDiagnosis) -> io::Result<()> {
    let unit = crate::report::figures::unit_or(&d.unit);
    let spectrum = d.spectra().iter().find(|s| s.0 == d.channels[0]).map(|s| &s.1);
    writeln!(
        w,
        "machine          {} (orders of the tracked shaft `{}`; channel {}, amplitudes in {unit})",
        md.machine, md.tracked_shaft, d.channels[0]
    )?;
    for s in &md.stages {
        let hz = s.mesh_hz.map_or(String::new(), |f| format!(" = {} Hz", num(f)));
        writeln!(
            w,
            "  {}: order {} ({}){hz}",
            crate::report::figures::stage_words(s),
            num(s.mesh_order),
            s.mesh_order_exact
        )?;
        for h in &s.mesh_harmonics {
            let mut sb: Vec<_> = h
                .sidebands
                .iter()
                .filter(|x| spectrum.is_some_and(|sp| crate::report::figures::machine_sideband_stands_out(sp, x)))
                .collect();
            sb.sort_by(|a, b| b.amplitude.unwrap_or(0.0).total_cmp(&a.amplitude.unwrap_or(0.0)));
            let top: Vec<String> =
                sb.iter().map(|x| format!("{:+} {} {}", x.offset, x.family, num(x.amplitude.unwrap_or(0.0)))).collect();
            let top = if top.is_empty() { "none".to_string() } else { top.join("; ") };
            let f = h.frequency_hz.map_or("-".into(), |f| format!("{} Hz", num(f)));
            let a = h.amplitude.map_or("-".into(), num);
            writeln!(w, "    {}x mesh  {f:>10}  {a}   sidebands 12 dB over the local floor: {top}", h.k)?;
        }
        if let Some(p) = &s.planetary {
            let orders: Vec<String> = p
                .orders
                .iter()
                .map(|(k, v)| match p.frequencies_hz.get(k) {
                    Some(f) => format!("{} {} ({} Hz)", k.replace('_', " "), num(*v), num(*f)),
                    None => format!("{} {}", k.replace('_', " "), num(*v)),
                })
                .collect();
            writeln!(w, "    orders: {}", orders.join(", "))?;
            for a in &p.planet_averages {
                let get = |k: Indicator| a.indicators.get(&k).copied().map_or("-".into(), table_number);
                writeln!(
                    w,
                    "    planet {} average ({} passes): FM4 {}, M6A {}, kurtosis {}, RMS {}",
                    a.planet,
                    a.passes,
                    get(Indicator::Fm4),
                    get(Indicator::M6a),
                    get(Indicator::Kurtosis),
                    get(Indicator::Rms)
                )?;
            }
            if let Some(why) = &p.no_averages {
                writeln!(w, "    no planet averages: {why}")?;
            }
        }
    }
    Ok(())
}

/// The text form of `simulate` (the stability part, then the output's strongest lines).
pub fn simulate(w: &mut dyn Write, summary: &SimulateSummary) -> io::Result<()> {
    stability(w, &summary.stability)?;
    writeln!(
        w,
        "output           {} [{}], RMS {:.4e}, peak-to-peak {:.4e}",
        summary.quantity, summary.unit, summary.rms, summary.peak_to_peak
    )?;
    let peak = summary.orders.iter().skip(1).map(|o| o.amplitude).fold(0.0, f64::max);
    writeln!(w, "strongest lines (order of {} = {:.4} Hz, above 1 % of the largest):", summary.base, summary.base_hz)?;
    writeln!(w, "  order     freq [Hz]    amplitude [{}]", summary.unit)?;
    let mut lines: Vec<_> = summary.orders.iter().skip(1).filter(|o| o.amplitude >= 0.01 * peak).collect();
    lines.sort_by(|a, b| b.amplitude.total_cmp(&a.amplitude));
    for o in lines.iter().take(20) {
        writeln!(w, "  {:8.3}  {:10.3}   {:.4e}", o.order, o.frequency_hz, o.amplitude)?;
    }
    Ok(())
}

/// The text form of `simulate` on a gear train.
pub fn train(w: &mut dyn Write, s: &crate::jobs::train::TrainSummary) -> io::Result<()> {
    if let Some(f) = &s.signal_file {
        writeln!(w, "wrote {f} and {f}.json")?;
    }
    writeln!(w, "method           {} ({})", s.method, s.method_reason)?;
    match (s.rho_max, s.stable) {
        (Some(r), Some(st)) => {
            writeln!(w, "stability        |rho|max = {r:.6} ({})", if st { "stable" } else { "UNSTABLE" })?
        }
        _ => writeln!(w, "stability        {}", s.stability_note)?,
    }
    writeln!(w, "error estimate   {:.2e}", s.error_estimate)?;
    for (name, hz) in s.shafts.iter().zip(&s.shaft_hz) {
        writeln!(w, "shaft {name:<10} {hz:.4} Hz")?;
    }
    for (k, hz) in s.mesh_hz.iter().enumerate() {
        writeln!(w, "mesh {}           {hz:.3} Hz", k + 1)?;
    }
    writeln!(w, "sum of dq/dt     RMS {:.4e} m/s; strongest lines:", s.rms)?;
    for l in s.lines.iter().take(20) {
        writeln!(w, "  {:10.3} Hz   {:.4e} m/s   {}", l.frequency_hz, l.amplitude, l.label)?;
    }
    Ok(())
}

/// The text form of `bench`.
pub fn bench(w: &mut dyn Write, all: &BenchReport) -> io::Result<()> {
    writeln!(w, "{:<36} {:<22} {:>10} {:>12} {:>12}", "scene", "method", "resolution", "time [s]", "error")?;
    for r in &all.results {
        writeln!(w, "{:<36} {:<22} {:>10} {:>12.3e} {:>12.3e}", r.scene, r.method, r.resolution, r.time_s, r.error)?;
    }
    for r in &all.references {
        writeln!(w, "reference {}: rk4 points against {}; hill points against {}", r.scene, r.for_rk4, r.for_hill)?;
    }
    Ok(())
}

/// The text form of `sweep`: the unstable ranges first, then at most about 40 rows (every point when
/// there are fewer; otherwise every n-th and every unstable or failed point, and a line saying so).
pub fn sweep(w: &mut dyn Write, s: &SweepSummary) -> io::Result<()> {
    let unstable: usize = s.unstable_ranges.iter().map(|r| r.points).sum();
    if s.unstable_ranges.is_empty() {
        writeln!(w, "stable at all {} points", s.points.len())?;
    } else {
        writeln!(w, "UNSTABLE at {unstable} of {} points, in {} range(s):", s.points.len(), s.unstable_ranges.len())?;
        for r in &s.unstable_ranges {
            writeln!(
                w,
                "  {} from {} to {} ({} points, |rho|max up to {})",
                s.param,
                num(r.from),
                num(r.to),
                r.points,
                num(r.rho_max)
            )?;
        }
    }
    let stride = (s.points.len() / 40).max(1);
    let shown: Vec<_> = s
        .points
        .iter()
        .enumerate()
        .filter(|(i, p)| {
            let edge = s.unstable_ranges.iter().any(|r| p.value == r.from || p.value == r.to);
            i % stride == 0 || i + 1 == s.points.len() || edge || !p.trusted || p.error.is_some()
        })
        .map(|(_, p)| p)
        .collect();
    if shown.len() < s.points.len() {
        writeln!(
            w,
            "rows thinned: {} of {} points shown (every {stride}th, the ends of each unstable range, every untrusted or failed one; all in --json)",
            shown.len(),
            s.points.len()
        )?;
    }
    writeln!(w, "{:>14} {:>14} {:>8} {:>8}  lines", s.param, "|rho|max", "stable", "trusted")?;
    for p in shown {
        match (p.rho_max, &p.error) {
            (Some(r), _) => {
                let lines: Vec<String> = p.lines.iter().map(|l| format!("{}={}", l.0, num(l.1))).collect();
                let trusted = if p.trusted { "yes" } else { "NO" };
                let stable = if p.stable == Some(true) { "yes" } else { "NO" };
                writeln!(w, "{:>14} {:>14} {:>8} {:>8}  {}", num(p.value), num(r), stable, trusted, lines.join(" "))?;
            }
            (None, e) => writeln!(w, "{:>14} failed: {}", num(p.value), e.clone().unwrap_or_default())?,
        }
    }
    Ok(())
}

/// A number in at most 10 characters: four decimals while it fits, else three significant digits in
/// scientific notation (an NA4* of 9.9e9 must not run into the next column).
fn table_number(v: f64) -> String {
    let plain = format!("{v:.4}");
    if plain.len() <= 10 && (v == 0.0 || v.abs() >= 1e-3) { plain } else { format!("{v:.3e}") }
}

fn error_rows(w: &mut dyn Write, gear: &str, e: &[ErrorHarmonic]) -> io::Result<()> {
    for h in e {
        writeln!(
            w,
            "  {gear:<6} {:>3}   {:>9.3} +- {:<7.3} {:>+8.4} +- {:<7.4}{}",
            h.order,
            h.amplitude_m * 1e6,
            h.amplitude_std_m * 1e6,
            h.phase_rad,
            h.phase_std_rad,
            if h.resolved { "" } else { "  not resolved (under 3 std)" }
        )?;
    }
    Ok(())
}

fn origin(o: PhaseOrigin) -> &'static str {
    match o {
        PhaseOrigin::Tachometer => "absolute (tachometer)",
        PhaseOrigin::Arbitrary => "relative to an arbitrary origin (no tachometer)",
    }
}

/// The text form of `identify`.
pub fn identification(w: &mut dyn Write, r: &Identification) -> io::Result<()> {
    writeln!(w, "recording        {}", r.recording)?;
    writeln!(w, "scene            {} (z1 {}, z2 {})", r.scene, r.pinion_teeth, r.wheel_teeth)?;
    writeln!(
        w,
        "speed            {:.4} Hz mean ({:.4} .. {:.4}; scene {:.4} Hz); model solved at the mean",
        r.speed.mean_hz, r.speed.min_hz, r.speed.max_hz, r.speed.scene_hz
    )?;
    writeln!(
        w,
        "averaged         {} periods of {} pinion revolution(s), {} mesh harmonics, {} in {}",
        r.periods,
        r.period_revolutions,
        r.mesh_harmonics,
        r.quantity.name(),
        r.unit
    )?;
    writeln!(w, "phases           pinion {}, wheel {}", origin(r.phase_origin.pinion), origin(r.phase_origin.wheel))?;
    writeln!(w, "errors           gear  order  e_i [um] +- std    alpha_i [rad] +- std")?;
    error_rows(w, "pinion", &r.pinion_errors)?;
    error_rows(w, "wheel", &r.wheel_errors)?;
    let teeth = |v: &[f64]| v.iter().map(|d| format!("{:.2}", d * 1e6)).collect::<Vec<_>>().join(" ");
    writeln!(w, "pinion teeth     deviation [um], tooth 1 first: {}", teeth(&r.tooth_deviation_m.pinion))?;
    if !r.tooth_deviation_m.wheel.is_empty() {
        writeln!(w, "wheel teeth      deviation [um], tooth 1 first: {}", teeth(&r.tooth_deviation_m.wheel))?;
    }
    let gains: Vec<String> =
        r.path_gains.iter().map(|g| format!("{}: {:.3}/{:+.2} rad", g.harmonic, g.magnitude, g.phase_rad)).collect();
    writeln!(w, "path gains       {}", gains.join(", "))?;
    writeln!(
        w,
        "fit              {:.2} % of the sideband energy explained, chi2/dof {:.2}, condition number {}{}",
        100.0 * r.explained_fraction,
        r.chi2_per_dof,
        condition_words(r.condition),
        if r.identifiable { "" } else { "  NOT IDENTIFIABLE" }
    )?;
    for l in &r.residual_lines {
        writeln!(
            w,
            "missed line      order {:.3} ({:.1} Hz, {}): measured {:.3e}, model {:.3e}, residual {:.1} noise std",
            l.order,
            l.frequency_hz,
            l.label,
            l.measured,
            l.model,
            l.residual / l.noise
        )?;
    }
    match &r.local_fault {
        Some(f) => writeln!(
            w,
            "LOCAL FAULT      {} on {} tooth {}: {} (removes {} % of the residual, significance {})",
            f.kind.name(),
            f.gear.name(),
            f.tooth,
            fault_size(f.kind, f.depth),
            num(100.0 * f.improvement),
            num(f.significance)
        )?,
        None if r.fault_candidates.is_empty() => writeln!(w, "local fault      not searched (--faults crack,pit)")?,
        None => {
            writeln!(w, "local fault      none: no pit or crack on any tooth explains the lines beyond their noise")?
        }
    }
    for c in &r.fault_candidates {
        writeln!(
            w,
            "  candidate      {} on {} tooth {}: {}, significance {} (reported above 25)",
            c.kind.name(),
            c.gear.name(),
            c.tooth,
            fault_size(c.kind, c.depth),
            num(c.significance)
        )?;
    }
    for n in &r.warnings {
        writeln!(w, "note             {n}")?;
    }
    Ok(())
}

/// What `learn` wrote: the machine and settings, and each gear's reference in a line.
pub fn profile(w: &mut dyn Write, p: &crate::jobs::diagnose::profile::Profile, file: &str) -> std::io::Result<()> {
    let o = &p.processing;
    writeln!(w, "profile          {file} ({} healthy recording(s))", p.learned_from.len())?;
    let teeth = match (&o.machine, o.teeth) {
        (Some(m), _) => {
            let m = m.machine();
            format!("the machine `{}`: {} stage(s), shafts {}", m.name, m.stages.len(), m.shafts.join(", "))
        }
        (None, Some((a, b))) => format!("{a},{b}"),
        (None, None) => "estimated".to_string(),
    };
    writeln!(w, "teeth            {teeth}")?;
    let speed = match (p.baseline.speed_hz, o.shaft_hz) {
        (Some(m), Some(g)) => format!("{m:.4} Hz measured (given {g:.4} Hz, +-{:.1} %)", 100.0 * o.speed_tolerance),
        (Some(m), None) => format!("{m:.4} Hz measured"),
        (None, _) => format!("{:.3} samples per revolution", p.baseline.shaft_period_samples),
    };
    writeln!(w, "speed            {speed}, wandering +-{:.3} %", p.baseline.fluctuation_percent)?;
    writeln!(
        w,
        "channels         {:?} in {}",
        p.baseline.channels,
        if p.baseline.unit.is_empty() { "the file's own scale (no unit)" } else { &p.baseline.unit }
    )?;
    writeln!(
        w,
        "processing       blocks of {} revolutions, averages of {} points per revolution{}",
        o.block_revs.unwrap_or(0),
        p.geometry.tsa_points.unwrap_or(0),
        p.geometry.envelope_band.map_or(String::new(), |(a, b)| format!(", envelope band {a:.0}..{b:.0} Hz"))
    )?;
    for doubt in &p.baseline.speed_doubts {
        writeln!(w, "warning          {doubt}; no recording judged against this profile is called healthy")?;
    }
    Ok(())
}
