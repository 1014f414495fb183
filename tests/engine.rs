//! Simulation engine against references independent of the code under test: closed forms, matrix
//! exponentials, tabulated Mathieu characteristic values, the paper's Table 2, physics invariants of the
//! gear model, and an independent tiny-step integrator.
#![allow(clippy::needless_range_loop)] // matrix maths reads best with indices

mod common;
use common::*;
use gearvib::model::catalog;
use gearvib::scene::{Model, Scene};
use gearvib::solver::{Method, SolverOptions, solve};
use std::f64::consts::PI;

fn opts(tol: f64) -> SolverOptions {
    SolverOptions { method: Method::Rk4, tolerance: tol, ..Default::default() }
}

fn fixed(steps: usize) -> SolverOptions {
    SolverOptions { method: Method::Rk4, tolerance: 0.5, steps: Some(steps), ..Default::default() }
}

#[test]
fn constant_coefficients_give_exp_at() {
    // 2 DOF, constant M, C, K: Phi = exp(A T) with A = [0 I; -M^-1 K  -M^-1 C]
    let (m, c, k) = ([[2.0, 0.5], [0.5, 1.0]], [[0.3, -0.1], [-0.1, 0.2]], [[5.0, -2.0], [-2.0, 3.0]]);
    let period = 1.7;
    let ent = |a: [[f64; 2]; 2]| {
        format!(
            "[[{{\"mean\": {}}}, {{\"mean\": {}}}], [{{\"mean\": {}}}, {{\"mean\": {}}}]]",
            a[0][0], a[0][1], a[1][0], a[1][1]
        )
    };
    let json = ltp_scene(
        period,
        &ent(m),
        &ent(c),
        &ent(k),
        r#"[{"mean": 0.0}, {"mean": 0.0}]"#,
        r#"{"method": "rk4", "tolerance": 1e-11}"#,
    );
    let scene = Scene::from_value(serde_json::from_str(&json).unwrap(), "const.json").unwrap();
    let ss = solve(scene.system(), &scene.solver).unwrap();
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let minv = [[m[1][1] / det, -m[0][1] / det], [-m[1][0] / det, m[0][0] / det]];
    let mut a = vec![vec![0.0; 4]; 4];
    a[0][2] = 1.0;
    a[1][3] = 1.0;
    for i in 0..2 {
        for j in 0..2 {
            a[2 + i][j] = -(minv[i][0] * k[0][j] + minv[i][1] * k[1][j]) * period;
            a[2 + i][2 + j] = -(minv[i][0] * c[0][j] + minv[i][1] * c[1][j]) * period;
        }
    }
    a[0][2] *= period;
    a[1][3] *= period;
    let want = expm(&a);
    let scale = want.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
    for i in 0..4 {
        for j in 0..4 {
            // requested 1e-11; entries compared relative to the largest entry, 10x margin for the asymptotic estimate
            assert!(
                (ss.monodromy[(i, j)] - want[i][j]).abs() < 1e-10 * scale,
                "Phi[{i}][{j}] {} vs {}",
                ss.monodromy[(i, j)],
                want[i][j]
            );
        }
    }
}

#[test]
fn undamped_oscillator_multipliers_on_unit_circle() {
    // y'' + 4 y = 0 over T = 1: Phi is a rotation, rho = exp(+-2i)
    let sys = catalog::meissner(1.0, 0.5, 4.0, 4.0, 0.0);
    let ss = solve(&sys, &opts(1e-10)).unwrap();
    for r in &ss.floquet.multipliers {
        assert!((r.norm() - 1.0).abs() < 1e-9, "{r}");
        assert!((r.arg().abs() - 2.0).abs() < 1e-9, "{r}");
    }
    assert!(!ss.floquet.stable, "multipliers on the unit circle are not asymptotically stable");
}

