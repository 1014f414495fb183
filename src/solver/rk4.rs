//! The paper's RK4 product method (Eqs 15-21).
//!
//! One RK4 step of the linear system x' = P(t) x + f(t) is affine, x_i = A_{i-1} x_{i-1} + b_{i-1} (Eq 17).
//! A and b are never written out from the printed Eqs 18-19 (misprinted: spurious factors 1/2 make them
//! first-order accurate). Instead the four RK4 stages are applied to the augmented block
//! W = [Phi_i | c_i] (n x (n+1)) with augmented last row [0 ... 0 1]:
//!
//! ```text
//! K1 = h (P(t)     W          + f(t)     s)
//! K2 = h (P(t+h/2) (W + K1/2) + f(t+h/2) s)
//! K3 = h (P(t+h/2) (W + K2/2) + f(t+h/2) s)
//! K4 = h (P(t+h)   (W + K3)   + f(t+h)   s)        s = [0 ... 0 1]
//! W <- W + (K1 + 2 K2 + 2 K3 + K4) / 6             (= A_i W + b_i s, exactly Eq 17)
//! ```
//! Starting from W = [I | 0], after m steps W = [Phi | c_m] (Eq 20), and the periodic initial state
//! solves (I - Phi) x0 = c_m (Eq 21). Step boundaries are placed on every coefficient jump, so a
//! piecewise-smooth system keeps fourth order.

use crate::system::{PeriodicSystem, Side};
use nalgebra::{DMatrix, DVector};

/// Step grid over one period: nodes t_0 = 0 < ... < t_m = T, with every breakpoint a node.
#[derive(Clone, Debug)]
pub struct Grid {
    /// Node times in s.
    pub nodes: Vec<f64>,
}

impl Grid {
    /// About `steps` steps of nearly equal size, split so that breakpoints are nodes; each piece gets at
    /// least one step.
    pub fn new(period_s: f64, breakpoints: &[f64], steps: usize) -> Self {
        let mut edges = vec![0.0];
        edges.extend_from_slice(breakpoints);
        edges.push(period_s);
        let h = period_s / steps.max(1) as f64;
        let mut nodes = vec![0.0];
        for w in edges.windows(2) {
            let k = ((w[1] - w[0]) / h).round().max(1.0) as usize;
            for j in 1..=k {
                nodes.push(if j == k { w[1] } else { w[0] + (w[1] - w[0]) * j as f64 / k as f64 });
            }
        }
        Self { nodes }
    }

    /// The grid with every step halved (its node 2 i is node i of `self`).
    pub fn refined(&self) -> Self {
        let mut nodes = Vec::with_capacity(2 * self.nodes.len());
        for w in self.nodes.windows(2) {
            nodes.push(w[0]);
            nodes.push(0.5 * (w[0] + w[1]));
        }
        nodes.push(*self.nodes.last().unwrap_or(&0.0));
        Self { nodes }
    }

    /// Number of steps m.
    pub fn steps(&self) -> usize {
        self.nodes.len() - 1
    }
}

/// A one-step scheme for linear periodic systems.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scheme {
    /// Classical RK4 applied to the augmented block (the paper's method).
    Rk4,
    /// Fourth-order Magnus integrator (two Gauss points, exact exponential of the augmented matrix):
    /// A-stable, exact for constant coefficients, so stiff systems need no step below 2.78 / |lambda|.
    ///
    /// ```text
    /// A_i = [P(t_i) f(t_i); 0 0],  t_{1,2} = t + h (1/2 -+ sqrt(3)/6)
    /// Omega = h/2 (A_1 + A_2) + sqrt(3) h^2 / 12 [A_2, A_1],   W <- exp(Omega) W
    /// ```
    Magnus4,
}

/// Preallocated buffers for one-step schemes of one system.
pub struct Stepper<'a> {
    pub(super) sys: &'a dyn PeriodicSystem,
    scheme: Scheme,
    pub(super) n: usize,
    pub(super) p: [DMatrix<f64>; 3],
    pub(super) f: [DVector<f64>; 3],
    k: Vec<f64>,
    acc: Vec<f64>,
    tmp: Vec<f64>,
}

