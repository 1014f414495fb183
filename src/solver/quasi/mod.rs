//! Quasi-periodic steady state by two-frequency harmonic balance, for a system whose coefficients are the
//! sum of two periodic parts of unrelated (or only distantly related) frequencies w_a and w_b: two gear
//! stages, each with its own mesh stiffness and tooth errors, whose common period would be huge.
//!
//! ```text
//! M y'' + C y' + (K_a(w_a t) + K_b(w_b t)) y = d_a(w_a t) + d_b(w_b t)      (M, C constant)
//! y(t) = sum_{|k|<=K, |l|<=L} Y_kl exp(i (k w_a + l w_b) t)
//! line (k, l), w = k w_a + l w_b:
//!     (-w^2 M + i w C + Ka_0 + Kb_0) Y_kl + sum_{j!=0} Ka_j Y_{k-j,l} + sum_{j!=0} Kb_j Y_{k,l-j} = Da_k [l=0] + Db_l [k=0]
//! ```
//! Stiffness harmonics of tone a that are all multiples of g_a (the mesh harmonics of a stage over one
//! pinion revolution: g_a = z) couple only k of one residue class mod g_a, likewise l mod g_b: the lines split
//! into independent classes (k mod g_a, l mod g_b), and only those holding a forcing line are solved. In a
//! class the unknowns are ordered l-major; the operator restricted to one l (the tone-a coupling, banded in k)
//! is factored with the banded LU of harmonic balance and is the preconditioner of a restarted GMRES on the
//! whole class (the tone-b coupling is what the iteration resolves); when the tone-a coupling touches only
//! some DOFs (a mesh: its two gears) the band is that of its Schur complement on them (`Precond`). The
//! classes are solved in parallel, each truncation's GMRES from the coarser truncation's solution. K and L
//! count layers of their stride around each class's centre and grow each on its own, as far as the
//! outermost layer's geometric decay predicts is needed (a train may need many mesh harmonics of one stage
//! and few of the other); the error estimate is the change between successive truncations (widened when
//! the layers shrink slowly), plus the linear solves' error (`solve`).

use super::SolverError;
use super::band::Band;
use crate::system::FourierSeries;
pub use crate::system::TwoToneForm;
use crate::system::gcd;
use nalgebra::Complex;

type C64 = Complex<f64>;

/// The lines of one class: k = k0 + ik gk (ik < nk), l = l0 + il gl (il < nl), l-major from line `start`.
#[derive(Clone, Copy, Debug)]
struct Block {
    k0: isize,
    gk: isize,
    nk: usize,
    l0: isize,
    gl: isize,
    nl: usize,
    start: usize,
}

impl Block {
    fn new(ks: &[isize], ls: &[isize], strides: [usize; 2], start: usize) -> Self {
        let [gk, gl] = strides.map(|g| g as isize);
        Self { k0: ks[0], gk, nk: ks.len(), l0: ls[0], gl, nl: ls.len(), start }
    }

    /// (ik, il) of line (k, l) when the block holds it.
    fn locate(&self, k: isize, l: isize) -> Option<(usize, usize)> {
        let at = |x: isize, x0: isize, g: isize, n: usize| -> Option<usize> {
            let d = x - x0;
            let i = if g == 0 {
                (d == 0).then_some(0)?
            } else {
                (d.rem_euclid(g) == 0 && d >= 0).then_some((d / g) as usize)?
            };
            (i < n).then_some(i)
        };
        Some((at(k, self.k0, self.gk, self.nk)?, at(l, self.l0, self.gl, self.nl)?))
    }

    /// Whether `other` holds lines of the same class (the same strides and residues).
    fn same_class(&self, other: &Block) -> bool {
        let same = |x: isize, y: isize, g: isize| if g == 0 { x == y } else { (x - y).rem_euclid(g) == 0 };
        self.gk == other.gk
            && self.gl == other.gl
            && same(self.k0, other.k0, self.gk)
            && same(self.l0, other.l0, self.gl)
    }

    /// Line index in `other` (a block of the same class) of this block's line (ik, il), if held there.
    fn map_to(&self, other: &Block, ik: usize, il: usize) -> Option<usize> {
        let shift = |x0: isize, y0: isize, g: isize| if g == 0 { 0 } else { (x0 - y0) / g };
        let jk = ik as isize + shift(self.k0, other.k0, self.gk);
        let jl = il as isize + shift(self.l0, other.l0, self.gl);
        (jk >= 0 && jk < other.nk as isize && jl >= 0 && jl < other.nl as isize)
            .then(|| other.start + jl as usize * other.nk + jk as usize)
    }
}

