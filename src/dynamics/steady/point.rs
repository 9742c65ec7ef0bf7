//! One periodic steady state of the `steady` response (docs/STEADY.md): the orbit of the
//! model free under the balanced torques of one input torque, at one input speed, by the
//! harmonic balance condensed onto the contact coordinates, started from a neighbour's
//! orbit (the continuation the cycle drives), from a short march out of a neighbour's state
//! where that Newton fails (a fold: the response jumps to the branch the march reaches),
//! or from the static state.

use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::periodic::{
    max_abs, CondensedBalance, HarmonicBalance, HarmonicOrbit, HarmonicSettings, PeriodicError,
    PeriodicProblem, ShootingSettings, Symmetry,
};
use crate::dynamics::response::Work;
use crate::dynamics::solver::SecondOrderSystem;
use crate::dynamics::spectrum::{mesh_harmonics, separation_fraction, Harmonics};

/// Periods a restart marches at most from a neighbour's state before Newton (the branch
/// the response jumps to past a fold): three input revolutions of the example. The march
/// stops earlier once a period changes the state by less than [`MARCH_SETTLED`] of it.
pub const MARCH_PERIODS: usize = 100;

/// A march has settled once one period changes its state by at most this fraction of it
/// (the continuation's restarts use the same).
pub const MARCH_SETTLED: f64 = 1e-3;

/// Periods a march runs at most where it is the steady state itself (a coast load, or
/// where the balance finds no orbit): about three and a half input revolutions of the
/// example. A march that has not settled by then is kept with its last period's change
/// ([`SteadyPoint::settled`]): the response is not periodic there (the teeth rattle). A
/// restart's march counts towards these periods: where its Newton fails, the march goes
/// on from where it stopped.
pub const COAST_MARCH_PERIODS: usize = 120;

/// Integrator steps one node's marches take at most, together (docs/STEADY.md, "A node's
/// cost"). A period's steps are set by the fastest modes, not by the mesh, so a slower
/// period takes more of them: on the example about 1 100 at 3 000 rpm and 6 400 at
/// 525 rpm. The budget is then the [`COAST_MARCH_PERIODS`] down to about 2 700 rpm and
/// about 23 periods at 500 rpm, over 20 decay times of the lowest mode at ζ = 0.05: a march
/// that has not settled by then rattles. It is kept as one that has not settled within
/// its periods.
pub const MARCH_STEPS: u64 = 150_000;

/// The largest mean mesh force, over the static load, of an orbit the steady response
/// keeps ([`TorqueLevel::solve`]).
pub const PLAUSIBLE_MEAN: f64 = 10.0;

/// The largest mesh force, over the static load, of an orbit the steady response keeps:
/// impacts of rattling worn teeth reached 35 times it on the example.
pub const PLAUSIBLE_PEAK: f64 = 1e3;

/// A march's state and what it may still spend: the relative state at a period's start,
/// the last period's change (relative), the periods run and the steps taken.
struct March {
    z: Vec<f64>,
    change: f64,
    periods: usize,
    steps: u64,
    /// A period failed to integrate from `z`.
    failed: bool,
}

impl March {
    fn from(z: &[f64]) -> Self {
        Self { z: z.to_vec(), change: f64::INFINITY, periods: 0, steps: 0, failed: false }
    }

    fn settled(&self) -> bool {
        self.change <= MARCH_SETTLED
    }

    /// Marches on at `omega` [rad/s] until a period changes the state by at most
    /// [`MARCH_SETTLED`] of it, `periods` periods have run in all, or [`MARCH_STEPS`]
    /// steps have been taken in all; the error of a period that fails (the state stays at
    /// that period's start).
    fn run(
        &mut self,
        problem: &mut PeriodicProblem,
        omega: f64,
        periods: usize,
        work: &mut Work,
    ) -> Result<(), PeriodicError> {
        while !self.settled() && self.periods < periods && self.steps < MARCH_STEPS {
            let before = work.steps;
            let r = problem.residual(omega, &self.z, work).inspect_err(|_| self.failed = true)?;
            self.steps += work.steps - before;
            self.periods += 1;
            self.z.iter_mut().zip(&r).for_each(|(a, b)| *a += b);
            self.change = max_abs(&r) / max_abs(&self.z).max(1.0);
        }
        Ok(())
    }
}

