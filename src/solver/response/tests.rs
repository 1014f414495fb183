//! Tests of the printed response against exact integrals and a fine reference.

use super::*;

/// Whether t lies on the first half [0, 1/2) of the unit period, taking the `side` limit at a jump.
fn first_half(t: f64, side: Side) -> bool {
    let tau = t.rem_euclid(1.0);
    if side == Side::Right { tau < 0.5 } else { tau > 0.0 && tau <= 0.5 }
}

/// A test system of period 1 whose coefficients jump at 1/2: `dim` states, P and f written by
/// `coefficients(t, on the first half)`.
struct HalfJump {
    dim: usize,
    max_harmonic: usize,
    piecewise_constant: bool,
    coefficients: fn(f64, bool, &mut DMatrix<f64>, &mut DVector<f64>),
}

impl PeriodicSystem for HalfJump {
    fn dim(&self) -> usize {
        self.dim
    }
    fn period_s(&self) -> f64 {
        1.0
    }
    fn eval(&self, t: f64, side: Side, p: &mut DMatrix<f64>, f: &mut DVector<f64>) {
        (self.coefficients)(t, first_half(t, side), p, f);
    }
    fn breakpoints(&self) -> Vec<f64> {
        vec![0.5]
    }
    fn piecewise_constant(&self) -> bool {
        self.piecewise_constant
    }
    fn max_harmonic(&self) -> usize {
        self.max_harmonic
    }
}

/// x' = -x + f with f = 1 on [0, T/2), 0 after: piecewise constant, one state.
const SQUARE: HalfJump = HalfJump {
    dim: 1,
    max_harmonic: 0,
    piecewise_constant: true,
    coefficients: |_, first, p, f| {
        p[(0, 0)] = -1.0;
        f[0] = if first { 1.0 } else { 0.0 };
    },
};

/// x'' + 0.3 x' + k(t) x = cos(2 pi t) + 0.2 with k = 50 on [0, 1/2), 40 after: several oscillations per
/// period, so the probe has interior extremes on many steps.
const OSCILLATOR: HalfJump = HalfJump {
    dim: 2,
    max_harmonic: 1,
    piecewise_constant: false,
    coefficients: |t, first, p, f| {
        p[(0, 0)] = 0.0;
        p[(0, 1)] = 1.0;
        p[(1, 0)] = if first { -50.0 } else { -40.0 };
        p[(1, 1)] = -0.3;
        f[0] = 0.0;
        f[1] = (2.0 * std::f64::consts::PI * t).cos() + 0.2;
    },
};

/// The exact periodic solution: x = 1 - A e^-t on the first half, B e^-(t - 1/2) on the second, with
/// B = 1 - A e^-1/2 and A = 1 - B e^-1/2 (continuity at both ends).
fn exact(t: f64) -> f64 {
    let e = (-0.5f64).exp();
    let a = (1.0 - e) / (1.0 - e * e);
    let b = 1.0 - a * e;
    if t < 0.5 { 1.0 - a * (-t).exp() } else { b * (-(t - 0.5)).exp() }
}

/// The closed forms on the cubic Hermite dense output (moments per run, z^2 per step, roots of z') against
/// fine 4-point Gauss quadrature and the golden-section extreme search on the same dense output, on a
/// grid of two runs of different step (41 steps, a jump at 0.5) with a probe mixing the state and a constant.
#[test]
fn hermite_closed_forms_match_quadrature_of_the_same_dense_output() {
    let sys = OSCILLATOR;
    let grid = rk4::Grid::new(1.0, &[0.5], 41);
    let x0 = DVector::from_vec(vec![0.02, -0.1]);
    let states = rk4::trajectory(&sys, &grid, &x0);
    let probe = Probe { weights: vec![-2.5, 0.3], derivative: false };
    let closed = hermite_response(&sys, &grid, &states, &probe, 12, 1.0, &[1.0, 1.0]).expect("two runs");
    // theta clamps to 0.05 at 1e-15: the quadrature's own error is near 2.9e-7 (0.025)^8 ~ 5e-20
    let quad = gauss_response(&sys, &grid, &states, rk4::Scheme::Rk4, &probe, 12, 1.0, &[1.0, 1.0], 1e-15);
    let scale = closed.max.abs().max(closed.min.abs());
    for (k, (a, b)) in closed.lines.iter().zip(&quad.lines).enumerate() {
        // sums of ~1e3 terms of size 1: rounding far below 1e-13
        assert!((a - b).norm() < 1e-13 * scale, "line {k}: {a} against {b}");
    }
    assert!((closed.rms - quad.rms).abs() < 1e-13 * scale, "{} against {}", closed.rms, quad.rms);
    // golden section ends within 2e-17 (b - a)^2 |z''| of an interior extreme
    assert!((closed.max - quad.max).abs() < 1e-13 * scale, "{} against {}", closed.max, quad.max);
    assert!((closed.min - quad.min).abs() < 1e-13 * scale, "{} against {}", closed.min, quad.min);
}

#[test]
fn piecewise_lines_and_rms_match_the_closed_form() {
    let sys = SQUARE;
    let grid = rk4::Grid::new(1.0, &[0.5], 2);
    let states = vec![exact(0.0), exact(0.5), exact(0.0)];
    let traj = Trajectory::Grid { grid, states, scheme: rk4::Scheme::Magnus4 };
    let probe = Probe { weights: vec![1.0], derivative: false };
    let r = response(&sys, &traj, 1.0, &probe, 5, &[1.0], 1e-10);
    // mean of x = mean of f (integrate x' = -x + f over a period) = 1/2, exactly
    assert!((r.lines[0].re - 0.5).abs() < 1e-15, "{}", r.lines[0]);
    // Z_1 and the rms by Simpson on 2 x 20000 points of the closed form (error ~1e-17)
    let m = 20000;
    let (mut z1, mut sq) = (C64::new(0.0, 0.0), 0.0);
    for half in 0..2 {
        let h = 0.5 / m as f64;
        for j in 0..=m {
            let t = 0.5 * half as f64 + j as f64 * h;
            let x = if half == 0 && j == m { exact(0.5 - 1e-300) } else { exact(t) };
            let w = if j == 0 || j == m {
                1.0
            } else if j % 2 == 1 {
                4.0
            } else {
                2.0
            };
            z1 += C64::from_polar(x, -2.0 * std::f64::consts::PI * t) * (w * h / 3.0);
            sq += x * x * w * h / 3.0;
        }
    }
    assert!((r.lines[1] - z1).norm() < 1e-14, "{} vs {z1}", r.lines[1]);
    assert!((r.rms - sq.sqrt()).abs() < 1e-14, "{} vs {}", r.rms, sq.sqrt());
}
