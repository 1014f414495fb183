//! Probe: solver costs on the smooth stiff two-DOF model.
use gearvib::scene::Scene;
use gearvib::solver::{Method, SolverOptions, solve};
fn main() {
    let text = std::fs::read_to_string("/tmp/stiff.json").unwrap();
    let scene = Scene::from_value(serde_json::from_str(&text).unwrap(), "stiff").unwrap();
    for (m, tol, steps) in [(Method::Magnus, 0.5, Some(57usize)), (Method::Rk4, 0.5, Some(57))] {
        let t = std::time::Instant::now();
        eprintln!("start {m:?}");
        match solve(scene.system(), &SolverOptions { method: m, tolerance: tol, steps, ..Default::default() }) {
            Ok(ss) => println!(
                "{m:?} {tol:e}: {} res, est {:e}, {:.3} s, {}",
                ss.resolution,
                ss.error_estimate,
                t.elapsed().as_secs_f64(),
                ss.reason
            ),
            Err(e) => println!("{m:?} {tol:e}: {e} ({:.3} s)", t.elapsed().as_secs_f64()),
        }
    }
}
