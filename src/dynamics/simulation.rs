//! A time-domain simulation of the planetary set between communication
//! points: the API the FMU (and any other co-simulation shell) drives.
//!
//! The caller owns time: `do_step(t, h)` checks that t is the current time
//! (to a rounding tolerance), takes ⌈h / h_nominal⌉ internal steps whose
//! times come from integer counts inside the interval, and lands exactly on
//! t + h. Inputs (torques, the speed reference) hold over a step. A step that
//! cannot be completed leaves the last good state and reports why; it never
//! returns a non-finite state.

use serde::{Deserialize, Serialize};

use std::collections::VecDeque;
use std::sync::OnceLock;

use crate::dynamics::duty::{input_torque_per_mesh_force, DutyBins, LoadDuty};
use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::response::{static_state, Stepper};
use crate::dynamics::solver::{RelativeOrigin, Rk45, Rk45Settings, SecondOrderSystem, SolverError};
use crate::dynamics::spectrum::{mesh_harmonics, separation_fraction, Harmonics};
use crate::dynamics::steady::point::MeshSummary;
use crate::dynamics::steady::{DriveInputs, SteadyEngine};
use crate::model::gear::{Drive, GearSet, IntegratorKind, Member, MeshKind};
use crate::model::lumped::{central_index, full_index, planet_bearing_vectors, Coordinate, Fidelity};
use crate::model::run::RunSettings;

/// Why a simulation step or setting was refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SimulationError {
    /// A value that cannot be used.
    #[error("{name} = {value}: {reason}")]
    InvalidInput {
        /// Name of the input or argument.
        name: String,
        /// Value.
        value: String,
        /// What is allowed.
        reason: String,
    },
    /// The step needed more work than its budget
    /// ([`WORK_PER_INTERNAL_STEP`] force evaluations per internal step at the
    /// nominal speed, plus [`WORK_BASE`]): the response has left the range the
    /// step was sized for (for example a run-away speed in an unstable
    /// coupling), and going on would take without bound.
    #[error(
        "step from t = {t} s stopped at t = {reached} s: the adaptive integrator used more than {budget} \
         force evaluations ({internal} internal steps of the nominal speed {nominal_speed} rad/s); \
         the input member turns at {speed} rad/s"
    )]
    WorkBudget {
        /// Start of the step \[s\].
        t: f64,
        /// Time reached \[s\].
        reached: f64,
        /// The budget [force evaluations].
        budget: u64,
        /// Internal steps of the communication step at the nominal speed.
        internal: u64,
        /// The speed the internal step was sized for [rad/s].
        nominal_speed: f64,
        /// The input member's speed when the budget ran out [rad/s].
        speed: f64,
    },
    /// The integrator could not complete the step.
    #[error("step from t = {t} s failed: {source}")]
    Integration {
        /// Start of the step \[s\].
        t: f64,
        /// The integrator's error.
        source: SolverError,
    },
}

/// Work budget of one communication step with the adaptive integrator:
/// force evaluations allowed per internal step at the nominal speed. The
/// default setting needs 10 to 80 (7 per step, 90 to 1300 steps per mesh
/// cycle against 120 internal steps), so this is a margin of 25 at least.
pub const WORK_PER_INTERNAL_STEP: u64 = 2000;
/// Force evaluations every communication step may use besides
/// [`WORK_PER_INTERNAL_STEP`] (short steps, restarts after input changes).
pub const WORK_BASE: u64 = 100_000;

/// A restorable snapshot of a simulation (plain data, no pointers).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    /// Time \[s\].
    pub time: f64,
    /// Coordinates.
    pub q: Vec<f64>,
    /// Velocities.
    pub v: Vec<f64>,
    /// The integrator's own state (generalized-α's algorithmic acceleration),
    /// so a restored run continues bit-identically.
    pub integrator: Vec<f64>,
    /// Torques on sun, ring, carrier [N·m].
    pub torques: [f64; 3],
    /// Speed reference of the speed drive [rad/s].
    pub speed_reference: f64,
    /// Harmonic window: planet 1's sun and ring mesh-force samples, oldest first \[N\].
    pub window_sun: Vec<f64>,
    /// See `window_sun`.
    pub window_ring: Vec<f64>,
    /// The window's last (travel \[m\], sun force \[N\], ring force \[N\]), if any.
    pub window_last: Vec<f64>,
    /// The speed drive's source state (empty for the torque drive).
    pub drive: Vec<f64>,
    /// The load duty's counts ([`LoadDuty::counts`]; empty when no duty is recorded).
    pub duty: Vec<f64>,
}

/// Order-tracked samples of planet 1's two mesh forces over the last mesh
/// cycles: a sample each time the sun mesh's travel crosses a multiple of
/// p_b / S (interpolated linearly between internal steps), so the window
/// holds whole mesh cycles whatever the speed and the communication step.
#[derive(Clone, Debug)]
struct Window {
    cycles: usize,
    samples_per_cycle: usize,
    spacing: f64,
    last: Option<(f64, f64, f64)>,
    sun: VecDeque<f64>,
    ring: VecDeque<f64>,
    collected: u64,
    /// The window's harmonics and separation fraction of each mesh (sun, ring), taken
    /// once per window content: an FMU reads them several times a step (its outputs and
    /// its separation check), each a spectrum of cycles × samples per cycle samples.
    harmonics: [OnceLock<Option<(Harmonics, f64)>>; 2],
}

impl Window {
    fn push(&mut self, s: f64, fs: f64, fr: f64) {
        let before = self.collected;
        self.push_samples(s, fs, fr);
        if self.collected != before {
            self.changed();
        }
    }

    /// Forgets the harmonics taken of the former content.
    fn changed(&mut self) {
        self.harmonics = Default::default();
    }

