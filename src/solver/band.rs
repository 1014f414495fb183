//! Complex banded LU with partial pivoting for harmonic balance's residue classes, and a solve with one
//! step of iterative refinement that measures the rounding the factorisation left.

use nalgebra::Complex;

type C64 = Complex<f64>;

/// Complex banded LU with partial pivoting (LAPACK gbtrf layout: `kl` extra rows for fill-in).
pub(super) struct Band {
    n: usize,
    kl: usize,
    ku: usize,
    ab: Vec<C64>, // column-major, leading dimension ld = 2 kl + ku + 1
}

impl Band {
    pub(super) fn new(n: usize, kl: usize, ku: usize) -> Self {
        Self { n, kl, ku, ab: vec![C64::new(0.0, 0.0); (2 * kl + ku + 1) * n] }
    }
    fn ld(&self) -> usize {
        2 * self.kl + self.ku + 1
    }
    fn idx(&self, i: usize, j: usize) -> usize {
        j * self.ld() + (self.kl + self.ku + i - j)
    }
    pub(super) fn add(&mut self, i: usize, j: usize, v: C64) {
        let k = self.idx(i, j);
        self.ab[k] += v;
    }
    fn get(&self, i: usize, j: usize) -> C64 {
        self.ab[self.idx(i, j)]
    }
    /// y += A x for the band as built (before [`Band::factor`]).
    pub(super) fn mul_add(&self, x: &[C64], y: &mut [C64]) {
        for (j, xj) in x.iter().enumerate() {
            for (i, yi) in
                y.iter_mut().enumerate().take((j + self.kl).min(self.n - 1) + 1).skip(j.saturating_sub(self.ku))
            {
                *yi += self.get(i, j) * xj;
            }
        }
    }

    /// LU with partial pivoting in place (LAPACK gbtrf: the multipliers of L kept below the diagonal, U
    /// with fill-in up to kl + ku above it). Returns the pivot rows, or `None` when a pivot is exactly zero.
    /// The updates run down columns (contiguous in the band storage) and skip the zero entries of U, most
    /// of the fill-in band when no row was swapped.
    pub(super) fn factor(&mut self) -> Option<Vec<usize>> {
        let (n, kl, ld) = (self.n, self.kl, self.ld());
        let kumax = self.kl + self.ku; // upper bandwidth after fill-in
        let mut pivots = Vec::with_capacity(n);
        for j in 0..n {
            let last = (j + kl).min(n - 1);
            // column j, rows j..=last, lies at diag..=diag + last - j
            let diag = self.idx(j, j);
            let mut p = j;
            for r in j + 1..=last {
                if self.ab[diag + r - j].norm_sqr() > self.ab[diag + p - j].norm_sqr() {
                    p = r;
                }
            }
            if self.ab[diag + p - j].norm_sqr() == 0.0 {
                return None;
            }
            pivots.push(p);
            let cmax = (j + kumax).min(n - 1);
            if p != j {
                for c in j..=cmax {
                    let (a, b) = (self.idx(j, c), self.idx(p, c));
                    self.ab.swap(a, b);
                }
            }
            let piv = self.ab[diag];
            for r in j + 1..=last {
                self.ab[diag + r - j] /= piv;
            }
            // column c > j lies after column j: split there to read the multipliers while updating
            let (left, right) = self.ab.split_at_mut((j + 1) * ld);
            let l = &left[diag + 1..diag + 1 + last - j];
            for c in j + 1..=cmax {
                // row i of column c at i + c ld + kumax - c - (j + 1) ld in `right`
                let base = c * ld + kumax - c - (j + 1) * ld;
                let v = right[base + j];
                if v.norm_sqr() == 0.0 {
                    continue;
                }
                for (x, f) in right[base + j + 1..=base + last].iter_mut().zip(l) {
                    *x -= f * v;
                }
            }
        }
        Some(pivots)
    }

    /// Solves A x = b in place with the factors of [`Band::factor`] (both sweeps down columns).
    pub(super) fn solve_factored(&self, pivots: &[usize], b: &mut [C64]) {
        let (n, kl) = (self.n, self.kl);
        let kumax = self.kl + self.ku;
        for (j, &p) in pivots.iter().enumerate() {
            b.swap(j, p);
            let bj = b[j];
            let last = (j + kl).min(n - 1);
            let diag = self.idx(j, j);
            for (br, l) in b[j + 1..=last].iter_mut().zip(&self.ab[diag + 1..=diag + last - j]) {
                *br -= l * bj;
            }
        }
        for j in (0..n).rev() {
            let diag = self.idx(j, j);
            b[j] /= self.ab[diag];
            let bj = b[j];
            let first = j.saturating_sub(kumax);
            // rows first..j of column j lie at diag - (j - first)..diag
            for (br, u) in b[first..j].iter_mut().zip(&self.ab[diag - (j - first)..diag]) {
                *br -= u * bj;
            }
        }
    }
}

/// What [`solve_refined`] returns: the solution x, its correction d, and the LU factors with their pivots
/// (for further solves with the same matrix).
pub(super) type Refined = (Vec<C64>, Vec<C64>, Band, Vec<usize>);

/// A class system solved with one step of iterative refinement: x from the LU, the residual r = b - A x,
/// the correction A d = r with the same factors, x + d returned with d. The size of d against x is the
/// rounding error the LU left (a near-singular system, as at a multiplier near +1, makes it large).
pub(super) fn solve_refined(a: Band, mut b: Vec<C64>, refine: bool) -> Option<Refined> {
    if !refine {
        let mut lu = a;
        let pivots = lu.factor()?;
        lu.solve_factored(&pivots, &mut b);
        let zero = vec![C64::new(0.0, 0.0); b.len()];
        return Some((b, zero, lu, pivots));
    }
    let original = Band { n: a.n, kl: a.kl, ku: a.ku, ab: a.ab.clone() };
    let mut lu = a;
    let pivots = lu.factor()?;
    let rhs = b.clone();
    lu.solve_factored(&pivots, &mut b);
    let mut ax = vec![C64::new(0.0, 0.0); b.len()];
    original.mul_add(&b, &mut ax);
    let mut d: Vec<C64> = rhs.iter().zip(&ax).map(|(r, v)| r - v).collect();
    lu.solve_factored(&pivots, &mut d);
    let x = b.iter().zip(&d).map(|(x, dx)| x + dx).collect();
    Some((x, d, lu, pivots))
}
