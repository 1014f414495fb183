//! Harmonic balance (Hill's method) for linear periodic second-order systems.
//!
//! ```text
//! M(t) y'' + C(t) y' + K(t) y = d(t),  all Fourier series of w = 2 pi / T
//! y(t) = sum_{n=-H..H} Y_n exp(i n w t)
//! harmonic n:  sum_m [ -(m w)^2 M_{n-m} + i m w C_{n-m} + K_{n-m} ] Y_m = D_n
//! ```
//! Coefficient harmonics k couple Y_m to Y_{m+k}; if every k is a multiple of g, the harmonics split into
//! g independent residue classes (n mod g), each a banded system of half-bandwidth (h_c / g) blocks. The gear
//! over one pinion revolution has g = 14 (mesh harmonics only) and over the hunting period g = 546: each
//! class is then tiny. Spectrally accurate for smooth coefficients; H grows until the estimated truncation
//! error is below the tolerance: the first-order error of the dropped harmonics (the residual beyond H
//! solved on a ring of 2 h_c harmonics, fed back inside through the class's own factors), else the change
//! of the solution between successive H. Where the diagonal blocks dominate beyond a truncation, the H to
//! solve is predicted from a smaller solution continued outward by forward substitution, so a gear pair
//! needs one small and one final solve instead of a ladder.

use super::SolverError;
use super::band::{Band, solve_refined};
use super::companion::companion_monodromy;
use super::floquet::{Floquet, floquet_warnings};
use super::steady::{SteadyState, Trajectory};
use super::{Method, RK4_STABILITY_LIMIT, SolverOptions};
use crate::system::FourierForm;
use crate::system::PeriodicSystem;
use crate::system::gcd;
use nalgebra::Complex;
use nalgebra::{DMatrix, DVector};

type C64 = Complex<f64>;

/// Complex Fourier coefficients of each entry: `coef[e][k + h]` for k in -h..=h.
struct Coefficients {
    h: usize,
    mass: Vec<Vec<C64>>,
    damping: Vec<Vec<C64>>,
    stiffness: Vec<Vec<C64>>,
}

fn complex(s: &crate::system::FourierSeries, h: usize) -> Vec<C64> {
    let c = s.complex_coefficients();
    let hs = s.harmonics();
    (0..=2 * h)
        .map(|i| {
            let k = i as isize - h as isize;
            if k.unsigned_abs() <= hs {
                C64::new(c[(k + hs as isize) as usize].0, c[(k + hs as isize) as usize].1)
            } else {
                C64::new(0.0, 0.0)
            }
        })
        .collect()
}

/// The periodic solution as Fourier coefficients of y (`coeffs[i][n + H]` for DOF i, harmonic n).
#[derive(Clone, Debug)]
pub struct HillSolution {
    /// Base angular frequency w in rad/s.
    pub omega: f64,
    /// Truncation order H.
    pub harmonics: usize,
    /// Y_n per DOF.
    pub coeffs: Vec<Vec<C64>>,
    /// Coupling stride g (gcd of the coefficient harmonics).
    pub stride: usize,
}

impl HillSolution {
    /// Complex Fourier coefficient X_c(k), k >= 0, of state component c (c < N: y_c; c >= N: y'_{c-N} =
    /// i k w Y_{c-N}(k)), so that x_c(t) = Re X_c(0) + 2 Re sum_k X_c(k) e^{i k w t}. Zero beyond H.
    pub fn coefficient(&self, c: usize, k: usize) -> Complex<f64> {
        let n = self.coeffs.len();
        if k > self.harmonics || c >= 2 * n {
            return Complex::new(0.0, 0.0);
        }
        let y = self.coeffs[c % n][self.harmonics + k];
        if c < n { y } else { y * Complex::new(0.0, k as f64 * self.omega) }
    }

    /// State [y; y'] at time t.
    pub fn state(&self, t: f64, out: &mut [f64]) {
        let n = self.coeffs.len();
        let h = self.harmonics as isize;
        let (s1, c1) = (self.omega * t).sin_cos();
        let e1 = C64::new(c1, s1);
        for i in 0..n {
            let y = &self.coeffs[i];
            let (mut acc_y, mut acc_v) = (y[h as usize].re, 0.0);
            let mut e = C64::new(1.0, 0.0);
            for k in 1..=h {
                e *= e1;
                let (p, m) = (y[(h + k) as usize], y[(h - k) as usize]);
                let term = p * e + m * e.conj();
                acc_y += term.re;
                let kw = k as f64 * self.omega;
                acc_v += (C64::new(0.0, kw) * (p * e - m * e.conj())).re;
            }
            out[i] = acc_y;
            out[n + i] = acc_v;
        }
    }
}

/// Solves the harmonic-balance system with truncation order `h_trunc`; returns the solution and the
/// relative size of its iterative-refinement correction (the rounding error of the solve, in the measure of
/// [`difference`]).
///
/// # Errors
/// [`SolverError::Singular`] when a class system is singular (a harmonic in resonance).
pub fn solve_order(form: &FourierForm, h_trunc: usize) -> Result<(HillSolution, f64), SolverError> {
    solve_order_with(form, h_trunc, true, false).map(|(s, r, _)| (s, r))
}

/// The harmonic-balance operator of `form` split into its independent residue classes.
struct Classes {
    nd: usize,
    w: f64,
    co: Coefficients,
    stride: usize,
    /// gcd of the coefficient harmonics present (0 when none: then every harmonic is its own class).
    g: usize,
    band_blocks: usize,
    h: isize,
    /// Per entry e = i N + l: whether M_e or C_e has a harmonic besides the mean.
    varying: Vec<bool>,
    /// Per entry e: sum over k != 0 of |K_e,k|, |M_e,k| and |C_e,k| (bounds of the coupling between
    /// harmonics).
    coupling: Vec<[f64; 3]>,
}

impl Classes {
    fn new(form: &FourierForm, h_trunc: usize) -> Self {
        let hc = form.mass.iter().chain(&form.damping).chain(&form.stiffness).map(|s| s.harmonics()).max().unwrap_or(0);
        let co = Coefficients {
            h: hc,
            mass: form.mass.iter().map(|s| complex(s, hc)).collect(),
            damping: form.damping.iter().map(|s| complex(s, hc)).collect(),
            stiffness: form.stiffness.iter().map(|s| complex(s, hc)).collect(),
        };
        // coupling stride: gcd of the harmonic indices present in M, C, K
        let mut g = 0usize;
        for k in 1..=hc {
            let present = co.mass.iter().chain(&co.damping).chain(&co.stiffness).any(|c| c[hc + k].norm_sqr() > 0.0);
            if present {
                g = gcd(g, k);
            }
        }
        let stride = if g == 0 { 2 * h_trunc + 1 } else { g };
        let varying = co
            .mass
            .iter()
            .zip(&co.damping)
            .map(|(m, c)| (0..=2 * hc).any(|k| k != hc && (m[k].norm_sqr() > 0.0 || c[k].norm_sqr() > 0.0)))
            .collect();
        let off = |c: &[C64]| (0..=2 * hc).filter(|&k| k != hc).map(|k| c[k].norm_sqr().sqrt()).sum::<f64>();
        let coupling =
            (0..co.mass.len()).map(|e| [off(&co.stiffness[e]), off(&co.mass[e]), off(&co.damping[e])]).collect();
        Self {
            nd: form.dof,
            w: 2.0 * std::f64::consts::PI / form.period_s,
            coupling,
            co,
            stride,
            g,
            band_blocks: hc.checked_div(g).unwrap_or(0),
            h: h_trunc as isize,
            varying,
        }
    }

    /// The same operator truncated at H = `h_trunc` instead.
    fn set_truncation(&mut self, h_trunc: usize) {
        self.h = h_trunc as isize;
        self.stride = if self.g == 0 { 2 * h_trunc + 1 } else { self.g };
    }