    fn push_samples(&mut self, s: f64, fs: f64, fr: f64) {
        if let Some((s0, fs0, fr0)) = self.last {
            let d = self.spacing;
            let mut add = |g: f64| {
                let w = if s != s0 { (g - s0) / (s - s0) } else { 1.0 };
                self.sun.push_back(fs0 + w * (fs - fs0));
                self.ring.push_back(fr0 + w * (fr - fr0));
                self.collected += 1;
            };
            // Only the last `cap` crossings can stay in the window: a jump
            // over more (a huge travel in one step) adds just those, so the
            // loop is bounded whatever the travel.
            let cap = self.cycles * self.samples_per_cycle;
            let bounded = |first: f64, last: f64| {
                let n = last - first + 1.0;
                if n >= 1.0 && n.is_finite() {
                    (first.max(last - (cap as f64 - 1.0)), n.min(cap as f64) as usize)
                } else {
                    (first, 0)
                }
            };
            if s > s0 {
                let (a, n) = bounded((s0 / d).floor() + 1.0, (s / d).floor());
                for j in 0..n {
                    add((a + j as f64) * d);
                }
            } else if s < s0 {
                let (b, n) = bounded(-((s0 / d).ceil() - 1.0), -(s / d).ceil());
                for j in 0..n {
                    add(-(b + j as f64) * d);
                }
            }
            while self.sun.len() > cap {
                self.sun.pop_front();
                self.ring.pop_front();
            }
        }
        self.last = Some((s, fs, fr));
    }

    fn full(&self) -> bool {
        self.sun.len() == self.cycles * self.samples_per_cycle
    }
}

/// The extremes of one mesh's forces over a communication step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshExtremes {
    /// Smallest mesh force \[N\] (0 if the mesh separated).
    pub min: f64,
    /// Largest mesh force \[N\].
    pub max: f64,
    /// Largest tooth-pair force in magnitude, on either flank \[N\].
    pub peak_pair: f64,
    /// Whether the mesh had no tooth pair in contact (a zero mesh force: the
    /// mesh separated) at one of the points.
    pub separated: bool,
}

impl MeshExtremes {
    fn at(m: &crate::dynamics::equations::MeshState) -> Self {
        Self { min: m.force, max: m.force, peak_pair: m.peak_pair_force, separated: m.force == 0.0 }
    }

    fn observe(&mut self, m: &crate::dynamics::equations::MeshState) {
        self.min = self.min.min(m.force);
        self.max = self.max.max(m.force);
        self.peak_pair = self.peak_pair.max(m.peak_pair_force);
        self.separated |= m.force == 0.0;
    }
}

/// The extremes of the mesh forces over one communication step, at every
/// point the step's integration passed through: the step's start, each
/// internal step end (the fixed-step integrator's steps; for the adaptive
/// one the internal grid points read from its dense output, both
/// `stepsPerMeshCycle` points per mesh cycle at the nominal speed) and the
/// step's end.
#[derive(Clone, Debug, PartialEq)]
pub struct StepExtremes {
    /// Per mesh, planet-major: planet 1's sun–planet mesh, its ring–planet
    /// mesh, planet 2's, …
    meshes: Vec<MeshExtremes>,
    /// Per mesh: the sum of the forces at the internal points after the step's start \[N\].
    sums: Vec<f64>,
    /// The internal points summed.
    samples: usize,
}

impl StepExtremes {
    /// The extremes of a single state's mesh forces (planet-major: sun, ring).
    fn at(meshes: &[crate::dynamics::equations::MeshState]) -> Self {
        let mut e = Self { meshes: Vec::new(), sums: Vec::new(), samples: 0 };
        e.reset(meshes);
        e
    }

    /// Starts again from a single state, keeping the allocation.
    fn reset(&mut self, meshes: &[crate::dynamics::equations::MeshState]) {
        self.meshes.clear();
        self.meshes.extend(meshes.iter().map(MeshExtremes::at));
        self.sums.clear();
        self.sums.resize(meshes.len(), 0.0);
        self.samples = 0;
    }

    /// The extremes and means of a steady state's meshes over its period.
    fn of_steady(&mut self, meshes: impl Iterator<Item = MeshSummary>) {
        self.meshes.clear();
        self.sums.clear();
        for m in meshes {
            self.meshes.push(MeshExtremes {
                min: m.min,
                max: m.max,
                peak_pair: m.peak_pair,
                separated: m.separation > 0.0,
            });
            self.sums.push(m.mean);
        }
        self.samples = 1;
    }

    fn observe(&mut self, meshes: &[crate::dynamics::equations::MeshState]) {
        for ((e, s), m) in self.meshes.iter_mut().zip(&mut self.sums).zip(meshes) {
            e.observe(m);
            *s += m.force;
        }
        self.samples += 1;
    }

    /// The mean force of planet `p`'s (0-based) mesh of kind `kind` over the step \[N\]: the
    /// mean of its values at the step's internal points after its start (equally spaced, so
    /// the time average to the grid's resolution); before a step, the force at the start.
    /// `None` beyond the number of planets.
    pub fn mean(&self, p: usize, kind: MeshKind) -> Option<f64> {
        let m = kind.of_planet(p);
        let extremes = self.meshes.get(m)?;
        Some(if self.samples == 0 { extremes.min } else { self.sums[m] / self.samples as f64 })
    }

    /// The extremes of planet `p`'s (0-based) mesh of kind `kind`; `None`
    /// beyond the number of planets.
    pub fn mesh(&self, p: usize, kind: MeshKind) -> Option<MeshExtremes> {
        self.meshes.get(kind.of_planet(p)).copied()
    }

    fn of_kind(&self, kind: MeshKind) -> impl Iterator<Item = &MeshExtremes> {
        self.meshes.iter().skip(kind.offset()).step_by(2)
    }

    /// The largest mesh force of any planet's mesh of kind `kind` \[N\] (0
    /// without planets).
    pub fn any_max(&self, kind: MeshKind) -> f64 {
        self.of_kind(kind).map(|e| e.max).fold(0.0, f64::max)
    }

    /// The largest tooth-pair force of any planet's mesh of kind `kind` \[N\].
    pub fn any_peak_pair(&self, kind: MeshKind) -> f64 {
        self.of_kind(kind).map(|e| e.peak_pair).fold(0.0, f64::max)
    }

    /// Whether any planet's mesh of kind `kind` separated at one of the points.
    pub fn any_separated(&self, kind: MeshKind) -> bool {
        self.of_kind(kind).any(|e| e.separated)
    }
}

