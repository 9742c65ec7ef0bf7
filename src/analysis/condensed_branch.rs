//! The continuation's solver on the harmonic balance condensed onto the contact coordinates
//! ([`CondensedBalance`], docs/PERIODIC.md §2 and §3): the same loop as on shooting and on the
//! full balance ([`crate::analysis::continuation::follow_branch`]), its Y the contact
//! coordinates' coefficients and λ, each point's orbit expanded to every coordinate, its
//! Floquet multipliers the whole model's (so an orbit of the planets' symmetry that loses
//! stability to one that breaks it shows as a multiplier leaving the unit circle).

use crate::analysis::accuracy::harmonic_error;
use crate::analysis::continuation::{balance_point, march, BranchSolver};
use crate::dynamics::periodic::{
    CondensedArc, CondensedBalance, HarmonicOrbit, PeriodicError, PeriodicOrbit, Symmetry,
    CONDENSED_MAX_HARMONICS,
};
use crate::dynamics::response::Work;

/// Intervals per kept harmonic on which a branch point's Floquet multipliers are computed
/// (`HarmonicBalance::floquet_multipliers`): the full model's monodromy is most of a point's
/// cost. Measured on the example at 3000, 8200, 9500 and 11 400 rpm (docs/PERIODIC.md §3):
/// the three largest |μ| agree to 1e-5 with those on the balance's N = 16 H intervals, in
/// 0.18 to 0.27 of the time.
pub const MULTIPLIER_INTERVALS_PER_HARMONIC: usize = 2;

/// A restart's march whose period lies further than this (relative to its largest
/// coefficient, [`CondensedBalance::asymmetry`]) from the planets' symmetry is solved with
/// every mesh: well above what a march that settles on a symmetric orbit leaves (it stops
/// at a change of 1e-3 of the state over a period), well below the broken states of the
/// example (one planet's sun–planet F^(rms) three times the others' near 11 500 rpm).
pub const MARCHED_ASYMMETRY: f64 = 1e-2;

/// ... and the run goes on with every mesh where the orbit Newton finds from it breaks the
/// symmetry by more than this (Newton's tolerance is 1e-7 of the coefficients).
pub const BROKEN_SYMMETRY: f64 = 1e-4;

/// A branch point whose spectrum asks for more harmonics keeps twice them where the mesh
/// forces' harmonics there differ from its own by more than this (E_h of the one against
/// the other, docs/ACCURACY.md): half the 1e-3 the periodic states are held to.
pub const SPECTRAL_ESTIMATE: f64 = 5e-4;

/// A check that found a point within [`SPECTRAL_ESTIMATE`] at its own harmonics stands for
/// points within this share of its speed whose top quarter holds no more.
pub const SPECTRAL_SPAN: f64 = 0.1;

/// The checks of [`spectral_harmonics`] along a run.
#[derive(Clone, Copy, Debug, Default)]
pub struct Checks {
    /// The speed [rad/s] and top-quarter share of the last point a check found within
    /// [`SPECTRAL_ESTIMATE`] at its own harmonics.
    pub passed: Option<(f64, f64)>,
    /// Solves at twice a point's harmonics.
    pub count: usize,
}

/// The coordinates `x` at `omega` [rad/s] (at the balance's H), or the point solved again
/// at twice the harmonics (up to [`CONDENSED_MAX_HARMONICS`]) where its spectrum asks for
/// them ([`HarmonicOrbit::spectral_harmonics`]) and the mesh forces' harmonics at twice
/// the harmonics differ from the point's by more than [`SPECTRAL_ESTIMATE`] (E_h of the
/// one against the other: an estimate of the point's own). A check that finds the point's
/// forces within it lets points within [`SPECTRAL_SPAN`] of its speed whose top quarter
/// holds no more go unchecked. A point kept at more harmonics sets the floor of the next
/// steps' H ([`CondensedBalance::set_harmonic_floor`]), lowered where its spectrum says
/// half of them would do. Where a solve at more harmonics fails, or breaks the planets'
/// symmetry, the point stays at the H it was found at. `checks` counts the solves at
/// twice the harmonics and keeps the last check that passed.
pub fn spectral_harmonics(
    balance: &mut CondensedBalance,
    omega: f64,
    x: &[f64],
    checks: &mut Checks,
    work: &mut Work,
) -> Result<Option<Vec<f64>>, PeriodicError> {
    // The coordinates kept so far (`None`: `x`) and the harmonics they are at.
    let mut resolved: Option<Vec<f64>> = None;
    loop {
        let kept = balance.harmonics();
        let at = resolved.as_deref().unwrap_or(x);
        let mut evaluations = 0;
        let orbit = balance.orbit_at(omega, at, 0, &mut evaluations)?;
        work.rhs_evaluations += evaluations;
        let asked = orbit.spectral_harmonics().min(CONDENSED_MAX_HARMONICS);
        let tail = orbit.band_share(3 * kept / 4, kept);
        let tolerated = checks
            .passed
            .is_some_and(|(speed, share)| (omega - speed).abs() <= SPECTRAL_SPAN * speed && tail <= share);
        let floor = balance.harmonic_floor();
        if asked <= kept || tolerated {
            // A floor the spectrum set earlier goes where half its harmonics would do.
            if asked < kept && floor > asked {
                balance.set_harmonic_floor(asked);
            }
            return Ok(resolved);
        }
        let before = balance.balance().steady_state(&orbit)?;
        balance.set_harmonic_floor(asked);
        balance.arc_fit(omega)?;
        let guess = balance.fitted(at);
        let symmetry = balance.symmetry();
        let solved = match balance.solve(omega, Some(&guess)) {
            Ok((doubled, report)) if balance.symmetry() == symmetry => {
                work.rhs_evaluations += report.law_evaluations;
                work.newton_iterations += report.iterations as u64;
                Some(doubled)
            }
            _ => None,
        };
        checks.count += 1;
        let estimate = match &solved {
            Some(doubled) => {
                let after = balance.balance().steady_state(doubled)?;
                let meshes = |s: &crate::dynamics::response::SteadyState| -> Vec<_> {
                    s.meshes.iter().map(|m| m.harmonics.clone()).collect()
                };
                harmonic_error(&meshes(&before), &meshes(&after))
            }
            None => 0.0,
        };
        match solved {
            Some(doubled) if estimate > SPECTRAL_ESTIMATE => {
                resolved = Some(balance.coordinates_of(&doubled)?);
            }
            _ => {
                // The point's own harmonics do (or no more can be had): back to them.
                if solved.is_some() {
                    checks.passed = Some((omega, tail));
                }
                balance.restore_symmetry(symmetry, omega)?;
                balance.set_harmonic_floor(kept);
                balance.arc_fit(omega)?;
                balance.set_harmonic_floor(if resolved.is_some() { kept } else { floor });
                return Ok(resolved);
            }
        }
    }
}

