//! Tests of the two-frequency harmonic balance.

use super::*;

/// A constant-coefficient oscillator forced at two frequencies: each line is the closed-form response
/// F / (k - m w^2 + i c w), nothing else is excited.
#[test]
fn solve_works_on_a_linear_oscillator_with_two_tones() {
    let (m, c, k) = (2.0, 0.3, 50.0);
    let (wa, wb) = (3.0, 3.0 * std::f64::consts::SQRT_2);
    let form = TwoToneForm {
        dof: 1,
        omega_rad_s: [wa, wb],
        mass: vec![m],
        damping: vec![c],
        stiffness: [vec![FourierSeries::constant(k)], vec![FourierSeries::constant(0.0)]],
        forcing: [
            vec![FourierSeries::new(wa, 1.0, vec![0.0, 2.0], vec![])],
            vec![FourierSeries::new(wb, 0.0, vec![], vec![0.5])],
        ],
    };
    let (sol, rep) = solve(&form, 1e-12, 1 << 12).unwrap();
    let h = |w: f64| C64::new(1.0, 0.0) / C64::new(k - m * w * w, c * w);
    // 2 cos(2 wa t) = e^{2 i wa t} + c.c.; 0.5 sin(wb t) = -0.25 i e^{i wb t} + c.c.
    assert!((sol.coefficient(0, 0, 0) - h(0.0)).norm() < 1e-14);
    assert!((sol.coefficient(0, 2, 0) - h(2.0 * wa)).norm() < 1e-14);
    assert!((sol.coefficient(0, 0, 1) - C64::new(0.0, -0.25) * h(wb)).norm() < 1e-14);
    assert!(sol.coefficient(0, 1, 1).norm() == 0.0);
    assert!(rep.error_estimate <= 1e-12);
}
