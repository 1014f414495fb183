//! One harness, written once: every solver against every catalog problem with an exact answer
//! (`gearvib::model::catalog::problems`, each with its citation), then through the common
//! `check_periodic_solver` (every printed quantity against the test-side reference and its estimate), each
//! problem its own test.

mod common;
use common::check::{self, Case, Source};
use gearvib::model::catalog::{self, Problem};
use gearvib::solver::response::Probe;
use gearvib::solver::{Method, SolverError, SolverOptions, solve};
use gearvib::system::PeriodicSystem;

/// The result of one check, for messages.
struct Outcome {
    x0_error: f64,
    rho_error: f64,
    state_estimate: f64,
    multiplier_estimate: f64,
}

/// Solves `problem` with `method` at `tolerance` and checks the periodic state and the multipliers against
/// the exact answer. Errors are relative to the largest state component (x0) and to max(1, |rho|max)
/// (multipliers). Tolerance: 10x the requested accuracy, because every solver's step or harmonic count
/// comes from an asymptotic error estimate (Richardson or geometric decay) that may be off by a small
/// factor. Returns `None` when the method rightly refuses the problem (harmonic balance on jumps).
fn check_exact(problem: &Problem, method: Method, tolerance: f64) -> Option<Outcome> {
    let opts = SolverOptions { method, tolerance, ..Default::default() };
    let ss = match solve(&problem.system, &opts) {
        Err(SolverError::Unsupported(why)) if method == Method::Hill && problem.system.fourier_form().is_none() => {
            assert!(why.contains("jumps"), "{}: {why}", problem.name);
            return None;
        }
        r => r.unwrap_or_else(|e| panic!("{} with {method:?} at {tolerance:e}: {e}", problem.name)),
    };
    let exact = &problem.exact;
    let scale = exact.x0.iter().fold(1e-300f64, |a, v| a.max(v.abs()));
    let x0_error = ss.x0.iter().zip(&exact.x0).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max)
        / if exact.x0.iter().all(|v| *v == 0.0) { 1.0 } else { scale };
    let rho_scale = exact.rho_max.max(1.0);
    let mut rho_error = (ss.floquet.rho_max - exact.rho_max).abs() / rho_scale;
    if let Some(m) = &exact.multipliers {
        for r in m {
            let nearest = ss.floquet.multipliers.iter().map(|s| (s - r).norm()).fold(f64::INFINITY, f64::min);
            rho_error = rho_error.max(nearest / rho_scale);
        }
    }
    let what = format!("{} ({}) with {method:?} at {tolerance:e}", problem.name, problem.citation);
    assert!(x0_error <= 10.0 * tolerance, "{what}: x0 error {x0_error:e}");
    assert!(rho_error <= 10.0 * tolerance, "{what}: multiplier error {rho_error:e}");
    // honest estimates (the exact answers carry about 1e-13): the state's bounds the x0 error and overstates
    // it at most 30x; the monodromy's bounds the multiplier error (a multiplier can be far more accurate than
    // the matrix, e.g. |rho| fixed by det Phi, so no upper check here: tests/solver_matrix.rs checks the
    // monodromy estimate against the monodromy's own error)
    let floor = 1e-13;
    assert!(x0_error <= ss.state_error.max(floor), "{what}: x0 error {x0_error:e} above {:e}", ss.state_error);
    assert!(ss.state_error <= 30.0 * x0_error.max(floor), "{what}: x0 estimate {:e} over 30x", ss.state_error);
    assert!(
        rho_error <= ss.multiplier_error.max(floor),
        "{what}: rho error {rho_error:e} above {:e}",
        ss.multiplier_error
    );
    Some(Outcome { x0_error, rho_error, state_estimate: ss.state_error, multiplier_estimate: ss.multiplier_error })
}

/// Every solver at three tolerances on catalog problem `index`: its exact answer, then every printed
/// quantity (displacement lines to 8, rms, peak-to-peak, multipliers) against the reference.
fn every_solver_on(index: usize) {
    let p = &catalog::problems()[index];
    let case = Case {
        name: p.name.into(),
        source: Source::System(p.system.clone(), Probe { weights: vec![1.0, 0.0], derivative: false }),
        lines: 8,
        reference_steps: 1 << 15,
    };
    let reference = check::reference(&case);
    for method in [Method::Rk4, Method::Magnus, Method::Hill, Method::Auto] {
        for tol in [1e-6, 1e-8, 1e-10] {
            if let Some(o) = check_exact(p, method, tol) {
                eprintln!(
                    "{:<28} {method:?} {tol:e}: x0 {:.1e} (est {:.1e}), rho {:.1e} (est {:.1e})",
                    p.name, o.x0_error, o.state_estimate, o.rho_error, o.multiplier_estimate
                );
            }
            check::check_periodic_solver(&case, &reference, method, tol);
        }
    }
}

#[test]
fn undamped_oscillator() {
    every_solver_on(0);
}

#[test]
fn constant_coefficients() {
    every_solver_on(1);
}

#[test]
fn forced_damped_oscillator() {
    every_solver_on(2);
}

#[test]
fn mathieu_a0_b1() {
    every_solver_on(3);
}

#[test]
fn mathieu_a1_b2() {
    every_solver_on(4);
}

#[test]
fn damped_meissner() {
    every_solver_on(5);
}

#[test]
fn the_catalog_is_covered() {
    // one test above per problem
    assert_eq!(catalog::problems().len(), 6);
}

#[test]
fn every_problem_cites_its_answer() {
    for p in catalog::problems() {
        assert!(p.citation.len() > 20, "{}", p.name);
        assert!(p.exact.x0.iter().all(|v| v.is_finite()) && p.exact.rho_max.is_finite(), "{}", p.name);
    }
}
