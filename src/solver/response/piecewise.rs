//! Lines, RMS and extremes of piecewise-constant coefficients stepped by exact exponentials (Van Loan's
//! block exponentials; see the parent module).

use super::*;

/// The augmented matrix [P f; 0 0] (n + 1) of a piece.
pub(super) fn augmented(p: &DMatrix<f64>, f: &DVector<f64>) -> DMatrix<f64> {
    let n = p.nrows();
    let mut a = DMatrix::zeros(n + 1, n + 1);
    a.view_mut((0, 0), (n, n)).copy_from(p);
    a.view_mut((0, n), (n, 1)).copy_from(f);
    a
}

/// int_0^h c^T exp(B tau) dtau for a complex B (n + 1): the corner row of exp([[0, c^T], [0, B]] h).
pub(super) fn integral_row(c: &DVector<f64>, b: &DMatrix<C64>, h: f64) -> Vec<C64> {
    let m = b.nrows();
    let mut big = DMatrix::<C64>::zeros(m + 1, m + 1);
    for j in 0..m {
        big[(0, j + 1)] = C64::new(c[j] * h, 0.0);
        for i in 0..m {
            big[(i + 1, j + 1)] = b[(i, j)] * h;
        }
    }
    let e = big.exp();
    (0..m).map(|j| e[(0, j + 1)]).collect()
}

/// Gram matrix int_0^h exp(A^T tau) c c^T exp(A tau) dtau (Van Loan: F22^T F12 of exp([[-A^T, c c^T],
/// [0, A]] h)).
pub(super) fn gram(a: &DMatrix<f64>, c: &DVector<f64>, h: f64) -> DMatrix<f64> {
    let m = a.nrows();
    let mut big = DMatrix::zeros(2 * m, 2 * m);
    big.view_mut((0, 0), (m, m)).copy_from(&(-a.transpose() * h));
    big.view_mut((0, m), (m, m)).copy_from(&(c * c.transpose() * h));
    big.view_mut((m, m), (m, m)).copy_from(&(a * h));
    let e = big.exp();
    let f12 = e.view((0, m), (m, m)).clone_owned();
    let f22 = e.view((m, m), (m, m)).clone_owned();
    f22.transpose() * f12
}

/// Exact lines, RMS and extremes on piecewise-constant coefficients (see the module docs). Each step lies
/// inside one piece; it is cut into q equal sub-pieces with (|A| + kmax w) h / q <= 1 so that every block
/// exponential is of modest norm, and the sub-pieces share their exponentials.
#[allow(clippy::too_many_arguments)]
pub(super) fn piecewise_response(
    sys: &dyn PeriodicSystem,
    grid: &rk4::Grid,
    states: &[f64],
    probe: &Probe,
    kmax: usize,
    period_s: f64,
    d: &[f64],
    tolerance: f64,
) -> Response {
    let n = sys.dim();
    let omega = 2.0 * std::f64::consts::PI / period_s;
    let theta = phase_per_interval(tolerance);
    let (mut p, mut f) = (DMatrix::zeros(n, n), DVector::zeros(n));
    let mut lines = vec![C64::new(0.0, 0.0); kmax + 1];
    let mut square = 0.0;
    let mut segments = Vec::with_capacity(grid.steps());
    let mut pieces = Vec::with_capacity(grid.steps());
    let mut gain_row: f64 = 0.0;
    // balanced coordinates: x^ = Dh z^ with Dh = diag(d, 1), so A^ becomes Dh^-1 A^ Dh (norm ~ |lambda|)
    let dh: Vec<f64> = d.iter().copied().chain([1.0]).collect();
    for (j, w) in grid.nodes.windows(2).enumerate() {
        let h = w[1] - w[0];
        sys.eval(0.5 * (w[0] + w[1]), Side::Right, &mut p, &mut f);
        let a_raw = augmented(&p, &f);
        let c_raw = probe.row(&p, &f);
        gain_row = gain_row.max(row_gain(&c_raw, d));
        let a = DMatrix::from_fn(n + 1, n + 1, |r, s| a_raw[(r, s)] * dh[s] / dh[r]);
        let c = DVector::from_fn(n + 1, |r, _| c_raw[r] * dh[r]);
        let norm = a.view((0, 0), (n, n)).abs().row_sum().max();
        let q = ((h * (norm + omega * kmax as f64) / theta).ceil() as usize).max(1);
        let hs = h / q as f64;
        let e_sub = (&a * hs).exp();
        let g = gram(&a, &c, hs);
        // int over a sub-piece of e^{-i k w tau} c^T exp(A tau) = row_k; phases from the sub-piece start
        let rows: Vec<Vec<C64>> = (0..=kmax)
            .map(|k| {
                let b = DMatrix::from_fn(n + 1, n + 1, |r, s| {
                    C64::new(a[(r, s)], if r == s { -(k as f64) * omega } else { 0.0 })
                });
                integral_row(&c, &b, hs)
            })
            .collect();
        // four samples per sub-piece for the extremes: exp(A hs i / 4)
        let quarter = (&a * (0.25 * hs)).exp();
        let mut zb = DVector::from_fn(n + 1, |r, _| if r < n { states[j * n + r] / d[r] } else { 1.0 });
        let mut ts = Vec::with_capacity(4 * q + 1);
        let mut vs = Vec::with_capacity(4 * q + 1);
        for s in 0..q {
            let t0 = w[0] + s as f64 * hs;
            square += (zb.transpose() * &g * &zb)[(0, 0)];
            for (k, row) in rows.iter().enumerate() {
                let v: C64 = row.iter().zip(zb.iter()).map(|(r, x)| r * *x).sum();
                lines[k] += v * C64::from_polar(1.0, -(k as f64) * omega * t0) / period_s;
            }
            let mut y = zb.clone();
            for i in 0..4 {
                ts.push(t0 + 0.25 * hs * i as f64);
                vs.push(c.dot(&y));
                y = &quarter * y;
            }
            zb = &e_sub * zb;
        }
        ts.push(w[1]);
        vs.push(c.dot(&zb));
        segments.push(Segment { ts, zs: vs, curvature: None });
        pieces.push((a, c));
    }
    let value = |j: usize, t: f64| {
        let (a, c) = &pieces[j];
        let x0 = DVector::from_fn(n + 1, |r, _| if r < n { states[j * n + r] / d[r] } else { 1.0 });
        c.dot(&((a * (t - grid.nodes[j])).exp() * x0))
    };
    let (max, min, slack, _) = extremes(&segments, &value, MAX_CANDIDATES);
    let gain = gain_row * balanced_scale(states, d);
    Response { lines, rms: (square / period_s).max(0.0).sqrt(), max, min, gain, extreme_slack: slack }
}
