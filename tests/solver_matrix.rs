//! Every solver on the gear scenes at two tolerances, against a converged reference from a different
//! method at a much tighter tolerance: the result within the tolerance, the estimate honest (it bounds the
//! true error and, for the step-based methods, overstates it by at most 30x), no refusal. Errors are
//! measured on the balanced state over 256 times of the period.

mod common;
use common::*;
use gearvib::scene::Scene;
use gearvib::solver::steady::state_scales;
use gearvib::solver::{Method, SolverOptions, SteadyState, solve};
use gearvib::system::PeriodicSystem;

fn states(sys: &dyn PeriodicSystem, s: &SteadyState) -> Vec<f64> {
    let times: Vec<f64> = (0..256).map(|i| s.period_s * i as f64 / 256.0).collect();
    let mut out = Vec::new();
    s.states_at(sys, &times, &mut out);
    out
}

/// Largest difference of the balanced state relative to the largest balanced value of `reference`.
fn error(a: &[f64], reference: &[f64], d: &[f64]) -> f64 {
    let n = d.len();
    let scale = reference.chunks(n).flat_map(|x| x.iter().zip(d).map(|(v, s)| (v / s).abs())).fold(0.0, f64::max);
    a.iter().zip(reference).enumerate().map(|(i, (x, y))| (x - y).abs() / d[i % n]).fold(0.0, f64::max) / scale
}

#[test]
fn every_solver_on_the_gear_scenes() {
    for name in [
        "paper-gear-fig8a",
        "hard-gear-light-damping",
        "gear-z14z39-rectangular-stiffness",
        "gear-z14z39-cracked-pinion-tooth3",
    ] {
        let scene = Scene::load(&repo(&format!("data/scenes/{name}.json"))).unwrap();
        let sys = scene.system();
        let d = state_scales(sys);
        let smooth = sys.fourier_form().is_some();
        // reference: harmonic balance at 1e-12 for smooth coefficients, else the rk4 product at 1e-11
        let (ref_method, ref_tol) = if smooth { (Method::Hill, 1e-12) } else { (Method::Rk4, 1e-11) };
        let reference =
            solve(sys, &SolverOptions { method: ref_method, tolerance: ref_tol, ..Default::default() }).unwrap();
        let want = states(sys, &reference);
        for method in [Method::Rk4, Method::Magnus, Method::Hill] {
            if method == Method::Hill && !smooth {
                continue;
            }
            for tol in [1e-6, 1e-8] {
                let s = solve(sys, &SolverOptions { method, tolerance: tol, ..Default::default() })
                    .unwrap_or_else(|e| panic!("{name} {method:?} {tol:e}: {e}"));
                assert!(s.trusted, "{name} {method:?} {tol:e}: {:?}", s.warnings);
                let err = error(&states(sys, &s), &want, &d);
                eprintln!("{name:<36} {method:?} {tol:e}: true {err:.2e}, estimate {:.2e}", s.error_estimate);
                // within the tolerance (10x: the estimate is asymptotic)
                assert!(err <= 10.0 * tol, "{name} {method:?} {tol:e}: error {err:e}");
                // honest: the estimate bounds the true error (the reference's own error, 1e-11, is the floor
                // of what can be measured)
                assert!(
                    err <= 3.0 * s.error_estimate.max(1e-11),
                    "{name} {method:?} {tol:e}: {err:e} vs {:e}",
                    s.error_estimate
                );
            }
        }
    }
}