    /// Harmonics of class r within [-H, H] (Y_{-n} = conj(Y_n): only r <= g / 2 is ever solved).
    fn members(&self, r: usize) -> Vec<isize> {
        let (h, g) = (self.h, self.stride as isize);
        // the first n >= -H with n = r (mod g), found by one remainder (a scan from -H cost a division per
        // harmonic: 1.5 ms per pass over the hunting period's 274 classes)
        let first = -h + (r as isize + h).rem_euclid(g);
        (0..).map(|j| first + j * g).take_while(|n| *n <= h).collect()
    }

    fn count(&self) -> usize {
        self.stride.min(2 * self.h as usize + 1)
    }

    /// The band matrix of one class: row n, column m holds -(m w)^2 M_{n-m} + i m w C_{n-m} + K_{n-m}.
    /// Built column by column (contiguous in the band storage); a mass or damping entry that is constant
    /// (the gear pair's) only touches the diagonal blocks.
    fn matrix(&self, members: &[isize]) -> Band {
        let (nd, m, hc) = (self.nd, members.len(), self.co.h);
        let bw = (self.band_blocks + 1) * nd - 1;
        let mut a = Band::new(m * nd, bw, bw);
        let (co, varying) = (&self.co, &self.varying);
        for (jc, &nc) in members.iter().enumerate() {
            let wn = nc as f64 * self.w;
            let lo = jc.saturating_sub(self.band_blocks);
            let hi = (jc + self.band_blocks).min(m - 1);
            for l in 0..nd {
                for (jr, &nr) in members.iter().enumerate().take(hi + 1).skip(lo) {
                    let kk = (nr - nc + hc as isize) as usize;
                    for i in 0..nd {
                        let e = i * nd + l;
                        let mut v = co.stiffness[e][kk];
                        if kk == hc || varying[e] {
                            v += co.mass[e][kk] * (-wn * wn) + co.damping[e][kk] * C64::new(0.0, wn);
                        }
                        a.add(jr * nd + i, jc * nd + l, v);
                    }
                }
            }
        }
        a
    }

    /// Entry (row harmonic nr, DOF i; column harmonic nc, DOF l) of the operator, for any harmonics (inside
    /// the truncation or not): -(nc w)^2 M_{nr-nc} + i nc w C_{nr-nc} + K_{nr-nc}.
    fn entry(&self, nr: isize, nc: isize, i: usize, l: usize) -> C64 {
        let hc = self.co.h as isize;
        if (nr - nc).abs() > hc {
            return C64::new(0.0, 0.0);
        }
        let kk = (nr - nc + hc) as usize;
        let e = i * self.nd + l;
        let wn = nc as f64 * self.w;
        let mut v = self.co.stiffness[e][kk];
        if kk == self.co.h || self.varying[e] {
            v += self.co.mass[e][kk] * (-wn * wn) + self.co.damping[e][kk] * C64::new(0.0, wn);
        }
        v
    }

    /// r -= L_nm y for the block (row harmonic n, column harmonic m) and `y` the nd values of harmonic m:
    /// [`Classes::entry`] with the block's index and frequency computed once.
    #[inline]
    fn couple(&self, n: isize, m: isize, y: &[C64], r: &mut [C64]) {
        let hc = self.co.h as isize;
        if (n - m).abs() > hc {
            return;
        }
        let kk = (n - m + hc) as usize;
        let wm = m as f64 * self.w;
        let (mass, damp) = (C64::new(-wm * wm, 0.0), C64::new(0.0, wm));
        let nd = self.nd;
        for (i, ri) in r.iter_mut().enumerate() {
            for (l, yl) in y.iter().enumerate() {
                let e = i * nd + l;
                let mut v = self.co.stiffness[e][kk];
                if kk == self.co.h || self.varying[e] {
                    v += self.co.mass[e][kk] * mass + self.co.damping[e][kk] * damp;
                }
                *ri -= v * yl;
            }
        }
    }

    /// r -= sum_j L_{n m_j} x_j over the class members m_j = `members[j]`, j in `js` (`x`: nd values per
    /// member): [`Classes::couple`] for a row of blocks. One DOF with constant mass and damping (the gear
    /// pair) couples through K alone off the diagonal: a dot product with the stiffness coefficients.
    fn couple_row(&self, n: isize, members: &[isize], js: std::ops::Range<usize>, x: &[C64], r: &mut [C64]) {
        let nd = self.nd;
        if nd == 1 && !self.varying[0] {
            let (k, hc) = (&self.co.stiffness[0], self.co.h as isize);
            let mut acc = C64::new(0.0, 0.0);
            for (&m, xj) in members[js.clone()].iter().zip(&x[js]) {
                acc += if m == n { self.entry(n, n, 0, 0) } else { k[(n - m + hc) as usize] } * xj;
            }
            r[0] -= acc;
            return;
        }
        for j in js {
            self.couple(n, members[j], &x[j * nd..(j + 1) * nd], r);
        }
    }

    /// b_j -= L_{m_j n} e for the class members m_j = `members[j]`, j in `js` (`b`: nd values per member,
    /// `e` the nd values of harmonic n): [`Classes::couple`] for a column of blocks, with the fast path of
    /// [`Classes::couple_row`].
    fn couple_column(&self, n: isize, members: &[isize], js: std::ops::Range<usize>, e: &[C64], b: &mut [C64]) {
        let nd = self.nd;
        if nd == 1 && !self.varying[0] {
            let (k, hc) = (&self.co.stiffness[0], self.co.h as isize);
            for (&m, bj) in members[js.clone()].iter().zip(&mut b[js]) {
                *bj -= if m == n { self.entry(n, n, 0, 0) } else { k[(m - n + hc) as usize] } * e[0];
            }
            return;
        }
        for j in js {
            self.couple(members[j], n, e, &mut b[j * nd..(j + 1) * nd]);
        }
    }

    /// Appends the inverse of the diagonal block L_nn (column-major) to `out`; returns delta(n): |L_nn^-1| times a bound on the
    /// sum of every off-diagonal block |L_no| of row n (infinity norms), from the coefficients' sums:
    /// |L_no| <= |K_k| + (o w)^2 |M_k| + |o w| |C_k| with |o| <= |n| + hc. `None` when L_nn is singular.
    fn dominance(&self, n: isize, out: &mut Vec<C64>) -> Option<f64> {
        let nd = self.nd;
        let at = out.len();
        // one division for one DOF
        if nd == 1 {
            out.push(C64::new(1.0, 0.0) / self.entry(n, n, 0, 0));
        } else {
            let diag = DMatrix::from_fn(nd, nd, |i, l| self.entry(n, n, i, l));
            out.extend_from_slice(diag.try_inverse()?.as_slice());
        }
        let inv = &out[at..];
        if inv.iter().any(|v| !v.re.is_finite() || !v.im.is_finite()) {
            return None;
        }
        let abs = |z: C64| z.norm_sqr().sqrt();
        let inv_norm = (0..nd).map(|i| (0..nd).map(|l| abs(inv[i + l * nd])).sum::<f64>()).fold(0.0, f64::max);
        let ow = (n.abs() + self.co.h as isize) as f64 * self.w;
        let coupling = (0..nd)
            .map(|i| {
                (0..nd)
                    .map(|l| {
                        let [k, m, c] = self.coupling[i * nd + l];
                        k + ow * ow * m + ow * c
                    })
                    .sum::<f64>()
            })
            .fold(0.0, f64::max);
        Some(inv_norm * coupling)
    }

    /// The smallest n0 >= 1 such that every harmonic n0 < n <= `up_to` has a dominant diagonal block
    /// (delta(n) < 1/2, see [`Classes::dominance`]): beyond a truncation at n0 the continuation of
    /// [`Classes::extend`] holds. `None` when harmonic `up_to` itself is not dominant.
    fn dominant_from(&self, up_to: isize) -> Option<isize> {
        let mut inv = Vec::new();
        let mut dominant = |n: isize| {
            inv.clear();
            self.dominance(n, &mut inv).is_some_and(|d| d < 0.5)
        };
        let mut n0 = up_to;
        while n0 >= 1 && dominant(n0) {
            n0 -= 1;
        }
        (n0 < up_to).then_some(n0.max(1))
    }