/// True when `p` is [0 I; A B] with n/2 x n/2 blocks: the first-order form of a second-order system.
fn companion_form(p: &DMatrix<f64>) -> bool {
    let n = p.nrows();
    let half = n / 2;
    n.is_multiple_of(2) && (0..n).all(|j| (0..half).all(|i| p[(i, j)] == if j == half + i { 1.0 } else { 0.0 }))
}

impl<'a> Stepper<'a> {
    /// Buffers for `sys`.
    pub fn new(sys: &'a dyn PeriodicSystem) -> Self {
        Self::with_scheme(sys, Scheme::Rk4)
    }

    /// Buffers for `sys` stepping with `scheme`.
    pub fn with_scheme(sys: &'a dyn PeriodicSystem, scheme: Scheme) -> Self {
        let n = sys.dim();
        let m = || DMatrix::zeros(n, n);
        let v = || DVector::zeros(n);
        Self { sys, scheme, n, p: [m(), m(), m()], f: [v(), v(), v()], k: Vec::new(), acc: Vec::new(), tmp: Vec::new() }
    }

    /// k = h (P W + f s), W column-major n x cols. Large systems use nalgebra's blocked matrix product;
    /// small ones (the gear pair's n = 2) a plain loop, which is faster there.
    fn stage(&mut self, which: usize, h: f64, w: &[f64], s: &[f64]) {
        let n = self.n;
        let cols = s.len();
        if n >= 8 {
            let wv = nalgebra::DMatrixView::from_slice(w, n, cols);
            let mut out = nalgebra::DMatrixViewMut::from_slice(&mut self.k, n, cols);
            let p = &self.p[which];
            if companion_form(p) {
                // P = [0 I; A B] (a second-order system): the top half of P W is W's bottom half, and only
                // the bottom half needs the product (half the flops of a 16-DOF chain's stage)
                let half = n / 2;
                for col in 0..cols {
                    for row in 0..half {
                        out[(row, col)] = h * wv[(half + row, col)];
                    }
                }
                out.rows_mut(half, half).gemm(h, &p.rows(half, half), &wv, 0.0);
            } else {
                out.gemm(h, p, &wv, 0.0);
            }
            let f = &self.f[which];
            for (col, &sc) in s.iter().enumerate() {
                if sc != 0.0 {
                    for row in 0..n {
                        out[(row, col)] += h * f[row] * sc;
                    }
                }
            }
            return;
        }
        let (p, f) = (self.p[which].as_slice(), self.f[which].as_slice());
        let out = &mut self.k;
        for (col, &sc) in s.iter().enumerate() {
            let wc = &w[col * n..(col + 1) * n];
            for row in 0..n {
                let mut acc = f[row] * sc;
                for (kk, wv) in wc.iter().enumerate() {
                    acc += p[row + kk * n] * wv;
                }
                out[col * n + row] = h * acc;
            }
        }
    }

    /// One RK4 step of the block `w` (column-major n x s.len()) from `ta` to `tb`, where the augmented
    /// row is `s`. `reuse_start` says P and f at `ta` are already in slot 0 (from the previous step's end).
    pub fn step(&mut self, ta: f64, tb: f64, w: &mut [f64], s: &[f64], reuse_start: bool) {
        if self.scheme == Scheme::Magnus4 {
            return self.magnus_step(ta, tb, w, s);
        }
        let h = tb - ta;
        let len = w.len();
        if self.k.len() != len {
            self.k.resize(len, 0.0);
            self.acc.resize(len, 0.0);
            self.tmp.resize(len, 0.0);
        }
        if !reuse_start {
            self.sys.eval(ta, Side::Right, &mut self.p[0], &mut self.f[0]);
        }
        self.sys.eval(ta + 0.5 * h, Side::Right, &mut self.p[1], &mut self.f[1]);
        self.sys.eval(tb, Side::Left, &mut self.p[2], &mut self.f[2]);
        // K1
        self.stage(0, h, w, s);
        let mut stage_in = std::mem::take(&mut self.tmp);
        for i in 0..len {
            self.acc[i] = self.k[i];
            stage_in[i] = w[i] + 0.5 * self.k[i];
        }
        // K2
        self.stage(1, h, &stage_in, s);
        for i in 0..len {
            self.acc[i] += 2.0 * self.k[i];
            stage_in[i] = w[i] + 0.5 * self.k[i];
        }
        // K3
        self.stage(1, h, &stage_in, s);
        for i in 0..len {
            self.acc[i] += 2.0 * self.k[i];
            stage_in[i] = w[i] + self.k[i];
        }
        // K4
        self.stage(2, h, &stage_in, s);
        for ((wi, a), k) in w.iter_mut().zip(&self.acc).zip(&self.k) {
            *wi += (a + k) / 6.0;
        }
        self.tmp = stage_in;
    }

