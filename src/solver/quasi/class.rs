//! One residue class's linear system (see the parent module): the operator applied to the class's lines,
//! its preconditioner (the tone-a operator per l factored as a band, or both tones' operators through the
//! Schur complement onto the DOFs their coupling touches, along chains of lines) and the restarted GMRES
//! that solves it.

use super::super::band::Band;
use super::{C64, Operator};

/// The non-zero entries (row, column, value) of one coupling matrix at a class offset s.
type Coupling = (isize, Vec<(usize, usize, C64)>);

/// The preconditioner of a class: the tone-a operator per l (block diagonal D_kl plus the coupling blocks
/// K_a(s g_a) between lines k and k - s) factored exactly, and when both tones' couplings touch only some
/// DOFs, the tone-b operator per k as well, in product.
///
/// ```text
/// Full:    P = A_a, the band of A_a over every DOF per l (bandwidth (s_max + 1) N - 1), LU with partial
///          pivoting
/// Reduced: P = A_a D^-1 A_b (or P = A_a when tone b touches every DOF): P - A = A_a D^-1 A_b - A
///          = E_a D^-1 E_b, second order in the two modulations where A_a alone leaves E_b
///          (E_t = A_t - D the couplings). Each A_t^-1 by the Schur complement onto the coupled DOFs
///          (`Chains`), along its own chains of lines.
/// ```
enum Precond {
    Full(Vec<(Band, Vec<usize>)>),
    Reduced {
        /// D^-1 (N x N, row-major) per line, in the class's order (l-major).
        dinv: Vec<C64>,
        /// The tone-a operator's chains (one per l, along k).
        a: Chains,
        /// The tone-b operator's chains (one per k, along l), when tone b couples only some DOFs.
        b: Option<Chains>,
    },
}

/// A tone's operator restricted to chains of lines (one chain per line of the other tone), inverted by the
/// Schur complement onto the DOFs P its coupling touches (a mesh: its two gears).
///
/// ```text
/// chain c, position q (line c chain + q pos): D_q the diagonal block, F_s = K_t(s g_t) on P x P,
/// G_q = (D_q^-1) on P x P:
///     y_q = D_q^-1 (x_q - P c_q),  c_q = sum_s F_s z_{q-s},  z_q = y_q on P
///     =>  z_q + G_q sum_s F_s z_{q-s} = (D_q^-1 x_q) on P        (a band of p DOFs per position)
/// so A_t^-1 x costs a dense N x N product per line and a band of p DOFs (bandwidth (s_max + 1) p - 1)
/// instead of one of N DOFs.
/// ```
struct Chains {
    /// Line index of chain c, position q: c chain + q pos.
    chain: usize,
    pos: usize,
    /// Positions per chain.
    len: usize,
    /// The coupled DOFs P.
    support: Vec<usize>,
    /// The coupling blocks F_s (p x p, row-major) with their offsets s.
    coupling: Vec<(isize, Vec<C64>)>,
    /// Per chain: the factored band of the reduced system.
    bands: Vec<(Band, Vec<usize>)>,
}

