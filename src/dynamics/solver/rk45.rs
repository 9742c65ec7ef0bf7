//! The adaptive explicit Runge–Kutta 5(4) pair of Dormand & Prince with dense output and event
//! location.
//!
//! # Scheme
//!
//! The second-order system is integrated in first-order form y = [q, v], y' = F(t, y) = [v, M⁻¹ f].
//! One step of size h from (t_n, y_n) uses the seven stages of J. R. Dormand & P. J. Prince,
//! "A family of embedded Runge–Kutta formulae", J. Comput. Appl. Math. 6:19–26 (1980):
//!
//! ```text
//! k_i     = F(t_n + c_i h, y_n + h Σ_{j<i} a_ij k_j),   i = 1 … 7,
//! y_{n+1} = y_n + h Σ_i b_i k_i                (fifth order; b_i = a_7i, so k_7 = F(t_{n+1}, y_{n+1}))
//! err     = h Σ_i e_i k_i                      (e = b − b̂, difference to the embedded fourth order)
//! ```
//!
//! The last stage of a step is the first of the next (FSAL), so an accepted step costs six force
//! evaluations. The error is measured as
//! `‖err‖ = (Σ_i (err_i / sk_i)² / 2n)^{1/2}`, `sk_i = atol_i + rtol · max(|y_{n,i}|, |y_{n+1,i}|)`,
//! with `atol_i` = `atol_q` for displacements and `atol_v` for velocities; with a relative origin
//! ([`Rk45::set_relative_origin`], a rigid motion o(t)) the relative part is measured from it,
//! `rtol · max(|y_{n,i} − o_i(t_n)|, |y_{n+1,i} − o_i(t_{n+1})|)`. A step is accepted when
//! ‖err‖ ≤ 1. The next step is h·fac with fac clamped to [`min_ratio`, `max_ratio`] (and to at
//! most 1 right after a rejection), where
//!
//! ```text
//! standard controller:  fac = safety · ‖err‖^{−1/5}
//! PI controller:        fac = safety · ‖err_n‖^{−(1/5 − 3β/4)} · ‖err_{n−1}‖^{β}
//! ```
//!
//! (Hairer, Nørsett & Wanner, *Solving Ordinary Differential Equations I*, 2nd ed., Springer 1993,
//! §II.4 and the code DOPRI5; β = 0.04 there). The initial step follows the same book's algorithm
//! (§II.4, "Starting step size") unless it is given.
//!
//! # Dense output
//!
//! Within the last accepted step, y(t_n + θh), θ ∈ [0, 1], is the fourth-order continuous extension
//! of Dormand & Prince in the form of Hairer, Nørsett & Wanner §II.6 (code DOPRI5):
//!
//! ```text
//! y(θ) = r1 + θ (r2 + (1 − θ)(r3 + θ (r4 + (1 − θ) r5))),
//! r1 = y_n,  r2 = y_{n+1} − y_n,  r3 = h k_1 − r2,  r4 = r2 − h k_7 − r3,
//! r5 = h (d1 k1 + d3 k3 + d4 k4 + d5 k5 + d6 k6 + d7 k7).
//! ```
//!
//! # Events
//!
//! After each step that passes the error test, the event functions g(t, q, v) of
//! [`SecondOrderSystem::events`] are evaluated at its end. For each function whose side changed
//! (negative versus non-negative) the first crossing is located on the dense output with the
//! Illinois variant of regula falsi (falling back to bisection after 50 iterations) to a time
//! tolerance `event_tolerance · max(|t_n|, |t_{n+1}|, h)`. The step is then discarded and retaken
//! with h = t_event − t_n, so that the jump in the force's derivative falls on a step boundary; the
//! time t_event is the end of the final bracket on the far side of the crossing. Crossings that
//! coincide within the tolerance (for example in-phase planets) are handled together, and each
//! crossing counts once in [`Stats::events_located`]. When a step fails the error test and an
//! event function changed sign over it, the switch is the likely cause, so the next attempt is aimed
//! at the crossing located roughly (to 10⁻³ of the step) on the rejected step's dense output; if
//! that attempt fails as well, the controller's reduction applies. With
//! [`Rk45Settings::hop_switches`] the aim is the crossing's near side, and where that crossing
//! lies within the event tolerance of the step's start (located to it), the state hops across it
//! instead: an Euler step of at most twice the tolerance on the last derivative, the
//! derivative then evaluated past the switch, taken only if the event function's side changes
//! on it. A force that jumps at the switch (a damping force proportional to a contact stiffness,
//! Rayleigh's η K) gives a step that straddles it an error of order h · jump, which a tight
//! tolerance accepts only as the step shrinks towards the rounding of the time; the hop steps
//! over it. (The retaken step that lands on a crossing's far side still takes its last stages
//! past the switch, an error of order h · jump that the embedded estimate sees about eight
//! times smaller; tests/solver.rs measures it.) Two crossings of the same function within
//! one step (a contact shorter than a step) leave no sign change at the step end and are not
//! seen; bound `max_step` by the shortest contact duration if that matters.

use super::{
    check_dim, check_initial_state, check_range, first_non_finite, SecondOrderSystem, SolverError, Stats,
};

// Dormand–Prince 5(4) coefficients (Hairer, Nørsett & Wanner, Table II.5.2, and DOPRI5).
const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;
const D1: f64 = -12715105075.0 / 11282082432.0;
const D3: f64 = 87487479700.0 / 32700410799.0;
const D4: f64 = -10690763975.0 / 1880347072.0;
const D5: f64 = 701980252875.0 / 199316789632.0;
const D6: f64 = -1453857185.0 / 822651844.0;
const D7: f64 = 69997945.0 / 29380423.0;

/// Iterations of the Illinois method before it switches to bisection.
const ILLINOIS_ITERATIONS: u32 = 50;
/// Total iteration cap of the event root finder (enough for bisection to reach 2⁻⁵³).
const ROOT_ITERATIONS: u32 = 160;

/// Step-size controller of [`Rk45`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepController {
    /// fac = safety · ‖err‖^{−1/5}.
    Standard,
    /// Proportional–integral controller fac = safety · ‖err_n‖^{−(1/5 − 3β/4)} · ‖err_{n−1}‖^β.
    PI {
        /// Integral gain β in [0, 0.1]: 0.04 in DOPRI5, 0 gives the standard controller, and the
        /// controller is stable only for β < 1/5 − 3β/4, i.e. β < 0.114 \[1\].
        beta: f64,
    },
}