/// How a steady state was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Found {
    /// No load: every mesh force is zero (the unloaded node of the torque grid).
    Unloaded,
    /// Newton from a neighbour's orbit.
    Continued,
    /// Newton from the state a march out of a neighbour's state reached (past a fold).
    Marched,
    /// Newton from the static state.
    Cold,
    /// Not found: every way failed (a march's period did not integrate), and the node took
    /// its torque row's nearest node, marked as not settled ([`SteadyPoint::settled`]
    /// infinite), so that its cells carry no estimate.
    Failed,
}

/// One mesh's forces over the steady period.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeshSummary {
    /// Smallest mesh force \[N\].
    pub min: f64,
    /// Largest mesh force \[N\].
    pub max: f64,
    /// Mean mesh force \[N\].
    pub mean: f64,
    /// Largest tooth-pair force in magnitude \[N\].
    pub peak_pair: f64,
    /// Fraction of the period with no tooth force.
    pub separation: f64,
}

/// A periodic steady state and what the outputs read from it.
#[derive(Clone, Debug)]
pub struct SteadyPoint {
    /// Input speed [rad/s].
    pub speed: f64,
    /// Input torque [N·m].
    pub torque: f64,
    /// Input angle over one period, signed as the speed \[rad\].
    pub angle_period: f64,
    /// Mesh cycles in the period.
    pub cycles: usize,
    /// Samples over the period.
    pub samples: usize,
    /// Offset of the samples from the period's start, a fraction of the sample interval.
    pub phase: f64,
    /// Coordinates relative to the rigid-body motion at each sample (sample-major) \[m\],
    /// kept in single precision (a tenth of a nanometre on micrometres; a cache of
    /// thousands of nodes stays at tens of megabytes).
    pub q: Vec<f32>,
    /// Velocities relative to the rigid-body motion at each sample (sample-major) [m/s].
    pub v: Vec<f32>,
    /// Per mesh, planet-major (sun, ring).
    pub meshes: Vec<MeshSummary>,
    /// Harmonics and separation fraction of planet 1's sun–planet and ring–planet mesh force.
    pub window: [(Harmonics, f64); 2],
    /// How it was found.
    pub found: Found,
    /// Its contact coordinates' coefficients under cyclic symmetry (a neighbour's Newton
    /// guess), `None` where the orbit breaks the planets' symmetry.
    pub(super) coordinates: Option<Vec<f32>>,
    /// The relative state at the period's start (a neighbour's march start).
    pub(super) start: Vec<f64>,
    /// Where the steady state is a march's period: that period's change, relative (0 for
    /// an orbit of the harmonic balance).
    pub settled: f64,
    /// Newton's and the march's work.
    pub work: Work,
}

impl SteadyPoint {
    /// The unloaded state at `speed` [rad/s]: the rigid-body motion, no tooth force.
    pub fn unloaded(speed: f64, model: &PlanetaryDynamics, samples_per_cycle: usize) -> Self {
        let n = model.dim();
        let zero = Harmonics { mean: 0.0, amplitude: vec![0.0; 6], rms: 0.0 };
        SteadyPoint {
            speed,
            torque: 0.0,
            angle_period: speed.signum() / model.mesh_frequency_per_input_speed,
            cycles: 1,
            samples: samples_per_cycle,
            phase: 0.0,
            q: vec![0.0; n * samples_per_cycle],
            v: vec![0.0; n * samples_per_cycle],
            meshes: vec![MeshSummary { separation: 1.0, ..MeshSummary::default() }; model.mesh_count()],
            window: [(zero.clone(), 1.0), (zero, 1.0)],
            found: Found::Unloaded,
            coordinates: None,
            start: Vec::new(),
            settled: 0.0,
            work: Work::default(),
        }
    }
}

