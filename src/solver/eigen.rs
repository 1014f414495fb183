//! Eigenvalues of a general real matrix that never hang and never return NaN for finite input.
//!
//! nalgebra's `complex_eigenvalues()` iterates without limit and mis-handles 2x2 blocks with real
//! eigenvalues, and its `balance_parlett_reinsch` can loop forever on matrices of huge dynamic range.
//! Recipe: our own bounded Parlett-Reinsch balancing, real Schur form with a bounded iteration count, own
//! 2x2 block eigenvalues, and up to three retries on an orthogonally rotated matrix.

use super::SolverError;
use nalgebra::{Complex, DMatrix};

/// Eigenvalues of a 2x2 real block [[a, b], [c, d]], real pairs handled separately.
fn block_eigenvalues(a: f64, b: f64, c: f64, d: f64) -> [Complex<f64>; 2] {
    let half_tr = 0.5 * (a + d);
    let det = a * d - b * c;
    let p = 0.5 * (a - d);
    let disc = p * p + b * c;
    if disc >= 0.0 {
        let s = disc.sqrt();
        // avoid cancellation: larger root first, the other from the determinant
        let r1 = if half_tr >= 0.0 { half_tr + s } else { half_tr - s };
        let r2 = if r1 != 0.0 { det / r1 } else { half_tr - s };
        [Complex::new(r1, 0.0), Complex::new(r2, 0.0)]
    } else {
        let im = (-disc).sqrt();
        [Complex::new(half_tr, im), Complex::new(half_tr, -im)]
    }
}

/// Deterministic orthogonal matrix (Householder reflector of a fixed pseudo-random vector).
fn rotation(n: usize, seed: u64) -> DMatrix<f64> {
    let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let v = nalgebra::DVector::from_fn(n, |_, _| {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    });
    let v = v.normalize();
    DMatrix::identity(n, n) - 2.0 * &v * v.transpose()
}

/// Parlett-Reinsch balancing by powers of 2 (a similarity, so eigenvalues are unchanged), at most 100
/// sweeps and scale factors within 2^+-500 (nalgebra's version has no bound and can spin forever).
/// Returns the diagonal d of the similarity: the balanced matrix is D^-1 M D, D = diag(d).
pub fn balance(m: &mut DMatrix<f64>) -> Vec<f64> {
    let n = m.nrows();
    let mut d = vec![1.0; n];
    const RADIX: f64 = 2.0;
    for _ in 0..100 {
        let mut done = true;
        for i in 0..n {
            let c: f64 = (0..n).filter(|&j| j != i).map(|j| m[(j, i)].abs()).sum();
            let r: f64 = (0..n).filter(|&j| j != i).map(|j| m[(i, j)].abs()).sum();
            if c == 0.0 || r == 0.0 || !c.is_finite() || !r.is_finite() {
                continue;
            }
            let s = c + r;
            let (mut f, mut cc) = (1.0f64, c);
            let mut guard = 0;
            while cc < r / RADIX && guard < 500 {
                f *= RADIX;
                cc *= RADIX * RADIX;
                guard += 1;
            }
            while cc > r * RADIX && guard < 1000 {
                f /= RADIX;
                cc /= RADIX * RADIX;
                guard += 1;
            }
            // column i scaled by f and row i by 1/f: keep it when the two norms shrink by 5 %
            if c * f + r / f < 0.95 * s {
                done = false;
                d[i] *= f;
                for j in 0..n {
                    m[(i, j)] /= f;
                    m[(j, i)] *= f;
                }
            }
        }
        if done {
            break;
        }
    }
    d
}

/// Eigenvalues of `m` (any finite square real matrix), sorted by decreasing modulus.
///
/// # Errors
/// [`SolverError::NonFinite`] for NaN/inf entries, [`SolverError::EigenFailed`] when the QR iteration does
/// not converge within 300 n iterations on the matrix and three rotated copies.
pub fn eigenvalues(m: &DMatrix<f64>) -> Result<Vec<Complex<f64>>, SolverError> {
    let n = m.nrows();
    if m.iter().any(|v| !v.is_finite()) {
        return Err(SolverError::NonFinite { what: "matrix passed to the eigenvalue solver".into() });
    }
    let mut out = match n {
        0 => Vec::new(),
        1 => vec![Complex::new(m[(0, 0)], 0.0)],
        2 => block_eigenvalues(m[(0, 0)], m[(0, 1)], m[(1, 0)], m[(1, 1)]).to_vec(),
        _ => schur_eigenvalues(m)?,
    };
    out.sort_by(|a, b| b.norm().total_cmp(&a.norm()).then(b.im.total_cmp(&a.im)));
    Ok(out)
}

