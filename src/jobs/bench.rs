//! Speed against error: every solver over a range of resolutions on a scene, timed (median of repeats)
//! and compared with a converged reference computed by a different solver.
//!
//! Error = max over state components of max_t |x(t) - x_ref(t)| / max_t |x_ref(t)|, on 512 equally spaced
//! times of one period. Time = median wall time of producing the periodic solution at that resolution
//! (rk4: monodromy product, (I - Phi) x0 = c_m and the node states; hill: the Fourier solve).

use super::JobError;
use crate::Error;
use crate::report::summary::{BenchReport, BenchResult, Reference};
use crate::scene::Scene;
use crate::solver::{self, Method, SolverOptions, hill, rk4};
use crate::system::PeriodicSystem;
use nalgebra::{DMatrix, DVector};
use std::path::PathBuf;
use std::time::Instant;

/// One `bench` call.
#[derive(Clone, Debug, Default)]
pub struct BenchJob {
    /// Scenes; empty means [`DEFAULT_SCENES`].
    pub scenes: Vec<PathBuf>,
    /// Directory for `bench.json` and the work-precision PNGs.
    pub report: Option<PathBuf>,
}

/// What [`run`] produced.
#[derive(Clone, Debug)]
pub struct BenchOutcome {
    /// Every measured point and the references.
    pub report: BenchReport,
    /// Images written.
    pub images: Vec<PathBuf>,
}

/// Benchmarks every scene of `job` (`progress` receives a short status line) and writes the report.
///
/// # Errors
/// A scene cannot be loaded, a reference cannot be computed, or the report cannot be written.
pub fn run(job: &BenchJob, progress: &dyn Fn(&str)) -> Result<BenchOutcome, Error> {
    crate::io::begin_run();
    let paths: Vec<PathBuf> =
        if job.scenes.is_empty() { DEFAULT_SCENES.iter().map(PathBuf::from).collect() } else { job.scenes.clone() };
    let loaded = paths.iter().map(|p| Scene::load(&p.display().to_string())).collect::<Result<Vec<_>, _>>()?;
    let mut all = BenchReport { results: Vec::new(), references: Vec::new() };
    for scene in &loaded {
        let (r, reference) = bench_scene(scene, progress)?;
        all.results.extend(r);
        all.references.push(reference);
    }
    let mut images = Vec::new();
    if let Some(dir) = &job.report {
        crate::io::create_dir(dir)?;
        crate::io::write_atomic(&dir.join("bench.json"), crate::report::summary::to_json_line(&all).as_bytes())?;
        for scene in &loaded {
            let png = dir.join(format!("bench-{}.png", scene.name));
            crate::report::figures::bench(&png, &scene.name, &all.results)?;
            images.push(png);
        }
        let section = crate::report::html::bench_section(&all, &images);
        images.push(crate::report::html::write(dir, "gearvib bench", &[section])?);
    }
    Ok(BenchOutcome { report: all, images })
}

const SAMPLES: usize = 512;

fn sample_times(period: f64) -> Vec<f64> {
    (0..SAMPLES).map(|i| period * i as f64 / SAMPLES as f64).collect()
}

fn rel_error(x: &[f64], reference: &[f64], n: usize) -> f64 {
    let mut worst: f64 = 0.0;
    for c in 0..n {
        let scale = reference.iter().skip(c).step_by(n).fold(0.0f64, |a, v| a.max(v.abs()));
        let diff = x.iter().zip(reference).skip(c).step_by(n).fold(0.0f64, |a, (p, q)| a.max((p - q).abs()));
        if scale > 0.0 {
            worst = worst.max(diff / scale);
        }
    }
    worst
}

/// Median wall time of `f` over repeats (at least 3, until 0.1 s or 15 repeats).
fn median_time<T>(mut f: impl FnMut() -> T) -> (f64, T) {
    let mut times = Vec::new();
    let mut last;
    let start = Instant::now();
    loop {
        let t = Instant::now();
        last = f();
        times.push(t.elapsed().as_secs_f64());
        if times.len() >= 15 || (times.len() >= 3 && start.elapsed().as_secs_f64() > 0.1) {
            break;
        }
    }
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], last)
}