/// Settings of the [`Rk45`] integrator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rk45Settings {
    /// Relative tolerance of the local error; in (0, 1) \[1\].
    pub rtol: f64,
    /// Absolute tolerance of the displacement components; non-negative [m or rad].
    pub atol_q: f64,
    /// Absolute tolerance of the velocity components; non-negative [m/s or rad/s].
    pub atol_v: f64,
    /// Safety factor of the step-size prediction; in (0, 1] \[1\].
    pub safety: f64,
    /// Smallest ratio between consecutive step sizes; in (0, 1) \[1\].
    pub min_ratio: f64,
    /// Largest ratio between consecutive step sizes; above 1 \[1\].
    pub max_ratio: f64,
    /// Step-size controller.
    pub controller: StepController,
    /// First step size; `None` selects it automatically \[s\].
    pub initial_step: Option<f64>,
    /// Largest step size; positive, may be infinite \[s\].
    pub max_step: f64,
    /// Smallest step size below which the integration stops with an error; the step that lands on
    /// `t_end` or on an event may be shorter \[s\].
    pub min_step: f64,
    /// Largest number of step attempts (accepted, rejected and event retakes) in one
    /// [`Rk45::advance_to`] call.
    pub max_steps: u64,
    /// Relative time tolerance of event location, applied as
    /// `event_tolerance · max(|t_n|, |t_{n+1}|, h)`; in [1e-15, 0.1] \[1\].
    pub event_tolerance: f64,
    /// Whether located events are stored for [`Rk45::located_events`]; they are always counted.
    pub record_events: bool,
    /// Whether a step rejected at a crossing is aimed at the crossing's near side and a
    /// crossing at a rejected step's start is hopped across (module documentation): needed
    /// where a force jumps at a switch and the tolerance is tight (the accuracy study's
    /// reference at 1e-13). Off by default: with it the shooting's monodromy under Rayleigh
    /// damping misses a period doubling the harmonic balance finds (tests/periodic.rs).
    pub hop_switches: bool,
}

impl Default for Rk45Settings {
    /// rtol = 1e-8, atol_q = 1e-12, atol_v = 1e-10, safety 0.9, step ratios [0.2, 10], the PI
    /// controller with β = 0.04, automatic initial step, no maximum step, no minimum step,
    /// 10⁶ attempts per call, event tolerance 1e-12, events not recorded, switches not hopped.
    fn default() -> Self {
        Self {
            rtol: 1e-8,
            atol_q: 1e-12,
            atol_v: 1e-10,
            safety: 0.9,
            min_ratio: 0.2,
            max_ratio: 10.0,
            controller: StepController::PI { beta: 0.04 },
            initial_step: None,
            max_step: f64::INFINITY,
            min_step: 0.0,
            max_steps: 1_000_000,
            event_tolerance: 1e-12,
            record_events: false,
            hop_switches: false,
        }
    }
}

impl Rk45Settings {
    /// Checks every setting.
    pub fn validate(&self) -> Result<(), SolverError> {
        let inv = |name: &'static str, value: f64, reason: &'static str| {
            Err(SolverError::InvalidSetting { name, value, reason })
        };
        if !(self.rtol.is_finite() && self.rtol > 0.0 && self.rtol < 1.0) {
            return inv("rtol", self.rtol, "rtol must lie in (0, 1)");
        }
        check_range("atol_q", self.atol_q, 0.0, f64::MAX, "atol_q must be finite and non-negative")?;
        check_range("atol_v", self.atol_v, 0.0, f64::MAX, "atol_v must be finite and non-negative")?;
        if !(self.safety > 0.0 && self.safety <= 1.0) {
            return inv("safety", self.safety, "safety must lie in (0, 1]");
        }
        if !(self.min_ratio > 0.0 && self.min_ratio < 1.0) {
            return inv("min_ratio", self.min_ratio, "min_ratio must lie in (0, 1)");
        }
        if !(self.max_ratio.is_finite() && self.max_ratio > 1.0) {
            return inv("max_ratio", self.max_ratio, "max_ratio must be finite and above 1");
        }
        if let StepController::PI { beta } = self.controller {
            check_range("beta", beta, 0.0, 0.1, "the PI gain beta must lie in [0, 0.1]")?;
        }
        if let Some(h) = self.initial_step {
            if !(h.is_finite() && h > 0.0) {
                return inv("initial_step", h, "initial_step must be positive and finite");
            }
        }
        if self.max_step.is_nan() || self.max_step <= 0.0 {
            return inv("max_step", self.max_step, "max_step must be positive");
        }
        check_range("min_step", self.min_step, 0.0, f64::MAX, "min_step must be finite and non-negative")?;
        if self.min_step > self.max_step {
            return inv("min_step", self.min_step, "min_step must not exceed max_step");
        }
        if self.max_steps == 0 {
            return inv("max_steps", 0.0, "max_steps must be at least 1");
        }
        if !(self.event_tolerance >= 1e-15 && self.event_tolerance <= 0.1) {
            return inv("event_tolerance", self.event_tolerance, "event_tolerance must lie in [1e-15, 0.1]");
        }
        Ok(())
    }
}

/// A rigid motion from which the relative part of the error weight is measured
/// ([`Rk45::set_relative_origin`]): component i of the displacements is weighted by
/// `atol_q + rtol · |q_i − o_i(t)|` with `o_i(t) = q_anchor_i + rate_i · (t − t_anchor)`, and
/// of the velocities by `atol_v + rtol · |v_i − rate_i|`. A coordinate that grows without bound
/// with a uniform motion (a rotation) then keeps the allowance of its deviation from that motion
/// instead of one that grows with time.
#[derive(Debug, Clone, PartialEq)]
pub struct RelativeOrigin {
    /// Time of the anchor \[s\].
    pub t_anchor: f64,
    /// Displacements of the rigid motion at `t_anchor` [m or rad].
    pub q_anchor: Vec<f64>,
    /// Velocities of the rigid motion [m/s or rad/s].
    pub rate: Vec<f64>,
}

impl RelativeOrigin {
    /// Refuses an origin whose displacements or rates are not `n` long.
    fn check_dimension(&self, n: usize) -> Result<(), SolverError> {
        if self.q_anchor.len() != n || self.rate.len() != n {
            return Err(SolverError::InvalidArgument {
                name: "relative origin",
                value: self.q_anchor.len().min(self.rate.len()) as f64,
                reason: "the origin must have as many displacements and rates as the system",
            });
        }
        Ok(())
    }

    /// Component `i` of the origin of y = [q, v] at time `t`, for `n` displacements.
    fn at(&self, i: usize, n: usize, t: f64) -> f64 {
        if i < n {
            self.q_anchor[i] + self.rate[i] * (t - self.t_anchor)
        } else {
            self.rate[i - n]
        }
    }
}

/// One located zero crossing of an event function.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocatedEvent {
    /// Time of the crossing \[s\].
    pub t: f64,
    /// Index of the event function.
    pub index: usize,
    /// Whether the function went from negative to non-negative (`true`) or back (`false`).
    pub rising: bool,
}

/// Failure of a stage evaluation.
#[derive(Debug, Clone, Copy)]
enum StageFailure {
    State { t: f64, index: usize },
    Force { t: f64, index: usize },
}

impl StageFailure {
    fn into_error(self) -> SolverError {
        match self {
            StageFailure::State { t, index } => SolverError::NonFiniteState { t, index },
            StageFailure::Force { t, index } => SolverError::NonFiniteForce { t, index },
        }
    }
}

