//! The local-fault search of `identify`: for every tooth of each gear the period covers, the pit depth
//! (linear: one more column of the fit) or the crack's stiffness loss (a grid of losses, each one
//! time-stepped solve shared by all teeth, then a golden-section refinement on the best tooth) that best
//! explains the lines, kept when it lowers the weighted residual beyond the noise.
//!
//! ```text
//! significance = (S_healthy - S_fault) / s^2,   s^2 = S_fault / dof   (an F statistic; kept above 25)
//! improvement  = 1 - S_fault / S_healthy
//! ```

use super::IdentifyJob;
use super::fit::{self, Fit, Problem};
use super::transfer::{self, Setup};
use crate::Error;
use crate::model::gear::Gear;
use crate::report::summary::{FaultKind, LocalFault};
use nalgebra::Complex;
use rayon::prelude::*;

type C64 = Complex<f64>;

/// Significance above which a fault is reported (an F statistic with one degree of freedom of 25 has a
/// false-alarm probability below 1e-6 per candidate, so below 1e-4 over a hundred teeth).
pub const SIGNIFICANCE: f64 = 25.0;

/// Losses of the crack grid.
const CRACK_GRID: [f64; 12] = [0.03, 0.06, 0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.6, 0.7, 0.85];

/// The fault chosen and its fit.
pub struct Chosen {
    /// The fault.
    pub fault: LocalFault,
    /// The fit with it.
    pub fit: Fit,
}

/// What the search found.
pub struct Search {
    /// The best significant fault, if any.
    pub chosen: Option<Chosen>,
    /// The best candidate of each kind and gear.
    pub candidates: Vec<LocalFault>,
}

fn gears(setup: &Setup) -> Vec<(Gear, usize)> {
    let mut g = vec![(Gear::Pinion, setup.params.pinion_teeth)];
    if setup.wheel_orders > 0 {
        g.push((Gear::Wheel, setup.params.wheel_teeth));
    }
    g
}

/// Runs the search for the kinds `job` asks.
///
/// # Errors
/// Solver failures of the fault responses.
pub fn search(job: &IdentifyJob, setup: &Setup, problem: &Problem, healthy: &Fit) -> Result<Search, Error> {
    let mut best: Vec<(LocalFault, Fit)> = Vec::new();
    for &(gear, teeth) in &gears(setup) {
        for kind in &job.faults {
            let found = match kind {
                FaultKind::Pit => pit(job, setup, problem, healthy, gear, teeth)?,
                FaultKind::Crack => crack(setup, problem, healthy, gear, teeth)?,
            };
            best.extend(found);
        }
    }
    let candidates: Vec<LocalFault> = best.iter().map(|b| b.0.clone()).collect();
    let chosen = best
        .into_iter()
        .filter(|b| b.0.significant)
        .max_by(|a, b| a.0.significance.total_cmp(&b.0.significance))
        .map(|(fault, fit)| Chosen { fault, fit });
    Ok(Search { chosen, candidates })
}

fn judged(kind: FaultKind, gear: Gear, tooth: usize, depth: f64, healthy: &Fit, f: &Fit) -> LocalFault {
    let s2 = (f.chi2 / f.dof as f64).max(f64::MIN_POSITIVE);
    let significance = (healthy.chi2 - f.chi2) / s2;
    LocalFault {
        kind,
        gear,
        tooth,
        depth,
        depth_unit: match kind {
            FaultKind::Pit => "m",
            FaultKind::Crack => "fraction",
        },
        // a candidate that fits worse than none (its best depth at the end of the search range) improves nothing
        improvement: (1.0 - f.chi2 / healthy.chi2.max(f64::MIN_POSITIVE)).max(0.0),
        significance: significance.max(0.0),
        significant: significance > SIGNIFICANCE,
    }
}

/// Pit on each tooth: the tooth-1 response delayed, one more real column (the depth).
fn pit(
    job: &IdentifyJob,
    setup: &Setup,
    problem: &Problem,
    healthy: &Fit,
    gear: Gear,
    teeth: usize,
) -> Result<Option<(LocalFault, Fit)>, Error> {
    let unit = transfer::pit(setup, gear, job.pit_width_teeth)?;
    let fits: Vec<(usize, Fit)> = (1..=teeth)
        .into_par_iter()
        .filter_map(|tooth| {
            let col = transfer::delayed(setup, &unit, tooth);
            let mut cols: Vec<&[C64]> = problem.columns.to_vec();
            cols.push(&col);
            let p = Problem { columns: &cols, ..*problem };
            fit::fit(&p, Some(&healthy.params)).ok().map(|f| (tooth, f))
        })
        .collect();
    Ok(fits.into_iter().min_by(|a, b| a.1.chi2.total_cmp(&b.1.chi2)).map(|(tooth, f)| {
        let depth = f.params.last().copied().unwrap_or(0.0);
        (judged(FaultKind::Pit, gear, tooth, depth, healthy, &f), f)
    }))
}