/// Where a bearing force acts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bearing {
    /// The bearing of a central member.
    Member(Member),
    /// The bearing of planet `p` (0-based).
    Planet(usize),
}

/// A running simulation.
#[derive(Clone)]
pub struct Simulation {
    model: PlanetaryDynamics,
    stepper: Stepper,
    set: GearSet,
    run: RunSettings,
    time: f64,
    nominal_step: f64,
    /// Scale of the elastic coordinates: the largest static mesh deflection
    /// \[m\] ([`stepper_for`]).
    deflection: f64,
    torques: [f64; 3],
    speed_reference: f64,
    window: Window,
    extremes: StepExtremes,
    /// The load duty recorded at each communication step, when asked for
    /// ([`Simulation::record_duty`]).
    duty: Option<LoadDuty>,
    /// The `steady` response's rigid-body rotation and steady states, when asked for
    /// ([`Simulation::use_steady`]): the stepper is then not used.
    steady: Option<Box<SteadyEngine>>,
}

const TIME_TOLERANCE: f64 = 1e-9;

/// The integrator of a simulation at mesh frequency `fm` \[Hz\]:
/// generalized-α as [`Stepper::new`] sets it; the adaptive method at the
/// run's simulation relative tolerance
/// ([`RunSettings::simulation_relative_tolerance`]) with absolute
/// tolerances that relative tolerance times the elastic state's scales,
/// the static mesh deflection `deflection` \[m\] for coordinates and that
/// times the mesh angular frequency for velocities (as the periodic solver
/// scales them), its largest step a quarter of a mesh cycle. The relative
/// part of the error weight is measured from the rigid-body motion of the
/// communication step ([`Simulation::anchor_origin`]), so it controls the
/// rotations' deviation from that motion, not the angle turned since the
/// start (which grows without bound and made the allowance grow with time:
/// docs/PERFORMANCE.md). The translations of the transverse–torsional
/// model, as small as the deflections, are controlled by the absolute
/// part, which fixed absolute tolerances of 1e-6 m and 1e-3 m/s per unit
/// of relative tolerance made some 20 times tighter than the deflection
/// needs.
fn stepper_for(run: &RunSettings, fm: f64, deflection: f64) -> Result<Stepper, SolverError> {
    let d = run.values();
    match d.integrator {
        IntegratorKind::Rk45 => {
            let rtol = d.simulation_relative_tolerance;
            let settings = Rk45Settings {
                rtol,
                atol_q: rtol * deflection,
                atol_v: rtol * deflection * 2.0 * std::f64::consts::PI * fm,
                max_step: 0.25 / fm,
                ..Rk45Settings::default()
            };
            Ok(Stepper::Rk(Box::new(Rk45::new(settings)?)))
        }
        IntegratorKind::GeneralizedAlpha => Stepper::new(run, 1.0 / fm),
    }
}

/// Sets the adaptive method's error-weight origin to the rigid-body motion
/// at input speed `speed` \[rad/s\] through displacements `q` at time `t`
/// \[s\] (see [`Simulation::anchor_origin`]); a no-op for generalized-α.
fn anchor(
    stepper: &mut Stepper,
    model: &PlanetaryDynamics,
    speed: f64,
    t: f64,
    q: &[f64],
) -> Result<(), SolverError> {
    match stepper {
        Stepper::Rk(r) => r.set_relative_origin(Some(RelativeOrigin {
            t_anchor: t,
            q_anchor: q.to_vec(),
            rate: model.rigid_velocity_at(if speed.is_finite() { speed } else { 0.0 }),
        })),
        Stepper::Alpha(_) => Ok(()),
    }
}

/// Most internal steps one communication step may take: about a minute of
/// work at the default settings, hundreds of thousands of mesh cycles. A
/// longer step (1e20 s, or any step at an absurd speed or step count) is
/// refused at once instead of running for ever.
pub const MAX_INTERNAL_STEPS: u64 = 10_000_000;

impl Simulation {
    /// Starts at time `t0` \[s\] from the static deflection with the input
    /// member turning at `input_speed` [rad/s]; internal steps follow the
    /// run settings' steps per mesh cycle at that speed.
    pub fn new(
        set: &GearSet,
        run: &RunSettings,
        model: PlanetaryDynamics,
        t0: f64,
        input_speed: f64,
    ) -> Result<Self, SimulationError> {
        let invalid = |name: &str, value: f64, reason: &str| SimulationError::InvalidInput {
            name: name.into(),
            value: value.to_string(),
            reason: reason.into(),
        };
        if !t0.is_finite() {
            return Err(invalid("t0", t0, "must be finite"));
        }
        if !(input_speed.is_finite() && input_speed != 0.0) {
            return Err(invalid("input speed", input_speed, "must be finite and non-zero"));
        }
        let fm = model.mesh_frequency_per_input_speed * input_speed.abs();
        let nominal_step = 1.0 / (fm * run.steps_per_mesh_cycle() as f64);
        let mut model = model;
        let start = static_state(&model, input_speed);
        let torques = set.balanced_torques();
        model.set_torques(torques[0], torques[1], torques[2]);
        model.set_drive_speed(input_speed);
        model.rebase_drive(&start.q);
        let err = |source| SimulationError::Integration { t: t0, source };
        let mut f = vec![0.0; model.dim()];
        model.force(t0, &start.q, &start.v, &mut f);
        let deflection = model.meshes.iter().fold(0.0_f64, |a, m| a.max(m.approach.abs()));
        let deflection = if deflection > 0.0 { deflection } else { 1e-6 };
        let mut stepper = stepper_for(run, fm, deflection).map_err(err)?;
        anchor(&mut stepper, &model, input_speed, t0, &start.q).map_err(err)?;
        stepper.init(&mut model, t0, &start.q, &start.v).map_err(err)?;
        // The outputs at t0 are the initial state's, not a trial state's of
        // the integrator's start.
        model.force(t0, &start.q, &start.v, &mut f);
        let extremes = StepExtremes::at(&model.meshes);
        Ok(Self {
            extremes,
            duty: None,
            steady: None,
            model,
            stepper,
            set: set.clone(),
            run: *run,
            time: t0,
            nominal_step,
            deflection,
            torques,
            speed_reference: input_speed,
            window: Window {
                cycles: 34,
                samples_per_cycle: run.samples_per_mesh_cycle(),
                spacing: set.sun().base_pitch() / run.samples_per_mesh_cycle() as f64,
                last: None,
                sun: VecDeque::new(),
                ring: VecDeque::new(),
                collected: 0,
                harmonics: Default::default(),
            },
        })
    }

