//! The homogeneous companion x' = P(t) x over the period of P(t) alone, whose monodromy (by RK4 with two
//! Richardson eliminations) gives the Floquet multipliers for solvers that do not step in time.

use super::{RK4_STABILITY_LIMIT, SolverError, SolverOptions, rk4};
use crate::system::{PeriodicSystem, Side};
use nalgebra::{DMatrix, DVector};

/// The RK4 product of x' = P(t) x over equal steps h, from P sampled at every node and midpoint
/// (`samples`: 2 m + 1 matrices, n x n column-major): the monodromy of the homogeneous system, the RK4
/// steps of [`rk4::monodromy`] (for n = 2 and 4 grouped as one matrix per step, see `fixed_product`)
/// without the forcing column and without evaluating P twice at a node.
fn homogeneous_product(n: usize, h: f64, samples: &[f64]) -> DMatrix<f64> {
    // a fixed size lets the compiler unroll the gear pair's 2 x 2 products (a third of the companion's time
    // went into the loops' bookkeeping)
    match n {
        2 => fixed_product::<2>(h, samples),
        4 => fixed_product::<4>(h, samples),
        _ => sized_product(n, h, samples),
    }
}

/// [`homogeneous_product`] for n = N known at compile time.
fn fixed_product<const N: usize>(h: f64, samples: &[f64]) -> DMatrix<f64> {
    type Block<const N: usize> = [[f64; N]; N];
    let nn = N * N;
    let steps = (samples.len() / nn - 1) / 2;
    let at = |j: usize| -> Block<N> {
        let p = &samples[j * nn..(j + 1) * nn];
        std::array::from_fn(|col| std::array::from_fn(|row| p[row + col * N]))
    };
    // k = h P x, blocks stored by column
    let product = |p: &Block<N>, x: &Block<N>| -> Block<N> {
        std::array::from_fn(|col| {
            std::array::from_fn(|row| {
                let mut a = 0.0;
                for kk in 0..N {
                    a += p[kk][row] * x[col][kk];
                }
                h * a
            })
        })
    };
    // I + c x
    let shifted = |x: &Block<N>, c: f64| -> Block<N> {
        std::array::from_fn(|col| std::array::from_fn(|row| f64::from(u8::from(row == col)) + c * x[col][row]))
    };
    let mut w: Block<N> = shifted(&[[0.0; N]; N], 0.0);
    let mut p0 = at(0);
    for i in 0..steps {
        let (pm, p1) = (at(2 * i + 1), at(2 * i + 2));
        // on a linear system the step is a matrix of P alone: k1 = A1 W with A1 = h P0, k2 = A2 W with
        // A2 = h Pm (I + A1 / 2), k3 = A3 W with A3 = h Pm (I + A2 / 2), k4 = A4 W with A4 = h P1 (I + A3),
        // so W <- S W with S = I + (A1 + 2 A2 + 2 A3 + A4) / 6. The steps' matrices do not wait for each
        // other, only the product S W does (stage by stage on W, each stage waited for the one before)
        let a1: Block<N> = std::array::from_fn(|col| std::array::from_fn(|row| h * p0[col][row]));
        let a2 = product(&pm, &shifted(&a1, 0.5));
        let a3 = product(&pm, &shifted(&a2, 0.5));
        let a4 = product(&p1, &shifted(&a3, 1.0));
        let step: Block<N> = std::array::from_fn(|col| {
            std::array::from_fn(|row| {
                let acc = a1[col][row] + 2.0 * a2[col][row] + 2.0 * a3[col][row] + a4[col][row];
                f64::from(u8::from(row == col)) + acc / 6.0
            })
        });
        w = std::array::from_fn(|col| {
            std::array::from_fn(|row| (0..N).map(|kk| step[kk][row] * w[col][kk]).sum::<f64>())
        });
        p0 = p1;
    }
    DMatrix::from_fn(N, N, |row, col| w[col][row])
}

