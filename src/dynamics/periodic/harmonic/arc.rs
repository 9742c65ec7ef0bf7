//! The harmonic balance bordered by one linear equation in its coefficients
//! and the speed, for pseudo-arclength continuation (`analysis::continuation`,
//! docs/PERIODIC.md §3).
//!
//! The unknowns are Y = (x, λ): the coefficients x and the speed in units of
//! the continuation's nominal step, λ = ω / Δω. A linearization at a point
//! holds the balance's Jacobian J = ∂R/∂x there (dense LU or the operator
//! with its band, as a solve takes it), ∂R/∂λ by a forward difference of the
//! projected residual, and a = J⁻¹ ∂R/∂λ. The bordered system
//!
//! [J  ∂R/∂λ; cₓᵀ  c_λ] (δx, δλ) = (−R, g)
//!
//! is solved by block elimination on J: b = −J⁻¹R, δλ = (g − cₓᵀb) / (c_λ −
//! cₓᵀa), δx = b − δλ a; and the branch's tangent, the null vector of
//! [J ∂R/∂λ], is (−a, 1) normalized. Block elimination loses accuracy where J
//! itself is singular to working precision, at a fold exactly; the branch's
//! points lie off it by the arclength step. The corrections update the
//! bordered system's inverse by Broyden's formula between linearizations
//! ([`HarmonicBalance::arc_correct`]).

use super::jacobian::{newton_remainder, Newton};
use super::*;
use crate::dynamics::periodic::max_abs;

/// Relative change of the speed in the forward difference of ∂R/∂λ.
pub const SPEED_DIFFERENCE: f64 = 1e-6;

/// A corrector's iteration that lowers the residual by less than this factor
/// takes a fresh linearization at its point before the next. Measured on the
/// torsional example, κ = 0, 500 to 15 000 rpm at 50 rpm (docs/PERIODIC.md
/// §3): 0.25 took 13.2 to 14.1 s (492 points), 0.1 and 0.5 15.5 s each (511 and
/// 666 points; 0.1 stepped over the fold pair at 4110 / 4127 rpm).
pub const ARC_CHORD_CONTRACTION: f64 = 0.25;

/// The balance linearized at a point of a branch ([`HarmonicBalance::arc_linearize`]).
pub struct ArcLinear {
    /// The balance's Jacobian this linearization refers to (the balance keeps
    /// one; a later linearization replaces it).
    generation: u64,
    /// Harmonics H of the point.
    harmonics: usize,
    /// R at the point (switches projected).
    residual: Vec<f64>,
    /// a = J⁻¹ ∂R/∂λ.
    solved_derivative: Vec<f64>,
}

impl ArcLinear {
    /// Largest residual coefficient at the point.
    pub fn residual(&self) -> f64 {
        max_abs(&self.residual)
    }
}

/// The work of the bordered balance's calls: force evaluations, Jacobians and
/// GMRES products, added up.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ArcWork {
    /// Force evaluations.
    pub evaluations: u64,
    /// Jacobians assembled and factorised.
    pub factorizations: usize,
    /// Products with the Jacobian in GMRES.
    pub products: usize,
    /// Newton corrections.
    pub corrections: usize,
}