/// Continuation on a [`CondensedBalance`].
pub struct CondensedBranch<'a> {
    balance: &'a mut CondensedBalance,
    /// The symmetry the run follows its branch with (the balance's when the run began).
    symmetry: Symmetry,
    /// The symmetry of the run's points since its last restart: [`Symmetry::Full`] after a
    /// restart that found a state breaking the planets' symmetry.
    points: Symmetry,
    /// Whether a restart whose march breaks the planets' symmetry goes on with every mesh
    /// ([`Self::follow_broken_symmetry`]).
    broken_symmetry: bool,
    /// Restarts that went on with every mesh along a symmetry-broken branch.
    broken_restarts: usize,
    /// The orbits of the points accepted, in the full balance's coordinates, in the order of
    /// the branch's points (for their forces: `HarmonicBalance::steady_state`).
    pub orbits: Vec<HarmonicOrbit>,
    /// The last accepted point's coordinates where it was solved again at the harmonics its
    /// spectrum asked ([`BranchSolver::resolved`]).
    resolved: Option<Vec<f64>>,
    /// Points solved again at more harmonics than the rule's ([`Self::spectral_resolves`]).
    spectral_resolves: usize,
    /// The run's checks at twice a point's harmonics ([`spectral_harmonics`]).
    checks: Checks,
}

impl<'a> CondensedBranch<'a> {
    /// Continuation on `balance`.
    pub fn new(balance: &'a mut CondensedBalance) -> Self {
        let symmetry = balance.symmetry();
        Self {
            symmetry,
            points: symmetry,
            broken_symmetry: false,
            broken_restarts: 0,
            balance,
            orbits: Vec::new(),
            resolved: None,
            spectral_resolves: 0,
            checks: Checks::default(),
        }
    }

    /// How many branch points were solved again at more harmonics because their spectrum
    /// asked for them ([`HarmonicOrbit::spectral_harmonics`]).
    pub fn spectral_resolves(&self) -> usize {
        self.spectral_resolves
    }

    /// How many branch points were checked by a solve at twice their harmonics.
    pub fn spectral_checks(&self) -> usize {
        self.checks.count
    }

    /// Whether a restart whose march reaches a state that breaks the planets' symmetry goes
    /// on with every mesh from it ([`Symmetry::Full`]: the symmetry-broken branch, at four
    /// times the unknowns, until the next restart) instead of along the run's symmetric
    /// branch, unstable there. Off by default (docs/PERIODIC.md §3).
    pub fn follow_broken_symmetry(&mut self, follow: bool) {
        self.broken_symmetry = follow;
    }

