//! Pseudo-arclength continuation of periodic steady states in input speed
//! (docs/PERIODIC.md): one connected branch through folds, with every
//! point's Floquet multipliers and stability, and the folds (a real
//! multiplier through +1, where the branch turns back in speed) and
//! period-doubling points (a real multiplier through −1) located between
//! the points that bracket them.
//!
//! The unknowns are Y = (z, λ): the periodic state's scaled relative state z
//! ([`PeriodicProblem`]) and the speed in units of the nominal step,
//! λ = ω / Δω. A step predicts along the unit tangent t of the branch
//! (the null vector of [∂G/∂z, ∂G/∂λ], oriented as the previous one) and
//! corrects by chord-Newton on G(z, λ) = 0 with tᵀ(Y − Y_pred) = 0, on the
//! linearization of the last point; the arclength step grows after easy
//! corrections and shrinks after hard or failed ones. All speeds are rad/s.

mod follow;

use serde::{Deserialize, Serialize};

use crate::dynamics::periodic::{
    floquet_multipliers, max_abs, newton_converged, refit, solve_dense, ArcLinear, ArcWork, HarmonicBalance,
    HarmonicOrbit, Linearization, PeriodicError, PeriodicOrbit, PeriodicProblem,
};
use crate::dynamics::response::Work;
use follow::follow;

/// Settings of a continuation run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContinuationSettings {
    /// Speed where the branch starts [rad/s].
    pub from: f64,
    /// Speed where it ends [rad/s] (either side of `from`).
    pub to: f64,
    /// Nominal speed step [rad/s]: the unit of λ, the first arclength step,
    /// and the largest change of speed from one point to the next (the
    /// curve is at least as fine as a marching sweep at this step).
    pub step: f64,
    /// Largest arclength step, in nominal steps.
    pub max_step: f64,
    /// Smallest arclength step, in nominal steps; a step that fails below it ends the run.
    pub min_step: f64,
    /// Most points on the branch.
    pub max_points: usize,
    /// Most chord-Newton corrections per step.
    pub max_corrections: usize,
    /// How far a branch may run back below the furthest speed reached, in
    /// nominal steps; and twice this is the most speed it may travel (either
    /// way) without reaching further. Beyond either the run restarts past
    /// the furthest speed ([`GapKind::Restart`]), so a tangle of unstable
    /// branches (where the teeth separate) cannot hold it.
    #[serde(default = "default_max_back")]
    pub max_back: f64,
}

fn default_max_back() -> f64 {
    10.0
}

impl ContinuationSettings {
    /// From `from` to `to` at nominal step `step` [rad/s], with the default
    /// step bounds (1/256 to 1 nominal step), at most 20 000 points, 8
    /// corrections per step, and at most 10 nominal steps back.
    pub fn new(from: f64, to: f64, step: f64) -> Self {
        Self {
            from,
            to,
            step,
            max_step: 1.0,
            min_step: 1.0 / 256.0,
            max_points: 20_000,
            max_corrections: 8,
            max_back: default_max_back(),
        }
    }

    fn check(&self) -> Result<(), ContinuationError> {
        let bad = |name: &str, value: f64, reason: &str| {
            Err(ContinuationError::InvalidRequest {
                name: name.into(),
                value: value.to_string(),
                reason: reason.into(),
            })
        };
        if !(self.from.is_finite() && self.from > 0.0) {
            return bad("from", self.from, "the first speed must be positive and finite");
        }
        if !(self.to.is_finite() && self.to > 0.0 && self.to != self.from) {
            return bad("to", self.to, "the last speed must be positive, finite and differ from the first");
        }
        if !(self.step.is_finite() && self.step > 0.0 && self.step <= (self.to - self.from).abs()) {
            return bad("step", self.step, "must be positive and at most the speed range");
        }
        if !(self.min_step > 0.0 && self.min_step <= 1.0 && self.max_step >= 1.0 && self.max_step.is_finite())
        {
            return bad("step bounds", self.min_step, "need 0 < min_step ≤ 1 ≤ max_step");
        }
        if !(self.max_back.is_finite() && self.max_back > 0.0) {
            return bad("max_back", self.max_back, "must be positive and finite (nominal steps)");
        }
        if self.max_points < 2 || self.max_corrections == 0 {
            return bad("max_points", self.max_points as f64, "need at least 2 points and 1 correction");
        }
        Ok(())
    }
}

/// Errors of a continuation run.
#[derive(Debug, thiserror::Error)]
pub enum ContinuationError {
    /// The periodic solver failed at the start.
    #[error(transparent)]
    Periodic(#[from] PeriodicError),
    /// A request that cannot be met.
    #[error("{name} = {value}: {reason}")]
    InvalidRequest {
        /// Name.
        name: String,
        /// Value.
        value: String,
        /// What is allowed.
        reason: String,
    },
}

/// One point of a branch.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BranchPoint {
    /// The periodic state (speed, multipliers, work).
    pub orbit: PeriodicOrbit,
    /// All Floquet multipliers inside the unit circle.
    pub stable: bool,
    /// Segment of the branch between folds and gaps: 0 up to the first, 1 to the
    /// second, …
    pub segment: usize,
    /// dω/ds along the branch's tangent [rad/s per unit arclength]: its sign
    /// says whether the branch runs towards `to` (positive) or back.
    pub speed_slope: f64,
    /// The first point after a gap ([`Branch::gaps`]): not joined to the point before.
    #[serde(default)]
    pub after_gap: bool,
}

/// What happens at a bifurcation point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BifurcationKind {
    /// A real multiplier crosses +1; the branch turns back in speed (the
    /// jump of a sweep).
    Fold,
    /// A real multiplier crosses −1; a branch of twice the period starts.
    PeriodDoubling,
}