    /// Sets the window of the harmonic outputs: `cycles` mesh cycles of
    /// `samples_per_cycle` samples (the window restarts).
    pub fn set_window(&mut self, cycles: usize, samples_per_cycle: usize) -> Result<(), SimulationError> {
        if !(1..=10_000).contains(&cycles) {
            return Err(SimulationError::InvalidInput {
                name: "harmonicWindowCycles".into(),
                value: cycles.to_string(),
                reason: "must be between 1 and 10000".into(),
            });
        }
        if !(16..=10_000).contains(&samples_per_cycle) {
            return Err(SimulationError::InvalidInput {
                name: "samplesPerMeshCycle".into(),
                value: samples_per_cycle.to_string(),
                reason: "must be between 16 and 10000 (harmonic 6 needs more than 12)".into(),
            });
        }
        self.window.cycles = cycles;
        self.window.samples_per_cycle = samples_per_cycle;
        self.window.spacing = self.set.sun().base_pitch() / samples_per_cycle as f64;
        self.window.sun.clear();
        self.window.ring.clear();
        self.window.collected = 0;
        self.window.changed();
        Ok(())
    }

    /// Current time \[s\].
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Sets the torques on sun, ring and carrier [N·m] for the next steps.
    pub fn set_torques(&mut self, sun: f64, ring: f64, carrier: f64) -> Result<(), SimulationError> {
        for (name, v) in [("sunTorque", sun), ("ringTorque", ring), ("carrierTorque", carrier)] {
            if !v.is_finite() {
                return Err(SimulationError::InvalidInput {
                    name: name.into(),
                    value: v.to_string(),
                    reason: "must be finite".into(),
                });
            }
        }
        if self.torques == [sun, ring, carrier] {
            return Ok(());
        }
        self.torques = [sun, ring, carrier];
        self.model.set_torques(sun, ring, carrier);
        if self.steady.is_some() {
            // The rigid-body rotation reads them at the next step.
            return Ok(());
        }
        let t = self.time;
        self.stepper
            .forces_changed(&mut self.model)
            .map_err(|source| SimulationError::Integration { t, source })?;
        let mut f = vec![0.0; self.model.dim()];
        self.refresh(&mut f);
        Ok(())
    }

    /// Sets the input speed reference [rad/s]. Under the speed drive the
    /// shaft's source turns at it from now on; under [`Drive::SpeedSteps`] a
    /// new reference steps the rigid-body speed to it (the elastic state is
    /// kept); under the torque drive it is only recorded. With the speed
    /// drive and the speed steps the internal step follows the reference, so
    /// a step count per mesh cycle holds at every speed.
    pub fn set_speed_reference(&mut self, omega: f64) -> Result<(), SimulationError> {
        let invalid = |reason: &str| SimulationError::InvalidInput {
            name: "inputSpeedReference".into(),
            value: omega.to_string(),
            reason: reason.into(),
        };
        if !omega.is_finite() {
            return Err(invalid("must be finite"));
        }
        if omega == self.speed_reference {
            return Ok(());
        }
        if self.steady.is_some() {
            if self.set.drive() == Drive::SpeedSteps && omega == 0.0 {
                return Err(invalid("must be non-zero with driveMode 2 (speed steps)"));
            }
            // The rigid-body rotation follows it from the next step (docs/STEADY.md).
            self.speed_reference = omega;
            return Ok(());
        }
        match self.set.drive() {
            Drive::Torque if !self.model.has_load_balance() => self.speed_reference = omega,
            Drive::Torque => {
                // The load balance's source follows the reference.
                self.speed_reference = omega;
                self.model.change_drive_speed(omega, self.time);
                let t = self.time;
                self.stepper
                    .forces_changed(&mut self.model)
                    .map_err(|source| SimulationError::Integration { t, source })?;
            }
            Drive::Speed => {
                self.speed_reference = omega;
                self.model.change_drive_speed(omega, self.time);
                if let Some(mut stepper) = self.retuned_stepper(omega)? {
                    // Continue from the current state, integrator state included.
                    let t = self.time;
                    let (q, v) = self.stepper.state();
                    let internal = self.stepper.internal();
                    stepper
                        .restore(&mut self.model, t, q, v, &internal)
                        .map_err(|source| SimulationError::Integration { t, source })?;
                    self.stepper = stepper;
                }
            }
            Drive::SpeedSteps => {
                if omega == 0.0 {
                    return Err(invalid("must be non-zero with driveMode 2 (speed steps)"));
                }
                let (q, v) = self.stepper.state();
                let q = q.to_vec();
                let dv = omega - self.speed_reference;
                let v: Vec<f64> = v.iter().zip(&self.model.rigid_velocity).map(|(v, r)| v + r * dv).collect();
                self.speed_reference = omega;
                self.model.set_frame_speed(omega);
                if let Some(stepper) = self.retuned_stepper(omega)? {
                    self.stepper = stepper;
                }
                let t = self.time;
                anchor(&mut self.stepper, &self.model, omega, t, &q)
                    .and_then(|()| self.stepper.init(&mut self.model, t, &q, &v))
                    .map_err(|source| SimulationError::Integration { t, source })?;
            }
        }
        // Starting an integrator may evaluate the model at trial states (the
        // adaptive method's first-step estimate): the outputs are the
        // accepted state's.
        let mut f = vec![0.0; self.model.dim()];
        self.refresh(&mut f);
        Ok(())
    }