    /// First-order truncation error of one class solution `x` (the class's `members`, factors `lu`):
    /// the harmonics beyond H that the truncation drops answer the residual R_n = sum_m L_nm Y_m - D_n
    /// (H < |n| <= H + hc), e_out = -L_out^-1 R. Where the outside block is dominated by its diagonal
    /// blocks (delta < 1/2, the gear pair) e_n = -L_nn^-1 R_n; else (a cam's varying mass couples the
    /// outside harmonics as strongly as their diagonal) e_out is solved exactly on a ring of 2 hc harmonics
    /// on each side (its own band system). They feed back inside through the coupling,
    /// e_in = -L_in^-1 B e_out (the class's own factors: a nearly resonant class amplifies it as it
    /// amplifies everything). Adds sum_n |e_n| (and times |n| w, for velocities) per DOF to `sums`, with
    /// `weight` 2 for a class standing for its mirror too, and e into `corr` (harmonics -H - 2 hc..=
    /// H + 2 hc). Returns delta: |L_nn^-1| times the sum of |L_nn'| over the other outside n', the
    /// largest over H < |n| <= H + hc (infinite when a block or ring is singular).
    #[allow(clippy::too_many_arguments)]
    fn tail(
        &self,
        members: &[isize],
        x: &[C64],
        lu: &Band,
        pivots: &[usize],
        forcing: &[Vec<C64>],
        hf: usize,
        weight: f64,
        sums: &mut [[f64; 2]],
        corr: &mut [Vec<C64>],
    ) -> f64 {
        let (nd, g, hc, h) = (self.nd, self.stride as isize, self.co.h as isize, self.h);
        if hc == 0 || members.is_empty() {
            return 0.0;
        }
        let h2 = h + 2 * hc;
        let zero = C64::new(0.0, 0.0);
        // |z| without hypot (the magnitudes here are far from overflow)
        let abs = |z: C64| z.norm_sqr().sqrt();
        // the members within hc of harmonic n (members[j] = members[0] + j g)
        let near = |n: isize| {
            let (m0, last) = (members[0], members.len() as isize - 1);
            let lo = (n - hc - m0 + g - 1).div_euclid(g).max(0);
            let hi = (n + hc - m0).div_euclid(g).min(last);
            if lo > hi { 0..0 } else { lo as usize..hi as usize + 1 }
        };
        let r0 = members[0].rem_euclid(g);
        let first_pos = h + 1 + (r0 - (h + 1)).rem_euclid(g);
        let last_neg = -h - 1 - (-h - 1 - r0).rem_euclid(g);
        let rings: [Vec<isize>; 2] = [
            (0..).map(|j| first_pos + j * g).take_while(|n| *n <= h2).collect(),
            (0..).map(|j| last_neg - j * g).take_while(|n| *n >= -h2).collect(),
        ];
        // residuals (negated) on the rings, zero beyond H + hc; the diagonal blocks' inverses and delta
        let mut delta: f64 = 0.0;
        let mut rs: Vec<Vec<C64>> = Vec::with_capacity(2);
        let mut inverses: Vec<Vec<C64>> = Vec::with_capacity(2);
        for ring in &rings {
            let mut r = vec![zero; ring.len() * nd];
            let mut inv_ring = Vec::new();
            for (jr, &n) in ring.iter().enumerate().take_while(|(_, n)| n.abs() <= h + hc) {
                self.couple_row(n, members, near(n), x, &mut r[jr * nd..(jr + 1) * nd]);
                if n.unsigned_abs() <= hf {
                    for i in 0..nd {
                        r[jr * nd + i] += forcing[i][(n + hf as isize) as usize];
                    }
                }
                let Some(d) = self.dominance(n, &mut inv_ring) else { return f64::INFINITY };
                delta = delta.max(d);
            }
            rs.push(r);
            inverses.push(inv_ring);
        }
        let mut b = vec![zero; members.len() * nd];
        for ((ring, mut r), inv_ring) in rings.iter().zip(rs).zip(&inverses) {
            if ring.is_empty() {
                continue;
            }
            if delta < 0.5 {
                let mut e = vec![zero; nd];
                for (jr, inv) in inv_ring.chunks(nd * nd).enumerate() {
                    let rj = &mut r[jr * nd..(jr + 1) * nd];
                    for (i, ei) in e.iter_mut().enumerate() {
                        *ei = (0..nd).map(|l| inv[i + l * nd] * rj[l]).sum();
                    }
                    rj.copy_from_slice(&e);
                }
            } else {
                let mut ring_lu = self.matrix(ring);
                let Some(ring_pivots) = ring_lu.factor() else { return f64::INFINITY };
                ring_lu.solve_factored(&ring_pivots, &mut r);
            }
            for (jr, &n) in ring.iter().enumerate() {
                let e = &r[jr * nd..(jr + 1) * nd];
                if e.iter().all(|v| *v == zero) {
                    continue;
                }
                for (i, s) in sums.iter_mut().enumerate() {
                    let v = abs(e[i]);
                    s[0] += weight * v;
                    s[1] += weight * v * (n as f64 * self.w).abs();
                    corr[i][(n + h2) as usize] += e[i];
                    if weight > 1.0 {
                        corr[i][(h2 - n) as usize] += e[i].conj();
                    }
                }
                // b holds -B e_out until the solve
                self.couple_column(n, members, near(n), e, &mut b);
            }
        }
        b.iter_mut().for_each(|v| *v = -*v);
        // the inside answer to the dropped harmonics: e_in = -L_in^-1 B e_out
        lu.solve_factored(pivots, &mut b);
        for (j, &m) in members.iter().enumerate() {
            for (i, s) in sums.iter_mut().enumerate() {
                let v = abs(b[j * nd + i]);
                s[0] += weight * v;
                s[1] += weight * v * (m as f64 * self.w).abs();
                corr[i][(m + h2) as usize] -= b[j * nd + i];
                if weight > 1.0 {
                    corr[i][(h2 - m) as usize] -= b[j * nd + i].conj();
                }
            }
        }
        delta
    }

    /// Continues one class solution `x` (its `members`, within [-H, H]) beyond the truncation by forward
    /// substitution, outward on each side up to |n| <= `h_cap`:
    ///
    /// ```text
    /// Y_n = L_nn^-1 (D_n - sum_m L_nm Y_m),   m in the class, |n - m| <= hc, m between n and the inside
    /// ```
    /// (Y_m from `x` within H, from the continuation beyond). The coupling to harmonics further out is
    /// dropped: where the outside block is dominated by its diagonal blocks (delta < 1/2) that is at most a
    /// fraction delta of each, so this is the untruncated system's solution beyond H to within a factor
    /// about 1 / (1 - delta), at the cost of a band product instead of a factorization. Adds `weight` |Y_n|
    /// (and times |n| w, for velocities) per DOF to `beyond[i][|n| - H - 1]`. A side stops early once a
    /// whole band of continued harmonics is below `negligible` times the class's largest |Y_n| (the
    /// continuation falls faster than geometrically there). Returns false when a diagonal block is singular
    /// or the continuation is not finite.
    #[allow(clippy::too_many_arguments)]
    fn extend(
        &self,
        r0: isize,
        members: &[isize],
        x: &[C64],
        forcing: &[Vec<C64>],
        hf: usize,
        weight: f64,
        h_cap: isize,
        negligible: f64,
        beyond: &mut [Vec<[f64; 2]>],
    ) -> bool {
        let (nd, g, hc, h) = (self.nd, self.stride as isize, self.co.h as isize, self.h);
        if hc == 0 {
            return true;
        }
        let small = negligible * x.iter().map(|v| v.norm_sqr()).fold(0.0, f64::max).sqrt();
        let band = (hc / g).max(1) as usize;
        let zero = C64::new(0.0, 0.0);
        let (m0, last) = (members.first().copied().unwrap_or(r0), members.len() as isize - 1);
        let starts = [h + 1 + (r0 - (h + 1)).rem_euclid(g), -h - 1 - (-h - 1 - r0).rem_euclid(g)];
        for (side, start) in [1isize, -1].into_iter().zip(starts) {
            if nd == 1 && !self.varying[0] {
                if !self.extend_scalar(side, start, small, x, (forcing, hf), weight, h_cap, beyond) {
                    return false;
                }
                continue;
            }
            // continued values of this side, nd per harmonic start + side j g
            let mut ext: Vec<C64> = Vec::new();
            let mut r = vec![zero; nd];
            for j in 0.. {
                let n = start + side * j * g;
                if n.abs() > h_cap {
                    break;
                }
                r.fill(zero);
                if n.unsigned_abs() <= hf {
                    for (i, ri) in r.iter_mut().enumerate() {
                        *ri = forcing[i][(n + hf as isize) as usize];
                    }
                }
                // inside members within hc of n
                let lo = (n - hc - m0 + g - 1).div_euclid(g).max(0);
                let hi = (n + hc - m0).div_euclid(g).min(last);
                for jm in lo..=hi {
                    let jm = jm as usize;
                    self.couple(n, members[jm], &x[jm * nd..(jm + 1) * nd], &mut r);
                }
                // continued members within hc of n (those before it on this side)
                for jp in (j - hc / g).max(0)..j {
                    let at = jp as usize * nd;
                    self.couple(n, start + side * jp * g, &ext[at..at + nd], &mut r);
                }
                let at = ext.len();
                if nd == 1 {
                    ext.push(r[0] / self.entry(n, n, 0, 0));
                } else {
                    let diag = DMatrix::from_fn(nd, nd, |i, l| self.entry(n, n, i, l));
                    let Some(inv) = diag.try_inverse() else { return false };
                    ext.extend((inv * DVector::from_column_slice(&r)).iter());
                }
                let y = &ext[at..];
                if y.iter().any(|v| !v.re.is_finite() || !v.im.is_finite()) {
                    return false;
                }
                let slot = (n.abs() - h - 1) as usize;
                for (i, yi) in y.iter().enumerate() {
                    let v = yi.norm_sqr().sqrt();
                    add_beyond(&mut beyond[i], slot, weight * v, (n as f64 * self.w).abs());
                }
                if ext.len() >= band * nd && ext[ext.len() - band * nd..].iter().all(|v| v.norm_sqr().sqrt() <= small) {
                    break;
                }
            }
        }
        true
    }