/// A located bifurcation point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bifurcation {
    /// Kind.
    pub kind: BifurcationKind,
    /// Speed [rad/s] (cubic Hermite interpolation of the speed along the
    /// arclength for a fold; linear interpolation of μ + 1 for a period doubling).
    pub speed: f64,
    /// Indices of the two branch points that bracket it.
    pub between: (usize, usize),
    /// The real multiplier nearest the crossing value at those two points
    /// (NaN at a point with no real multiplier: a fold at a grazing corner,
    /// where no multiplier passes +1).
    pub multipliers: (f64, f64),
}

/// A branch of periodic states.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Branch {
    /// The points in the order continued.
    pub points: Vec<BranchPoint>,
    /// Folds and period doublings, in the order met.
    pub bifurcations: Vec<Bifurcation>,
    /// Stretches not continued (leaps over non-smooth points, restarts), in the order met.
    #[serde(default)]
    pub gaps: Vec<Gap>,
    /// Why the run ended: "reached the last speed", or the reason it stopped early.
    pub ended: String,
    /// Work of the whole run.
    pub work: Work,
    /// Flows over one period integrated in the whole run.
    pub flows: usize,
    /// What one unit of each component of the points' unknowns z is in SI
    /// units ([`PeriodicProblem::unknown_scales`]; empty where not known).
    #[serde(default)]
    pub scales: Vec<f64>,
}

fn add(work: &mut Work, w: &Work) {
    work.steps += w.steps;
    work.rejected_steps += w.rejected_steps;
    work.rhs_evaluations += w.rhs_evaluations;
    work.events_located += w.events_located;
}

/// The bordered matrix [[M − I, ∂G/∂λ]; cᵀ] (column-major, size m + 1).
fn bordered(lin: &Linearization, unit: f64, c: &[f64]) -> Vec<f64> {
    let m = lin.dim;
    let k = m + 1;
    let mut a = vec![0.0; k * k];
    for j in 0..m {
        for i in 0..m {
            a[i + k * j] = lin.monodromy[i + m * j] - if i == j { 1.0 } else { 0.0 };
        }
    }
    for i in 0..m {
        a[i + k * m] = lin.speed_derivative[i] * unit;
    }
    for (j, cj) in c.iter().enumerate() {
        a[m + k * j] = *cj;
    }
    a
}

/// The unit tangent of the branch at a point, oriented along `previous`.
fn tangent(lin: &Linearization, unit: f64, previous: &[f64]) -> Vec<f64> {
    let k = lin.dim + 1;
    let a = bordered(lin, unit, previous);
    let mut rhs = vec![0.0; k];
    rhs[k - 1] = 1.0;
    let t = solve_dense(&a, k, &rhs);
    let norm = t.iter().map(|x| x * x).sum::<f64>().sqrt();
    let sign = if t.iter().zip(previous).map(|(a, b)| a * b).sum::<f64>() < 0.0 { -1.0 } else { 1.0 };
    t.iter().map(|x| sign * x / norm).collect()
}

/// The point of a cubic Hermite curve on [0, h] (values y0, y1, slopes d0,
/// d1) where its slope vanishes, and the value there; `None` without such a point.
fn hermite_extremum(h: f64, y0: f64, y1: f64, d0: f64, d1: f64) -> Option<f64> {
    // p(σ) = y0 + d0 σ + a σ² + b σ³.
    let a = (3.0 * (y1 - y0) / h - 2.0 * d0 - d1) / h;
    let b = (d0 + d1 - 2.0 * (y1 - y0) / h) / (h * h);
    let roots: Vec<f64> = if b.abs() < 1e-14 * (a.abs() + d0.abs()) / h {
        if a == 0.0 {
            vec![]
        } else {
            vec![-d0 / (2.0 * a)]
        }
    } else {
        let disc = 4.0 * a * a - 12.0 * b * d0;
        if disc < 0.0 {
            vec![]
        } else {
            vec![(-2.0 * a + disc.sqrt()) / (6.0 * b), (-2.0 * a - disc.sqrt()) / (6.0 * b)]
        }
    };
    roots
        .into_iter()
        .filter(|s| (0.0..=h).contains(s))
        .map(|s| y0 + d0 * s + a * s * s + b * s * s * s)
        .next()
}

/// The most negative real multiplier (or 0 when none is real and negative).
fn most_negative_real(orbit: &PeriodicOrbit) -> f64 {
    orbit.multipliers.iter().filter(|m| m.is_real() && m.re < 0.0).map(|m| m.re).fold(0.0, f64::min)
}

/// The chord-Newton corrector of one continuation step: from `predicted`,
/// with the bordered matrix `chord` and the constraint row `constraint`;
/// the corrected point and the corrections it took, or `None`.
struct Corrector<'a> {
    unit: f64,
    tol: f64,
    max_corrections: usize,
    work: &'a mut Work,
    flows: &'a mut usize,
}