    /// Sets the internal step for input speed `omega` [rad/s] and returns a
    /// new, not yet started integrator for it; `None` at zero speed (step and
    /// integrator unchanged). The caller starts it from the state it needs.
    fn retuned_stepper(&mut self, omega: f64) -> Result<Option<Stepper>, SimulationError> {
        let fm = self.model.mesh_frequency_per_input_speed * omega.abs();
        if !(fm.is_finite() && fm > 0.0) {
            return Ok(None);
        }
        self.nominal_step = 1.0 / (fm * self.run.steps_per_mesh_cycle() as f64);
        let t = self.time;
        stepper_for(&self.run, fm, self.deflection)
            .map(Some)
            .map_err(|source| SimulationError::Integration { t, source })
    }

    /// Advances from `t` (which must be the current time) by `h` > 0 \[s\].
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<(), SimulationError> {
        if !(h.is_finite() && h > 0.0) {
            return Err(SimulationError::InvalidInput {
                name: "communicationStepSize".into(),
                value: h.to_string(),
                reason: "must be finite and greater than zero".into(),
            });
        }
        if !t.is_finite() || (t - self.time).abs() > TIME_TOLERANCE * self.time.abs().max(h).max(1.0) {
            return Err(SimulationError::InvalidInput {
                name: "currentCommunicationPoint".into(),
                value: t.to_string(),
                reason: format!("must be the current time {} s", self.time),
            });
        }
        if self.steady.is_some() {
            return self.steady_step(t, h);
        }
        let steps = ((h / self.nominal_step) - 1e-9).ceil().max(1.0);
        // Also catches a non-finite or zero nominal step (NaN fails the test).
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(steps <= MAX_INTERNAL_STEPS as f64) {
            return Err(SimulationError::InvalidInput {
                name: "communicationStepSize".into(),
                value: h.to_string(),
                reason: format!(
                    "needs {steps:.3e} internal steps of {:.3e} s, more than the {MAX_INTERNAL_STEPS} one \
                     communication step may take: take steps of at most {:.3e} s",
                    self.nominal_step,
                    self.nominal_step * MAX_INTERNAL_STEPS as f64
                ),
            });
        }
        let steps = steps as u64;
        // The caller's communication point is the time base (it was checked
        // to be the current time), so no rounding accumulates across steps.
        let start = t;
        let end = start + h;
        let mut f = vec![0.0; self.model.dim()];
        let n = self.model.dim();
        let (mut q_dense, mut v_dense) = (vec![0.0; n], vec![0.0; n]);
        let budget = WORK_BASE + WORK_PER_INTERNAL_STEP * steps;
        let nominal_speed = 1.0
            / (self.nominal_step
                * self.run.steps_per_mesh_cycle() as f64
                * self.model.mesh_frequency_per_input_speed);
        // The extremes start from the state at t (the last accepted one).
        self.extremes.reset(&self.model.meshes);
        let input_angle = self.angle(self.set.input());
        self.anchor_origin().map_err(|source| SimulationError::Integration { t, source })?;
        let work_start = match &self.stepper {
            Stepper::Rk(r) => r.stats().rhs_evaluations,
            Stepper::Alpha(_) => 0,
        };
        for k in 1..=steps {
            // Internal step ends from integer counts; the last is exactly t + h.
            let tk = if k == steps { end } else { start + h * (k as f64) / (steps as f64) };
            let advanced = match &mut self.stepper {
                // The adaptive method takes its own steps up to the
                // communication point; the internal grid times inside them
                // are read from its dense output (forcing step ends onto
                // them would cost steps and change nothing it controls). Its
                // work is bounded per communication step.
                Stepper::Rk(r) => {
                    let mut result = Ok(());
                    while r.time() < tk {
                        let used = r.stats().rhs_evaluations - work_start;
                        if used > budget {
                            let reached = r.time();
                            let speed = r.v()[self.model.input_index] / self.model.input_lever;
                            self.time = reached;
                            self.refresh(&mut f);
                            return Err(SimulationError::WorkBudget {
                                t,
                                reached,
                                budget,
                                internal: steps,
                                nominal_speed,
                                speed,
                            });
                        }
                        result = r.step(&mut self.model, end);
                        if result.is_err() {
                            break;
                        }
                    }
                    result.and_then(|()| {
                        if r.time() == tk {
                            q_dense.copy_from_slice(r.q());
                            v_dense.copy_from_slice(r.v());
                            Ok(())
                        } else {
                            r.dense_at(tk, &mut q_dense, &mut v_dense)
                        }
                    })
                }
                stepper => stepper.advance(&mut self.model, tk, 1).map(|()| {
                    let (q, v) = stepper.state();
                    q_dense.copy_from_slice(q);
                    v_dense.copy_from_slice(v);
                }),
            };
            if let Err(source) = advanced {
                // Keep the last good state's time and mesh outputs.
                self.time = self.stepper_time();
                self.refresh(&mut f);
                return Err(SimulationError::Integration { t: self.time, source });
            }
            self.model.force(tk, &q_dense, &v_dense, &mut f);
            let m = &self.model.meshes;
            self.extremes.observe(m);
            if m.len() >= 2 {
                self.window.push(m[0].position, m[0].force, m[1].force);
            }
        }
        self.time = end;
        // The outputs read the accepted state at the communication point.
        self.refresh(&mut f);
        self.record_step(input_angle, h)
    }

    /// Switches to the `steady` response (docs/STEADY.md): from now on a step integrates the
    /// rigid-body rotation and takes the tooth outputs from the periodic steady state at its
    /// speed and mesh load, cached on the grid of the run settings' steady values. The first steady state
    /// (at the current speed reference and the set's torques) is solved here.
    ///
    /// With `shared_key` the cache is shared with every later simulation of the same key in
    /// this process ([`crate::dynamics::steady::SHARED_CACHES`]): the key must stand for
    /// everything the steady states depend on (the gear set, its worn state, the run settings).
    pub fn use_steady(&mut self, shared_key: Option<u64>) -> Result<(), SimulationError> {
        let settings = *self.run.steady();
        let engine = SteadyEngine::new(
            settings,
            &self.model,
            &self.set,
            self.speed_reference,
            self.run.samples_per_mesh_cycle(),
            shared_key,
        )
        .map_err(|e| SimulationError::InvalidInput {
            name: "steady response".into(),
            value: format!("{} rad/s", self.speed_reference),
            reason: e.to_string(),
        })?;
        self.extremes.of_steady((0..self.model.mesh_count()).map(|k| engine.blend().mesh(k)));
        self.steady = Some(Box::new(engine));
        let mut f = vec![0.0; self.model.dim()];
        self.refresh(&mut f);
        Ok(())
    }

