//! Time integrators for the nonlinear tooth-contact dynamics of the gear set.
//!
//! The equations of motion are written as the second-order system
//!
//! ```text
//! M q'' = f(t, q, q'),        M = diag(m_1, …, m_n) constant and positive,
//! ```
//!
//! where `f` is the total generalised force (external minus internal minus damping). The tooth
//! contact forces are piecewise linear in `q`: they are continuous, but their derivative jumps
//! when a tooth pair starts or ends contact. Two integrators are provided:
//!
//! * [`GeneralizedAlpha`] — the implicit generalized-α method of Chung & Hulbert (J. Appl. Mech.
//!   60:371–375, 1993), with Newmark's average-acceleration rule, the HHT-α method (Hilber, Hughes
//!   & Taylor 1977) and plain Newmark (γ, β) as special cases. It takes a fixed number of equal
//!   steps per call, solves each step by Newton's method with the exact piecewise Jacobian and
//!   halves the step locally when Newton fails. It is the workhorse for long runs with stiff
//!   (under-resolved) mesh modes, whose energy it damps in a controlled way (spectral radius at
//!   infinite frequency ρ∞).
//! * [`Rk45`] — the explicit embedded Runge–Kutta 5(4) pair of Dormand & Prince (J. Comput. Appl.
//!   Math. 6:19–26, 1980) on the first-order form y = [q, v], y' = [v, M⁻¹ f], with adaptive step
//!   size control, the fourth-order continuous extension for dense output (Hairer, Nørsett &
//!   Wanner, *Solving Ordinary Differential Equations I*, 2nd ed., Springer 1993, §II.6) and
//!   location of the contact switches through the event functions of
//!   [`SecondOrderSystem::events`]. It is the accurate reference for short runs.
//!
//! # Contract of [`SecondOrderSystem`]
//!
//! * `dim()` and `mass().len()` must agree and stay constant; the masses must be positive.
//! * `force` overwrites all `dim()` entries of `f`.
//! * The integrators set `k` and `c` to zero before calling `jacobian`, so an implementation may
//!   add only its non-zero entries.
//! * The integrators clear `out` before calling `events`; an implementation pushes one value per
//!   event function, and the number of event functions must stay constant over a run. A sign
//!   change of an event function marks a switch of the piecewise force; a value of exactly zero
//!   counts as non-negative.
//! * No method may rely on being called at monotonically increasing times: rejected steps, Newton
//!   iterations and event location evaluate the system at trial points.
//!
//! Both integrators return [`SolverError`] instead of panicking, never return non-finite states,
//! and count their work in [`Stats`].

mod generalized_alpha;
mod low_rank;
mod rk45;

pub use generalized_alpha::{AlphaParameters, GeneralizedAlpha, GeneralizedAlphaSettings};
pub use low_rank::{LowRankJacobian, RankOneTerm, TermCoefficients};
pub use rk45::{LocatedEvent, RelativeOrigin, Rk45, Rk45Settings, StepController};

use thiserror::Error;

/// A second-order system M q'' = f(t, q, q') with a constant diagonal mass matrix.
pub trait SecondOrderSystem {
    /// Number of degrees of freedom.
    fn dim(&self) -> usize;
    /// Diagonal of the mass matrix (positive) [kg or kg·m², per coordinate].
    fn mass(&self) -> &[f64];
    /// Total generalised force f(t, q, v) (external minus internal minus damping) into `f`.
    fn force(&mut self, t: f64, q: &[f64], v: &[f64], f: &mut [f64]);
    /// Event functions: their zero crossings mark switches of the piecewise force
    /// (a tooth pair starting or ending contact). Default: none.
    fn events(&mut self, _t: f64, _q: &[f64], _v: &[f64], _out: &mut Vec<f64>) {}
}

/// A [`SecondOrderSystem`] that also gives its tangent matrices: what the
/// implicit generalized-α method needs (the explicit Runge–Kutta method
/// needs only the force).
pub trait TangentSystem: SecondOrderSystem {
    /// Tangent stiffness K = −∂f/∂q and damping C = −∂f/∂v at (t, q, v), with the
    /// piecewise (contact) status taken at (t, q, v) and frozen (exact piecewise Jacobian).
    fn jacobian(
        &mut self,
        t: f64,
        q: &[f64],
        v: &[f64],
        k: &mut nalgebra::DMatrix<f64>,
        c: &mut nalgebra::DMatrix<f64>,
    );
    /// The Jacobian's structure when it is a constant matrix plus rank-one terms
    /// ([`LowRankJacobian`]); the generalized-α method then solves its Newton systems by the
    /// Woodbury identity instead of factorising the n × n matrix. Read once at initialisation;
    /// it must not change during a run, and [`Self::jacobian`] must equal
    /// [`LowRankJacobian::assemble`] of [`Self::jacobian_coefficients`]. Default: none.
    fn low_rank_jacobian(&self) -> Option<LowRankJacobian> {
        None
    }
    /// The coefficients of the terms of [`Self::low_rank_jacobian`] at (t, q, v), one per term,
    /// contact status frozen as in [`Self::jacobian`]. Called only when the structure is given.
    fn jacobian_coefficients(&mut self, _t: f64, _q: &[f64], _v: &[f64], _out: &mut [TermCoefficients]) {}
}