#[test]
fn forced_damped_oscillator_matches_closed_form() {
    let (m, c, k, f0, w) = (1.0, 0.2, 4.0, 1.0, 1.5);
    let sys = catalog::forced_oscillator(m, c, k, f0, w);
    let (amp, lag) = catalog::forced_oscillator_response(m, c, k, f0, w);
    for tol in [1e-6, 1e-9] {
        let ss = solve(&sys, &opts(tol)).unwrap();
        // y = amp cos(w t - lag): y(0) = amp cos(lag), y'(0) = amp w sin(lag); errors relative to amp, amp w.
        // The tolerance bounds an asymptotic (Richardson) estimate: allow a factor 2.
        assert!((ss.x0[0] - amp * lag.cos()).abs() < 2.0 * tol * amp, "tol {tol}: {}", ss.x0[0]);
        assert!((ss.x0[1] - amp * w * lag.sin()).abs() < 2.0 * tol * amp * w, "tol {tol}: {}", ss.x0[1]);
        // |rho| = exp(-c T / 2m) for both multipliers (complex pair)
        let want = (-c * (2.0 * PI / w) / (2.0 * m)).exp();
        assert!(rel(ss.floquet.rho_max, want) < 2.0 * tol);
    }
}

#[test]
fn rk4_product_converges_at_fourth_order() {
    let (m, c, k, f0, w) = (1.0, 0.2, 4.0, 1.0, 1.5);
    let sys = catalog::forced_oscillator(m, c, k, f0, w);
    let (amp, lag) = catalog::forced_oscillator_response(m, c, k, f0, w);
    let err = |steps| {
        let ss = solve(&sys, &fixed(steps)).unwrap();
        (ss.x0[0] - amp * lag.cos()).abs() + (ss.x0[1] - amp * w * lag.sin()).abs()
    };
    let (e1, e2, e3) = (err(40), err(80), err(160));
    // fourth order: halving h divides the error by 2^4 = 16 (asymptotically; 13..19 allows the next term)
    for r in [e1 / e2, e2 / e3] {
        assert!((13.0..19.0).contains(&r), "ratios {} {}", e1 / e2, e2 / e3);
    }
}

