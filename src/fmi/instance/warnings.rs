//! The FMU's plausibility warnings (docs/FMU.md, "Messages"): after
//! fmi2ExitInitializationMode and after every completed fmi2DoStep the
//! checks of [`crate::analysis::plausibility`] run on the simulation's
//! state; a condition is reported once, when it sets in (its onset), and
//! again only after it has cleared and set in anew. The step itself
//! completes: the call returns fmi2Warning and the message goes to the
//! logger under logStatusWarning.

use std::collections::BTreeSet;

use crate::analysis::plausibility as check;
use crate::dynamics::simulation::Simulation;
use crate::model::gear::{Drive, Member, MeshKind};
use crate::scene::units::{rad_per_s_to_rpm, rpm_to_rad_per_s};

/// A condition that is reported at its onset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Condition {
    Overspeed,
    RunAway,
    Separation(u8),
    Pressure(u8),
    SteadyNotFound,
}

fn mesh_index(mesh: MeshKind) -> u8 {
    match mesh {
        MeshKind::SunPlanet => 0,
        MeshKind::RingPlanet => 1,
    }
}

/// What the importer gives with each step: the external torques (sun,
/// ring, carrier) \[N·m\] and the speed reference \[rad/s\].
#[derive(Clone, Copy, Debug)]
pub struct Inputs {
    /// sunTorque, ringTorque, carrierTorque.
    pub torques: [f64; 3],
    /// inputSpeedReference.
    pub speed_reference: f64,
}

/// The conditions in force, and the rigid-body speed change the torques
/// given have caused since the start (or the last speed step).
#[derive(Clone, Debug, Default)]
pub struct Watch {
    active: BTreeSet<Condition>,
    /// Speed the input member started from or was stepped to \[rad/s\].
    reference: f64,
    /// The torques' rigid-body speed change since then \[rad/s\].
    drift: f64,
    /// Time of the last check \[s\].
    time: f64,
}

impl Watch {
    /// Forgets every onset (after fmi2Reset or a restored FMU state: a
    /// condition still in force is reported again at the next step).
    pub fn forget(&mut self, time: f64) {
        self.active.clear();
        self.time = time;
    }

    /// The margin on the threshold of condition `c`: the threshold itself
    /// for an onset, [`check::CLEAR_MARGIN`] of it while in force.
    fn margin(&self, c: Condition) -> f64 {
        if self.active.contains(&c) {
            check::CLEAR_MARGIN
        } else {
            1.0
        }
    }

    /// Keeps `finding` (of a check at [`Watch::margin`]) for the report if
    /// its condition sets in now.
    fn note(&mut self, c: Condition, finding: Option<String>, out: &mut Vec<String>) {
        match finding {
            Some(m) => {
                if self.active.insert(c) {
                    out.push(m);
                }
            }
            None => {
                self.active.remove(&c);
            }
        }
    }

    /// The checks of a simulation just built from its parameters: the
    /// initial speed's overspeed, worded for a speed given in rpm by mistake.
    pub fn at_start(&mut self, sim: &Simulation, initial_speed: f64) -> Vec<String> {
        self.active.clear();
        self.reference = sim.speed(sim.gear_set().input());
        self.drift = 0.0;
        self.time = sim.time();
        let mut out = Vec::new();
        let finding =
            check::overspeed(sim.gear_set(), sim.speed(Member::Sun), sim.speed(Member::Carrier), 1.0).map(
                |m| {
                    format!(
                    "initialSpeed = {initial_speed} rad/s ({:.6e} rpm): {m}; if {initial_speed} was meant in \
                     rpm, give initialSpeed = {} rad/s",
                    rad_per_s_to_rpm(initial_speed),
                    rpm_to_rad_per_s(initial_speed)
                )
                },
            );
        self.note(Condition::Overspeed, finding, &mut out);
        out
    }

    /// The checks after a completed step, each condition reported at its
    /// onset.
    pub fn after_step(&mut self, sim: &Simulation, inputs: Inputs) -> Vec<String> {
        let set = sim.gear_set();
        let mut out = Vec::new();
        let at = |m: String| format!("at t = {} s: {m}", sim.time());
        let margin = self.margin(Condition::Overspeed);
        let finding =
            check::overspeed(set, sim.speed(Member::Sun), sim.speed(Member::Carrier), margin).map(at);
        self.note(Condition::Overspeed, finding, &mut out);
        // The torques' rigid-body acceleration over the step, integrated
        // from the speed the input member started from or, under
        // driveMode 2, was last stepped to. A speed drive (driveMode 1)
        // holds the speed through its shaft, and the load balance
        // (loadBalance = 1) replaces the output's torque by the one that
        // keeps its mean speed: nothing runs away.
        let margin = self.margin(Condition::RunAway);
        let finding = match set.drive() {
            _ if set.load_balance() => None,
            Drive::Speed => None,
            drive => {
                if drive == Drive::SpeedSteps && inputs.speed_reference != self.reference {
                    (self.reference, self.drift) = (inputs.speed_reference, 0.0);
                }
                let (_, accel) = check::torque_imbalance(set, inputs.torques);
                self.drift += accel * (sim.time() - self.time);
                let speed = sim.speed(set.input());
                check::speed_drift(set, self.drift, speed, self.reference, inputs.torques, margin)
            }
        };
        self.time = sim.time();
        self.note(Condition::RunAway, finding.map(at), &mut out);
        for mesh in MeshKind::ALL {
            let c = Condition::Separation(mesh_index(mesh));
            let fraction = sim.window_separation(mesh);
            let finding = fraction.and_then(|f| check::separation(1, mesh, f, self.margin(c))).map(at);
            self.note(c, finding, &mut out);
            // The most loaded planet of the mesh, at the largest force its
            // integration passed through within the step (a force sampled
            // at the step's end would clear and re-arm the condition as it
            // oscillates through the step).
            let extremes = sim.step_extremes();
            let worst = (0..set.planet_angles().len())
                .filter_map(|p| extremes.mesh(p, mesh).map(|e| (p, e.max.abs().max(e.min.abs()))))
                .max_by(|a, b| a.1.total_cmp(&b.1));
            let c = Condition::Pressure(mesh_index(mesh));
            let margin = self.margin(c);
            let finding =
                worst.and_then(|(p, f)| check::contact_pressure(set, p + 1, mesh, f, margin)).map(at);
            self.note(c, finding, &mut out);
        }
        // The steady response: a node of the step's cell that no way solved took its row's
        // nearest node (docs/STEADY.md, "Solving a node").
        let failed = sim.steady().and_then(|e| {
            let b = e.blend();
            b.found().any(|f| f == crate::dynamics::steady::point::Found::Failed).then(|| {
                format!(
                    "the steady state near {:.0} rpm and {:.1} N·m was not found (a march's period did not \
                     integrate): the outputs take the nearest steady state of the same torque",
                    rad_per_s_to_rpm(b.speed.abs()),
                    b.torque
                )
            })
        });
        self.note(Condition::SteadyNotFound, failed.map(at), &mut out);
        out
    }
}