/// Work counters of an integrator; all counts accumulate until [`Stats::reset`] is called.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct Stats {
    /// Number of accepted steps (for the generalized-α method, sub-steps after halving count
    /// individually).
    pub steps: u64,
    /// Number of rejected step attempts: failed Newton solves or non-finite trial states
    /// (generalized-α), error-test failures or non-finite stages (Runge–Kutta).
    pub rejected_steps: u64,
    /// Number of Newton corrections, i.e. linear solves with the iteration matrix.
    pub newton_iterations: u64,
    /// Number of calls to [`SecondOrderSystem::force`].
    pub rhs_evaluations: u64,
    /// Number of calls to [`TangentSystem::jacobian`].
    pub jacobian_evaluations: u64,
    /// Number of LU factorisations of the iteration matrix.
    pub lu_factorizations: u64,
    /// Number of located event-function sign changes (contact switches).
    pub events_located: u64,
}

impl Stats {
    /// Sets every counter back to zero.
    pub fn reset(&mut self) {
        *self = Stats::default();
    }
}

/// Errors of the time integrators.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SolverError {
    /// A setting is out of its admissible range.
    #[error("invalid setting `{name}` = {value}: {reason}")]
    InvalidSetting {
        /// Name of the setting.
        name: &'static str,
        /// Offending value.
        value: f64,
        /// Why the value is not admissible.
        reason: &'static str,
    },
    /// An argument of a call is out of its admissible range.
    #[error("invalid argument `{name}` = {value}: {reason}")]
    InvalidArgument {
        /// Name of the argument.
        name: &'static str,
        /// Offending value.
        value: f64,
        /// Why the value is not admissible.
        reason: &'static str,
    },
    /// A slice or the system has a length that does not match the number of degrees of freedom.
    #[error("dimension mismatch for `{name}`: expected {expected}, found {found}")]
    DimensionMismatch {
        /// Name of the mismatched quantity.
        name: &'static str,
        /// Expected length.
        expected: usize,
        /// Length found.
        found: usize,
    },
    /// A mass-matrix entry is not positive and finite.
    #[error("mass of coordinate {index} is {value}; masses must be positive and finite")]
    InvalidMass {
        /// Coordinate index.
        index: usize,
        /// Offending mass [kg or kg·m²].
        value: f64,
    },
    /// The integrator was used before `init`.
    #[error("the integrator has not been initialised (call `init` first)")]
    NotInitialized,
    /// A displacement, velocity or acceleration became non-finite.
    #[error("non-finite state component {index} at t = {t} s")]
    NonFiniteState {
        /// Time at which the state was formed \[s\].
        t: f64,
        /// Index of the first non-finite component in the stacked state [q, v, a]: indices at or
        /// above the number of degrees of freedom n refer to velocities, at or above 2n to
        /// accelerations (or Newton corrections).
        index: usize,
    },
    /// The system returned a non-finite force.
    #[error("non-finite force component {index} at t = {t} s")]
    NonFiniteForce {
        /// Time of the force evaluation \[s\].
        t: f64,
        /// Index of the first non-finite force component.
        index: usize,
    },
    /// The system returned a non-finite Jacobian entry.
    #[error("non-finite Jacobian entry ({row}, {col}) at t = {t} s")]
    NonFiniteJacobian {
        /// Time of the Jacobian evaluation \[s\].
        t: f64,
        /// Row of the first non-finite entry.
        row: usize,
        /// Column of the first non-finite entry.
        col: usize,
    },
    /// The system returned a non-finite event-function value.
    #[error("non-finite event function {index} at t = {t} s")]
    NonFiniteEvent {
        /// Time of the evaluation \[s\].
        t: f64,
        /// Index of the first non-finite event function.
        index: usize,
    },
    /// The number of event functions changed during a run.
    #[error("number of event functions changed from {expected} to {found} at t = {t} s")]
    EventCountChanged {
        /// Time of the evaluation \[s\].
        t: f64,
        /// Number of event functions at initialisation.
        expected: usize,
        /// Number returned now.
        found: usize,
    },
    /// Newton's method did not converge, even on the smallest admissible (halved) step.
    #[error("Newton iteration failed at t = {t} s on a step of {step} s after {iterations} iterations")]
    NewtonDiverged {
        /// Start time of the failed step \[s\].
        t: f64,
        /// Size of the last (smallest) step tried \[s\].
        step: f64,
        /// Newton iterations spent on that last attempt.
        iterations: u32,
    },
    /// The Newton iteration matrix was singular, even on the smallest admissible step.
    #[error("singular iteration matrix at t = {t} s on a step of {h} s")]
    SingularMatrix {
        /// Start time of the failed step \[s\].
        t: f64,
        /// Size of the step \[s\].
        h: f64,
    },
    /// The step size fell below the admissible minimum.
    #[error("step size {h} s at t = {t} s is below the admissible minimum")]
    StepTooSmall {
        /// Time at which the step would start \[s\].
        t: f64,
        /// Step size that would be needed \[s\].
        h: f64,
    },
    /// One call took more step attempts than allowed.
    #[error("more than {max_steps} step attempts in one call; stopped at t = {t} s")]
    TooManySteps {
        /// Time reached \[s\].
        t: f64,
        /// The limit that was hit.
        max_steps: u64,
    },
    /// Dense output was requested outside the last step.
    #[error("time {t} s lies outside the last step [{start}, {end}] s")]
    TimeOutOfRange {
        /// Requested time \[s\].
        t: f64,
        /// Start of the last step \[s\].
        start: f64,
        /// End of the last step \[s\].
        end: f64,
    },
}