impl Chains {
    /// The chains of tone `t` over a class of `na` x `nb` lines (l-major); `None` when a reduced band
    /// cannot be factored.
    fn new(
        op: &Operator,
        t: usize,
        couple: &[(isize, isize)],
        support: &[usize],
        dinv: &[C64],
        na: usize,
        nb: usize,
    ) -> Option<Self> {
        let (n, p) = (op.n, support.len());
        let (chain, pos, len, count) = if t == 0 { (na, 1, na, nb) } else { (1, na, nb, na) };
        let coupling: Vec<(isize, Vec<C64>)> = couple
            .iter()
            .filter_map(|&(s, j)| {
                let m = op.k(t, j)?;
                Some((s, (0..p * p).map(|e| m[support[e / p] * n + support[e % p]]).collect()))
            })
            .collect();
        let band_blocks = coupling.iter().map(|c| c.0.unsigned_abs()).max().unwrap_or(0);
        let bw = (band_blocks + 1) * p - 1;
        let mut bands = Vec::with_capacity(count);
        for c in 0..count {
            let mut b = Band::new(len * p, bw, bw);
            for q in 0..len {
                let line = c * chain + q * pos;
                let d = &dinv[line * n * n..(line + 1) * n * n];
                for a in 0..p {
                    b.add(q * p + a, q * p + a, C64::new(1.0, 0.0));
                }
                for (s, f) in &coupling {
                    let src = q as isize - s;
                    if src < 0 || src >= len as isize {
                        continue;
                    }
                    // G_q F_s, G_q = D_q^-1 on P x P
                    for a in 0..p {
                        for e in 0..p {
                            let v: C64 = (0..p).map(|m| d[support[a] * n + support[m]] * f[m * p + e]).sum();
                            b.add(q * p + a, src as usize * p + e, v);
                        }
                    }
                }
            }
            let pivots = b.factor()?;
            bands.push((b, pivots));
        }
        Some(Self { chain, pos, len, support: support.to_vec(), coupling, bands })
    }

    /// x = A_t^-1 x in place, `dinv` the class's D^-1 blocks, `n` the DOFs.
    fn solve(&self, dinv: &[C64], n: usize, x: &mut [C64]) {
        let (p, len) = (self.support.len(), self.len);
        let mut t = vec![C64::new(0.0, 0.0); n];
        let mut z = vec![C64::new(0.0, 0.0); len * p];
        let mut c = vec![C64::new(0.0, 0.0); p];
        for (ch, (band, piv)) in self.bands.iter().enumerate() {
            let line = |q: usize| ch * self.chain + q * self.pos;
            // t_q = D_q^-1 x_q (kept in x), its coupled DOFs the reduced right-hand side
            for q in 0..len {
                let at = line(q);
                let d = &dinv[at * n * n..(at + 1) * n * n];
                let xq = &mut x[at * n..(at + 1) * n];
                for (r, tr) in t.iter_mut().enumerate() {
                    *tr = d[r * n..(r + 1) * n].iter().zip(xq.iter()).map(|(a, b)| a * b).sum();
                }
                xq.copy_from_slice(&t);
                for (a, &dof) in self.support.iter().enumerate() {
                    z[q * p + a] = t[dof];
                }
            }
            band.solve_factored(piv, &mut z);
            // y_q = t_q - D_q^-1 on (all, P) times c_q, c_q = sum_s F_s z_{q-s}
            for q in 0..len {
                c.fill(C64::new(0.0, 0.0));
                for (s, f) in &self.coupling {
                    let src = q as isize - s;
                    if src < 0 || src >= len as isize {
                        continue;
                    }
                    let zs = &z[src as usize * p..(src as usize + 1) * p];
                    for (a, ca) in c.iter_mut().enumerate() {
                        *ca += f[a * p..(a + 1) * p].iter().zip(zs).map(|(u, v)| u * v).sum::<C64>();
                    }
                }
                let at = line(q);
                let d = &dinv[at * n * n..(at + 1) * n * n];
                let xq = &mut x[at * n..(at + 1) * n];
                for (r, xr) in xq.iter_mut().enumerate() {
                    *xr -= self.support.iter().zip(&c).map(|(&dof, ca)| d[r * n + dof] * ca).sum::<C64>();
                }
            }
        }
    }
}

/// One class: its lines, the preconditioner's factors, and the coupling lists.
pub(super) struct Class<'a> {
    op: &'a Operator,
    pub(super) ks: Vec<isize>,
    pub(super) ls: Vec<isize>,
    /// Angular frequency of each line (l-major), rad/s.
    omegas: Vec<f64>,
    /// The exact inverse of the tone-a operator per l (times that of tone b per k).
    precond: Precond,
    /// The coupling matrices' non-zero entries (row, column, value) per class offset, tone a and tone b
    /// (a mesh's stiffness couples only its two gears: 4 entries of N^2).
    sparse_a: Vec<Coupling>,
    sparse_b: Vec<Coupling>,
}

