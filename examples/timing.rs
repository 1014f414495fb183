//! Ad-hoc solve timing used while tuning (the user-facing tool is `gearvib bench`).
use gearvib::scene::Scene;
use gearvib::solver::{Method, SolverOptions, solve};
fn main() {
    let scene = Scene::load("data/scenes/paper-gear-fig8a.json").unwrap();
    for (m, tol) in [(Method::Rk4, 1e-6), (Method::Rk4, 1e-8), (Method::Hill, 1e-8), (Method::Hill, 1e-10)] {
        let o = SolverOptions { method: m, tolerance: tol, ..Default::default() };
        let mut times = Vec::new();
        for _ in 0..21 {
            let t = std::time::Instant::now();
            let ss = solve(scene.system(), &o).unwrap();
            times.push(t.elapsed().as_secs_f64());
            std::hint::black_box(ss);
        }
        times.sort_by(f64::total_cmp);
        println!("{:?} tol {tol:e}: median {:.3} ms", m, times[10] * 1e3);
    }

    let form = gearvib::model::PeriodicSystem::fourier_form(scene.system()).unwrap();
    let t = std::time::Instant::now();
    for _ in 0..20 {
        std::hint::black_box(
            gearvib::solver::hill::solve(
                &form,
                gearvib::model::PeriodicSystem::max_harmonic(scene.system()),
                1e-10,
                1 << 20,
            )
            .unwrap(),
        );
    }
    println!("hill::solve alone at 1e-10: {:.3} ms", t.elapsed().as_secs_f64() / 20.0 * 1e3);
}

#[allow(dead_code)]
fn unused() {}