impl Corrector<'_> {
    fn correct(
        &mut self,
        problem: &mut PeriodicProblem,
        chord: &[f64],
        constraint: &[f64],
        predicted: &[f64],
    ) -> Option<(Vec<f64>, usize)> {
        let m = predicted.len() - 1;
        let k = m + 1;
        let mut chord = chord.to_vec();
        let mut x = predicted.to_vec();
        let mut previous_norm = f64::INFINITY;
        let mut last: Option<(Vec<f64>, Vec<f64>)> = None;
        for iteration in 1..=self.max_corrections {
            let g = problem.residual(x[m] * self.unit, &x[..m], self.work).ok()?;
            *self.flows += 1;
            let norm = max_abs(&g);
            if newton_converged(norm, &x[..m], previous_norm, self.tol) {
                return Some((x, iteration - 1));
            }
            if (norm >= previous_norm || norm.is_nan()) && iteration > 2 {
                return None;
            }
            previous_norm = norm;
            // Broyden's update of the residual rows with the change the last
            // correction made: ∂G/∂λ turns quickly with speed where the free
            // vibration's phase at the period's start does (low speeds), and
            // the chord of the last point alone then converges slowly
            // (contraction about 0.4 per correction at 600 rpm).
            if let Some((dx, g_before)) = &last {
                let dd: f64 = dx.iter().map(|v| v * v).sum();
                if dd > 0.0 {
                    for i in 0..m {
                        let predicted_change: f64 = (0..k).map(|j| chord[i + k * j] * dx[j]).sum();
                        let miss = (g[i] - g_before[i]) - predicted_change;
                        for j in 0..k {
                            chord[i + k * j] += miss * dx[j] / dd;
                        }
                    }
                }
            }
            let mut rhs: Vec<f64> = g.iter().map(|v| -v).collect();
            rhs.push(
                -constraint.iter().zip(x.iter().zip(predicted)).map(|(c, (a, b))| c * (a - b)).sum::<f64>(),
            );
            let dx = solve_dense(&chord, k, &rhs);
            if dx.iter().any(|v| !v.is_finite()) {
                return None;
            }
            x.iter_mut().zip(&dx).for_each(|(a, d)| *a += d);
            last = Some((dx, g));
        }
        None
    }

    /// The chord matrix at `at` (the linearization there), or `fallback`'s
    /// when the linearization fails.
    fn chord_at(
        &mut self,
        problem: &mut PeriodicProblem,
        at: &[f64],
        fallback: &Linearization,
        constraint: &[f64],
    ) -> Vec<f64> {
        let m = at.len() - 1;
        match problem.linearize(at[m] * self.unit, &at[..m], self.work) {
            Ok(l) => {
                *self.flows += problem.linearization_flows();
                bordered(&l, self.unit, constraint)
            }
            Err(_) => bordered(fallback, self.unit, constraint),
        }
    }
}

/// How a continuation run got past a point where the corrector failed at
/// the smallest step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GapKind {
    /// A step of one or two nominal steps along the tangent, corrected with
    /// the linearization at its far end: the branch goes on beyond a
    /// non-smooth point (a contact that starts or ends with zero rate,
    /// where the period map has no derivative).
    Leap,
    /// Marching at one nominal step beyond the furthest speed reached, from
    /// the state there, then Newton: the branch is left, as a marching sweep
    /// leaves it at a fold, and a new one is followed.
    Restart,
}

/// A stretch of a run that was not continued.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gap {
    /// How the run got past it.
    pub kind: GapKind,
    /// Speed of the last point before it [rad/s].
    pub from: f64,
    /// Speed of the first point after it [rad/s].
    pub to: f64,
    /// Index of the first point after it.
    pub point: usize,
}

/// Periods marched at most before Newton when a run restarts (one input
/// revolution of the example, as a marching sweep's run-in).
const RESTART_PERIODS: usize = 34;

/// Speeds, one nominal step apart, at which a restart is tried before the run ends.
const RESTART_TRIES: usize = 4;

/// The state marching reaches at `omega` from `z`: periods until one changes
/// the state by at most 1e-3 of the state scales, at most [`RESTART_PERIODS`].
pub(crate) fn march(
    problem: &mut PeriodicProblem,
    omega: f64,
    z: &[f64],
    work: &mut Work,
    flows: &mut usize,
) -> Option<Vec<f64>> {
    let mut z = z.to_vec();
    for _ in 0..RESTART_PERIODS {
        let r = problem.residual(omega, &z, work).ok()?;
        *flows += 1;
        z.iter_mut().zip(&r).for_each(|(a, b)| *a += b);
        if max_abs(&r) <= 1e-3 * max_abs(&z).max(1.0) {
            break;
        }
    }
    Some(z)
}

/// What a continuation run follows a branch with ([`follow_branch`]): the
/// shooting problem ([`PeriodicProblem`]) or the harmonic balance
/// ([`BalanceBranch`]). The run's unknowns are Y = (x, λ): the solver's own x
/// (the relative state at the period's start, or Fourier coefficients) and
/// the speed in nominal steps λ = ω / Δω, last.
pub trait BranchSolver {
    /// The linearization at an accepted point: its tangent and the first
    /// chord of the next step's corrector.
    type Linear;

    /// What one unit of each component of the orbits' z is in SI units.
    fn unknown_scales(&self) -> Vec<f64>;

    /// The first point at `omega` [rad/s] (λ in units of `unit`): its orbit
    /// (with the work of the whole solve), its x and its linearization.
    fn start(
        &mut self,
        omega: f64,
        unit: f64,
    ) -> Result<(PeriodicOrbit, Vec<f64>, Self::Linear), PeriodicError>;

    /// The unit tangent of the branch at `linear`'s point, oriented along `orient`.
    fn tangent(&mut self, linear: &Self::Linear, unit: f64, orient: &[f64]) -> Vec<f64>;

    /// Newton's corrections from `predicted` on G = 0 and cᵀ(Y − `predicted`) = 0
    /// (c = `constraint`), on `linear` or, when `fresh`, on a linearization
    /// at `predicted`; `limits` are the nominal step and the most corrections,
    /// `counts` the step's work and flows. The corrected Y and the
    /// corrections it took, or `None`.
    fn correct(
        &mut self,
        linear: &Self::Linear,
        fresh: bool,
        constraint: &[f64],
        predicted: &[f64],
        limits: (f64, usize),
        counts: (&mut Work, &mut usize),
    ) -> Option<(Vec<f64>, usize)>;

    /// The x of a periodic state at `omega` [rad/s] reached by marching from
    /// `from` (the x of the furthest point), then Newton; `None` where there is none.
    fn restart(&mut self, omega: f64, from: &[f64], work: &mut Work, flows: &mut usize) -> Option<Vec<f64>>;

