//! The FMU's variables: generated from `modelDescription/variables.toml`
//! (the single source of truth) by build.rs, together with
//! [`MODEL_DESCRIPTION_XML`].

// Start values are the table's decimal literals (45° as 0.785398163397448 rad,
// for instance), not approximations of named constants.
#![allow(clippy::approx_constant)]

use crate::model::gear::{Member, MeshKind};
use crate::scene::Scene;

/// FMI base type of a variable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// fmi2Real.
    Real,
    /// fmi2Integer.
    Integer,
    /// fmi2Boolean.
    Boolean,
    /// fmi2String.
    String,
}

/// FMI causality.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Causality {
    /// Set before initialization.
    Parameter,
    /// Set by the importer during the simulation.
    Input,
    /// Computed by the FMU.
    Output,
}

/// FMI variability.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variability {
    /// Fixed after initialization.
    Fixed,
    /// Changeable between steps.
    Tunable,
    /// Changes only at steps (non-real outputs).
    Discrete,
    /// Changes continuously.
    Continuous,
}

/// Start value of a variable.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Start {
    /// No start value (outputs).
    None,
    /// Real.
    Real(f64),
    /// Integer.
    Integer(i32),
    /// Boolean.
    Boolean(bool),
    /// String.
    String(&'static str),
}

/// One row of the variable table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VariableInfo {
    /// Structured name.
    pub name: &'static str,
    /// Value reference (unique within its base type).
    pub vr: u32,
    /// Base type.
    pub kind: Kind,
    /// Causality.
    pub causality: Causality,
    /// Variability.
    pub variability: Variability,
    /// SI unit ("" for none).
    pub unit: &'static str,
    /// Start value.
    pub start: Start,
    /// Inclusive lower bound (modelDescription.xml's `min`; Integer bounds
    /// as exact reals), where the instance refuses every value below it.
    pub min: Option<f64>,
    /// Inclusive upper bound (modelDescription.xml's `max`).
    pub max: Option<f64>,
    /// Description.
    pub description: &'static str,
}

/// What an output reads from the simulation (the table's `read`): the
/// quantity, and the planet (0-based), member, mesh or harmonic order where
/// it is read. The instance gives each quantity its one line of physics.
/// The fields say where: `planet` (0-based), `member`, `mesh`, `order`
/// (the harmonic, 1-based).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum Reading {
    /// A central member's speed.
    Speed { member: Member },
    /// A central member's angle.
    Angle { member: Member },
    /// The torque in the input shaft.
    InputShaftTorque,
    /// A planet's mesh force.
    MeshForce { planet: usize, mesh: MeshKind },
    /// The force on the tracked tooth pair of planet 1's mesh.
    TrackedPairForce { mesh: MeshKind },
    /// A planet's dynamic transmission error.
    TransmissionError { planet: usize, mesh: MeshKind },
    /// A planet's static transmission error.
    StaticTransmissionError { planet: usize, mesh: MeshKind },
    /// A central member's bearing force.
    BearingForce { member: Member },
    /// A planet's bearing force.
    PlanetBearingForce { planet: usize },
    /// A mesh's window harmonic amplitude of an order (1-based).
    WindowAmplitude { mesh: MeshKind, order: usize },
    /// A mesh's window F^(rms).
    WindowRms { mesh: MeshKind },
    /// A mesh's window separation share.
    WindowSeparation { mesh: MeshKind },
    /// A mesh's window mean.
    WindowMean { mesh: MeshKind },
    /// The mesh cycles in the window.
    WindowCycles,
    /// The tooth pairs in contact in a planet's mesh.
    PairsInContact { planet: usize, mesh: MeshKind },
    /// A planet's mesh force maximum over the step.
    MeshForceMax { planet: usize, mesh: MeshKind },
    /// A planet's mesh force minimum over the step.
    MeshForceMin { planet: usize, mesh: MeshKind },
    /// A planet's largest tooth-pair force over the step.
    ToothForceMax { planet: usize, mesh: MeshKind },
    /// Whether a planet's mesh separated in the step.
    Separated { planet: usize, mesh: MeshKind },
    /// The largest mesh force of a mesh kind over the step.
    AnyMeshForceMax { mesh: MeshKind },
    /// The largest tooth-pair force of a mesh kind over the step.
    AnyToothForceMax { mesh: MeshKind },
    /// Whether any mesh of a kind separated in the step.
    AnySeparated { mesh: MeshKind },
    /// The load duty document.
    DutyCycle,
    /// The held member's reaction torque.
    ReactionTorque,
    /// The load balance's torque.
    BalancingTorque,
}

/// A scene field a settable variable writes (the table's `scene.slot`).
#[derive(Clone, Copy, Debug)]
pub enum SceneField {
    /// Real fields, in the variable's SI unit as the scene holds them:
    /// every one takes the value.
    Real(&'static [fn(&mut Scene) -> &mut f64]),
    /// Counts: every one takes the value, which must not be negative.
    Count(&'static [fn(&mut Scene) -> &mut u32]),
    /// An optional real: 0 means "derived from the geometry" (`None`).
    Derived(fn(&mut Scene) -> &mut Option<f64>),
}

/// How a settable variable acts on the scene.
#[derive(Clone, Copy, Debug)]
pub enum Target {
    /// Through its scene fields.
    Field(SceneField),
    /// By hand (`fmi::instance::parameters`).
    Special(Special),
}

include!(concat!(env!("OUT_DIR"), "/fmi_variables.rs"));

/// modelDescription.xml generated from the same table.
pub const MODEL_DESCRIPTION_XML: &str = include_str!(concat!(env!("OUT_DIR"), "/modelDescription.xml"));

/// The variable with a value reference of a base type.
pub fn find(kind: Kind, vr: u32) -> Option<&'static VariableInfo> {
    VARIABLES.iter().find(|v| v.kind == kind && v.vr == vr)
}
