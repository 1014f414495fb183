//! Numerically hard cases, each against a reference independent of the solver under test.
#![allow(clippy::needless_range_loop)] // matrix maths reads best with indices

mod common;
use common::check;
use common::*;
use gearvib::model::catalog;
use gearvib::scene::Scene;
use gearvib::solver::{Method, SolverOptions, SteadyState, solve};
use std::f64::consts::PI;

fn with(method: Method, tol: f64) -> SolverOptions {
    SolverOptions { method, tolerance: tol, ..Default::default() }
}

/// Eigenvalues of a symmetric tridiagonal matrix (diagonal d, off-diagonal e) by Sturm-sequence bisection:
/// the k-th smallest, to 1e-15 relative. Written here, independently of the library.
fn tridiagonal_eigenvalue(d: &[f64], e: &[f64], k: usize) -> f64 {
    let count_below = |x: f64| {
        let mut count = 0;
        let mut q = d[0] - x;
        if q < 0.0 {
            count += 1;
        }
        for i in 1..d.len() {
            let qq = if q.abs() < 1e-300 { 1e-300 } else { q };
            q = d[i] - x - e[i - 1] * e[i - 1] / qq;
            if q < 0.0 {
                count += 1;
            }
        }
        count
    };
    let (mut lo, mut hi) = (-1e4, 1e4);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if count_below(mid) > k { hi = mid } else { lo = mid }
    }
    0.5 * (lo + hi)
}

/// Mathieu characteristic values from the recurrences of the Fourier coefficients (30 terms):
/// a_0: diag 0, 4, 16, ... with off-diagonals sqrt(2) q, q, q, ...; b_1: diag 1 - q, 9, 25, ...; a_1: diag
/// 1 + q, 9, 25, ... (off-diagonals q).
fn mathieu_a0(q: f64) -> f64 {
    let d: Vec<f64> = (0..30).map(|k| (2.0 * k as f64).powi(2)).collect();
    let mut e = vec![q; 29];
    e[0] = 2f64.sqrt() * q;
    tridiagonal_eigenvalue(&d, &e, 0)
}
fn mathieu_odd(q: f64, sign: f64) -> f64 {
    let mut d: Vec<f64> = (0..30).map(|k| (2.0 * k as f64 + 1.0).powi(2)).collect();
    d[0] += sign * q;
    tridiagonal_eigenvalue(&d, &vec![q; 29], 0)
}

#[test]
fn characteristic_values_agree_with_tables() {
    // Abramowitz & Stegun Table 20.1, q = 1 (data/reference/mathieu-q1.json): guards the test-side
    // reference itself; the table has 10 decimals
    let m = read_json(&repo("data/reference/mathieu-q1.json"));
    let q = m["q"].as_f64().unwrap();
    assert!((mathieu_a0(q) - m["a0"].as_f64().unwrap()).abs() < 1e-9);
    assert!((mathieu_odd(q, -1.0) - m["b1"].as_f64().unwrap()).abs() < 1e-9);
    assert!((mathieu_odd(q, 1.0) - m["a1"].as_f64().unwrap()).abs() < 1e-9);
}

fn bounded(ss: &SteadyState) -> bool {
    // undamped: det Phi = 1, so bounded <=> |rho|max = 1
    (ss.floquet.rho_max - 1.0).abs() < 1e-9
}