/// [`homogeneous_product`] for any n.
fn sized_product(n: usize, h: f64, samples: &[f64]) -> DMatrix<f64> {
    let nn = n * n;
    let steps = (samples.len() / nn - 1) / 2;
    let mut w = vec![0.0; nn];
    for i in 0..n {
        w[i * n + i] = 1.0;
    }
    let (mut k, mut acc, mut stage_in) = (vec![0.0; nn], vec![0.0; nn], vec![0.0; nn]);
    // P = [0 I; A B] at every sample (a second-order system): the top half of P x is x's bottom half
    let half = n / 2;
    let second_order = n.is_multiple_of(2)
        && samples
            .chunks(nn)
            .all(|p| (0..n).all(|j| (0..half).all(|i| p[i + j * n] == f64::from(u8::from(j == half + i)))));
    let first_row = if second_order { half } else { 0 };
    // k = h P x (all n x n column-major)
    let product = |p: &[f64], x: &[f64], k: &mut [f64]| {
        for col in 0..n {
            let xc = &x[col * n..(col + 1) * n];
            for row in 0..first_row {
                k[col * n + row] = h * xc[half + row];
            }
            for row in first_row..n {
                let mut a = 0.0;
                for (kk, xv) in xc.iter().enumerate() {
                    a += p[row + kk * n] * xv;
                }
                k[col * n + row] = h * a;
            }
        }
    };
    for i in 0..steps {
        let p0 = &samples[2 * i * nn..(2 * i + 1) * nn];
        let pm = &samples[(2 * i + 1) * nn..(2 * i + 2) * nn];
        let p1 = &samples[(2 * i + 2) * nn..(2 * i + 3) * nn];
        product(p0, &w, &mut k);
        for j in 0..nn {
            acc[j] = k[j];
            stage_in[j] = w[j] + 0.5 * k[j];
        }
        product(pm, &stage_in, &mut k);
        for j in 0..nn {
            acc[j] += 2.0 * k[j];
            stage_in[j] = w[j] + 0.5 * k[j];
        }
        product(pm, &stage_in, &mut k);
        for j in 0..nn {
            acc[j] += 2.0 * k[j];
            stage_in[j] = w[j] + k[j];
        }
        product(p1, &stage_in, &mut k);
        for j in 0..nn {
            w[j] += (acc[j] + k[j]) / 6.0;
        }
    }
    DMatrix::from_column_slice(n, n, &w)
}

/// P(t) over its own period with no forcing: the companion system whose monodromy gives the multipliers.
struct Homogeneous<'a> {
    sys: &'a dyn PeriodicSystem,
    period_s: f64,
}

impl PeriodicSystem for Homogeneous<'_> {
    fn dim(&self) -> usize {
        self.sys.dim()
    }
    fn period_s(&self) -> f64 {
        self.period_s
    }
    fn eval(&self, t: f64, side: Side, p: &mut DMatrix<f64>, f: &mut DVector<f64>) {
        self.sys.eval_matrix(t, side, p);
        f.fill(0.0);
    }
    fn eval_matrix(&self, t: f64, side: Side, p: &mut DMatrix<f64>) {
        self.sys.eval_matrix(t, side, p);
    }
    fn eval_matrix_uniform(&self, t0: f64, dt: f64, count: usize, out: &mut Vec<f64>) {
        self.sys.eval_matrix_uniform(t0, dt, count, out);
    }
    fn breakpoints(&self) -> Vec<f64> {
        self.sys.breakpoints().into_iter().filter(|&b| b < self.period_s * (1.0 - 1e-12)).collect()
    }
    fn max_harmonic(&self) -> usize {
        let k = (self.sys.period_s() / self.period_s).round().max(1.0) as usize;
        self.sys.max_harmonic() / k
    }
}

/// Monodromy over the full period from the companion over the homogeneous period: Phi = Phi_h^k. The
/// companion's tolerance is divided by k because relative multiplier errors grow k-fold.
/// The companion's monodromy over the full period and what it cost.
pub(super) struct Companion {
    /// Monodromy matrix over the full period.
    pub monodromy: DMatrix<f64>,
    /// Estimated relative error of the monodromy.
    pub error: f64,
    /// RK4 steps taken in all.
    pub steps: usize,
    /// The table's higher-order value raised to the same power: the multipliers' change to it estimates
    /// their error.
    pub better: DMatrix<f64>,
}