/// Checks a system and an initial state: dimensions (as [`check_system`]),
/// a finite time, finite coordinates and velocities (velocity indices are
/// reported after the n coordinates). Returns n.
pub(crate) fn check_initial_state<S: SecondOrderSystem + ?Sized>(
    sys: &S,
    t0: f64,
    q0: &[f64],
    v0: &[f64],
) -> Result<usize, SolverError> {
    let n = check_system(sys, q0, v0)?;
    if !t0.is_finite() {
        return Err(SolverError::InvalidArgument { name: "t0", value: t0, reason: "time must be finite" });
    }
    if let Some(index) = first_non_finite(q0) {
        return Err(SolverError::NonFiniteState { t: t0, index });
    }
    if let Some(index) = first_non_finite(v0) {
        return Err(SolverError::NonFiniteState { t: t0, index: n + index });
    }
    Ok(n)
}

/// Checks that the system, its mass vector and the given state slices agree in length and that the
/// masses are positive and finite.
fn check_system<S: SecondOrderSystem + ?Sized>(sys: &S, q: &[f64], v: &[f64]) -> Result<usize, SolverError> {
    let n = sys.dim();
    let mass = sys.mass();
    if mass.len() != n {
        return Err(SolverError::DimensionMismatch { name: "mass", expected: n, found: mass.len() });
    }
    if q.len() != n {
        return Err(SolverError::DimensionMismatch { name: "q", expected: n, found: q.len() });
    }
    if v.len() != n {
        return Err(SolverError::DimensionMismatch { name: "v", expected: n, found: v.len() });
    }
    if let Some((index, &value)) = mass.iter().enumerate().find(|(_, m)| !(m.is_finite() && **m > 0.0)) {
        return Err(SolverError::InvalidMass { index, value });
    }
    Ok(n)
}

/// Checks that the system still has `n` degrees of freedom.
fn check_dim<S: SecondOrderSystem + ?Sized>(sys: &S, n: usize) -> Result<(), SolverError> {
    if sys.dim() != n {
        return Err(SolverError::DimensionMismatch { name: "system", expected: n, found: sys.dim() });
    }
    if sys.mass().len() != n {
        return Err(SolverError::DimensionMismatch { name: "mass", expected: n, found: sys.mass().len() });
    }
    Ok(())
}

/// Index of the first non-finite entry of `x`, if any.
fn first_non_finite(x: &[f64]) -> Option<usize> {
    x.iter().position(|z| !z.is_finite())
}

/// Checks a setting that must be finite and lie in `[lo, hi]`.
fn check_range(
    name: &'static str,
    value: f64,
    lo: f64,
    hi: f64,
    reason: &'static str,
) -> Result<(), SolverError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(())
    } else {
        Err(SolverError::InvalidSetting { name, value, reason })
    }
}