    /// One side of [`Classes::extend`] for one DOF with constant mass and damping (the gear pair): the
    /// coupling is K alone, so harmonic n = start + side j g takes the band of the class's values before
    /// it (inside members, then the continuation) through K_{+-d g}, d = 1..hc / g, a strided dot product.
    #[allow(clippy::too_many_arguments)]
    fn extend_scalar(
        &self,
        side: isize,
        start: isize,
        small: f64,
        x: &[C64],
        (forcing, hf): (&[Vec<C64>], usize),
        weight: f64,
        h_cap: isize,
        beyond: &mut [Vec<[f64; 2]>],
    ) -> bool {
        let (g, hc, h) = (self.stride as isize, self.co.h as isize, self.h);
        let band = (hc / g) as usize;
        let k = &self.co.stiffness[0];
        // K_{side d g} for d = 1..band: the coupling of n to the value d places before it on this side
        let kd: Vec<C64> = (1..=band as isize).map(|d| k[(hc + side * d * g) as usize]).collect();
        // the class's values in the order of this side: inside members toward it, then the continuation
        let mut seq: Vec<C64> = if side > 0 { x.to_vec() } else { x.iter().rev().copied().collect() };
        let coupling: f64 = kd.iter().map(|k| k.norm_sqr().sqrt()).sum();
        // how many of the last values were each below the stopping bound of their own harmonic
        let mut quiet = 0;
        for j in 0.. {
            let n = start + side * j * g;
            if n.abs() > h_cap {
                break;
            }
            let r = if n.unsigned_abs() <= hf { forcing[0][(n + hf as isize) as usize] } else { C64::new(0.0, 0.0) };
            let diag = self.entry(n, n, 0, 0);
            let diag2 = diag.norm_sqr();
            let inv = diag.conj() * (1.0 / diag2);
            // the newest value's product last, the older ones in two partial sums before it: only that
            // product and the division wait for the previous harmonic (the sum's latency bounds the loop)
            let mut older = kd.iter().zip(seq.iter().rev()).skip(1);
            let (mut even, mut odd) = (r, C64::new(0.0, 0.0));
            while let Some((k1, y1)) = older.next() {
                even -= k1 * y1;
                if let Some((k2, y2)) = older.next() {
                    odd -= k2 * y2;
                }
            }
            let newest = seq.last().map_or(C64::new(0.0, 0.0), |y| kd[0] * y);
            let y = (even + odd - newest) * inv;
            let y2 = y.norm_sqr();
            if !y2.is_finite() {
                return false;
            }
            let slot = (n.abs() - h - 1) as usize;
            add_beyond(&mut beyond[0], slot, weight * y2.sqrt(), (n as f64 * self.w).abs());
            seq.push(y);
            // every later value is at most q = sum |K_dg| / |L_nn| (falling with n, so the bound below
            // grows) times the largest of the band before it, so all of them together at most q / (1 - q)
            // times the band's largest
            let q = coupling / diag2.sqrt();
            let bound = small * (1.0 - q) / q;
            quiet = if q < 1.0 && y2 <= bound * bound { quiet + 1 } else { 0 };
            if n.unsigned_abs() >= hf && q < 0.5 && quiet >= band {
                break;
            }
        }
        true
    }

    /// Right-hand side of one class from complex forcing coefficients `f[i][n + hf]`, or `None` when the
    /// class is not forced (a non-singular homogeneous class has the zero solution).
    fn rhs(&self, members: &[isize], forcing: &[Vec<C64>], hf: usize) -> Option<Vec<C64>> {
        let nd = self.nd;
        let mut rhs = vec![C64::new(0.0, 0.0); members.len() * nd];
        let mut forced = false;
        for (jr, &nr) in members.iter().enumerate() {
            if nr.unsigned_abs() > hf {
                continue;
            }
            for i in 0..nd {
                let v = forcing[i][(nr + hf as isize) as usize];
                forced |= v.norm_sqr() > 0.0;
                rhs[jr * nd + i] = v;
            }
        }
        forced.then_some(rhs)
    }

    /// Stores a class solution (and its mirror class) into per-DOF coefficient lists.
    fn store(&self, r: usize, members: &[isize], x: &[C64], coeffs: &mut [Vec<C64>]) {
        let h = self.h;
        for (j, &n) in members.iter().enumerate() {
            for (i, c) in coeffs.iter_mut().enumerate() {
                c[(n + h) as usize] = x[j * self.nd + i];
                if r != 0 && 2 * r != self.count() {
                    c[(h - n) as usize] = x[j * self.nd + i].conj();
                }
            }
        }
    }

    fn solution(&self, coeffs: Vec<Vec<C64>>) -> Result<HillSolution, SolverError> {
        if coeffs.iter().flatten().any(|c| !c.re.is_finite() || !c.im.is_finite()) {
            return Err(SolverError::NonFinite { what: "harmonic-balance solution".into() });
        }
        Ok(HillSolution { omega: self.w, harmonics: self.h as usize, coeffs, stride: self.stride })
    }
}

fn complex_forcing(forcing: &[crate::system::FourierSeries]) -> (Vec<Vec<C64>>, usize) {
    let hf = forcing.iter().map(|s| s.harmonics()).max().unwrap_or(0);
    (forcing.iter().map(|s| complex(s, hf)).collect(), hf)
}

/// [`solve_order`], with the iterative refinement only when `refine` (else the rounding returned is 0).
/// The third value is the first-order truncation error of the solution (see `Classes::tail`), in the
/// measure of [`difference`]; infinite when a ring beyond H is singular.
fn solve_order_with(
    form: &FourierForm,
    h_trunc: usize,
    refine: bool,
    want_tail: bool,
) -> Result<(HillSolution, f64, Option<Tail>), SolverError> {
    solve_order_extended(form, h_trunc, refine, want_tail, None)
}

/// What [`solve_order_extended`] continues beyond H ([`Classes::extend`]), and when.
#[derive(Clone, Copy, Debug)]
struct Extension {
    /// The highest harmonic continued to.
    h_cap: usize,
    /// A side stops where a band of its harmonics falls below this fraction of its class's largest.
    negligible: f64,
    /// No continuation when the first-order truncation error is at most this (the truncation is kept).
    unless_met: f64,
}