/// `rate` is the largest |eigenvalue| of P(t) and `d` the state scales of `sys`
/// ([`state_scales`](super::steady::state_scales)): the companion has the same P, so both carry over.
///
/// Phi_h is first computed to the plain tolerance: a damped Phi_h shrinks its own error in the powers
/// (fig8a: 2e-13 for the full period from 3e-12 for the mesh cycle), so an a-priori division (by k, or by
/// the state dimension: fig8a at 1e-10 then took 1260 steps where 620 meet the tolerance) asks for Romberg
/// doublings the result does not need. When the powers do amplify the error (light damping, unstable,
/// non-normal), the same Romberg table is refined further, never restarted.
pub(super) fn companion_monodromy(
    sys: &dyn PeriodicSystem,
    opts: &SolverOptions,
    rate: f64,
    d: &[f64],
) -> Result<Companion, SolverError> {
    let th = sys.homogeneous_period_s();
    let k = (sys.period_s() / th).round().max(1.0) as usize;
    let hom = Homogeneous { sys, period_s: sys.period_s() / k as f64 };
    let mut tol = opts.tolerance;
    let mut table = Romberg::new(&hom, rate, d)?;
    loop {
        let (phi_h, est, better_h) = table.refine_to(tol, opts.max_steps)?;
        let (phi, error) = power_with_error(&phi_h, est, k, d);
        // the powers of a growing (unstable or non-normal) Phi_h amplify its error beyond k-fold: tighten
        // the companion's tolerance by what the powers cost (rounding caps the tightening)
        if error <= opts.tolerance || tol < 1e-14 {
            let better = (0..k).fold(DMatrix::identity(d.len(), d.len()), |acc, _| &better_h * acc);
            return Ok(Companion { monodromy: phi, error, steps: table.total, better });
        }
        tol = est * 0.5 * opts.tolerance / error;
    }
}

/// Phi = Phi_h^k and its error from an error `est` of Phi_h (relative to max(|B_h|, 1), B the balanced
/// matrix D^-1 Phi D): Phi - Phi_exact = sum_j B_h^j dB B_h^(k-1-j), so its size is at most
/// |dB| sum_j s_j s_(k-1-j) with s_j = ||B_h^j||_inf, returned relative to max(|B|, 1). A strongly damped
/// Phi_h thus shrinks the error with its powers, as the product itself shrinks (the hunting period:
/// Phi ~ 1e-78), and a non-normal Phi_h whose norm exceeds 1 is not overstated by a^k.
fn power_with_error(phi_h: &DMatrix<f64>, est: f64, k: usize, d: &[f64]) -> (DMatrix<f64>, f64) {
    let n = d.len();
    let balanced = |m: &DMatrix<f64>| DMatrix::from_fn(n, n, |i, j| m[(i, j)] * d[j] / d[i]);
    let inf_norm = |m: &DMatrix<f64>| m.row_iter().map(|r| r.iter().map(|v| v.abs()).sum::<f64>()).fold(0.0, f64::max);
    let b_h = balanced(phi_h);
    let mut phi = DMatrix::identity(n, n);
    let mut norms = Vec::with_capacity(k);
    for _ in 0..k {
        norms.push(inf_norm(&balanced(&phi)));
        phi = phi_h * phi;
    }
    let growth: f64 = (0..k).map(|j| norms[j] * norms[k - 1 - j]).sum();
    let absolute = est * b_h.amax().max(1.0);
    // n times the largest entry bounds the 2-norm (the measure of `SteadyState::multiplier_error`)
    let error = n as f64 * absolute * growth / balanced(&phi).amax().max(1.0);
    (phi, error)
}

