//! Parameter sweeps: Floquet analysis and steady state over a range of one scene parameter, in parallel.

use super::{Given, JobError};
use crate::Error;
use crate::report::format::num;
use crate::report::summary::{SweepPoint, SweepSummary};
use crate::scene::{Model, Scene};
use rayon::prelude::*;
use std::path::PathBuf;

/// One `sweep` call.
#[derive(Clone, Debug)]
pub struct SweepJob {
    /// Scene file.
    pub scene: PathBuf,
    /// Parameter: `speed`, `damping`, `load`, or a dotted JSON path such as `gear_pair.damping_ratio`.
    pub param: String,
    /// First value (the parameter's unit).
    pub from: f64,
    /// Last value.
    pub to: f64,
    /// Number of values, at least 2.
    pub steps: usize,
    /// Stability-map images to draw (PNG).
    pub images: Vec<PathBuf>,
    /// Directory for `sweep.json` and the stability map.
    pub report: Option<PathBuf>,
}

/// What [`run`] produced.
#[derive(Clone, Debug)]
pub struct SweepOutcome {
    /// The points and the resolved parameter.
    pub summary: SweepSummary,
    /// Images written.
    pub images: Vec<PathBuf>,
}

/// Runs a sweep: loads the scene, resolves the parameter, evaluates every point on all cores (`tick` after
/// each), writes the JSON and the stability maps asked for.
///
/// # Errors
/// Unreadable scene, unknown parameter, bad range, unwritable outputs.
pub fn run(job: &SweepJob, progress: &Progress<'_>) -> Result<SweepOutcome, Error> {
    crate::io::begin_run();
    let scene = Scene::load(&job.scene.display().to_string())?;
    let field = resolve(&scene, &job.param)?;
    let partial = match &job.report {
        Some(dir) => {
            crate::io::create_dir(dir)?;
            Some(dir.join("sweep.partial.jsonl"))
        }
        None => None,
    };
    let points = sweep(&scene, &field, (job.from, job.to, job.steps), partial.as_deref(), progress)?;
    if let Some(p) = &partial {
        let _ = std::fs::remove_file(p); // complete: sweep.json replaces the partial record
    }
    let summary = summarize(&scene, &field, points)?;
    let mut images = job.images.clone();
    if let Some(dir) = &job.report {
        crate::io::write_atomic(&dir.join("sweep.json"), crate::report::summary::to_json_line(&summary).as_bytes())?;
        images.push(dir.join(format!("stability-map-{}.png", scene.name)));
    }
    for img in &images {
        crate::report::figures::stability_map(img, &scene.name, &field, scene.output.quantity.unit(), &summary.points)?;
    }
    if let Some(dir) = &job.report {
        let own: Vec<PathBuf> = images.iter().filter(|i| i.starts_with(dir)).cloned().collect();
        let section = crate::report::html::sweep_section(&summary, &own);
        images.push(crate::report::html::write(dir, &format!("gearvib sweep: {}", scene.name), &[section])?);
    }
    Ok(SweepOutcome { summary, images })
}

/// The `sweep --json` summary of `points` of the parameter at dotted path `field`.
///
/// # Errors
/// Every point failed (the first failure is quoted).
pub fn summarize(scene: &Scene, field: &str, points: Vec<SweepPoint>) -> Result<SweepSummary, Error> {
    if let Some(first) =
        points.iter().find_map(|p| p.error.clone()).filter(|_| points.iter().all(|p| p.error.is_some()))
    {
        return Err(JobError::Input {
            file: scene.file.clone(),
            message: format!("every one of the {} sweep points failed; the first: {first}", points.len()),
        }
        .into());
    }
    let unstable_ranges = crate::report::summary::unstable_ranges(&points);
    Ok(SweepSummary { param: field.to_string(), points, scene: scene.name.clone(), unstable_ranges })
}

