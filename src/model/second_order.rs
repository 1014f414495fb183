//! Generic N-DOF second-order periodic system M(t) y'' + C(t) y' + K(t) y = d(t) (Eq 2).

use crate::system::{Coefficient, FourierForm, PeriodicSystem, Side};
use nalgebra::{DMatrix, DVector};

/// Row-major N x N coefficient matrices and N forcing entries, all of one period `period_s`.
#[derive(Clone, Debug)]
pub struct SecondOrderSystem {
    dof: usize,
    period_s: f64,
    mass: Vec<Coefficient>,
    damping: Vec<Coefficient>,
    stiffness: Vec<Coefficient>,
    forcing: Vec<Coefficient>,
    /// M^-1 when M is constant (symmetric positive definite, checked), so that each evaluation is one
    /// matrix product (the triangular solves with a stored LU cost 18 % of a 16-DOF chain's run).
    constant_mass_inverse: Option<DMatrix<f64>>,
    breakpoints: Vec<f64>,
}

/// Why a second-order system could not be built.
#[derive(Clone, Debug, PartialEq)]
pub enum BuildError {
    /// The named matrix does not have N x N (or N) entries.
    Size {
        /// "mass", "damping", "stiffness" or "forcing".
        what: &'static str,
        /// Entries expected.
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// M(t) is singular (or nearly so) at time t.
    SingularMass {
        /// Time in s.
        t: f64,
    },
    /// M(t) is not symmetric positive definite at time t (a negative mass or inertia, or an asymmetric
    /// mass matrix): kinetic energy must be positive.
    MassNotPositiveDefinite {
        /// Time in s.
        t: f64,
    },
}

impl SecondOrderSystem {
    /// Builds the system and checks sizes and that M(t) is invertible, symmetric and positive definite at
    /// 64 sample times per period.
    ///
    /// # Errors
    /// [`BuildError`] on mismatched sizes or a singular mass matrix.
    pub fn new(
        period_s: f64,
        mass: Vec<Coefficient>,
        damping: Vec<Coefficient>,
        stiffness: Vec<Coefficient>,
        forcing: Vec<Coefficient>,
    ) -> Result<Self, BuildError> {
        let dof = forcing.len();
        for (what, m) in [("mass", &mass), ("damping", &damping), ("stiffness", &stiffness)] {
            if m.len() != dof * dof {
                return Err(BuildError::Size { what, expected: dof * dof, got: m.len() });
            }
        }
        let mut breakpoints: Vec<f64> = Vec::new();
        for c in mass.iter().chain(&damping).chain(&stiffness).chain(&forcing) {
            if let Coefficient::Piecewise(p) = c {
                let reps = (period_s / p.period_s).round().max(1.0) as usize;
                for r in 0..reps {
                    breakpoints.extend(p.jumps().iter().map(|j| j + r as f64 * p.period_s));
                }
            }
        }
        breakpoints.retain(|&b| b > 1e-12 * period_s && b < period_s * (1.0 - 1e-12));
        breakpoints.sort_by(f64::total_cmp);
        breakpoints.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * period_s);
        let mut sys =
            Self { dof, period_s, mass, damping, stiffness, forcing, constant_mass_inverse: None, breakpoints };
        for i in 0..64 {
            let t = period_s * i as f64 / 64.0;
            let m = sys.matrix(&sys.mass, t, Side::Right);
            let scale = m.amax();
            let lu = m.lu();
            let ok = scale > 0.0 && lu.u().diagonal().iter().all(|d| d.abs() > 1e-12 * scale);
            if !ok {
                return Err(BuildError::SingularMass { t });
            }
            let m = sys.matrix(&sys.mass, t, Side::Right);
            let symmetric = (0..dof).all(|r| (0..r).all(|c| (m[(r, c)] - m[(c, r)]).abs() <= 1e-12 * scale));
            if !symmetric || m.cholesky().is_none() {
                return Err(BuildError::MassNotPositiveDefinite { t });
            }
        }
        if sys.mass.iter().all(Coefficient::is_constant) {
            sys.constant_mass_inverse = sys.matrix(&sys.mass, 0.0, Side::Right).cholesky().map(|c| c.inverse());
        }
        Ok(sys)
    }