    /// The orbit at the corrected `point` = (x, ω [rad/s], the nominal step
    /// [rad/s]) with its multipliers (`counts`: the step's work and flows, the
    /// linearization's added), and its linearization.
    fn accept(
        &mut self,
        point: (&[f64], f64, f64),
        corrections: usize,
        counts: (&mut Work, &mut usize),
    ) -> Result<(PeriodicOrbit, Self::Linear), PeriodicError>;

    /// Whether steps clear of folds are corrected at their predicted speed
    /// ([`FIXED_SPEED_SLOPE`]): for a solver whose every new speed costs a
    /// build (the condensed balance's linear part), so that a step's
    /// corrections share one. Shooting and the full balance keep the
    /// pseudo-arclength corrector everywhere.
    fn fixed_speed_steps(&self) -> bool {
        false
    }

    /// Brings `vectors` (each Y, λ last) to the unknowns the solver takes
    /// for a step whose points lie between the speeds `speeds` = (low, high)
    /// [rad/s]; whether they changed (the last linearization then no longer
    /// fits them), or why the solver cannot take those speeds (the run ends
    /// there).
    fn fit(&mut self, _speeds: (f64, f64), _vectors: &mut [&mut Vec<f64>]) -> Result<bool, PeriodicError> {
        Ok(false)
    }

    /// The x the last [`Self::accept`] took its point at, where that is not the corrected
    /// x it was given (the balance solved the point again at the harmonics its spectrum
    /// asked); `None` where the point is the corrected x. The run then brings its vectors
    /// to the new unknowns ([`Self::fit`] at the point's speed).
    fn resolved(&mut self) -> Option<Vec<f64>> {
        None
    }
}

impl BranchSolver for PeriodicProblem {
    type Linear = Linearization;

    fn unknown_scales(&self) -> Vec<f64> {
        PeriodicProblem::unknown_scales(self)
    }

    fn start(
        &mut self,
        omega: f64,
        _unit: f64,
    ) -> Result<(PeriodicOrbit, Vec<f64>, Linearization), PeriodicError> {
        let (first, lin) = self.solve_linearized(omega, None)?;
        let z = first.z.clone();
        Ok((first, z, lin))
    }

    fn tangent(&mut self, linear: &Linearization, unit: f64, orient: &[f64]) -> Vec<f64> {
        tangent(linear, unit, orient)
    }

    fn correct(
        &mut self,
        linear: &Linearization,
        fresh: bool,
        constraint: &[f64],
        predicted: &[f64],
        (unit, max_corrections): (f64, usize),
        (work, flows): (&mut Work, &mut usize),
    ) -> Option<(Vec<f64>, usize)> {
        let tol = self.settings().newton_tolerance;
        let mut corrector = Corrector { unit, tol, max_corrections, work, flows };
        // After a failed correction the chord matrix is taken at the
        // predicted point instead of the last accepted one (a contact that
        // starts or ends between the two changes the linearization).
        let chord = if fresh {
            corrector.chord_at(self, predicted, linear, constraint)
        } else {
            bordered(linear, unit, constraint)
        };
        corrector.correct(self, &chord, constraint, predicted)
    }

    fn restart(&mut self, omega: f64, from: &[f64], work: &mut Work, flows: &mut usize) -> Option<Vec<f64>> {
        let z = march(self, omega, from, work, flows)?;
        let orbit = self.solve(omega, Some(&z)).ok()?;
        add(work, &orbit.work);
        *flows += orbit.flows;
        Some(orbit.z)
    }

    fn accept(
        &mut self,
        (z, omega, _): (&[f64], f64, f64),
        corrections: usize,
        (work, flows): (&mut Work, &mut usize),
    ) -> Result<(PeriodicOrbit, Linearization), PeriodicError> {
        let lin = self.linearize(omega, z, work)?;
        *flows += self.linearization_flows();
        let multipliers = floquet_multipliers(&lin.monodromy, z.len())?;
        let orbit = PeriodicOrbit {
            speed: omega,
            period: self.period(omega),
            cycles: self.cycles(),
            z: z.to_vec(),
            residual: max_abs(&lin.residual),
            newton_iterations: corrections,
            multipliers,
            flows: *flows,
            work: *work,
        };
        Ok((orbit, lin))
    }
}

/// The harmonic balance as a [`BranchSolver`]: x are the Fourier
/// coefficients at the number of harmonics the rule gives at the lowest
/// speed each step can reach ([`HarmonicBalance::arc_fit`]: the last point's
/// where the branch rises in speed, one nominal step below it where it
/// falls; so a point keeps at least the rule's at its own speed, and at most
/// the rule's change over one step more), corrected by Newton on the bordered
/// balance (`HarmonicBalance::arc_correct`), each point's multipliers from
/// the balance's own monodromy over the settings' N intervals.
pub struct BalanceBranch<'a> {
    balance: &'a mut HarmonicBalance,
    /// The balance's orbits of the points accepted, in the order of the
    /// branch's points (for their forces: [`HarmonicBalance::steady_state`]).
    pub orbits: Vec<HarmonicOrbit>,
}

impl<'a> BalanceBranch<'a> {
    /// Continuation on `balance`.
    pub fn new(balance: &'a mut HarmonicBalance) -> Self {
        Self { balance, orbits: Vec::new() }
    }

    /// The branch point's orbit at `x` and `omega` with its multipliers, kept in [`Self::orbits`].
    fn orbit(
        &mut self,
        omega: f64,
        x: &[f64],
        linear: &ArcLinear,
        corrections: usize,
        arc: &ArcWork,
        (work, flows): (&mut Work, &mut usize),
    ) -> Result<PeriodicOrbit, PeriodicError> {
        let orbit = self.balance.arc_orbit(omega, x, linear, corrections, arc);
        let intervals = self.balance.settings().samples;
        let point =
            balance_point(self.balance, &orbit, intervals, (corrections, linear.residual()), (work, flows))?;
        self.orbits.push(orbit);
        Ok(point)
    }
}