/// An event located inside a step; the step is being retaken to end at `t_event`.
#[derive(Debug, Clone)]
struct Pending {
    t_event: f64,
    /// (index, located time, value on the far side of the crossing).
    components: Vec<(usize, f64, f64)>,
    h_after: f64,
}

/// One attempted step: from `t` to `t_new` \[s\], of length `h` = `t_new` − `t`.
#[derive(Debug, Clone, Copy)]
struct Span {
    t: f64,
    t_new: f64,
    h: f64,
}

impl Span {
    /// The time tolerance of event location on this attempt, `event_tolerance · max(|t|,
    /// |t_new|, h)` \[s\].
    fn event_time_tolerance(self, event_tolerance: f64) -> f64 {
        event_tolerance * self.t.abs().max(self.t_new.abs()).max(self.h)
    }
}

/// The Dormand–Prince 5(4) integrator (see the module documentation for the equations).
///
/// Typical use: [`Rk45::new`], [`Rk45::init`], then repeated [`Rk45::advance_to`] calls, reading
/// [`Rk45::q`] and [`Rk45::v`] in between and [`Rk45::dense_at`] for times inside the last step.
#[derive(Debug, Clone)]
pub struct Rk45 {
    settings: Rk45Settings,
    origin: Option<RelativeOrigin>,
    initialized: bool,
    n: usize,
    t: f64,
    y: Vec<f64>,
    y_new: Vec<f64>,
    y_stage: Vec<f64>,
    k1: Vec<f64>,
    k2: Vec<f64>,
    k3: Vec<f64>,
    k4: Vec<f64>,
    k5: Vec<f64>,
    k6: Vec<f64>,
    k7: Vec<f64>,
    fbuf: Vec<f64>,
    mass: Vec<f64>,
    h_next: f64,
    err_old: f64,
    rejected_last: bool,
    n_events: usize,
    g_ref: Vec<f64>,
    g_new: Vec<f64>,
    g_tmp: Vec<f64>,
    dense: [Vec<f64>; 5],
    dense_t0: f64,
    dense_h: f64,
    dense_valid: bool,
    located: Vec<LocatedEvent>,
    stats: Stats,
}

/// Evaluates y' = [v, M⁻¹ f(t, q, v)] into `out`.
#[allow(clippy::too_many_arguments)]
fn deriv<S: SecondOrderSystem + ?Sized>(
    sys: &mut S,
    mass: &[f64],
    n: usize,
    t: f64,
    y: &[f64],
    out: &mut [f64],
    fbuf: &mut [f64],
    stats: &mut Stats,
) -> Result<(), StageFailure> {
    if let Some(index) = first_non_finite(y) {
        return Err(StageFailure::State { t, index });
    }
    let (q, v) = y.split_at(n);
    sys.force(t, q, v, fbuf);
    stats.rhs_evaluations += 1;
    if let Some(index) = first_non_finite(fbuf) {
        return Err(StageFailure::Force { t, index });
    }
    out[..n].copy_from_slice(v);
    for i in 0..n {
        out[n + i] = fbuf[i] / mass[i];
    }
    Ok(())
}

/// Evaluates the event functions at (t, y) into `out` and checks their number and finiteness.
fn eval_events<S: SecondOrderSystem + ?Sized>(
    sys: &mut S,
    n: usize,
    expected: Option<usize>,
    t: f64,
    y: &[f64],
    out: &mut Vec<f64>,
) -> Result<(), SolverError> {
    out.clear();
    let (q, v) = y.split_at(n);
    sys.events(t, q, v, out);
    if let Some(expected) = expected {
        if out.len() != expected {
            return Err(SolverError::EventCountChanged { t, expected, found: out.len() });
        }
    }
    if let Some(index) = first_non_finite(out) {
        return Err(SolverError::NonFiniteEvent { t, index });
    }
    Ok(())
}

/// The dense-output polynomial at θ.
fn dense_eval(dense: &[Vec<f64>; 5], theta: f64, out: &mut [f64]) {
    let th1 = 1.0 - theta;
    for (i, o) in out.iter_mut().enumerate() {
        *o = dense[0][i]
            + theta * (dense[1][i] + th1 * (dense[2][i] + theta * (dense[3][i] + th1 * dense[4][i])));
    }
}

/// Side of an event-function value: `true` for negative.
fn negative(g: f64) -> bool {
    g < 0.0
}

impl Rk45 {
    /// Creates an integrator after checking the settings; call [`Rk45::init`] next.
    pub fn new(settings: Rk45Settings) -> Result<Self, SolverError> {
        settings.validate()?;
        Ok(Self {
            settings,
            origin: None,
            initialized: false,
            n: 0,
            t: 0.0,
            y: Vec::new(),
            y_new: Vec::new(),
            y_stage: Vec::new(),
            k1: Vec::new(),
            k2: Vec::new(),
            k3: Vec::new(),
            k4: Vec::new(),
            k5: Vec::new(),
            k6: Vec::new(),
            k7: Vec::new(),
            fbuf: Vec::new(),
            mass: Vec::new(),
            h_next: 0.0,
            err_old: 1e-4,
            rejected_last: false,
            n_events: 0,
            g_ref: Vec::new(),
            g_new: Vec::new(),
            g_tmp: Vec::new(),
            dense: Default::default(),
            dense_t0: 0.0,
            dense_h: 0.0,
            dense_valid: false,
            located: Vec::new(),
            stats: Stats::default(),
        })
    }