/// [`solve_order_with`], and with a tail that does not meet `extension.unless_met`, where the outside block
/// is diagonally dominant, the solution continued beyond H ([`Classes::extend`], in [`Tail::beyond`]).
fn solve_order_extended(
    form: &FourierForm,
    h_trunc: usize,
    refine: bool,
    want_tail: bool,
    extension: Option<Extension>,
) -> Result<(HillSolution, f64, Option<Tail>), SolverError> {
    let classes = Classes::new(form, h_trunc);
    let (forcing, hf) = complex_forcing(&form.forcing);
    solve_classes(&classes, &forcing, hf, refine, want_tail, extension)
}

/// [`solve_order_extended`] on the operator `classes` (truncated at its H) with complex forcing
/// coefficients `forcing[i][n + hf]`.
fn solve_classes(
    classes: &Classes,
    forcing: &[Vec<C64>],
    hf: usize,
    refine: bool,
    want_tail: bool,
    extension: Option<Extension>,
) -> Result<(HillSolution, f64, Option<Tail>), SolverError> {
    let h_trunc = classes.h as usize;
    let dof = classes.nd;
    let mut coeffs = vec![vec![C64::new(0.0, 0.0); 2 * h_trunc + 1]; dof];
    let mut rounding = coeffs.clone();
    let mut sums = vec![[0.0; 2]; dof];
    let mut delta: f64 = 0.0;
    let h2 = h_trunc + 2 * classes.co.h;
    let mut corr = vec![vec![C64::new(0.0, 0.0); 2 * h2 + 1]; dof];
    for r in 0..=classes.count() / 2 {
        let members = classes.members(r);
        let Some(rhs) = (!members.is_empty()).then(|| classes.rhs(&members, forcing, hf)).flatten() else {
            continue;
        };
        let (x, dx, lu, pivots) = solve_refined(classes.matrix(&members), rhs, refine).ok_or(SolverError::Singular)?;
        let weight = if r != 0 && 2 * r != classes.count() { 2.0 } else { 1.0 };
        if want_tail {
            let d = classes.tail(&members, &x, &lu, &pivots, forcing, hf, weight, &mut sums, &mut corr);
            delta = delta.max(d);
        }
        classes.store(r, &members, &x, &mut coeffs);
        classes.store(r, &members, &dx, &mut rounding);
    }
    let solution = classes.solution(coeffs)?;
    let rounding =
        if refine { relative_size(&HillSolution { coeffs: rounding, ..solution.clone() }, &solution) } else { 0.0 };
    if !want_tail {
        return Ok((solution, rounding, None));
    }
    // the factor on the first-order error: 1.25 / (1 - delta) where the outside block is dominated by its
    // diagonal (the gear scenes: the first-order error matches the true one within 1 % from 1e-4 to 1e-25
    // in this measure, fig8a, fig8b, light damping, H = 146..703); 6 where it is not (a cam's varying
    // mass, the press cases: 0.35 to 1.45 times the true error from 1e-1 to 1e-15, H = 24..118)
    let factor = if delta < 0.5 { 1.25 / (1.0 - delta) } else { 6.0 };
    let tail = if delta.is_finite() { factor * tail_size(&sums, &solution) } else { f64::INFINITY };
    // the solution plus its first-order correction, to H + 2 hc
    for (c, y) in corr.iter_mut().zip(&solution.coeffs) {
        for (k, v) in y.iter().enumerate() {
            c[k + h2 - h_trunc] += v;
        }
    }
    let corrected = HillSolution { harmonics: h2, coeffs: corr, ..solution.clone() };
    // the continuation holds only where the outside is diagonally dominant
    let beyond = extension
        .filter(|e| delta < 0.5 && e.h_cap > h_trunc && (tail > e.unless_met || tail.is_nan()))
        .and_then(|e| continuation(classes, &solution, forcing, hf, e));
    Ok((solution, rounding, Some(Tail { size: tail, factor, corrected, beyond })))
}

/// Adds `v` and `v` times `rate` (|n| w) at `slot` of a [`Tail::beyond`] list, growing it as needed.
fn add_beyond(list: &mut Vec<[f64; 2]>, slot: usize, v: f64, rate: f64) {
    if list.len() <= slot {
        list.resize(slot + 1, [0.0; 2]);
    }
    list[slot][0] += v;
    list[slot][1] += v * rate;
}

/// [`Classes::extend`] of every class of `solution` (unforced classes too: their forcing may lie beyond
/// H), into the per-DOF sums of [`Tail::beyond`]; `None` when a continuation fails.
fn continuation(
    classes: &Classes,
    solution: &HillSolution,
    forcing: &[Vec<C64>],
    hf: usize,
    e: Extension,
) -> Option<Vec<Vec<[f64; 2]>>> {
    let (nd, h) = (classes.nd, classes.h);
    // grown as the continuation reaches further (it mostly stops far below the cap)
    let mut beyond = vec![Vec::new(); nd];
    for r in 0..=classes.count() / 2 {
        let members = classes.members(r);
        let x: Vec<C64> =
            members.iter().flat_map(|&n| solution.coeffs.iter().map(move |c| c[(n + h) as usize])).collect();
        let weight = if r != 0 && 2 * r != classes.count() { 2.0 } else { 1.0 };
        if !classes.extend(r as isize, &members, &x, forcing, hf, weight, e.h_cap as isize, e.negligible, &mut beyond) {
            return None;
        }
    }
    Some(beyond)
}

/// The first-order truncation error of a harmonic-balance solution.
struct Tail {
    /// Its size in the measure of [`difference`] times the factor that makes it a bound (1.25 / (1 - delta)
    /// or 6, see [`solve_order_with`]); infinite when a ring beyond H is singular.
    size: f64,
    /// That factor: the estimate over the difference from `corrected`.
    factor: f64,
    /// The solution plus the error's first-order estimate (harmonics to H + 2 hc).
    corrected: HillSolution,
    /// The solution continued beyond H ([`Classes::extend`]): per DOF, per |n| - H - 1, the sums of |Y_n|
    /// and |n| w |Y_n|; `None` when not asked for or where the outside block is not diagonally dominant.
    beyond: Option<Vec<Vec<[f64; 2]>>>,
}

impl Tail {
    /// The smallest truncation H' > H (H = `of.harmonics`) at which the first-order truncation error is
    /// predicted to be at most `target`, from the continuation beyond H: the harmonics beyond H' weigh
    /// S(H') / size (per component, as in [`tail_size`]), and the estimate at H' is taken to keep its ratio
    /// to that weight at H (the measured estimate over S(H) / size: the inside feedback and the factor, at
    /// least 1/2). `None` without a continuation or when even its end does not meet `target`.
    fn predict(&self, of: &HillSolution, target: f64) -> Option<usize> {
        let beyond = self.beyond.as_ref()?;
        let len = beyond.iter().map(Vec::len).max()?;
        // per component and derivative: the weight beyond H + o for every offset o, over the size
        let mut worst = vec![0.0f64; len + 1];
        for (b, y) in beyond.iter().zip(&of.coeffs) {
            for deriv in 0..2 {
                let size = component_size(y, of.omega, deriv == 1);
                if size <= 0.0 {
                    continue;
                }
                let mut suffix = 0.0;
                for (row, w) in b.iter().zip(worst.iter_mut()).rev() {
                    suffix += row[deriv];
                    *w = w.max(suffix / size);
                }
            }
        }
        if worst[0].is_nan() || worst[0] <= 0.0 || !self.size.is_finite() {
            return None;
        }
        let ratio = (self.size / worst[0]).max(0.5);
        (1..len).find(|&o| ratio * worst[o] <= target).map(|o| of.harmonics + o)
    }
}

