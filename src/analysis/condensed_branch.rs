//! The continuation's solver on the harmonic balance condensed onto the contact coordinates
//! ([`CondensedBalance`], docs/PERIODIC.md §2 and §3): the same loop as on shooting and on the
//! full balance ([`crate::analysis::continuation::follow_branch`]), its Y the contact
//! coordinates' coefficients and λ, each point's orbit expanded to every coordinate, its
//! Floquet multipliers the whole model's (so an orbit of the planets' symmetry that loses
//! stability to one that breaks it shows as a multiplier leaving the unit circle).

use crate::analysis::continuation::{balance_point, march, BranchSolver};
use crate::dynamics::periodic::{
    CondensedArc, CondensedBalance, HarmonicOrbit, PeriodicError, PeriodicOrbit, Symmetry,
};
use crate::dynamics::response::Work;

/// Intervals per kept harmonic on which a branch point's Floquet multipliers are computed
/// (`HarmonicBalance::floquet_multipliers`): the full model's monodromy is most of a point's
/// cost. Measured on the example at 3000, 8200, 9500 and 11 400 rpm (docs/PERIODIC.md §3):
/// the three largest |μ| agree to 1e-5 with those on the balance's N = 16 H intervals, in
/// 0.18 to 0.27 of the time.
pub const MULTIPLIER_INTERVALS_PER_HARMONIC: usize = 2;

/// Continuation on a [`CondensedBalance`].
pub struct CondensedBranch<'a> {
    balance: &'a mut CondensedBalance,
    /// The symmetry the run follows its branch with (the balance's when the run began).
    symmetry: Symmetry,
    /// The orbits of the points accepted, in the full balance's coordinates, in the order of
    /// the branch's points (for their forces: `HarmonicBalance::steady_state`).
    pub orbits: Vec<HarmonicOrbit>,
}

impl<'a> CondensedBranch<'a> {
    /// Continuation on `balance`.
    pub fn new(balance: &'a mut CondensedBalance) -> Self {
        Self { symmetry: balance.symmetry(), balance, orbits: Vec::new() }
    }

    /// The branch point at `x` and `omega` with its multipliers, its orbit kept in
    /// [`Self::orbits`].
    fn orbit(
        &mut self,
        omega: f64,
        x: &[f64],
        (corrections, residual): (usize, f64),
        (work, flows): (&mut Work, &mut usize),
    ) -> Result<PeriodicOrbit, PeriodicError> {
        let mut evaluations = 0;
        let orbit = self.balance.orbit_at(omega, x, corrections, &mut evaluations)?;
        work.rhs_evaluations += evaluations;
        let full = self.balance.balance();
        let intervals = MULTIPLIER_INTERVALS_PER_HARMONIC * full.settings().harmonics;
        let point = balance_point(full, &orbit, intervals, (corrections, residual), (work, flows))?;
        self.orbits.push(orbit);
        Ok(point)
    }
}

impl BranchSolver for CondensedBranch<'_> {
    type Linear = CondensedArc;

    fn unknown_scales(&self) -> Vec<f64> {
        self.balance.problem().unknown_scales()
    }

    fn start(
        &mut self,
        omega: f64,
        unit: f64,
    ) -> Result<(PeriodicOrbit, Vec<f64>, CondensedArc), PeriodicError> {
        self.balance.arc_fit(omega)?;
        let (solved, report) = self.balance.solve(omega, None)?;
        let mut work = Work {
            rhs_evaluations: report.law_evaluations,
            newton_iterations: report.iterations as u64,
            ..Work::default()
        };
        let x = self.balance.coordinates_of(&solved)?;
        let mut evaluations = 0;
        let linear = self.balance.arc_linearize(omega, &x, unit, &mut evaluations)?;
        work.rhs_evaluations += evaluations;
        let orbit = self.orbit(omega, &x, (report.iterations, linear.residual()), (&mut work, &mut 0))?;
        Ok((orbit, x, linear))
    }

    fn tangent(&mut self, linear: &CondensedArc, _unit: f64, orient: &[f64]) -> Vec<f64> {
        self.balance.arc_tangent(linear, orient)
    }

    fn correct(
        &mut self,
        linear: &CondensedArc,
        fresh: bool,
        constraint: &[f64],
        predicted: &[f64],
        limits: (f64, usize),
        (work, _): (&mut Work, &mut usize),
    ) -> Option<(Vec<f64>, usize)> {
        let mut evaluations = 0;
        let found = self.balance.arc_correct(linear, fresh, constraint, predicted, limits, &mut evaluations);
        work.rhs_evaluations += evaluations;
        if let Some((_, corrections)) = &found {
            work.newton_iterations += *corrections as u64;
        }
        found
    }

    /// By marching from the state at `from`, then Newton from the marched state. Where the
    /// march reaches no periodic state, or one that breaks the planets' symmetry, the run
    /// goes on along its own branch from `from` ([`CondensedBalance::solve_on_branch`]), and
    /// where that branch has turned back, from the balance's cold start
    /// ([`CondensedBalance::solve_cold`]).
    /// An earlier try may have left the balance at another H or without the symmetry: the
    /// run's symmetry is taken back first, and `from` is brought to the balance's H where
    /// it is read (each time from the run's own coefficients, so no harmonic is lost to an
    /// H in between).
    fn restart(&mut self, omega: f64, from: &[f64], work: &mut Work, flows: &mut usize) -> Option<Vec<f64>> {
        self.balance.restore_symmetry(self.symmetry, omega).ok()?;
        let marched = (|| {
            let z = self.balance.state_of(omega, &self.balance.fitted(from), work).ok()?;
            let z = march(self.balance.problem_mut(), omega, &z, work, flows)?;
            self.balance.arc_fit(omega).ok()?;
            self.balance.solve_from_state(omega, &z, work).ok()
        })();
        match marched {
            Some(x) if self.balance.symmetry() == self.symmetry && x.len() == self.balance.unknowns() => {
                Some(x)
            }
            _ => {
                let x = match self.balance.solve_on_branch(omega, self.symmetry, from) {
                    Ok(x) => x,
                    Err(_) => self.balance.solve_cold(omega, self.symmetry).ok()?,
                };
                (x.len() == self.balance.unknowns()).then_some(x)
            }
        }
    }

    fn accept(
        &mut self,
        (x, omega, unit): (&[f64], f64, f64),
        corrections: usize,
        (work, flows): (&mut Work, &mut usize),
    ) -> Result<(PeriodicOrbit, CondensedArc), PeriodicError> {
        let mut evaluations = 0;
        let linear = self.balance.arc_linearize(omega, x, unit, &mut evaluations)?;
        work.rhs_evaluations += evaluations;
        let orbit = self.orbit(omega, x, (corrections, linear.residual()), (work, flows))?;
        Ok((orbit, linear))
    }

    /// The linear part is built once per speed: a step's corrections share it.
    fn fixed_speed_steps(&self) -> bool {
        true
    }

    /// The rule's harmonics at the lower speed, as the full balance's continuation.
    fn fit(&mut self, (low, _): (f64, f64), vectors: &mut [&mut Vec<f64>]) -> Result<bool, PeriodicError> {
        let changed = self.balance.arc_fit(low)?;
        self.balance.refit_all(vectors);
        Ok(changed)
    }
}
