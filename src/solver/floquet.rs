//! Floquet multipliers and exponents of a monodromy matrix (Eqs 8-11), and the stability warnings every
//! solver shares.
//!
//! ```text
//! rho_k = eig(Phi) (Eqs 9-10),  lambda_k = ln(rho_k) / T (Eq 11),  asymptotically stable <=> |rho|max < 1
//! ```

use super::{SolverError, eigen};
use nalgebra::{Complex, DMatrix};

/// Floquet multipliers and what they say about stability.
#[derive(Clone, Debug)]
pub struct Floquet {
    /// Multipliers rho_k, by decreasing modulus.
    pub multipliers: Vec<Complex<f64>>,
    /// Exponents lambda_k = ln(rho_k) / T in 1/s (principal logarithm; `None` for rho = 0).
    pub exponents: Vec<Option<Complex<f64>>>,
    /// |rho|max.
    pub rho_max: f64,
    /// |rho|max < 1.
    pub stable: bool,
}

impl Floquet {
    /// Multipliers of `phi` for a period `period_s`.
    ///
    /// # Errors
    /// From [`eigen::eigenvalues`].
    pub fn from_monodromy(phi: &DMatrix<f64>, period_s: f64) -> Result<Self, SolverError> {
        let multipliers = eigen::eigenvalues(phi)?;
        let rho_max = multipliers.iter().map(|r| r.norm()).fold(0.0, f64::max);
        let exponents = multipliers.iter().map(|r| (r.norm() > 0.0).then(|| r.ln() / period_s)).collect();
        Ok(Self { multipliers, exponents, rho_max, stable: rho_max < 1.0 })
    }
}

/// Stability warnings shared by all solvers: marginal (|rho|max = 1 within `accuracy`, then marked not
/// stable), unstable, a multiplier near +1, nearly repeated multipliers.
pub(super) fn floquet_warnings(floquet: &mut Floquet, accuracy: f64, rho_error: f64, warnings: &mut Vec<String>) {
    if (floquet.rho_max - 1.0).abs() <= accuracy {
        // on the unit circle within the accuracy: bounded at best, never asymptotically stable
        floquet.stable = false;
        warnings.push(format!(
            "|rho|max = {:.12} equals 1 within the accuracy: marginally stable at best (not asymptotically stable)",
            floquet.rho_max
        ));
    } else if !floquet.stable {
        warnings.push(format!(
            "unstable: |rho|max = {} > 1; the periodic solution exists but is not the attractor (free vibration grows)",
            fmt_rho(floquet.rho_max)
        ));
    }
    if let Some(r) = floquet.multipliers.iter().map(|r| (r - 1.0).norm()).reduce(f64::min) {
        if r < 1e-6 {
            warnings.push(format!("a Floquet multiplier lies within {r:.1e} of +1 (near resonance)"));
        }
    }
    repeated_warning(floquet, rho_error, warnings);
}

/// Nearly repeated multipliers (as at a parametric-resonance boundary) can be sensitive like the square root
/// of the monodromy error: say how far their values can be trusted (`rho_error`, relative to max(|rho|max,
/// 1)).
fn repeated_warning(f: &Floquet, rho_error: f64, warnings: &mut Vec<String>) {
    let m = &f.multipliers;
    let scale = f.rho_max.max(f64::MIN_POSITIVE);
    for i in 0..m.len() {
        for j in i + 1..m.len() {
            if (m[i] - m[j]).norm() < 1e-3 * scale && m[i].norm() > 1e-6 * scale {
                let spread = rho_error * scale;
                warnings.push(format!(
                    "multipliers {i} and {j} nearly coincide ({:.6}{:+.6}i): near a stability boundary their values are only good to about {spread:.1e}",
                    m[i].re, m[i].im
                ));
                return;
            }
        }
    }
}

/// Says so when the multipliers' estimated error is above the tolerance (the result is then not trusted).
pub(super) fn untrusted_multipliers(rho_error: f64, tolerance: f64, warnings: &mut Vec<String>) {
    if rho_error > tolerance {
        warnings.push(format!(
            "the multipliers are only good to about {rho_error:.1e} (relative to max(|rho|max, 1)), above the tolerance: nearly repeated multipliers move like the square root of the monodromy's error"
        ));
    }
}

