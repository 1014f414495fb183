//! The dense output of a stepped solution (rk4's cubic Hermite interpolant, magnus4's partial steps) and
//! its lines, RMS and extremes: closed forms on runs of equal steps, else Gauss-Legendre quadrature.

use super::*;

/// States of a grid trajectory at `times` (each in [0, T]): a partial step of `scheme` from the node at or
/// before it.
pub fn grid_states(
    sys: &dyn PeriodicSystem,
    grid: &rk4::Grid,
    states: &[f64],
    scheme: rk4::Scheme,
    times: &[f64],
    out: &mut Vec<f64>,
) {
    let n = sys.dim();
    let mut st = rk4::Stepper::with_scheme(sys, scheme);
    let mut x = vec![0.0; n];
    out.clear();
    out.reserve(times.len() * n);
    for &t in times {
        rk4::state_at(&mut st, grid, states, t, &mut x);
        out.extend_from_slice(&x);
    }
}

const GAUSS_NODES: [f64; 4] =
    [-0.861_136_311_594_052_6, -0.339_981_043_584_856_3, 0.339_981_043_584_856_3, 0.861_136_311_594_052_6];
const GAUSS_WEIGHTS: [f64; 4] =
    [0.347_854_845_137_453_9, 0.652_145_154_862_546_1, 0.652_145_154_862_546_1, 0.347_854_845_137_453_9];

/// Node values of a grid trajectory: per step the slopes x' = P x + f at its start (right limit) and end
/// (left limit), and the probe there.
pub(super) struct NodeSlopes {
    pub(super) start: Vec<f64>,
    pub(super) end: Vec<f64>,
    pub(super) z_start: Vec<f64>,
    pub(super) z_end: Vec<f64>,
}

pub(super) fn node_slopes(sys: &dyn PeriodicSystem, grid: &rk4::Grid, states: &[f64], probe: &Probe) -> NodeSlopes {
    let n = sys.dim();
    let m = grid.steps();
    let (mut p, mut f) = (DMatrix::zeros(n, n), DVector::zeros(n));
    let mut out =
        NodeSlopes { start: vec![0.0; m * n], end: vec![0.0; m * n], z_start: vec![0.0; m], z_end: vec![0.0; m] };
    for (j, w) in grid.nodes.windows(2).enumerate() {
        let (xa, xb) = (&states[j * n..(j + 1) * n], &states[(j + 1) * n..(j + 2) * n]);
        sys.eval(w[0], Side::Right, &mut p, &mut f);
        crate::system::state_derivative(&p, &f, xa, &mut out.start[j * n..(j + 1) * n]);
        out.z_start[j] = probe.value(xa, &p, &f);
        sys.eval(w[1], Side::Left, &mut p, &mut f);
        crate::system::state_derivative(&p, &f, xb, &mut out.end[j * n..(j + 1) * n]);
        out.z_end[j] = probe.value(xb, &p, &f);
    }
    out
}

/// The cubic Hermite interpolant of step j at time t from its end states and slopes: an RK4 trajectory's
/// dense output. Its error, h^4 |x''''| / 384, is of the scheme's own order and below the global error of
/// the nodes (which gather the local errors of about 1 / (zeta w h) steps), so the printed quantities keep
/// fourth order and the comparison of two resolutions still estimates their error.
pub(super) fn hermite(grid: &rk4::Grid, states: &[f64], slopes: &NodeSlopes, j: usize, t: f64, x: &mut [f64]) {
    let n = x.len();
    let (ta, tb) = (grid.nodes[j], grid.nodes[j + 1]);
    let h = tb - ta;
    let s = ((t - ta) / h).clamp(0.0, 1.0);
    let (s2, s3) = (s * s, s * s * s);
    let (h00, h10, h01, h11) = (2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, 3.0 * s2 - 2.0 * s3, s3 - s2);
    for (c, out) in x.iter_mut().enumerate() {
        *out = h00 * states[j * n + c]
            + h01 * states[(j + 1) * n + c]
            + h * (h10 * slopes.start[j * n + c] + h11 * slopes.end[j * n + c]);
    }
}