/// The healthy static response R0 plus a tooth-1 static-load change moved to `tooth`.
fn cracked_base(setup: &Setup, problem: &Problem, change: &[C64], tooth: usize) -> Vec<C64> {
    let moved = transfer::delayed(setup, change, tooth);
    problem.base.iter().zip(&moved).map(|(b, d)| b + d).collect()
}

/// The fit with the healthy static response R0 replaced by R0 + (R_crack - R_crack(0)) moved to `tooth`
/// (the difference of two time-stepped responses on one grid: their discretisation error cancels).
fn crack_fit(setup: &Setup, problem: &Problem, healthy: &Fit, change: &[C64], tooth: usize) -> Option<Fit> {
    let base = cracked_base(setup, problem, change, tooth);
    let p = Problem { base: &base, ..*problem };
    fit::fit(&p, Some(&healthy.params)).ok()
}

/// Crack on each tooth. The static-load change R_crack(L) - R_crack(0) is solved on a grid of losses (one
/// solve per loss, shared by the teeth: a crack on tooth n is the tooth-1 crack delayed) and interpolated
/// between them (cubic Hermite in L, per line). The tooth is the one whose best grid loss fits best with
/// the healthy errors kept and only the gains refitted (closed form, cheap); its loss L1 comes from a
/// golden-section search on full fits with the healthy mesh's error transfers T0. A crack that matters
/// then gets the cracked mesh's own error transfers T1 at L1 (one solve per column), taken linear in the
/// loss (T(L) = T0 + (L / L1) (T1 - T0)), and the loss is refined on full fits within 20 % of L1: on the
/// bundled cracked recording (30 % loss) L1 = 0.292 with chi2/dof 380 and the refined 0.299 with 0.56.
fn crack(
    setup: &Setup,
    problem: &Problem,
    healthy: &Fit,
    gear: Gear,
    teeth: usize,
) -> Result<Option<(LocalFault, Fit)>, Error> {
    let zero = transfer::cracked(setup, gear, 1, 0.0, None)?;
    let change = |loss: f64| -> Result<Vec<C64>, Error> {
        let r = transfer::cracked(setup, gear, 1, loss, None)?;
        Ok(r.iter().zip(&zero).map(|(a, b)| a - b).collect())
    };
    let changes: Vec<Vec<C64>> = CRACK_GRID.par_iter().map(|&loss| change(loss)).collect::<Result<_, _>>()?;
    let ranked: Vec<(usize, usize, f64)> = (0..CRACK_GRID.len())
        .flat_map(|k| (1..=teeth).map(move |t| (k, t)))
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|(k, tooth)| (k, tooth, gains_only_chi2(setup, problem, healthy, &changes[k], tooth)))
        .collect();
    let Some(&(_, tooth, _)) = ranked.iter().min_by(|a, b| a.2.total_cmp(&b.2)) else { return Ok(None) };
    // the loss on this tooth: golden section over the whole range on full fits of the interpolated change
    // (with the healthy mesh's error transfers)
    let plain = |loss: f64| -> Result<(f64, Option<Fit>), Error> {
        let f = crack_fit(setup, problem, healthy, &interpolated(&changes, loss), tooth);
        Ok((f.as_ref().map_or(f64::INFINITY, |f| f.chi2), f))
    };
    let (first, approx) = golden(1e-3, CRACK_GRID[CRACK_GRID.len() - 1], 20, plain)?;
    let Some(approx) = approx else { return Ok(None) };
    if !judged(FaultKind::Crack, gear, tooth, first, healthy, &approx).significant {
        return Ok(Some((judged(FaultKind::Crack, gear, tooth, first, healthy, &approx), approx)));
    }
    // a crack that matters: the cracked mesh's own error transfers T1 at that loss (one solve per column),
    // taken linear in the loss around it (T(L) = T0 + (L / L1) (T1 - T0)), and the loss refined on full fits
    let at = change(first)?;
    let exact: Vec<Vec<C64>> = transfer::cracked_columns(setup, gear, tooth, first)?;
    let at_first = interpolated(&changes, first);
    let refined = |loss: f64| -> Option<Fit> {
        let r = loss / first;
        let cols: Vec<Vec<C64>> = problem
            .columns
            .iter()
            .zip(&exact)
            .map(|(t0, t1)| t0.iter().zip(t1).map(|(a, b)| a + (b - a) * r).collect())
            .collect();
        let refs: Vec<&[C64]> = cols.iter().map(Vec::as_slice).collect();
        let change: Vec<C64> =
            interpolated(&changes, loss).iter().zip(&at_first).zip(&at).map(|((a, b), c)| c + a - b).collect();
        let base = cracked_base(setup, problem, &change, tooth);
        let p = Problem { base: &base, columns: &refs, ..*problem };
        fit::fit(&p, Some(&approx.params)).ok()
    };
    let eval = |loss: f64| -> Result<(f64, Option<Fit>), Error> {
        let f = refined(loss);
        Ok((f.as_ref().map_or(f64::INFINITY, |f| f.chi2), f))
    };
    let (loss, f) = match golden(0.8 * first, (1.2 * first).min(0.95), 15, eval)? {
        (loss, Some(f)) if f.chi2 <= approx.chi2 => (loss, f),
        _ => (first, approx),
    };
    Ok(Some((judged(FaultKind::Crack, gear, tooth, loss, healthy, &f), f)))
}