/// A branch point of the balance's `orbit` (its speed the orbit's) with its Floquet
/// multipliers on `intervals` ([`HarmonicBalance::floquet_multipliers`]): its state at t = 0
/// as the shooting problem's unknowns, the `corrections` that found it and its `residual`,
/// the step's `work` and `flows`.
pub(crate) fn balance_point(
    balance: &mut HarmonicBalance,
    orbit: &HarmonicOrbit,
    intervals: usize,
    (corrections, residual): (usize, f64),
    (work, flows): (&mut Work, &mut usize),
) -> Result<PeriodicOrbit, PeriodicError> {
    let multipliers = balance.floquet_multipliers(orbit, intervals)?;
    let omega = orbit.speed;
    Ok(PeriodicOrbit {
        speed: omega,
        period: balance.problem().period(omega),
        cycles: balance.problem().cycles(),
        z: balance.initial_unknowns(orbit),
        residual,
        newton_iterations: corrections,
        multipliers,
        flows: *flows,
        work: *work,
    })
}

/// `arc`'s force evaluations and corrections into `work`.
fn add_arc(work: &mut Work, arc: &ArcWork) {
    work.rhs_evaluations += arc.evaluations;
    work.newton_iterations += arc.corrections as u64;
}

impl BranchSolver for BalanceBranch<'_> {
    type Linear = ArcLinear;

    fn unknown_scales(&self) -> Vec<f64> {
        self.balance.problem().unknown_scales()
    }

    fn start(
        &mut self,
        omega: f64,
        unit: f64,
    ) -> Result<(PeriodicOrbit, Vec<f64>, ArcLinear), PeriodicError> {
        self.balance.arc_fit(omega)?;
        let solved = self.balance.solve(omega, None)?;
        let mut work = Work {
            steps: solved.march_steps,
            rhs_evaluations: solved.force_evaluations,
            newton_iterations: solved.iterations as u64,
            ..Work::default()
        };
        let mut arc = ArcWork::default();
        let x = solved.coefficients;
        let linear = self.balance.arc_linearize(omega, &x, unit, &mut arc)?;
        add_arc(&mut work, &arc);
        let orbit = self.orbit(omega, &x, &linear, solved.iterations, &arc, (&mut work, &mut 0))?;
        Ok((orbit, x, linear))
    }

    fn tangent(&mut self, linear: &ArcLinear, _unit: f64, orient: &[f64]) -> Vec<f64> {
        self.balance.arc_tangent(linear, orient)
    }

    fn correct(
        &mut self,
        linear: &ArcLinear,
        fresh: bool,
        constraint: &[f64],
        predicted: &[f64],
        limits: (f64, usize),
        (work, _): (&mut Work, &mut usize),
    ) -> Option<(Vec<f64>, usize)> {
        let mut arc = ArcWork::default();
        let found = self.balance.arc_correct(linear, fresh, constraint, predicted, limits, &mut arc);
        add_arc(work, &arc);
        found
    }

    fn restart(&mut self, omega: f64, from: &[f64], work: &mut Work, flows: &mut usize) -> Option<Vec<f64>> {
        let z = self.balance.state_of(omega, from);
        let z = march(self.balance.problem_mut(), omega, &z, work, flows)?;
        self.balance.arc_fit(omega).ok()?;
        let orbit = self.balance.solve_from_state(omega, &z).ok()?;
        work.rhs_evaluations += orbit.force_evaluations;
        work.steps += orbit.march_steps;
        work.newton_iterations += orbit.iterations as u64;
        Some(orbit.coefficients)
    }

    fn accept(
        &mut self,
        (x, omega, unit): (&[f64], f64, f64),
        corrections: usize,
        (work, flows): (&mut Work, &mut usize),
    ) -> Result<(PeriodicOrbit, ArcLinear), PeriodicError> {
        let mut arc = ArcWork::default();
        let linear = self.balance.arc_linearize(omega, x, unit, &mut arc)?;
        add_arc(work, &arc);
        let orbit = self.orbit(omega, x, &linear, corrections, &arc, (work, flows))?;
        Ok((orbit, linear))
    }

    /// The rule's harmonics at the lower speed, the most the step's points
    /// ask (the rule's H falls with the speed), so that no point keeps fewer
    /// than the rule at its own; an error where they would exceed what the
    /// balance takes ([`crate::dynamics::periodic::MAX_UNKNOWNS`]). Every
    /// vector of another length (the run's furthest point, after a restart
    /// took other harmonics) is brought to them too.
    fn fit(&mut self, (low, _): (f64, f64), vectors: &mut [&mut Vec<f64>]) -> Result<bool, PeriodicError> {
        let changed = self.balance.arc_fit(low)?;
        let unknowns = self.balance.unknowns();
        for v in vectors.iter_mut().filter(|v| v.len() != unknowns + 1) {
            **v = refit(v, unknowns, true);
        }
        Ok(changed)
    }
}