impl HarmonicBalance {
    /// The balance linearized at the coefficients `x` and speed `omega` [rad/s]
    /// with the switches projected, λ in units of `unit` [rad/s]. The
    /// crossings are the point's afterwards ([`Self::arc_orbit`]).
    pub fn arc_linearize(
        &mut self,
        omega: f64,
        x: &[f64],
        unit: f64,
        work: &mut ArcWork,
    ) -> Result<ArcLinear, PeriodicError> {
        if x.len() != self.unknowns() {
            return Err(PeriodicError::invalid(
                "harmonic-balance coefficients",
                x.len() as f64,
                "must hold m(2H + 1) values for the balance's H",
            ));
        }
        self.samples = self.settings.samples;
        let mut newton = Newton { jacobian: self.take_jacobian(x.len()), ..Newton::default() };
        let evaluated = self.evaluate(omega, x, Some(&mut newton.jacobian), &mut work.evaluations, true);
        let residual = match evaluated {
            Ok(r) => r,
            Err(e) => {
                self.jacobian = std::mem::take(&mut newton.jacobian);
                return Err(e);
            }
        };
        // The difference in speed, the point's evaluation and crossings kept.
        let (kept, crossings) = (self.projected.take(), self.crossings.clone());
        let d_omega = SPEED_DIFFERENCE * omega.abs().max(unit);
        let ahead = self.evaluate(omega + d_omega, x, None, &mut work.evaluations, true);
        (self.projected, self.crossings) = (kept, crossings);
        let ahead = match ahead {
            Ok(r) => r,
            Err(e) => {
                self.jacobian = std::mem::take(&mut newton.jacobian);
                return Err(e);
            }
        };
        newton.factorize(x.len());
        // ∂R/∂λ, λ in units of the nominal step.
        let speed_derivative: Vec<f64> =
            ahead.iter().zip(&residual).map(|(a, r)| (a - r) / d_omega * unit).collect();
        // step(v) = −J⁻¹v.
        let solved_derivative: Vec<f64> = newton.step(&speed_derivative).iter().map(|v| -v).collect();
        work.factorizations += newton.factorizations;
        work.products += newton.products;
        self.jacobian = std::mem::take(&mut newton.jacobian);
        self.arc_generation += 1;
        Ok(ArcLinear {
            generation: self.arc_generation,
            harmonics: self.settings.harmonics,
            residual,
            solved_derivative,
        })
    }

    /// The unit tangent of the branch at `linear`'s point, (−J⁻¹∂R/∂λ, 1)
    /// normalized, oriented along `previous` (same length, λ last).
    pub fn arc_tangent(&self, linear: &ArcLinear, previous: &[f64]) -> Vec<f64> {
        let mut t: Vec<f64> = linear.solved_derivative.iter().map(|v| -v).chain([1.0]).collect();
        let norm = t.iter().map(|v| v * v).sum::<f64>().sqrt();
        let along: f64 = t.iter().zip(previous).map(|(a, b)| a * b).sum();
        let sign = if along < 0.0 { -1.0 } else { 1.0 };
        t.iter_mut().for_each(|v| *v *= sign / norm);
        t
    }

    /// Whether `linear` is the linearization whose Jacobian the balance holds
    /// at its present number of harmonics.
    fn arc_current(&self, linear: &ArcLinear) -> bool {
        linear.generation == self.arc_generation && linear.harmonics == self.settings.harmonics
    }

    /// H_k `v` for the bordered system's right-hand side `v` = (v_R, v_c): the
    /// bordered solve on `linear`'s Jacobian, which the balance must hold
    /// ([`Self::arc_current`]), by block elimination (b = J⁻¹v_R, δλ = (v_c −
    /// cₓᵀb) / (c_λ − cₓᵀa), δx = b − δλ a), with the `updates` a ỹᵀ added.
    fn arc_apply(
        &mut self,
        linear: &ArcLinear,
        v: &[f64],
        constraint: &[f64],
        updates: &[(Vec<f64>, Vec<f64>)],
        work: &mut ArcWork,
    ) -> Vec<f64> {
        let n = v.len() - 1;
        // step(r) = −J⁻¹r.
        let minus: Vec<f64> = v[..n].iter().map(|x| -x).collect();
        let mut newton = Newton { jacobian: std::mem::take(&mut self.jacobian), ..Newton::default() };
        let b = newton.step(&minus);
        work.products += newton.products;
        self.jacobian = std::mem::take(&mut newton.jacobian);
        bordered_elimination(v, &b, &linear.solved_derivative, constraint, updates)
    }