/// The quasi-periodic solution: Y_kl per DOF on the lines that were solved (the forced classes; every other
/// line of the truncation is zero).
#[derive(Clone, Debug)]
pub struct TwoToneSolution {
    /// Base angular frequencies, rad/s.
    pub omega_rad_s: [f64; 2],
    /// Truncation K (tone a) and L (tone b).
    pub harmonics: [usize; 2],
    /// Degrees of freedom N.
    pub dof: usize,
    /// The lines (k, l) held.
    lines: Vec<(isize, isize)>,
    /// Y_kl of line j at j N + i.
    coeffs: Vec<C64>,
    /// The classes' blocks of lines.
    blocks: Vec<Block>,
}

impl TwoToneSolution {
    fn empty(omega_rad_s: [f64; 2], harmonics: [usize; 2], dof: usize) -> Self {
        Self { omega_rad_s, harmonics, dof, lines: Vec::new(), coeffs: Vec::new(), blocks: Vec::new() }
    }

    /// Appends a class of the given strides: lines k in `ks`, l in `ls` (its members), values l-major.
    fn push_class(&mut self, ks: &[isize], ls: &[isize], strides: [usize; 2], y: &[C64]) {
        self.blocks.push(Block::new(ks, ls, strides, self.lines.len()));
        self.lines.extend(ls.iter().flat_map(|&l| ks.iter().map(move |&k| (k, l))));
        self.coeffs.extend_from_slice(y);
    }

    /// Index of line (k, l) among those held.
    fn find(&self, k: isize, l: isize) -> Option<usize> {
        self.blocks.iter().find_map(|b| b.locate(k, l).map(|(ik, il)| b.start + il * b.nk + ik))
    }

    /// The lines (k, l) held (all others are zero).
    pub fn lines_held(&self) -> &[(isize, isize)] {
        &self.lines
    }

    /// The N coefficients of the `j`-th line held (in the order of [`TwoToneSolution::lines_held`]).
    pub fn line_coefficients(&self, j: usize) -> &[C64] {
        &self.coeffs[j * self.dof..(j + 1) * self.dof]
    }

    /// Complex coefficient Y_kl of DOF i (zero beyond the truncation): y_i(t) = sum Y_kl e^{i(k w_a + l w_b)t}.
    pub fn coefficient(&self, i: usize, k: isize, l: isize) -> C64 {
        match self.find(k, l) {
            Some(j) if i < self.dof => self.coeffs[j * self.dof + i],
            _ => C64::new(0.0, 0.0),
        }
    }

    /// Angular frequency k w_a + l w_b, rad/s.
    pub fn frequency_rad_s(&self, k: isize, l: isize) -> f64 {
        k as f64 * self.omega_rad_s[0] + l as f64 * self.omega_rad_s[1]
    }

    /// State [y; y'] at time t (s): 2N values.
    pub fn state(&self, t: f64, out: &mut [f64]) {
        let n = self.dof;
        out[..2 * n].fill(0.0);
        for (j, &(k, l)) in self.lines.iter().enumerate() {
            let w = self.frequency_rad_s(k, l);
            // the phase of each base reduced first: k w_a t for large t loses digits otherwise
            let phase = (k as f64 * (self.omega_rad_s[0] * t).rem_euclid(std::f64::consts::TAU))
                + (l as f64 * (self.omega_rad_s[1] * t).rem_euclid(std::f64::consts::TAU));
            let p = C64::from_polar(1.0, phase);
            for i in 0..n {
                let c = self.coeffs[j * n + i] * p;
                out[i] += c.re;
                out[n + i] -= w * c.im;
            }
        }
    }

    /// Real amplitudes of the lines of `sum_i weights[i] y_i + sum_i dweights[i] y_i'` at w = k w_a + l w_b >= 0
    /// (lines at the same |w| are not merged), largest first, those above `floor` of the largest:
    /// (k, l, w rad/s, amplitude).
    pub fn lines(&self, weights: &[f64], dweights: &[f64], floor: f64) -> Vec<(isize, isize, f64, f64)> {
        let mut out = Vec::new();
        for (j, &(k, l)) in self.lines.iter().enumerate() {
            let w = self.frequency_rad_s(k, l);
            if w < 0.0 || (w == 0.0 && (k, l) != (0, 0) && (k < 0 || (k == 0 && l < 0))) {
                continue;
            }
            let z: C64 =
                (0..self.dof).map(|i| self.coeffs[j * self.dof + i] * C64::new(weights[i], w * dweights[i])).sum();
            let a = if (k, l) == (0, 0) { z.norm() } else { 2.0 * z.norm() };
            out.push((k, l, w, a));
        }
        out.sort_by(|a, b| b.3.total_cmp(&a.3));
        let top = out.first().map_or(0.0, |x| x.3);
        out.retain(|x| x.3 > floor * top);
        out
    }
}