/// Follows the branch of periodic states of `problem` from `settings.from`
/// to `settings.to` by pseudo-arclength continuation; `progress` sees every
/// point as it is accepted.
///
/// A step that cannot be corrected even at the smallest arclength step is
/// a non-smooth point of the period map (a contact that starts or ends
/// with zero rate) or the end of the branch. The run then leaps one and
/// then two nominal steps along the tangent. Failing that, and whenever the
/// branch turns back past the first speed, runs back more than
/// [`ContinuationSettings::max_back`] nominal steps below the furthest speed
/// reached, travels twice that without reaching further, or meets again a
/// fold it passed (within a tenth of a nominal step: a closed loop, or back
/// and forth between two corners), it restarts by marching at one nominal
/// step beyond the furthest speed reached (as a marching sweep jumps at a
/// fold), or up to three steps further where marching finds no periodic
/// state. Each is recorded in [`Branch::gaps`]; the points after it start a
/// new segment. The run ends early, keeping the points found, only when the
/// restarts fail too (the reason is in [`Branch::ended`]).
pub fn continue_branch(
    problem: &mut PeriodicProblem,
    settings: &ContinuationSettings,
    progress: impl FnMut(&BranchPoint),
) -> Result<Branch, ContinuationError> {
    follow_branch(problem, settings, progress)
}

/// [`continue_branch`] with any [`BranchSolver`]: the shooting problem, or
/// the harmonic balance ([`BalanceBranch`]).
pub fn follow_branch<S: BranchSolver>(
    solver: &mut S,
    settings: &ContinuationSettings,
    progress: impl FnMut(&BranchPoint),
) -> Result<Branch, ContinuationError> {
    follow(solver, settings, None, progress)
}

/// Two periodic states at one speed whose states at the period's start
/// differ by at most this (in one problem's state scales, of the larger's
/// largest component, at least 1) are one orbit: a tenth of the accuracy
/// rule's E_h ≤ 1e-3, far below the distance between two branches at one
/// speed.
pub const JOIN_TOLERANCE: f64 = 1e-4;

/// For a solver that asks for it ([`BranchSolver::fixed_speed_steps`]), a
/// step is corrected at its predicted speed (the arclength row replaced by
/// the speed's) where the branch's tangent changes the speed at least this
/// much per unit of arclength: clear of folds, where a step at fixed speed
/// cannot be corrected. Elsewhere the corrections move along the
/// pseudo-arclength plane. At a fixed speed every correction, and the
/// point's linearization, take the linear part of one speed: the condensed
/// balance builds it once for them instead of once per correction. A step
/// is aimed at a stable point of the other run ([`follow_joining`]) only
/// where the slope is this steep too, and the aimed step is at least half
/// the planned one.
pub const FIXED_SPEED_SLOPE: f64 = 0.5;

/// ... and only from a point whose state lies within this share of the
/// other run's, interpolated between its two points that bracket the speed
/// (distinct branches at one speed lie 0.15 to 5 of the state's largest
/// component apart on the example): elsewhere the steps are the plain run's.
const JOIN_NEAR: f64 = 0.05;

/// `other`'s state `z` (in its units) in the units `scales` of another
/// problem of the same model (the two may scale velocities differently).
fn rescaled(other: &Branch, z: &[f64], scales: &[f64]) -> Option<Vec<f64>> {
    (other.scales.len() == z.len() && scales.len() == z.len())
        .then(|| z.iter().zip(&other.scales).zip(scales).map(|((v, a), b)| v * a / b).collect())
}

/// The largest difference of two states in one problem's units, over the
/// larger of their largest components and 1.
fn state_distance(a: &[f64], b: &[f64]) -> f64 {
    let size = a.iter().chain(b).fold(1.0_f64, |m, v| m.max(v.abs()));
    a.iter().zip(b).fold(0.0_f64, |m, (p, q)| m.max((p - q).abs())) / size
}

/// The points of `other` before its first gap: the stretch it followed
/// without a break from its first speed, which is where a run in the other
/// direction ends. A run that meets this stretch would follow it to its
/// end; beyond a gap (a restart that landed on a branch by marching) the
/// branch below the landing point was never followed.
fn unbroken(other: &Branch) -> &[BranchPoint] {
    let end = other.gaps.iter().map(|g| g.point).min().unwrap_or(other.points.len());
    &other.points[..end.min(other.points.len())]
}

/// Whether `z` (in units `scales`) at `speed` lies within [`JOIN_NEAR`] of
/// `other`'s unbroken stretch ([`unbroken`]): of its state interpolated
/// between two successive points that bracket the speed.
fn near_branch(other: &Branch, speed: f64, z: &[f64], scales: &[f64]) -> bool {
    unbroken(other).windows(2).any(|w| {
        let (a, b) = (&w[0], &w[1]);
        let (sa, sb) = (a.orbit.speed, b.orbit.speed);
        let share = (speed - sa) / (sb - sa);
        if sa == sb || !(0.0..=1.0).contains(&share) {
            return false;
        }
        let (Some(za), Some(zb)) = (rescaled(other, &a.orbit.z, scales), rescaled(other, &b.orbit.z, scales))
        else {
            return false;
        };
        let at: Vec<f64> = za.iter().zip(&zb).map(|(p, q)| p + share * (q - p)).collect();
        state_distance(&at, z) <= JOIN_NEAR
    })
}

/// [`follow_branch`], ending where the run meets `other`'s branch (a run
/// of the same model from this run's last speed towards its first, its
/// [`Branch::scales`] known) on the stretch `other` followed without a
/// break from its first speed: once the run's state lies near that
/// stretch (within 5 % of its state), a step within which one of its stable points
/// lies, on a stretch of this run clear of folds, lands at that point's
/// speed, and when the orbit found there is that point's (within
/// [`JOIN_TOLERANCE`]) the rest of this run would retrace `other` back to
/// its first speed: the run ends with that point (its [`Branch::ended`]
/// says where). A run that never meets `other` is the branch
/// [`follow_branch`] gives but for where some steps land.
pub fn follow_joining<S: BranchSolver>(
    solver: &mut S,
    settings: &ContinuationSettings,
    other: &Branch,
    progress: impl FnMut(&BranchPoint),
) -> Result<Branch, ContinuationError> {
    follow(solver, settings, Some(other), progress)
}