    /// Newton's corrections of the bordered balance from `predicted` (x, λ) on
    /// R(x, λ·`unit`) = 0, cᵀ(Y − `predicted`) = 0 with c = `constraint`,
    /// starting on `linear` (or on a fresh linearization at `predicted` when
    /// `fresh`, or when the balance no longer holds `linear`'s Jacobian), at
    /// most `max_corrections`; an iteration that contracts the residual less
    /// than [`ARC_CHORD_CONTRACTION`] takes a fresh one at its point, and the
    /// others update the bordered system's inverse by Broyden's rank-one
    /// formula with the change of the residual the last correction made (the
    /// balance's Jacobian is the plain sums', not the projected residual's:
    /// without the updates the corrections contract by 0.2 to 0.5 each and
    /// near a fold run out; torsional example, 9000 to 10 500 rpm: 140 points
    /// without, 80 with, docs/PERIODIC.md §3). The
    /// corrected point and the corrections it took (the last, below the
    /// tolerance, not counted), or `None` where the residual grows, an
    /// evaluation fails or the corrections run out.
    pub fn arc_correct(
        &mut self,
        linear: &ArcLinear,
        fresh: bool,
        constraint: &[f64],
        predicted: &[f64],
        (unit, max_corrections): (f64, usize),
        work: &mut ArcWork,
    ) -> Option<(Vec<f64>, usize)> {
        let n = predicted.len() - 1;
        if n != self.unknowns() || constraint.len() != n + 1 {
            return None;
        }
        let mut own = None;
        if fresh || !self.arc_current(linear) {
            own = Some(self.arc_linearize(predicted[n] * unit, &predicted[..n], unit, work).ok()?);
        }
        let tolerance = self.settings.tolerance;
        let mut run = FullArc { balance: self, unit, work };
        bordered_correct(&mut run, linear, own, constraint, predicted, (unit, max_corrections), tolerance)
    }

    /// The orbit at the coefficients `x` and speed `omega` [rad/s] whose
    /// linearization `linear` is the last one taken (its residual and the
    /// crossings located there); `iterations` are the corrections that found it.
    pub fn arc_orbit(
        &self,
        omega: f64,
        x: &[f64],
        linear: &ArcLinear,
        iterations: usize,
        work: &ArcWork,
    ) -> HarmonicOrbit {
        HarmonicOrbit {
            speed: omega,
            period: self.problem.period(omega),
            cycles: self.problem.cycles,
            harmonics: self.settings.harmonics,
            coefficients: x.to_vec(),
            iterations,
            residual: linear.residual(),
            last_step: 0.0,
            factorizations: work.factorizations,
            products: work.products,
            force_evaluations: work.evaluations,
            march_steps: 0,
            neighbour: None,
            crossings: self.crossings.clone(),
        }
    }

    /// Takes the number of harmonics (and samples) the rule gives at `omega`
    /// [rad/s] ([`Self::settings_for_speed`]); whether it changed (then
    /// coefficients taken before are brought to it by [`refit`]).
    pub fn arc_fit(&mut self, omega: f64) -> Result<bool, PeriodicError> {
        let wanted = self.settings_for_speed(omega);
        if wanted.harmonics == self.settings.harmonics {
            return Ok(false);
        }
        let settings =
            HarmonicSettings { harmonics: wanted.harmonics, samples: wanted.samples, ..self.settings };
        self.set_settings(settings)?;
        Ok(true)
    }

    /// The periodic state at `omega` [rad/s] from the relative state `z` (the
    /// shooting problem's unknowns): `z`'s period sampled at the settings' N
    /// and analysed into coefficients, then [`Self::solve`]'s Newton from
    /// there. Marching counts into the orbit's force evaluations and steps.
    pub fn solve_from_state(&mut self, omega: f64, z: &[f64]) -> Result<HarmonicOrbit, PeriodicError> {
        let mut newton = Newton::default();
        let mut work = Work::default();
        self.samples = self.settings.samples;
        let coordinates = self.problem.sampled_flow(omega, z, self.settings.samples, &mut work)?;
        newton.evaluations += work.rhs_evaluations;
        newton.march_steps += work.steps;
        let x = self.analyse_samples(&coordinates);
        self.attempt(omega, x, &mut newton)
    }

    /// The relative state at t = 0 (the shooting problem's unknowns) of the
    /// coefficients `x` at `omega` [rad/s] ([`Self::initial_unknowns`]).
    pub fn state_of(&self, omega: f64, x: &[f64]) -> Vec<f64> {
        self.unknowns_of(x, self.problem.period(omega))
    }

    /// The shooting problem, to march on (the continuation's restarts).
    pub fn problem_mut(&mut self) -> &mut PeriodicProblem {
        &mut self.problem
    }
}