/// Non-normality of a (balanced) monodromy `b`: ||b b^T - b^T b||_F / ||b||_F, zero for a normal matrix and
/// of the order of the strictly upper part of its Schur form otherwise (a Jordan block [1 1; 0 1]: 0.8). A
/// nearly repeated pair moves like the square root of a perturbation only when this is large against their
/// distance. (Henrici's sqrt(||b||_F^2 - sum |rho|^2) loses half the digits to cancellation: 1e-8 for a
/// monodromy near the identity.)
pub fn departure_from_normality(b: &DMatrix<f64>) -> f64 {
    let size = b.norm();
    if size == 0.0 { 0.0 } else { (b * b.transpose() - b.transpose() * b).norm() / size }
}

/// Estimated error of the multipliers of `printed` relative to max(|rho|max, 1), from the change of each to
/// its nearest multiplier of `other` (the same system at another resolution). `factors` turn the change into
/// the printed one's error: the first for a multiplier that moves linearly with the monodromy's error, the
/// second for a nearly repeated one (within 1e-3 of another) of a non-normal monodromy (`departure`, see
/// [`departure_from_normality`], above ten times their distance), which moves like its square root.
/// `rounding` is the relative rounding of the monodromy (of its own size `phi_size`): a simple multiplier
/// inherits it, such a pair at distance s inherits min(sqrt(r departure), r departure / s) more (the
/// perturbation of a 2 x 2 Schur block [rho1 t; 0 rho2]).
pub fn multiplier_change(
    printed: &Floquet,
    other: &Floquet,
    factors: (f64, f64),
    rounding: f64,
    departure: f64,
    phi_size: f64,
) -> f64 {
    let m = &printed.multipliers;
    let scale = printed.rho_max.max(1.0);
    let r_abs = rounding * phi_size;
    let mut worst: f64 = 0.0;
    for (i, r) in m.iter().enumerate() {
        let change = other.multipliers.iter().map(|s| (s - r).norm()).fold(f64::INFINITY, f64::min);
        let change = if change.is_finite() { change } else { 0.0 };
        let gap =
            m.iter().enumerate().filter(|(j, _)| *j != i).map(|(_, s)| (s - r).norm()).fold(f64::INFINITY, f64::min);
        let repeated = gap < 1e-3 * r.norm() && departure > 10.0 * gap;
        let factor = if repeated { factors.1 } else { factors.0 };
        let own = if repeated {
            r_abs + (r_abs * departure).sqrt().min(r_abs * departure / gap.max(f64::MIN_POSITIVE))
        } else {
            r_abs
        };
        worst = worst.max((factor * change + own) / scale);
    }
    worst
}

/// ", a multiplier near +1 (within D)" when one is (D < 1e-3), else nothing: a large cond(I - Phi) is
/// only blamed on a multiplier near +1 when there is one.
pub fn nearest_to_one(f: &Floquet) -> String {
    match f.multipliers.iter().map(|r| (r - 1.0).norm()).reduce(f64::min) {
        Some(d) if d < 1e-3 => format!(", a multiplier near +1 (within {d:.1e})"),
        _ => String::new(),
    }
}

/// 2-norm condition number by an SVD with a bounded number of sweeps (nalgebra's plain
/// `singular_values()` iterates without limit); infinite when singular or not converged.
pub fn condition_number(a: &DMatrix<f64>) -> f64 {
    match nalgebra::linalg::SVD::try_new(a.clone(), false, false, f64::EPSILON, 200 * a.nrows().max(1)) {
        Some(svd) => {
            let (smax, smin) = (svd.singular_values.max(), svd.singular_values.min());
            if smin > 0.0 && smax.is_finite() { smax / smin } else { f64::INFINITY }
        }
        None => f64::INFINITY,
    }
}

fn fmt_rho(r: f64) -> String {
    if r < 1e3 { format!("{r:.6}") } else { format!("{r:.3e}") }
}