    /// Moves the end-of-step evaluation into the start slot (valid when the end node is no breakpoint).
    pub fn carry_end(&mut self) {
        self.p.swap(0, 2);
        self.f.swap(0, 2);
    }
}

/// Result of one RK4 product over a grid.
#[derive(Clone, Debug)]
pub struct Rk4Run {
    /// The grid used.
    pub grid: Grid,
    /// Monodromy matrix Phi (Eq 20).
    pub monodromy: DMatrix<f64>,
    /// Accumulated forcing c_m (Eq 20).
    pub forcing: DVector<f64>,
}

/// True when `t` is within 1e-12 periods of a breakpoint; `breaks` sorted ([`sorted_breaks`]): a binary
/// search, so a table of 1e5 pieces costs 1e5 log 1e5 lookups per pass, not 1e10.
pub(super) fn is_break(breaks: &[f64], t: f64, period: f64) -> bool {
    let tol = 1e-12 * period;
    let i = breaks.partition_point(|&b| b < t - tol);
    breaks.get(i).is_some_and(|b| (b - t).abs() <= tol)
}

/// The system's breakpoints in increasing order.
pub(super) fn sorted_breaks(sys: &dyn PeriodicSystem) -> Vec<f64> {
    let mut breaks = sys.breakpoints();
    breaks.sort_by(f64::total_cmp);
    breaks
}

/// Monodromy matrix and c_m by the RK4 product over `grid` (Eqs 17-20).
pub fn monodromy(sys: &dyn PeriodicSystem, grid: &Grid) -> Rk4Run {
    monodromy_with(sys, grid, Scheme::Rk4)
}

/// Monodromy matrix and c_m by the product of `scheme`'s step maps over `grid`.
pub fn monodromy_with(sys: &dyn PeriodicSystem, grid: &Grid, scheme: Scheme) -> Rk4Run {
    let n = sys.dim();
    let breaks = sorted_breaks(sys);
    let period = sys.period_s();
    let mut w = vec![0.0; n * (n + 1)];
    for i in 0..n {
        w[i * n + i] = 1.0;
    }
    let mut s = vec![0.0; n + 1];
    s[n] = 1.0;
    let mut st = Stepper::with_scheme(sys, scheme);
    let mut reuse = false;
    for win in grid.nodes.windows(2) {
        st.step(win[0], win[1], &mut w, &s, reuse);
        reuse = !is_break(&breaks, win[1], period);
        if reuse {
            st.carry_end();
        }
    }
    let monodromy = DMatrix::from_column_slice(n, n, &w[..n * n]);
    let forcing = DVector::from_column_slice(&w[n * n..]);
    Rk4Run { grid: grid.clone(), monodromy, forcing }
}

/// States x(t_i) at every node, propagated from `x0` (flattened, node-major, n per node).
pub fn trajectory(sys: &dyn PeriodicSystem, grid: &Grid, x0: &DVector<f64>) -> Vec<f64> {
    trajectory_with(sys, grid, x0, Scheme::Rk4)
}