/// 1e-10 on both sides of a Mathieu boundary (undamped, q = 1): the bounded side is told from the unbounded
/// one, and the multipliers, a nearly double pair that moves like the square root of the monodromy's error,
/// are printed only with an estimate that bounds their true error (against a test-side RK4 monodromy of
/// 2^16 steps, tests/common/check.rs), or not trusted.
fn mathieu_near(boundary: f64, below: bool) {
    let q = 1.0;
    for (a, want) in [(boundary - 1e-10, below), (boundary + 1e-10, !below)] {
        let case = check::Case {
            name: format!("Mathieu a = {a:.12}"),
            source: check::Source::System(
                catalog::mathieu(a, q, 0.0),
                gearvib::solver::response::Probe { weights: vec![1.0, 0.0], derivative: false },
            ),
            lines: 4,
            reference_steps: 1 << 16,
        };
        let reference = check::reference(&case);
        for method in [Method::Rk4, Method::Magnus, Method::Hill] {
            check::check_periodic_solver(&case, &reference, method, 1e-10);
            let Ok(ss) = solve(case.system(), &with(method, 1e-10)) else { continue };
            // unbounded side: |rho| - 1 ~ sqrt(1e-10) = 1e-5, far above the monodromy's accuracy; bounded
            // side: a complex pair with |rho|^2 = det Phi = 1
            assert_eq!(bounded(&ss), want, "{method:?} a = {a:.12}: |rho|max - 1 = {:e}", ss.floquet.rho_max - 1.0);
            // the two multipliers nearly coincide there: the tool says how far they can be trusted
            assert!(ss.warnings.iter().any(|w| w.contains("nearly coincide")), "{:?}", ss.warnings);
        }
    }
}

#[test]
fn mathieu_1e10_from_a0() {
    mathieu_near(mathieu_a0(1.0), false);
}

#[test]
fn mathieu_1e10_from_b1() {
    mathieu_near(mathieu_odd(1.0, -1.0), true);
}

#[test]
fn mathieu_1e10_from_a1() {
    mathieu_near(mathieu_odd(1.0, 1.0), false);
}

#[test]
fn lightly_damped_gear_matches_closed_form_decay_and_other_solver() {
    let mut v = read_json(&repo("data/scenes/hard-gear-light-damping.json"));
    v["solver"] = serde_json::json!({"method": "auto", "tolerance": 1e-10});
    let scene = Scene::from_value(v, "light").unwrap();
    let sys = scene.system();
    let hill = solve(sys, &scene.solver).unwrap();
    assert_eq!(hill.method, Method::Hill);
    let rk = solve(sys, &with(Method::Rk4, 1e-9)).unwrap();
    // |rho| = exp(-c T / (2 m)) for a 1-DOF Hill equation with a complex pair (Liouville), c/m = 2 zeta w0
    let gearvib::scene::Model::GearPair(g) = &scene.model else { panic!() };
    let want = (-1e-4 * g.natural_frequency_rad_s() * sys.period_s()).exp();
    assert!(rel(hill.floquet.rho_max, want) < 1e-9, "{} vs {want}", hill.floquet.rho_max);
    // time marching would need ln(1e-8) / ln(rho) revolutions to settle
    assert!(want > 0.97, "hundreds of revolutions: {}", 18.4 / -want.ln());
    let (mut a, mut b) = (Vec::new(), Vec::new());
    let times: Vec<f64> = (0..256).map(|i| sys.period_s() * i as f64 / 256.0).collect();
    hill.states_at(sys, &times, &mut a);
    rk.states_at(sys, &times, &mut b);
    let vmax = b.iter().skip(1).step_by(2).fold(0.0f64, |m, x| m.max(x.abs()));
    for (x, y) in a.iter().zip(&b).skip(1).step_by(2) {
        // rk4 at 1e-9 is the looser of the two: 2e-9 of the velocity scale
        assert!((x - y).abs() < 2e-9 * vmax, "{x} {y}");
    }
}

#[test]
fn hunting_period_with_pinion_and_wheel_errors() {
    let scene = Scene::load(&repo("data/scenes/gear-z14z39-wheel-eccentricity.json")).unwrap();
    let sys = scene.system();
    assert!(rel(sys.period_s(), 39.0 / 30.0) < 1e-12);
    let hill = solve(sys, &with(Method::Hill, 1e-9)).unwrap();
    let gearvib::solver::Trajectory::Fourier(sol) = &hill.trajectory else { panic!() };
    assert_eq!(sol.stride, 546, "k_z couples harmonics 546 apart over the hunting period");
    let rk = solve(sys, &with(Method::Rk4, 1e-6)).unwrap();
    let times: Vec<f64> = (0..400).map(|i| sys.period_s() * i as f64 / 400.0).collect();
    let (mut a, mut b) = (Vec::new(), Vec::new());
    hill.states_at(sys, &times, &mut a);
    rk.states_at(sys, &times, &mut b);
    let vmax = b.iter().skip(1).step_by(2).fold(0.0f64, |m, x| m.max(x.abs()));
    for (x, y) in a.iter().zip(&b).skip(1).step_by(2) {
        assert!((x - y).abs() < 2e-6 * vmax, "{x} {y}");
    }
    // multipliers are asked to the tolerance against the unit circle (relative to max(|rho|max, 1)): over
    // 39 revolutions they are ~1e-74, and both methods put them there
    for (p, q) in hill.floquet.multipliers.iter().zip(&rk.floquet.multipliers) {
        assert!((p - q).norm() < 1e-6 * rk.floquet.rho_max.max(1.0), "{p} {q}");
        assert!(p.norm() < 1e-60 && q.norm() < 1e-60, "{p} {q}");
    }
}