/// Z_k = sum_i v_i e^{-i k w t_i}, k = 0..=kmax: each point's phasor advanced by one multiplication per
/// harmonic, in four independent lanes of separate real and imaginary parts (so the loop runs at the
/// multipliers' throughput and vectorises).
pub(super) fn phasor_sums(values: &[f64], times: &[f64], omega: f64, kmax: usize) -> Vec<C64> {
    let m = values.len();
    let (mut cr, mut ci): (Vec<f64>, Vec<f64>) =
        times.iter().map(|t| (omega * t).sin_cos()).map(|(s, c)| (c, -s)).unzip();
    let (mut er, mut ei) = (values.to_vec(), vec![0.0; m]);
    // padded to a multiple of four with zero values (their phasors stay zero)
    let padded = m.div_ceil(4) * 4;
    for v in [&mut cr, &mut ci, &mut er, &mut ei] {
        v.resize(padded, 0.0);
    }
    let mut lines = Vec::with_capacity(kmax + 1);
    for _ in 0..=kmax {
        let (mut sr, mut si) = ([0.0f64; 4], [0.0f64; 4]);
        for (((a, b), c), d) in
            er.chunks_exact_mut(4).zip(ei.chunks_exact_mut(4)).zip(cr.chunks_exact(4)).zip(ci.chunks_exact(4))
        {
            for l in 0..4 {
                let (x, y) = (a[l], b[l]);
                sr[l] += x;
                si[l] += y;
                a[l] = x * c[l] - y * d[l];
                b[l] = x * d[l] + y * c[l];
            }
        }
        lines.push(C64::new((sr[0] + sr[1]) + (sr[2] + sr[3]), (si[0] + si[1]) + (si[2] + si[3])));
    }
    lines
}

/// M_p(phi) = int_0^1 s^p e^{-i phi s} ds for p = 0..=3: the series for |phi| < 1.5 (no cancellation), else
/// integration by parts upwards, M_0 = (1 - e^{-i phi}) / (i phi), M_p = (p M_{p-1} - e^{-i phi}) / (i phi).
pub(super) fn power_moments(phi: f64) -> [C64; 4] {
    let mut out = [C64::new(0.0, 0.0); 4];
    if phi.abs() < 1.5 {
        // (-i phi)^j / j! until far below rounding (|phi|^30 / 30! < 1e-26)
        let mut term = C64::new(1.0, 0.0);
        for j in 0..30 {
            for (p, o) in out.iter_mut().enumerate() {
                *o += term / (j + p + 1) as f64;
            }
            term *= C64::new(0.0, -phi) / (j + 1) as f64;
        }
    } else {
        let e = C64::from_polar(1.0, -phi);
        let i_phi = C64::new(0.0, phi);
        out[0] = (C64::new(1.0, 0.0) - e) / i_phi;
        for p in 1..4 {
            out[p] = (out[p - 1] * p as f64 - e) / i_phi;
        }
    }
    out
}

