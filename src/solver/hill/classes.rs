//! The harmonic-balance operator split into its independent residue classes (see the parent module).

use super::{C64, HillSolution, SolverError};
use crate::solver::band::Band;
use crate::system::FourierForm;
use crate::system::gcd;
use nalgebra::DMatrix;

pub(super) struct Coefficients {
    pub(super) h: usize,
    pub(super) mass: Vec<Vec<C64>>,
    pub(super) damping: Vec<Vec<C64>>,
    pub(super) stiffness: Vec<Vec<C64>>,
}

pub(super) fn complex(s: &crate::system::FourierSeries, h: usize) -> Vec<C64> {
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

/// The harmonic-balance operator of `form` split into its independent residue classes.
pub(super) struct Classes {
    pub(super) nd: usize,
    pub(super) w: f64,
    pub(super) co: Coefficients,
    pub(super) stride: usize,
    /// gcd of the coefficient harmonics present (0 when none: then every harmonic is its own class).
    pub(super) g: usize,
    pub(super) band_blocks: usize,
    pub(super) h: isize,
    /// Per entry e = i N + l: whether M_e or C_e has a harmonic besides the mean.
    pub(super) varying: Vec<bool>,
    /// Per entry e: sum over k != 0 of |K_e,k|, |M_e,k| and |C_e,k| (bounds of the coupling between
    /// harmonics).
    pub(super) coupling: Vec<[f64; 3]>,
}

impl Classes {
    pub(super) fn new(form: &FourierForm, h_trunc: usize) -> Self {
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
    pub(super) fn set_truncation(&mut self, h_trunc: usize) {
        self.h = h_trunc as isize;
        self.stride = if self.g == 0 { 2 * h_trunc + 1 } else { self.g };
    }

    /// Harmonics of class r within [-H, H] (Y_{-n} = conj(Y_n): only r <= g / 2 is ever solved).
    pub(super) fn members(&self, r: usize) -> Vec<isize> {
        let (h, g) = (self.h, self.stride as isize);
        // the first n >= -H with n = r (mod g), found by one remainder (a scan from -H cost a division per
        // harmonic: 1.5 ms per pass over the hunting period's 274 classes)
        let first = -h + (r as isize + h).rem_euclid(g);
        (0..).map(|j| first + j * g).take_while(|n| *n <= h).collect()
    }

    pub(super) fn count(&self) -> usize {
        self.stride.min(2 * self.h as usize + 1)
    }

    /// The band matrix of one class: row n, column m holds -(m w)^2 M_{n-m} + i m w C_{n-m} + K_{n-m}.
    /// Built column by column (contiguous in the band storage); a mass or damping entry that is constant
    /// (the gear pair's) only touches the diagonal blocks.
    pub(super) fn matrix(&self, members: &[isize]) -> Band {
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
    pub(super) fn entry(&self, nr: isize, nc: isize, i: usize, l: usize) -> C64 {
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
    pub(super) fn couple(&self, n: isize, m: isize, y: &[C64], r: &mut [C64]) {
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
    pub(super) fn couple_row(&self, n: isize, members: &[isize], js: std::ops::Range<usize>, x: &[C64], r: &mut [C64]) {
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
    pub(super) fn couple_column(
        &self,
        n: isize,
        members: &[isize],
        js: std::ops::Range<usize>,
        e: &[C64],
        b: &mut [C64],
    ) {
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
    pub(super) fn dominance(&self, n: isize, out: &mut Vec<C64>) -> Option<f64> {
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
    pub(super) fn dominant_from(&self, up_to: isize) -> Option<isize> {
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

    /// Right-hand side of one class from complex forcing coefficients `f[i][n + hf]`, or `None` when the
    /// class is not forced (a non-singular homogeneous class has the zero solution).
    pub(super) fn rhs(&self, members: &[isize], forcing: &[Vec<C64>], hf: usize) -> Option<Vec<C64>> {
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
    pub(super) fn store(&self, r: usize, members: &[isize], x: &[C64], coeffs: &mut [Vec<C64>]) {
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

    pub(super) fn solution(&self, coeffs: Vec<Vec<C64>>) -> Result<HillSolution, SolverError> {
        if coeffs.iter().flatten().any(|c| !c.re.is_finite() || !c.im.is_finite()) {
            return Err(SolverError::NonFinite { what: "harmonic-balance solution".into() });
        }
        Ok(HillSolution { omega: self.w, harmonics: self.h as usize, coeffs, stride: self.stride })
    }
}