/// Monodromy by RK4 at m, 2m, 4m, ... steps in a Richardson table: the RK4 error of a smooth P expands in
/// h^4, h^5, h^6, ..., so T(i, 0) = Phi at m 2^i steps and
///
/// ```text
/// T(i, j) = (2^(3+j) T(i, j-1) - T(i-1, j-1)) / (2^(3+j) - 1)
/// ```
///
/// is of order 4 + j (j = 1, 2: the (16 Phi_2m - Phi_m) / 15 and (32 R1(2m) - R1(m)) / 31 of before). Each
/// doubling adds one order, so the table converges faster than any fixed order (the light-damping gear at
/// 1e-8: 620 steps, where the fixed sixth order needed 1260; fig8a at 1e-10: 1260 either way). The value
/// returned is T(i, i-1) with 2 |T(i, i) - T(i, i-1)| as its error (T(i, i) is an order better): an
/// estimate of what is returned, not a loose bound on the better value. Differences are taken on the
/// balanced monodromy D^-1 Phi D (unit-free) relative to max(|Phi|, 1), as for the step-based solvers:
/// multipliers matter against the unit circle.
struct Romberg<'a> {
    sys: &'a dyn PeriodicSystem,
    breaks: Vec<f64>,
    /// d_j / d_i: entry (i, j) of the balanced D^-1 Phi D is Phi_ij d_j / d_i.
    scales: DMatrix<f64>,
    /// Steps of the finest run so far.
    m: usize,
    /// The table's last row T(i, 0..=i).
    row: Vec<DMatrix<f64>>,
    /// The best value and its error estimate once the table has three rows.
    best: Option<(DMatrix<f64>, f64)>,
    /// RK4 steps taken in all.
    total: usize,
    /// Without breakpoints and below [`SAMPLED_BELOW`] states: P at the 2 m + 1 times j T / (2 m) of the last run (n x n column-major each),
    /// the nodes and midpoints of its steps; the next run (2 m steps) reuses them as its nodes and
    /// evaluates only its new midpoints, so the whole table costs one evaluation per point of its finest
    /// run (half of what separate runs cost).
    samples: Vec<f64>,
}

/// State dimensions below which the companion samples P once per point of its table ([`Romberg::sample`]).
const SAMPLED_BELOW: usize = 8;

/// Deepest elimination of the table (order 4 + 8): beyond it the weights' rounding outweighs the gain.
const MAX_DEPTH: usize = 8;

impl<'a> Romberg<'a> {
    fn new(sys: &'a dyn PeriodicSystem, rate: f64, d: &[f64]) -> Result<Self, SolverError> {
        let limit = (sys.period_s() * rate / RK4_STABILITY_LIMIT).ceil() as usize;
        let m = (2 * limit).max(sys.max_harmonic() * 2).max(16);
        let n = d.len();
        let mut r = Self {
            sys,
            breaks: sys.breakpoints(),
            scales: DMatrix::from_fn(n, n, |i, j| d[j] / d[i]),
            m,
            row: Vec::new(),
            best: None,
            total: m,
            samples: Vec::new(),
        };
        let first = r.run(m)?;
        r.row.push(first);
        Ok(r)
    }

    fn run(&mut self, steps: usize) -> Result<DMatrix<f64>, SolverError> {
        // sampled once per point only for small systems, where evaluating P is most of a step: from 8 states
        // on the product is (a 16-DOF chain: the stored samples' 5 MB cost more in page faults than the
        // evaluations they saved)
        let phi = if self.breaks.is_empty() && self.sys.dim() < SAMPLED_BELOW {
            self.sample(steps);
            homogeneous_product(self.sys.dim(), self.sys.period_s() / steps as f64, &self.samples)
        } else {
            rk4::monodromy(self.sys, &rk4::Grid::new(self.sys.period_s(), &self.breaks, steps)).monodromy
        };
        if phi.iter().any(|v| !v.is_finite()) {
            return Err(SolverError::NonFinite { what: format!("companion monodromy after {steps} steps") });
        }
        Ok(phi)
    }

