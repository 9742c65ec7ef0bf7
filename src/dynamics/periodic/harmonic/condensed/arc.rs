//! The condensed balance bordered by one linear equation in its coefficients and the speed,
//! for pseudo-arclength continuation (`analysis::continuation`, docs/PERIODIC.md §3): the
//! bordered system of the full balance's `arc` module on the contact coordinates, its steps
//! by block elimination on the condensed Jacobian's Woodbury solve.

use super::*;
use crate::dynamics::periodic::harmonic::arc::{bordered_correct, bordered_elimination, Bordered};
use crate::dynamics::periodic::harmonic::{refit, SPEED_DIFFERENCE};
use crate::dynamics::periodic::{HarmonicSettings, PeriodicProblem};
use crate::dynamics::response::Work;

/// The condensed balance linearized at a point of a branch ([`CondensedBalance::arc_linearize`]).
pub struct CondensedArc {
    /// Harmonics H of the point.
    harmonics: usize,
    /// R at the point (switches projected).
    residual: Vec<f64>,
    /// a = J⁻¹ ∂R/∂λ.
    solved_derivative: Vec<f64>,
    /// J's factorisation (the plain sums' Jacobian at the point).
    steps: Steps,
}

impl CondensedArc {
    /// Largest residual coefficient at the point.
    pub fn residual(&self) -> f64 {
        max_abs(&self.residual)
    }
}

impl CondensedBalance {
    /// The balance linearized at the contact coordinates' coefficients `x` and speed `omega`
    /// [rad/s] with the switches projected, λ in units of `unit` [rad/s]; its force
    /// evaluations go to `evaluations`.
    pub fn arc_linearize(
        &mut self,
        omega: f64,
        x: &[f64],
        unit: f64,
        evaluations: &mut u64,
    ) -> Result<CondensedArc, PeriodicError> {
        self.linearize(omega, x, (unit, true), evaluations)
    }

    /// [`Self::arc_linearize`], with ∂R/∂λ only when `derivative`: a correction at fixed
    /// speed eliminates δλ = 0 and never reads it (without, a = 0 and the linear part at
    /// the speed plus the difference is not built).
    fn linearize(
        &mut self,
        omega: f64,
        x: &[f64],
        (unit, derivative): (f64, bool),
        evaluations: &mut u64,
    ) -> Result<CondensedArc, PeriodicError> {
        self.balance.samples = self.balance.settings.samples;
        self.prepare(omega)?;
        if x.len() != self.unknowns() {
            return Err(PeriodicError::invalid(
                "condensed harmonic-balance coefficients",
                x.len() as f64,
                "must hold the contact coordinates × (2H + 1) values for the balance's H",
            ));
        }
        let dims = self.dims();
        let mut at = self.evaluate(omega, x, (true, true), evaluations)?;
        let conv = at.convolution.take().expect("asked for");
        let steps = Steps::new(self.linear.as_ref().expect("prepared"), conv, dims, DenseLu::default());
        if !derivative {
            let solved_derivative = vec![0.0; at.residual.len()];
            let harmonics = self.balance.settings.harmonics;
            return Ok(CondensedArc { harmonics, residual: at.residual, solved_derivative, steps });
        }
        let d_omega = SPEED_DIFFERENCE * omega.abs().max(unit);
        self.prepare(omega + d_omega)?;
        let ahead = self.evaluate(omega + d_omega, x, (false, true), evaluations)?;
        let derivative: Vec<f64> =
            ahead.residual.iter().zip(&at.residual).map(|(a, r)| (a - r) / d_omega * unit).collect();
        // step(v) = −J⁻¹v.
        let solved_derivative = steps.step(&derivative).iter().map(|v| -v).collect();
        Ok(CondensedArc {
            harmonics: self.balance.settings.harmonics,
            residual: at.residual,
            solved_derivative,
            steps,
        })
    }

    /// The unit tangent of the branch at `linear`'s point, (−J⁻¹∂R/∂λ, 1) normalized,
    /// oriented along `previous` (same length, λ last).
    pub fn arc_tangent(&self, linear: &CondensedArc, previous: &[f64]) -> Vec<f64> {
        let mut t: Vec<f64> = linear.solved_derivative.iter().map(|v| -v).chain([1.0]).collect();
        let norm = t.iter().map(|v| v * v).sum::<f64>().sqrt();
        let along: f64 = t.iter().zip(previous).map(|(a, b)| a * b).sum();
        let sign = if along < 0.0 { -1.0 } else { 1.0 };
        t.iter_mut().for_each(|v| *v *= sign / norm);
        t
    }

