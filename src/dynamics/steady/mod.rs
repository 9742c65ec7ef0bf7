//! The `steady` response (docs/STEADY.md): the rigid-body rotation of the free members is
//! integrated at the communication step under the drive's torques and speed reference,
//! and every tooth-level output comes from the periodic steady state at the speed and the
//! mesh load the rotation has reached, cached on a grid of speed and torque
//! ([`grid::SteadyGrid`]) and solved by the condensed harmonic balance where the grid has
//! no node yet ([`point::TorqueLevel`]).
//!
//! The quasi-steady assumption: within one communication step the tooth dynamics have
//! settled on the periodic state of the current speed and load. It holds while speed and
//! torque change slowly against the decay of the mesh modes (docs/STEADY.md, "Limits").
//!
//! Imports: the dynamic model, the periodic solvers, the spectrum (stage 5, earlier files).

pub mod grid;
pub mod point;

use std::sync::{Arc, Mutex};

use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::periodic::PeriodicError;
use crate::dynamics::steady::grid::{Blend, GridStats, SteadyGrid};
use crate::model::gear::{Drive, GearSet, Member};
use crate::model::lumped::central_index;
use crate::model::run::SteadyValues;

/// Caches kept for later engines of the same model in this process, at most this many
/// (the oldest dropped first): a second FMU instance of the same parameters and worn state
/// starts warm.
pub const SHARED_CACHES: usize = 2;

/// The process's shared caches by key, oldest first.
static SHARED: Mutex<Vec<(u64, Arc<Mutex<SteadyGrid>>)>> = Mutex::new(Vec::new());

/// The shared cache of `key`, made by `make` when there is none (and kept, dropping the
/// oldest beyond [`SHARED_CACHES`]).
fn shared(key: u64, make: impl FnOnce() -> SteadyGrid) -> Arc<Mutex<SteadyGrid>> {
    let mut caches = SHARED.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, grid)) = caches.iter().find(|(k, _)| *k == key) {
        return grid.clone();
    }
    let grid = Arc::new(Mutex::new(make()));
    caches.push((key, grid.clone()));
    if caches.len() > SHARED_CACHES {
        caches.remove(0);
    }
    grid
}

/// The drive the rigid-body rotation follows over a step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveInputs {
    /// Torques on sun, ring, carrier [N·m].
    pub torques: [f64; 3],
    /// The input speed reference [rad/s].
    pub reference: f64,
}

/// The rigid-body rotation and the steady tooth dynamics of a simulation. A clone shares
/// the cache (the same model and worn state).
#[derive(Clone)]
pub struct SteadyEngine {
    grid: Arc<Mutex<SteadyGrid>>,
    drive: Drive,
    load_balance: bool,
    input: Member,
    output: Member,
    /// The train's inertia referred to the input member [kg·m²].
    inertia: f64,
    /// The input member's own inertia [kg·m²].
    input_inertia: f64,
    /// Output speed per unit input speed.
    output_ratio: f64,
    /// Input angle \[rad\] and speed [rad/s].
    angle: f64,
    speed: f64,
    /// The mesh load of the last step as input torque [N·m].
    load_torque: f64,
    /// The torque the input member received [N·m] (its shaft's under the speed drive).
    input_torque: f64,
    /// The load balance's controller torque on the output [N·m] (0 without it).
    balancing_torque: f64,
    blend: Blend,
    rigid: Vec<f64>,
    q: Vec<f64>,
    v: Vec<f64>,
}

/// Why the steady response cannot take a set.
pub fn unsupported(set: &GearSet) -> Option<String> {
    (matches!(set.drive(), Drive::Speed | Drive::SpeedSteps) && set.speed_driven_member() != set.input())
        .then(|| {
            "the steady response drives the input member: a speed drive on the output member \
         (dynamics.speed_driven_member) is a time-domain drive"
                .to_string()
        })
}

impl SteadyEngine {
    /// The engine of `model` (the simulation's) for `set`, starting at input angle 0 and
    /// speed `speed` [rad/s] under the set's balanced torques. With `shared_key` the cache
    /// is the process's one of that key (the caller's hash of everything the steady states
    /// depend on: the set, its worn state, the grid and run settings).
    pub fn new(
        settings: SteadyValues,
        model: &PlanetaryDynamics,
        set: &GearSet,
        speed: f64,
        samples_per_cycle: usize,
        shared_key: Option<u64>,
    ) -> Result<Self, PeriodicError> {
        if let Some(reason) = unsupported(set) {
            return Err(PeriodicError::InvalidRequest {
                name: "dynamics.speed_driven_member".into(),
                value: format!("{:?}", set.speed_driven_member()),
                reason,
            });
        }
        let unit = set.with_input_torque(1.0).expect("finite");
        let make = || {
            SteadyGrid::new(
                settings,
                model.clone(),
                unit.balanced_torques(),
                unit.mesh_load_per_planet(),
                samples_per_cycle,
            )
        };
        let grid = match shared_key {
            Some(key) => shared(key, make),
            None => Arc::new(Mutex::new(make())),
        };
        let output = set.output();
        let (index, lever) = model.rotations[central_index(output)];
        let output_ratio = index.map_or(0.0, |i| model.rigid_velocity[i] / lever);
        let n = model.rigid_velocity.len();
        let torque = set.input_torque();
        let mut engine = Self {
            grid,
            drive: set.drive(),
            load_balance: set.load_balance(),
            input: set.input(),
            output,
            inertia: model.rigid_inertia(),
            input_inertia: model.input_member_inertia(),
            output_ratio,
            angle: 0.0,
            speed,
            load_torque: torque,
            input_torque: torque,
            balancing_torque: 0.0,
            blend: Blend { corners: Vec::new(), speed, torque, level: 0, estimate: 0.0 },
            rigid: model.rigid_velocity.clone(),
            q: vec![0.0; n],
            v: vec![0.0; n],
        };
        engine.settle(speed, torque)?;
        Ok(engine)
    }