    /// Fills `samples` with P at j T / (2 `steps`), j = 0..=2 `steps`, keeping the even points from the
    /// previous run when `steps` doubles it.
    fn sample(&mut self, steps: usize) {
        let n = self.sys.dim();
        let nn = n * n;
        let points = 2 * steps + 1;
        let old = std::mem::take(&mut self.samples);
        let dt = self.sys.period_s() / (2 * steps) as f64;
        let mut out = Vec::with_capacity(points * nn);
        if old.len() != (steps + 1) * nn {
            // no breakpoints here, so no side to choose at the period's end
            self.sys.eval_matrix_uniform(0.0, dt, points, &mut out);
            self.samples = out;
            return;
        }
        let mut odd = Vec::with_capacity(steps * nn);
        self.sys.eval_matrix_uniform(dt, 2.0 * dt, steps, &mut odd);
        for j in 0..steps {
            out.extend_from_slice(&old[j * nn..(j + 1) * nn]);
            out.extend_from_slice(&odd[j * nn..(j + 1) * nn]);
        }
        out.extend_from_slice(&old[steps * nn..]);
        self.samples = out;
    }

    /// One more row: RK4 at twice the steps, then the eliminations.
    fn double(&mut self) -> Result<(), SolverError> {
        self.m *= 2;
        self.total += self.m;
        let mut next = vec![self.run(self.m)?];
        for j in 1..=self.row.len().min(MAX_DEPTH) {
            let w = f64::powi(2.0, 3 + j as i32);
            let t = (&next[j - 1] * w - &self.row[j - 1]) / (w - 1.0);
            next.push(t);
        }
        self.row = next;
        if self.row.len() >= 3 {
            let balanced = |x: &DMatrix<f64>| x.component_mul(&self.scales);
            let (top, below) = (&self.row[self.row.len() - 1], &self.row[self.row.len() - 2]);
            let scale = balanced(top).amax().max(1.0);
            self.best = Some((below.clone(), 2.0 * balanced(&(top - below)).amax() / scale));
        }
        Ok(())
    }

    /// Doubles the steps until the estimate meets `tol`; returns the best monodromy and its estimated error.
    fn refine_to(&mut self, tol: f64, max_steps: usize) -> Result<(DMatrix<f64>, f64, DMatrix<f64>), SolverError> {
        loop {
            if let Some((best, est)) = &self.best {
                if *est <= tol {
                    return Ok((best.clone(), *est, self.row[self.row.len() - 1].clone()));
                }
                if self.m >= max_steps {
                    return Err(SolverError::ToleranceNotReached {
                        cond: f64::NAN,
                        tolerance: tol,
                        steps: self.m,
                        estimate: *est,
                    });
                }
            }
            self.double()?;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// x' = P(t) x, n x n, smooth entries of period 1 (a [0 I; A B] form when `second_order`).
    struct Smooth {
        n: usize,
        second_order: bool,
    }

    impl PeriodicSystem for Smooth {
        fn dim(&self) -> usize {
            self.n
        }
        fn period_s(&self) -> f64 {
            1.0
        }
        fn max_harmonic(&self) -> usize {
            2
        }
        fn eval(&self, t: f64, _side: Side, p: &mut DMatrix<f64>, f: &mut DVector<f64>) {
            let (n, half) = (self.n, self.n / 2);
            let w = 2.0 * std::f64::consts::PI;
            for j in 0..n {
                for i in 0..n {
                    p[(i, j)] = if self.second_order && i < half {
                        f64::from(u8::from(j == half + i))
                    } else {
                        0.3 * ((i * n + j) as f64 + w * t).sin() - if i == j { 0.5 } else { 0.0 }
                    };
                }
            }
            f.fill(0.0);
        }
    }

    #[test]
    fn homogeneous_product_works() {
        // against the forced product of rk4.rs (its Stepper, P evaluated per step): the same RK4 steps
        for (n, second_order) in [(2, true), (3, false), (4, true), (4, false), (6, true), (8, true), (9, false)] {
            let sys = Smooth { n, second_order };
            let steps = 40;
            let mut table = Romberg::new(&sys, 1.0, &vec![1.0; n]).unwrap();
            let mine = table.run(steps).unwrap();
            // and after a doubling, from the reused samples
            let doubled = table.run(2 * steps).unwrap();
            for (m, got) in [(steps, mine), (2 * steps, doubled)] {
                let want = rk4::monodromy(&sys, &rk4::Grid::new(1.0, &[], m)).monodromy;
                // the same operations in another order: rounding only
                assert!((&got - &want).amax() < 1e-13, "n {n} ({second_order}), {m} steps: {got} against {want}");
            }
        }
    }
}
