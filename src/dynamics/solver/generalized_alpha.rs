//! The generalized-α method of Chung & Hulbert for M q'' = f(t, q, q').
//!
//! # Scheme
//!
//! Source: J. Chung & G. M. Hulbert, "A time integration algorithm for structural dynamics with
//! improved numerical dissipation: the generalized-α method", J. Appl. Mech. 60:371–375 (1993).
//! With step h = t_{n+1} − t_n, the algorithmic acceleration a_n and the force f_n = f(t_n, q_n, v_n),
//! one step solves for a_{n+1}
//!
//! ```text
//! q_{n+1} = q_n + h v_n + h² [(1/2 − β) a_n + β a_{n+1}]                      (Newmark)
//! v_{n+1} = v_n + h [(1 − γ) a_n + γ a_{n+1}]
//! M [(1 − α_m) a_{n+1} + α_m a_n] = (1 − α_f) f(t_{n+1}, q_{n+1}, v_{n+1}) + α_f f_n
//! ```
//!
//! For a linear system f = F(t) − K q − C v this is Chung & Hulbert's eq. (7) except that the load
//! is interpolated, (1 − α_f) F(t_{n+1}) + α_f F(t_n), instead of evaluated at t_{n+1−α_f}; both
//! are second-order accurate. Chung & Hulbert's optimal parameters for a spectral radius ρ∞ ∈ [0, 1]
//! at infinite frequency (their eqs. 25 and 17, 20) are
//!
//! ```text
//! α_m = (2ρ∞ − 1)/(ρ∞ + 1),   α_f = ρ∞/(ρ∞ + 1),   γ = 1/2 − α_m + α_f,   β = (1 − α_m + α_f)²/4.
//! ```
//!
//! Special cases: Newmark's average-acceleration (trapezoidal) rule α_m = α_f = 0, γ = 1/2,
//! β = 1/4 (equivalent in exact arithmetic to ρ∞ = 1); the HHT-α method (Hilber, Hughes & Taylor,
//! Earthquake Eng. Struct. Dyn. 5:283–292, 1977) α_m = 0, α_f = α ∈ [0, 1/3], γ = 1/2 + α,
//! β = (1 + α)²/4, whose ρ∞ = (1 − α)/(1 + α); and plain Newmark with any (γ, β), e.g. the
//! conditionally stable central difference γ = 1/2, β = 0.
//!
//! # Nonlinear solution
//!
//! The unknown is a_{n+1} (so that β = 0 is allowed). Newton's method with the predictor
//! a_{n+1}⁽⁰⁾ = a_n solves the residual
//! `r(a) = M[(1 − α_m) a + α_m a_n] − (1 − α_f) f(t_{n+1}, q(a), v(a)) − α_f f_n`
//! with the iteration matrix
//!
//! ```text
//! S = ∂r/∂a = (1 − α_m) M + (1 − α_f) γ h C + (1 − α_f) β h² K,
//! ```
//!
//! which is β h² times the usual displacement-form effective matrix
//! M(1 − α_m)/(β h²) + C(1 − α_f)γ/(β h) + K(1 − α_f); K and C come from
//! [`TangentSystem::jacobian`] at the current iterate (exact piecewise Jacobian) and S is
//! factorised by nalgebra's LU with partial pivoting at every iteration. At least one correction is
//! always made (the bare predictor is never accepted). After each correction the force is evaluated
//! at the new iterate, and the size of the next correction is estimated with the last factorisation,
//! δ = −S⁻¹ r, at the cost of one back-substitution; the step has converged when that estimate is
//! small in the displacement-like weighted norm
//!
//! ```text
//! WRMS_i( h² δ_i / w_i ) ≤ 1,   w_i = atol + rtol · max(|q_{n+1,i}|, |q_{n,i}|),
//! WRMS(x) = (Σ x_i² / n)^{1/2}.
//! ```
//!
//! (h² δ bounds the displacement change β h² δ of the next correction for β ≤ 1 and keeps the test
//! meaningful for β = 0.) For a linear system, or a piecewise-linear one whose contact status at the
//! predictor is already that of the solution, one correction is exact and the test passes at once, so a step
//! costs two force evaluations, one Jacobian and one LU factorisation. The Newton error left in a
//! step is at most of the order of w, so the tolerances should be well below the accuracy wanted
//! from the run.
//!
//! When α_m = α_f (ρ∞ = 1, Newmark) the committed state satisfies M a_n = f_n up to rounding, and
//! the term α_m (M a_n − f_n) is dropped from the residual; this is the same scheme in exact
//! arithmetic but removes the neutral parasitic root −α_m/(1 − α_m) = −1 of ρ∞ = 1, through which
//! rounding and Newton errors would otherwise accumulate.
//!
//! When Newton does not converge within `max_iterations`, the iteration matrix is singular or a
//! trial state or force is non-finite, the step is split into
//! two halves (recursively); the sub-step times are t_a + (t_b − t_a)·j/2^ℓ so that the sub-steps
//! land exactly on the end t_b of the original step, and after two successful halves the step size
//! doubles again. A step that would be shorter than `min_step` ends the call with an error.