    /// Newton's corrections of the bordered balance from `predicted` (x, λ) on
    /// R(x, λ·`unit`) = 0, cᵀ(Y − `predicted`) = 0 with c = `constraint`, on `linear` (or a
    /// fresh linearization at `predicted` when `fresh`), at most `max_corrections`: the full
    /// balance's corrector (`HarmonicBalance::arc_correct`: a fresh linearization where an
    /// iteration contracts less than [`super::super::ARC_CHORD_CONTRACTION`], Broyden's updates of the
    /// bordered inverse otherwise, the stop on the steps' contraction; a fresh linearization
    /// too where `linear` was taken at other harmonics). The corrected point and the
    /// corrections it took, or `None`.
    pub fn arc_correct(
        &mut self,
        linear: &CondensedArc,
        fresh: bool,
        constraint: &[f64],
        predicted: &[f64],
        (unit, max_corrections): (f64, usize),
        evaluations: &mut u64,
    ) -> Option<(Vec<f64>, usize)> {
        let n = predicted.len() - 1;
        if n != self.unknowns() || constraint.len() != n + 1 {
            return None;
        }
        let mut own = None;
        // At fixed speed (the speed's row) the corrections need no ∂R/∂λ.
        let derivative = constraint[..n].iter().any(|c| *c != 0.0);
        // A linearization at other harmonics (the rule's H changed with the speed) is not
        // this balance's: a fresh one at the predicted point.
        if fresh || linear.harmonics != self.balance.settings.harmonics {
            let at = (unit, derivative);
            own = Some(self.linearize(predicted[n] * unit, &predicted[..n], at, evaluations).ok()?);
        }
        let tolerance = self.balance.settings.tolerance;
        let mut run = CondensedRun { balance: self, unit, derivative, evaluations };
        bordered_correct(&mut run, linear, own, constraint, predicted, (unit, max_corrections), tolerance)
    }

    /// The orbit, in the full balance's coordinates, at the contact coordinates' coefficients
    /// `x` and speed `omega` [rad/s] (switches projected); `iterations` and `evaluations`
    /// are the work that found it.
    pub fn orbit_at(
        &mut self,
        omega: f64,
        x: &[f64],
        iterations: usize,
        evaluations: &mut u64,
    ) -> Result<HarmonicOrbit, PeriodicError> {
        self.prepare(omega)?;
        let at = self.evaluate(omega, x, (false, self.projected), evaluations)?;
        let coefficients = self.expand(omega, &at.forces);
        Ok(HarmonicOrbit {
            iterations,
            residual: max_abs(&at.residual),
            force_evaluations: *evaluations,
            ..self.series(omega, coefficients)
        })
    }

    /// Takes the harmonics (and samples) the rule gives at `omega` [rad/s], at least the
    /// floor the branch's spectrum set ([`Self::set_harmonic_floor`]), held at
    /// [`CONDENSED_MAX_HARMONICS`]; whether they changed (coefficients taken before are then
    /// brought to them by [`refit`]).
    pub fn arc_fit(&mut self, omega: f64) -> Result<bool, PeriodicError> {
        let rule = self.balance.settings_for_speed(omega);
        let wanted = if self.floor > rule.harmonics {
            let per = rule.samples / rule.harmonics.max(1);
            held(HarmonicSettings { harmonics: self.floor, samples: per * self.floor, ..rule })
        } else {
            held(rule)
        };
        if wanted.harmonics == self.balance.settings.harmonics {
            return Ok(false);
        }
        let settings = HarmonicSettings {
            harmonics: wanted.harmonics,
            samples: wanted.samples,
            ..self.balance.settings
        };
        self.balance.set_settings(settings)?;
        self.linear = None;
        self.spare = None;
        Ok(true)
    }

    /// Sets the fewest harmonics [`Self::arc_fit`] takes (0: the rule's alone): a branch
    /// point's spectrum asks for more than the rule where a narrow force peak needs them
    /// ([`HarmonicOrbit::spectral_harmonics`]).
    pub fn set_harmonic_floor(&mut self, harmonics: usize) {
        self.floor = harmonics;
    }

    /// The floor [`Self::set_harmonic_floor`] set (0: none).
    pub fn harmonic_floor(&self) -> usize {
        self.floor
    }