/// The per-DOF sums of [`Classes::tail`] relative to the solution's own sum_n |Y_n| (times |n| w for
/// velocities): the largest over components, as in [`relative_size`].
fn tail_size(sums: &[[f64; 2]], of: &HillSolution) -> f64 {
    let mut worst: f64 = 0.0;
    for (s, y) in sums.iter().zip(&of.coeffs) {
        for (deriv, err) in s.iter().enumerate() {
            let size = component_size(y, of.omega, deriv == 1);
            if size > 0.0 {
                worst = worst.max(err / size);
            }
        }
    }
    worst
}

/// A component's size in the measure of [`difference`]: sum_n |Y_n| over its coefficients `y` (harmonics
/// -H..=H), each times |n| w (w = `omega`, rad/s) for the velocity.
fn component_size(y: &[C64], omega: f64, velocity: bool) -> f64 {
    let h = (y.len() / 2) as f64;
    let term = |i: usize, v: &C64| v.norm_sqr().sqrt() * if velocity { ((i as f64 - h) * omega).abs() } else { 1.0 };
    // four partial sums: one sum's additions in a row bound the loop (the hunting period: 27809
    // coefficients per component, four sums per solve)
    let mut acc = [0.0; 4];
    let quads = y.chunks_exact(4);
    let rest = quads.remainder();
    for (q, quad) in quads.enumerate() {
        for (l, (a, v)) in acc.iter_mut().zip(quad).enumerate() {
            *a += term(4 * q + l, v);
        }
    }
    let done = y.len() - rest.len();
    let tail: f64 = rest.iter().enumerate().map(|(l, v)| term(done + l, v)).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// Harmonic balance of one operator (the mass, damping and stiffness of `form`; its own forcing is
/// ignored) for many forcings at truncation order `h_trunc`: each residue class is factored once and
/// solved for every right-hand side. The response to forcing j is `result[j]`.
///
/// # Errors
/// [`SolverError::Singular`] when a forced class is singular; non-finite coefficients.
pub fn solve_many(
    form: &FourierForm,
    h_trunc: usize,
    forcings: &[Vec<crate::system::FourierSeries>],
) -> Result<Vec<HillSolution>, SolverError> {
    let classes = Classes::new(form, h_trunc);
    let forcing: Vec<(Vec<Vec<C64>>, usize)> = forcings.iter().map(|f| complex_forcing(f)).collect();
    let mut coeffs = vec![vec![vec![C64::new(0.0, 0.0); 2 * h_trunc + 1]; form.dof]; forcings.len()];
    for r in 0..=classes.count() / 2 {
        let members = classes.members(r);
        if members.is_empty() {
            continue;
        }
        let rhs: Vec<Option<Vec<C64>>> = forcing.iter().map(|(f, hf)| classes.rhs(&members, f, *hf)).collect();
        if rhs.iter().all(Option::is_none) {
            continue;
        }
        let mut lu = classes.matrix(&members);
        let pivots = lu.factor().ok_or(SolverError::Singular)?;
        for (j, b) in rhs.into_iter().enumerate() {
            let Some(mut b) = b else { continue };
            lu.solve_factored(&pivots, &mut b);
            classes.store(r, &members, &b, &mut coeffs[j]);
        }
    }
    coeffs.into_iter().map(|c| classes.solution(c)).collect()
}

/// Relative difference between two solutions (the second with more harmonics): per state component, the
/// bound sum_n |dY_n| (times n w for velocities) over the component's size sum_n |Y_n|.
pub fn difference(a: &HillSolution, b: &HillSolution) -> f64 {
    let (ha, hb) = (a.harmonics as isize, b.harmonics as isize);
    let delta: Vec<Vec<C64>> = (0..a.coeffs.len())
        .map(|i| {
            (-hb..=hb)
                .map(|n| {
                    let ya = if n.abs() <= ha { a.coeffs[i][(n + ha) as usize] } else { C64::new(0.0, 0.0) };
                    b.coeffs[i][(n + hb) as usize] - ya
                })
                .collect()
        })
        .collect();
    relative_size(&HillSolution { coeffs: delta, ..b.clone() }, b)
}

/// Size of `delta` relative to `of` (same truncation): per state component, sum_n |dY_n| (times n w for
/// velocities) over sum_n |Y_n|, the largest over components; a bound on the time-domain change.
fn relative_size(delta: &HillSolution, of: &HillSolution) -> f64 {
    let mut worst: f64 = 0.0;
    for (d, y) in delta.coeffs.iter().zip(&of.coeffs) {
        for velocity in [false, true] {
            let size = component_size(y, of.omega, velocity);
            if size > 0.0 {
                worst = worst.max(component_size(d, of.omega, velocity) / size);
            }
        }
    }
    worst
}

/// Harmonic balance to a tolerance: H from h_max (at least 8) until the estimated error is below
/// `tolerance`, at most `max_harmonics`. Where the outside of a truncation is diagonally dominant, the next
/// H is predicted from the solution continued beyond a smaller one (see [`solve_compared`]); elsewhere H
/// grows by 1.25 (by 1.6 while the estimate is above 1000 times the tolerance). The estimate is the first-
/// order truncation error; where that is not at hand, the change between successive H (it bounds the error
/// of the smaller one; with two changes the geometric rate gives the larger one's, times a safety factor
/// 10). Returns the solution, its truncation error estimate and its rounding error (see [`solve_order`]).
///
/// # Errors
/// Singular classes, or the tolerance not reached.
pub fn solve(
    form: &FourierForm,
    max_harmonic: usize,
    tolerance: f64,
    max_harmonics: usize,
) -> Result<(HillSolution, f64, f64), SolverError> {
    solve_compared(form, max_harmonic, tolerance, max_harmonics).map(|r| (r.solution, r.estimate, r.rounding))
}

/// A harmonic-balance solution with the smaller truncation it was compared with.
pub struct Compared {
    /// The solution.
    pub solution: HillSolution,
    /// Its estimated truncation error ([`difference`] measure).
    pub estimate: f64,
    /// Its rounding error (see [`solve_order`]).
    pub rounding: f64,
    /// The solution it is compared with: the solution plus its first-order truncation error (to H + 2 hc,
    /// hc the coefficients' highest harmonic) where that is at hand, else the previous (smaller) truncation.
    pub previous: HillSolution,
    /// `estimate` over the difference of the two: what turns the change of any quantity between them into
    /// the solution's error.
    pub factor: f64,
}

/// [`solve`], keeping the previous truncation for estimates of derived quantities.
///
/// # Errors
/// Singular classes, or the tolerance not reached.
pub fn solve_compared(
    form: &FourierForm,
    max_harmonic: usize,
    tolerance: f64,
    max_harmonics: usize,
) -> Result<Compared, SolverError> {
    let start = max_harmonic.max(8);
    // Each truncation after the first is predicted from a solution continued beyond the previous one (a
    // band product per class, where the outside is diagonally dominant: `Tail::predict`), aiming at half
    // the tolerance, to at most 4 H (or H + 8 hc) harmonics; the prediction only chooses H, the estimate of
    // the H printed is its own first-order error. The first prediction comes from a smaller truncation,
    // where the diagonal blocks start to dominate (fig8a: 35 harmonics, then 330 at 1e-10, where growing
    // by 1.6 and 1.25 from 146 took four solves, 146-234-293-367).
    let hc = coefficient_harmonics(form);
    let target = 0.5 * tolerance;
    let extension = |h: usize| Extension {
        h_cap: (4 * h).max(h + 8 * hc).min(max_harmonics.max(h)),
        negligible: 1e-2 * target,
        unless_met: tolerance,
    };
    let mut predicted = None;
    let mut prev: Option<HillSolution> = None;
    // the operator and forcing are set up once for every truncation
    let mut classes = Classes::new(form, start);
    let (forcing, hf) = complex_forcing(&form.forcing);
    if let Some(h0) = predictor_truncation(&classes, start) {
        classes.set_truncation(h0);
        let (sol, _, tail) = solve_classes(&classes, &forcing, hf, false, true, Some(extension(h0)))?;
        predicted = tail.and_then(|t| t.predict(&sol, target)).map(|p| p.max(start));
        prev = Some(sol);
    }
    // Where the first-order truncation error (`Tail`) is at hand, it is the estimate (times its factor), and
    // the solution plus that error is the comparison (the same factor on every derived quantity's change):
    // the geometric rate of the changes below overstated the error up to 1e4x (the convergence accelerates
    // with H: press case 2 at 1e-8).
    let met = |tail: Option<Tail>| tail.filter(|t| t.size.is_finite() && t.size <= tolerance);
    // the rounding is measured once, at the first truncation that can be printed: it comes from the low,
    // nearly resonant harmonics, which every larger truncation holds alike, while the harmonics added
    // later are dominated by -(n w)^2 M and well conditioned (a refinement at every order cost 30 % of a
    // sweep)
    let mut rounding: Option<f64> = None;
    let mut last_change: Option<f64> = None;
    let mut h = start;
    let mut next_h = predicted.unwrap_or(start);
    loop {
        let refine = rounding.is_none();
        classes.set_truncation(next_h);
        let (next, r, tail) = solve_classes(&classes, &forcing, hf, refine, true, Some(extension(next_h)))?;
        let rounding = *rounding.get_or_insert(r);
        let tail_size = tail.as_ref().map(|t| t.size).filter(|v| v.is_finite());
        predicted = tail.as_ref().and_then(|t| t.predict(&next, target));
        if let Some(t) = met(tail) {
            return Ok(Compared {
                solution: next,
                estimate: t.size,
                rounding,
                previous: t.corrected,
                factor: t.factor,
            });
        }
        // without a first-order error (a ring beyond H singular): the change between successive H. Spectral
        // convergence is geometric with a rate r = change / last change per growth step: the larger H's
        // error is about change r / (1 - r); ten times that is the estimate (three times fell short by 30 %
        // on the light-damping gear). Without a rate yet (the first change) the plain change is the
        // estimate: it bounds the smaller H's error, so the larger one's too (measured 12x above the truth on
        // fig8a at 1e-6, tests/solver_matrix.rs).
        let change = prev.as_ref().filter(|p| p.harmonics >= start).map(|p| difference(p, &next));
        let est = match (tail_size, change, last_change) {
            (Some(t), _, _) => t,
            (None, Some(c), Some(l)) if c < l => {
                let r = c / l;
                (10.0 * c * r / (1.0 - r)).min(c)
            }
            (None, Some(c), _) => c,
            (None, None, _) => f64::INFINITY,
        };
        // a change at the rounding level is rounding: more harmonics cannot lower it
        if let Some(c) = change
            && (est <= tolerance || c <= 4.0 * rounding)
        {
            let factor = if c > 0.0 { est / c } else { 1.0 };
            let previous = prev.take().unwrap_or_else(|| next.clone());
            return Ok(Compared { solution: next, estimate: est, rounding, previous, factor });
        }
        last_change = change;
        if next_h >= max_harmonics {
            return Err(SolverError::ToleranceNotReached { cond: f64::NAN, tolerance, steps: next_h, estimate: est });
        }
        h = h.max(next_h);
        let growth = if est > 1e3 * tolerance { 1.6 } else { 1.25 };
        let grown = ((h as f64 * growth).ceil() as usize).max(h + 1);
        // a prediction is followed, but by at least a tenth more harmonics (its estimate was not met at H)
        next_h = predicted.map_or(grown, |p| p.max((h as f64 * 1.1).ceil() as usize).max(h + 1));
        prev = Some(next);
    }
}

/// The truncation whose continuation predicts the first one solved ([`solve_compared`]) on `classes`: where every
/// harmonic up to `start` beyond it has a dominant diagonal block, and at least the coupling stride (every
/// class has members) and 8; `None` when that is not below `start` (then `start` is solved first).
fn predictor_truncation(classes: &Classes, start: usize) -> Option<usize> {
    let n0 = classes.dominant_from(start as isize)? as usize;
    let h0 = n0.max(classes.stride).max(8);
    (h0 < start).then_some(h0)
}

/// The highest harmonic hc of the mass, damping and stiffness of `form`.
fn coefficient_harmonics(form: &FourierForm) -> usize {
    form.mass.iter().chain(&form.damping).chain(&form.stiffness).map(|s| s.harmonics()).max().unwrap_or(0)
}

/// Estimated floating-point work of harmonic balance at truncation H = `h` on `form`: the band LU of each
/// residue class (mod the coupling stride g) with N (2H + 1) / g unknowns and a band of N (2 hc / g + 1),
/// complex (x4), half the classes (conjugate symmetry), about four truncation orders tried:
/// 16 N (2H + 1) (N (2 hc / g + 1))^2. Against measured times for hc = 50..400 on one DOF: within 3x.
pub fn work_estimate(form: &FourierForm, h: usize) -> f64 {
    let hc = form.mass.iter().chain(&form.damping).chain(&form.stiffness).map(|s| s.harmonics()).max().unwrap_or(0);
    let mut g = 0usize;
    for s in form.mass.iter().chain(&form.damping).chain(&form.stiffness) {
        for k in 1..=s.harmonics() {
            if s.cos[k - 1] != 0.0 || s.sin[k - 1] != 0.0 {
                g = gcd(g, k);
            }
        }
    }
    let n = form.dof as f64;
    let band = n * (2.0 * hc as f64 / g.max(1) as f64 + 1.0);
    16.0 * n * (2.0 * h as f64 + 1.0) * band * band
}

/// Harmonic-balance steady state with multipliers from the companion monodromy.
pub(super) fn solve_steady(
    sys: &dyn PeriodicSystem,
    form: Option<FourierForm>,
    opts: &SolverOptions,
    reason: String,
    rate: f64,
) -> Result<SteadyState, SolverError> {
    let form = form.ok_or_else(|| {
        SolverError::Unsupported(
            "harmonic balance needs Fourier-series coefficients; this scene has jumps (use rk4 or auto)".into(),
        )
    })?;
    let (sol, truncation, rounding, previous, factor) = match opts.harmonics {
        Some(h) if h < sys.max_harmonic() => {
            return Err(SolverError::Unsupported(format!(
                "solver.harmonics = {h} is below the highest harmonic of the scene's coefficients ({}): the truncated system cannot represent them",
                sys.max_harmonic()
            )));
        }
        Some(h) => {
            // fixed H: its error is estimated against 1.25 H
            let (sol, rounding) = solve_order(&form, h)?;
            let (finer, _) = solve_order(&form, (h * 5).div_ceil(4).max(h + 1))?;
            let est = difference(&sol, &finer);
            (sol, est, rounding, finer, 1.0)
        }
        None => {
            let c = solve_compared(&form, sys.max_harmonic(), opts.tolerance, 1 << 20)?;
            (c.solution, c.estimate, c.rounding, c.previous, c.factor)
        }
    };
    let d = super::steady::state_scales(sys);
    let companion = companion_monodromy(sys, opts, rate, &d)?;
    let (monodromy, phi_err, companion_steps) = (companion.monodromy, companion.error, companion.steps);
    let period = sys.period_s();
    let floquet = Floquet::from_monodromy(&monodromy, period)?;
    // the companion's better (higher-order) monodromy: the change of each multiplier to it is that
    // multiplier's error (twice, as for the monodromy), whether it moves linearly or like a square root
    let better = Floquet::from_monodromy(&companion.better, period)?;
    let b = DMatrix::from_fn(sys.dim(), sys.dim(), |i, j| monodromy[(i, j)] * d[j] / d[i]);
    let departure = super::floquet::departure_from_normality(&b);
    let rho_error =
        super::floquet::multiplier_change(&floquet, &better, (2.0, 2.0), 100.0 * f64::EPSILON, departure, b.amax());
    let n = sys.dim();
    let a = DMatrix::identity(n, n) - &monodromy;
    // reported, not judged: harmonic balance never solves with I - Phi; its own system's rounding is
    // measured by the iterative-refinement correction (`rounding`)
    let cond = super::steady::scaled_condition(&a, &d);
    let mut x0 = DVector::zeros(n);
    sol.state(0.0, x0.as_mut_slice());
    let mut warnings = Vec::new();
    let floor = 100.0 * f64::EPSILON;
    let (state_error, multiplier_error) = ((truncation + rounding).max(floor), phi_err.max(floor));
    let estimate = state_error.max(multiplier_error).max(rho_error);
    let mut trusted = estimate <= opts.tolerance;
    if rounding > opts.tolerance {
        trusted = false;
        warnings.push(format!(
            "the harmonic-balance system is ill-conditioned: rounding left a relative error of {rounding:.1e} (measured by iterative refinement), above the tolerance{}",
            super::floquet::nearest_to_one(&floquet)
        ));
    }
    let mut floquet = floquet;
    floquet_warnings(&mut floquet, opts.tolerance.max(phi_err).max(rho_error), rho_error, &mut warnings);
    super::floquet::untrusted_multipliers(rho_error, opts.tolerance, &mut warnings);
    let limit = (period * rate / RK4_STABILITY_LIMIT).ceil() as usize;
    Ok(SteadyState {
        method: Method::Hill,
        reason: format!(
            "{reason}; {} harmonics in {} independent classes (coupling stride {}), multipliers from an rk4 companion of {} steps over {:.6} s",
            sol.harmonics,
            sol.stride.min(2 * sol.harmonics + 1),
            sol.stride,
            companion_steps,
            sys.homogeneous_period_s()
        ),
        period_s: period,
        resolution: sol.harmonics,
        error_estimate: estimate,
        state_error,
        multiplier_error,
        monodromy,
        floquet,
        x0,
        cond_i_minus_phi: cond,
        stability_limit_steps: limit,
        trusted,
        warnings,
        trajectory: Trajectory::Fourier(sol),
        comparison: Some(super::steady::Comparison { trajectory: Trajectory::Fourier(previous), factor }),
        rounding,
        rho_error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::system::FourierSeries;

    /// y'' + 0.05 y' + (2 + 60 cos 3t + 20 cos 6t + 10 sin 9t) y = d(t), d up to harmonic 12 (period 2 pi):
    /// coupling stride 3, hc = 9; the diagonal blocks 2 - n^2 + 0.05 i n dominate their rows' coupling
    /// (sum 90 at most) from n = 14 on.
    fn hill_form() -> FourierForm {
        let w = 1.0;
        let series = |mean: f64, cos: Vec<f64>, sin: Vec<f64>| FourierSeries::new(w, mean, cos, sin);
        let mut kc = vec![0.0; 9];
        let mut ks = vec![0.0; 9];
        kc[2] = 60.0;
        kc[5] = 20.0;
        ks[8] = 10.0;
        let mut dc = vec![0.0; 12];
        let mut ds = vec![0.0; 12];
        dc[0] = 1.0;
        ds[4] = 0.5;
        dc[10] = 0.3;
        ds[11] = 0.2;
        FourierForm {
            dof: 1,
            period_s: 2.0 * std::f64::consts::PI,
            mass: vec![series(1.0, vec![], vec![])],
            damping: vec![series(0.05, vec![], vec![])],
            stiffness: vec![series(2.0, kc, ks)],
            forcing: vec![series(0.0, dc, ds)],
        }
    }

    /// Sums over |n| > H' of |Y_n| (both signs), for H' = H..H + len.
    fn suffix(values: impl Fn(usize) -> f64, from: usize, to: usize) -> Vec<f64> {
        let mut out = vec![0.0; to - from + 1];
        let mut acc = 0.0;
        for m in (from + 1..=to).rev() {
            acc += values(m);
            out[m - from - 1] = acc;
        }
        out
    }

    #[test]
    fn the_operator_applied_matches_its_band() {
        // couple_row over a class (the tail's residual, from the coefficients) against the band matrix the
        // class solve factors, built column by column: one DOF with constant mass and damping
        // (the dot-product path), and two DOFs with a varying mass (the block path)
        let one = hill_form();
        let mut two = hill_form();
        let series = |mean: f64, cos: Vec<f64>| FourierSeries::new(1.0, mean, cos, vec![]);
        two.dof = 2;
        two.mass =
            vec![series(1.0, vec![0.0, 0.0, 0.2]), series(0.0, vec![]), series(0.1, vec![]), series(2.0, vec![])];
        two.damping = vec![series(0.05, vec![]), series(0.0, vec![]), series(0.0, vec![]), series(0.03, vec![])];
        two.stiffness = vec![
            one.stiffness[0].clone(),
            series(-0.5, vec![]),
            series(-0.5, vec![]),
            series(3.0, vec![0.0, 0.0, 1.0]),
        ];
        two.forcing = vec![one.forcing[0].clone(), one.forcing[0].clone()];
        for form in [one, two] {
            let classes = Classes::new(&form, 30);
            for r in 0..classes.count() {
                let members = classes.members(r);
                let nd = form.dof;
                let x: Vec<C64> =
                    (0..members.len() * nd).map(|i| C64::new((i as f64).sin(), (0.3 * i as f64).cos())).collect();
                let mut want = vec![C64::new(0.0, 0.0); x.len()];
                classes.matrix(&members).mul_add(&x, &mut want);
                let mut got = vec![C64::new(0.0, 0.0); x.len()];
                let band = classes.band_blocks;
                for (j, &n) in members.iter().enumerate() {
                    let js = j.saturating_sub(band)..(j + band + 1).min(members.len());
                    classes.couple_row(n, &members, js, &x, &mut got[j * nd..(j + 1) * nd]);
                }
                let scale = want.iter().map(|v| v.norm()).fold(0.0, f64::max);
                for (g, w) in got.iter().zip(&want) {
                    // the same products summed in another order: rounding of the largest entries (~1e3)
                    assert!((g + w).norm() <= 1e-12 * scale, "{nd} DOF, class {r}: {g} against -{w}");
                }
            }
        }
    }

    #[test]
    fn continuation_matches_a_larger_truncation() {
        let form = hill_form();
        let (h0, cap, big) = (20, 120, 300);
        let mut classes = Classes::new(&form, h0);
        classes.set_truncation(h0);
        let (forcing, hf) = complex_forcing(&form.forcing);
        let e = Extension { h_cap: cap, negligible: 0.0, unless_met: 0.0 };
        let (_, _, tail) = solve_classes(&classes, &forcing, hf, false, true, Some(e)).unwrap();
        let beyond = tail.unwrap().beyond.expect("dominant beyond 14: a continuation");
        // the reference: the band LU of a truncation far beyond (its own truncation error is below 1e-100 here)
        let (reference, _) = solve_order(&form, big).unwrap();
        let y = |m: usize| 2.0 * reference.coeffs[0][big + m].norm();
        let want = suffix(y, h0, cap);
        let got = suffix(|m| beyond[0][m - h0 - 1][0], h0, cap);
        for o in [0, 10, 20, 40, 60] {
            let ratio = got[o] / want[o];
            // the continuation drops the coupling to harmonics further out, a fraction delta < 1/2 of each
            // row's diagonal (delta ~ 90 / n^2 < 0.23 beyond 20), and starts from the truncated solution
            // at 20, whose own error near 20 is of the size of what it drops: within a factor 1.5
            assert!((1.0 / 1.5..=1.5).contains(&ratio), "beyond {}: {} against {}", h0 + o, got[o], want[o]);
        }
    }

    #[test]
    fn solve_compared_meets_the_tolerance_near_the_smallest_truncation() {
        let form = hill_form();
        let tol = 1e-10;
        let c = solve_compared(&form, 12, tol, 1 << 12).unwrap();
        assert!(c.estimate <= tol);
        // the true error against a truncation far beyond, in the same measure
        let (reference, _) = solve_order(&form, 400).unwrap();
        let truth = difference(&c.solution, &reference);
        assert!(truth <= c.estimate, "true {truth:e} above the estimate {:e}", c.estimate);
        // the smallest truncation whose bare solution meets the tolerance, found by scanning
        let smallest = (12..400).find(|&h| difference(&solve_order(&form, h).unwrap().0, &reference) <= tol).unwrap();
        // the prediction aims at half the tolerance: a few harmonics beyond the smallest, never a second
        // doubling
        assert!(
            c.solution.harmonics >= smallest && c.solution.harmonics <= smallest + smallest / 2,
            "{} harmonics where {smallest} meet the tolerance",
            c.solution.harmonics
        );
    }
}
