//! The FMU's variables: generated from `modelDescription/variables.toml`
//! (the single source of truth) by build.rs, together with
//! [`MODEL_DESCRIPTION_XML`].

// Start values are the table's decimal literals (45° as 0.785398163397448 rad,
// for instance), not approximations of named constants.
#![allow(clippy::approx_constant)]

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

include!(concat!(env!("OUT_DIR"), "/fmi_variables.rs"));

/// modelDescription.xml generated from the same table.
pub const MODEL_DESCRIPTION_XML: &str = include_str!(concat!(env!("OUT_DIR"), "/modelDescription.xml"));

/// The variable with a value reference of a base type.
pub fn find(kind: Kind, vr: u32) -> Option<&'static VariableInfo> {
    VARIABLES.iter().find(|v| v.kind == kind && v.vr == vr)
}