/// What the bordered corrector ([`bordered_correct`]) asks of a balance: the full one
/// ([`HarmonicBalance::arc_correct`]) or the condensed one.
pub(super) trait Bordered {
    /// A linearization at a point.
    type Linear;
    /// The residual at the coefficients `x` and speed `omega` [rad/s] (switches projected).
    fn residual_at(&mut self, omega: f64, x: &[f64]) -> Option<Vec<f64>>;
    /// A fresh linearization at `x` and `omega`.
    fn linearize_at(&mut self, omega: f64, x: &[f64]) -> Option<Self::Linear>;
    /// The residual a linearization was taken with.
    fn residual_of(linear: &Self::Linear) -> &[f64];
    /// H_k `v`: the bordered solve on `linear` with the Broyden `updates` a ỹᵀ added.
    fn bordered_solve(
        &mut self,
        linear: &Self::Linear,
        v: &[f64],
        constraint: &[f64],
        updates: &[(Vec<f64>, Vec<f64>)],
    ) -> Vec<f64>;
    /// Counts a correction.
    fn corrected(&mut self) {}
}

/// Newton's corrections of a bordered balance from `predicted` (x, λ) on R(x, λ·`unit`) =
/// 0, cᵀ(Y − `predicted`) = 0 with c = `constraint`, starting on `own` (a fresh
/// linearization at `predicted`) or on `linear`, at most `max_corrections`: an iteration that
/// contracts the residual less than [`ARC_CHORD_CONTRACTION`] takes a fresh linearization at
/// its point, and the others update the bordered system's inverse by Broyden's rank-one
/// formula with the change of the residual the last correction made (the balance's Jacobian
/// is not exactly the projected residual's: without the updates the corrections contract by
/// 0.2 to 0.5 each and near a fold run out; torsional example, 9000 to 10 500 rpm: 140 points
/// without, 80 with, docs/PERIODIC.md §3). Stops when the step, or the distance to the root
/// it leaves estimated from the steps' contraction, is at most `tolerance`. The corrected
/// point and the corrections it took (the last, below the tolerance, not counted), or `None`
/// where the residual grows, an evaluation fails or the corrections run out.
pub(super) fn bordered_correct<B: Bordered>(
    balance: &mut B,
    linear: &B::Linear,
    mut own: Option<B::Linear>,
    constraint: &[f64],
    predicted: &[f64],
    (unit, max_corrections): (f64, usize),
    tolerance: f64,
) -> Option<(Vec<f64>, usize)> {
    let n = predicted.len() - 1;
    let mut y = predicted.to_vec();
    let mut previous = f64::INFINITY;
    let mut last = None;
    // Broyden's updates of the bordered system's inverse since the last linearization,
    // H_k = H_0 + Σ a_i ỹ_iᵀ ("bad" Broyden: no transposed solves), and the residual
    // f = (R, −g) of the last correction's start.
    let mut updates: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    let mut before: Option<Vec<f64>> = None;
    for iteration in 1..=max_corrections {
        let omega = y[n] * unit;
        let r = match (&own, iteration) {
            // A fresh linearization at the predicted point holds its residual.
            (Some(l), 1) => B::residual_of(l).to_vec(),
            _ => balance.residual_at(omega, &y[..n])?,
        };
        let norm = max_abs(&r);
        if !norm.is_finite() || (norm >= previous && iteration > 2) {
            return None;
        }
        let g = -constraint.iter().zip(y.iter().zip(predicted)).map(|(c, (a, b))| c * (a - b)).sum::<f64>();
        let mut f = r;
        f.push(-g);
        // H_k f, and the step −H_{k+1} f with Broyden's update from the last correction
        // s_k = −H_k f_k: H_{k+1} = H_k + a ỹᵀ with ỹ = y / yᵀy, y = f − f_k and
        // a = s_k − H_k y = −H_k f, so H_{k+1} f = H_k f (1 − ỹᵀf), one solve.
        let mut update = None;
        if norm > ARC_CHORD_CONTRACTION * previous {
            own = Some(balance.linearize_at(omega, &y[..n])?);
            updates.clear();
        } else if let Some(f_before) = before.take() {
            let dy: Vec<f64> = f.iter().zip(&f_before).map(|(a, b)| a - b).collect();
            let yy: f64 = dy.iter().map(|v| v * v).sum();
            if yy > 0.0 {
                update = Some(dy.into_iter().map(|v| v / yy).collect::<Vec<f64>>());
            }
        }
        previous = norm;
        let l = own.as_ref().unwrap_or(linear);
        let w = balance.bordered_solve(l, &f, constraint, &updates);
        let step: Vec<f64> = match update {
            Some(ytilde) => {
                let along: f64 = ytilde.iter().zip(&f).map(|(p, q)| p * q).sum();
                let step = w.iter().map(|v| -v * (1.0 - along)).collect();
                updates.push((w.iter().map(|v| -v).collect(), ytilde));
                step
            }
            None => w.iter().map(|v| -v).collect(),
        };
        if step.iter().any(|v| !v.is_finite()) {
            return None;
        }
        before = Some(f);
        balance.corrected();
        y.iter_mut().zip(&step).for_each(|(a, d)| *a += d);
        // The step, or the distance to the root it leaves estimated from the steps'
        // contraction ([`newton_remainder`]), at most the tolerance, in x and in λ alike.
        let length = max_abs(&step[..n]) / max_abs(&y[..n]).max(1.0);
        let length = length.max(step[n].abs() / y[n].abs().max(1.0));
        let remainder = newton_remainder(last, length);
        if length <= tolerance || remainder <= tolerance {
            return Some((y, iteration - 1));
        }
        last = Some(length);
    }
    None
}

