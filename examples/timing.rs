use gearvib::scene::Scene;
fn main() {
    let scene = Scene::load("data/scenes/paper-gear-fig8a.json").unwrap();
    let mut times = Vec::new();
    for _ in 0..21 {
        let t = std::time::Instant::now();
        let ss = gearvib::solver::solve(scene.system(), &scene.solver).unwrap();
        times.push(t.elapsed().as_secs_f64());
        std::hint::black_box(ss);
    }
    times.sort_by(f64::total_cmp);
    println!("median solve {:.3} ms", times[10] * 1e3);
}