impl<'a> Class<'a> {
    pub(super) fn new(op: &'a Operator, ks: Vec<isize>, ls: Vec<isize>) -> Option<Self> {
        let n = op.n;
        let coupling = |t: usize| -> Vec<(isize, isize)> {
            let g = op.strides[t];
            if g == 0 {
                return Vec::new();
            }
            let h = op.stiff[t].h as isize;
            let smax = h / g as isize;
            (-smax..=smax).filter(|&s| s != 0).map(|s| (s, s * g as isize)).collect()
        };
        let (couple_a, couple_b) = (coupling(0), coupling(1));
        let omegas: Vec<f64> = ls.iter().flat_map(|&l| ks.iter().map(move |&k| op.omega(k, l))).collect();
        let (na, nb) = (ks.len(), ls.len());
        let support = |t: usize, couple: &[(isize, isize)]| -> Vec<usize> {
            (0..n)
                .filter(|&d| {
                    couple.iter().any(|&(_, j)| {
                        op.k(t, j).is_some_and(|m| {
                            (0..n).any(|e| m[d * n + e].norm_sqr() > 0.0 || m[e * n + d].norm_sqr() > 0.0)
                        })
                    })
                })
                .collect()
        };
        let (support_a, support_b) = (support(0, &couple_a), support(1, &couple_b));
        let reduced = || -> Option<Precond> {
            if support_a.len() >= n {
                return None;
            }
            let dinv = inverses(op, &omegas)?;
            let a = Chains::new(op, 0, &couple_a, &support_a, &dinv, na, nb)?;
            let b = if support_b.is_empty() || support_b.len() >= n {
                None
            } else {
                Some(Chains::new(op, 1, &couple_b, &support_b, &dinv, na, nb)?)
            };
            Some(Precond::Reduced { dinv, a, b })
        };
        let precond = match reduced() {
            Some(p) => p,
            None => Precond::Full(full(op, &couple_a, &omegas, na, nb)?),
        };
        let sparse = |t: usize, couple: &[(isize, isize)]| -> Vec<Coupling> {
            couple
                .iter()
                .filter_map(|&(s, j)| {
                    let m = op.k(t, j)?;
                    let e: Vec<_> =
                        (0..n * n).filter(|&e| m[e].norm_sqr() > 0.0).map(|e| (e / n, e % n, m[e])).collect();
                    (!e.is_empty()).then_some((s, e))
                })
                .collect()
        };
        let (sparse_a, sparse_b) = (sparse(0, &couple_a), sparse(1, &couple_b));
        Some(Self { op, ks, ls, omegas, precond, sparse_a, sparse_b })
    }
}

/// The inverses of the diagonal blocks D(w) at the angular frequencies `omegas` (N x N, row-major, one
/// after another); `None` when one is singular.
fn inverses(op: &Operator, omegas: &[f64]) -> Option<Vec<C64>> {
    let n = op.n;
    let mut out = Vec::with_capacity(omegas.len() * n * n);
    let mut d = vec![C64::new(0.0, 0.0); n * n];
    for &w in omegas {
        op.diagonal(w, &mut d);
        if n == 4 {
            let inv = nalgebra::Matrix4::from_row_slice(&d).try_inverse()?;
            out.extend((0..16).map(|e| inv[(e / 4, e % 4)]));
        } else {
            let inv = nalgebra::DMatrix::from_row_slice(n, n, &d).try_inverse()?;
            out.extend((0..n * n).map(|e| inv[(e / n, e % n)]));
        }
    }
    Some(out)
}