/// The full balance in a corrector's run: its speed unit and work.
struct FullArc<'a> {
    balance: &'a mut HarmonicBalance,
    unit: f64,
    work: &'a mut ArcWork,
}

impl Bordered for FullArc<'_> {
    type Linear = ArcLinear;

    fn residual_at(&mut self, omega: f64, x: &[f64]) -> Option<Vec<f64>> {
        self.balance.evaluate(omega, x, None, &mut self.work.evaluations, true).ok()
    }

    fn linearize_at(&mut self, omega: f64, x: &[f64]) -> Option<ArcLinear> {
        self.balance.arc_linearize(omega, x, self.unit, self.work).ok()
    }

    fn residual_of(linear: &ArcLinear) -> &[f64] {
        &linear.residual
    }

    fn bordered_solve(
        &mut self,
        linear: &ArcLinear,
        v: &[f64],
        constraint: &[f64],
        updates: &[(Vec<f64>, Vec<f64>)],
    ) -> Vec<f64> {
        self.balance.arc_apply(linear, v, constraint, updates, self.work)
    }

    fn corrected(&mut self) {
        self.work.corrections += 1;
    }
}

/// `x` (coefficients of H' harmonics, λ last when `with_speed`) brought to
/// `unknowns` coefficients: the common harmonics, the rest zero.
pub fn refit(x: &[f64], unknowns: usize, with_speed: bool) -> Vec<f64> {
    let (coefficients, speed) = if with_speed { x.split_at(x.len() - 1) } else { (x, &[][..]) };
    let mut out = vec![0.0; unknowns];
    let common = coefficients.len().min(unknowns);
    out[..common].copy_from_slice(&coefficients[..common]);
    out.extend_from_slice(speed);
    out
}

/// The bordered system's solution from its block elimination: `b` the balance's step −J⁻¹ of
/// `v`'s first n entries, `a` J⁻¹ ∂R/∂λ, `constraint` the arclength row (λ last), then the
/// corrector's rank-one `updates` (a, y) applied as a·(y·v).
pub(crate) fn bordered_elimination(
    v: &[f64],
    b: &[f64],
    a: &[f64],
    constraint: &[f64],
    updates: &[(Vec<f64>, Vec<f64>)],
) -> Vec<f64> {
    let n = v.len() - 1;
    let (cx, cl) = constraint.split_at(n);
    let dot = |u: &[f64], w: &[f64]| u.iter().zip(w).map(|(p, q)| p * q).sum::<f64>();
    let dl = (v[n] - dot(cx, b)) / (cl[0] - dot(cx, a));
    let mut out: Vec<f64> = b.iter().zip(a).map(|(bi, ai)| bi - dl * ai).chain([dl]).collect();
    for (a, y) in updates {
        let along: f64 = y.iter().zip(v).map(|(p, q)| p * q).sum();
        out.iter_mut().zip(a).for_each(|(o, ai)| *o += along * ai);
    }
    out
}