/// What changes along a branch at a point where a marching sweep can jump.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EventKind {
    /// The branch turns back in speed ([`BifurcationKind::Fold`], corners included).
    Fold,
    /// A real multiplier passes −1.
    PeriodDoubling,
    /// The branch turns stable (towards `to`).
    TurnsStable,
    /// The branch turns unstable (towards `to`).
    TurnsUnstable,
}

/// A fold, period doubling or change of stability of a branch.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BranchEvent {
    /// Speed [rad/s]: a bifurcation's located speed; for a change of
    /// stability the middle of the two points either side.
    pub speed: f64,
    /// What happens.
    pub kind: EventKind,
}

/// The folds, period doublings and changes of stability of `branch`, in
/// the order met (a change of stability across a gap is none).
pub fn branch_events(branch: &Branch) -> Vec<BranchEvent> {
    let mut events: Vec<(usize, BranchEvent)> = branch
        .bifurcations
        .iter()
        .map(|b| {
            let kind = match b.kind {
                BifurcationKind::Fold => EventKind::Fold,
                BifurcationKind::PeriodDoubling => EventKind::PeriodDoubling,
            };
            (b.between.1, BranchEvent { speed: b.speed, kind })
        })
        .collect();
    for (i, w) in branch.points.windows(2).enumerate() {
        if w[0].stable != w[1].stable && !w[1].after_gap {
            let kind = if w[1].stable { EventKind::TurnsStable } else { EventKind::TurnsUnstable };
            events.push((i + 1, BranchEvent { speed: 0.5 * (w[0].orbit.speed + w[1].orbit.speed), kind }));
        }
    }
    events.sort_by_key(|(i, _)| *i);
    events.into_iter().map(|(_, e)| e).collect()
}

/// A jump of a marching sweep: a measure changing by more than a ratio
/// from one speed to the next.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Jump {
    /// Speed before the jump, in the sweep's order [rad/s].
    pub from: f64,
    /// Speed after it [rad/s].
    pub to: f64,
    /// The measure before.
    pub before: f64,
    /// The measure after.
    pub after: f64,
}

/// The jumps of a sweep: successive points (`speeds` in the sweep's order)
/// whose `values` differ by a factor above `ratio` (> 1) either way.
pub fn marching_jumps(speeds: &[f64], values: &[f64], ratio: f64) -> Vec<Jump> {
    speeds
        .windows(2)
        .zip(values.windows(2))
        .filter(|(_, v)| v[0] > 0.0 && v[1] > 0.0 && (v[1] / v[0] > ratio || v[0] / v[1] > ratio))
        .map(|(s, v)| Jump { from: s[0], to: s[1], before: v[0], after: v[1] })
        .collect()
}

/// The event nearest a jump and its distance [rad/s] from the jump's
/// speed step (0 inside it), or `None` without events; of events at the
/// same distance a fold first, then a period doubling, then a change of
/// stability.
pub fn nearest_event(jump: &Jump, events: &[BranchEvent]) -> Option<(BranchEvent, f64)> {
    let (lo, hi) = (jump.from.min(jump.to), jump.from.max(jump.to));
    let rank = |k: EventKind| match k {
        EventKind::Fold => 0,
        EventKind::PeriodDoubling => 1,
        EventKind::TurnsStable | EventKind::TurnsUnstable => 2,
    };
    let distance = |speed: f64| (lo - speed).max(speed - hi).max(0.0);
    events
        .iter()
        .map(|e| (*e, distance(e.speed)))
        .min_by(|a, b| a.1.total_cmp(&b.1).then(rank(a.0.kind).cmp(&rank(b.0.kind))))
}

/// A point of a continuation run's curve of one measure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurvePoint {
    /// Speed [rad/s].
    pub speed: f64,
    /// The measure.
    pub value: f64,
    /// Whether the point is stable.
    pub stable: bool,
    /// Whether it is the first point after a gap.
    pub after_gap: bool,
}

/// Whether both ends of a marching step lie on one stable stretch of a
/// continued curve (stable points joined without a gap), each within
/// `tolerance` (relative) of the curve interpolated linearly at its speed:
/// then the step is a steep flank of one branch, not a jump between two.
pub fn on_one_stable_branch(curve: &[CurvePoint], jump: &Jump, tolerance: f64) -> bool {
    let mut start = 0;
    while start < curve.len() {
        // The stable stretch from `start`.
        if !curve[start].stable {
            start += 1;
            continue;
        }
        let mut end = start + 1;
        while end < curve.len() && curve[end].stable && !curve[end].after_gap {
            end += 1;
        }
        let stretch = &curve[start..end];
        let at = |speed: f64| -> Option<f64> {
            stretch.windows(2).find_map(|w| {
                let (lo, hi) = (w[0].speed.min(w[1].speed), w[0].speed.max(w[1].speed));
                (speed >= lo && speed <= hi && hi > lo).then(|| {
                    w[0].value + (w[1].value - w[0].value) * (speed - w[0].speed) / (w[1].speed - w[0].speed)
                })
            })
        };
        let near =
            |speed: f64, value: f64| at(speed).is_some_and(|c| (c - value).abs() <= tolerance * value.abs());
        if near(jump.from, jump.before) && near(jump.to, jump.after) {
            return true;
        }
        start = end;
    }
    false
}

