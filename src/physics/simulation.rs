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

use super::dynamics::PlanetaryDynamics;
use super::gear::{GearSet, Member, MeshKind};
use super::response::{static_state, Stepper};
use crate::solver::{SecondOrderSystem, SolverError};

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
    /// The integrator could not complete the step.
    #[error("step from t = {t} s failed: {source}")]
    Integration {
        /// Start of the step [s].
        t: f64,
        /// The integrator's error.
        source: SolverError,
    },
}

/// A restorable snapshot of a simulation (plain data, no pointers).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    /// Time [s].
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
}

/// A running simulation.
#[derive(Clone)]
pub struct Simulation {
    model: PlanetaryDynamics,
    stepper: Stepper,
    set: GearSet,
    time: f64,
    nominal_step: f64,
    torques: [f64; 3],
    speed_reference: f64,
}

const TIME_TOLERANCE: f64 = 1e-9;

impl Simulation {
    /// Starts at time `t0` [s] from the static deflection with the input
    /// member turning at `input_speed` [rad/s]; internal steps follow the
    /// scene's steps per mesh cycle at that speed.
    pub fn new(
        set: &GearSet,
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
        let nominal_step = 1.0 / (fm * set.dynamics.steps_per_mesh_cycle as f64);
        let mut model = model;
        let start = static_state(&model, input_speed);
        let torques = torques_of(set);
        model.set_torques(torques[0], torques[1], torques[2]);
        model.set_drive_speed(input_speed);
        model.rebase_drive(&start.q);
        let err = |source| SimulationError::Integration { t: t0, source };
        let mut stepper = Stepper::new(set, 1.0 / fm).map_err(err)?;
        stepper.init(&mut model, t0, &start.q, &start.v).map_err(err)?;
        Ok(Self {
            model,
            stepper,
            set: set.clone(),
            time: t0,
            nominal_step,
            torques,
            speed_reference: input_speed,
        })
    }

    /// Current time [s].
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
        self.torques = [sun, ring, carrier];
        self.model.set_torques(sun, ring, carrier);
        Ok(())
    }

    /// Sets the speed the speed drive's source turns at [rad/s].
    pub fn set_speed_reference(&mut self, omega: f64) -> Result<(), SimulationError> {
        if !omega.is_finite() {
            return Err(SimulationError::InvalidInput {
                name: "inputSpeedReference".into(),
                value: omega.to_string(),
                reason: "must be finite".into(),
            });
        }
        self.speed_reference = omega;
        self.model.set_drive_speed(omega);
        Ok(())
    }

    /// Advances from `t` (which must be the current time) by `h` > 0 [s].
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
        let steps = ((h / self.nominal_step) - 1e-9).ceil().max(1.0) as u64;
        let end = self.time + h;
        self.stepper
            .advance(&mut self.model, end, steps)
            .map_err(|source| SimulationError::Integration { t: self.time, source })?;
        self.time = end;
        // Refresh the mesh states at the accepted state for the outputs.
        let (q, v) = self.stepper.state();
        let (q, v) = (q.to_vec(), v.to_vec());
        let mut f = vec![0.0; q.len()];
        self.model.force(end, &q, &v, &mut f);
        Ok(())
    }

    fn rotation(&self, m: Member, rate: bool) -> f64 {
        let k = match m {
            Member::Carrier => 0,
            Member::Ring => 1,
            Member::Sun => 2,
        };
        let (index, lever) = self.model.rotations[k];
        let (q, v) = self.stepper.state();
        index.map_or(0.0, |i| (if rate { v[i] } else { q[i] }) / lever)
    }

    /// Angular speed of a member [rad/s] (0 when held).
    pub fn speed(&self, m: Member) -> f64 {
        self.rotation(m, true)
    }

    /// Rotation of a member since the start [rad] (0 when held).
    pub fn angle(&self, m: Member) -> f64 {
        self.rotation(m, false)
    }

    /// Mesh force of one mesh of planet `p` [N] (0 for a planet that does not exist).
    pub fn mesh_force(&self, p: usize, mesh: MeshKind) -> f64 {
        self.mesh_state(p, mesh).map_or(0.0, |s| s.force)
    }

    /// Dynamic transmission error (approach along the line of action) of a mesh of planet `p` [m].
    pub fn transmission_error(&self, p: usize, mesh: MeshKind) -> f64 {
        self.mesh_state(p, mesh).map_or(0.0, |s| s.approach)
    }

    fn mesh_state(&self, p: usize, mesh: MeshKind) -> Option<super::dynamics::MeshState> {
        let i = 2 * p + usize::from(mesh == MeshKind::RingPlanet);
        (i < self.model.mesh_count()).then(|| self.model.meshes[i])
    }

    /// A restorable snapshot.
    pub fn snapshot(&self) -> Snapshot {
        let (q, v) = self.stepper.state();
        Snapshot {
            time: self.time,
            q: q.to_vec(),
            v: v.to_vec(),
            integrator: self.stepper.internal(),
            torques: self.torques,
            speed_reference: self.speed_reference,
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
        self.set_torques(s.torques[0], s.torques[1], s.torques[2])?;
        self.set_speed_reference(s.speed_reference)?;
        self.stepper
            .restore(&mut self.model, s.time, &s.q, &s.v, &s.integrator)
            .map_err(|source| SimulationError::Integration { t: s.time, source })?;
        self.time = s.time;
        let mut f = vec![0.0; n];
        self.model.force(s.time, &s.q, &s.v, &mut f);
        Ok(())
    }

    /// The gear set simulated.
    pub fn gear_set(&self) -> &GearSet {
        &self.set
    }
}

/// The balanced torques of a gear set's operation: the input torque on the
/// input member and the balancing torque on the output member [N·m] on
/// sun, ring, carrier.
pub fn torques_of(set: &GearSet) -> [f64; 3] {
    let n = set.planet_angles.len() as f64;
    let f0 = set.mesh_load_per_planet() * set.input_torque.signum();
    let (rbs, rbr) = (set.sun.base_radius(), set.ring.base_radius());
    let torque = |m: Member| match m {
        Member::Sun => n * f0 * rbs,
        Member::Ring => n * f0 * rbr,
        Member::Carrier => -n * f0 * (rbs + rbr),
    };
    let mut t = [0.0; 3];
    for m in [set.input, set.output()] {
        let k = match m {
            Member::Sun => 0,
            Member::Ring => 1,
            Member::Carrier => 2,
        };
        t[k] = torque(m);
    }
    t
}