/// How a quasi-periodic solve went.
#[derive(Clone, Debug)]
pub struct TwoToneReport {
    /// Estimated relative error of the solution (the measure of [`difference`]).
    pub error_estimate: f64,
    /// Error of the linear solves (GMRES), in the measure of [`difference`]: the size of one preconditioned
    /// correction of GMRES's solution, which is then applied (included in `error_estimate`).
    pub solve_error: f64,
    /// Classes (k mod g_a, l mod g_b) held (of a class and its mirror only one is solved).
    pub classes: usize,
    /// Coupling strides g_a, g_b of the stiffness harmonics (0: that tone does not vary the stiffness).
    pub strides: [usize; 2],
    /// Total GMRES iterations over the classes solved and the truncations.
    pub iterations: usize,
}

/// The complex coefficients c_j of a list of series (entry by entry) at the harmonics j where one of them
/// is non-zero (and j = 0): a mesh's series over a stage's base frequency hold thousands of harmonics, of
/// which only the mesh harmonics and the errors' orders are not zero.
struct Harmonics {
    /// Highest harmonic of the series.
    h: usize,
    /// (j, c_j of every entry), j ascending over -h..=h.
    terms: Vec<(isize, Vec<C64>)>,
}

impl Harmonics {
    fn new(series: &[FourierSeries]) -> Self {
        let h = series.iter().map(|s| s.harmonics()).max().unwrap_or(0);
        let at =
            |s: &FourierSeries, j: usize| if j <= s.harmonics() { (s.cos[j - 1], s.sin[j - 1]) } else { (0.0, 0.0) };
        let mut positive: Vec<(isize, Vec<C64>, Vec<C64>)> = Vec::new();
        for j in 1..=h {
            if series.iter().all(|s| at(s, j) == (0.0, 0.0)) {
                continue;
            }
            // a cos + b sin = (a - i b)/2 e^{i..} + (a + i b)/2 e^{-i..}
            let plus = series.iter().map(|s| at(s, j)).map(|(a, b)| C64::new(a / 2.0, -b / 2.0)).collect();
            let minus = series.iter().map(|s| at(s, j)).map(|(a, b)| C64::new(a / 2.0, b / 2.0)).collect();
            positive.push((j as isize, plus, minus));
        }
        let mean = (0, series.iter().map(|s| C64::new(s.mean, 0.0)).collect());
        let mut terms: Vec<(isize, Vec<C64>)> = positive.iter().rev().map(|(j, _, m)| (-j, m.clone())).collect();
        terms.push(mean);
        terms.extend(positive.into_iter().map(|(j, p, _)| (j, p)));
        Self { h, terms }
    }

    /// The coefficients of harmonic j (`None` when every entry's is zero, j != 0).
    fn get(&self, j: isize) -> Option<&[C64]> {
        self.terms.binary_search_by_key(&j, |t| t.0).ok().map(|i| self.terms[i].1.as_slice())
    }
}

/// The operator's coefficients: per tone, the N x N stiffness matrix of each harmonic (row-major), and the
/// forcing vectors.
struct Operator {
    n: usize,
    w: [f64; 2],
    mass: Vec<f64>,
    damping: Vec<f64>,
    /// Per tone: the stiffness matrices (N x N) of its harmonics.
    stiff: [Harmonics; 2],
    /// The mean stiffness Ka_0 + Kb_0 (N x N).
    k0: Vec<C64>,
    /// Per tone: the forcing vectors (N) of its harmonics.
    force: [Harmonics; 2],
    strides: [usize; 2],
}