/// [`trajectory`] with a chosen scheme.
pub fn trajectory_with(sys: &dyn PeriodicSystem, grid: &Grid, x0: &DVector<f64>, scheme: Scheme) -> Vec<f64> {
    let n = sys.dim();
    let breaks = sorted_breaks(sys);
    let period = sys.period_s();
    let mut out = Vec::with_capacity(grid.nodes.len() * n);
    let mut x: Vec<f64> = x0.iter().copied().collect();
    out.extend_from_slice(&x);
    let mut st = Stepper::with_scheme(sys, scheme);
    let mut reuse = false;
    for win in grid.nodes.windows(2) {
        st.step(win[0], win[1], &mut x, &[1.0], reuse);
        reuse = !is_break(&breaks, win[1], period);
        if reuse {
            st.carry_end();
        }
        out.extend_from_slice(&x);
    }
    out
}

/// State at time `tau` in [0, T]: one partial RK4 step from the node at or before `tau` (same piece, so
/// as accurate as the grid's own steps).
pub fn state_at(stepper: &mut Stepper<'_>, grid: &Grid, states: &[f64], tau: f64, out: &mut [f64]) {
    let n = out.len();
    let i = grid.nodes.partition_point(|&t| t <= tau).saturating_sub(1).min(grid.steps() - 1);
    out.copy_from_slice(&states[i * n..(i + 1) * n]);
    let ta = grid.nodes[i];
    if tau > ta {
        stepper.step(ta, tau, out, &[1.0], false);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// x' = P(t) x + f(t) with P = [0 I; A(t) B(t)] (n = 8, time-varying blocks) or a full P (`full`).
    struct Test {
        full: bool,
    }

    impl PeriodicSystem for Test {
        fn dim(&self) -> usize {
            8
        }
        fn period_s(&self) -> f64 {
            1.0
        }
        fn max_harmonic(&self) -> usize {
            1
        }
        fn eval(&self, t: f64, _side: Side, p: &mut DMatrix<f64>, f: &mut DVector<f64>) {
            for j in 0..8 {
                for i in 0..8 {
                    let v = ((i * 8 + j) as f64 * 0.37 + 3.0 * t).sin();
                    p[(i, j)] = match (i < 4, self.full) {
                        (true, false) => f64::from(u8::from(j == i + 4)),
                        _ => v,
                    };
                }
                f[j] = (j as f64 + t).cos();
            }
        }
    }

    /// One RK4 step written out with full matrix products: the reference for the stepper's shortcuts.
    fn naive_step(sys: &dyn PeriodicSystem, ta: f64, h: f64, x: &DVector<f64>) -> DVector<f64> {
        let rate = |t: f64, y: &DVector<f64>| {
            let (mut p, mut f) = (DMatrix::zeros(8, 8), DVector::zeros(8));
            sys.eval(t, Side::Right, &mut p, &mut f);
            &p * y + f
        };
        let k1 = rate(ta, x) * h;
        let k2 = rate(ta + h / 2.0, &(x + &k1 / 2.0)) * h;
        let k3 = rate(ta + h / 2.0, &(x + &k2 / 2.0)) * h;
        let k4 = rate(ta + h, &(x + &k3)) * h;
        x + (k1 + k2 * 2.0 + k3 * 2.0 + k4) / 6.0
    }

    #[test]
    fn a_step_matches_plain_rk4_with_and_without_the_companion_shortcut() {
        for full in [false, true] {
            let sys = Test { full };
            let x0 = DVector::from_fn(8, |i, _| 0.1 * i as f64 - 0.3);
            let mut w: Vec<f64> = x0.iter().copied().collect();
            let mut st = Stepper::new(&sys);
            st.step(0.2, 0.25, &mut w, &[1.0], false);
            let want = naive_step(&sys, 0.2, 0.05, &x0);
            for (a, b) in w.iter().zip(want.iter()) {
                // the same arithmetic in another order: rounding only
                assert!((a - b).abs() <= 1e-14 * (1.0 + b.abs()), "full {full}: {a} against {b}");
            }
        }
    }
}