/// Mathieu y'' + (a - 2q cos 2t) y = 0 at q = 1 through the LTP scene form. Characteristic values from
/// `data/reference/mathieu-q1.json` (Abramowitz & Stegun Table 20.1). Stable: (a0, b1), (a1, b2), (a2, b3);
/// unstable elsewhere.
#[test]
fn mathieu_stability_both_sides_of_tabulated_boundaries() {
    let m = read_json(&repo("data/reference/mathieu-q1.json"));
    let v = |k: &str| m[k].as_f64().unwrap();
    let bounds = [(v("a0"), false), (v("b1"), true), (v("a1"), false), (v("b2"), true), (v("a2"), false)];
    // (boundary, whether the interval just below it is stable)
    let dir = temp_dir("mathieu");
    for (b, below_stable) in bounds {
        for (a, want_stable) in [(b - 1e-3, below_stable), (b + 1e-3, !below_stable)] {
            let json = ltp_scene(
                PI,
                r#"[[{"mean": 1.0}]]"#,
                r#"[[{"mean": 0.0}]]"#,
                &format!(r#"[[{{"mean": {a}, "cos": [-2.0]}}]]"#),
                r#"[{"mean": 0.0}]"#,
                r#"{"method": "rk4", "tolerance": 1e-10}"#,
            );
            let path = write(&dir, "m.json", &json);
            let run = gearvib(&["stability", &path, "--json"]);
            assert_eq!(run.code, 0, "{}", run.stderr);
            let v: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
            let rho = v["rho_max"].as_f64().unwrap();
            // undamped: det Phi = 1, so bounded <=> |rho|max = 1 (to the tolerance); unbounded <=> > 1.
            // 1e-3 from a boundary the growing multiplier exceeds 1 by about sqrt(1e-3) ~ 0.03.
            let bounded = (rho - 1.0).abs() < 1e-8;
            assert_eq!(bounded, want_stable, "a = {a}: |rho|max = {rho}");
            if !want_stable {
                assert!(rho > 1.001, "a = {a}: {rho}");
            }
        }
    }
}

#[test]
fn damped_mathieu_multipliers_scale_by_exp_minus_ct_over_2() {
    // y = exp(-c t/2) z turns y'' + c y' + (a - 2q cos 2t) y = 0 into z'' + (a - c^2/4 - 2q cos 2t) z = 0:
    // the multipliers are exp(-c pi / 2) times those of the undamped equation at a - c^2/4.
    let (a, q, c) = (2.5, 1.3, 0.3);
    let damped = solve(&catalog::mathieu(a, q, c), &opts(1e-11)).unwrap();
    let undamped = solve(&catalog::mathieu(a - c * c / 4.0, q, 0.0), &opts(1e-11)).unwrap();
    let f = (-c * PI / 2.0).exp();
    for (r, s) in damped.floquet.multipliers.iter().zip(&undamped.floquet.multipliers) {
        assert!((r - s * f).norm() < 1e-9, "{r} vs {}", s * f);
    }
    // trace too, not only the modulus (which |rho| = exp(-cT/2) fixes whatever k(t) is)
    let tr = damped.monodromy.trace();
    let tr_u = undamped.monodromy.trace() * f;
    assert!((tr - tr_u).abs() < 1e-9, "{tr} {tr_u}");
}

fn press_lines(case: &str, quantity: &str) -> (f64, Vec<(f64, f64)>) {
    let mut v = read_json(&repo(&format!("data/scenes/paper-press-{case}.json")));
    v["output"]["quantity"] = quantity.into();
    let scene = Scene::from_value(v, case).unwrap();
    let sim = gearvib::jobs::simulate::simulate(&scene).unwrap();
    (sim.steady.floquet.rho_max, sim.orders.iter().map(|o| (o.order, o.amplitude)).collect())
}

#[test]
fn press_reproduces_table_2_and_symmetry() {
    // Table 2 of the paper (data/reference/paper-table2.json), with F = 0
    let t2 = read_json(&repo("data/reference/paper-table2.json"));
    for case in ["case1", "case2"] {
        let want = t2[format!("rho_max_{case}")].as_f64().unwrap();
        let (rho, q1) = press_lines(case, "q1");
        assert!(rel(rho, want) < 0.005, "{case}: {rho} vs {want}");
        let (_, q2) = press_lines(case, "q2");
        // F = 0: t -> t + T/2 symmetry leaves only even orders in q1 and odd orders in q2 (Figs 3b, 4b)
        let peak1 = q1.iter().skip(1).map(|l| l.1).fold(0.0, f64::max);
        let peak2 = q2.iter().skip(1).map(|l| l.1).fold(0.0, f64::max);
        for (o, a) in &q1 {
            if (*o as usize) % 2 == 1 {
                assert!(*a < 1e-9 * peak1, "{case} q1 order {o}: {a}");
            }
        }
        for (o, a) in &q2 {
            if *o > 0.0 && (*o as usize).is_multiple_of(2) {
                assert!(*a < 1e-9 * peak2, "{case} q2 order {o}: {a}");
            }
        }
    }
}

fn gear_scene(edit: impl Fn(&mut serde_json::Value)) -> Scene {
    let mut v = read_json(&repo("data/scenes/paper-gear-fig8a.json"));
    v["solver"]["tolerance"] = 1e-10.into();
    edit(&mut v);
    Scene::from_value(v, "gear").unwrap()
}

fn lines(scene: &Scene) -> Vec<f64> {
    gearvib::jobs::simulate::simulate(scene).unwrap().orders.iter().map(|o| o.amplitude).collect()
}

#[test]
fn gear_natural_frequency_matches_paper() {
    let scene = gear_scene(|_| {});
    let Model::GearPair(g) = &scene.model else { panic!() };
    // the paper: w0 = sqrt(k0 / m_red) ~ 5462 1/s, 869 Hz
    assert!((g.natural_frequency_rad_s() - 5462.0).abs() < 1.0, "{}", g.natural_frequency_rad_s());
    assert!((g.mesh_hz() - 420.0).abs() < 1e-12);
}

#[test]
fn gear_mesh_lines_do_not_depend_on_errors_and_sidebands_follow_e_j() {
    let base = lines(&gear_scene(|_| {}));
    let fig8b = lines(&gear_scene(|v| {
        *v = {
            let mut b = read_json(&repo("data/scenes/paper-gear-fig8b.json"));
            b["solver"]["tolerance"] = 1e-10.into();
            b
        }
    }));
    let peak = base.iter().skip(1).fold(0.0f64, |a, b| a.max(*b));
    for k in 1..=10 {
        // mesh orders 14 k: forcing at 14k comes only from k0 q0 through k_z, never from e(t) (orders 1..6)
        assert!(rel(fig8b[14 * k], base[14 * k]) < 1e-6 || base[14 * k] < 1e-9 * peak, "order {}", 14 * k);
    }
    for (o, a) in base.iter().enumerate() {
        if o % 14 == 7 {
            assert!(*a < 1e-9 * peak, "order {o} ≡ 7 mod 14: {a}");
        }
    }
    // doubling e_3 doubles the lines at 14k +- 3 and leaves 14k +- 2 alone
    let doubled = lines(&gear_scene(|v| {
        let a = v["gear_pair"]["pinion"]["errors"][2]["amplitude_m"].as_f64().unwrap();
        v["gear_pair"]["pinion"]["errors"][2]["amplitude_m"] = (2.0 * a).into();
    }));
    for k in 1..=4 {
        for o in [14 * k - 3, 14 * k + 3] {
            assert!((doubled[o] / base[o] - 2.0).abs() < 1e-6, "order {o}: {}", doubled[o] / base[o]);
        }
        for o in [14 * k - 2, 14 * k + 2] {
            assert!(rel(doubled[o], base[o]) < 1e-6, "order {o}");
        }
    }
    // the phases of e_j do not change any line amplitude
    let shifted = lines(&gear_scene(|v| {
        for (j, e) in v["gear_pair"]["pinion"]["errors"].as_array_mut().unwrap().iter_mut().enumerate() {
            e["phase_rad"] = (0.7 * j as f64 + 0.3).into();
        }
    }));
    for (o, (a, b)) in base.iter().zip(&shifted).enumerate() {
        if *a > 1e-6 * peak {
            assert!(rel(*b, *a) < 1e-6, "order {o}: {a} vs {b}");
        }
    }
}

/// Eq 42 written again here, independently of the model code, and integrated by shooting with a test-side
/// RK4 at 200 000 steps per period (error ~1e-14) as the reference periodic state.
fn gear_reference(scene_path: &str) -> (f64, f64, f64) {
    let v = read_json(&repo(scene_path));
    let g = &v["gear_pair"];
    let f = |p: &serde_json::Value| p.as_f64().unwrap();
    let (j1, j2) = (f(&g["pinion"]["inertia_kg_m2"]), f(&g["wheel"]["inertia_kg_m2"]));
    let (r1, r2) = (f(&g["pinion"]["base_radius_m"]), f(&g["wheel"]["base_radius_m"]));
    let m = j1 * j2 / (j1 * r2 * r2 + j2 * r1 * r1);
    let k0 = f(&g["mesh_stiffness"]["fourier"]["mean_n_per_m"]);
    let c = 2.0 * f(&g["damping_ratio"]) * (k0 * m).sqrt();
    let q0 = f(&g["static_deflection_m"]);
    let w1 = f(&g["speed_rpm"]) / 60.0 * 2.0 * PI;
    let wz = 14.0 * w1;
    let kn: Vec<(f64, f64)> = g["mesh_stiffness"]["fourier"]["harmonics"]
        .as_array()
        .unwrap()
        .iter()
        .map(|h| (f(&h["amplitude_n_per_m"]), f(&h["phase_rad"])))
        .collect();
    let en: Vec<(f64, f64, f64)> = g["pinion"]["errors"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| (f(&e["order"]), f(&e["amplitude_m"]), f(&e["phase_rad"])))
        .collect();
    let kz = move |t: f64| {
        k0 + kn.iter().enumerate().map(|(n, (a, p))| a * ((n + 1) as f64 * wz * t + p).cos()).sum::<f64>()
    };
    let en2 = en.clone();
    let e = move |t: f64| en.iter().map(|(i, a, p)| a * (i * w1 * t + p).cos()).sum::<f64>();
    let ed = move |t: f64| en2.iter().map(|(i, a, p)| -a * i * w1 * (i * w1 * t + p).sin()).sum::<f64>();
    let kz2 = kz.clone();
    let full = move |t: f64, y: f64, v: f64| (k0 * q0 - (kz(t) - k0) * e(t) - c * ed(t) - c * v - kz(t) * y) / m;
    let homog = move |t: f64, y: f64, v: f64| (-c * v - kz2(t) * y) / m;
    let period = 2.0 * PI / w1;
    let (y0, v0) = periodic_scalar(&full, &homog, period, 200_000);
    // scale of q': its largest value over the period
    let mut vmax: f64 = 0.0;
    let (mut y, mut vv) = (y0, v0);
    let n = 2000;
    for _ in 0..n {
        (y, vv) = rk4_scalar(&|t, a, b| full(t, a, b), y, vv, period / n as f64, 100);
        vmax = vmax.max(vv.abs());
    }
    (y0, v0, vmax)
}

#[test]
fn gear_meets_requested_tolerance_against_independent_integration() {
    let (y0, v0, vmax) = gear_reference("data/scenes/paper-gear-fig8a.json");
    for tol in [1e-6, 1e-9] {
        let scene = gear_scene(|v| v["solver"]["tolerance"] = tol.into());
        let ss = solve(scene.system(), &scene.solver).unwrap();
        assert!(ss.error_estimate <= tol);
        // per-component relative error (component scale: its largest value); factor 2 for the estimate
        assert!((ss.x0[1] - v0).abs() < 2.0 * tol * vmax, "tol {tol}: v0 {} vs {v0}", ss.x0[1]);
        assert!((ss.x0[0] - y0).abs() < 2.0 * tol * y0.abs().max(1e-12), "tol {tol}: y0 {} vs {y0}", ss.x0[0]);
    }
    // and fourth order on the gear itself, with fixed step counts
    let scene = gear_scene(|_| {});
    let err = |steps| (solve(scene.system(), &fixed(steps)).unwrap().x0[1] - v0).abs();
    let (e1, e2) = (err(4000), err(8000));
    assert!((13.0..19.0).contains(&(e1 / e2)), "ratio {}", e1 / e2);
}

#[test]
fn gear_period_is_one_mesh_cycle_without_errors() {
    let scene = gear_scene(|v| v["gear_pair"]["pinion"]["errors"] = serde_json::json!([]));
    assert!(rel(scene.system().period_s(), 1.0 / 420.0) < 1e-12);
    let sim = gearvib::jobs::simulate::simulate(&scene).unwrap();
    // only multiples of the mesh order appear in the listing
    for o in &sim.orders {
        assert!((o.order / 14.0 - (o.order / 14.0).round()).abs() < 1e-9);
    }
    let fig8a = lines(&gear_scene(|_| {}));
    // the mesh lines of the healthy pair equal those of Fig 8a (which adds only sidebands)
    for o in &sim.orders[1..=5] {
        assert!(rel(o.amplitude, fig8a[o.order.round() as usize]) < 1e-6);
    }
}

#[test]
fn explicit_steps_below_stability_limit_warn() {
    let scene = gear_scene(|_| {});
    let ss = solve(scene.system(), &fixed(40)).unwrap_or_else(|e| panic!("{e}"));
    assert!(ss.stability_limit_steps > 40);
    assert!(ss.warnings.iter().any(|w| w.contains("stability limit")));
    assert!(!ss.trusted);
}

#[test]
fn every_bundled_scene_meets_three_tolerances_without_refusal() {
    // once refused: light damping at its own 1e-8, fig8a at 1e-12 (cond of an unscaled I - Phi ~ w0^2)
    let mut paths: Vec<_> = std::fs::read_dir(repo("data/scenes")).unwrap().map(|e| e.unwrap().path()).collect();
    // gear_train scenes have no single periodic system: tests/gear_train_cli.rs runs them
    paths.retain(|p| !gearvib::scene::train::is_gear_train(p.to_str().unwrap()));
    paths.sort();
    assert!(paths.len() >= 10);
    // gear-train scenes have their own solver path and checks (tests/gear_train.rs)
    paths.retain(|p| read_json(p.to_str().unwrap())["model"] != "gear_train");
    for p in &paths {
        for tol in [1e-6, 1e-8, 1e-10] {
            let mut v = read_json(p.to_str().unwrap());
            v["solver"]["tolerance"] = tol.into();
            let scene = Scene::from_value(v, p.to_str().unwrap()).unwrap();
            let sim = gearvib::jobs::simulate::simulate(&scene).unwrap();
            let s = &sim.steady;
            assert!(s.trusted, "{p:?} at {tol:e}: {:?}", s.warnings);
            assert!(s.error_estimate <= tol, "{p:?} at {tol:e}: estimate {:e}", s.error_estimate);
            assert!(!s.warnings.iter().any(|w| w.contains("near +1")), "{p:?}: {:?}", s.warnings);
        }
    }
}