use nalgebra::{DMatrix, DVector, Dyn, LU};

use super::low_rank::{LowRankSolver, TermCoefficients};

use super::{
    check_dim, check_initial_state, check_range, first_non_finite, SolverError, Stats, TangentSystem,
};

/// The deepest halving level of one step (2⁴⁰ sub-steps), a guard independent of `min_step`.
const MAX_HALVINGS: u32 = 40;

/// The four parameters (α_m, α_f, γ, β) of the generalized-α family.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlphaParameters {
    /// Weight α_m of the old acceleration in the inertia term; below 1 \[1\].
    pub alpha_m: f64,
    /// Weight α_f of the old force in the force term; in [0, 1) \[1\].
    pub alpha_f: f64,
    /// Newmark velocity parameter γ; non-negative \[1\].
    pub gamma: f64,
    /// Newmark displacement parameter β; non-negative \[1\].
    pub beta: f64,
}

impl AlphaParameters {
    /// Chung & Hulbert's optimal parameters for the spectral radius `rho_inf` ∈ [0, 1] at infinite
    /// frequency: α_m = (2ρ∞ − 1)/(ρ∞ + 1), α_f = ρ∞/(ρ∞ + 1), γ = 1/2 − α_m + α_f,
    /// β = (1 − α_m + α_f)²/4.
    pub fn chung_hulbert(rho_inf: f64) -> Result<Self, SolverError> {
        check_range("rho_inf", rho_inf, 0.0, 1.0, "the spectral radius at infinity must lie in [0, 1]")?;
        let alpha_m = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0);
        let alpha_f = rho_inf / (rho_inf + 1.0);
        let gamma = 0.5 - alpha_m + alpha_f;
        let beta = 0.25 * (1.0 - alpha_m + alpha_f).powi(2);
        Ok(Self { alpha_m, alpha_f, gamma, beta })
    }

    /// Newmark's average-acceleration (trapezoidal) rule: α_m = α_f = 0, γ = 1/2, β = 1/4.
    pub fn newmark_average_acceleration() -> Self {
        Self { alpha_m: 0.0, alpha_f: 0.0, gamma: 0.5, beta: 0.25 }
    }

    /// The HHT-α method with `alpha` ∈ [0, 1/3]: α_m = 0, α_f = α, γ = 1/2 + α, β = (1 + α)²/4;
    /// its spectral radius at infinity is (1 − α)/(1 + α).
    pub fn hht(alpha: f64) -> Result<Self, SolverError> {
        check_range("alpha", alpha, 0.0, 1.0 / 3.0, "the HHT parameter must lie in [0, 1/3]")?;
        Ok(Self { alpha_m: 0.0, alpha_f: alpha, gamma: 0.5 + alpha, beta: 0.25 * (1.0 + alpha).powi(2) })
    }

    /// Plain Newmark with arbitrary γ ≥ 0 and β ≥ 0 (α_m = α_f = 0). It is second-order accurate
    /// only for γ = 1/2, and unconditionally stable only for 2β ≥ γ ≥ 1/2; other choices (for
    /// example the central difference γ = 1/2, β = 0) are allowed for demonstrations.
    pub fn newmark(gamma: f64, beta: f64) -> Result<Self, SolverError> {
        let p = Self { alpha_m: 0.0, alpha_f: 0.0, gamma, beta };
        p.validate()?;
        Ok(p)
    }

    /// Checks that the parameters are finite and define a solvable step: α_m < 1, 0 ≤ α_f < 1,
    /// γ ≥ 0 and β ≥ 0.
    pub fn validate(&self) -> Result<(), SolverError> {
        if !(self.alpha_m.is_finite() && self.alpha_m < 1.0) {
            return Err(SolverError::InvalidSetting {
                name: "alpha_m",
                value: self.alpha_m,
                reason: "alpha_m must be finite and below 1",
            });
        }
        if !(self.alpha_f.is_finite() && (0.0..1.0).contains(&self.alpha_f)) {
            return Err(SolverError::InvalidSetting {
                name: "alpha_f",
                value: self.alpha_f,
                reason: "alpha_f must lie in [0, 1)",
            });
        }
        check_range("gamma", self.gamma, 0.0, f64::MAX, "gamma must be finite and non-negative")?;
        check_range("beta", self.beta, 0.0, f64::MAX, "beta must be finite and non-negative")
    }
}

