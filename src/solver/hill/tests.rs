//! Tests of the harmonic-balance solver: an operator with a stride-3 coupling against its band and a larger truncation.

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
    two.mass = vec![series(1.0, vec![0.0, 0.0, 0.2]), series(0.0, vec![]), series(0.1, vec![]), series(2.0, vec![])];
    two.damping = vec![series(0.05, vec![]), series(0.0, vec![]), series(0.0, vec![]), series(0.03, vec![])];
    two.stiffness =
        vec![one.stiffness[0].clone(), series(-0.5, vec![]), series(-0.5, vec![]), series(3.0, vec![0.0, 0.0, 1.0])];
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
