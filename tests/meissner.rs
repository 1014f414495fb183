//! Discontinuous coefficients keep full accuracy: the Meissner equation y'' + k(t) y = F with piecewise-
//! constant k against its exact solution by matrix exponentials (computed in the test).
#![allow(clippy::needless_range_loop)] // matrix maths reads best with indices

mod common;
use common::*;
use gearvib::scene::Scene;
use gearvib::solver::{Method, SolverOptions, solve};

const T: f64 = 2.0;
const DUTY: f64 = 0.37; // jump at 0.74 s: not on a uniform grid of any small step count
const K_HI: f64 = 9.0;
const K_LO: f64 = 2.5;
const F: f64 = 1.5;
const C: f64 = 0.1;

/// Exact monodromy and periodic state: on a piece with stiffness k, x - x* evolves by exp(A t),
/// x* = (F/k, 0).
fn exact() -> (Vec<Vec<f64>>, [f64; 2]) {
    let piece = |k: f64, dt: f64| expm(&[vec![0.0, dt], vec![-k * dt, -C * dt]]);
    let (e1, e2) = (piece(K_HI, DUTY * T), piece(K_LO, (1.0 - DUTY) * T));
    let phi = matmul(&e2, &e1);
    // x(T) = x2* + E2 (x1* + E1 (x0 - x1*) - x2*)  =>  x(T) = Phi x0 + c
    let (s1, s2) = ([F / K_HI, 0.0], [F / K_LO, 0.0]);
    let mut inner = [0.0; 2];
    for i in 0..2 {
        inner[i] = s1[i] - (e1[i][0] * s1[0] + e1[i][1] * s1[1]) - s2[i];
    }
    let mut c = [0.0; 2];
    for i in 0..2 {
        c[i] = s2[i] + e2[i][0] * inner[0] + e2[i][1] * inner[1];
    }
    let (a, b, cc, d) = (1.0 - phi[0][0], -phi[0][1], -phi[1][0], 1.0 - phi[1][1]);
    let det = a * d - b * cc;
    (phi, [(d * c[0] - b * c[1]) / det, (a * c[1] - cc * c[0]) / det])
}

fn scene(solver: &str) -> Scene {
    let json = ltp_scene(
        T,
        r#"[[{"mean": 1.0}]]"#,
        &format!(r#"[[{{"mean": {C}}}]]"#),
        &format!(r#"[[{{"steps": {{"starts_s": [0.0, {}], "values": [{K_HI}, {K_LO}]}}}}]]"#, DUTY * T),
        &format!(r#"[{{"mean": {F}}}]"#),
        solver,
    );
    Scene::from_value(serde_json::from_str(&json).unwrap(), "meissner.json").unwrap()
}

#[test]
fn meissner_matches_exact_monodromy_multipliers_and_state() {
    let (phi, x0) = exact();
    let s = scene(r#"{"method": "rk4", "tolerance": 1e-10}"#);
    assert_eq!(s.system().breakpoints(), vec![DUTY * T]);
    let ss = solve(s.system(), &s.solver).unwrap();
    for i in 0..2 {
        for j in 0..2 {
            // requested 1e-10 relative; 10x margin for the asymptotic estimate
            assert!((ss.monodromy[(i, j)] - phi[i][j]).abs() < 1e-9, "Phi[{i}][{j}]");
        }
        assert!(rel(ss.x0[i], x0[i]) < 1e-9, "x0[{i}] {} vs {}", ss.x0[i], x0[i]);
    }
    // multipliers: eigenvalues of the exact 2x2 monodromy
    let (tr, det) = (phi[0][0] + phi[1][1], phi[0][0] * phi[1][1] - phi[0][1] * phi[1][0]);
    let disc = tr * tr / 4.0 - det;
    let want = if disc < 0.0 { det.sqrt() } else { tr.abs() / 2.0 + disc.sqrt() };
    assert!(rel(ss.floquet.rho_max, want) < 1e-9);
}

#[test]
fn meissner_keeps_fourth_order_with_steps_on_the_jump() {
    let (_, x0) = exact();
    let s = scene("{}");
    let err = |m| {
        let o = SolverOptions { method: Method::Rk4, tolerance: 0.5, steps: Some(m), ..Default::default() };
        let ss = solve(s.system(), &o).unwrap();
        (ss.x0[0] - x0[0]).abs() + (ss.x0[1] - x0[1]).abs()
    };
    let (e1, e2, e3) = (err(100), err(200), err(400));
    // a step straddling the jump would drop RK4 to first order (ratio 2); aligned steps keep ratio 16
    for r in [e1 / e2, e2 / e3] {
        assert!((13.0..19.0).contains(&r), "{} {}", e1 / e2, e2 / e3);
    }
}

#[test]
fn gear_periods_are_the_shortest_the_content_needs() {
    let base = read_json(&repo("data/scenes/paper-gear-fig8a.json"));
    let period = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut v = base.clone();
        edit(&mut v);
        Scene::from_value(v, "g").unwrap().system().period_s()
    };
    let t1 = 1.0 / 30.0;
    let none = period(&|v| v["gear_pair"]["pinion"]["errors"] = serde_json::json!([]));
    assert!(rel(none, t1 / 14.0) < 1e-12, "healthy smooth mesh: one mesh cycle");
    assert!(rel(period(&|_| {}), t1) < 1e-12, "pinion errors: one pinion revolution");
    let wheel_only = period(&|v| {
        v["gear_pair"]["pinion"]["errors"] = serde_json::json!([]);
        v["gear_pair"]["wheel"]["errors"] = serde_json::json!([{"order": 1, "amplitude_m": 1e-6}]);
    });
    assert!(rel(wheel_only, t1 * 39.0 / 14.0) < 1e-12, "wheel errors only: one wheel revolution");
    let both = period(&|v| v["gear_pair"]["wheel"]["errors"] = serde_json::json!([{"order": 1, "amplitude_m": 1e-6}]));
    // hunting period: z_w / gcd(14, 39) = 39 pinion revolutions = 546 mesh cycles
    assert!(rel(both, 39.0 * t1) < 1e-12);
    let crack = period(&|v| {
        v["gear_pair"]["pinion"]["errors"] = serde_json::json!([]);
        v["gear_pair"]["crack"] = serde_json::json!({"gear": "pinion", "tooth": 2, "stiffness_loss": 0.2});
    });
    assert!(rel(crack, t1) < 1e-12, "cracked pinion tooth: one pinion revolution");
}