/// Settings of the [`GeneralizedAlpha`] integrator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeneralizedAlphaSettings {
    /// Method parameters (α_m, α_f, γ, β).
    pub parameters: AlphaParameters,
    /// Relative tolerance of the Newton convergence test; in [0, 1] \[1\].
    pub rtol: f64,
    /// Absolute tolerance of the Newton convergence test, applied to every coordinate in that
    /// coordinate's unit. The relative part scales with |q|, so for coordinates that grow without
    /// bound (rigid-body rotation angles) the absolute part governs only if `rtol` is small
    /// [m or rad].
    pub atol: f64,
    /// Maximum number of Newton corrections per step attempt before the step is halved (≥ 1).
    /// Each correction costs one Jacobian, one LU factorisation and one force evaluation.
    pub max_iterations: u32,
    /// Smallest step the halving may produce; positive \[s\].
    pub min_step: f64,
}

impl GeneralizedAlphaSettings {
    /// Settings with the given parameters and the default tolerances (rtol = 1e-10, atol = 1e-14,
    /// 10 Newton iterations, minimum step 1e-12 s).
    pub fn new(parameters: AlphaParameters) -> Self {
        Self { parameters, rtol: 1e-10, atol: 1e-14, max_iterations: 10, min_step: 1e-12 }
    }

    /// Default settings with Chung & Hulbert's parameters for spectral radius `rho_inf` ∈ [0, 1].
    pub fn chung_hulbert(rho_inf: f64) -> Result<Self, SolverError> {
        Ok(Self::new(AlphaParameters::chung_hulbert(rho_inf)?))
    }

    /// Default settings with Newmark's average-acceleration rule.
    pub fn newmark_average_acceleration() -> Self {
        Self::new(AlphaParameters::newmark_average_acceleration())
    }

    /// Default settings with the HHT-α method, `alpha` ∈ [0, 1/3].
    pub fn hht(alpha: f64) -> Result<Self, SolverError> {
        Ok(Self::new(AlphaParameters::hht(alpha)?))
    }

    /// Default settings with plain Newmark (γ, β), both ≥ 0.
    pub fn newmark(gamma: f64, beta: f64) -> Result<Self, SolverError> {
        Ok(Self::new(AlphaParameters::newmark(gamma, beta)?))
    }

    /// Checks every setting.
    pub fn validate(&self) -> Result<(), SolverError> {
        self.parameters.validate()?;
        check_range("rtol", self.rtol, 0.0, 1.0, "rtol must lie in [0, 1]")?;
        check_range("atol", self.atol, 0.0, f64::MAX, "atol must be finite and non-negative")?;
        if self.rtol == 0.0 && self.atol == 0.0 {
            return Err(SolverError::InvalidSetting {
                name: "atol",
                value: 0.0,
                reason: "rtol and atol must not both be zero",
            });
        }
        if self.max_iterations == 0 {
            return Err(SolverError::InvalidSetting {
                name: "max_iterations",
                value: 0.0,
                reason: "at least one Newton iteration is needed",
            });
        }
        if !(self.min_step.is_finite() && self.min_step > 0.0) {
            return Err(SolverError::InvalidSetting {
                name: "min_step",
                value: self.min_step,
                reason: "min_step must be positive and finite",
            });
        }
        Ok(())
    }
}

