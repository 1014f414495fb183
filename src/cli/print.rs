//! Text output of every command (the JSON forms are `report::summary`). Writes to any `Write`, so a
//! closed pipe comes back as an `io::Error` of kind `BrokenPipe` instead of a panic.

use crate::report::summary::{
    BenchReport, Diagnosis, ErrorHarmonic, Identification, PhaseOrigin, SimulateSummary, StabilitySummary, SweepSummary,
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

/// The text form of one diagnosis.
pub fn diagnosis(w: &mut dyn Write, d: &Diagnosis) -> io::Result<()> {
    writeln!(w, "file             {}", d.file)?;
    match d.sample_rate_hz {
        Some(fs) => writeln!(w, "sample rate      {fs} Hz, {} samples, channels {:?}", d.samples, d.channels)?,
        None => {
            writeln!(w, "sample rate      unknown (orders only), {} samples, channels {:?}", d.samples, d.channels)?
        }
    }
    let shafts: Vec<String> = d
        .shaft_hz
        .entries()
        .into_iter()
        .map(|(k, v)| match v {
            Some(f) => format!("{k} {f:.4} Hz"),
            None => format!("{k} period {:.3} samples", d.shaft_period_samples),
        })
        .collect();
    writeln!(w, "speed            {} ({}, confidence {:.2})", shafts.join(", "), d.speed_source, d.speed_confidence)?;
    let p = &d.speed_profile;
    let range = match (p.min_hz, p.max_hz) {
        (Some(lo), Some(hi)) => {
            format!("revolutions from {lo:.4} to {hi:.4} Hz (10-90 % within +-{:.3} %), ", p.fluctuation_percent)
        }
        _ => format!("revolutions 10-90 % within +-{:.3} %, ", p.fluctuation_percent),
    };
    let snr = p.line_snr_db.map_or(String::new(), |s| format!(", tracked line {s:.0} dB above its band"));
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
    writeln!(w, "VERDICT          {} (gear: {})", d.verdict.state.name().to_uppercase(), d.verdict.gear.name())?;
    for r in &d.verdict.reasons {
        writeln!(w, "  - {r}")?;
    }
    writeln!(w, "indicators (TSA of each gear's shaft; FM4/M6A/M8A on the difference signal, NA4 on the residual):")?;
    let keys = ["fm0", "fm4", "m6a", "m8a", "na4", "er", "si", "slf", "ser", "rms", "kurtosis", "crest"];
    let name_width = d.gears.iter().map(|g| g.gear.name().len()).max().unwrap_or(4).max(4);
    let head: String = keys.iter().map(|k| format!(" {k:>10}")).collect();
    writeln!(w, "  {:<name_width$} {:>3}{head}", "gear", "ch")?;
    for g in &d.gears {
        let vals: String = keys
            .iter()
            .map(|k| {
                let key = if *k == "crest" { "crest_factor" } else { k };
                format!(" {:>10}", table_number(g.indicators.get(key).copied().unwrap_or(f64::NAN)))
            })
            .collect();
        writeln!(w, "  {:<name_width$} {:>3}{vals}", g.gear.name(), g.channel)?;
    }
    let unit = if d.unit.is_empty() { "unit of the file" } else { d.unit.as_str() };
    writeln!(w, "mesh harmonics (channel {}, amplitudes in {unit}):", d.channels[0])?;
    for h in &d.mesh_harmonics {
        let f = h.frequency_hz.map_or("-".into(), |f| format!("{f:.2} Hz"));
        let mut sb = h.sidebands.iter().filter(|s| s.resolved).cloned().collect::<Vec<_>>();
        sb.sort_by(|a, b| b.amplitude.total_cmp(&a.amplitude));
        let top: Vec<String> =
            sb.iter().take(4).map(|s| format!("{:+} {} {:.3e}", s.offset, s.shaft, s.amplitude)).collect();
        writeln!(w, "  {}x mesh  {f:>12}  {:.4e}   strongest sidebands: {}", h.k, h.amplitude, top.join("; "))?;
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
            "envelope         band {:.0}..{:.0} Hz (spectral kurtosis {:.2}{}): {}",
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
    for warning in &d.warnings {
        writeln!(w, "warning          {warning}")?;
    }
    writeln!(w)?;
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

/// The text form of `sweep` (at most about 40 rows).
pub fn sweep(w: &mut dyn Write, s: &SweepSummary) -> io::Result<()> {
    writeln!(w, "{:>14} {:>14} {:>8} {:>8}  lines", s.param, "|rho|max", "stable", "trusted")?;
    let stride = (s.points.len() / 40).max(1);
    for p in s.points.iter().step_by(stride) {
        match (p.rho_max, &p.error) {
            (Some(r), _) => {
                let lines: Vec<String> = p.lines.iter().map(|l| format!("{}={:.3e}", l.0, l.1)).collect();
                let trusted = if p.trusted { "yes" } else { "NO" };
                let stable = p.stable.unwrap_or(false);
                writeln!(w, "{:>14.6} {:>14.6e} {:>8} {:>8}  {}", p.value, r, stable, trusted, lines.join(" "))?;
            }
            (None, e) => writeln!(w, "{:>14.6} failed: {}", p.value, e.clone().unwrap_or_default())?,
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
        "fit              {:.2} % of the sideband energy explained, chi2/dof {:.2}, condition {:.1e}{}",
        100.0 * r.explained_fraction,
        r.chi2_per_dof,
        r.condition,
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
            "LOCAL FAULT      {} on {} tooth {}: depth {:.4e} {} (removes {:.1} % of the residual, significance {:.2e})",
            f.kind.name(),
            f.gear.name(),
            f.tooth,
            f.depth,
            f.depth_unit,
            100.0 * f.improvement,
            f.significance
        )?,
        None if r.fault_candidates.is_empty() => writeln!(w, "local fault      not searched (--faults crack,pit)")?,
        None => writeln!(w, "local fault      none fits better than none beyond the noise")?,
    }
    for c in &r.fault_candidates {
        writeln!(
            w,
            "  candidate      {} on {} tooth {}: depth {:.4e} {}, significance {:.3e} (reported above 25)",
            c.kind.name(),
            c.gear.name(),
            c.tooth,
            c.depth,
            c.depth_unit,
            c.significance
        )?;
    }
    for n in &r.warnings {
        writeln!(w, "note             {n}")?;
    }
    Ok(())
}