/// Mathieu with damping and forcing inside the first instability tongue (b1(0.2) < 1 < a1(0.2)).
fn unstable_scene(q: f64, solver: &str) -> Scene {
    let json = ltp_scene(
        PI,
        r#"[[{"mean": 1.0}]]"#,
        r#"[[{"mean": 0.02}]]"#,
        &format!(r#"[[{{"mean": 1.0, "cos": [{}]}}]]"#, -2.0 * q),
        r#"[{"mean": 0.3, "sin": [0.5, 0.2]}]"#,
        solver,
    );
    Scene::from_value(serde_json::from_str(&json).unwrap(), "unstable.json").unwrap()
}

#[test]
fn unstable_system_periodic_solution_is_accurate_and_flagged() {
    for q in [0.2, 1.5] {
        let scene = unstable_scene(q, r#"{"method": "hill", "tolerance": 1e-11}"#);
        let sys = scene.system();
        let hill = solve(sys, &scene.solver).unwrap();
        assert!(!hill.floquet.stable && hill.floquet.rho_max > 1.0);
        assert!(hill.warnings.iter().any(|w| w.contains("not the attractor")), "{:?}", hill.warnings);
        let rk = solve(sys, &with(Method::Rk4, 1e-9)).unwrap();
        assert!(rk.warnings.iter().any(|w| w.contains("not the attractor")));
        // the periodic solution satisfies x(T) = x(0) although it is not the attractor: compare the two solvers
        for i in 0..2 {
            assert!((hill.x0[i] - rk.x0[i]).abs() < 1e-7 * rk.x0.amax(), "q {q}: {} {}", hill.x0[i], rk.x0[i]);
        }
    }
}

#[test]
fn multiplier_near_plus_one_gives_accurate_result_or_honest_refusal() {
    // Mathieu 1e-9 inside the a0 boundary: a multiplier within ~1e-4.5 of +1, and with damping 1e-7 a
    // multiplier within ~1e-6 of +1; forcing makes I - Phi matter
    let q = 1.0;
    let a = mathieu_a0(q) + 1e-12;
    let json = ltp_scene(
        PI,
        r#"[[{"mean": 1.0}]]"#,
        r#"[[{"mean": 1e-7}]]"#,
        &format!(r#"[[{{"mean": {a}, "cos": [{}]}}]]"#, -2.0 * q),
        r#"[{"mean": 1.0}]"#,
        r#"{"method": "rk4", "tolerance": 1e-8}"#,
    );
    let dir = temp_dir("near-one");
    let path = write(&dir, "near.json", &json);
    let run = gearvib(&["simulate", &path, "--json"]);
    let scene = Scene::from_value(serde_json::from_str(&json).unwrap(), "near").unwrap();
    let reference = solve(scene.system(), &with(Method::Hill, 1e-12));
    match run.code {
        0 => {
            // accepted: it must then agree with harmonic balance at a much tighter tolerance
            let v: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
            let r = reference.expect("a trusted answer implies a solvable reference");
            let mean = v["orders"][0]["amplitude"].as_f64().unwrap();
            let gearvib::solver::Trajectory::Fourier(sol) = &r.trajectory else { panic!() };
            let want = sol.coeffs[0][sol.harmonics].re.abs();
            assert!(rel(mean, want) < 1e-6, "{mean} vs {want}");
        }
        2 => {
            assert_one_line_error(&run, &["near.json", "cannot meet", "near +1"]);
            assert!(run.stdout.is_empty());
        }
        c => panic!("exit {c}: {}", run.stderr),
    }
}

/// Two DOF: the mesh (rectangular stiffness) and a stiff bearing at 100 times the mesh frequency.
fn stiff_scene(piecewise: bool, solver: &str) -> (Scene, f64) {
    let tz = 1.0 / 420.0;
    let (m1, m2) = (27.43, 0.5);
    let kb = m2 * (2.0 * PI * 42_000.0f64).powi(2);
    let k_pair = 5.1e8;
    let mesh = if piecewise {
        format!(
            r#"{{"steps": {{"starts_s": [0.0, {}], "values": [{}, {}]}}}}"#,
            0.6 * tz,
            2.0 * k_pair + kb,
            k_pair + kb
        )
    } else {
        format!(r#"{{"mean": {}, "cos": [{}, {}]}}"#, 1.6 * k_pair + kb, 0.3 * k_pair, 0.1 * k_pair)
    };
    let mass = format!(r#"[[{{"mean": {m1}}}, {{"mean": 0.0}}], [{{"mean": 0.0}}, {{"mean": {m2}}}]]"#);
    let damping = format!(
        r#"[[{{"mean": {}}}, {{"mean": 0.0}}], [{{"mean": 0.0}}, {{"mean": {}}}]]"#,
        2.0 * 0.024 * (1.6 * k_pair * m1).sqrt(),
        2.0 * 0.02 * (kb * m2).sqrt()
    );
    let stiffness = format!(r#"[[{mesh}, {{"mean": {}}}], [{{"mean": {}}}, {{"mean": {}}}]]"#, -kb, -kb, 2.0 * kb);
    let forcing = r#"[{"mean": 9821.5}, {"mean": 0.0}]"#;
    let json = ltp_scene(tz, &mass, &damping, &stiffness, forcing, solver);
    (Scene::from_value(serde_json::from_str(&json).unwrap(), "stiff.json").unwrap(), kb)
}

#[test]
fn stiff_two_dof_piecewise_is_exact_with_magnus_and_auto_picks_it() {
    let (scene, _) = stiff_scene(true, r#"{"method": "auto", "tolerance": 1e-10}"#);
    let sys = scene.system();
    let ss = solve(sys, &scene.solver).unwrap();
    assert_eq!(ss.method, Method::Magnus, "{}", ss.reason);
    assert!(
        ss.stability_limit_steps > ss.resolution,
        "rk4 would need {} steps for stability alone, magnus used {}",
        ss.stability_limit_steps,
        ss.resolution
    );
    // Magnus is exact on constant pieces; the reference is the rk4 product (a different scheme) converged to
    // 1e-9 with steps on the jump (the 42 kHz bearing mode makes tighter rk4 references cost ~1e6 steps)
    let reference = solve(sys, &with(Method::Rk4, 1e-9)).unwrap();
    assert!(reference.resolution > 10 * ss.resolution, "{} vs {}", reference.resolution, ss.resolution);
    let scale = reference.monodromy.amax();
    for (x, y) in ss.monodromy.iter().zip(reference.monodromy.iter()) {
        assert!((x - y).abs() < 2e-9 * scale, "{x} {y}");
    }
    // x0 in the balanced state (velocities divided by about their natural frequencies): the 42 kHz
    // bearing mass's velocity is 1e-5 of the state there, and the rk4 reference's 1e-9 holds in that norm
    let d = gearvib::solver::steady::state_scales(sys);
    let zmax = (0..4).map(|i| (reference.x0[i] / d[i]).abs()).fold(0.0, f64::max);
    for i in 0..4 {
        let dz = (ss.x0[i] - reference.x0[i]).abs() / d[i];
        assert!(
            dz < 2e-9 * zmax,
            "x0[{i}]: {} vs {} ({} and {} steps)",
            ss.x0[i],
            reference.x0[i],
            ss.resolution,
            reference.resolution
        );
    }
}

#[test]
fn stiff_two_dof_smooth_hill_and_magnus_agree() {
    let (scene, _) = stiff_scene(false, r#"{"method": "auto", "tolerance": 1e-8}"#);
    let sys = scene.system();
    let hill = solve(sys, &scene.solver).unwrap();
    assert_eq!(hill.method, Method::Hill);
    let magnus = solve(sys, &with(Method::Magnus, 1e-7)).unwrap();
    // A-stability: at a quarter of rk4's stability limit, magnus stays bounded and close while rk4 is
    // refused or flagged
    let few = SolverOptions {
        method: Method::Magnus,
        tolerance: 0.5,
        steps: Some(magnus.stability_limit_steps / 4),
        ..Default::default()
    };
    let coarse = solve(sys, &few).unwrap();
    assert!((coarse.x0[0] - hill.x0[0]).abs() < 1e-3 * hill.x0[0].abs(), "{} {}", coarse.x0[0], hill.x0[0]);
    let rk_few = solve(sys, &SolverOptions { method: Method::Rk4, ..few });
    assert!(rk_few.map_or(true, |r| !r.trusted || r.warnings.iter().any(|w| w.contains("stability limit"))));
    // tolerances 1e-8 and 1e-7: agreement to 2e-7 of the largest state component
    for i in 0..4 {
        assert!((hill.x0[i] - magnus.x0[i]).abs() < 2e-7 * hill.x0.amax().max(1e-30), "x0[{i}]");
    }
    for (p, q) in hill.floquet.multipliers.iter().zip(&magnus.floquet.multipliers) {
        assert!((p - q).norm() < 2e-7 * hill.floquet.rho_max.max(1e-30), "{p} {q}");
    }
}

#[test]
fn a_multiplier_within_1e12_of_plus_one_is_refused_by_time_stepping_and_exact_by_harmonic_balance() {
    // x'' + c x' + w^2 x = cos(w t) with w T = 2 pi: both multipliers are exp(-c T / 2) e^(+-i w T), within
    // c T / 2 = 1e-13 of +1. Time stepping solves (I - Phi) x0 = c with cond ~ 1e13: rounding alone costs
    // ~1e-3 relative, so rk4 and magnus4 must refuse and say why. Harmonic balance solves the diagonal
    // system (w^2 - w^2 + i w c) Y_1 = 1/2 exactly to rounding: its answer is the closed form
    // x = sin(w t) / (w c) and it must print it.
    let period = 1.0;
    let w = 2.0 * PI / period;
    let c = 2e-13 / period;
    let solver = |m: &str| format!(r#"{{"method": "{m}", "tolerance": 1e-8}}"#);
    let scene = |m: &str| {
        ltp_scene(
            period,
            r#"[[{"mean": 1.0}]]"#,
            &format!(r#"[[{{"mean": {c}}}]]"#),
            &format!(r#"[[{{"mean": {}}}]]"#, w * w),
            r#"[{"mean": 0.0, "cos": [1.0]}]"#,
            &solver(m),
        )
    };
    let dir = temp_dir("within-1e12");
    for m in ["rk4", "magnus4"] {
        let path = write(&dir, &format!("{m}.json"), &scene(m));
        let run = gearvib(&["simulate", &path, "--json"]);
        assert_eq!(run.code, 2, "{m}: {}", run.stdout);
        assert_one_line_error(&run, &[&format!("{m}.json"), "ill-conditioned", "near +1"]);
    }
    let s = Scene::from_value(serde_json::from_str(&scene("hill")).unwrap(), "hill").unwrap();
    let r = solve(s.system(), &with(Method::Hill, 1e-8)).unwrap();
    assert!(r.trusted, "{:?}", r.warnings);
    let want = 1.0 / (w * c); // amplitude of sin(w t)
    let mut x = Vec::new();
    r.states_at(s.system(), &[period / 4.0], &mut x);
    // 1e-8: the tolerance asked (the closed form is exact)
    assert!(rel(x[0], want) < 1e-8, "{} vs {want}", x[0]);
}