impl Default for GeneralizedAlphaSettings {
    /// Chung & Hulbert's parameters with ρ∞ = 0.9 and the default tolerances of
    /// [`GeneralizedAlphaSettings::new`].
    fn default() -> Self {
        let rho_inf: f64 = 0.9;
        let alpha_m = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0);
        let alpha_f = rho_inf / (rho_inf + 1.0);
        Self::new(AlphaParameters {
            alpha_m,
            alpha_f,
            gamma: 0.5 - alpha_m + alpha_f,
            beta: 0.25 * (1.0 - alpha_m + alpha_f).powi(2),
        })
    }
}

/// Why one step attempt failed.
#[derive(Debug, Clone, Copy)]
enum Failure {
    Newton { iterations: u32 },
    Singular,
    NonFiniteState { t: f64, index: usize },
    NonFiniteForce { t: f64, index: usize },
    NonFiniteJacobian { t: f64, row: usize, col: usize },
}

impl Failure {
    fn into_error(self, t: f64, h: f64) -> SolverError {
        match self {
            Failure::Newton { iterations } => SolverError::NewtonDiverged { t, step: h, iterations },
            Failure::Singular => SolverError::SingularMatrix { t, h },
            Failure::NonFiniteState { t, index } => SolverError::NonFiniteState { t, index },
            Failure::NonFiniteForce { t, index } => SolverError::NonFiniteForce { t, index },
            Failure::NonFiniteJacobian { t, row, col } => SolverError::NonFiniteJacobian { t, row, col },
        }
    }
}

/// The generalized-α integrator (see the module documentation for the equations).
///
/// Typical use: [`GeneralizedAlpha::new`], [`GeneralizedAlpha::init`], then repeated
/// [`GeneralizedAlpha::advance`] calls, reading [`GeneralizedAlpha::q`] and
/// [`GeneralizedAlpha::v`] in between.
#[derive(Debug, Clone)]
pub struct GeneralizedAlpha {
    settings: GeneralizedAlphaSettings,
    initialized: bool,
    n: usize,
    t: f64,
    q: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    f: Vec<f64>,
    mass: Vec<f64>,
    q_new: Vec<f64>,
    v_new: Vec<f64>,
    a_new: Vec<f64>,
    f_new: Vec<f64>,
    q_pred: Vec<f64>,
    v_pred: Vec<f64>,
    k: DMatrix<f64>,
    c: DMatrix<f64>,
    rhs: DVector<f64>,
    estimate: DVector<f64>,
    /// The Woodbury solver when the system gives a low-rank Jacobian structure.
    low_rank: Option<LowRankSolver>,
    coefficients: Vec<TermCoefficients>,
    stats: Stats,
}

impl GeneralizedAlpha {
    /// Creates an integrator after checking the settings; call [`GeneralizedAlpha::init`] next.
    pub fn new(settings: GeneralizedAlphaSettings) -> Result<Self, SolverError> {
        settings.validate()?;
        Ok(Self {
            settings,
            initialized: false,
            n: 0,
            t: 0.0,
            q: Vec::new(),
            v: Vec::new(),
            a: Vec::new(),
            f: Vec::new(),
            mass: Vec::new(),
            q_new: Vec::new(),
            v_new: Vec::new(),
            a_new: Vec::new(),
            f_new: Vec::new(),
            q_pred: Vec::new(),
            v_pred: Vec::new(),
            k: DMatrix::zeros(0, 0),
            c: DMatrix::zeros(0, 0),
            rhs: DVector::zeros(0),
            estimate: DVector::zeros(0),
            low_rank: None,
            coefficients: Vec::new(),
            stats: Stats::default(),
        })
    }