    /// The harmonics H the balance keeps now.
    pub fn harmonics(&self) -> usize {
        self.balance.settings.harmonics
    }

    /// Solves with `symmetry` again where a solve had given it up (a march's state that broke
    /// the planets' symmetry), its layout built at `omega` [rad/s].
    pub fn restore_symmetry(&mut self, symmetry: Symmetry, omega: f64) -> Result<(), PeriodicError> {
        self.set_symmetry(symmetry);
        self.layout_at(omega)?;
        Ok(())
    }

    /// The coefficients `x` (no λ) brought to the balance's unknowns (its H may have changed
    /// since they were taken: a restart's fit at its own speed).
    pub fn fitted(&self, x: &[f64]) -> Vec<f64> {
        let unknowns = self.unknowns();
        if x.len() == unknowns {
            x.to_vec()
        } else {
            refit(x, unknowns, false)
        }
    }

    /// The contact coordinates of the periodic state at `omega` [rad/s] on the branch of
    /// `symmetry` through `from` (a branch point's coordinates under that symmetry, Newton's
    /// guess): where a restart by marching reaches no periodic state, or one that breaks
    /// the planets' symmetry (past a period doubling or a torus of the symmetric branch),
    /// the run goes on along its own branch. The symmetry and the rule's H at `omega` are
    /// taken first.
    pub fn solve_on_branch(
        &mut self,
        omega: f64,
        symmetry: Symmetry,
        from: &[f64],
    ) -> Result<Vec<f64>, PeriodicError> {
        self.solve_with(omega, symmetry, Some(from))
    }

    /// The contact coordinates of the periodic state at `omega` [rad/s] under `symmetry` from
    /// the balance's cold start (the static deflection, as a run's first point): a restart's
    /// last resort, where neither a march nor the run's own branch gives a state there (the
    /// branch has turned back at a fold behind it).
    pub fn solve_cold(&mut self, omega: f64, symmetry: Symmetry) -> Result<Vec<f64>, PeriodicError> {
        self.solve_with(omega, symmetry, None)
    }

    fn solve_with(
        &mut self,
        omega: f64,
        symmetry: Symmetry,
        from: Option<&[f64]>,
    ) -> Result<Vec<f64>, PeriodicError> {
        self.restore_symmetry(symmetry, omega)?;
        self.arc_fit(omega)?;
        let guess = from.map(|from| self.fitted(from));
        let (orbit, report) = self.solve(omega, guess.as_deref())?;
        if let Some(reason) = report.cyclic_refused {
            return Err(PeriodicError::InvalidRequest {
                name: "symmetry".into(),
                value: format!("{symmetry:?}"),
                reason,
            });
        }
        self.coordinates_of(&orbit)
    }

    /// `vectors` (each Y, λ last) brought to the balance's unknowns.
    pub fn refit_all(&self, vectors: &mut [&mut Vec<f64>]) {
        let unknowns = self.unknowns();
        for v in vectors.iter_mut().filter(|v| v.len() != unknowns + 1) {
            **v = refit(v, unknowns, true);
        }
    }

    /// The relative state at t = 0 (the shooting problem's unknowns) of the orbit at the
    /// contact coordinates' coefficients `x` at `omega` [rad/s].
    pub fn state_of(&mut self, omega: f64, x: &[f64], work: &mut Work) -> Result<Vec<f64>, PeriodicError> {
        let mut evaluations = 0;
        let orbit = self.orbit_at(omega, x, 0, &mut evaluations)?;
        work.rhs_evaluations += evaluations;
        Ok(self.balance.initial_unknowns(&orbit))
    }

    /// The contact coordinates of the periodic state at `omega` [rad/s] from the relative
    /// state `z` (a march's): `z`'s period sampled at the settings' N and analysed, then
    /// Newton on the condensed balance from its contact coordinates (where that fails, from
    /// the orbit shooting finds from `z`); the work into `work`.
    pub fn solve_from_state(
        &mut self,
        omega: f64,
        z: &[f64],
        work: &mut Work,
    ) -> Result<Vec<f64>, PeriodicError> {
        match self.solve_from_marched_period(omega, z, work) {
            Ok(x) => Ok(x),
            Err(_) => {
                // Where Newton does not reach the orbit from the marched period, shooting from
                // the marched state, and the balance from shooting's orbit.
                let orbit = self.balance.problem.solve(omega, Some(z))?;
                work.steps += orbit.work.steps;
                work.rhs_evaluations += orbit.work.rhs_evaluations;
                work.newton_iterations += orbit.work.newton_iterations;
                self.solve_from_marched_period(omega, &orbit.z, work)
            }
        }
    }