/// The full band of the tone-a operator per l, factored (see [`Precond`]); `None` for an exactly zero pivot.
fn full(
    op: &Operator,
    couple_a: &[(isize, isize)],
    omegas: &[f64],
    na: usize,
    nl: usize,
) -> Option<Vec<(Band, Vec<usize>)>> {
    let n = op.n;
    let band_blocks = couple_a.iter().map(|c| c.0.unsigned_abs()).max().unwrap_or(0);
    let bw = (band_blocks + 1) * n - 1;
    let mut lu = Vec::with_capacity(nl);
    let mut d = vec![C64::new(0.0, 0.0); n * n];
    for il in 0..nl {
        let mut a = Band::new(na * n, bw, bw);
        for ik in 0..na {
            op.diagonal(omegas[il * na + ik], &mut d);
            for r in 0..n {
                for c in 0..n {
                    a.add(ik * n + r, ik * n + c, d[r * n + c]);
                }
            }
            for &(s, j) in couple_a {
                let src = ik as isize - s;
                if src < 0 || src >= na as isize {
                    continue;
                }
                let m = op.k(0, j)?;
                for r in 0..n {
                    for c in 0..n {
                        a.add(ik * n + r, src as usize * n + c, m[r * n + c]);
                    }
                }
            }
        }
        let pivots = a.factor()?;
        lu.push((a, pivots));
    }
    Some(lu)
}

impl Class<'_> {
    pub(super) fn len(&self) -> usize {
        self.ks.len() * self.ls.len() * self.op.n
    }

    /// y = A x.
    fn apply(&self, x: &[C64], y: &mut [C64]) {
        let (n, na, nb) = (self.op.n, self.ks.len(), self.ls.len());
        y.fill(C64::new(0.0, 0.0));
        for il in 0..nb {
            for ik in 0..na {
                let at = (il * na + ik) * n;
                self.op.diagonal_mul_add(self.omegas[il * na + ik], &x[at..at + n], &mut y[at..at + n]);
                for (s, entries) in &self.sparse_a {
                    let src = ik as isize - s;
                    if src >= 0 && src < na as isize {
                        let from = (il * na + src as usize) * n;
                        entries.iter().for_each(|&(r, c, v)| y[at + r] += v * x[from + c]);
                    }
                }
                for (s, entries) in &self.sparse_b {
                    let src = il as isize - s;
                    if src >= 0 && src < nb as isize {
                        let from = (src as usize * na + ik) * n;
                        entries.iter().for_each(|&(r, c, v)| y[at + r] += v * x[from + c]);
                    }
                }
            }
        }
    }

    /// x = P^-1 x in place (see [`Precond`]).
    pub(super) fn precondition(&self, x: &mut [C64]) {
        let (n, na) = (self.op.n, self.ks.len());
        let m = na * n;
        match &self.precond {
            Precond::Full(lu) => {
                for (il, (lu, piv)) in lu.iter().enumerate() {
                    lu.solve_factored(piv, &mut x[il * m..(il + 1) * m]);
                }
            }
            Precond::Reduced { dinv, a, b } => {
                a.solve(dinv, n, x);
                if let Some(b) = b {
                    // x = A_b^-1 D x
                    let mut t = vec![C64::new(0.0, 0.0); n];
                    for (xq, &w) in x.chunks_exact_mut(n).zip(&self.omegas) {
                        t.fill(C64::new(0.0, 0.0));
                        self.op.diagonal_mul_add(w, xq, &mut t);
                        xq.copy_from_slice(&t);
                    }
                    b.solve(dinv, n, x);
                }
            }
        }
    }
}

fn norm(v: &[C64]) -> f64 {
    v.iter().map(|c| c.norm_sqr()).sum::<f64>().sqrt()
}

