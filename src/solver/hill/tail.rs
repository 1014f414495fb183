//! The first-order truncation error of a harmonic-balance solution and its continuation beyond H.

use super::classes::Classes;
use super::{C64, Extension, HillSolution, component_size};
use crate::solver::band::Band;
use nalgebra::{DMatrix, DVector};

impl Classes {
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
    pub(super) fn tail(
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
    pub(super) fn extend(
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
    pub(super) fn extend_scalar(
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
}

/// Adds `v` and `v` times `rate` (|n| w) at `slot` of a [`Tail::beyond`] list, growing it as needed.
pub(super) fn add_beyond(list: &mut Vec<[f64; 2]>, slot: usize, v: f64, rate: f64) {
    if list.len() <= slot {
        list.resize(slot + 1, [0.0; 2]);
    }
    list[slot][0] += v;
    list[slot][1] += v * rate;
}

/// [`Classes::extend`] of every class of `solution` (unforced classes too: their forcing may lie beyond
/// H), into the per-DOF sums of [`Tail::beyond`]; `None` when a continuation fails.
pub(super) fn continuation(
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
pub(super) struct Tail {
    /// Its size in the measure of [`difference`] times the factor that makes it a bound (1.25 / (1 - delta)
    /// or 6, see [`solve_order_with`]); infinite when a ring beyond H is singular.
    pub(super) size: f64,
    /// That factor: the estimate over the difference from `corrected`.
    pub(super) factor: f64,
    /// The solution plus the error's first-order estimate (harmonics to H + 2 hc).
    pub(super) corrected: HillSolution,
    /// The solution continued beyond H ([`Classes::extend`]): per DOF, per |n| - H - 1, the sums of |Y_n|
    /// and |n| w |Y_n|; `None` when not asked for or where the outside block is not diagonally dominant.
    pub(super) beyond: Option<Vec<Vec<[f64; 2]>>>,
}

impl Tail {
    /// The smallest truncation H' > H (H = `of.harmonics`) at which the first-order truncation error is
    /// predicted to be at most `target`, from the continuation beyond H: the harmonics beyond H' weigh
    /// S(H') / size (per component, as in [`tail_size`]), and the estimate at H' is taken to keep its ratio
    /// to that weight at H (the measured estimate over S(H) / size: the inside feedback and the factor, at
    /// least 1/2). `None` without a continuation or when even its end does not meet `target`.
    pub(super) fn predict(&self, of: &HillSolution, target: f64) -> Option<usize> {
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
pub(super) fn tail_size(sums: &[[f64; 2]], of: &HillSolution) -> f64 {
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