    /// The `steady` response's engine, when on.
    pub fn steady(&self) -> Option<&SteadyEngine> {
        self.steady.as_deref()
    }

    /// [`Self::do_step`] of the `steady` response.
    fn steady_step(&mut self, t: f64, h: f64) -> Result<(), SimulationError> {
        let input_angle = self.angle(self.set.input());
        let engine = self.steady.as_mut().expect("steady response");
        let inputs = DriveInputs { torques: self.torques, reference: self.speed_reference };
        engine.advance(&self.model, inputs, h).map_err(|e| SimulationError::InvalidInput {
            name: "steady response".into(),
            value: format!("t = {t} s"),
            reason: e.to_string(),
        })?;
        let meshes = self.model.mesh_count();
        self.extremes.of_steady((0..meshes).map(|k| engine.blend().mesh(k)));
        self.time = t + h;
        let mut f = vec![0.0; self.model.dim()];
        self.refresh(&mut f);
        self.record_step(input_angle, h)
    }

    /// Records the load duty of the step of `h` \[s\] just taken from the input angle
    /// `input_angle` \[rad\] at its start ([`crate::dynamics::duty`]): each mesh's mean force
    /// over the step as the input torque it balances, the input's mean speed and the
    /// revolutions it turned.
    fn record_step(&mut self, input_angle: f64, h: f64) -> Result<(), SimulationError> {
        let turned = self.angle(self.set.input()) - input_angle;
        let Some(duty) = &mut self.duty else { return Ok(()) };
        let per_newton = input_torque_per_mesh_force(&self.set);
        let (time, extremes) = (self.time, &self.extremes);
        let torques: Vec<f64> = (0..duty.planets())
            .flat_map(|p| MeshKind::ALL.map(|kind| extremes.mean(p, kind).unwrap_or(f64::NAN) * per_newton))
            .collect();
        duty.record(&torques, turned / h, turned.abs() / std::f64::consts::TAU, h).map_err(|e| {
            SimulationError::InvalidInput {
                name: "load duty".into(),
                value: format!("t = {time} s"),
                reason: e.to_string(),
            }
        })
    }

    /// Records the load duty on `bins` from the next communication step on (from zero).
    pub fn record_duty(&mut self, bins: DutyBins) {
        self.duty = Some(LoadDuty::new(bins, self.set.planet_angles().len()));
    }

    /// The load duty recorded since [`Self::record_duty`] (`None` when not asked for).
    pub fn duty(&self) -> Option<&LoadDuty> {
        self.duty.as_ref()
    }

    /// Anchors the adaptive method's error weight at the accepted state:
    /// during the communication step its relative part measures each
    /// coordinate's change beyond the rigid-body motion at the current speed,
    /// o_q(t) = q(t_k) + r·ω·(t − t_k), o_v = r·ω (r the rigid-body velocity
    /// per unit input speed, ω the speed reference, or under the plain torque
    /// drive, which does not follow the reference, the input member's speed
    /// at t_k). A no-op for generalized-α.
    fn anchor_origin(&mut self) -> Result<(), SolverError> {
        let Stepper::Rk(r) = &self.stepper else {
            return Ok(());
        };
        let speed = if self.set.drive() == Drive::Torque && !self.model.has_load_balance() {
            r.v()[self.model.input_index] / self.model.input_lever
        } else {
            self.speed_reference
        };
        let (t, q) = (r.time(), r.q().to_vec());
        anchor(&mut self.stepper, &self.model, speed, t, &q)
    }

    /// The accepted state: the steady response's, else the integrator's.
    fn state(&self) -> (&[f64], &[f64]) {
        match &self.steady {
            Some(engine) => engine.state(),
            None => self.stepper.state(),
        }
    }

    fn stepper_time(&self) -> f64 {
        self.stepper.time()
    }

    /// Re-evaluates the meshes at the accepted state (a cache hit when the
    /// integrator's last evaluation was that state).
    fn refresh(&mut self, f: &mut [f64]) {
        let (q, v) = match &self.steady {
            Some(engine) => engine.state(),
            None => self.stepper.state(),
        };
        self.model.force(self.time, q, v, f);
    }

    /// Torque the input member receives [N·m]: from its shaft in the speed
    /// drive, else its input torque.
    pub fn input_torque(&self) -> f64 {
        if let Some(engine) = &self.steady {
            return engine.input_torque();
        }
        let (q, v) = self.state();
        match self.model.shaft_torque(self.time, q, v) {
            Some(t) => t,
            None => match self.set.input() {
                Member::Sun => self.torques[0],
                Member::Ring => self.torques[1],
                Member::Carrier => self.torques[2],
            },
        }
    }

    /// The extremes of the mesh forces over the last communication step
    /// ([`StepExtremes`]; before the first step, and after a restore until
    /// the next step, those of the current state alone).
    pub fn step_extremes(&self) -> &StepExtremes {
        &self.extremes
    }

    /// Torque the support exerts on the held member [N·m], counter-clockwise
    /// positive, at the current state
    /// ([`PlanetaryDynamics::reaction_torque`]).
    pub fn reaction_torque(&self) -> f64 {
        let (q, v) = self.state();
        self.model.reaction_torque(q, v)
    }

    /// Torque of the load balance's speed controller on the output member
    /// [N·m], counter-clockwise positive; 0 without the load balance.
    pub fn balancing_torque(&self) -> f64 {
        if let Some(engine) = &self.steady {
            return engine.balancing_torque();
        }
        let (q, v) = self.state();
        self.model.balancing_torque(self.time, q, v).unwrap_or(0.0)
    }