impl Operator {
    fn new(form: &TwoToneForm) -> Self {
        let n = form.dof;
        let stiff = [0, 1].map(|t| Harmonics::new(&form.stiffness[t]));
        let force = [0, 1].map(|t| Harmonics::new(&form.forcing[t]));
        let strides = stiff.each_ref().map(|k| {
            k.terms
                .iter()
                .filter(|(j, c)| *j > 0 && c.iter().any(|c| c.norm_sqr() > 0.0))
                .fold(0, |g, t| gcd(g, t.0 as usize))
        });
        let k0 = (0..n * n).map(|e| stiff.iter().filter_map(|k| k.get(0)?.get(e)).sum()).collect();
        Self {
            n,
            w: form.omega_rad_s,
            mass: form.mass.clone(),
            damping: form.damping.clone(),
            stiff,
            k0,
            force,
            strides,
        }
    }

    /// Stiffness matrix of harmonic j of tone t (`None` when zero).
    fn k(&self, t: usize, j: isize) -> Option<&[C64]> {
        self.stiff[t].get(j)
    }

    /// Angular frequency of line (k, l), rad/s.
    fn omega(&self, k: isize, l: isize) -> f64 {
        k as f64 * self.w[0] + l as f64 * self.w[1]
    }

    /// The diagonal block at angular frequency w, -w^2 M + i w C + Ka_0 + Kb_0, into `out` (row-major).
    fn diagonal(&self, w: f64, out: &mut [C64]) {
        for (e, o) in out.iter_mut().enumerate() {
            *o = self.k0[e] + C64::new(-w * w * self.mass[e], w * self.damping[e]);
        }
    }

    /// y += D(w) x for the diagonal block at w, without forming it.
    fn diagonal_mul_add(&self, w: f64, x: &[C64], y: &mut [C64]) {
        let n = self.n;
        let w2 = w * w;
        for (r, yr) in y.iter_mut().enumerate().take(n) {
            let row = r * n..(r + 1) * n;
            let mut acc = C64::new(0.0, 0.0);
            for (((k, m), c), xc) in
                self.k0[row.clone()].iter().zip(&self.mass[row.clone()]).zip(&self.damping[row]).zip(x)
            {
                acc += (k + C64::new(-w2 * m, w * c)) * xc;
            }
            *yr += acc;
        }
    }

    /// Forcing vector of line (k, l), or `None` when zero.
    fn forcing(&self, k: isize, l: isize) -> Option<Vec<C64>> {
        let mut f = vec![C64::new(0.0, 0.0); self.n];
        let mut any = false;
        for (t, j, other) in [(0, k, l), (1, l, k)] {
            if other != 0 {
                continue;
            }
            if let Some(v) = self.force[t].get(j) {
                for (fi, v) in f.iter_mut().zip(v) {
                    *fi += v;
                    any |= v.norm_sqr() > 0.0;
                }
            }
        }
        any.then_some(f)
    }
}

/// Members of residue class r (mod `stride`; stride 0: each line its own class) within [-h, h].
fn members(r: isize, stride: usize, h: isize) -> Vec<isize> {
    if stride == 0 {
        return if r.abs() <= h { vec![r] } else { Vec::new() };
    }
    let s = stride as isize;
    let first = -h + (r - (-h)).rem_euclid(s);
    (0..).map(|j| first + j * s).take_while(|x| *x <= h).collect()
}