    /// [`Self::asymmetry`] of the period the relative state `z` (a march's) runs through at
    /// `omega` [rad/s], sampled at the settings' N and analysed (with every mesh; no Newton):
    /// whether a march reached a state that breaks the planets' symmetry.
    pub fn marched_asymmetry(
        &mut self,
        omega: f64,
        z: &[f64],
        work: &mut Work,
    ) -> Result<f64, PeriodicError> {
        let x = self.marched_coordinates(omega, z, work)?;
        self.asymmetry(omega, &x)
    }

    /// The contact coordinates of the period the relative state `z` runs through at `omega`
    /// [rad/s], sampled at the settings' N and analysed (no Newton); the flow into `work`.
    fn marched_coordinates(
        &mut self,
        omega: f64,
        z: &[f64],
        work: &mut Work,
    ) -> Result<Vec<f64>, PeriodicError> {
        let samples = self.balance.settings.samples;
        let coordinates = self.balance.problem.sampled_flow(omega, z, samples, work)?;
        let y = self.balance.analyse_samples(&coordinates);
        let marched = self.series(omega, y);
        self.coordinates_of(&marched)
    }

    /// The contact coordinates of the periodic state at `omega` [rad/s] by Newton on the
    /// condensed balance from the period the relative state `z` (a march's) runs through,
    /// without [`Self::solve_from_state`]'s fallback to shooting (which, from a march that
    /// has not settled, costs many flows and seldom converges).
    pub fn solve_from_marched_period(
        &mut self,
        omega: f64,
        z: &[f64],
        work: &mut Work,
    ) -> Result<Vec<f64>, PeriodicError> {
        let guess = self.marched_coordinates(omega, z, work)?;
        let (solved, report) = self.solve(omega, Some(&guess))?;
        work.rhs_evaluations += report.law_evaluations;
        work.newton_iterations += report.iterations as u64;
        self.coordinates_of(&solved)
    }

    /// The shooting problem, to march on (the continuation's restarts).
    pub fn problem_mut(&mut self) -> &mut PeriodicProblem {
        &mut self.balance.problem
    }

    /// Newton's unknowns: contact coordinates × (2H + 1).
    pub fn unknowns(&self) -> usize {
        self.layout.as_ref().map_or(0, |l| l.coordinates()) * (2 * self.balance.settings.harmonics + 1)
    }

    fn dims(&self) -> (usize, usize) {
        let layout = self.layout.as_ref().expect("prepared");
        (layout.coordinates(), layout.computed.len())
    }
}

/// The condensed balance in a corrector's run: its speed unit, whether it needs ∂R/∂λ, and
/// its evaluations.
struct CondensedRun<'a> {
    balance: &'a mut CondensedBalance,
    unit: f64,
    /// Whether its linearizations take ∂R/∂λ (not at fixed speed).
    derivative: bool,
    evaluations: &'a mut u64,
}

impl Bordered for CondensedRun<'_> {
    type Linear = CondensedArc;

    fn residual_at(&mut self, omega: f64, x: &[f64]) -> Option<Vec<f64>> {
        self.balance.prepare(omega).ok()?;
        Some(self.balance.evaluate(omega, x, (false, true), self.evaluations).ok()?.residual)
    }

    fn linearize_at(&mut self, omega: f64, x: &[f64]) -> Option<CondensedArc> {
        self.balance.linearize(omega, x, (self.unit, self.derivative), self.evaluations).ok()
    }

    fn residual_of(linear: &CondensedArc) -> &[f64] {
        &linear.residual
    }

    /// By block elimination on `linear`'s Woodbury solve (b = J⁻¹v_R, δλ = (v_c − cₓᵀb) /
    /// (c_λ − cₓᵀa), δx = b − δλ a), with the `updates` a ỹᵀ added.
    fn bordered_solve(
        &mut self,
        linear: &CondensedArc,
        v: &[f64],
        constraint: &[f64],
        updates: &[(Vec<f64>, Vec<f64>)],
    ) -> Vec<f64> {
        let n = v.len() - 1;
        let b: Vec<f64> = linear.steps.step(&v[..n]).iter().map(|x| -x).collect();
        bordered_elimination(v, &b, &linear.solved_derivative, constraint, updates)
    }
}