    /// Tooth pairs carrying load in a mesh of planet `p`.
    pub fn pairs_in_contact(&self, p: usize, mesh: MeshKind) -> u32 {
        let Some(state) = self.mesh_state(p, mesh) else { return 0 };
        let mut pairs = Vec::new();
        // A deformable solve fails only on a non-finite state, which the stepper refuses first.
        let _ = self.model.mesh_model(mesh).pairs(state.position, state.approach, &mut pairs);
        pairs.iter().filter(|c| c.force != 0.0).count() as u32
    }

    /// Force \[N\] of the tracked tooth pair of planet 1's mesh: the pair of
    /// gear 1's tooth 0 (sun tooth 0, or planet tooth 0 in the ring mesh),
    /// which comes round once per revolution of that gear relative to the
    /// carrier.
    pub fn tracked_pair_force(&self, mesh: MeshKind) -> f64 {
        let Some(state) = self.mesh_state(0, mesh) else { return 0.0 };
        let model = self.model.mesh_model(mesh);
        let teeth = match mesh {
            MeshKind::SunPlanet => self.set.sun().teeth,
            MeshKind::RingPlanet => self.set.planet().teeth,
        };
        let period = f64::from(teeth) * model.path().base_pitch;
        let start = model.table_start();
        let pos = start + (state.position - start).rem_euclid(period);
        model.pair_force(pos, state.approach).unwrap_or(f64::NAN)
    }

    /// Static transmission error \[m\]: the approach of a mesh of planet `p` at
    /// its current position under the scene's mean tooth force.
    pub fn static_transmission_error(&self, p: usize, mesh: MeshKind) -> f64 {
        let Some(state) = self.mesh_state(p, mesh) else { return 0.0 };
        self.model
            .mesh_model(mesh)
            .approach_for(state.position, self.set.mesh_load_per_planet())
            .unwrap_or(f64::NAN)
    }

    /// Magnitude of a bearing's elastic force \[N\] (central members: 0 in the
    /// torsional model, where they have no translations).
    pub fn bearing_force(&self, bearing: Bearing) -> f64 {
        let (q, _) = self.state();
        let full = self.model.full_coordinates(q);
        let lumped = &self.model.lumped;
        match bearing {
            Bearing::Member(m) => {
                if lumped.fidelity == Fidelity::Torsional {
                    return 0.0;
                }
                let j = central_index(m);
                let (x, y) = (full[full_index(Coordinate::X(m))], full[full_index(Coordinate::Y(m))]);
                lumped.central_bearing[j] * x.hypot(y)
            }
            Bearing::Planet(p) if p < lumped.planet_angles.len() => {
                if lumped.fidelity == Fidelity::Torsional {
                    return 0.0;
                }
                let n = lumped.planet_angles.len();
                let [radial, tangential] = planet_bearing_vectors(n, p, lumped.planet_angles[p]);
                let dot = |b: &[f64]| b.iter().zip(&full).map(|(a, c)| a * c).sum::<f64>();
                lumped.planet_bearing_of(p) * dot(&radial).hypot(dot(&tangential))
            }
            Bearing::Planet(_) => 0.0,
        }
    }

    /// Whole mesh cycles in the harmonic window so far (at most its length).
    pub fn window_cycles(&self) -> usize {
        if self.steady.is_some() {
            return self.window.cycles;
        }
        self.window.sun.len() / self.window.samples_per_cycle
    }

    /// The separation fraction of planet 1's mesh force over the window, once the window
    /// is full: [`Self::window_harmonics`]' second value (`None` where it gives none),
    /// without the spectrum, which a reader of the separation alone (the FMU's check at
    /// every step) does not need.
    pub fn window_separation(&self, mesh: MeshKind) -> Option<f64> {
        if self.steady.is_some() {
            return self.window_harmonics(mesh).map(|(_, s)| s);
        }
        if !self.window.full() {
            return None;
        }
        let k = usize::from(mesh == MeshKind::RingPlanet);
        if let Some(taken) = self.window.harmonics[k].get() {
            return taken.as_ref().map(|(_, s)| *s);
        }
        let data = match mesh {
            MeshKind::SunPlanet => &self.window.sun,
            MeshKind::RingPlanet => &self.window.ring,
        };
        // The spectrum refuses a window with a non-finite sample, and so gives no fraction.
        if !data.iter().all(|f| f.is_finite()) {
            return None;
        }
        Some(separation_fraction(data))
    }

    /// Harmonics 1..6 and separation fraction of planet 1's mesh force over
    /// the window, once the window is full.
    pub fn window_harmonics(&self, mesh: MeshKind) -> Option<(Harmonics, f64)> {
        if let Some(engine) = &self.steady {
            return Some(engine.blend().window(mesh.offset()));
        }
        if !self.window.full() {
            return None;
        }
        let k = usize::from(mesh == MeshKind::RingPlanet);
        let taken = self.window.harmonics[k].get_or_init(|| {
            let data: Vec<f64> = match mesh {
                MeshKind::SunPlanet => self.window.sun.iter().copied().collect(),
                MeshKind::RingPlanet => self.window.ring.iter().copied().collect(),
            };
            let h = mesh_harmonics(&data, self.window.cycles, 6).ok()?;
            Some((h, separation_fraction(&data)))
        });
        taken.clone()
    }

    fn rotation(&self, m: Member, rate: bool) -> f64 {
        let (index, lever) = self.model.rotations[central_index(m)];
        let (q, v) = self.state();
        index.map_or(0.0, |i| (if rate { v[i] } else { q[i] }) / lever)
    }

    /// Angular speed of a member [rad/s] (0 when held).
    pub fn speed(&self, m: Member) -> f64 {
        self.rotation(m, true)
    }

    /// Rotation of a member since the start \[rad\] (0 when held).
    pub fn angle(&self, m: Member) -> f64 {
        self.rotation(m, false)
    }

    /// Mesh force of one mesh of planet `p` \[N\] (0 for a planet that does not exist).
    pub fn mesh_force(&self, p: usize, mesh: MeshKind) -> f64 {
        self.mesh_state(p, mesh).map_or(0.0, |s| s.force)
    }

