//! Shared helpers for integration tests: running the real binary, temporary files, reference maths.
#![allow(dead_code)]
#![allow(clippy::needless_range_loop)] // matrix maths reads best with indices

pub mod check;
pub mod gearbox_gen;
pub mod mutants;

use std::path::{Path, PathBuf};
use std::process::Command;

/// Output of one run of the gearvib binary.
pub struct Run {
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
}

pub fn gearvib(args: &[&str]) -> Run {
    let out = Command::new(env!("CARGO_BIN_EXE_gearvib")).args(args).output().expect("binary runs");
    Run {
        code: out.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// A fresh directory under the target dir, removed and re-created.
pub fn temp_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

pub fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_string_lossy().into_owned()
}

pub fn repo(path: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path).to_string_lossy().into_owned()
}

pub fn read_json(path: &str) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Asserts an error run: exit code 2, exactly one stderr line, containing every needle.
pub fn assert_one_line_error(run: &Run, needles: &[&str]) {
    assert_eq!(run.code, 2, "exit code; stderr: {}", run.stderr);
    let lines: Vec<&str> = run.stderr.lines().collect();
    assert_eq!(lines.len(), 1, "want one stderr line, got: {:?}", run.stderr);
    for n in needles {
        assert!(lines[0].contains(n), "stderr {:?} lacks {:?}", lines[0], n);
    }
    assert!(!run.stderr.contains("panicked"), "panic: {}", run.stderr);
}

/// exp(A) by scaling and squaring with a 20-term Taylor series (independent of nalgebra's exp).
pub fn expm(a: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = a.len();
    let norm: f64 = a.iter().map(|r| r.iter().map(|v| v.abs()).sum::<f64>()).fold(0.0, f64::max);
    let s = (norm.max(1e-300).log2().ceil() + 1.0).max(0.0) as i32;
    let scale = 2f64.powi(-s);
    let a: Vec<Vec<f64>> = a.iter().map(|r| r.iter().map(|v| v * scale).collect()).collect();
    let mut result = identity(n);
    let mut term = identity(n);
    for k in 1..=20 {
        term = matmul(&term, &a).iter().map(|r| r.iter().map(|v| v / k as f64).collect()).collect();
        for i in 0..n {
            for j in 0..n {
                result[i][j] += term[i][j];
            }
        }
    }
    for _ in 0..s {
        result = matmul(&result, &result);
    }
    result
}

pub fn identity(n: usize) -> Vec<Vec<f64>> {
    (0..n).map(|i| (0..n).map(|j| if i == j { 1.0 } else { 0.0 }).collect()).collect()
}

pub fn matmul(a: &[Vec<f64>], b: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let (n, m, p) = (a.len(), b.len(), b[0].len());
    (0..n).map(|i| (0..p).map(|j| (0..m).map(|k| a[i][k] * b[k][j]).sum()).collect()).collect()
}

/// Classical RK4 with `steps` equal steps of a scalar second-order ODE y'' = g(t, y, y'), written here
/// independently of the library, returning the state after time `t_end` from (y0, v0).
pub fn rk4_scalar(g: &dyn Fn(f64, f64, f64) -> f64, y0: f64, v0: f64, t_end: f64, steps: usize) -> (f64, f64) {
    let h = t_end / steps as f64;
    let (mut y, mut v) = (y0, v0);
    for i in 0..steps {
        let t = i as f64 * h;
        let (k1y, k1v) = (v, g(t, y, v));
        let (k2y, k2v) = (v + 0.5 * h * k1v, g(t + 0.5 * h, y + 0.5 * h * k1y, v + 0.5 * h * k1v));
        let (k3y, k3v) = (v + 0.5 * h * k2v, g(t + 0.5 * h, y + 0.5 * h * k2y, v + 0.5 * h * k2v));
        let (k4y, k4v) = (v + h * k3v, g(t + h, y + h * k3y, v + h * k3v));
        y += h / 6.0 * (k1y + 2.0 * k2y + 2.0 * k3y + k4y);
        v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
    }
    (y, v)
}

/// Periodic state of a scalar second-order ODE by shooting with [`rk4_scalar`]: with the homogeneous
/// solutions and one particular solution over a period, solve (I - Phi) x0 = c.
pub fn periodic_scalar(
    g: &dyn Fn(f64, f64, f64) -> f64,
    gh: &dyn Fn(f64, f64, f64) -> f64,
    t_end: f64,
    steps: usize,
) -> (f64, f64) {
    let c = rk4_scalar(g, 0.0, 0.0, t_end, steps);
    let p1 = rk4_scalar(gh, 1.0, 0.0, t_end, steps);
    let p2 = rk4_scalar(gh, 0.0, 1.0, t_end, steps);
    let (a, b, cc, d) = (1.0 - p1.0, -p2.0, -p1.1, 1.0 - p2.1);
    let det = a * d - b * cc;
    ((d * c.0 - b * c.1) / det, (a * c.1 - cc * c.0) / det)
}

pub fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}

/// An LTP scene JSON from entry strings.
pub fn ltp_scene(period: f64, mass: &str, damping: &str, stiffness: &str, forcing: &str, solver: &str) -> String {
    format!(
        r#"{{"model": "ltp", "ltp": {{"period_s": {period}, "mass": {mass}, "damping": {damping}, "stiffness": {stiffness}, "forcing": {forcing}}}, "solver": {solver}}}"#
    )
}

/// The tests' one seeded random generator (a 64-bit LCG, Knuth's MMIX constants): reproducible noise and
/// random inputs without a dependency.
pub struct Rng(u64);

impl Rng {
    /// A generator from `seed`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    /// The next 64-bit state.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        self.0
    }
    /// Uniform in [-0.5, 0.5) from the state's top 31 bits.
    pub fn centered(&mut self) -> f64 {
        ((self.next_u64() >> 33) as f64 / (1u64 << 31) as f64) - 0.5
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}
