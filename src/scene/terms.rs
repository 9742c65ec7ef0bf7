//! The words a scene is written in: which member is held, driven or
//! loaded, how the input is driven, which integrator runs and which degrees
//! of freedom a model carries. They are part of the scene file's format;
//! the model re-exports them where it uses them.

use serde::{Deserialize, Serialize};

/// A member of the planetary set that can be held, driven or loaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Member {
    /// The central external gear.
    Sun,
    /// The internal gear.
    Ring,
    /// The planet carrier.
    Carrier,
}

impl Member {
    /// Sun, ring and carrier in the order of the per-member arrays (torques, speeds): 0, 1, 2.
    pub const ALL: [Member; 3] = [Member::Sun, Member::Ring, Member::Carrier];

    /// The member's place in the per-member arrays (torques, speeds): sun 0, ring 1, carrier 2.
    pub fn index(self) -> usize {
        match self {
            Member::Sun => 0,
            Member::Ring => 1,
            Member::Carrier => 2,
        }
    }

    /// The name used in files and messages.
    pub fn name(self) -> &'static str {
        match self {
            Member::Sun => "sun",
            Member::Ring => "ring",
            Member::Carrier => "carrier",
        }
    }
}

/// How the input member is driven in the dynamic model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Drive {
    /// Constant input torque; the output carries the balancing torque and the
    /// running speed is set by the initial condition.
    Torque,
    /// The input member is driven through a torsional shaft from a source
    /// turning at the set speed; the output carries the balancing torque.
    Speed,
    /// Constant input torque as [`Drive::Torque`], and each new speed
    /// reference steps the set's rigid-body speed to it, keeping the elastic
    /// state (deflections and vibration velocities): the continuation of a
    /// speed sweep (docs/MODEL.md §3) with the published torque boundary
    /// condition, which a stiff shaft from a constant-speed source would
    /// change (it clamps the input member and shifts the rotational modes).
    SpeedSteps,
}

/// Time integrator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IntegratorKind {
    /// Generalized-α (Chung–Hulbert), fixed steps per mesh cycle.
    GeneralizedAlpha,
    /// Adaptive Runge–Kutta 5(4) (Dormand–Prince) with contact events.
    Rk45,
}

/// Which degrees of freedom a model carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Fidelity {
    /// One rotation per body (planets pinned to the carrier).
    Torsional,
    /// Two in-plane translations and one rotation per body.
    TransverseTorsional,
}

/// How a time-domain run (`simulate`, the FMU) computes its tooth-level outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Response {
    /// The equations of motion integrated over every mesh cycle.
    #[default]
    Time,
    /// The rigid-body rotation integrated at the communication step, the tooth outputs
    /// from the periodic steady state at its speed and mesh load (docs/STEADY.md).
    Steady,
}

impl Response {
    /// Whether this is the default (the scene file then omits it).
    pub fn is_time(&self) -> bool {
        *self == Response::Time
    }
}

/// The tooth contact law of the dynamic model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactModel {
    /// Each tooth pair a spring of its own (potential-energy stiffness, a
    /// Hertzian band), the pairs of a mesh independent.
    #[default]
    Pair,
    /// The pairs of a mesh solved together over finite-element gear bodies
    /// with a local Hertzian term, tabulated per mesh (docs/DEFORMABLE.md).
    Deformable,
}

impl ContactModel {
    /// Whether this is the default law (the scene file then omits it).
    pub fn is_pair(&self) -> bool {
        *self == ContactModel::Pair
    }
}

/// How the structure is damped in the dynamic model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DampingModel {
    /// A damping ratio per mesh (on the mesh mode, acting while a pair
    /// touches) and per bearing (on the body on its bearing).
    #[default]
    Ratio,
    /// Rayleigh damping C = μM + ηK: η times each mesh's tangent stiffness
    /// and each bearing's stiffness, μ times the masses on the motion
    /// relative to the train's rigid-body rotation.
    Rayleigh,
}

impl DampingModel {
    /// Whether this is the default model (the scene file then omits it).
    pub fn is_ratio(&self) -> bool {
        *self == DampingModel::Ratio
    }
}