/// The steady states of one input torque: the model free under its balanced torques and
/// its condensed balance, kept across speeds (its linear parts, its H).
pub struct TorqueLevel {
    torque: f64,
    /// Static mesh force per planet at this torque \[N\].
    static_load: f64,
    model: PlanetaryDynamics,
    balance: CondensedBalance,
    samples_per_cycle: usize,
    /// Offset of the samples from the period's start, a fraction of the sample interval.
    phase: f64,
}

impl TorqueLevel {
    /// The level of input torque `torque` [N·m] with balanced torques `torques` on sun, ring
    /// and carrier and static mesh force per planet `static_load` \[N\], from `base` (the
    /// simulation's model), its state scales at `reference_speed` [rad/s];
    /// `samples_per_cycle` samples per mesh cycle for the outputs.
    pub fn new(
        base: &PlanetaryDynamics,
        (torque, static_load): (f64, f64),
        torques: [f64; 3],
        reference_speed: f64,
        (samples_per_cycle, phase): (usize, f64),
    ) -> Result<Self, PeriodicError> {
        let model = base.free_under(torques);
        let settings =
            ShootingSettings { samples_per_mesh_cycle: samples_per_cycle, ..ShootingSettings::default() };
        let problem = PeriodicProblem::new(model.clone(), settings, reference_speed)?;
        let harmonics = HarmonicSettings::for_speed(&problem, reference_speed);
        let hb = HarmonicBalance::new(problem, crate::dynamics::periodic::held(harmonics))?;
        Ok(Self {
            torque,
            static_load,
            model,
            balance: CondensedBalance::new(hb, Symmetry::Cyclic),
            samples_per_cycle,
            phase,
        })
    }

    /// The steady state at `omega` [rad/s], from `neighbour` (a point of this level) where
    /// given: Newton from its orbit, else from a march out of its state, else cold. Under a
    /// negative (coast) load, and wherever the balance finds no orbit, the settled period
    /// of a march.
    pub fn solve(
        &mut self,
        omega: f64,
        neighbour: Option<&SteadyPoint>,
    ) -> Result<SteadyPoint, PeriodicError> {
        let mut work = Work::default();
        let mut march = neighbour.map(|n| &n.start).filter(|z| !z.is_empty()).map(|z| March::from(z));
        if self.torque < 0.0 {
            return self.marched(omega, march, work);
        }
        match self.orbit(omega, neighbour, &mut march, &mut work) {
            Ok((orbit, found)) => {
                let point = self.point(&orbit, found, work)?;
                match self.plausible(&point) {
                    true => Ok(point),
                    false => self.marched(omega, march, point.work),
                }
            }
            Err(_) => self.marched(omega, march, work),
        }
    }

    /// Whether an orbit of the balance is a motion of the gear set: each mesh's mean force
    /// within [`PLAUSIBLE_MEAN`] of the static load (over any bounded steady motion the
    /// mean forces carry the torques; on rattling worn flanks a planet's mean was 0.2–2.2
    /// of it) and its extremes within [`PLAUSIBLE_PEAK`]. Newton on the balance can
    /// converge to a root that is not: on the worn example at 6 850 rpm and 18.75 N·m, from
    /// a march that had not settled, to mean forces of −1.4e19 times the static load.
    fn plausible(&self, p: &SteadyPoint) -> bool {
        let load = self.static_load.abs();
        p.meshes.iter().all(|m| {
            m.mean.abs() <= PLAUSIBLE_MEAN * load
                && m.max.abs().max(m.min.abs()).max(m.peak_pair.abs()) <= PLAUSIBLE_PEAK * load
        })
    }