/// Restarted GMRES(m) with right preconditioning on one class, from `x0` (or 0): x such that
/// |b - A x| <= rtol |b|.
/// Returns the solution, its residual b - A x, the iterations used and whether `rtol` was reached (else the
/// last iterate).
pub(super) fn gmres(
    class: &Class<'_>,
    b: &[C64],
    x0: Option<Vec<C64>>,
    rtol: f64,
    max_iter: usize,
) -> (Vec<C64>, Vec<C64>, usize, bool) {
    const RESTART: usize = 40;
    let len = class.len();
    let bnorm = norm(b);
    let mut tmp = vec![C64::new(0.0, 0.0); len];
    let (mut z, mut w) = (tmp.clone(), tmp.clone());
    let (mut x, mut r) = match x0 {
        Some(x) => {
            class.apply(&x, &mut tmp);
            let r = b.iter().zip(&tmp).map(|(bi, ai)| bi - ai).collect();
            (x, r)
        }
        None => (vec![C64::new(0.0, 0.0); len], b.to_vec()),
    };
    if bnorm == 0.0 {
        return (x, r, 0, true);
    }
    let mut iters = 0;
    loop {
        let beta = norm(&r);
        if beta <= rtol * bnorm {
            return (x, r, iters, true);
        }
        if iters >= max_iter {
            return (x, r, iters, false);
        }
        let mut v: Vec<Vec<C64>> = vec![r.iter().map(|c| c / beta).collect()];
        let mut h = vec![vec![C64::new(0.0, 0.0); RESTART]; RESTART + 1];
        let (mut cs, mut sn) = (vec![C64::new(0.0, 0.0); RESTART], vec![C64::new(0.0, 0.0); RESTART]);
        let mut g = vec![C64::new(0.0, 0.0); RESTART + 1];
        g[0] = C64::new(beta, 0.0);
        let mut used = 0;
        for j in 0..RESTART {
            z.copy_from_slice(&v[j]);
            class.precondition(&mut z);
            class.apply(&z, &mut w);
            for (i, vi) in v.iter().enumerate() {
                let hij: C64 = vi.iter().zip(&w).map(|(a, b)| a.conj() * b).sum();
                h[i][j] = hij;
                w.iter_mut().zip(vi).for_each(|(wk, vk)| *wk -= hij * vk);
            }
            let hn = norm(&w);
            h[j + 1][j] = C64::new(hn, 0.0);
            for i in 0..j {
                let t = cs[i].conj() * h[i][j] + sn[i].conj() * h[i + 1][j];
                h[i + 1][j] = -sn[i] * h[i][j] + cs[i] * h[i + 1][j];
                h[i][j] = t;
            }
            let (a, bb) = (h[j][j], h[j + 1][j]);
            let den = (a.norm_sqr() + bb.norm_sqr()).sqrt();
            if den == 0.0 {
                return (x, r, iters, false);
            }
            cs[j] = a / den;
            sn[j] = bb / den;
            h[j][j] = C64::new(den, 0.0);
            h[j + 1][j] = C64::new(0.0, 0.0);
            g[j + 1] = -sn[j] * g[j];
            g[j] = cs[j].conj() * g[j];
            used = j + 1;
            iters += 1;
            if g[j + 1].norm() <= rtol * bnorm || hn == 0.0 || iters >= max_iter {
                break;
            }
            v.push(w.iter().map(|c| c / hn).collect());
        }
        // back substitution for the Krylov coefficients, then x += P^-1 V y
        let mut y = vec![C64::new(0.0, 0.0); used];
        for i in (0..used).rev() {
            let mut s = g[i];
            for (k, yk) in y.iter().enumerate().take(used).skip(i + 1) {
                s -= h[i][k] * yk;
            }
            y[i] = s / h[i][i];
        }
        let mut dx = vec![C64::new(0.0, 0.0); len];
        for (vi, yi) in v.iter().zip(&y) {
            dx.iter_mut().zip(vi).for_each(|(d, a)| *d += yi * a);
        }
        class.precondition(&mut dx);
        x.iter_mut().zip(&dx).for_each(|(a, d)| *a += d);
        class.apply(&x, &mut tmp);
        r.iter_mut().zip(b.iter().zip(&tmp)).for_each(|(ri, (bi, ai))| *ri = bi - ai);
    }
}