fn rk4_states(sys: &dyn PeriodicSystem, steps: usize, times: &[f64]) -> Option<Vec<f64>> {
    let grid = rk4::Grid::new(sys.period_s(), &sys.breakpoints(), steps);
    let run = rk4::monodromy(sys, &grid);
    let n = sys.dim();
    let x0: DVector<f64> = (DMatrix::identity(n, n) - &run.monodromy).lu().solve(&run.forcing)?;
    let states = rk4::trajectory(sys, &grid, &x0);
    let mut st = rk4::Stepper::new(sys);
    let mut out = Vec::with_capacity(times.len() * n);
    let mut x = vec![0.0; n];
    for &t in times {
        rk4::state_at(&mut st, &grid, &states, t, &mut x);
        out.extend_from_slice(&x);
    }
    out.iter().all(|v| v.is_finite()).then_some(out)
}

fn hill_states(sol: &hill::HillSolution, n: usize, times: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(times.len() * n);
    let mut x = vec![0.0; n];
    for &t in times {
        sol.state(t, &mut x);
        out.extend_from_slice(&x);
    }
    out
}

/// Benchmarks one scene.
///
/// # Errors
/// The references cannot be computed.
pub fn bench_scene(scene: &Scene, progress: &dyn Fn(&str)) -> Result<(Vec<BenchResult>, Reference), Error> {
    let sys = scene.system();
    let n = sys.dim();
    let times = sample_times(sys.period_s());
    let form = sys.fourier_form();
    let name = scene.name.clone();
    // references: each method is judged against the other, converged far beyond the bench range
    progress(&format!("{name}: references"));
    // the tightest rk4 reference that converges within its step cap (the hunting period stops near 1e-10)
    let rk4_ref = [1e-11, 1e-10, 1e-9].iter().find_map(|&tol| {
        solver::solve(sys, &SolverOptions { method: Method::Rk4, tolerance: tol, ..Default::default() })
            .ok()
            .map(|r| (r, tol))
    });
    let hill_ref = match &form {
        Some(f) => Some(hill::solve(f, sys.max_harmonic(), 1e-13, 1 << 20)?.0),
        None => None,
    };
    // the rk4 ladder is judged against another method: harmonic balance for smooth Fourier coefficients,
    // magnus4 with one step per piece (exact exponentials) for piecewise-constant ones, else rk4 itself at
    // 16 times the finest step count
    let exact = (form.is_none() && sys.piecewise_constant()).then(|| {
        let pieces = sys.breakpoints().len() + 1;
        let o = SolverOptions { method: Method::Magnus, steps: Some(pieces), ..Default::default() };
        solver::solve(sys, &o).map(|ss| {
            let mut out = Vec::new();
            ss.states_at(sys, &times, &mut out);
            out
        })
    });
    let mut ref_for_rk4 = "rk4 at 16x the finest step count (no second method for coefficients with jumps)".to_string();
    let reference_for_rk4: Vec<f64> = match (&hill_ref, exact) {
        (Some(h), _) => {
            ref_for_rk4 = format!("hill, {} harmonics, tolerance 1e-13", h.harmonics);
            hill_states(h, n, &times)
        }
        (None, Some(states)) => {
            ref_for_rk4 =
                "magnus4, one step per piece of the piecewise-constant coefficients (exact exponentials)".into();
            states?
        }
        (None, None) => Vec::new(),
    };
    let reference_for_hill: Option<Vec<f64>> = rk4_ref.as_ref().map(|(r, _)| {
        let mut out = Vec::new();
        r.states_at(sys, &times, &mut out);
        out
    });
    let mut results = Vec::new();
    // rk4 ladder: from twice the stability limit, doubling, while a solve takes under 0.3 s
    let limit = (sys.period_s() * solver::max_rate(sys) / solver::RK4_STABILITY_LIMIT).ceil() as usize;
    let m0 = (2 * limit).max(32).max(2 * (sys.breakpoints().len() + 1));
    let mut ladder = Vec::new();
    let mut m = m0;
    for _ in 0..9 {
        ladder.push(m);
        m *= 2;
    }
    let reference_for_rk4 = if reference_for_rk4.is_empty() {
        let finest = 16 * ladder[ladder.len() - 1].min(1 << 18);
        rk4_states(sys, finest, &times).ok_or_else(|| JobError::Input {
            file: scene.file.clone(),
            message: format!("the rk4 reference of {finest} steps failed"),
        })?
    } else {
        reference_for_rk4
    };
    for &m in &ladder {
        progress(&format!("{name}: rk4 {m} steps"));
        let (t, states) = median_time(|| rk4_states(sys, m, &times));
        if let Some(s) = states {
            results.push(BenchResult {
                scene: name.clone(),
                method: "rk4".into(),
                resolution: m,
                time_s: t,
                error: rel_error(&s, &reference_for_rk4, n),
            });
        }
        if t > 0.3 {
            break;
        }
    }
    if let (Some(f), Some(reference)) = (&form, &reference_for_hill) {
        let hmax = sys.max_harmonic().max(4);
        let mut h = hmax;
        for _ in 0..10 {
            progress(&format!("{name}: hill {h} harmonics"));
            let (t, sol) = median_time(|| hill::solve_order(f, h));
            if let Ok((sol, _)) = sol {
                results.push(BenchResult {
                    scene: name.clone(),
                    method: "hill".into(),
                    resolution: h,
                    time_s: t,
                    error: rel_error(&hill_states(&sol, n, &times), reference, n),
                });
            }
            h = (h * 5).div_ceil(4);
        }
    }
    // auto at a few tolerances: the full solve (multipliers and error estimate included)
    for tol in [1e-6, 1e-8, 1e-10] {
        progress(&format!("{name}: auto at {tol:e}"));
        let o = SolverOptions { method: Method::Auto, tolerance: tol, ..Default::default() };
        let (t, ss) = median_time(|| solver::solve(sys, &o));
        if let Ok(ss) = ss {
            let mut out = Vec::new();
            ss.states_at(sys, &times, &mut out);
            // judged by another method: hill and magnus4 by the converged rk4 solve, rk4 by the ladder's
            let reference = match ss.method {
                Method::Hill | Method::Magnus => reference_for_hill.as_ref().unwrap_or(&reference_for_rk4),
                _ => &reference_for_rk4,
            };
            results.push(BenchResult {
                scene: name.clone(),
                method: format!("auto@{tol:e}->{}", ss.method),
                resolution: ss.resolution,
                time_s: t,
                error: rel_error(&out, reference, n),
            });
        }
    }
    let for_hill = match &rk4_ref {
        Some((r, tol)) => format!("rk4, tolerance {tol:e} ({} steps); also for auto's magnus4", r.resolution),
        None => "none".into(),
    };
    Ok((results, Reference { scene: name, for_rk4: ref_for_rk4, for_hill }))
}

/// The default scenes: the paper's cases and the hard cases shipped in `data/scenes/`, a piecewise-constant
/// Meissner equation (exact by magnus4) and a forced Mathieu equation 1e-10 from a stability boundary
/// (`data/bench/`).
pub const DEFAULT_SCENES: [&str; 7] = [
    "data/scenes/paper-gear-fig8a.json",
    "data/scenes/paper-press-case1.json",
    "data/scenes/hard-gear-light-damping.json",
    "data/scenes/gear-z14z39-rectangular-stiffness.json",
    "data/scenes/gear-z14z39-wheel-eccentricity.json",
    "data/bench/meissner-steps.json",
    "data/bench/mathieu-near-a1.json",
];