    /// The orbit at `omega` [rad/s]: Newton from `neighbour`'s orbit, else from the state
    /// `march` (out of the neighbour's state) reaches, else cold. The march is left where
    /// it stopped.
    fn orbit(
        &mut self,
        omega: f64,
        neighbour: Option<&SteadyPoint>,
        march: &mut Option<March>,
        work: &mut Work,
    ) -> Result<(HarmonicOrbit, Found), PeriodicError> {
        let cb = &mut self.balance;
        if cb.symmetry() != Symmetry::Cyclic {
            cb.restore_symmetry(Symmetry::Cyclic, omega)?;
        }
        cb.arc_fit(omega)?;
        if let Some(x) = neighbour.and_then(|n| n.coordinates.as_ref()) {
            let x: Vec<f64> = x.iter().map(|&a| f64::from(a)).collect();
            let guess = cb.fitted(&x);
            if let Ok((orbit, report)) = cb.solve(omega, Some(&guess)) {
                work.newton_iterations += report.iterations as u64;
                work.rhs_evaluations += report.law_evaluations;
                return Ok((orbit, Found::Continued));
            }
            if cb.symmetry() != Symmetry::Cyclic {
                cb.restore_symmetry(Symmetry::Cyclic, omega)?;
            }
        }
        if let Some(m) = march.as_mut() {
            if m.run(cb.problem_mut(), omega, MARCH_PERIODS, work).is_ok() {
                // Shooting, the fallback of Newton from a marched state, only from a march
                // that settled: from one that did not (the budget spent, the teeth rattle)
                // it costs tens of seconds at low speed and does not converge.
                let r = match m.settled() {
                    true => cb.solve_from_state(omega, &m.z, work),
                    false => cb.solve_from_marched_period(omega, &m.z, work),
                };
                if let Ok(x) = r {
                    let mut evaluations = 0;
                    let orbit = cb.orbit_at(omega, &x, 0, &mut evaluations)?;
                    work.rhs_evaluations += evaluations;
                    return Ok((orbit, Found::Marched));
                }
            }
            if cb.symmetry() != Symmetry::Cyclic {
                cb.restore_symmetry(Symmetry::Cyclic, omega)?;
            }
        }
        let (orbit, report) = cb.solve(omega, None)?;
        work.newton_iterations += report.iterations as u64;
        work.rhs_evaluations += report.law_evaluations;
        Ok((orbit, Found::Cold))
    }

    /// The settled period of a march at `omega` [rad/s] going on from `march` (a
    /// neighbour's state, where a restart may have marched already; else the static
    /// state), at most [`COAST_MARCH_PERIODS`] and
    /// [`MARCH_STEPS`] in all: the steady state where the periodic solvers find none
    /// (the coast flanks, measured in docs/STEADY.md). Its `settled` is the last period's
    /// change.
    fn marched(
        &mut self,
        omega: f64,
        march: Option<March>,
        mut work: Work,
    ) -> Result<SteadyPoint, PeriodicError> {
        let problem = self.balance.problem_mut();
        // A period that does not integrate from the neighbour's state (on the worn example
        // at 4 925 rpm and 18.75 N·m the step size collapses at its start): the march starts
        // once more from the static state, within what is left of the budget.
        let from_static =
            |p: &PeriodicProblem, spent: u64| March { steps: spent, ..March::from(&p.static_start(omega)) };
        let failed = |e| PeriodicError::invalid("steady state", omega, &format!("the march failed: {e}"));
        let march = match march {
            Some(mut m) if !m.failed => {
                if m.run(problem, omega, COAST_MARCH_PERIODS, &mut work).is_err() {
                    m = from_static(problem, m.steps);
                    m.run(problem, omega, COAST_MARCH_PERIODS, &mut work).map_err(failed)?;
                }
                m
            }
            other => {
                let mut m = from_static(problem, other.map_or(0, |m| m.steps));
                m.run(problem, omega, COAST_MARCH_PERIODS, &mut work).map_err(failed)?;
                m
            }
        };
        let (z, change) = (march.z, march.change);
        let cycles = problem.cycles();
        let samples = self.samples_per_cycle * cycles;
        let (q, v, sampled, end) = problem.sampled_period(omega, &z, samples, &mut work)?;
        let force: Vec<Vec<f64>> = sampled.iter().map(|m| m.iter().map(|(f, _)| *f).collect()).collect();
        let peak: Vec<f64> =
            sampled.iter().map(|m| m.iter().map(|(_, p)| p.abs()).fold(0.0, f64::max)).collect();
        let period = problem.period(omega);
        let mut point =
            self.summarise(omega, (cycles, period), (q, v), (&force, &peak), Found::Marched, work)?;
        point.start = end;
        point.settled = change;
        Ok(point)
    }

