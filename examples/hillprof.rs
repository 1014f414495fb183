//! Profiling aid: repeated harmonic-balance solves of the Fig 8a scene.
use gearvib::scene::Scene;
use gearvib::solver::{Method, SolverOptions, solve};
fn main() {
    let scene = Scene::load("data/scenes/paper-gear-fig8a.json").unwrap();
    let o = SolverOptions { method: Method::Hill, tolerance: 1e-10, ..Default::default() };
    let ss = solve(scene.system(), &o).unwrap();
    println!("{}", ss.reason);
    for _ in 0..300 {
        std::hint::black_box(solve(scene.system(), &o).unwrap());
    }
}