/// Dotted JSON path of a parameter: an alias (`speed`, `damping`, `load`) or any numeric field of the scene
/// by its path, e.g. `gear_pair.pinion.errors[0].amplitude_m`.
///
/// # Errors
/// The path does not lead to a number in this scene.
pub fn resolve(scene: &Scene, name: &str) -> Result<String, Error> {
    let path = match (name, &scene.model) {
        ("speed", Model::GearPair(_)) => "gear_pair.speed_rpm".to_string(),
        ("speed", Model::Press(..)) => "press.speed_rpm".to_string(),
        ("damping", Model::GearPair(_)) => "gear_pair.damping_ratio".to_string(),
        ("load", Model::Press(..)) => "press.load_n".to_string(),
        ("load", Model::GearPair(_)) => "gear_pair.static_deflection_m".to_string(),
        _ => name.to_string(),
    };
    match pointer(&scene.json, &path).and_then(|v| v.as_f64()) {
        Some(_) => Ok(path),
        None => Err(JobError::Parameter {
            scene: scene.file.clone(),
            name: name.to_string(),
            message: format!(
                "the scene has no numeric field `{path}` (aliases: speed, damping, load; or a dotted path such as gear_pair.damping_ratio)"
            ),
        }
        .into()),
    }
}

fn json_pointer(path: &str) -> String {
    let mut out = String::new();
    for part in path.split('.') {
        let (key, idx) = match part.find('[') {
            Some(i) => (&part[..i], Some(&part[i..])),
            None => (part, None),
        };
        out.push('/');
        out.push_str(key);
        if let Some(idx) = idx {
            for i in idx.split(['[', ']']).filter(|s| !s.is_empty()) {
                out.push('/');
                out.push_str(i);
            }
        }
    }
    out
}

fn pointer<'a>(v: &'a serde_json::Value, path: &str) -> Option<&'a serde_json::Value> {
    v.pointer(&json_pointer(path))
}

/// What a sweep tells its caller while it runs.
pub struct Progress<'a> {
    /// Called once after the first point, with the estimated run time of the whole sweep in s.
    pub estimate: &'a (dyn Fn(f64) + Sync),
    /// Called after each point.
    pub tick: &'a (dyn Fn() + Sync),
}

/// Runs the sweep: `steps` values evenly from `from` to `to` (`range` = (from, to, steps)). Each finished
/// point is appended to `partial` (JSON Lines) when given, so an interrupted sweep keeps what it computed.
///
/// # Errors
/// Bad range or parameter; the partial file cannot be written.
pub fn sweep(
    scene: &Scene,
    path: &str,
    range: (f64, f64, usize),
    partial: Option<&std::path::Path>,
    progress: &Progress<'_>,
) -> Result<Vec<SweepPoint>, Error> {
    let (from, to, steps) = range;
    if !(from.is_finite() && to.is_finite() && (2..=1_000_000).contains(&steps)) {
        return Err(JobError::Value {
            what: Given::SweepRange,
            message: format!("needs finite bounds and 2..=1000000 values, got from {from} to {to} in {steps}"),
        }
        .into());
    }
    let values = if takes_whole_numbers(scene, path) {
        whole_values(path, from, to, steps)?
    } else {
        (0..steps).map(|i| from + (to - from) * i as f64 / (steps - 1) as f64).collect()
    };
    sweep_values(scene, path, &values, partial, progress)
}

/// Whether the scene holds a whole number at `path` (a tooth count, a harmonic count): a sweep then takes
/// whole values only.
fn takes_whole_numbers(scene: &Scene, path: &str) -> bool {
    pointer(&scene.json, path).is_some_and(|v| v.is_i64() || v.is_u64())
}

/// `steps` whole numbers spread evenly from `from` to `to` (the bounds rounded inwards), each rounded:
/// distinct, since there are at least `steps` whole numbers between the bounds (their spacing is then at
/// least 1).
///
/// # Errors
/// Fewer whole numbers in the range than `steps`.
fn whole_values(path: &str, from: f64, to: f64, steps: usize) -> Result<Vec<f64>, Error> {
    let (lo, hi) = if from <= to { (from.ceil(), to.floor()) } else { (from.floor(), to.ceil()) };
    let count = ((hi - lo).abs() + 1.0) * if (hi - lo) * (to - from) >= 0.0 { 1.0 } else { 0.0 };
    if count < steps as f64 {
        return Err(JobError::Value {
            what: Given::SweepSteps,
            message: format!(
                "`{path}` takes whole numbers and {} to {} holds {}, fewer than the {steps} values asked",
                num(from),
                num(to),
                num(count)
            ),
        }
        .into());
    }
    Ok((0..steps).map(|i| (lo + (hi - lo) * i as f64 / (steps - 1) as f64).round()).collect())
}

