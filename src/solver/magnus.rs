//! Fourth-order Magnus step (two Gauss points, exact exponential of the augmented matrix): A-stable and
//! exact for constant coefficients, so stiff systems and piecewise-constant coefficients need no step below
//! the explicit limit 2.78 / |lambda|.
//!
//! ```text
//! A_i = [P(t_i) f(t_i); 0 0],  t_{1,2} = t + h (1/2 -+ sqrt(3)/6)
//! Omega = h/2 (A_1 + A_2) + sqrt(3) h^2 / 12 [A_2, A_1],   W <- exp(Omega) W
//! ```

use super::rk4::Stepper;
use crate::system::Side;
use nalgebra::DMatrix;

impl Stepper<'_> {
    fn augmented(&self, slot: usize) -> DMatrix<f64> {
        let n = self.n;
        let mut a = DMatrix::zeros(n + 1, n + 1);
        a.view_mut((0, 0), (n, n)).copy_from(&self.p[slot]);
        a.view_mut((0, n), (n, 1)).copy_from(&self.f[slot]);
        a
    }

    pub(super) fn magnus_step(&mut self, ta: f64, tb: f64, w: &mut [f64], s: &[f64]) {
        let h = tb - ta;
        let c = 3f64.sqrt() / 6.0;
        self.sys.eval(ta + h * (0.5 - c), Side::Right, &mut self.p[0], &mut self.f[0]);
        self.sys.eval(ta + h * (0.5 + c), Side::Right, &mut self.p[1], &mut self.f[1]);
        let (a1, a2) = (self.augmented(0), self.augmented(1));
        let omega = (&a1 + &a2) * (0.5 * h) + (&a2 * &a1 - &a1 * &a2) * (3f64.sqrt() * h * h / 12.0);
        // exponentiated balanced (a similarity by powers of 2): a gear's Omega mixes metres and metres per
        // second (entries 1e-3 against 4e4), and the exponential of the unbalanced matrix lost three digits
        let mut balanced = omega;
        let d = super::eigen::balance(&mut balanced);
        let eb = balanced.exp();
        let e = DMatrix::from_fn(eb.nrows(), eb.ncols(), |i, j| eb[(i, j)] * d[i] / d[j]);
        let n = self.n;
        let mut col = vec![0.0; n];
        for (j, &sj) in s.iter().enumerate() {
            let wc = &mut w[j * n..(j + 1) * n];
            for (r, out) in col.iter_mut().enumerate() {
                *out = e[(r, n)] * sj + (0..n).map(|k| e[(r, k)] * wc[k]).sum::<f64>();
            }
            wc.copy_from_slice(&col);
        }
    }
}