    /// The outputs of `orbit`: its states at the level's samples and each mesh's forces
    /// over the period, read from the free model at the absolute states.
    fn point(
        &mut self,
        orbit: &HarmonicOrbit,
        found: Found,
        work: Work,
    ) -> Result<SteadyPoint, PeriodicError> {
        let omega = orbit.speed;
        let samples = self.samples_per_cycle * orbit.cycles;
        let (q, v) = self.balance.balance().frame_samples(orbit, samples, self.phase);
        let start = self.balance.balance().initial_unknowns(orbit);
        let coordinates = match self.balance.symmetry() {
            Symmetry::Cyclic => Some(self.balance.coordinates_of(orbit)?.iter().map(|&a| a as f32).collect()),
            Symmetry::Full => None,
        };
        let n = self.model.dim();
        let meshes = self.model.mesh_count();
        let rigid = self.model.rigid_velocity_at(omega);
        self.model.set_drive_speed(omega);
        let (mut qa, mut va, mut f) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let mut force = vec![Vec::with_capacity(samples); meshes];
        let mut peak = vec![0.0_f64; meshes];
        for j in 0..samples {
            let t = orbit.period * (j as f64 + self.phase) / samples as f64;
            for i in 0..n {
                qa[i] = q[j * n + i] + rigid[i] * t;
                va[i] = v[j * n + i] + rigid[i];
            }
            self.model.force(t, &qa, &va, &mut f);
            for (k, m) in self.model.meshes.iter().enumerate() {
                force[k].push(m.force);
                peak[k] = peak[k].max(m.peak_pair_force.abs());
            }
        }
        let mut point =
            self.summarise(omega, (orbit.cycles, orbit.period), (q, v), (&force, &peak), found, work)?;
        point.coordinates = coordinates;
        point.start = start;
        point.phase = self.phase;
        Ok(point)
    }

    /// A steady point from its samples over one period of `cycles` mesh cycles: relative
    /// states, each mesh's forces and largest tooth-pair force.
    fn summarise(
        &self,
        omega: f64,
        (cycles, period): (usize, f64),
        (q, v): (Vec<f64>, Vec<f64>),
        (force, peak): (&[Vec<f64>], &[f64]),
        found: Found,
        work: Work,
    ) -> Result<SteadyPoint, PeriodicError> {
        if force.iter().flatten().chain(peak).chain(&q).chain(&v).any(|x| !x.is_finite()) {
            return Err(PeriodicError::invalid(
                "steady state",
                omega,
                "its states or mesh forces are not finite",
            ));
        }
        let summary = |f: &Vec<f64>, peak: f64| MeshSummary {
            min: f.iter().copied().fold(f64::INFINITY, f64::min),
            max: f.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            mean: f.iter().sum::<f64>() / f.len() as f64,
            peak_pair: peak,
            separation: separation_fraction(f),
        };
        let spectrum = |k: usize| {
            mesh_harmonics(&force[k], cycles, 6)
                .map(|h| (h, separation_fraction(&force[k])))
                .map_err(|source| PeriodicError::Spectrum { speed: omega, source })
        };
        Ok(SteadyPoint {
            speed: omega,
            torque: self.torque,
            angle_period: omega * period,
            cycles,
            samples: self.samples_per_cycle * cycles,
            phase: 0.0,
            meshes: force.iter().zip(peak).map(|(f, p)| summary(f, *p)).collect(),
            window: [spectrum(0)?, spectrum(1)?],
            q: q.iter().map(|&a| a as f32).collect(),
            v: v.iter().map(|&a| a as f32).collect(),
            found,
            coordinates: None,
            start: Vec::new(),
            settled: 0.0,
            work,
        })
    }
}