/// Exact lines, RMS and extremes of a linear probe along the cubic Hermite dense output of an rk4 trajectory
/// (the same dense output as [`gauss_response`]): on each step z(t_j + h s) = a0 + a1 s + a2 s^2 + a3 s^3 from
/// the probe and its slope c . x' at both ends, so
/// - RMS: int z^2 in closed form per step;
/// - extremes: the step ends and the roots of the quadratic z' inside;
/// - lines: on a run of equal steps, int_0^1 z(s) e^{-i phi s} ds (phi = k w h) is a combination of the four
///   moments M_p(phi) of the Hermite basis, so Z_k needs only two phasor sums over the run's nodes (of z and
///   of h z'), not one per quadrature point.
///
/// `None` when the grid has more than one run per 16 steps (a table of many short pieces), where the
/// per-run moments would cost more than quadrature.
#[allow(clippy::too_many_arguments)]
pub(super) fn hermite_response(
    sys: &dyn PeriodicSystem,
    grid: &rk4::Grid,
    states: &[f64],
    probe: &Probe,
    kmax: usize,
    period_s: f64,
    d: &[f64],
) -> Option<Response> {
    let n = sys.dim();
    let m = grid.steps();
    let period = sys.period_s();
    let breaks = rk4::sorted_breaks(sys);
    // runs of equal steps with no jump of the coefficients inside: [first step, end step)
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut first = 0;
    for j in 1..=m {
        let h0 = grid.nodes[first + 1] - grid.nodes[first];
        let split = j == m
            || rk4::is_break(&breaks, grid.nodes[j], period)
            || ((grid.nodes[j + 1] - grid.nodes[j]) - h0).abs() > 1e-9 * h0;
        if split {
            runs.push((first, j));
            first = j;
        }
    }
    if 16 * runs.len() > m.max(16) {
        return None;
    }
    let slopes = node_slopes(sys, grid, states, probe);
    let dot = |v: &[f64]| probe.weights.iter().zip(v).map(|(w, x)| w * x).sum::<f64>();
    let zd_start: Vec<f64> = slopes.start.chunks(n).map(dot).collect();
    let zd_end: Vec<f64> = slopes.end.chunks(n).map(dot).collect();
    // RMS and extremes step by step
    let (mut square, mut max, mut min) = (0.0, f64::NEG_INFINITY, f64::INFINITY);
    for j in 0..m {
        let h = grid.nodes[j + 1] - grid.nodes[j];
        let (z0, z1, d0, d1) = (slopes.z_start[j], slopes.z_end[j], h * zd_start[j], h * zd_end[j]);
        let a = [z0, d0, 3.0 * (z1 - z0) - 2.0 * d0 - d1, 2.0 * (z0 - z1) + d0 + d1];
        let mut integral = 0.0;
        for p in 0..4 {
            for q in 0..4 {
                integral += a[p] * a[q] / (p + q + 1) as f64;
            }
        }
        square += h * integral;
        let at = |s: f64| a[0] + s * (a[1] + s * (a[2] + s * a[3]));
        let mut consider = |v: f64| {
            max = f64::max(max, v);
            min = f64::min(min, v);
        };
        consider(z0);
        consider(z1);
        // z'(s) / 1 = a1 + 2 a2 s + 3 a3 s^2
        let (qa, qb, qc) = (3.0 * a[3], 2.0 * a[2], a[1]);
        if qa.abs() > 1e-300 {
            let disc = qb * qb - 4.0 * qa * qc;
            if disc >= 0.0 {
                // the stable pair of roots: q = -(b + sign(b) sqrt(disc)) / 2, s = q / a and c / q
                let q = -0.5 * (qb + qb.signum() * disc.sqrt());
                for s in [q / qa, if q != 0.0 { qc / q } else { f64::NAN }] {
                    if s > 0.0 && s < 1.0 {
                        consider(at(s));
                    }
                }
            }
        } else if qb.abs() > 1e-300 {
            let s = -qc / qb;
            if s > 0.0 && s < 1.0 {
                consider(at(s));
            }
        }
    }
    // lines, run by run
    let omega = 2.0 * std::f64::consts::PI / period_s;
    let mut lines = vec![C64::new(0.0, 0.0); kmax + 1];
    for &(j0, j1) in &runs {
        let steps = j1 - j0;
        let h = (grid.nodes[j1] - grid.nodes[j0]) / steps as f64;
        // node values of the run: z_i and h z'_i (the right slope, the left one at the run's last node)
        let times = &grid.nodes[j0..=j1];
        let mut zv: Vec<f64> = slopes.z_start[j0..j1].to_vec();
        zv.push(slopes.z_end[j1 - 1]);
        let mut dv: Vec<f64> = zd_start[j0..j1].iter().map(|v| h * v).collect();
        dv.push(h * zd_end[j1 - 1]);
        let sz = phasor_sums(&zv, times, omega, kmax);
        let sd = phasor_sums(&dv, times, omega, kmax);
        // phasors of the run's end nodes, advanced harmonic by harmonic
        let (r0, r1) = (C64::from_polar(1.0, -omega * times[0]), C64::from_polar(1.0, -omega * times[steps]));
        let (mut e0, mut e1) = (C64::new(1.0, 0.0), C64::new(1.0, 0.0));
        let (z_first, z_last, d_first, d_last) = (zv[0], zv[steps], dv[0], dv[steps]);
        for (k, line) in lines.iter_mut().enumerate() {
            let phi = k as f64 * omega * h;
            let mo = power_moments(phi);
            // the Hermite basis h00, h01, h10, h11 against e^{-i phi s}
            let ba = mo[3] * 2.0 - mo[2] * 3.0 + mo[0];
            let bb = mo[2] * 3.0 - mo[3] * 2.0;
            let bc = mo[3] - mo[2] * 2.0 + mo[1];
            let bd = mo[3] - mo[2];
            let shift = C64::from_polar(1.0, phi);
            let z_lo = sz[k] - e1 * z_last; // nodes 0..K-1
            let z_hi = sz[k] - e0 * z_first; // nodes 1..K
            let d_lo = sd[k] - e1 * d_last;
            let d_hi = sd[k] - e0 * d_first;
            *line += (ba * z_lo + bb * shift * z_hi + bc * d_lo + bd * shift * d_hi) * (h / period_s);
            e0 *= r0;
            e1 *= r1;
        }
    }
    let gain = row_gain(&probe.row(&DMatrix::zeros(n, n), &DVector::zeros(n)), d) * balanced_scale(states, d);
    Some(Response { lines, rms: (square / period_s).max(0.0).sqrt(), max, min, gain, extreme_slack: 0.0 })
}