    /// The steady state at `speed` and mesh load `torque` at the current angle.
    fn settle(&mut self, speed: f64, torque: f64) -> Result<(), PeriodicError> {
        let blend = self.grid().lookup(speed, torque)?;
        self.blend = blend;
        self.blend.relative_state(self.angle, &mut self.q, &mut self.v);
        for ((q, v), r) in self.q.iter_mut().zip(&mut self.v).zip(&self.rigid) {
            *q += r * self.angle;
            *v += r * self.speed;
        }
        Ok(())
    }

    /// Advances the rigid-body rotation by `h` \[s\] under `inputs` and takes the steady
    /// state at the step's mean speed and its mesh load. Returns the input angle turned.
    pub fn advance(
        &mut self,
        model: &PlanetaryDynamics,
        inputs: DriveInputs,
        h: f64,
    ) -> Result<f64, PeriodicError> {
        let (omega0, t) = (self.speed, inputs.torques);
        let without = |m: Member| {
            let mut t = t;
            t[m.index()] = 0.0;
            model.rigid_torque(t)
        };
        let follows_reference = self.drive != Drive::Torque || self.load_balance;
        let (omega1, alpha) = if follows_reference {
            (inputs.reference, (inputs.reference - omega0) / h)
        } else {
            let alpha = model.rigid_torque(t) / self.inertia;
            (omega0 + alpha * h, alpha)
        };
        let (input_torque, balancing) = match (self.drive, self.load_balance) {
            (Drive::Torque, false) => (t[self.input.index()], 0.0),
            (Drive::Torque, true) => {
                let ratio = if self.output_ratio != 0.0 { self.output_ratio } else { 1.0 };
                (t[self.input.index()], (self.inertia * alpha - without(self.output)) / ratio)
            }
            _ => (self.inertia * alpha - without(self.input), 0.0),
        };
        let load = input_torque - self.input_inertia * alpha;
        let turned = 0.5 * (omega0 + omega1) * h;
        if !(omega1.is_finite() && load.is_finite() && turned.is_finite()) {
            return Err(PeriodicError::invalid(
                "input speed",
                omega1,
                "the rigid-body rotation left the finite numbers",
            ));
        }
        let (angle, speed) = (self.angle, self.speed);
        self.angle += turned;
        self.speed = omega1;
        if let Err(e) = self.settle(0.5 * (omega0 + omega1), load) {
            (self.angle, self.speed) = (angle, speed);
            return Err(e);
        }
        (self.load_torque, self.input_torque, self.balancing_torque) = (load, input_torque, balancing);
        Ok(turned)
    }

    /// The engine's own state: input angle, rigid-body speed, mesh load, input torque,
    /// balancing torque and the speed of the last steady state ([`Self::restore`] reads it).
    pub fn internal(&self) -> Vec<f64> {
        vec![
            self.angle,
            self.speed,
            self.load_torque,
            self.input_torque,
            self.balancing_torque,
            self.blend.speed,
        ]
    }

    /// Restores the engine's own state `internal` ([`Self::internal`]) and takes its steady
    /// state again. Without it (a state of another length), the rotation is read from the
    /// absolute state `q`, `v` (its elastic part included) and the mesh load from `inputs`
    /// without acceleration.
    pub fn restore(
        &mut self,
        model: &PlanetaryDynamics,
        (q, v, internal): (&[f64], &[f64], &[f64]),
        inputs: DriveInputs,
    ) -> Result<(), PeriodicError> {
        if let [angle, speed, load, input, balancing, blend_speed] = *internal {
            (self.angle, self.speed, self.load_torque) = (angle, speed, load);
            (self.input_torque, self.balancing_torque) = (input, balancing);
            return self.settle(blend_speed, load);
        }
        let (i, lever) = (model.input_index, model.input_lever);
        self.angle = q[i] / lever;
        self.speed = v[i] / lever;
        let input_torque = match self.drive {
            Drive::Torque => inputs.torques[self.input.index()],
            _ => {
                let mut t = inputs.torques;
                t[self.input.index()] = 0.0;
                -model.rigid_torque(t)
            }
        };
        self.input_torque = input_torque;
        self.load_torque = input_torque;
        self.settle(self.speed, input_torque)
    }

    /// The absolute state (coordinates, velocities) at the last communication point.
    pub fn state(&self) -> (&[f64], &[f64]) {
        (&self.q, &self.v)
    }

    /// The rigid-body rotation: input angle \[rad\] and speed [rad/s].
    pub fn rotation(&self) -> (f64, f64) {
        (self.angle, self.speed)
    }

    /// The steady state of the last step.
    pub fn blend(&self) -> &Blend {
        &self.blend
    }

    /// The mesh load of the last step as input torque [N·m].
    pub fn load_torque(&self) -> f64 {
        self.load_torque
    }

    /// The torque the input member received over the last step [N·m].
    pub fn input_torque(&self) -> f64 {
        self.input_torque
    }

    /// The load balance's torque on the output member [N·m] (0 without it).
    pub fn balancing_torque(&self) -> f64 {
        self.balancing_torque
    }

    /// What the cache has done.
    pub fn stats(&self) -> GridStats {
        self.grid().stats()
    }

    /// Nodes in the cache.
    pub fn cached(&self) -> usize {
        self.grid().len()
    }

    /// The cache (a lookup that panicked left no half-written node: a node is inserted
    /// whole, so a poisoned lock's cache is still sound).
    fn grid(&self) -> std::sync::MutexGuard<'_, SteadyGrid> {
        self.grid.lock().unwrap_or_else(|e| e.into_inner())
    }
}