    /// Degrees of freedom N.
    pub fn dof(&self) -> usize {
        self.dof
    }

    fn matrix(&self, entries: &[Coefficient], t: f64, side: Side) -> DMatrix<f64> {
        DMatrix::from_fn(self.dof, self.dof, |i, j| entries[i * self.dof + j].eval(t, side))
    }
}

impl PeriodicSystem for SecondOrderSystem {
    fn dim(&self) -> usize {
        2 * self.dof
    }
    fn period_s(&self) -> f64 {
        self.period_s
    }
    fn eval(&self, t: f64, side: Side, p: &mut DMatrix<f64>, f: &mut DVector<f64>) {
        let n = self.dof;
        // rhs = [K | C | d]; solve M X = rhs, then P_bottom = -[X_K | X_C], f_bottom = X_d
        let mut rhs = DMatrix::zeros(n, 2 * n + 1);
        for i in 0..n {
            for j in 0..n {
                rhs[(i, j)] = self.stiffness[i * n + j].eval(t, side);
                rhs[(i, n + j)] = self.damping[i * n + j].eval(t, side);
            }
            rhs[(i, 2 * n)] = self.forcing[i].eval(t, side);
        }
        let solved = match &self.constant_mass_inverse {
            Some(inverse) => inverse * &rhs,
            None => self
                .matrix(&self.mass, t, side)
                .lu()
                .solve(&rhs)
                .expect("mass matrix checked invertible at construction"),
        };
        p.fill(0.0);
        f.fill(0.0);
        for i in 0..n {
            p[(i, n + i)] = 1.0;
            for j in 0..2 * n {
                p[(n + i, j)] = -solved[(i, j)];
            }
            f[n + i] = solved[(i, 2 * n)];
        }
    }
    /// P at equally spaced times with every mass, damping and stiffness entry a Fourier series: each entry
    /// sampled once over all the times ([`FourierSeries::sample_uniform`](crate::system::FourierSeries::sample_uniform):
    /// one inverse FFT over a period, else turned phasors) instead of a sine and cosine per harmonic and
    /// time, and no forcing (the multiplier companion samples P alone; the press over its cam period:
    /// 14600 times, most of its `auto` solve). Piecewise entries: P at each time.
    fn eval_matrix_uniform(&self, t0: f64, dt: f64, count: usize, out: &mut Vec<f64>) {
        let sampled = |entries: &[Coefficient]| -> Option<Vec<Vec<f64>>> {
            entries
                .iter()
                .map(|c| match c {
                    Coefficient::Fourier(s) => {
                        let mut v = vec![0.0; count];
                        s.sample_uniform(t0, dt, &mut v);
                        Some(v)
                    }
                    Coefficient::Piecewise(_) => None,
                })
                .collect()
        };
        let (Some(k), Some(c), Some(m)) = (sampled(&self.stiffness), sampled(&self.damping), sampled(&self.mass))
        else {
            let mut p = DMatrix::zeros(2 * self.dof, 2 * self.dof);
            for j in 0..count {
                self.eval_matrix(t0 + j as f64 * dt, Side::Right, &mut p);
                out.extend_from_slice(p.as_slice());
            }
            return;
        };
        let n = self.dof;
        let mut rhs = DMatrix::zeros(n, 2 * n);
        for j in 0..count {
            for i in 0..n {
                for l in 0..n {
                    rhs[(i, l)] = k[i * n + l][j];
                    rhs[(i, n + l)] = c[i * n + l][j];
                }
            }
            let solved = match &self.constant_mass_inverse {
                Some(inverse) => inverse * &rhs,
                None => DMatrix::from_fn(n, n, |i, l| m[i * n + l][j])
                    .lu()
                    .solve(&rhs)
                    .expect("mass matrix checked invertible at construction"),
            };
            // P = [0 I; -M^-1 K  -M^-1 C], column by column
            for col in 0..2 * n {
                out.extend((0..n).map(|row| f64::from(u8::from(col == n + row))));
                out.extend((0..n).map(|row| -solved[(row, col)]));
            }
        }
    }
    fn piecewise_constant(&self) -> bool {
        let flat = |c: &Coefficient| matches!(c, Coefficient::Piecewise(_)) || c.is_constant();
        self.mass.iter().chain(&self.damping).chain(&self.stiffness).chain(&self.forcing).all(flat)
    }
    fn breakpoints(&self) -> Vec<f64> {
        self.breakpoints.clone()
    }
    fn fourier_form(&self) -> Option<FourierForm> {
        let series = |v: &[Coefficient]| -> Option<Vec<_>> {
            v.iter()
                .map(|c| match c {
                    Coefficient::Fourier(s) => {
                        let mut s = s.clone();
                        s.omega_rad_s = 2.0 * std::f64::consts::PI / self.period_s;
                        Some(s)
                    }
                    Coefficient::Piecewise(_) => None,
                })
                .collect()
        };
        Some(FourierForm {
            dof: self.dof,
            period_s: self.period_s,
            mass: series(&self.mass)?,
            damping: series(&self.damping)?,
            stiffness: series(&self.stiffness)?,
            forcing: series(&self.forcing)?,
        })
    }
    fn eval_terms(&self) -> usize {
        let terms = |c: &Coefficient| match c {
            Coefficient::Fourier(s) => s.harmonics() + 1,
            Coefficient::Piecewise(p) => p.starts.len(),
        };
        self.mass.iter().chain(&self.damping).chain(&self.stiffness).chain(&self.forcing).map(terms).sum()
    }
    fn max_harmonic(&self) -> usize {
        self.mass
            .iter()
            .chain(&self.damping)
            .chain(&self.stiffness)
            .chain(&self.forcing)
            .map(Coefficient::harmonics)
            .max()
            .unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::system::FourierSeries;

    #[test]
    fn eval_matrix_uniform_matches_eval() {
        // two DOFs with a varying mass (a cam's follower), damping and stiffness, against eval at each time:
        // over exactly one period (the inverse-FFT path, 64 and 65 times) and not (turned phasors)
        let w = 2.0 * std::f64::consts::PI / 0.5;
        let f = |mean: f64, cos: Vec<f64>, sin: Vec<f64>| Coefficient::Fourier(FourierSeries::new(w, mean, cos, sin));
        let sys = SecondOrderSystem::new(
            0.5,
            vec![
                f(2.0, vec![0.3, 0.1], vec![0.05]),
                f(0.2, vec![], vec![]),
                f(0.2, vec![], vec![]),
                f(1.0, vec![0.1], vec![]),
            ],
            vec![f(0.4, vec![0.1], vec![]), f(0.0, vec![], vec![]), f(0.0, vec![], vec![]), f(0.3, vec![], vec![0.02])],
            vec![
                f(900.0, vec![80.0, 20.0], vec![10.0]),
                f(-100.0, vec![], vec![]),
                f(-100.0, vec![], vec![]),
                f(500.0, vec![], vec![30.0]),
            ],
            vec![f(0.0, vec![1.0], vec![]), f(0.0, vec![], vec![])],
        )
        .unwrap();
        let mut p = DMatrix::zeros(4, 4);
        for (t0, dt, count) in [(0.0, 0.5 / 64.0, 64), (0.1, 0.5 / 64.0, 65), (0.03, 0.0071, 40)] {
            let mut out = Vec::new();
            sys.eval_matrix_uniform(t0, dt, count, &mut out);
            assert_eq!(out.len(), count * 16);
            for (j, got) in out.chunks(16).enumerate() {
                sys.eval_matrix(t0 + j as f64 * dt, Side::Right, &mut p);
                for (g, want) in got.iter().zip(p.iter()) {
                    // entries up to ~500: a few hundred eps of the FFT or the turned phasors, and the solve
                    assert!((g - want).abs() <= 1e-12 * 500.0, "{count} times, time {j}: {g} against {want}");
                }
            }
        }
    }
}