fn schur_eigenvalues(m: &DMatrix<f64>) -> Result<Vec<Complex<f64>>, SolverError> {
    let n = m.nrows();
    for attempt in 0..4u64 {
        let mut a = if attempt == 0 {
            m.clone()
        } else {
            let q = rotation(n, attempt);
            q.transpose() * m * &q
        };
        balance(&mut a);
        let Some(schur) = nalgebra::linalg::Schur::try_new(a, f64::EPSILON, 300 * n) else { continue };
        let (_, t) = schur.unpack();
        let mut vals = Vec::with_capacity(n);
        let mut i = 0;
        while i < n {
            if i + 1 < n && t[(i + 1, i)] != 0.0 {
                vals.extend(block_eigenvalues(t[(i, i)], t[(i, i + 1)], t[(i + 1, i)], t[(i + 1, i + 1)]));
                i += 2;
            } else {
                vals.push(Complex::new(t[(i, i)], 0.0));
                i += 1;
            }
        }
        if vals.iter().all(|v| v.re.is_finite() && v.im.is_finite()) {
            return Ok(vals);
        }
    }
    Err(SolverError::EigenFailed { n })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigenvalues_works_on_cyclic_shift() {
        // cyclic shift: eigenvalues are the n-th roots of unity; plain QR without exceptional shifts stalls
        for n in [4usize, 6, 8, 12] {
            let m = DMatrix::from_fn(n, n, |i, j| if (i + 1) % n == j { 1.0 } else { 0.0 });
            let ev = eigenvalues(&m).unwrap();
            assert_eq!(ev.len(), n);
            for v in &ev {
                assert!((v.norm() - 1.0).abs() < 1e-10, "n={n} {v}");
                // each is a root of unity: v^n = 1
                assert!((v.powu(n as u32) - Complex::new(1.0, 0.0)).norm() < 1e-8);
            }
        }
    }

    #[test]
    fn eigenvalues_works_on_companion() {
        // roots 0.5, -2, 3 +- 1i  (polynomial built from them, eigenvalues of its companion matrix)
        let roots = [Complex::new(0.5, 0.0), Complex::new(-2.0, 0.0), Complex::new(3.0, 1.0), Complex::new(3.0, -1.0)];
        let mut poly = vec![Complex::new(1.0, 0.0)];
        for r in roots {
            let mut next = vec![Complex::new(0.0, 0.0); poly.len() + 1];
            for (i, c) in poly.iter().enumerate() {
                next[i] += c;
                next[i + 1] -= c * r;
            }
            poly = next;
        }
        let n = 4;
        let m = DMatrix::from_fn(n, n, |i, j| {
            if i == 0 {
                -poly[j + 1].re
            } else if i == j + 1 {
                1.0
            } else {
                0.0
            }
        });
        let ev = eigenvalues(&m).unwrap();
        for r in roots {
            assert!(ev.iter().any(|v| (v - r).norm() < 1e-12), "{r} not in {ev:?}");
        }
    }

    #[test]
    fn balance_terminates_on_huge_dynamic_range() {
        // regression: nalgebra's balance_parlett_reinsch spun forever on a diverged RK4 monodromy like this
        let m = DMatrix::from_row_slice(3, 3, &[1e300, 1e-300, 0.0, 1e-300, 1.0, 1e300, 0.0, 1e-200, 1e-10]);
        let mut b = m.clone();
        balance(&mut b);
        assert!(eigenvalues(&m).is_ok());
        // a similarity: the trace is unchanged
        assert_eq!(b.trace(), m.trace());
    }

    #[test]
    fn eigenvalues_rejects_nan() {
        let m = DMatrix::from_row_slice(2, 2, &[1.0, f64::NAN, 0.0, 1.0]);
        assert!(eigenvalues(&m).is_err());
    }
}