    /// Sets the initial time `t0` \[s\], displacements `q0` [m or rad] and velocities `v0`
    /// [m/s or rad/s], evaluates the force and the event functions there and chooses the first
    /// step. The counters and the event record are kept.
    pub fn init<S: SecondOrderSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t0: f64,
        q0: &[f64],
        v0: &[f64],
    ) -> Result<(), SolverError> {
        let n = check_initial_state(sys, t0, q0, v0)?;
        if let Some(o) = &self.origin {
            o.check_dimension(n)?;
        }
        let mut y = Vec::with_capacity(2 * n);
        y.extend_from_slice(q0);
        y.extend_from_slice(v0);
        self.initialized = false;
        self.n = n;
        self.t = t0;
        self.mass = sys.mass().to_vec();
        self.fbuf = vec![0.0; n];
        for buf in [
            &mut self.y_new,
            &mut self.y_stage,
            &mut self.k1,
            &mut self.k2,
            &mut self.k3,
            &mut self.k4,
            &mut self.k5,
            &mut self.k6,
            &mut self.k7,
        ] {
            *buf = vec![0.0; 2 * n];
        }
        for buf in self.dense.iter_mut() {
            *buf = vec![0.0; 2 * n];
        }
        self.y = y;
        deriv(sys, &self.mass, n, t0, &self.y, &mut self.k1, &mut self.fbuf, &mut self.stats)
            .map_err(StageFailure::into_error)?;
        let mut g = Vec::new();
        eval_events(sys, n, None, t0, &self.y, &mut g)?;
        self.n_events = g.len();
        self.g_new = vec![0.0; g.len()];
        self.g_tmp = Vec::with_capacity(g.len());
        self.g_ref = g;
        self.h_next = match self.settings.initial_step {
            Some(h) => h.min(self.settings.max_step),
            None => self.initial_step_size(sys),
        };
        self.err_old = 1e-4;
        self.rejected_last = false;
        self.dense_valid = false;
        self.initialized = true;
        Ok(())
    }

    /// Restarts from time `t` \[s\], displacements `q` [m or rad] and velocities `v`
    /// [m/s or rad/s]. Same as [`Rk45::init`].
    pub fn set_state<S: SecondOrderSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t: f64,
        q: &[f64],
        v: &[f64],
    ) -> Result<(), SolverError> {
        self.init(sys, t, q, v)
    }

    /// The step controller's state: the proposed next step \[s\], the last accepted error norm and
    /// whether the last attempt was rejected (1 or 0). With [`Rk45::restore`] a run continues
    /// bit-identically from a saved state.
    pub fn controller_state(&self) -> [f64; 3] {
        [self.h_next, self.err_old, if self.rejected_last { 1.0 } else { 0.0 }]
    }

    /// Restarts from time `t` \[s\], displacements `q` [m or rad] and velocities `v`
    /// [m/s or rad/s] as [`Rk45::init`], then takes the step controller's state from
    /// [`Rk45::controller_state`]: the continuation takes the steps the saved run would have
    /// taken (the force and event functions at the state are recomputed, and equal the saved
    /// run's because they are functions of it).
    pub fn restore<S: SecondOrderSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t: f64,
        q: &[f64],
        v: &[f64],
        controller: &[f64; 3],
    ) -> Result<(), SolverError> {
        let [h_next, err_old, rejected] = *controller;
        if !(h_next.is_finite() && h_next > 0.0) {
            return Err(SolverError::InvalidArgument {
                name: "h_next",
                value: h_next,
                reason: "the saved next step must be positive and finite",
            });
        }
        if !(err_old.is_finite() && err_old >= 0.0) {
            return Err(SolverError::InvalidArgument {
                name: "err_old",
                value: err_old,
                reason: "the saved error norm must be finite and non-negative",
            });
        }
        // The saved step replaces the automatic choice, which would evaluate the force at a
        // trial state.
        let automatic = self.settings.initial_step;
        self.settings.initial_step = Some(h_next);
        let started = self.init(sys, t, q, v);
        self.settings.initial_step = automatic;
        started?;
        self.h_next = h_next;
        self.err_old = err_old;
        self.rejected_last = rejected != 0.0;
        Ok(())
    }

    /// Sets the rigid motion from which the relative part of the error weight is measured (see
    /// [`RelativeOrigin`]); `None` (the default) measures it from zero, `sk_i = atol_i + rtol ·
    /// max(|y_{n,i}|, |y_{n+1,i}|)`. With an origin, `sk_i = atol_i + rtol · max(|y_{n,i} −
    /// o_i(t_n)|, |y_{n+1,i} − o_i(t_{n+1})|)`, and the automatic first step weights the state
    /// by its deviation in the same way. It applies to the steps from the next one on; the state
    /// and the step controller are kept.
    pub fn set_relative_origin(&mut self, origin: Option<RelativeOrigin>) -> Result<(), SolverError> {
        if let Some(o) = &origin {
            if self.initialized {
                o.check_dimension(self.n)?;
            }
            if let Some(index) = first_non_finite(&o.q_anchor).or(first_non_finite(&o.rate)) {
                return Err(SolverError::InvalidArgument {
                    name: "relative origin",
                    value: index as f64,
                    reason: "the origin's anchor, displacements and rates must be finite",
                });
            }
            if !o.t_anchor.is_finite() {
                return Err(SolverError::InvalidArgument {
                    name: "relative origin",
                    value: o.t_anchor,
                    reason: "the origin's anchor time must be finite",
                });
            }
        }
        self.origin = origin;
        Ok(())
    }

    /// The rigid motion of the error weight's relative part ([`Rk45::set_relative_origin`]).
    pub fn relative_origin(&self) -> Option<&RelativeOrigin> {
        self.origin.as_ref()
    }

    /// Magnitude of component `i` of `y` at time `t` in the relative part of the error weight:
    /// |y_i|, or its deviation from the origin (whose dimension `init` and
    /// [`Rk45::set_relative_origin`] have checked).
    fn magnitude(&self, i: usize, t: f64, y: f64) -> f64 {
        match &self.origin {
            None => y.abs(),
            Some(o) => (y - o.at(i, self.n, t)).abs(),
        }
    }

    /// Absolute tolerance of component `i` of y = [q, v].
    fn atol(&self, i: usize) -> f64 {
        if i < self.n {
            self.settings.atol_q
        } else {
            self.settings.atol_v
        }
    }

    /// Starting step size of Hairer, Nørsett & Wanner §II.4 (DOPRI5's HINIT).
    fn initial_step_size<S: SecondOrderSystem + ?Sized>(&mut self, sys: &mut S) -> f64 {
        let rtol = self.settings.rtol;
        let max_step = self.settings.max_step;
        let (mut dnf, mut dny) = (0.0, 0.0);
        for i in 0..2 * self.n {
            let sk = self.atol(i) + rtol * self.magnitude(i, self.t, self.y[i]);
            dnf += (self.k1[i] / sk).powi(2);
            dny += (self.y[i] / sk).powi(2);
        }
        let mut h = if dnf <= 1e-10 || dny <= 1e-10 { 1e-6 } else { (dny / dnf).sqrt() * 0.01 };
        h = h.min(max_step);
        for i in 0..2 * self.n {
            self.y_stage[i] = self.y[i] + h * self.k1[i];
        }
        let ok = deriv(
            sys,
            &self.mass,
            self.n,
            self.t + h,
            &self.y_stage,
            &mut self.k2,
            &mut self.fbuf,
            &mut self.stats,
        )
        .is_ok();
        if !ok || !dnf.is_finite() || !dny.is_finite() {
            return (1e-3 * h).max(f64::MIN_POSITIVE);
        }
        let mut der2 = 0.0;
        for i in 0..2 * self.n {
            let sk = self.atol(i) + rtol * self.magnitude(i, self.t, self.y[i]);
            der2 += ((self.k2[i] - self.k1[i]) / sk).powi(2);
        }
        let der2 = der2.sqrt() / h;
        let der12 = der2.max(dnf.sqrt());
        let h1 = if der12 <= 1e-15 { (h * 1e-3).max(1e-6) } else { (0.01 / der12).powf(0.2) };
        let h = (100.0 * h).min(h1).min(max_step);
        if h.is_finite() && h > 0.0 {
            h
        } else {
            1e-6_f64.min(max_step)
        }
    }

    /// Computes the stages of one step of size `h` ending at `t_new`; returns the error norm.
    fn attempt<S: SecondOrderSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        h: f64,
        t_new: f64,
    ) -> Result<f64, StageFailure> {
        let (n, t) = (self.n, self.t);
        let m = 2 * n;
        let Self { y, y_new, y_stage, k1, k2, k3, k4, k5, k6, k7, fbuf, mass, stats, .. } = self;
        for i in 0..m {
            y_stage[i] = y[i] + h * A21 * k1[i];
        }
        deriv(sys, mass, n, t + C2 * h, y_stage, k2, fbuf, stats)?;
        for i in 0..m {
            y_stage[i] = y[i] + h * (A31 * k1[i] + A32 * k2[i]);
        }
        deriv(sys, mass, n, t + C3 * h, y_stage, k3, fbuf, stats)?;
        for i in 0..m {
            y_stage[i] = y[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i]);
        }
        deriv(sys, mass, n, t + C4 * h, y_stage, k4, fbuf, stats)?;
        for i in 0..m {
            y_stage[i] = y[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]);
        }
        deriv(sys, mass, n, t + C5 * h, y_stage, k5, fbuf, stats)?;
        for i in 0..m {
            y_stage[i] = y[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] + A65 * k5[i]);
        }
        deriv(sys, mass, n, t_new, y_stage, k6, fbuf, stats)?;
        for i in 0..m {
            y_new[i] = y[i] + h * (A71 * k1[i] + A73 * k3[i] + A74 * k4[i] + A75 * k5[i] + A76 * k6[i]);
        }
        deriv(sys, mass, n, t_new, y_new, k7, fbuf, stats)?;
        let rtol = self.settings.rtol;
        let mut sum = 0.0;
        for i in 0..m {
            let atol = if i < n { self.settings.atol_q } else { self.settings.atol_v };
            let sk =
                atol + rtol * self.magnitude(i, t, self.y[i]).max(self.magnitude(i, t_new, self.y_new[i]));
            let e = h
                * (E1 * self.k1[i]
                    + E3 * self.k3[i]
                    + E4 * self.k4[i]
                    + E5 * self.k5[i]
                    + E6 * self.k6[i]
                    + E7 * self.k7[i]);
            sum += (e / sk).powi(2);
        }
        let err = (sum / m.max(1) as f64).sqrt();
        Ok(if err.is_nan() { f64::INFINITY } else { err })
    }

    /// Fills the dense-output coefficients of the step (t, h) just computed by `attempt`.
    fn prepare_dense(&mut self, h: f64) {
        let [r1, r2, r3, r4, r5] = &mut self.dense;
        for i in 0..2 * self.n {
            let dy = self.y_new[i] - self.y[i];
            let bspl = h * self.k1[i] - dy;
            r1[i] = self.y[i];
            r2[i] = dy;
            r3[i] = bspl;
            r4[i] = dy - h * self.k7[i] - bspl;
            r5[i] = h
                * (D1 * self.k1[i]
                    + D3 * self.k3[i]
                    + D4 * self.k4[i]
                    + D5 * self.k5[i]
                    + D6 * self.k6[i]
                    + D7 * self.k7[i]);
        }
        self.dense_t0 = self.t;
        self.dense_h = h;
    }

    /// Accepts the step to `t_new` (dense output must already be prepared).
    fn commit(&mut self, t_new: f64, err: f64) {
        std::mem::swap(&mut self.y, &mut self.y_new);
        std::mem::swap(&mut self.k1, &mut self.k7);
        self.t = t_new;
        self.dense_valid = true;
        self.stats.steps += 1;
        self.err_old = err.max(1e-4);
        self.rejected_last = false;
    }

    /// Counts (and possibly records) one located crossing.
    fn record(&mut self, t: f64, index: usize, post: f64) {
        self.stats.events_located += 1;
        if self.settings.record_events {
            self.located.push(LocatedEvent { t, index, rising: !negative(post) });
        }
    }

    /// Locates the crossing of event function `index` inside the step whose dense output is
    /// prepared, between the values `fa` at its start and `fb` at its end, to the tolerance `tol`
    /// in θ; returns the times on the near and the far side of the final bracket.
    fn locate<S: SecondOrderSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        index: usize,
        mut fa: f64,
        mut fb: f64,
        t_new: f64,
        tol: f64,
    ) -> Result<(f64, f64), SolverError> {
        let (t0, h) = (self.dense_t0, self.dense_h);
        let (mut a, mut b) = (0.0_f64, 1.0_f64);
        let mut last_side = 0i8;
        let mut g = std::mem::take(&mut self.g_tmp);
        let mut result = Ok(());
        for iteration in 0..ROOT_ITERATIONS {
            if b - a <= tol {
                break;
            }
            let mut c = if iteration < ILLINOIS_ITERATIONS && fb != fa {
                b - fb * (b - a) / (fb - fa)
            } else {
                f64::NAN
            };
            if !(c > a && c < b) {
                c = 0.5 * (a + b);
            }
            if !(c > a && c < b) {
                break;
            }
            dense_eval(&self.dense, c, &mut self.y_stage);
            let tc = t0 + c * h;
            if let Err(e) = eval_events(sys, self.n, Some(self.n_events), tc, &self.y_stage, &mut g) {
                result = Err(e);
                break;
            }
            let fc = g[index];
            if negative(fc) == negative(fb) {
                b = c;
                fb = fc;
                if last_side == -1 {
                    fa *= 0.5;
                }
                last_side = -1;
            } else {
                a = c;
                fa = fc;
                if last_side == 1 {
                    fb *= 0.5;
                }
                last_side = 1;
            }
        }
        self.g_tmp = g;
        result?;
        Ok((t0 + a * h, if b >= 1.0 { t_new } else { t0 + b * h }))
    }

    /// Earliest sign change of an event function over a step that failed the error test, located
    /// roughly (to 1e-3 of the step) on that step's dense output: its index and the side of its
    /// bracket a retake aims at (the near side where switches are hopped, the far side
    /// otherwise); `None` if no function changed sign or the step's end state is unusable.
    fn rough_crossing<S: SecondOrderSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        h: f64,
        t_new: f64,
    ) -> Result<Option<(usize, f64)>, SolverError> {
        if first_non_finite(&self.y_new).is_some() {
            return Ok(None);
        }
        let mut g_new = std::mem::take(&mut self.g_new);
        let ev = eval_events(sys, self.n, Some(self.n_events), t_new, &self.y_new, &mut g_new);
        self.g_new = g_new;
        ev?;
        if !(0..self.n_events).any(|i| negative(self.g_ref[i]) != negative(self.g_new[i])) {
            return Ok(None);
        }
        self.prepare_dense(h);
        let mut earliest: Option<(usize, f64)> = None;
        for i in 0..self.n_events {
            let (fa, fb) = (self.g_ref[i], self.g_new[i]);
            if negative(fa) != negative(fb) {
                let (near, far) = self.locate(sys, i, fa, fb, t_new, 1e-3)?;
                let aim = if self.settings.hop_switches { near } else { far };
                if earliest.is_none_or(|e| aim < e.1) {
                    earliest = Some((i, aim));
                }
            }
        }
        Ok(earliest)
    }

    /// Integrates from the current time to `t_end` \[s\] with adaptive steps, landing exactly on
    /// `t_end` and on every located event in between.
    ///
    /// On error the integrator keeps the last accepted state.
    pub fn advance_to<S: SecondOrderSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t_end: f64,
    ) -> Result<(), SolverError> {
        self.integrate(sys, t_end, false)
    }

    /// Takes one accepted step towards `t_max` \[s\]: the step the controller proposes, ending
    /// at a located event inside it or at `t_max` if it would reach that far. Dense output
    /// ([`Rk45::dense_at`]) then covers the step; this is how a caller samples the solution at
    /// times of its own without forcing step ends onto them. Does nothing at `t_max`.
    ///
    /// On error the integrator keeps the last accepted state.
    pub fn step<S: SecondOrderSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t_max: f64,
    ) -> Result<(), SolverError> {
        self.integrate(sys, t_max, true)
    }

    /// The step loop of [`Rk45::advance_to`] and [`Rk45::step`]: up to `t_end`, or one accepted
    /// step when `single`.
    fn integrate<S: SecondOrderSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t_end: f64,
        single: bool,
    ) -> Result<(), SolverError> {
        if !self.initialized {
            return Err(SolverError::NotInitialized);
        }
        check_dim(sys, self.n)?;
        if !t_end.is_finite() || t_end < self.t {
            return Err(SolverError::InvalidArgument {
                name: "t_end",
                value: t_end,
                reason: "t_end must be finite and not before the current time",
            });
        }
        let s = self.settings;
        let mut attempts: u64 = 0;
        let mut pending: Option<Pending> = None;
        let mut aimed = false;
        while self.t < t_end {
            if attempts >= s.max_steps {
                return Err(SolverError::TooManySteps { t: self.t, max_steps: s.max_steps });
            }
            attempts += 1;
            let t = self.t;
            let (t_new, h_proposed) = self.step_end(pending.as_ref(), t_end);
            let span = Span { t, t_new, h: t_new - t };
            let tiny = 4.0 * f64::EPSILON * t.abs();
            if span.h.is_nan()
                || span.h <= tiny
                || (pending.is_none() && t_new < t_end && span.h < s.min_step)
            {
                return Err(SolverError::StepTooSmall { t, h: span.h });
            }
            // A retake that ends on a located event (`pending`) and fails the error test is not
            // re-aimed at the crossing: that would propose the step that found it again, and
            // when the crossing lies within 1 % of `t_end` that step reaches `t_end` and the two
            // alternate for ever. The controller's shorter step ends before the crossing.
            let landing = pending.is_some();
            let err = match self.attempt(sys, span.h, t_new) {
                Err(failure) => {
                    pending = None;
                    aimed = false;
                    self.reject_failed(span.h, tiny, failure)?;
                    continue;
                }
                Ok(err) if err > 1.0 => {
                    pending = None;
                    let hopped;
                    (aimed, hopped) = self.reject_inaccurate(sys, span, err, tiny, !aimed && !landing)?;
                    // A hop ends a single step: its crossing is recorded at the hop's end, where
                    // a caller reading the located events after each step finds the switch.
                    if hopped && single {
                        break;
                    }
                    continue;
                }
                Ok(err) => err,
            };
            // The step passes the error test: propose the next step size.
            aimed = false;
            let mut h_next = self.next_step_size(span.h, err);
            if t_new == t_end && span.h < h_proposed {
                h_next = h_next.max(h_proposed);
            }
            self.prepare_dense(span.h);
            pending = self.accept(sys, span, err, h_next, pending.take())?;
            if pending.is_none() && single {
                break;
            }
        }
        Ok(())
    }

    /// Where the next attempt ends, and the step the controller proposes: at the pending
    /// event, or the proposed step (at most the largest allowed), stretched to `t_end` when
    /// that lies within 1 % beyond it.
    #[inline]
    fn step_end(&self, pending: Option<&Pending>, t_end: f64) -> (f64, f64) {
        match pending {
            Some(p) => (p.t_event, p.h_after),
            None => {
                let h = self.h_next.min(self.settings.max_step);
                if self.t + 1.01 * h >= t_end {
                    (t_end, h)
                } else {
                    (self.t + h, h)
                }
            }
        }
    }

    /// Rejects an attempt of length `h` whose stages failed (a state or force not finite):
    /// the next attempt is shorter by the least ratio; the failure is the error where that
    /// falls below the least step (or `tiny`, the rounding of the time).
    #[inline]
    fn reject_failed(&mut self, h: f64, tiny: f64, failure: StageFailure) -> Result<(), SolverError> {
        let s = self.settings;
        self.stats.rejected_steps += 1;
        self.rejected_last = true;
        self.h_next = h * s.min_ratio;
        if self.h_next < s.min_step.max(tiny) {
            return Err(failure.into_error());
        }
        Ok(())
    }

    /// Rejects the attempt `span` whose error norm `err` exceeds 1: the controller's shorter
    /// step next, or, where `may_aim` (the attempt neither aimed at a crossing nor landing on
    /// one) and the model has events, a step aimed at a crossing roughly located on the
    /// rejected step ([`Rk45::rough_crossing`]): a switch inside the step (a kink or a jump in
    /// the force) is the likely cause of the rejection; if the aimed attempt fails too, the
    /// controller takes over. With [`Rk45Settings::hop_switches`] a crossing within the event
    /// tolerance of the step's start (located to it) is hopped across where the hop crosses
    /// it ([`Rk45::hop`]), and the attempt is repeated past it. Whether the next attempt is
    /// aimed, and whether the state hopped.
    #[inline]
    fn reject_inaccurate<S: SecondOrderSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        span: Span,
        err: f64,
        tiny: f64,
        may_aim: bool,
    ) -> Result<(bool, bool), SolverError> {
        let s = self.settings;
        self.stats.rejected_steps += 1;
        self.rejected_last = true;
        self.h_next = span.h * (s.safety * err.powf(-0.2)).max(s.min_ratio);
        let mut aimed = false;
        if self.n_events > 0 && may_aim {
            if let Some((i, mut aim)) = self.rough_crossing(sys, span.h, span.t_new)? {
                let tol_t = span.event_time_tolerance(s.event_tolerance);
                if s.hop_switches && aim - span.t <= tol_t {
                    let (fa, fb) = (self.g_ref[i], self.g_new[i]);
                    let (near, far) = self.locate(sys, i, fa, fb, span.t_new, tol_t / span.h)?;
                    if near - span.t <= tol_t && far > span.t && self.hop(sys, far, i)? {
                        self.h_next = span.h;
                        return Ok((false, true));
                    }
                    aim = near;
                }
                if aim - span.t > tiny {
                    self.h_next = aim - span.t;
                    aimed = true;
                }
            }
        }
        if self.h_next < s.min_step.max(tiny) {
            return Err(SolverError::StepTooSmall { t: span.t, h: self.h_next });
        }
        Ok((aimed, false))
    }

    /// The step after an accepted step of length `h` with error norm `err`: the
    /// controller's factor within the allowed ratios, not growing right after a rejection.
    #[inline]
    fn next_step_size(&self, h: f64, err: f64) -> f64 {
        let s = self.settings;
        let mut fac = if err == 0.0 {
            s.max_ratio
        } else {
            match s.controller {
                StepController::Standard => s.safety * err.powf(-0.2),
                StepController::PI { beta } => {
                    s.safety * err.powf(-(0.2 - 0.75 * beta)) * self.err_old.powf(beta)
                }
            }
        };
        fac = fac.clamp(s.min_ratio, s.max_ratio);
        if self.rejected_last {
            fac = fac.min(1.0);
        }
        h * fac
    }

    /// Accepts the attempt `span` that passed the error test (its dense output prepared),
    /// `h_next` the step after it: committed where the model has no events, or where it
    /// lands on the `pending` event, or where no event crosses inside it. Otherwise the
    /// event to retake the step onto.
    #[inline]
    fn accept<S: SecondOrderSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        span: Span,
        err: f64,
        h_next: f64,
        pending: Option<Pending>,
    ) -> Result<Option<Pending>, SolverError> {
        if self.n_events == 0 {
            self.commit(span.t_new, err);
            self.h_next = h_next;
            return Ok(None);
        }
        let mut g_new = std::mem::take(&mut self.g_new);
        let ev = eval_events(sys, self.n, Some(self.n_events), span.t_new, &self.y_new, &mut g_new);
        self.g_new = g_new;
        ev?;
        if let Some(p) = pending {
            self.land(p, span.t_new, err);
            return Ok(None);
        }
        let interior = self.interior_event(sys, span, h_next)?;
        if interior.is_some() {
            // Retake the step so that it ends on the event.
            return Ok(interior);
        }
        self.commit(span.t_new, err);
        self.h_next = h_next;
        self.g_ref.copy_from_slice(&self.g_new);
        Ok(None)
    }

    /// Commits the retaken step that lands on its located event `p` at `t_new`: the event's
    /// components recorded at their located times with their values past the crossing, any
    /// other sign change at the step's end.
    #[inline]
    fn land(&mut self, p: Pending, t_new: f64, err: f64) {
        self.commit(t_new, err);
        self.h_next = p.h_after;
        for i in 0..self.n_events {
            if let Some(&(_, te, post)) = p.components.iter().find(|c| c.0 == i) {
                self.record(te, i, post);
                self.g_ref[i] = post;
            } else {
                let gi = self.g_new[i];
                if negative(gi) != negative(self.g_ref[i]) {
                    self.record(t_new, i, gi);
                }
                self.g_ref[i] = gi;
            }
        }
    }

    /// Moves the state from the current time across a switch at it to `t_far` \[s\], within the
    /// event tolerance past it, on the last derivative (an Euler step of at most twice the
    /// tolerance), where event function `index` changes side on that line: then evaluates the
    /// derivative there (the next step's first stage, on the force past the switch), records
    /// the event functions whose side changed and gives `true`. Otherwise, or on a failure,
    /// the state stays as it was.
    fn hop<S: SecondOrderSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        t_far: f64,
        index: usize,
    ) -> Result<bool, SolverError> {
        let dt = t_far - self.t;
        for ((x, y), k) in self.y_stage.iter_mut().zip(self.y.iter()).zip(self.k1.iter()) {
            *x = y + dt * k;
        }
        let mut g = std::mem::take(&mut self.g_tmp);
        let ev = eval_events(sys, self.n, Some(self.n_events), t_far, &self.y_stage, &mut g);
        let crossed = ev.is_ok() && negative(g[index]) != negative(self.g_ref[index]);
        if !crossed {
            self.g_tmp = g;
            return ev.map(|()| false);
        }
        let Self { y_stage, k7, fbuf, mass, stats, n, .. } = self;
        if let Err(e) = deriv(sys, mass, *n, t_far, y_stage, k7, fbuf, stats) {
            self.g_tmp = g;
            return Err(e.into_error());
        }
        for (i, &gi) in g.iter().enumerate().take(self.n_events) {
            if negative(gi) != negative(self.g_ref[i]) {
                self.record(t_far, i, gi);
            }
            self.g_ref[i] = gi;
        }
        self.g_tmp = g;
        std::mem::swap(&mut self.y, &mut self.y_stage);
        std::mem::swap(&mut self.k1, &mut self.k7);
        self.t = t_far;
        Ok(true)
    }

    /// The event functions whose sign changes over the accepted attempt `span`, each
    /// located: crossings at the step's start are recorded (nothing to retake for them),
    /// crossings at its end too (the step already ends there); otherwise the earliest
    /// crossing inside the step, with those within the tolerance of it, as the event to
    /// retake the step onto, `h_next` the step after it.
    #[inline]
    fn interior_event<S: SecondOrderSystem + ?Sized>(
        &mut self,
        sys: &mut S,
        span: Span,
        h_next: f64,
    ) -> Result<Option<Pending>, SolverError> {
        let Span { t, t_new, h } = span;
        let s = self.settings;
        let tol_t = span.event_time_tolerance(s.event_tolerance);
        let tol_theta = tol_t / h;
        let mut crossings: Vec<(usize, f64)> = Vec::new();
        for i in 0..self.n_events {
            let (fa, fb) = (self.g_ref[i], self.g_new[i]);
            if negative(fa) != negative(fb) {
                let (_, te) = self.locate(sys, i, fa, fb, t_new, tol_theta)?;
                crossings.push((i, te));
            }
        }
        while !crossings.is_empty() {
            let t_star = crossings.iter().map(|c| c.1).fold(f64::INFINITY, f64::min);
            if t_star <= t + tol_t {
                let mut k = 0;
                while k < crossings.len() {
                    let (i, te) = crossings[k];
                    if te <= t + tol_t {
                        let post = self.g_new[i];
                        self.record(te, i, post);
                        self.g_ref[i] = post;
                        crossings.swap_remove(k);
                    } else {
                        k += 1;
                    }
                }
            } else if t_star >= t_new - tol_t {
                for &(i, te) in &crossings {
                    self.record(te, i, self.g_new[i]);
                }
                break;
            } else {
                let components = crossings
                    .iter()
                    .filter(|c| c.1 <= t_star + tol_t)
                    .map(|&(i, te)| (i, te, self.g_new[i]))
                    .collect();
                return Ok(Some(Pending { t_event: t_star, components, h_after: h_next }));
            }
        }
        Ok(None)
    }

    /// Writes the dense-output displacements [m or rad] and velocities [m/s or rad/s] at time
    /// `t` \[s\] inside the last accepted step into `q` and `v`. Before the first step only the
    /// current time is available.
    pub fn dense_at(&self, t: f64, q: &mut [f64], v: &mut [f64]) -> Result<(), SolverError> {
        if !self.initialized {
            return Err(SolverError::NotInitialized);
        }
        let n = self.n;
        if q.len() != n {
            return Err(SolverError::DimensionMismatch { name: "q", expected: n, found: q.len() });
        }
        if v.len() != n {
            return Err(SolverError::DimensionMismatch { name: "v", expected: n, found: v.len() });
        }
        if t == self.t {
            q.copy_from_slice(&self.y[..n]);
            v.copy_from_slice(&self.y[n..]);
            return Ok(());
        }
        let start = if self.dense_valid { self.dense_t0 } else { self.t };
        if !(t >= start && t <= self.t) {
            return Err(SolverError::TimeOutOfRange { t, start, end: self.t });
        }
        let theta = (t - self.dense_t0) / self.dense_h;
        let th1 = 1.0 - theta;
        let d = &self.dense;
        for i in 0..2 * n {
            let yi = d[0][i] + theta * (d[1][i] + th1 * (d[2][i] + theta * (d[3][i] + th1 * d[4][i])));
            if i < n {
                q[i] = yi;
            } else {
                v[i - n] = yi;
            }
        }
        Ok(())
    }

    /// Current time \[s\].
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Current displacements [m or rad, per coordinate].
    pub fn q(&self) -> &[f64] {
        &self.y[..self.n]
    }

    /// Current velocities [m/s or rad/s, per coordinate].
    pub fn v(&self) -> &[f64] {
        &self.y[self.n..]
    }

    /// Current acceleration M⁻¹ f(t, q, v) [m/s² or rad/s², per coordinate].
    pub fn a(&self) -> &[f64] {
        &self.k1[self.n..]
    }

    /// Size of the next step the controller proposes \[s\].
    pub fn next_step(&self) -> f64 {
        self.h_next
    }

    /// Start and end of the last accepted step, if a step has been taken since `init` \[s\].
    pub fn last_step(&self) -> Option<(f64, f64)> {
        self.dense_valid.then_some((self.dense_t0, self.t))
    }

    /// Events located so far, in order, if [`Rk45Settings::record_events`] is set.
    pub fn located_events(&self) -> &[LocatedEvent] {
        &self.located
    }

    /// Removes and returns the recorded events.
    pub fn take_located_events(&mut self) -> Vec<LocatedEvent> {
        std::mem::take(&mut self.located)
    }

    /// The settings in use.
    pub fn settings(&self) -> &Rk45Settings {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A mass on a spring whose far end moves at `rate`: q = rate·t + A sin(ω t) for the start
    /// below (a uniform drift plus a small oscillation).
    struct Drift {
        rate: f64,
        omega: f64,
        mass: [f64; 1],
    }

    impl SecondOrderSystem for Drift {
        fn dim(&self) -> usize {
            1
        }
        fn mass(&self) -> &[f64] {
            &self.mass
        }
        fn force(&mut self, t: f64, q: &[f64], _v: &[f64], f: &mut [f64]) {
            f[0] = -self.omega * self.omega * (q[0] - self.rate * t);
        }
    }

    const RATE: f64 = 50.0;
    const OMEGA: f64 = 2.0 * std::f64::consts::PI * 100.0;
    const AMPLITUDE: f64 = 1e-5;

    /// Accepted steps over 20 periods of the oscillation from `t0`, with `origin` anchored at the
    /// start (the drift) or none.
    fn steps_from(t0: f64, origin: Option<fn(f64, f64) -> RelativeOrigin>) -> (u64, Vec<f64>) {
        let mut sys = Drift { rate: RATE, omega: OMEGA, mass: [1.0] };
        let settings =
            Rk45Settings { rtol: 1e-6, atol_q: 1e-12, atol_v: 1e-12 * OMEGA, ..Rk45Settings::default() };
        let mut rk = Rk45::new(settings).unwrap();
        let q0 = RATE * t0 + AMPLITUDE * (OMEGA * t0).sin();
        let v0 = RATE + AMPLITUDE * OMEGA * (OMEGA * t0).cos();
        if let Some(make) = origin {
            rk.set_relative_origin(Some(make(t0, q0))).unwrap();
        }
        rk.init(&mut sys, t0, &[q0], &[v0]).unwrap();
        let end = t0 + 20.0 * 2.0 * std::f64::consts::PI / OMEGA;
        let mut times = Vec::new();
        while rk.time() < end {
            rk.step(&mut sys, end).unwrap();
            times.push(rk.time());
        }
        (rk.stats().steps, times)
    }

    fn drift_origin(t0: f64, q0: f64) -> RelativeOrigin {
        RelativeOrigin { t_anchor: t0, q_anchor: vec![q0], rate: vec![RATE] }
    }

    fn zero_origin(t0: f64, _q0: f64) -> RelativeOrigin {
        RelativeOrigin { t_anchor: t0, q_anchor: vec![0.0], rate: vec![0.0] }
    }

    /// Without an origin the weight is `atol + rtol · max(|y_n|, |y_{n+1}|)` as before: an origin
    /// of zero displacement and zero rate (|y − 0| = |y|) takes bit-identical steps.
    #[test]
    fn no_origin_weights_from_zero() {
        for t0 in [0.0, 3.0] {
            let (n_none, t_none) = steps_from(t0, None);
            let (n_zero, t_zero) = steps_from(t0, Some(zero_origin));
            assert_eq!(n_none, n_zero);
            assert_eq!(t_none, t_zero);
        }
    }

    /// An origin of another dimension than the system is refused when the
    /// integrator starts, naming the origin.
    #[test]
    fn an_origin_of_another_dimension_is_refused_at_init() {
        let mut sys = Drift { rate: RATE, omega: OMEGA, mass: [1.0] };
        let mut rk = Rk45::new(Rk45Settings::default()).unwrap();
        let two = RelativeOrigin { t_anchor: 0.0, q_anchor: vec![0.0; 2], rate: vec![RATE; 2] };
        rk.set_relative_origin(Some(two)).unwrap();
        let e = rk.init(&mut sys, 0.0, &[0.0], &[RATE]).unwrap_err();
        assert!(e.to_string().contains("relative origin"), "{e}");
    }

    /// With the drift as origin the allowance does not grow with time: the same number of steps
    /// (within 1 %, the first step's choice) at any time offset; without it the allowance rtol·|q| grows with the drift and
    /// the step count falls (to where the velocities' allowance, which does not grow, sets it).
    #[test]
    fn an_origin_on_the_drift_keeps_the_allowance_from_growing_with_time() {
        let period = 2.0 * std::f64::consts::PI / OMEGA;
        let offsets = [0.0, 100.0 * period, 10_000.0 * period];
        let with: Vec<u64> = offsets.iter().map(|t0| steps_from(*t0, Some(drift_origin)).0).collect();
        let without: Vec<u64> = offsets.iter().map(|t0| steps_from(*t0, None).0).collect();
        for n in &with {
            assert!(100 * n.abs_diff(with[0]) <= with[0], "with the origin: {with:?}");
        }
        assert!(without[1] < without[0] && without[2] <= without[1], "without: {without:?}");
        assert!(without[2] < with[2], "with {with:?}, without {without:?}");
    }
}
