//! Errors of the solver layer.

/// Errors of the solver layer.
#[derive(Debug, thiserror::Error)]
pub enum SolverError {
    /// A matrix or vector contained NaN or infinity.
    #[error("non-finite values in {what}")]
    NonFinite {
        /// What was non-finite.
        what: String,
    },
    /// The eigenvalue iteration did not converge.
    #[error("eigenvalues of a {n}x{n} matrix did not converge (QR iteration limit reached)")]
    EigenFailed {
        /// Matrix size.
        n: usize,
    },
    /// I - Phi is singular: a Floquet multiplier equals 1 and no unique periodic solution exists.
    #[error("I - Phi is singular (a Floquet multiplier equals 1): no unique periodic solution")]
    Singular,
    /// The requested tolerance needs more steps than allowed.
    #[error(
        "the periodic solution cannot meet tolerance {tolerance:e}: {steps} steps (or harmonics) still leave an estimated error of {estimate:.2e}{}; raise solver.tolerance",
        conditioning(*cond)
    )]
    ToleranceNotReached {
        /// Condition number of I - Phi at the last attempt (NaN when unknown).
        cond: f64,
        /// Requested tolerance.
        tolerance: f64,
        /// Steps of the last attempt.
        steps: usize,
        /// Error estimate of the last attempt.
        estimate: f64,
    },
    /// I - Phi is so ill-conditioned that rounding alone exceeds the tolerance, at any step count.
    #[error(
        "the periodic solution cannot meet tolerance {tolerance:e}: I - Phi is ill-conditioned (cond {cond:.2e} on the balanced state{nearest}), so rounding alone costs about {roundoff:.1e} relative error at any step count; use method hill for smooth coefficients, or raise solver.tolerance"
    )]
    IllConditioned {
        /// Condition number of the balanced I - Phi.
        cond: f64,
        /// Estimated rounding error cond eps sqrt(steps), relative.
        roundoff: f64,
        /// Requested tolerance.
        tolerance: f64,
        /// ", a multiplier near +1 (within D)" or nothing.
        nearest: String,
    },
    /// The work the system needs is beyond the stated budget: refused before anything is allocated.
    #[error(
        "the system's fastest mode (|lambda| = {rate:.3e} 1/s, {hz:.3e} Hz) needs about {needed:.2e} RK4 steps per period of {period_s:.3e} s, beyond the limit of {limit}: a mass, inertia or radius far too small, or a stiffness, damping or period far too large",
        hz = rate / (2.0 * std::f64::consts::PI)
    )]
    TooMuchWork {
        /// Largest |eigenvalue| of P(t), 1/s.
        rate: f64,
        /// Period in s.
        period_s: f64,
        /// Steps the explicit stability limit asks for.
        needed: f64,
        /// The step limit.
        limit: usize,
    },
    /// The requested method is not available for this system.
    #[error("{0}")]
    Unsupported(String),
}

fn conditioning(cond: f64) -> String {
    if cond.is_finite() && cond > 1e4 {
        format!(
            " because cond(I - Phi) = {cond:.2e} on the balanced state: a Floquet multiplier near +1 amplifies every error"
        )
    } else {
        String::new()
    }
}