/// Weighted residual with the healthy fit's error parameters kept and only the gains refitted (closed
/// form): the ranking of crack candidates.
fn gains_only_chi2(setup: &Setup, problem: &Problem, healthy: &Fit, change: &[C64], tooth: usize) -> f64 {
    let base = cracked_base(setup, problem, change, tooth);
    let p = Problem { base: &base, ..*problem };
    fit::chi2_with_params(&p, &healthy.params)
}

/// The change at `loss` from the grid: zero at loss 0, cubic (Catmull-Rom) between grid losses, per line.
fn interpolated(changes: &[Vec<C64>], loss: f64) -> Vec<C64> {
    // knots: loss 0 (no change) then the grid
    let xs: Vec<f64> = std::iter::once(0.0).chain(CRACK_GRID).collect();
    let zero = vec![C64::new(0.0, 0.0); changes[0].len()];
    let ys: Vec<&Vec<C64>> = std::iter::once(&zero).chain(changes).collect();
    let last = xs.len() - 1;
    let i = xs.partition_point(|&x| x <= loss).clamp(1, last) - 1;
    let t = (loss - xs[i]) / (xs[i + 1] - xs[i]);
    // Hermite with finite-difference slopes on the uneven grid
    let slope = |j: usize, l: usize| -> C64 {
        let (a, b) = (j.saturating_sub(1), (j + 1).min(last));
        (ys[b][l] - ys[a][l]) / (xs[b] - xs[a])
    };
    let h = xs[i + 1] - xs[i];
    let (h00, h10, h01, h11) = (
        2.0 * t.powi(3) - 3.0 * t * t + 1.0,
        t.powi(3) - 2.0 * t * t + t,
        -2.0 * t.powi(3) + 3.0 * t * t,
        t.powi(3) - t * t,
    );
    (0..zero.len())
        .map(|l| ys[i][l] * h00 + slope(i, l) * (h10 * h) + ys[i + 1][l] * h01 + slope(i + 1, l) * (h11 * h))
        .collect()
}

/// Golden-section minimum of `eval` on [a, b] with `iterations` narrowings; returns the best point seen
/// and its payload.
fn golden<T>(
    mut a: f64,
    mut b: f64,
    iterations: usize,
    mut eval: impl FnMut(f64) -> Result<(f64, Option<T>), Error>,
) -> Result<(f64, Option<T>), Error> {
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
    let (mut fc, mut fd) = (eval(c)?, eval(d)?);
    for _ in 0..iterations {
        if fc.0 < fd.0 {
            b = d;
            d = c;
            fd = fc;
            c = b - r * (b - a);
            fc = eval(c)?;
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + r * (b - a);
            fd = eval(d)?;
        }
    }
    Ok(if fc.0 < fd.0 { (c, fc.1) } else { (d, fd.1) })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Golden section finds the minimum of a parabola to the bracket's shrinkage (0.618^n of the width).
    #[test]
    fn golden_finds_parabola_minimum() {
        let (x, _) = golden(0.0, 1.0, 30, |x| Ok(((x - 0.3141).powi(2), Some(())))).unwrap();
        assert!((x - 0.3141).abs() < 1e-5, "{x}");
    }
}
