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
pub(super) fn floquet_warnings(floquet: &mut Floquet, accuracy: f64, phi_error: f64, warnings: &mut Vec<String>) {
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
    repeated_warning(floquet, phi_error, warnings);
}

/// Nearly repeated multipliers (as at a parametric-resonance boundary) are sensitive like the square root of
/// the monodromy error: say how far their values can be trusted.
fn repeated_warning(f: &Floquet, phi_error: f64, warnings: &mut Vec<String>) {
    let m = &f.multipliers;
    let scale = f.rho_max.max(f64::MIN_POSITIVE);
    for i in 0..m.len() {
        for j in i + 1..m.len() {
            if (m[i] - m[j]).norm() < 1e-3 * scale && m[i].norm() > 1e-6 * scale {
                let spread = phi_error.max(f64::EPSILON).sqrt() * scale;
                warnings.push(format!(
                    "multipliers {i} and {j} nearly coincide ({:.6}{:+.6}i): near a stability boundary their values are only good to about {spread:.1e}; the monodromy itself meets the tolerance",
                    m[i].re, m[i].im
                ));
                return;
            }
        }
    }
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