    /// How many restarts went on with every mesh along a symmetry-broken branch
    /// ([`Self::follow_broken_symmetry`]).
    pub fn broken_restarts(&self) -> usize {
        self.broken_restarts
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

impl CondensedBranch<'_> {
    /// [`spectral_harmonics`] for a branch point, with the run's checks; a point solved
    /// again is counted.
    fn spectral(
        &mut self,
        omega: f64,
        x: &[f64],
        work: &mut Work,
    ) -> Result<Option<Vec<f64>>, PeriodicError> {
        let resolved = spectral_harmonics(self.balance, omega, x, &mut self.checks, work)?;
        self.spectral_resolves += usize::from(resolved.is_some());
        Ok(resolved)
    }

    /// [`BranchSolver::restart`] once `from` is in the run's symmetry and `z` is its state.
    fn restarted(
        &mut self,
        omega: f64,
        from: &[f64],
        z: &[f64],
        (work, flows): (&mut Work, &mut usize),
    ) -> Option<Vec<f64>> {
        let marched = march(self.balance.problem_mut(), omega, z, work, flows);
        if let Some(z) = &marched {
            if self.broken_symmetry {
                if let Some(x) = self.broken(omega, z, work) {
                    return Some(x);
                }
            }
            let solved = (|| {
                self.balance.arc_fit(omega).ok()?;
                self.balance.solve_from_state(omega, z, work).ok()
            })();
            if let Some(x) = solved {
                if self.balance.symmetry() == self.symmetry && x.len() == self.balance.unknowns() {
                    return Some(x);
                }
            }
        }
        let x = match self.balance.solve_on_branch(omega, self.symmetry, from) {
            Ok(x) => x,
            Err(_) => self.balance.solve_cold(omega, self.symmetry).ok()?,
        };
        (x.len() == self.balance.unknowns()).then_some(x)
    }

    /// The orbit with every mesh from the marched state `z` at `omega` [rad/s], where the
    /// march and that orbit break the planets' symmetry; the balance then holds every mesh.
    /// `None` (the balance back at the run's symmetry) otherwise.
    fn broken(&mut self, omega: f64, z: &[f64], work: &mut Work) -> Option<Vec<f64>> {
        if self.symmetry == Symmetry::Full {
            return None;
        }
        let found = (|| {
            self.balance.restore_symmetry(Symmetry::Full, omega).ok()?;
            self.balance.arc_fit(omega).ok()?;
            let marched = self.balance.marched_asymmetry(omega, z, work).ok()?;
            if marched <= MARCHED_ASYMMETRY {
                return None;
            }
            let x = self.balance.solve_from_state(omega, z, work).ok()?;
            let solved = self.balance.asymmetry(omega, &x).ok()?;
            (solved > BROKEN_SYMMETRY && x.len() == self.balance.unknowns()).then_some(x)
        })();
        if found.is_none() {
            self.balance.restore_symmetry(self.symmetry, omega).ok()?;
        }
        found
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
        let resolved = self.spectral(omega, &x, &mut work)?;
        let x = resolved.unwrap_or(x);
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
    /// run follows broken symmetry ([`Self::follow_broken_symmetry`]) and the march reaches
    /// a state that breaks the planets' symmetry (its period more than
    /// [`MARCHED_ASYMMETRY`] from it), Newton with every mesh from it: where that orbit
    /// breaks the symmetry too (by more than [`BROKEN_SYMMETRY`]), the run goes on with
    /// every mesh from there (the balance holds [`Symmetry::Full`] until the next restart).
    /// Otherwise with the run's symmetry; where the march reaches no periodic state, the run
    /// goes on along its own branch from `from` ([`CondensedBalance::solve_on_branch`]), and
    /// where that branch has turned back, from the balance's cold start
    /// ([`CondensedBalance::solve_cold`]). `from` is read in the layout of the run's last
    /// points (every mesh after a symmetry-broken restart) and brought to the balance's H.
    fn restart(&mut self, omega: f64, from: &[f64], work: &mut Work, flows: &mut usize) -> Option<Vec<f64>> {
        // `from` in the layout it was taken in: the state to march from, and where the run
        // went on with every mesh, its coordinates under the run's symmetry.
        self.balance.restore_symmetry(self.points, omega).ok()?;
        let z = self.balance.state_of(omega, &self.balance.fitted(from), work).ok()?;
        let converted;
        let from = if self.points == self.symmetry {
            from
        } else {
            let mut evaluations = 0;
            let orbit = self.balance.orbit_at(omega, &self.balance.fitted(from), 0, &mut evaluations).ok()?;
            work.rhs_evaluations += evaluations;
            self.balance.restore_symmetry(self.symmetry, omega).ok()?;
            converted = self.balance.coordinates_of(&orbit).ok()?;
            &converted[..]
        };
        // The balance holds the run's symmetry now (taken above, or back in the conversion).
        let found = self.restarted(omega, from, &z, (work, flows));
        if found.is_some() {
            self.points = self.balance.symmetry();
            self.broken_restarts += usize::from(self.points != self.symmetry);
        }
        found
    }

    fn accept(
        &mut self,
        (x, omega, unit): (&[f64], f64, f64),
        corrections: usize,
        (work, flows): (&mut Work, &mut usize),
    ) -> Result<(PeriodicOrbit, CondensedArc), PeriodicError> {
        let resolved = self.spectral(omega, x, work)?;
        let x = resolved.as_deref().unwrap_or(x);
        let mut evaluations = 0;
        let linear = self.balance.arc_linearize(omega, x, unit, &mut evaluations)?;
        work.rhs_evaluations += evaluations;
        let orbit = self.orbit(omega, x, (corrections, linear.residual()), (work, flows))?;
        self.resolved = resolved;
        Ok((orbit, linear))
    }

    fn resolved(&mut self) -> Option<Vec<f64>> {
        self.resolved.take()
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