/// Most values one sweep takes.
pub const MAX_SWEEP_VALUES: usize = 1_000_000;

/// [`sweep`] over the given parameter `values` (in the parameter's unit, any order; 1 to 1 000 000 finite
/// values), one point per value in the same order.
///
/// # Errors
/// No value, too many, a value that is not finite; the partial file cannot be written.
pub fn sweep_values(
    scene: &Scene,
    path: &str,
    values: &[f64],
    partial: Option<&std::path::Path>,
    progress: &Progress<'_>,
) -> Result<Vec<SweepPoint>, Error> {
    if values.is_empty() || values.len() > MAX_SWEEP_VALUES || values.iter().any(|v| !v.is_finite()) {
        return Err(JobError::Value {
            what: Given::SweepValues,
            message: format!(
                "needs 1..=1000000 finite values, got {} ({} not finite)",
                values.len(),
                values.iter().filter(|v| !v.is_finite()).count()
            ),
        }
        .into());
    }
    let z1 = match &scene.model {
        Model::GearPair(g) => Some(g.params().pinion_teeth),
        _ => None,
    };
    let steps = values.len();
    let log = match partial {
        Some(p) => Some(std::sync::Mutex::new(std::io::BufWriter::new(
            std::fs::File::create(p).map_err(|e| crate::io::DataError::io(p, format!("cannot write: {e}")))?,
        ))),
        None => None,
    };
    let record = |p: &SweepPoint| {
        if let Some(log) = &log {
            use std::io::Write;
            let mut w = log.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            let _ = writeln!(w, "{}", crate::report::summary::to_json_line(p)).and_then(|_| w.flush());
        }
        (progress.tick)();
    };
    // the first point alone, timed, gives the run-time estimate
    let started = std::time::Instant::now();
    let first = point(scene, path, values[0], z1);
    (progress.estimate)(started.elapsed().as_secs_f64() * steps as f64 / rayon::current_num_threads().max(1) as f64);
    record(&first);
    let mut points = vec![first];
    points.par_extend(values[1..].par_iter().map(|&value| {
        let p = point(scene, path, value, z1);
        record(&p);
        p
    }));
    Ok(points)
}

fn point(scene: &Scene, path: &str, value: f64, z1: Option<usize>) -> SweepPoint {
    let failed = |e: String| SweepPoint {
        value,
        rho_max: None,
        stable: None,
        trusted: false,
        lines: Vec::new(),
        error: Some(e),
    };
    let mut json = scene.json.clone();
    match json.pointer_mut(&json_pointer(path)) {
        // a whole-number field keeps its type (serde refuses 10.0 for a tooth count)
        Some(slot) if slot.is_i64() || slot.is_u64() => {
            if value.fract() != 0.0 || value.abs() > 9.0e15 {
                return failed(format!("field `{path}` takes whole numbers, got {}", num(value)));
            }
            *slot = (value as i64).into();
        }
        Some(slot) => *slot = value.into(),
        None => return failed(format!("no field {path}")),
    }
    let s = match Scene::from_value(json, &scene.file) {
        Ok(s) => s,
        Err(e) => return failed(e.to_string()),
    };
    // the point's own teeth: a sweep of the tooth count moves the mesh orders
    let z1 = match &s.model {
        Model::GearPair(g) => Some(g.params().pinion_teeth),
        _ => z1,
    };
    match super::simulate::solve_with_orders(&s) {
        Ok((steady, _, orders)) => {
            let lines = match z1 {
                Some(z) => (1..=3)
                    .map(|k| {
                        let order = (k * z) as f64;
                        let a = orders.iter().find(|l| (l.order - order).abs() < 1e-9).map_or(0.0, |l| l.amplitude);
                        (format!("{k}x mesh (order {})", k * z), a)
                    })
                    .collect(),
                None => orders.iter().skip(1).take(3).map(|l| (format!("order {:.3}", l.order), l.amplitude)).collect(),
            };
            SweepPoint {
                value,
                rho_max: Some(steady.floquet.rho_max),
                stable: Some(steady.floquet.stable),
                trusted: steady.trusted,
                lines,
                error: None,
            }
        }
        Err(e) => failed(e.to_string()),
    }
}