/// Residue representative of line index x for a stride (stride 0: x itself).
fn residue(x: isize, stride: usize) -> isize {
    if stride == 0 { x } else { x.rem_euclid(stride as isize) }
}

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
struct Class<'a> {
    op: &'a Operator,
    ks: Vec<isize>,
    ls: Vec<isize>,
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
    fn new(op: &'a Operator, ks: Vec<isize>, ls: Vec<isize>) -> Option<Self> {
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
    fn len(&self) -> usize {
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
    fn precondition(&self, x: &mut [C64]) {
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
fn gmres(
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

/// Solves at truncation (K, L) = `h`, GMRES to a relative residual `rtol`.
///
/// # Errors
/// [`SolverError::Singular`] when a preconditioner block is singular, [`SolverError::ToleranceNotReached`]
/// when GMRES does not converge.
pub fn solve_order(
    form: &TwoToneForm,
    h: [usize; 2],
    rtol: f64,
) -> Result<(TwoToneSolution, TwoToneReport), SolverError> {
    let op = Operator::new(form);
    solve_with(&op, h, rtol, None)
}

/// [`solve_order`] with the operator built, GMRES started from `guess` (a coarser truncation's solution:
/// its lines, zero on the new ones) when given.
fn solve_with(
    op: &Operator,
    h: [usize; 2],
    rtol: f64,
    guess: Option<&TwoToneSolution>,
) -> Result<(TwoToneSolution, TwoToneReport), SolverError> {
    let n = op.n;
    let (kk, ll) = (h[0] as isize, h[1] as isize);
    let mut sol = TwoToneSolution::empty(op.w, h, n);
    let mut coarse = TwoToneSolution::empty(op.w, h, n);
    // the classes holding a forcing line: (k, 0) lines of tone a, (0, l) lines of tone b
    let mut classes: Vec<(isize, isize)> = Vec::new();
    for t in 0..2 {
        let hf = op.force[t].h as isize;
        for j in -hf.min(if t == 0 { kk } else { ll })..=hf.min(if t == 0 { kk } else { ll }) {
            let (k, l) = if t == 0 { (j, 0) } else { (0, j) };
            if op.forcing(k, l).is_some() {
                let c = (residue(k, op.strides[0]), residue(l, op.strides[1]));
                if !classes.contains(&c) {
                    classes.push(c);
                }
            }
        }
    }
    // the coefficients are real, so Y_{-k,-l} = conj(Y_kl): of a class and its mirror (-k mod g_a, -l mod
    // g_b), whose lines are the negated ones, one is solved and the other mirrored
    let mirror = |c: (isize, isize)| (residue(-c.0, op.strides[0]), residue(-c.1, op.strides[1]));
    let solved_here: Vec<(isize, isize)> =
        classes.iter().copied().filter(|&c| !(mirror(c) < c && classes.contains(&mirror(c)))).collect();
    // the classes are independent: solved in parallel, gathered in order
    use rayon::prelude::*;
    let solved: Vec<Option<ClassSolution>> = solved_here
        .par_iter()
        .map(|&(ra, rb)| solve_class(op, [ra, rb], [kk, ll], rtol, guess))
        .collect::<Result<_, _>>()?;
    let mut iterations = 0;
    for &c in &classes {
        let (at, mirrored) = match solved_here.iter().position(|&x| x == c) {
            Some(i) => (i, false),
            None => (solved_here.iter().position(|&x| x == mirror(c)).expect("a class or its mirror is solved"), true),
        };
        let Some(cs) = &solved[at] else { continue };
        if mirrored {
            let m = cs.mirrored(n);
            coarse.push_class(&m.ks, &m.ls, op.strides, &m.gmres);
            sol.push_class(&m.ks, &m.ls, op.strides, &m.corrected);
        } else {
            iterations += cs.iterations;
            coarse.push_class(&cs.ks, &cs.ls, op.strides, &cs.gmres);
            sol.push_class(&cs.ks, &cs.ls, op.strides, &cs.corrected);
        }
    }
    if sol.coeffs.iter().any(|c| !c.re.is_finite() || !c.im.is_finite()) {
        return Err(SolverError::NonFinite { what: "two-frequency harmonic-balance solution".into() });
    }
    let solve_error = difference(&coarse, &sol);
    let report = TwoToneReport {
        error_estimate: f64::NAN,
        solve_error,
        classes: classes.len(),
        strides: op.strides,
        iterations,
    };
    Ok((sol, report))
}

/// One class solved: its lines, GMRES's solution to rtol and that solution after one preconditioned
/// correction, l-major.
struct ClassSolution {
    ks: Vec<isize>,
    ls: Vec<isize>,
    gmres: Vec<C64>,
    corrected: Vec<C64>,
    iterations: usize,
}

impl ClassSolution {
    /// The mirror class (lines -k, -l, ascending) and its coefficients conj(Y_kl), `n` DOFs per line.
    fn mirrored(&self, n: usize) -> ClassSolution {
        let negated = |xs: &[isize]| xs.iter().rev().map(|x| -x).collect::<Vec<_>>();
        // line (ik, il) of the mirror is line (na - 1 - ik, nb - 1 - il) here: the l-major order reversed
        let flip = |y: &[C64]| y.chunks_exact(n).rev().flat_map(|line| line.iter().map(|c| c.conj())).collect();
        ClassSolution {
            ks: negated(&self.ks),
            ls: negated(&self.ls),
            gmres: flip(&self.gmres),
            corrected: flip(&self.corrected),
            iterations: 0,
        }
    }
}

/// Solves the class of residues `r` (k mod g_a, l mod g_b) at truncation `h`, from `guess` when given;
/// `None` for a class with no line in the truncation.
fn solve_class(
    op: &Operator,
    r: [isize; 2],
    h: [isize; 2],
    rtol: f64,
    guess: Option<&TwoToneSolution>,
) -> Result<Option<ClassSolution>, SolverError> {
    let n = op.n;
    let (ks, ls) = (members(r[0], op.strides[0], h[0]), members(r[1], op.strides[1], h[1]));
    if ks.is_empty() || ls.is_empty() {
        return Ok(None);
    }
    let class = Class::new(op, ks, ls).ok_or(SolverError::Singular)?;
    let na = class.ks.len();
    let mut b = vec![C64::new(0.0, 0.0); class.len()];
    // forcing lines lie on k = 0 or l = 0 only
    for (il, &l) in class.ls.iter().enumerate() {
        for (ik, &k) in class.ks.iter().enumerate() {
            if k != 0 && l != 0 {
                continue;
            }
            if let Some(f) = op.forcing(k, l) {
                b[(il * na + ik) * n..(il * na + ik + 1) * n].copy_from_slice(&f);
            }
        }
    }
    let here = Block::new(&class.ks, &class.ls, op.strides, 0);
    let x0 = guess.map(|g| {
        let mut x0 = vec![C64::new(0.0, 0.0); class.len()];
        if let Some(from) = g.blocks.iter().find(|b| b.same_class(&here)) {
            for il in 0..class.ls.len() {
                for ik in 0..na {
                    if let Some(j) = here.map_to(from, ik, il) {
                        x0[(il * na + ik) * n..(il * na + ik + 1) * n].copy_from_slice(g.line_coefficients(j));
                    }
                }
            }
        }
        x0
    });
    let (x, mut r, iterations, ok) = gmres(&class, &b, x0, rtol, 2000);
    if !ok {
        return Err(SolverError::ToleranceNotReached {
            cond: f64::NAN,
            tolerance: rtol,
            steps: 2000,
            estimate: f64::NAN,
        });
    }
    // one preconditioned correction x + P^-1 (b - A x): its size estimates GMRES's error (measured 0.85 to
    // 0.96 of the change when the residual is lowered 100-fold further, on the 23/61-19/47 train), and the
    // corrected solution is the better one (4 to 5 times there)
    class.precondition(&mut r);
    let corrected = x.iter().zip(&r).map(|(a, e)| a + e).collect();
    let Class { ks, ls, .. } = class;
    Ok(Some(ClassSolution { ks, ls, gmres: x, corrected, iterations }))
}

/// Relative difference between two solutions (the second with the larger truncation): per DOF and for y
/// and y', sum |dY_kl| (times |w_kl| for y') over sum |Y_kl| of the second, the largest: a bound on the
/// time-domain change relative to the solution's size.
pub fn difference(a: &TwoToneSolution, b: &TwoToneSolution) -> f64 {
    let n = b.dof;
    // per DOF and kind (y, y'): sum |dY| w and sum |Y| w
    let (mut diff, mut size) = (vec![0.0; 2 * n], vec![0.0; 2 * n]);
    let abs = |c: C64| c.norm_sqr().sqrt();
    for bb in &b.blocks {
        let ab = a.blocks.iter().find(|x| x.same_class(bb));
        for il in 0..bb.nl {
            for ik in 0..bb.nk {
                let jb = bb.start + il * bb.nk + ik;
                let (k, l) = b.lines[jb];
                let w = b.frequency_rad_s(k, l).abs();
                let ja = ab.and_then(|ab| bb.map_to(ab, ik, il));
                for i in 0..n {
                    let yb = b.coeffs[jb * n + i];
                    let ya = ja.map_or(C64::new(0.0, 0.0), |j| a.coeffs[j * n + i]);
                    let (d, y) = (abs(yb - ya), abs(yb));
                    diff[i] += d;
                    size[i] += y;
                    diff[n + i] += d * w;
                    size[n + i] += y * w;
                }
            }
        }
    }
    // lines only the first holds (none when the second's truncation contains the first's)
    for ab in &a.blocks {
        let bb = b.blocks.iter().find(|x| x.same_class(ab));
        for il in 0..ab.nl {
            for ik in 0..ab.nk {
                if bb.is_some_and(|bb| ab.map_to(bb, ik, il).is_some()) {
                    continue;
                }
                let ja = ab.start + il * ab.nk + ik;
                let (k, l) = a.lines[ja];
                let w = a.frequency_rad_s(k, l).abs();
                for i in 0..n {
                    let d = abs(a.coeffs[ja * n + i]);
                    diff[i] += d;
                    diff[n + i] += d * w;
                }
            }
        }
    }
    diff.iter().zip(&size).filter(|(_, s)| **s > 0.0).map(|(d, s)| d / s).fold(0.0, f64::max)
}

/// Distance in strides of line index x from the centre of its residue class (the class's line nearest 0):
/// its layer, 0 for a tone that does not vary the stiffness (stride 0).
fn layer(x: isize, stride: usize) -> usize {
    if stride == 0 {
        return 0;
    }
    let g = stride as isize;
    let c = x.rem_euclid(g);
    let centre = if 2 * c > g { c - g } else { c };
    ((x - centre) / g).unsigned_abs()
}

/// Truncation of a tone holding `n` layers each side of every class centre: n g + floor(g / 2) harmonics,
/// so that every residue class has 2n + 1 lines (stride 0: the forcing's harmonics `forced`).
fn truncation(n: usize, stride: usize, forced: usize) -> usize {
    if stride == 0 { forced } else { n * stride + stride / 2 }
}

/// Per tone, the size of the outermost layer (n and beyond) and of the one inside it (n - 1), in the measure
/// of [`difference`] (per DOF and for y and y', sum |Y_kl| (times |w| for y') over the solution's sum, the
/// largest).
fn tails(sol: &TwoToneSolution, strides: [usize; 2], n: [usize; 2]) -> [[f64; 2]; 2] {
    let dof = sol.dof;
    // per tone, [outer, inner], per DOF and kind
    let mut part = vec![[[0.0; 2]; 2]; 2 * dof];
    let mut size = vec![0.0; 2 * dof];
    for (j, &(k, l)) in sol.lines.iter().enumerate() {
        let w = sol.frequency_rad_s(k, l).abs();
        let layers = [layer(k, strides[0]), layer(l, strides[1])];
        for i in 0..dof {
            let y = sol.coeffs[j * dof + i].norm_sqr().sqrt();
            for (kind, v) in [(i, y), (dof + i, y * w)] {
                size[kind] += v;
                for t in 0..2 {
                    if strides[t] == 0 || n[t] == 0 {
                        continue;
                    }
                    if layers[t] >= n[t] {
                        part[kind][t][0] += v;
                    } else if layers[t] + 1 == n[t] {
                        part[kind][t][1] += v;
                    }
                }
            }
        }
    }
    let mut out = [[0.0; 2]; 2];
    for (p, s) in part.iter().zip(&size) {
        if *s > 0.0 {
            for t in 0..2 {
                for e in 0..2 {
                    out[t][e] = f64::max(out[t][e], p[t][e] / s);
                }
            }
        }
    }
    out
}

/// Layers to add to a tone whose outermost layer has size `tail[0]` (`tail[1]` inside it): the fewest (at
/// least one) after which the geometric tail predicts the layers beyond below `target`; half the layers
/// again when the layers do not yet shrink; at most 3n (and 4).
fn grow(n: usize, tail: [f64; 2], target: f64) -> usize {
    let [outer, inner] = tail;
    let most = (3 * n).max(4);
    if outer == 0.0 {
        return 1;
    }
    if outer >= inner {
        return n.div_ceil(2).max(1);
    }
    let rho = outer / inner;
    let mut d = 1;
    // outer rho^(d + 1) / (1 - rho): the layers beyond n + d
    while d < most && outer * rho.powi(d as i32 + 1) / (1.0 - rho) > target {
        d += 1;
    }
    d
}

/// Two-frequency harmonic balance to a tolerance. Each tone's truncation counts layers of its stiffness
/// stride g around every class centre (K = n g + g/2), from at least twice the stiffness harmonics and the
/// forcing's. After each solve every tone grows on its own: by the fewest layers (at least one) after which
/// its outermost layer, shrinking geometrically at the ratio to the layer inside, predicts the layers
/// beyond below a quarter of `tolerance` (a quasi-periodic response may need many harmonics of one tone and
/// few of the other). The estimate of a solution is the change from the previous one (which bounds the
/// previous one's error, so the new one's when the series converges) plus its own predicted tail beyond its
/// truncation (which covers slow convergence), plus the linear solves' error: GMRES runs to a relative
/// residual of tolerance / 1e4, within [1e-13, 1e-10], and one preconditioned correction follows, its size
/// the solve error.
///
/// # Errors
/// Singular lines, GMRES not converging, or the tolerance not reached within `max_harmonics` per tone.
pub fn solve(
    form: &TwoToneForm,
    tolerance: f64,
    max_harmonics: usize,
) -> Result<(TwoToneSolution, TwoToneReport), SolverError> {
    let op = Operator::new(form);
    let g = op.strides;
    let forced = [op.force[0].h, op.force[1].h];
    let start = |t: usize| {
        let need = (2 * op.stiff[t].h).max(forced[t]).max(8);
        if g[t] == 0 { 0 } else { need.saturating_sub(g[t] / 2).div_ceil(g[t]).max(1) }
    };
    let mut n = [start(0), start(1)];
    let h_of = |n: [usize; 2]| [0, 1].map(|t| truncation(n[t], g[t], forced[t]));
    // GMRES's error spreads over every line of a class while the solution sits on a few: far below the
    // tolerance, or the sum over lines of the difference measure counts it many times
    let rtol = (tolerance * 1e-4).clamp(1e-13, 1e-10);
    let (mut prev, mut report) = solve_with(&op, h_of(n), rtol, None)?;
    let target = 0.25 * tolerance;
    loop {
        let tail = tails(&prev, g, n);
        let next_n = [0, 1].map(|t| if g[t] == 0 { 0 } else { n[t] + grow(n[t], tail[t], target) });
        let next_h = h_of(next_n);
        if next_h.iter().any(|&x| x > max_harmonics) {
            return Err(SolverError::ToleranceNotReached {
                cond: f64::NAN,
                tolerance,
                steps: next_h[0].max(next_h[1]),
                estimate: report.error_estimate,
            });
        }
        let (next, r) = solve_with(&op, next_h, rtol, Some(&prev))?;
        report.iterations += r.iterations;
        report.classes = r.classes;
        let change = difference(&prev, &next);
        // the step's error ratio: each tone's last layer ratio to the power of the layers it grew by
        let next_tail = tails(&next, g, next_n);
        let ratio = (0..2)
            .filter(|&t| g[t] != 0 && next_tail[t][0] > 0.0)
            .map(|t| {
                let [outer, inner] = next_tail[t];
                if outer < inner { (outer / inner).powi((next_n[t] - n[t]) as i32) } else { f64::INFINITY }
            })
            .fold(0.0, f64::max);
        let est = change * (ratio / (1.0 - ratio)).max(1.0) + r.solve_error;
        let est = if ratio < 1.0 { est } else { f64::INFINITY };
        report.error_estimate = est;
        report.solve_error = r.solve_error;
        if est <= tolerance {
            return Ok((next, report));
        }
        // the truncation's change already at the level of the linear solves' error: more lines cannot help
        if change <= 10.0 * r.solve_error {
            return Err(SolverError::ToleranceNotReached {
                cond: f64::NAN,
                tolerance,
                steps: next_h[0].max(next_h[1]),
                estimate: est,
            });
        }
        n = next_n;
        prev = next;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A constant-coefficient oscillator forced at two frequencies: each line is the closed-form response
    /// F / (k - m w^2 + i c w), nothing else is excited.
    #[test]
    fn solve_works_on_a_linear_oscillator_with_two_tones() {
        let (m, c, k) = (2.0, 0.3, 50.0);
        let (wa, wb) = (3.0, 3.0 * std::f64::consts::SQRT_2);
        let form = TwoToneForm {
            dof: 1,
            omega_rad_s: [wa, wb],
            mass: vec![m],
            damping: vec![c],
            stiffness: [vec![FourierSeries::constant(k)], vec![FourierSeries::constant(0.0)]],
            forcing: [
                vec![FourierSeries::new(wa, 1.0, vec![0.0, 2.0], vec![])],
                vec![FourierSeries::new(wb, 0.0, vec![], vec![0.5])],
            ],
        };
        let (sol, rep) = solve(&form, 1e-12, 1 << 12).unwrap();
        let h = |w: f64| C64::new(1.0, 0.0) / C64::new(k - m * w * w, c * w);
        // 2 cos(2 wa t) = e^{2 i wa t} + c.c.; 0.5 sin(wb t) = -0.25 i e^{i wb t} + c.c.
        assert!((sol.coefficient(0, 0, 0) - h(0.0)).norm() < 1e-14);
        assert!((sol.coefficient(0, 2, 0) - h(2.0 * wa)).norm() < 1e-14);
        assert!((sol.coefficient(0, 0, 1) - C64::new(0.0, -0.25) * h(wb)).norm() < 1e-14);
        assert!(sol.coefficient(0, 1, 1).norm() == 0.0);
        assert!(rep.error_estimate <= 1e-12);
    }
}