    /// Sets the initial time `t0` \[s\], displacements `q0` [m or rad] and velocities `v0`
    /// [m/s or rad/s], and the consistent initial acceleration from M a0 = f(t0, q0, v0).
    /// The counters are kept; see [`GeneralizedAlpha::reset_stats`].
    pub fn init<S: TangentSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t0: f64,
        q0: &[f64],
        v0: &[f64],
    ) -> Result<(), SolverError> {
        let n = check_initial_state(sys, t0, q0, v0)?;
        let mut f = vec![0.0; n];
        sys.force(t0, q0, v0, &mut f);
        self.stats.rhs_evaluations += 1;
        if let Some(index) = first_non_finite(&f) {
            return Err(SolverError::NonFiniteForce { t: t0, index });
        }
        let mass = sys.mass().to_vec();
        let a: Vec<f64> = f.iter().zip(&mass).map(|(fi, mi)| fi / mi).collect();
        if let Some(index) = first_non_finite(&a) {
            return Err(SolverError::NonFiniteState { t: t0, index: 2 * n + index });
        }
        self.n = n;
        self.t = t0;
        self.q = q0.to_vec();
        self.v = v0.to_vec();
        self.a = a;
        self.f = f;
        self.mass = mass;
        self.q_new = vec![0.0; n];
        self.v_new = vec![0.0; n];
        self.a_new = vec![0.0; n];
        self.f_new = vec![0.0; n];
        self.q_pred = vec![0.0; n];
        self.v_pred = vec![0.0; n];
        self.k = DMatrix::zeros(n, n);
        self.c = DMatrix::zeros(n, n);
        self.rhs = DVector::zeros(n);
        self.estimate = DVector::zeros(n);
        let structure = sys.low_rank_jacobian();
        let terms = structure.as_ref().map_or(0, |j| j.terms.len());
        self.low_rank = structure.and_then(|j| LowRankSolver::new(j, n));
        self.coefficients = vec![TermCoefficients::default(); terms];
        self.initialized = true;
        Ok(())
    }

    /// Restarts from time `t` \[s\], displacements `q` [m or rad] and velocities `v`
    /// [m/s or rad/s]; the acceleration is recomputed from M a = f(t, q, v). Same as
    /// [`GeneralizedAlpha::init`].
    pub fn set_state<S: TangentSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t: f64,
        q: &[f64],
        v: &[f64],
    ) -> Result<(), SolverError> {
        self.init(sys, t, q, v)
    }

    /// Restores a state saved with [`GeneralizedAlpha::time`], [`GeneralizedAlpha::q`],
    /// [`GeneralizedAlpha::v`] and [`GeneralizedAlpha::a`]: the algorithmic acceleration is
    /// taken as given (it differs from M⁻¹f unless α_m = α_f), so the continuation is
    /// bit-identical to the run the state was saved from.
    pub fn restore<S: TangentSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t: f64,
        q: &[f64],
        v: &[f64],
        a: &[f64],
    ) -> Result<(), SolverError> {
        self.init(sys, t, q, v)?;
        if a.len() != self.n {
            return Err(SolverError::DimensionMismatch {
                name: "acceleration",
                expected: self.n,
                found: a.len(),
            });
        }
        if let Some(index) = first_non_finite(a) {
            return Err(SolverError::NonFiniteState { t, index: 2 * self.n + index });
        }
        self.a.copy_from_slice(a);
        Ok(())
    }

    /// Takes exactly `steps` equal steps from the current time to `t_end` \[s\]. The end of step k
    /// is t0 + (t_end − t0)·k/steps (with t0 the time at the call), and the last step ends at
    /// `t_end` exactly, so the time never drifts by accumulation. A step whose Newton iteration
    /// fails is halved recursively as described in the module documentation.
    ///
    /// On error the integrator keeps the last successfully reached state, so the caller can
    /// inspect it or restart with [`GeneralizedAlpha::set_state`].
    pub fn advance<S: TangentSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t_end: f64,
        steps: u64,
    ) -> Result<(), SolverError> {
        if !self.initialized {
            return Err(SolverError::NotInitialized);
        }
        check_dim(sys, self.n)?;
        if !t_end.is_finite() {
            return Err(SolverError::InvalidArgument {
                name: "t_end",
                value: t_end,
                reason: "time must be finite",
            });
        }
        if steps == 0 {
            if t_end == self.t {
                return Ok(());
            }
            return Err(SolverError::InvalidArgument {
                name: "steps",
                value: 0.0,
                reason: "zero steps can only reach the current time",
            });
        }
        if t_end <= self.t {
            return Err(SolverError::InvalidArgument {
                name: "t_end",
                value: t_end,
                reason: "t_end must lie after the current time",
            });
        }
        let t0 = self.t;
        let span = t_end - t0;
        let steps_f = steps as f64;
        // The nominal step of this call with its last 24 mantissa bits cleared (relative change
        // below 4e-9): the constant part of a low-rank iteration matrix is built for it, so calls
        // whose steps differ by rounding share one build, and a restored state, whose calls
        // compute the same nominal step, continues bit-identically.
        let nominal = f64::from_bits((span / steps_f).to_bits() & !((1u64 << 24) - 1));
        for k in 1..=steps {
            let tb = if k == steps { t_end } else { t0 + span * (k as f64) / steps_f };
            if tb <= self.t {
                return Err(SolverError::StepTooSmall { t: self.t, h: tb - self.t });
            }
            self.step_with_halving(sys, tb, nominal)?;
        }
        Ok(())
    }

    /// Advances from the current time to `tb`, halving on failure.
    fn step_with_halving<S: TangentSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        tb: f64,
        nominal: f64,
    ) -> Result<(), SolverError> {
        let ta = self.t;
        let span = tb - ta;
        let mut level: u32 = 0;
        let mut j: u64 = 0;
        loop {
            let n_sub = 1u64 << level;
            if j == n_sub {
                return Ok(());
            }
            let target = if j + 1 == n_sub { tb } else { ta + span * ((j + 1) as f64) / (n_sub as f64) };
            let h = target - self.t;
            match self.try_step(sys, target, nominal / (n_sub as f64)) {
                Ok(()) => {
                    self.commit(target);
                    j += 1;
                    if level > 0 && j % 2 == 0 {
                        level -= 1;
                        j /= 2;
                    }
                }
                Err(failure) => {
                    self.stats.rejected_steps += 1;
                    if level >= MAX_HALVINGS || h.is_nan() || 0.5 * h < self.settings.min_step {
                        return Err(failure.into_error(self.t, h));
                    }
                    level += 1;
                    j *= 2;
                }
            }
        }
    }

    /// Accepts the trial state computed by `try_step`.
    fn commit(&mut self, t1: f64) {
        std::mem::swap(&mut self.q, &mut self.q_new);
        std::mem::swap(&mut self.v, &mut self.v_new);
        std::mem::swap(&mut self.a, &mut self.a_new);
        std::mem::swap(&mut self.f, &mut self.f_new);
        self.t = t1;
        self.stats.steps += 1;
    }

    /// Weighted RMS norm of `x_i · scale_i / w_i`, w_i = atol + rtol·max(|q_new_i|, |q_i|).
    fn wrms(&self, x: impl Iterator<Item = f64>) -> f64 {
        let (rtol, atol) = (self.settings.rtol, self.settings.atol);
        let mut sum = 0.0;
        for (i, xi) in x.enumerate() {
            let w = atol + rtol * self.q_new[i].abs().max(self.q[i].abs());
            let r = xi / w;
            sum += r * r;
        }
        (sum / self.n.max(1) as f64).sqrt()
    }

    /// One generalized-α step from the committed state to `t1`, leaving the result in the
    /// `*_new` buffers.
    fn try_step<S: TangentSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t1: f64,
        nominal: f64,
    ) -> Result<(), Failure> {
        let AlphaParameters { alpha_m, alpha_f, gamma, beta } = self.settings.parameters;
        let n = self.n;
        let h = t1 - self.t;
        let h2 = h * h;
        if n == 0 {
            // Nothing to solve (and nalgebra's LU does not accept an empty matrix).
            return Ok(());
        }
        self.predict(h);
        let mut lu: Option<LU<f64, Dyn, Dyn>> = None;
        let mut low_rank_factored = false;
        let max_iterations = self.settings.max_iterations;
        let ck = (1.0 - alpha_f) * beta * h2;
        let cc = (1.0 - alpha_f) * gamma * h;
        if let Some(solver) = &mut self.low_rank {
            let (ckn, ccn) = ((1.0 - alpha_f) * beta * nominal * nominal, (1.0 - alpha_f) * gamma * nominal);
            solver.prepare(&self.mass, 1.0 - alpha_m, ckn, ccn).map_err(|_| Failure::Singular)?;
        }
        for iteration in 0..=max_iterations {
            self.correct(sys, t1, h)?;
            self.residual();
            if self.next_correction_small(lu.as_ref(), low_rank_factored, h2) {
                return Ok(());
            }
            if iteration == max_iterations {
                break;
            }
            if self.low_rank.is_some() {
                self.low_rank_correction(sys, t1, (ck, cc))?;
                low_rank_factored = true;
                continue;
            }
            lu = Some(self.dense_correction(sys, t1, (ck, cc))?);
        }
        Err(Failure::Newton { iterations: max_iterations })
    }

    /// The predictor of a step of length `h` from the committed state: q and v into
    /// `q_pred`, `v_pred`, and a_new = a.
    #[inline]
    fn predict(&mut self, h: f64) {
        let AlphaParameters { gamma, beta, .. } = self.settings.parameters;
        let h2 = h * h;
        for i in 0..self.n {
            self.q_pred[i] = self.q[i] + h * self.v[i] + h2 * (0.5 - beta) * self.a[i];
            self.v_pred[i] = self.v[i] + h * (1.0 - gamma) * self.a[i];
            self.a_new[i] = self.a[i];
        }
    }

    /// The corrected state at `t1` of the step of length `h` from the iterate a_new (q =
    /// q_pred + βh² a_new, v = v_pred + γh a_new) and the force there into `f_new`; the
    /// failure where either is not finite.
    #[inline]
    fn correct<S: TangentSystem + ?Sized>(&mut self, sys: &mut S, t1: f64, h: f64) -> Result<(), Failure> {
        let AlphaParameters { gamma, beta, .. } = self.settings.parameters;
        let (n, h2) = (self.n, h * h);
        for i in 0..n {
            self.q_new[i] = self.q_pred[i] + beta * h2 * self.a_new[i];
            self.v_new[i] = self.v_pred[i] + gamma * h * self.a_new[i];
        }
        if let Some(index) = first_non_finite(&self.q_new) {
            return Err(Failure::NonFiniteState { t: t1, index });
        }
        if let Some(index) = first_non_finite(&self.v_new) {
            return Err(Failure::NonFiniteState { t: t1, index: n + index });
        }
        sys.force(t1, &self.q_new, &self.v_new, &mut self.f_new);
        self.stats.rhs_evaluations += 1;
        if let Some(index) = first_non_finite(&self.f_new) {
            return Err(Failure::NonFiniteForce { t: t1, index });
        }
        Ok(())
    }

    /// The Newton residual at the corrected state into `rhs`:
    /// −(M((1 − α_m) a_new + α_m a) − (1 − α_f) f_new − α_f f).
    #[inline]
    fn residual(&mut self) {
        let AlphaParameters { alpha_m, alpha_f, .. } = self.settings.parameters;
        if alpha_m == alpha_f {
            // M a_n − f_n vanishes up to rounding; dropping it removes the neutral parasitic root
            // −α_m/(1 − α_m) = −1 of ρ∞ = 1 through which rounding errors would accumulate.
            for i in 0..self.n {
                self.rhs[i] = -(1.0 - alpha_m) * (self.mass[i] * self.a_new[i] - self.f_new[i]);
            }
        } else {
            for i in 0..self.n {
                self.rhs[i] = -(self.mass[i] * ((1.0 - alpha_m) * self.a_new[i] + alpha_m * self.a[i])
                    - (1.0 - alpha_f) * self.f_new[i]
                    - alpha_f * self.f[i]);
            }
        }
    }

    /// Whether the next correction, estimated with the last iteration matrix (the low-rank
    /// solver's once factorised, else the dense `lu`; none before the first), is small
    /// enough to accept the iterate: the weighted RMS of h²·Δa (`h2` = h²) at most 1.
    #[inline]
    fn next_correction_small(
        &mut self,
        lu: Option<&LU<f64, Dyn, Dyn>>,
        low_rank_factored: bool,
        h2: f64,
    ) -> bool {
        let n = self.n;
        if let (Some(solver), true) = (&mut self.low_rank, low_rank_factored) {
            self.estimate.copy_from(&self.rhs);
            solver.solve(self.estimate.as_mut_slice());
            first_non_finite(self.estimate.as_slice()).is_none()
                && self.wrms((0..n).map(|i| h2 * self.estimate[i])) <= 1.0
        } else if let Some(lu) = lu {
            self.estimate.copy_from(&self.rhs);
            lu.solve_mut(&mut self.estimate) && self.wrms((0..n).map(|i| h2 * self.estimate[i])) <= 1.0
        } else {
            false
        }
    }

    /// One Newton correction with the low-rank solver: the Jacobian's coefficients at the
    /// corrected state, the iteration matrix factorised (`ck`, `cc` the stiffness and damping
    /// factors: its rank-one part uses the actual step; only the constant part is built for
    /// the nominal one), the residual solved and added to a_new.
    #[inline]
    fn low_rank_correction<S: TangentSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t1: f64,
        (ck, cc): (f64, f64),
    ) -> Result<(), Failure> {
        sys.jacobian_coefficients(t1, &self.q_new, &self.v_new, &mut self.coefficients);
        self.stats.jacobian_evaluations += 1;
        if let Some(m) = self
            .coefficients
            .iter()
            .position(|c| !(c.stiffness.is_finite() && c.damping.is_finite() && c.cross.is_finite()))
        {
            return Err(Failure::NonFiniteJacobian { t: t1, row: m, col: m });
        }
        if let Some(solver) = &mut self.low_rank {
            solver.factor(&self.coefficients, ck, cc).map_err(|_| Failure::Singular)?;
            self.stats.lu_factorizations += 1;
            solver.solve(self.rhs.as_mut_slice());
        }
        self.apply_correction(t1)
    }

    /// One Newton correction with the dense iteration matrix (1 − α_m) M + c_k K + c_c C
    /// (`ck`, `cc`) at the corrected state: the Jacobian evaluated and checked, the matrix
    /// factorised, the residual solved and added to a_new. The factorisation, for the next
    /// correction's estimate.
    fn dense_correction<S: TangentSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t1: f64,
        (ck, cc): (f64, f64),
    ) -> Result<LU<f64, Dyn, Dyn>, Failure> {
        let (n, alpha_m) = (self.n, self.settings.parameters.alpha_m);
        self.k.as_mut_slice().fill(0.0);
        self.c.as_mut_slice().fill(0.0);
        sys.jacobian(t1, &self.q_new, &self.v_new, &mut self.k, &mut self.c);
        self.stats.jacobian_evaluations += 1;
        if self.k.shape() != (n, n) || self.c.shape() != (n, n) {
            // A Jacobian of the wrong shape cannot be used; treat it like a singular matrix.
            self.k = DMatrix::zeros(n, n);
            self.c = DMatrix::zeros(n, n);
            return Err(Failure::Singular);
        }
        // Column-major storage: entry (row, col) sits at col·n + row.
        let (kd, cd) = (self.k.as_slice(), self.c.as_slice());
        if let Some(p) = kd.iter().zip(cd).position(|(kv, cv)| !(kv.is_finite() && cv.is_finite())) {
            return Err(Failure::NonFiniteJacobian { t: t1, row: p % n, col: p / n });
        }
        let data: Vec<f64> = kd.iter().zip(cd).map(|(kv, cv)| ck * kv + cc * cv).collect();
        let mut s = DMatrix::from_vec(n, n, data);
        for (i, m) in self.mass.iter().enumerate() {
            s[(i, i)] += (1.0 - alpha_m) * m;
        }
        let factor = s.lu();
        self.stats.lu_factorizations += 1;
        if !factor.solve_mut(&mut self.rhs) {
            return Err(Failure::Singular);
        }
        self.apply_correction(t1)?;
        Ok(factor)
    }

    /// Adds the solved correction in `rhs` to a_new (one Newton iteration); the failure
    /// where it is not finite.
    #[inline]
    fn apply_correction(&mut self, t1: f64) -> Result<(), Failure> {
        let n = self.n;
        self.stats.newton_iterations += 1;
        if let Some(index) = first_non_finite(self.rhs.as_slice()) {
            return Err(Failure::NonFiniteState { t: t1, index: 2 * n + index });
        }
        for i in 0..n {
            self.a_new[i] += self.rhs[i];
        }
        Ok(())
    }

    /// Current time \[s\].
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Current displacements [m or rad, per coordinate].
    pub fn q(&self) -> &[f64] {
        &self.q
    }

    /// Current velocities [m/s or rad/s, per coordinate].
    pub fn v(&self) -> &[f64] {
        &self.v
    }

    /// Current algorithmic acceleration a_n; for α_m ≠ α_f it approximates q'' at a time shifted
    /// within the step rather than M⁻¹ f(t_n, q_n, v_n) [m/s² or rad/s², per coordinate].
    pub fn a(&self) -> &[f64] {
        &self.a
    }

    /// Force f(t_n, q_n, v_n) at the current state [N or N·m, per coordinate].
    pub fn force(&self) -> &[f64] {
        &self.f
    }

    /// The settings in use.
    pub fn settings(&self) -> &GeneralizedAlphaSettings {
        &self.settings
    }

    /// The work counters.
    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// Sets every work counter back to zero.
    pub fn reset_stats(&mut self) {
        self.stats.reset();
    }
}
