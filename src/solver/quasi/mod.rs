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
use crate::system::FourierSeries;
pub use crate::system::TwoToneForm;
use crate::system::gcd;
use nalgebra::Complex;

type C64 = Complex<f64>;

mod class;
use class::{Class, gmres};
mod estimate;
pub use estimate::difference;
use estimate::{grow, tails, truncation};

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
mod tests;