/// A branch point with only a speed [rad/s], a stability and a gap before
/// it, for the tests of what reads branches (here and in the reports).
#[cfg(test)]
pub(crate) fn test_point(speed: f64, stable: bool, after_gap: bool) -> BranchPoint {
    BranchPoint { orbit: PeriodicOrbit::bare(speed, 1e-3), stable, segment: 0, speed_slope: 1.0, after_gap }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_jump_is_a_change_beyond_the_ratio_and_meets_the_nearest_event() {
        let speeds = [100.0, 150.0, 200.0, 250.0];
        let values = [10.0, 11.0, 15.0, 5.0];
        let jumps = marching_jumps(&speeds, &values, 1.15);
        // 10 → 11 is 1.10: no jump; 11 → 15 is 1.36 and 15 → 5 is 3 (downwards).
        assert_eq!(jumps.len(), 2);
        assert_eq!((jumps[0].from, jumps[0].to, jumps[1].before, jumps[1].after), (150.0, 200.0, 15.0, 5.0));
        let events = [
            BranchEvent { speed: 170.0, kind: EventKind::Fold },
            BranchEvent { speed: 262.0, kind: EventKind::TurnsStable },
        ];
        let (e, d) = nearest_event(&jumps[0], &events).unwrap();
        assert_eq!((e.kind, d), (EventKind::Fold, 0.0));
        // Of two events inside the step the fold, whichever comes first.
        let both = [BranchEvent { speed: 160.0, kind: EventKind::TurnsUnstable }, events[0]];
        assert_eq!(nearest_event(&jumps[0], &both).unwrap().0.kind, EventKind::Fold);
        let (e, d) = nearest_event(&jumps[1], &events).unwrap();
        assert_eq!(e.kind, EventKind::TurnsStable);
        assert!((d - 12.0).abs() < 1e-12);
        assert!(nearest_event(&jumps[0], &[]).is_none());
    }

    use super::test_point as point;

    #[test]
    fn the_events_of_a_branch_are_its_bifurcations_and_changes_of_stability_in_order() {
        let branch = Branch {
            points: vec![
                point(1.0, true, false),
                point(2.0, false, false),
                point(3.0, false, false),
                point(5.0, true, true),
                point(6.0, true, false),
                point(7.0, false, false),
            ],
            bifurcations: vec![Bifurcation {
                kind: BifurcationKind::Fold,
                speed: 2.5,
                between: (1, 2),
                multipliers: (0.9, 1.1),
            }],
            gaps: vec![],
            ended: String::new(),
            work: Work::default(),
            flows: 0,
            scales: Vec::new(),
        };
        let events = branch_events(&branch);
        let got: Vec<(f64, EventKind)> = events.iter().map(|e| (e.speed, e.kind)).collect();
        // The change from unstable to stable across the gap (3 → 5) is none.
        assert_eq!(
            got,
            vec![(1.5, EventKind::TurnsUnstable), (2.5, EventKind::Fold), (6.5, EventKind::TurnsUnstable)]
        );
    }

    #[test]
    fn a_steep_flank_of_one_stable_stretch_is_no_jump() {
        let c = |speed: f64, value: f64, stable: bool, after_gap: bool| CurvePoint {
            speed,
            value,
            stable,
            after_gap,
        };
        // Stable 100–300 rising steeply, unstable to 350, then after a gap stable from 400.
        let curve = [
            c(100.0, 10.0, true, false),
            c(200.0, 20.0, true, false),
            c(300.0, 40.0, true, false),
            c(350.0, 45.0, false, false),
            c(400.0, 5.0, true, true),
            c(500.0, 6.0, true, false),
        ];
        let jump = |from, to, before, after| Jump { from, to, before, after };
        // 150 → 250 on the flank: 15 and 30 on the curve.
        assert!(on_one_stable_branch(&curve, &jump(150.0, 250.0, 15.2, 29.5), 0.05));
        // The same step with the second value off the curve by 20 %.
        assert!(!on_one_stable_branch(&curve, &jump(150.0, 250.0, 15.0, 36.0), 0.05));
        // 300 → 450 crosses the unstable stretch and the gap: a jump.
        assert!(!on_one_stable_branch(&curve, &jump(300.0, 450.0, 40.0, 5.5), 0.05));
        // Down a stretch works as up.
        assert!(on_one_stable_branch(&curve, &jump(450.0, 400.0, 5.5, 5.0), 0.05));
    }

    #[test]
    fn a_join_looks_at_the_other_runs_stretch_before_its_first_gap_in_this_runs_units() {
        let mut other = Branch {
            points: vec![
                point(1.0, true, false),
                point(2.0, true, false),
                point(5.0, true, true),
                point(6.0, true, false),
            ],
            bifurcations: vec![],
            gaps: vec![Gap { kind: GapKind::Restart, from: 2.0, to: 5.0, point: 2 }],
            ended: String::new(),
            work: Work::default(),
            flows: 0,
            scales: vec![2.0, 10.0],
        };
        assert_eq!(unbroken(&other).len(), 2);
        other.gaps.clear();
        assert_eq!(unbroken(&other).len(), 4);
        // Its units (2, 10) in ours (1, 5): both components double.
        assert_eq!(rescaled(&other, &[1.0, 1.0], &[1.0, 5.0]), Some(vec![2.0, 2.0]));
        assert_eq!(rescaled(&other, &[1.0], &[1.0]), None);
        other.scales.clear();
        assert_eq!(rescaled(&other, &[1.0, 1.0], &[1.0, 5.0]), None);
        // Of the larger's largest component, at least 1.
        assert!((state_distance(&[0.0, 2.0], &[0.0, 2.5]) - 0.2).abs() < 1e-15);
        assert!((state_distance(&[0.1], &[0.3]) - 0.2).abs() < 1e-15);
    }

    #[test]
    fn hermite_extremum_of_a_parabola() {
        // y = 1 − (s − 0.3)² on [0, 1]: slopes 0.6 and −1.4; the top is 1 at s = 0.3.
        let y = |s: f64| 1.0 - (s - 0.3) * (s - 0.3);
        let top = hermite_extremum(1.0, y(0.0), y(1.0), 0.6, -1.4).unwrap();
        assert!((top - 1.0).abs() < 1e-12, "{top}");
        assert!(hermite_extremum(1.0, 0.0, 1.0, 1.0, 1.0).is_none());
    }
}