    /// Dynamic transmission error (approach along the line of action) of a mesh of planet `p` \[m\].
    pub fn transmission_error(&self, p: usize, mesh: MeshKind) -> f64 {
        self.mesh_state(p, mesh).map_or(0.0, |s| s.approach)
    }

    fn mesh_state(&self, p: usize, mesh: MeshKind) -> Option<crate::dynamics::equations::MeshState> {
        let i = mesh.of_planet(p);
        (i < self.model.mesh_count()).then(|| self.model.meshes[i])
    }

    /// A restorable snapshot.
    pub fn snapshot(&self) -> Snapshot {
        let (q, v) = self.state();
        Snapshot {
            time: self.time,
            q: q.to_vec(),
            v: v.to_vec(),
            integrator: match &self.steady {
                Some(engine) => engine.internal(),
                None => self.stepper.internal(),
            },
            torques: self.torques,
            speed_reference: self.speed_reference,
            window_sun: self.window.sun.iter().copied().collect(),
            window_ring: self.window.ring.iter().copied().collect(),
            window_last: self.window.last.map_or(Vec::new(), |(a, b, c)| vec![a, b, c]),
            drive: self.model.drive_state(),
            duty: self.duty.as_ref().map_or_else(Vec::new, LoadDuty::counts),
        }
    }

    /// Restores a snapshot taken from a simulation of the same gear set.
    pub fn restore(&mut self, s: &Snapshot) -> Result<(), SimulationError> {
        let n = self.model.dim();
        if s.q.len() != n || s.v.len() != n || s.q.iter().chain(&s.v).any(|x| !x.is_finite()) {
            return Err(SimulationError::InvalidInput {
                name: "snapshot".into(),
                value: format!("{} coordinates", s.q.len()),
                reason: format!("must hold {n} finite coordinates and velocities of this model"),
            });
        }
        // Every number is checked before anything changes: a snapshot read
        // from bytes (a forged or damaged blob with a valid checksum) must not
        // bring a NaN or an infinity into the state.
        let parts: [(&str, &[f64]); 8] = [
            ("time", std::slice::from_ref(&s.time)),
            ("integrator state", &s.integrator),
            ("torques", &s.torques),
            ("speed reference", std::slice::from_ref(&s.speed_reference)),
            ("harmonic window (sun mesh)", &s.window_sun),
            ("harmonic window (ring mesh)", &s.window_ring),
            ("harmonic window (last point)", &s.window_last),
            ("speed drive state", &s.drive),
        ];
        for (part, values) in parts {
            if let Some((i, x)) = values.iter().enumerate().find(|(_, x)| !x.is_finite()) {
                return Err(SimulationError::InvalidInput {
                    name: "snapshot".into(),
                    value: format!("{part}[{i}] = {x}"),
                    reason: "every number of a state must be finite".into(),
                });
            }
        }
        if let Some(duty) = &mut self.duty {
            // Checked (length, finite, non-negative) before it changes anything else.
            let mut restored = duty.clone();
            restored.set_counts(&s.duty).map_err(|e| SimulationError::InvalidInput {
                name: "snapshot".into(),
                value: format!("load duty of {} counts", s.duty.len()),
                reason: format!("{e}: the state was saved with other duty bins"),
            })?;
            *duty = restored;
        }
        self.set_torques(s.torques[0], s.torques[1], s.torques[2])?;
        self.speed_reference = s.speed_reference;
        self.model.set_drive_state(&s.drive);
        // The carrier frame turns at the reference's carrier speed wherever
        // the reference moves the dynamics (not under the plain torque drive).
        if self.set.drive() != Drive::Torque || self.model.has_load_balance() {
            self.model.set_frame_speed(s.speed_reference);
        }
        if let Some(engine) = &mut self.steady {
            let inputs = DriveInputs { torques: self.torques, reference: self.speed_reference };
            engine.restore(&self.model, (&s.q, &s.v, &s.integrator), inputs).map_err(|e| {
                SimulationError::InvalidInput {
                    name: "snapshot".into(),
                    value: format!(
                        "input speed {} rad/s",
                        s.v[self.model.input_index] / self.model.input_lever
                    ),
                    reason: format!("no steady state there: {e}"),
                }
            })?;
        } else {
            if self.set.drive() != Drive::Torque {
                // The internal step follows the reference (see `set_speed_reference`).
                if let Some(stepper) = self.retuned_stepper(s.speed_reference)? {
                    self.stepper = stepper;
                }
            }
            self.stepper
                .restore(&mut self.model, s.time, &s.q, &s.v, &s.integrator)
                .map_err(|source| SimulationError::Integration { t: s.time, source })?;
        }
        self.time = s.time;
        let mut f = vec![0.0; n];
        self.model.force(s.time, &s.q, &s.v, &mut f);
        self.extremes = StepExtremes::at(&self.model.meshes);
        if let Some(engine) = &self.steady {
            let meshes = self.model.mesh_count();
            self.extremes.of_steady((0..meshes).map(|k| engine.blend().mesh(k)));
            self.refresh(&mut f);
        }
        let cap = self.window.cycles * self.window.samples_per_cycle;
        if s.window_sun.len() == s.window_ring.len() && s.window_sun.len() <= cap {
            self.window.sun = s.window_sun.iter().copied().collect();
            self.window.ring = s.window_ring.iter().copied().collect();
            self.window.last = match s.window_last.as_slice() {
                [a, b, c] => Some((*a, *b, *c)),
                _ => None,
            };
        } else {
            self.window.sun.clear();
            self.window.ring.clear();
            self.window.last = None;
        }
        self.window.changed();
        Ok(())
    }

    /// The gear set simulated.
    pub fn gear_set(&self) -> &GearSet {
        &self.set
    }

    /// The run settings of the simulation.
    pub fn run_settings(&self) -> &RunSettings {
        &self.run
    }

    /// Internal steps a communication step of `h` seconds takes (refused
    /// by [`Self::do_step`] above [`MAX_INTERNAL_STEPS`]).
    pub fn internal_steps(&self, h: f64) -> f64 {
        if self.steady.is_some() {
            return 1.0;
        }
        ((h / self.nominal_step) - 1e-9).ceil().max(1.0)
    }
}
