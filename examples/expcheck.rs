//! Checks nalgebra's matrix exponential on a stiff augmented matrix by repeated squaring consistency.
use nalgebra::DMatrix;
fn main() {
    let (m1, m2, kb, kp) = (27.43f64, 0.5f64, 0.5 * (2.0 * std::f64::consts::PI * 42000.0f64).powi(2), 5.1e8f64);
    let (c1, c2) = (2.0 * 0.024 * (1.6 * kp * m1).sqrt(), 2.0 * 0.02 * (kb * m2).sqrt());
    let k11 = 2.0 * kp + kb;
    let a = DMatrix::from_row_slice(
        5,
        5,
        &[
            0.0,
            0.0,
            1.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            1.0,
            0.0,
            -k11 / m1,
            kb / m1,
            -c1 / m1,
            0.0,
            9821.5 / m1,
            kb / m2,
            -2.0 * kb / m2,
            0.0,
            -c2 / m2,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
        ],
    );
    let h = 0.6 / 420.0;
    let e1 = (&a * h).exp();
    let mut e2 = (&a * (h / 64.0)).exp();
    for _ in 0..6 {
        e2 = &e2 * &e2;
    }
    let mut e3 = (&a * (h / 1024.0)).exp();
    for _ in 0..10 {
        e3 = &e3 * &e3;
    }
    println!("{:.12e} {:.12e} {:.12e}", e1[(2, 0)], e2[(2, 0)], e3[(2, 0)]);
}