#[allow(clippy::too_many_arguments)]
pub(super) fn gauss_response(
    sys: &dyn PeriodicSystem,
    grid: &rk4::Grid,
    states: &[f64],
    scheme: rk4::Scheme,
    probe: &Probe,
    kmax: usize,
    period_s: f64,
    d: &[f64],
    tolerance: f64,
) -> Response {
    let n = sys.dim();
    let omega = 2.0 * std::f64::consts::PI / period_s;
    let rate = crate::solver::max_rate(sys);
    let theta = phase_per_interval(tolerance);
    let band = rate + omega * (kmax.max(sys.max_harmonic()) as f64);
    // per step: the start node, the Gauss points of its sub-intervals, the end node
    let mut times = Vec::new();
    let mut weights = Vec::new();
    let mut owner = Vec::new();
    for (j, w) in grid.nodes.windows(2).enumerate() {
        let h = w[1] - w[0];
        let q = ((h * band / theta).ceil() as usize).max(1);
        let hs = h / q as f64;
        for s in 0..q {
            let mid = w[0] + (s as f64 + 0.5) * hs;
            for (x, g) in GAUSS_NODES.iter().zip(GAUSS_WEIGHTS) {
                times.push(mid + 0.5 * hs * x);
                weights.push(0.5 * hs * g);
                owner.push(j);
            }
        }
    }
    let slopes = node_slopes(sys, grid, states, probe);
    // the dense output: cubic Hermite on the nodes for rk4 (no evaluation of P), a partial step of the
    // scheme from the node before for magnus4 (A-stable steps can be far longer than 1 / |lambda|, where a
    // cubic through the ends would miss the fast transients inside the step)
    let hermite_output = scheme == rk4::Scheme::Rk4;
    let mut xs = Vec::new();
    if hermite_output {
        xs.resize(times.len() * n, 0.0);
        for (i, (&t, &j)) in times.iter().zip(&owner).enumerate() {
            hermite(grid, states, &slopes, j, t, &mut xs[i * n..(i + 1) * n]);
        }
    } else {
        grid_states(sys, grid, states, scheme, &times, &mut xs);
    }
    let (mut p, mut f) = (DMatrix::zeros(n, n), DVector::zeros(n));
    let mut gain_row: f64 = 0.0;
    let mut zs = Vec::with_capacity(times.len());
    for (i, &t) in times.iter().enumerate() {
        if probe.derivative {
            sys.eval(t, Side::Right, &mut p, &mut f);
            gain_row = gain_row.max(row_gain(&probe.row(&p, &f), d));
        }
        zs.push(probe.value(&xs[i * n..(i + 1) * n], &p, &f));
    }
    if !probe.derivative {
        gain_row = row_gain(&probe.row(&p, &f), d);
    }
    let scaled: Vec<f64> = zs.iter().zip(&weights).map(|(z, w)| z * w / period_s).collect();
    let lines = phasor_sums(&scaled, &times, omega, kmax);
    let rms = (zs.iter().zip(&weights).map(|(z, w)| z * z * w).sum::<f64>() / period_s).max(0.0).sqrt();
    // segments per step: start node (right limit), the Gauss points, end node (left limit)
    let mut segments = Vec::with_capacity(grid.steps());
    let mut at = 0;
    for (j, w) in grid.nodes.windows(2).enumerate() {
        let mut ts = vec![w[0]];
        let mut vs = vec![slopes.z_start[j]];
        while at < owner.len() && owner[at] == j {
            ts.push(times[at]);
            vs.push(zs[at]);
            at += 1;
        }
        ts.push(w[1]);
        vs.push(slopes.z_end[j]);
        segments.push(Segment { ts, zs: vs, curvature: None });
    }
    let value = |j: usize, t: f64| {
        let mut x = states[j * n..(j + 1) * n].to_vec();
        if hermite_output {
            hermite(grid, states, &slopes, j, t, &mut x);
        } else if t > grid.nodes[j] {
            let mut st = rk4::Stepper::with_scheme(sys, scheme);
            st.step(grid.nodes[j], t, &mut x, &[1.0], false);
        }
        let (mut p, mut f) = (DMatrix::zeros(n, n), DVector::zeros(n));
        if probe.derivative {
            sys.eval(t, if t >= grid.nodes[j + 1] { Side::Left } else { Side::Right }, &mut p, &mut f);
        }
        probe.value(&x, &p, &f)
    };
    let (max, min, slack, _) = extremes(&segments, &value, MAX_CANDIDATES);
    let gain = gain_row * balanced_scale(states, d);
    Response { lines, rms, max, min, gain, extreme_slack: slack }
}
