//! Every solver on the gear scenes at three tolerances, against a converged reference from a different
//! method at a much tighter tolerance: the result within the tolerance, both estimates honest (the state's
//! and the monodromy's each bound their true error and overstate it by at most 30x), no refusal. Errors
//! are measured on the balanced state over 256 times of the period and on the balanced monodromy.

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

/// n times the largest entry of the balanced D^-1 (Phi - Phi_ref) D relative to max(|D^-1 Phi_ref D|, 1):
/// the measure of `SteadyState::multiplier_error`.
fn monodromy_error(s: &SteadyState, reference: &SteadyState, d: &[f64]) -> f64 {
    let n = d.len();
    let b = |i: usize, j: usize, m: &nalgebra::DMatrix<f64>| m[(i, j)] * d[j] / d[i];
    let mut diff: f64 = 0.0;
    let mut size: f64 = 1.0;
    for i in 0..n {
        for j in 0..n {
            diff = diff.max((b(i, j, &s.monodromy) - b(i, j, &reference.monodromy)).abs());
            size = size.max(b(i, j, &reference.monodromy).abs());
        }
    }
    n as f64 * diff / size
}

/// The reference's own error: what a true error below it cannot be told from.
const FLOOR: f64 = 1e-11;

/// An estimate against the true error: it bounds it (above the floor) and overstates it at most 30x.
fn assert_honest(what: &str, estimate: f64, truth: f64) {
    assert!(truth <= estimate.max(FLOOR), "{what}: true {truth:e} above estimate {estimate:e}");
    assert!(estimate <= 30.0 * truth.max(FLOOR), "{what}: estimate {estimate:e} over 30x true {truth:e}");
}

#[test]
fn every_solver_on_the_gear_scenes() {
    // (scene, speed and damping ratio overrides): the mesh at twice the natural frequency (principal
    // parametric resonance, 7451 rpm) is stable with zeta 0.024 and inside the first tongue with 0.002
    let cases: [(&str, Option<(f64, f64)>); 7] = [
        ("gear-z14z39-wheel-eccentricity", None),
        ("paper-gear-fig8a", None),
        ("hard-gear-light-damping", None),
        ("gear-z14z39-rectangular-stiffness", None),
        ("gear-z14z39-cracked-pinion-tooth3", None),
        ("hard-gear-light-damping", Some((7451.0, 0.024))),
        ("hard-gear-light-damping", Some((7451.0, 0.002))),
    ];
    for (file, edit) in cases {
        let mut v = read_json(&repo(&format!("data/scenes/{file}.json")));
        if let Some((rpm, zeta)) = edit {
            v["gear_pair"]["speed_rpm"] = rpm.into();
            v["gear_pair"]["damping_ratio"] = zeta.into();
        }
        let name = match edit {
            Some((_, z)) => format!("{file} at 2 w0, zeta {z}"),
            None => file.to_string(),
        };
        let scene = Scene::from_value(v, &name).unwrap();
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
            for tol in [1e-6, 1e-8, 1e-10] {
                let s = solve(sys, &SolverOptions { method, tolerance: tol, ..Default::default() })
                    .unwrap_or_else(|e| panic!("{name} {method:?} {tol:e}: {e}"));
                assert!(s.trusted, "{name} {method:?} {tol:e}: {:?}", s.warnings);
                if let Some((_, zeta)) = edit {
                    assert_eq!(s.floquet.stable, zeta > 0.01, "{name}: |rho|max {}", s.floquet.rho_max);
                }
                let err = error(&states(sys, &s), &want, &d);
                let phi_err = monodromy_error(&s, &reference, &d);
                eprintln!(
                    "{name:<36} {method:?} {tol:e}: state true {err:.2e} est {:.2e}; monodromy true {phi_err:.2e} est {:.2e}",
                    s.state_error, s.multiplier_error
                );
                // within the tolerance (10x: the step counts come from asymptotic estimates)
                assert!(err <= 10.0 * tol && phi_err <= 10.0 * tol, "{name} {method:?} {tol:e}: {err:e} {phi_err:e}");
                let what = format!("{name} {method:?} {tol:e}");
                assert_honest(&format!("{what} state"), s.state_error, err);
                assert_honest(&format!("{what} monodromy"), s.multiplier_error, phi_err);
                assert_eq!(s.error_estimate, s.state_error.max(s.multiplier_error));
            }
        }
    }
}
